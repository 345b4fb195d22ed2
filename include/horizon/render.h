/* horizon renderer: the only module that talks to GL (through libepoxy).
 * Turns the LOD's index list into one indexed draw over a vertex-less grid:
 * gl_VertexID is the sample index, the vertex shader fetches the 16-bit height. */
#ifndef HORIZON_RENDER_H
#define HORIZON_RENDER_H

#include "horizon/camera.h"
#include "horizon/heightmap.h"

#ifdef __cplusplus
extern "C" {
#endif

/* A current OpenGL 4.5 core context. Headless: EGL surfaceless (Mesa llvmpipe
 * works, no window, no GPU). Only one per thread may be current. */
typedef struct hz_gl hz_gl;
hz_gl *hz_gl_create_headless(hz_err *err);
void hz_gl_destroy(hz_gl *gl);
/* "renderer | version" strings of the current context, for logs. */
const char *hz_gl_describe(const hz_gl *gl);

typedef struct hz_renderer hz_renderer;

typedef struct hz_renderer_desc {
    uint32_t width, height; /* target size in pixels; 0 -> 1280 x 720 */
    bool to_default_framebuffer; /* false (default): draw into an internal FBO
                                    (headless); true: draw to framebuffer 0 (a window) */
} hz_renderer_desc;

/* Requires a current context. NULL with err set on failure (shader compile
 * errors quote the GL log). */
hz_renderer *hz_renderer_create(const hz_renderer_desc *desc, hz_err *err);
void hz_renderer_destroy(hz_renderer *r);
/* Changes the target size (window resize). */
hz_result hz_renderer_resize(hz_renderer *r, uint32_t width, uint32_t height, hz_err *err);

/* Uploads the heights once (GL_R16 texture buffer, 2 bytes/sample). spacing:
 * metres between samples; zscale multiplies heights. Replaces any previous one. */
hz_result hz_renderer_set_heightmap(hz_renderer *r, const hz_heightmap *hm, float spacing,
                                    float zscale, hz_err *err);

/* Scene passes: the main view, and (with water) a mirrored reflection view. */
typedef enum hz_pass {
    HZ_PASS_MAIN = 0,
    HZ_PASS_REFLECTION = 1
} hz_pass;

/* What a draw hook gets for each scene pass. Depth is reverse-Z (clear 0,
 * GL_GREATER, clip depth [0, 1] via glClipControl), the pass's framebuffer
 * and viewport are bound, depth test and writes are on. */
typedef struct hz_pass_info {
    hz_pass pass;
    const hz_camera *cam;    /* the camera of this pass (mirrored for reflections) */
    mat4 view, proj, viewproj;
    vec4 clip_plane;         /* world space; keep points where dot(plane, (p, 1)) >= 0
                                (write gl_ClipDistance[0]); all zero = no plane */
    vec3 sun_dir;            /* resolved scene parameters, for consistent shading */
    vec3 sky_color;
    float fog_density;       /* per metre, 0 = no fog */
    float ambient;
    uint32_t width, height;  /* target size in pixels */
} hz_pass_info;

/* Draws extra opaque objects (trees, buildings...) into a scene pass, after
 * the terrain. Must leave: program 0, VAO 0, blending off, depth writes on. */
typedef void (*hz_draw_hook_fn)(void *user, const hz_pass_info *pass);

/* cdlod geomorphing: per-sample morph errors (hz_lod_morph_errors: h16 steps,
 * 65535 = never morphs, row-major) uploaded once as a GL_R16 texture buffer
 * (2 bytes/sample). NULL releases them. Call after hz_renderer_set_heightmap. */
hz_result hz_renderer_set_morph(hz_renderer *r, const uint16_t *morph_err, hz_err *err);

typedef struct hz_scene_params {
    vec3 sun_dir;       /* unit vector toward the sun; all 0 -> default (afternoon sun) */
    vec3 sky_color;     /* horizon colour the fog fades to; all 0 -> pale blue */
    float fog_density;  /* per metre, f = exp(-density * dist); 0 -> 3/zfar, < 0 -> no fog */
    float ambient;      /* Ie, 0 -> 0.3 */
    bool wireframe;     /* draw lines on top of shaded terrain */
    float morph_scale;  /* cdlod geomorphing (hz_lod_stats.morph_scale / morph_start of the
                           frame's selection); 0 = no morphing. Needs hz_renderer_set_morph */
    float morph_start;
    hz_draw_hook_fn draw_objects; /* optional: called in every scene pass after the terrain */
    void *draw_objects_user;
} hz_scene_params;

typedef struct hz_draw_stats {
    double upload_ms;   /* index upload */
    double draw_ms;     /* sky + terrain, bracketed by glFinish */
} hz_draw_stats;

/* Draws sky then terrain triangles (count indices, a multiple of 3, into the
 * row-major sample grid: index = j * size + i). params may be NULL (defaults).
 * stats may be NULL. */
hz_result hz_renderer_draw(hz_renderer *r, const hz_camera *cam, const hz_scene_params *params,
                           const uint32_t *indices, uint32_t count, hz_draw_stats *stats,
                           hz_err *err);

/* Reads the last frame as RGB8, top row first, width*height*3 bytes. */
hz_result hz_renderer_read_rgb(hz_renderer *r, uint8_t *rgb, hz_err *err);

/* Reads the last frame's sky mask, top row first, width*height bytes: 1 where
 * no terrain was drawn (sky), 0 elsewhere. Internal FBO only (fails with
 * to_default_framebuffer). */
hz_result hz_renderer_read_sky_mask(hz_renderer *r, uint8_t *mask, hz_err *err);


/* Writes RGB8 (top row first) as PNG. */
hz_result hz_image_write_png(const char *path, const uint8_t *rgb, uint32_t width,
                             uint32_t height, hz_err *err);

#ifdef __cplusplus
}
#endif
#endif
