/* The interactive window: GLFW on X11 with a GLX OpenGL 4.5 core context
 * (3.3 core as a fallback). Input is collected by GLFW callbacks into the
 * hz_window (found through the GLFW window user pointer) and handed out per
 * frame by hz_window_poll; scripted input goes through the same state. */
#include "horizon/window.h"

#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include <epoxy/gl.h>
/* epoxy provides the GL declarations; GLFW must not include its own. */
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

_Static_assert(HZ_KEY_A == GLFW_KEY_A && HZ_KEY_0 == GLFW_KEY_0 && HZ_KEY_TAB == GLFW_KEY_TAB &&
                   HZ_KEY_ESCAPE == GLFW_KEY_ESCAPE && HZ_KEY_F1 == GLFW_KEY_F1 &&
                   HZ_KEY_LEFT_SHIFT == GLFW_KEY_LEFT_SHIFT && HZ_KEY_RIGHT_CONTROL == GLFW_KEY_RIGHT_CONTROL &&
                   HZ_KEY_UP == GLFW_KEY_UP && HZ_KEY_HOME == GLFW_KEY_HOME && HZ_KEY_COUNT == GLFW_KEY_LAST + 1 &&
                   HZ_KEY_LEFT_BRACKET == GLFW_KEY_LEFT_BRACKET && HZ_KEY_SEMICOLON == GLFW_KEY_SEMICOLON,
               "hz key codes must equal GLFW's");
_Static_assert(HZ_MOUSE_COUNT == GLFW_MOUSE_BUTTON_LAST + 1, "hz mouse buttons must equal GLFW's");

struct hz_window {
    GLFWwindow *win;
    char desc[256];
    /* Input state, written by the callbacks and by the inject functions. */
    bool key_real[HZ_KEY_COUNT], key_injected[HZ_KEY_COUNT];
    bool button_real[HZ_MOUSE_COUNT], button_injected[HZ_MOUSE_COUNT];
    int presses[HZ_WINDOW_MAX_PRESSES];
    uint32_t press_count;
    double cursor_x, cursor_y;
    bool cursor_valid;       /* false until the first cursor event after a capture change */
    float mouse_dx, mouse_dy, scroll;
    bool captured;
    bool close_requested;
    uint32_t fb_w, fb_h;     /* last size handed out by hz_window_poll */
};

/* NOTE: the only mutable file-scope state: GLFW is initialised once per
 * process whatever we do, and glfwTerminate would destroy every window, so
 * it runs when the last of ours is destroyed. Main thread only (GLFW's rule). */
static int live_windows;

static hz_window *self(GLFWwindow *win)
{
    return (hz_window *)glfwGetWindowUserPointer(win);
}

static void add_press(hz_window *w, int key)
{
    if (w->press_count < HZ_WINDOW_MAX_PRESSES)
        w->presses[w->press_count++] = key;
}

static void on_key(GLFWwindow *win, int key, int scancode, int action, int mods)
{
    (void)scancode;
    (void)mods;
    hz_window *w = self(win);
    if (!w || key < 0 || key >= HZ_KEY_COUNT)
        return;
    if (action == GLFW_PRESS || action == GLFW_REPEAT)
        add_press(w, key);
    if (action != GLFW_REPEAT)
        w->key_real[key] = action == GLFW_PRESS;
}

static void on_button(GLFWwindow *win, int button, int action, int mods)
{
    (void)mods;
    hz_window *w = self(win);
    if (!w || button < 0 || button >= HZ_MOUSE_COUNT)
        return;
    w->button_real[button] = action == GLFW_PRESS;
}

static void on_cursor(GLFWwindow *win, double x, double y)
{
    hz_window *w = self(win);
    if (!w)
        return;
    if (w->cursor_valid) {
        w->mouse_dx += (float)(x - w->cursor_x);
        w->mouse_dy += (float)(y - w->cursor_y);
    }
    w->cursor_x = x;
    w->cursor_y = y;
    w->cursor_valid = true;
}

static void on_scroll(GLFWwindow *win, double dx, double dy)
{
    (void)dx;
    hz_window *w = self(win);
    if (w)
        w->scroll += (float)dy;
}

static void on_close(GLFWwindow *win)
{
    hz_window *w = self(win);
    if (w)
        w->close_requested = true;
}

