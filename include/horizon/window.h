/* horizon window: an interactive OpenGL window (GLFW, X11/GLX) with polled
 * input, and the overlay that `horizon view` draws over the terrain in it
 * (HUD text, 2D panels, world-space debug lines and coloured triangles).
 *
 * No globals of our own: every window keeps its state (keys, mouse, size) in
 * its hz_window, so a window and a headless EGL hz_gl can live in one process.
 * NOTE: GLFW itself is process-wide (glfwInit/glfwTerminate); the module only
 * counts live windows to terminate GLFW after the last one, and all GLFW calls
 * must come from the main thread. */
#ifndef HORIZON_WINDOW_H
#define HORIZON_WINDOW_H

#include "horizon/camera.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- window -------------------------------------------------------------- */

/* Key codes (the values are GLFW's, checked at build time). */
enum {
    HZ_KEY_SPACE = 32,
    HZ_KEY_APOSTROPHE = 39,
    HZ_KEY_COMMA = 44,
    HZ_KEY_MINUS = 45,
    HZ_KEY_PERIOD = 46,
    HZ_KEY_SLASH = 47,
    HZ_KEY_0 = 48, /* ... HZ_KEY_0 + 9 */
    HZ_KEY_SEMICOLON = 59,
    HZ_KEY_EQUAL = 61,
    HZ_KEY_A = 65, /* ... HZ_KEY_A + 25 */
    HZ_KEY_LEFT_BRACKET = 91,
    HZ_KEY_RIGHT_BRACKET = 93,
    HZ_KEY_ESCAPE = 256,
    HZ_KEY_ENTER = 257,
    HZ_KEY_TAB = 258,
    HZ_KEY_BACKSPACE = 259,
    HZ_KEY_RIGHT = 262,
    HZ_KEY_LEFT = 263,
    HZ_KEY_DOWN = 264,
    HZ_KEY_UP = 265,
    HZ_KEY_PAGE_UP = 266,
    HZ_KEY_PAGE_DOWN = 267,
    HZ_KEY_HOME = 268,
    HZ_KEY_F1 = 290, /* ... HZ_KEY_F1 + 11 = F12 */
    HZ_KEY_LEFT_SHIFT = 340,
    HZ_KEY_LEFT_CONTROL = 341,
    HZ_KEY_RIGHT_SHIFT = 344,
    HZ_KEY_RIGHT_CONTROL = 345,
    HZ_KEY_COUNT = 349 /* one past the last key code */
};

/* Mouse buttons (GLFW's values). */
enum { HZ_MOUSE_LEFT = 0, HZ_MOUSE_RIGHT = 1, HZ_MOUSE_MIDDLE = 2, HZ_MOUSE_COUNT = 8 };

typedef struct hz_window hz_window;

typedef struct hz_window_desc {
    uint32_t width, height; /* client area in screen coordinates; 0 -> 1280 x 720 */
    const char *title;      /* 0 -> "horizon" */
    bool no_vsync;          /* false (default): swap interval 1; true: 0 (measure FPS) */
    bool fixed_size;        /* false (default): the user may resize the window */
} hz_window_desc;

/* Opens a window with an OpenGL 4.5 core context (falling back to 3.3 core)
 * and makes the context current. NULL + err if there is no display (run
 * under xvfb-run on a machine without X) or no such context. */
hz_window *hz_window_create(const hz_window_desc *desc, hz_err *err);
/* Destroys the window and its context (NULL is ignored). */
void hz_window_destroy(hz_window *w);
/* "renderer | version" of the window's context, for logs and the HUD. */
const char *hz_window_describe(const hz_window *w);
void hz_window_make_current(hz_window *w);

/* What happened since the previous hz_window_poll. */
#define HZ_WINDOW_MAX_PRESSES 64
typedef struct hz_window_input {
    float mouse_dx, mouse_dy;  /* cursor motion in pixels (+x right, +y down) */
    float scroll;              /* wheel notches, + = away from the user */
    int presses[HZ_WINDOW_MAX_PRESSES]; /* keys pressed (or auto-repeated), in order */
    uint32_t press_count;
    bool close_requested;      /* window close button (or hz_window_request_close) */
    bool resized;              /* the framebuffer size changed */
    uint32_t fb_width, fb_height; /* current framebuffer size in pixels (0 when minimised) */
} hz_window_input;