static const char *glfw_error(void)
{
    const char *msg = NULL;
    int code = glfwGetError(&msg);
    if (code == GLFW_NO_ERROR)
        return "no error reported";
    return msg ? msg : "unknown GLFW error";
}

hz_window *hz_window_create(const hz_window_desc *desc, hz_err *err)
{
    hz_window_desc d = desc ? *desc : (hz_window_desc){0};
    if (d.width == 0 || d.height == 0) {
        d.width = 1280;
        d.height = 720;
    }
    if (d.width > 16384 || d.height > 16384) {
        hz_err_set(err, HZ_ERR_VALUE, "window: bad size %ux%u", d.width, d.height);
        return NULL;
    }
    if (!glfwInit()) {
        hz_err_set(err, HZ_ERR_GL, "window: cannot initialise GLFW (%s); an X display is needed "
                   "(on a machine without one: xvfb-run -a horizon view ...)", glfw_error());
        return NULL;
    }
    live_windows++;
    hz_window *w = calloc(1, sizeof *w);
    if (!w) {
        hz_err_set(err, HZ_ERR_MEMORY, "out of memory");
        goto fail;
    }

    /* 4.5 core is what the renderer targets; 3.3 core still runs it. */
    static const int versions[][2] = {{4, 5}, {3, 3}};
    for (size_t k = 0; k < sizeof versions / sizeof versions[0] && !w->win; k++) {
        glfwDefaultWindowHints();
        glfwWindowHint(GLFW_CLIENT_API, GLFW_OPENGL_API);
        glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, versions[k][0]);
        glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, versions[k][1]);
        glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
        glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
        /* Reverse-Z wants depth precision; GLFW takes the closest config. */
        glfwWindowHint(GLFW_DEPTH_BITS, 32);
        glfwWindowHint(GLFW_RESIZABLE, d.fixed_size ? GLFW_FALSE : GLFW_TRUE);
        w->win = glfwCreateWindow((int)d.width, (int)d.height, d.title ? d.title : "horizon", NULL, NULL);
    }
    if (!w->win) {
        hz_err_set(err, HZ_ERR_GL, "window: cannot create a window with an OpenGL 4.5 or 3.3 core context (%s)",
                   glfw_error());
        goto fail;
    }
    glfwSetWindowUserPointer(w->win, w);
    glfwMakeContextCurrent(w->win);
    glfwSwapInterval(d.no_vsync ? 0 : 1);
    glfwSetKeyCallback(w->win, on_key);
    glfwSetMouseButtonCallback(w->win, on_button);
    glfwSetCursorPosCallback(w->win, on_cursor);
    glfwSetScrollCallback(w->win, on_scroll);
    glfwSetWindowCloseCallback(w->win, on_close);

    const char *renderer = (const char *)glGetString(GL_RENDERER);
    const char *version = (const char *)glGetString(GL_VERSION);
    if (!renderer || !version) {
        hz_err_set(err, HZ_ERR_GL, "window: context is current but glGetString returned NULL");
        goto fail;
    }
    snprintf(w->desc, sizeof w->desc, "%s | %s", renderer, version);
    int fw = 0, fh = 0;
    glfwGetFramebufferSize(w->win, &fw, &fh);
    w->fb_w = (uint32_t)(fw > 0 ? fw : 0);
    w->fb_h = (uint32_t)(fh > 0 ? fh : 0);
    return w;

fail:
    hz_window_destroy(w);
    if (!w && --live_windows == 0)
        glfwTerminate();
    return NULL;
}

void hz_window_destroy(hz_window *w)
{
    if (!w)
        return;
    if (w->win) {
        if (glfwGetCurrentContext() == w->win)
            glfwMakeContextCurrent(NULL);
        glfwDestroyWindow(w->win);
    }
    free(w);
    if (--live_windows == 0)
        glfwTerminate();
}

const char *hz_window_describe(const hz_window *w)
{
    return w ? w->desc : "(no window)";
}

void hz_window_make_current(hz_window *w)
{
    glfwMakeContextCurrent(w ? w->win : NULL);
}

void hz_window_poll(hz_window *w, hz_window_input *in)
{
    HZ_ASSERT(w && in);
    glfwPollEvents();
    memset(in, 0, sizeof *in);
    in->mouse_dx = w->mouse_dx;
    in->mouse_dy = w->mouse_dy;
    in->scroll = w->scroll;
    memcpy(in->presses, w->presses, w->press_count * sizeof w->presses[0]);
    in->press_count = w->press_count;
    in->close_requested = w->close_requested || glfwWindowShouldClose(w->win);
    int fw = 0, fh = 0;
    glfwGetFramebufferSize(w->win, &fw, &fh);
    uint32_t nw = (uint32_t)(fw > 0 ? fw : 0), nh = (uint32_t)(fh > 0 ? fh : 0);
    in->resized = nw != w->fb_w || nh != w->fb_h;
    in->fb_width = w->fb_w = nw;
    in->fb_height = w->fb_h = nh;
    w->mouse_dx = w->mouse_dy = w->scroll = 0.0f;
    w->press_count = 0;
}

void hz_window_wait(hz_window *w, double timeout_s)
{
    (void)w;
    glfwWaitEventsTimeout(timeout_s > 0 ? timeout_s : 0.1);
}

void hz_window_swap(hz_window *w)
{
    HZ_ASSERT(w);
    glfwSwapBuffers(w->win);
}

bool hz_window_key_down(const hz_window *w, int key)
{
    return key >= 0 && key < HZ_KEY_COUNT && (w->key_real[key] || w->key_injected[key]);
}

bool hz_window_mouse_down(const hz_window *w, int button)
{
    return button >= 0 && button < HZ_MOUSE_COUNT && (w->button_real[button] || w->button_injected[button]);
}

void hz_window_framebuffer_size(const hz_window *w, uint32_t *width, uint32_t *height)
{
    int fw = 0, fh = 0;
    glfwGetFramebufferSize(w->win, &fw, &fh);
    *width = (uint32_t)(fw > 0 ? fw : 0);
    *height = (uint32_t)(fh > 0 ? fh : 0);
}

void hz_window_set_size(hz_window *w, uint32_t width, uint32_t height)
{
    if (width == 0 || height == 0 || width > 16384 || height > 16384)
        return;
    glfwSetWindowSize(w->win, (int)width, (int)height);
}

void hz_window_set_title(hz_window *w, const char *title)
{
    glfwSetWindowTitle(w->win, title ? title : "horizon");
}

void hz_window_request_close(hz_window *w)
{
    w->close_requested = true;
}

void hz_window_capture_mouse(hz_window *w, bool capture)
{
    if (capture == w->captured)
        return;
    w->captured = capture;
    glfwSetInputMode(w->win, GLFW_CURSOR, capture ? GLFW_CURSOR_DISABLED : GLFW_CURSOR_NORMAL);
    if (capture && glfwRawMouseMotionSupported())
        glfwSetInputMode(w->win, GLFW_RAW_MOUSE_MOTION, GLFW_TRUE);
    /* The cursor jumps when the mode changes: do not report that as motion. */
    w->cursor_valid = false;
}

bool hz_window_mouse_captured(const hz_window *w)
{
    return w->captured;
}

void hz_window_inject_key(hz_window *w, int key, bool down)
{
    if (key < 0 || key >= HZ_KEY_COUNT)
        return;
    if (down && !w->key_injected[key])
        add_press(w, key);
    w->key_injected[key] = down;
}

void hz_window_inject_mouse_button(hz_window *w, int button, bool down)
{
    if (button >= 0 && button < HZ_MOUSE_COUNT)
        w->button_injected[button] = down;
}

void hz_window_inject_mouse_move(hz_window *w, float dx, float dy)
{
    w->mouse_dx += dx;
    w->mouse_dy += dy;
    w->cursor_x += dx;
    w->cursor_y += dy;
    w->cursor_valid = true;
}

bool hz_window_cursor(const hz_window *w, float *x, float *y)
{
    if (!w->cursor_valid || hz_window_mouse_captured(w))
        return false;
    /* Screen coordinates -> framebuffer pixels (HiDPI). */
    int ww = 0, wh = 0, fw = 0, fh = 0;
    glfwGetWindowSize(w->win, &ww, &wh);
    glfwGetFramebufferSize(w->win, &fw, &fh);
    *x = (float)(w->cursor_x * (ww > 0 ? (double)fw / ww : 1.0));
    *y = (float)(w->cursor_y * (wh > 0 ? (double)fh / wh : 1.0));
    return true;
}