/* Processes window events (and injected ones) and returns this frame's input. */
void hz_window_poll(hz_window *w, hz_window_input *in);
/* Blocks until an event arrives or timeout_s passes (for minimised windows). */
void hz_window_wait(hz_window *w, double timeout_s);
/* Presents the back buffer. */
void hz_window_swap(hz_window *w);
/* True while the key / mouse button is held (real or injected). */
bool hz_window_key_down(const hz_window *w, int key);
bool hz_window_mouse_down(const hz_window *w, int button);
/* Current framebuffer size in pixels. */
void hz_window_framebuffer_size(const hz_window *w, uint32_t *width, uint32_t *height);
/* Asks the window system for a new client size (arrives as `resized` in a
 * later poll). */
void hz_window_set_size(hz_window *w, uint32_t width, uint32_t height);
void hz_window_set_title(hz_window *w, const char *title);
void hz_window_request_close(hz_window *w);
/* The cursor in framebuffer pixels from the top-left corner (x right, y
 * down); false while unknown (no cursor event yet) or captured. Injected
 * mouse moves move it too. */
bool hz_window_cursor(const hz_window *w, float *x, float *y);
/* Mouse capture for mouse look: hides the cursor and reports unbounded motion. */
void hz_window_capture_mouse(hz_window *w, bool capture);
bool hz_window_mouse_captured(const hz_window *w);

/* Scripted input, fed through the same path as real events: a key or button
 * stays down until injected up; a press is reported by the next poll. */
void hz_window_inject_key(hz_window *w, int key, bool down);
void hz_window_inject_mouse_button(hz_window *w, int button, bool down);
void hz_window_inject_mouse_move(hz_window *w, float dx, float dy);
void hz_window_inject_scroll(hz_window *w, float notches);

/* Key code for a name ("W", "TAB", "F12", "SHIFT", "ESC", "UP", "1", "[",
 * case-insensitive); -1 if unknown. hz_key_name is the reverse ("?" if none). */
int hz_key_from_name(const char *name);
const char *hz_key_name(int key);

/* ---- overlay (src/render/overlay.c) --------------------------------------- */

/* Draws what the renderer does not: HUD text (stb_easy_font glyphs as
 * triangles), 2D rectangles, world-space lines and per-vertex coloured
 * triangles. Calls queue geometry into CPU arrays; hz_overlay_draw uploads
 * and draws them all and empties the queues. Needs a current GL 3.3+ core
 * context (the one it was created in). */
typedef struct hz_overlay hz_overlay;

hz_overlay *hz_overlay_create(hz_err *err);
void hz_overlay_destroy(hz_overlay *o);

/* 2D, in pixels from the top-left corner. rgba in [0, 1]. scale 1 = the
 * font's native 7-pixel glyphs on a 10-pixel line; '\n' starts a new line. */
void hz_overlay_text(hz_overlay *o, float x, float y, float scale, const float rgba[4], const char *text);
/* Width and height in pixels that hz_overlay_text would cover. */
void hz_overlay_text_size(const char *text, float scale, float *width, float *height);
void hz_overlay_rect(hz_overlay *o, float x, float y, float w, float h, const float rgba[4]);

/* World space (metres). Lines are drawn depth-tested against the terrain
 * and again faintly where hidden. */
void hz_overlay_line(hz_overlay *o, const vec3 a, const vec3 b, const float rgba[4]);
/* The 12 edges of an axis-aligned box (box[0] = min, box[1] = max). */
void hz_overlay_box(hz_overlay *o, const vec3 box[2], const float rgba[4]);
/* The frustum of cam: near and far rectangles and the four side edges. */
void hz_overlay_frustum(hz_overlay *o, const hz_camera *cam, const float rgba[4]);
/* Reserves n triangles (3n vertices) of world-space geometry with per-vertex
 * colours; the caller writes xyz (3n*3 floats) and rgba8 (3n*4 bytes). Returns
 * false (and reserves nothing) when out of memory. */
bool hz_overlay_triangles(hz_overlay *o, size_t n, float **xyz, uint8_t **rgba);

typedef struct hz_overlay_frame {
    const hz_camera *cam;    /* required when world-space geometry was queued */
    uint32_t width, height;  /* framebuffer pixels; required */
    bool clear;              /* clear colour and depth first (loading screen) */
    float clear_rgb[3];
    bool shade_triangles;    /* light the triangles by their face normal */
    bool wire_triangles;     /* draw the triangles' edges on top, dark */
} hz_overlay_frame;

/* Draws everything queued into the currently bound draw framebuffer (0 for a
 * window): triangles (depth-tested, reverse-Z like the renderer), lines, then
 * 2D rectangles and text on top with alpha blending. Empties the queues. */
hz_result hz_overlay_draw(hz_overlay *o, const hz_overlay_frame *frame, hz_err *err);

/* Bytes queued right now (for HUD figures). */
size_t hz_overlay_queued_bytes(const hz_overlay *o);

#ifdef __cplusplus
}
#endif
#endif