void hz_window_inject_scroll(hz_window *w, float notches)
{
    w->scroll += notches;
}

/* ---- key names ------------------------------------------------------------ */

typedef struct key_name {
    const char *name;
    int key;
} key_name;

static const key_name key_names[] = {
    {"SPACE", HZ_KEY_SPACE},       {"'", HZ_KEY_APOSTROPHE},      {",", HZ_KEY_COMMA},
    {"-", HZ_KEY_MINUS},           {"MINUS", HZ_KEY_MINUS},       {".", HZ_KEY_PERIOD},
    {"/", HZ_KEY_SLASH},           {";", HZ_KEY_SEMICOLON},       {"=", HZ_KEY_EQUAL},
    {"EQUAL", HZ_KEY_EQUAL},       {"[", HZ_KEY_LEFT_BRACKET},    {"]", HZ_KEY_RIGHT_BRACKET},
    {"ESC", HZ_KEY_ESCAPE},        {"ESCAPE", HZ_KEY_ESCAPE},     {"ENTER", HZ_KEY_ENTER},
    {"TAB", HZ_KEY_TAB},           {"BACKSPACE", HZ_KEY_BACKSPACE}, {"RIGHT", HZ_KEY_RIGHT},
    {"LEFT", HZ_KEY_LEFT},         {"DOWN", HZ_KEY_DOWN},         {"UP", HZ_KEY_UP},
    {"PAGEUP", HZ_KEY_PAGE_UP},    {"PAGEDOWN", HZ_KEY_PAGE_DOWN}, {"HOME", HZ_KEY_HOME},
    {"SHIFT", HZ_KEY_LEFT_SHIFT},  {"LSHIFT", HZ_KEY_LEFT_SHIFT}, {"RSHIFT", HZ_KEY_RIGHT_SHIFT},
    {"CTRL", HZ_KEY_LEFT_CONTROL}, {"LCTRL", HZ_KEY_LEFT_CONTROL}, {"RCTRL", HZ_KEY_RIGHT_CONTROL},
};

int hz_key_from_name(const char *name)
{
    if (!name || !name[0])
        return -1;
    if (!name[1]) {
        int c = toupper((unsigned char)name[0]);
        if (c >= 'A' && c <= 'Z')
            return HZ_KEY_A + (c - 'A');
        if (c >= '0' && c <= '9')
            return HZ_KEY_0 + (c - '0');
    }
    if (toupper((unsigned char)name[0]) == 'F' && isdigit((unsigned char)name[1])) {
        char *end;
        long f = strtol(name + 1, &end, 10);
        if (!*end && f >= 1 && f <= 12)
            return HZ_KEY_F1 + (int)f - 1;
    }
    for (size_t k = 0; k < sizeof key_names / sizeof key_names[0]; k++)
        if (!strcasecmp(name, key_names[k].name))
            return key_names[k].key;
    return -1;
}

const char *hz_key_name(int key)
{
    static const char letters[] = "A\0B\0C\0D\0E\0F\0G\0H\0I\0J\0K\0L\0M\0N\0O\0P\0Q\0R\0S\0T\0U\0V\0W\0X\0Y\0Z";
    static const char digits[] = "0\0001\0002\0003\0004\0005\0006\0007\0008\0009";
    static const char *const fkeys[] = {"F1", "F2", "F3", "F4", "F5", "F6", "F7", "F8", "F9", "F10", "F11", "F12"};
    if (key >= HZ_KEY_A && key < HZ_KEY_A + 26)
        return letters + 2 * (key - HZ_KEY_A);
    if (key >= HZ_KEY_0 && key < HZ_KEY_0 + 10)
        return digits + 2 * (key - HZ_KEY_0);
    if (key >= HZ_KEY_F1 && key < HZ_KEY_F1 + 12)
        return fkeys[key - HZ_KEY_F1];
    for (size_t k = 0; k < sizeof key_names / sizeof key_names[0]; k++)
        if (key_names[k].key == key)
            return key_names[k].name;
    return "?";
}
