/* Private to src/render: the renderer's state, shared by renderer.c (the
 * frame driver) and the effect modules fx_*.c. */
#ifndef HZ_RENDER_INTERNAL_H
#define HZ_RENDER_INTERNAL_H

#include "horizon/render.h"
#include "gl_util.h"

#include <epoxy/gl.h>

/* ---- the per-pass common block (shaders/fx_common.glsl FxCommon, std140) ---- */
typedef struct fx_common_ubo {
    float sun[4], sun_color[4], horizon[4], zenith[4], eye[4], fog[4], fog_far[4], clip[4], cloud[4], cloud_off[4],
        map[4], lm[4];
    int32_t bits[4];
} fx_common_ubo;
_Static_assert(sizeof(fx_common_ubo) == 13 * 16, "fx_common_ubo mirrors the std140 FxCommon block");
_Static_assert(offsetof(fx_common_ubo, bits) == 12 * 16, "FxCommon.fx_bits offset");

#define FX_UBO_BINDING 0
#define FX_UNIT_HEIGHTS 0  /* texture units, fixed per sampler */
#define FX_UNIT_LIGHTMAP 1
#define FX_UNIT_DETAIL 2
#define FX_UNIT_COLORMAP 3
#define FX_UNIT_COVER 4
#define FX_UNIT_SPRITE 5
#define FX_UNIT_REFLECTION 6
#define FX_UNIT_CLOUDS 7
#define FX_UNIT_BB 8
#define FX_UNIT_LIT 9       /* the plain terrain's lit colour per sample (terrain_litmap.c) */
#define FX_UNIT_NORMALS 10  /* per-sample normals */
#define FX_UNIT_TILES 11    /* cdlod height tiles (texture array) */
#define FX_UNIT_IMG_OV 12   /* imagery overview */
#define FX_UNIT_IMG_TILES 13 /* imagery tiles (texture array) */
#define FX_UNIT_VALID 14    /* samples with data (water depth) */
#define FX_UNIT_COAST 15    /* a sea's coast beyond the data (hz_coast edges) */
#define FX_MAX_REFLECTIONS 4

/* What one scene pass sees: the main view or a mirrored reflection view. */
typedef struct fx_view {
    hz_pass pass;
    hz_camera cam;         /* the pass camera (mirrored for reflections) */
    mat4 view, proj, viewproj, inv_vp_rot;
    vec3 eye;              /* shading eye (mirrored for reflections) */
    vec4 clip;             /* keep dot(clip, (p, 1)) >= 0; all 0 = none */
    uint32_t w, h;         /* viewport */
    float water_level;     /* reflection passes: the plane */
} fx_view;

/* Resolved per-frame parameters. */
typedef struct fx_frame {
    hz_scene_params sp;    /* defaults applied */
    hz_fx_settings fx;     /* defaults applied */
    uint32_t bits;         /* effects actually drawn (resources present) */
    double time;
    float zfar;
    vec3 zenith, sun_color;
    float glow;            /* warm horizon toward a low sun, 0..1 */
    float ground_lo;       /* lowest terrain, metres (0 without heights) */
    float water_mask;      /* a sea's level: the terrain's alpha says whether it stands above it, and
                              the sea shows where it does not (-1e30: none) */
    bool post;             /* the scene renders to a texture and the chain runs */
    bool lit;              /* the plain terrain reads the lit map (terrain_litmap.c) */
    const uint32_t *refl_idx;
    uint32_t refl_count;
    GLuint refl_ibo;       /* index buffer holding refl_idx */
} fx_frame;

/* Effect shaders are compiled per variant: the effect bits that matter to
 * them (and a few resource flags) become compile-time constants. */
#define FX_VARIANT_COLORMAP (1u << 16)
#define FX_VARIANT_COVER (1u << 17)
#define FX_VARIANT_PATCH (1u << 18) /* terrain drawn as cdlod patches */
#define FX_VARIANT_CLIP (1u << 19)  /* a reflection pass: discard below the water plane */
#define FX_VARIANT_MASK (1u << 20)  /* cdlod patches over samples without data: clip the triangles touching them */
#define FX_VARIANT_IMAGERY (1u << 21) /* draped imagery */
#define FX_VARIANT_STREAM (1u << 22)  /* cdlod patches over a streamed pyramid (terrain_patch_vs.glsl's STREAM) */
#define FX_VARIANT_DETAIL_FAR (1u << 23) /* patches beyond the ground detail's fade: its far colour only */
#define FX_VARIANT_LIT (1u << 24)        /* the plain terrain reads its colour from the lit map */
#define FX_VARIANT_STILL (1u << 25)      /* patches none of whose vertices morph: no morph code */
#define FX_VARIANT_VLIT (1u << 26)       /* patches read the lit map per vertex (--lit-map vertex) */
#define FX_VARIANT_FINE (1u << 27)       /* with VLIT: full-resolution patches (still or not), read per
                                            vertex at the per-pixel read's filtering (terrain_patch_vs.glsl) */
#define FX_VARIANT_SIMPLE (1u << 28)     /* patches whose even vertices are still (hz_patch.simple): each
                                            odd vertex morphs toward its stored target */
#define SKY_CELLS (HZ_SKY_COLS * HZ_SKY_ROWS) /* the plain sky's grid (sky_grid_vs.glsl: SKY_COLS x SKY_ROWS) */
#define LIT_KEY_LEN 8 /* the lit map's lighting: sun (3), ambient, snow line, tree line, aridity, zscale */
/* The ground detail fades out between these multiples of its scale
 * (terrain_fs.glsl, splat); beyond the far one only its slow brightness
 * variation is left. */
#define FX_DETAIL_FADE_NEAR 150.0f
#define FX_DETAIL_FADE_FAR 900.0f
#define FX_MAX_LOCS 32
#define FX_MAX_VARIANTS 40 /* the --effect-costs run uses about 16 terrain variants */

typedef struct prog_variant {
    uint32_t key;
    GLuint prog;
    uint32_t last_use;
    GLint loc[FX_MAX_LOCS];
} prog_variant;

typedef struct prog_cache {
    prog_variant v[FX_MAX_VARIANTS];
    uint32_t n, tick;
} prog_cache;

/* The variant of a program family for key: compiled (and its uniform
 * locations looked up, names NULL-terminated) on first use; the least
 * recently used one is dropped when the cache is full. NULL + err on a
 * compile error. */
const prog_variant *prog_cache_get(prog_cache *c, uint32_t key, const char *vs, const char *fs, const char *name,
                                   int common_mask, const char *const *names, hz_err *err);
void prog_cache_clear(prog_cache *c);

/* Uniform location slots per family. */
enum { TL_SIZE, TL_SPACING, TL_HSCALE, TL_HOFFSET, TL_VIEWPROJ, TL_SUN, TL_HORIZON, TL_EYE, TL_FOG, TL_AMBIENT,
       TL_HRANGE, TL_WIRE, TL_MORPH_SCALE, TL_MORPH_START, TL_NORMAL_TEX, TL_NRM_SCALE, TL_MAP, TL_TILE, TL_TOP,
       TL_BASE, TL_CLIMATE, TL_IMG_MAP, TL_IMG_TILE, TL_TILE_SHIFT, TL_WATER_MASK, TL_LIT_LOD, TL_LIT_TOP,
       TL_MORPH_NEAR, TL_MORPH_NEAR_D0 };
enum { BL_VIEWPROJ, BL_CAM_RIGHT, BL_CAM_UP, BL_PX_PER_M, BL_BLEND, BL_FIRST, BL_FACING };
enum { WL_RECT, WL_LEVEL, WL_VIEWPROJ, WL_HAS_REFLECTION, WL_VIEWPORT, WL_SIZE, WL_SPACING, WL_HSCALE, WL_HOFFSET,
       WL_DEEP, WL_CLARITY, WL_WAVES, WL_REFLECTIVITY, WL_GRID, WL_HAS_VALID, WL_SEA, WL_COAST_RECT,
       WL_COAST_SPACING };
enum { QL_CENTER, QL_HALF, QL_Z, QL_CLOUDS };
enum { SL_INV_VP, SL_SKY_Z };

typedef struct sky_uniforms {
    GLint inv_viewproj_rot, horizon, zenith, sun_dir, sky_z;
} sky_uniforms;




typedef struct hist_slot {
    GLuint fbo[2], tex[2];
    int cur;               /* tex[cur] holds the last result */
    bool valid;
    uint32_t w, h;
} hist_slot;

/* cdlod patches: the main view's go in at most PATCH_CHUNKS flushed draws
 * (terrain_patch.c), cut once more where the ground detail fades. */
#define PATCH_CHUNKS 5
#define PATCH_SEGS (PATCH_CHUNKS + 1)

struct hz_renderer {
    void *ctx;         /* EGLContext or GLXContext current at creation */
    uint32_t width, height;
    bool to_default;   /* draw to framebuffer 0 instead of fbo */
    int default_alpha; /* framebuffer 0 has alpha bits: 1, 0, or -1 not asked yet */
    bool clip_control; /* GL 4.5 or ARB_clip_control: depth range [0, 1] */
    GLint max_tbo;     /* GL_MAX_TEXTURE_BUFFER_SIZE, texels */
    GLint max_tex;     /* GL_MAX_TEXTURE_SIZE */

    GLuint fbo, color_rb, depth_rb;
    GLuint vao;         /* empty: the terrain and the sky have no attributes */
    GLuint ibo;         /* per-frame indices, GL_STREAM_DRAW */
    size_t ibo_cap;     /* bytes allocated in ibo */
    GLuint ibo2;        /* reflection indices */
    size_t ibo2_cap;
    GLuint height_buf;  /* GL_TEXTURE_BUFFER storage, uint16 per sample */
    GLuint height_tex;  /* GL_R16 view of height_buf */
    GLuint valid_buf;   /* GL_TEXTURE_BUFFER, a byte per sample: has data */
    GLuint valid_tex;   /* GL_R8 view of valid_buf */
    bool has_valid;     /* valid_tex holds the heightmap's validity */
    GLuint coast_buf;   /* GL_TEXTURE_BUFFER, hz_coast edge bytes */
    GLuint coast_tex;   /* GL_R8 view of coast_buf */
    int32_t coast_rect[4]; /* x0, z0, x1, z1 samples; x1 < x0: no coast */
    float coast_spacing;   /* metres between the coast's samples */
    GLuint normal_tex;  /* GL_RG8_SNORM 2D texture of per-sample normals (x, z), 0: none */

    /* The plain terrain's lit map (terrain_litmap.c) */
    GLuint lit_tex;            /* GL_RGBA8, mipmapped, a texel per sample; 0: none */
    GLuint lit_fbo, lit_prog;
    GLint lit_loc[6];
    bool lit_valid;            /* lit_tex holds the shading of lit_key */
    bool lit_prev_set;         /* lit_prev holds the last plain frame's lighting */
    bool lit_failed;           /* a bake failed (GL): per-pixel shading until the next heightmap */
    float lit_key[LIT_KEY_LEN], lit_prev[LIT_KEY_LEN];
    /* Per block of lit_smooth_cells x lit_smooth_cells cells (a full-resolution
     * cdlod patch), lit_smooth_n a side: 1 where interpolating the map over
     * the mesh's triangles instead of bilinearly changes no colour by more
     * than LIT_SMOOTH_TOL (litmap_smooth). NULL: none (no map, no patches, or
     * the readback failed). lit_smooth_cells: the patch size last tried. */
    uint8_t *lit_smooth;
    uint32_t lit_smooth_cells, lit_smooth_n;

    /* cdlod patches (terrain_patch.c) */
    GLuint tiles_tex, tiles_buf; /* GL_TEXTURE_BUFFER (RGBA16UI) over tiles_buf: the tiles of the
                                    height pyramid (or the cache slots) back to back, each a square
                                    of tile_cells + 1 (+ 3 streamed: an apron) texels a side */
    uint32_t tile_cells, tile_top, tile_layers;
    bool streamed;             /* the tiles are a streamed pyramid's cache slots */
    bool wrap;                 /* ... of a repeating terrain: patches may lie a period off the map */
    bool tile_masked;          /* some samples have no data: the mask variant clips there */
    int32_t tile_base[16];     /* first layer per level */
    GLuint patch_vao, patch_ibo, patch_vbo;
    uint32_t patch_cells, patch_index_count;
    /* The patch's index buffer: its cells row by row (patch_index_count
     * indices), then again block by block (hz_lod_patch_blocks per side, in
     * Morton order): there a block is block_indices consecutive indices, so
     * the blocks a patch shows (hz_patch.hidden) are a few ranges. */
    uint32_t patch_blocks, block_indices;
    uint8_t block_morton[16];  /* block bit (B * bz + bx) of each position in the index order */
    uint16_t *inst_hidden;     /* hz_patch.hidden of each instance, in instance order */
    uint32_t inst_hidden_cap;
    bool any_hidden;           /* some instance of this frame has a hidden block */
    GLuint patch_cmd_buf;      /* indirect draws of the patches with hidden blocks */
    uint32_t *patch_cmds;      /* their commands (5 words each) */
    size_t patch_cmds_cap;     /* commands */
    size_t cmd_bytes;          /* their bytes uploaded this frame */
    uint32_t *inst_scratch;
    size_t inst_scratch_cap, inst_cap, inst_bytes;
    uint32_t n_inst;           /* instances uploaded for this frame */
    uint32_t n_inst_near;      /* the first n_inst_near of them reach nearer than the detail's fade
                                  (patch_detail_split; all of them without the detail); the rest
                                  draw with terrain_patch_far */
    /* The instances come in segments (the flushed chunks, split at
     * n_inst_near), each by class (PATCH_STILL_FINE .. PATCH_MORPH):
     * segment k is [seg[k], seg[k + 1]), its class c starts at
     * seg_class[k][c]; seg_flush[k]: it ends a chunk (a glFlush follows it). */
    uint32_t seg[PATCH_SEGS + 1], seg_class[PATCH_SEGS][6], n_seg;
    bool seg_flush[PATCH_SEGS];
    /* Late culling (hz_scene_params.patch_late_job): the segments from
     * late_seg on are packed only once the job is done, without the patches
     * late_hidden marks, so segment k's last class ends at seg_end[k]
     * (<= seg[k + 1]). late_p: the frame's patches, while it draws. */
    uint32_t seg_end[PATCH_SEGS], late_seg, late_skipped;
    hz_job *late_job;
    const uint8_t *late_hidden;
    const uint16_t *late_blocks;
    const hz_patch *late_p;
    double late_wait_ms;

    GLuint sky_prog;          /* the plain sky */
    uint32_t sky_cells;       /* cells of its grid the last main pass drew */
    GLint sky_first[SKY_CELLS], sky_count[SKY_CELLS]; /* its runs of visible cells */
    sky_uniforms su;
    prog_cache terrain;       /* variant 0: the plain terrain */
    const prog_variant *terrain_cur, *terrain_plain;
    const prog_variant *terrain_patch_cur; /* this frame's patch variant (NULL: no patches) */
    const prog_variant *terrain_patch_far; /* the same beyond the detail's fade (NULL: no detail) */
    const prog_variant *terrain_patch_still, *terrain_patch_far_still; /* the same two without the
                                              morph code, for the still patches (NULL: streamed) */
    const prog_variant *terrain_patch_fine, *terrain_patch_fine_still; /* full-resolution patches over
                                              smooth lit map, reading it per vertex (NULL: per pixel;
                                              see hz_scene_params.lit_pixel) */
    const prog_variant *terrain_patch_simple, *terrain_patch_fine_simple, *terrain_patch_far_simple;
                                           /* the morphing ones with the simpler morph, for the patches
                                              whose even vertices are still (NULL: streamed) */
    uint32_t fine_patches;     /* instances of this frame drawn with those two */
    const prog_variant *terrain_clip_cur;  /* this frame's reflection-pass variant (NULL: no water) */

    /* Current heightmap, world units (metres, zscale applied). */
    bool has_heights;
    uint32_t size;
    float spacing, hscale, hoffset, hmin, hmax;
    float zscale;
    hz_climate climate;  /* ground colour by absolute height (hz_renderer_set_climate) */

    GLuint depth_fbo;   /* the framebuffer holding the last frame's depth */

    /* ---- effects ---- */
    GLuint ubo;
    prog_cache fx_sky;
    const prog_variant *fx_sky_cur;
    GLuint noise_tex;               /* cloud fBm, made on the GPU at first use */
    /* ground */
    GLuint lightmap_tex, detail_tex, colormap_tex, cover_tex, dummy_tex, dummy_array;
    bool has_lightmap, has_colormap, has_cover, detail_ready;
    GLuint img_ov_tex, img_tiles_tex; /* draped imagery (0: none) */
    float img_map[4], img_tile[2];    /* u_img_map, u_img_tile */
    bool has_imagery;
    uint8_t *detail_cpu;            /* the packed detail texture (R grass, G rock, B snow, A sand) */
    vec3 lightmap_sun;
    float lm_xform[2];
    GLuint sunh_tex;      /* hz_renderer_set_sun_heights, 0: none */
    vec3 sunh_sun;
    vec4 sunh_map;
    /* billboards and weather */
    prog_cache bb;
    const prog_variant *bb_cur;
    GLuint bb_buf_gl, bb_tbo;   /* instances as a GL_RGBA32F texture buffer, 3 texels each */
    size_t bb_gl_cap;
    float *bb_gpu;              /* conversion scratch */
    size_t bb_gpu_cap;
    GLuint bb_tex[HZ_MAX_BB_TEXTURES];
    hz_bb_field *field;
    hz_billboard *bb_buf;  /* this frame's instances: main trees, reflection trees, particles */
    size_t bb_cap;
    size_t n_trees, n_refl_trees, n_particles; /* counts in bb_buf, in that order */
    hz_bb_batch tree_batches[HZ_MAX_BB_TEXTURES * 2], refl_batches[HZ_MAX_BB_TEXTURES * 2];
    size_t n_tree_batches, n_refl_batches;
    void *bb_scratch;
    size_t bb_scratch_cap;
    /* water */
    hz_water_plane *planes;
    hz_water_material *mats;
    uint32_t n_planes, n_mats;
    prog_cache water;
    const prog_variant *water_cur;
    GLuint refl_fbo[FX_MAX_REFLECTIONS], refl_tex[FX_MAX_REFLECTIONS], refl_depth[FX_MAX_REFLECTIONS];
    float refl_level[FX_MAX_REFLECTIONS];
    float refl_rect[FX_MAX_REFLECTIONS][4]; /* NDC x0, y0, x1, y1 where each level's water can show */
    uint32_t n_refl, refl_w, refl_h;
    /* Lowest terrain per block of wet_block samples and its neighbours
     * (wet_n blocks per side, world height): where a water plane can be
     * above the drawn ground. NULL for a streamed pyramid (then water may
     * show anywhere). */
    float *wet_min;
    uint32_t wet_n, wet_block;
    /* flare */
    prog_cache query;
    const prog_variant *query_cur;
    GLuint flare_prog, queries[2];
    GLint f_sun, f_aspect, f_t, f_size, f_color, f_intensity;
    /* post chain */
    GLuint scene_fbo, scene_color, scene_depth;
    uint32_t scene_w, scene_h;
    hist_slot hist[HZ_MAX_HISTORY];
    GLuint bloom_fbo[3], bloom_tex[3];
    uint32_t bloom_w, bloom_h;
    GLuint blur_prog, bright_prog, gauss_prog;
    GLuint final_prog[8];     /* by FINAL_* bits (fx_post.c), made on first use */
};

/* ---- renderer.c helpers ---- */
/* HZ_ERR_GL unless the renderer's context is current (libepoxy would abort). */
hz_result fx_check_context(const hz_renderer *r, hz_err *err, const char *what);
/* Links a program. common_mask: bit 0 vertex, bit 1 fragment stage get the
 * variant's constants and shaders/fx_common.glsl after their #version line
 * (effect shaders); other stages get "#define FX_VARIANT <variant>". 0 + err
 * on failure. */
GLuint link_program(const char *vs_src, const char *fs_src, const char *name, int common_mask, uint32_t variant,
                    hz_err *err);
/* Binds the FxCommon block and the fixed sampler units of a program. */
void fx_program_setup(GLuint prog);
void fx_upload_common(hz_renderer *r, const fx_frame *f, const fx_view *v);
/* Draws sky (plain or with effects), terrain and the object hook into the
 * bound framebuffer for a view: what an effect pass gets from the frame
 * driver when it must draw the scene (a reflection), so it never calls up
 * into renderer.c. */
typedef void (*fx_scene_fn)(hz_renderer *r, const fx_frame *f, const fx_view *v, GLuint ibo, uint32_t count);

/* The terrain variant for a frame's effects (patches: the cdlod vertex shader). */
hz_result fx_terrain_select(hz_renderer *r, const fx_frame *f, bool patches, hz_err *err);

/* ---- terrain_litmap.c: the plain terrain's lit map ---- */

/* use: the frame's plain terrain (plain: no terrain effect, colour map or
 * imagery) reads the lit map, baked first if the lighting changed and has
 * held since the previous frame. A failed bake leaves per-pixel shading.
 * Returns the ms spent baking (0: no bake). */
double litmap_prepare(hz_renderer *r, const fx_frame *f, bool plain, bool *use);
/* The heightmap changed: the map goes (GL objects of the last one freed). */
void litmap_invalidate(hz_renderer *r);
/* Whether the full-resolution patch with its corner at sample (x0, z0) may
 * read the lit map per vertex: the map is baked and smooth enough over it
 * (hz_renderer.lit_smooth, for the current patch size). */
bool litmap_smooth_at(const hz_renderer *r, uint32_t x0, uint32_t z0);
void litmap_release(hz_renderer *r);
void litmap_destroy(hz_renderer *r);

/* ---- terrain_patch.c: cdlod patches ---- */
/* The classes of patches, in their order inside a segment: still
 * (hz_patch.still), morphing simply (hz_patch.simple) or morphing, each
 * full-resolution (shift 0) over smooth lit map (litmap_smooth_at) or not. */
enum {
    PATCH_STILL_FINE,
    PATCH_STILL,
    PATCH_SIMPLE_FINE,
    PATCH_SIMPLE,
    PATCH_MORPH_FINE,
    PATCH_MORPH,
    PATCH_CLASSES
};
/* Converts and uploads a frame's patches (instances), in segments (the
 * flushed chunks, split at near), each by class. */
hz_result patch_upload(hz_renderer *r, const hz_patch *p, uint32_t count, uint32_t near, hz_err *err);
/* The same with late culling (see hz_renderer.late_seg): the segments
 * before hz_renderer_patch_lead(count) now, the rest when patch_draw
 * first reaches them, after waiting for job. */
hz_result patch_upload_late(hz_renderer *r, const hz_patch *p, uint32_t count, uint32_t near, hz_job *job,
                            const uint8_t *hidden, const uint16_t *blocks, hz_err *err);
/* Forgets the frame's late culling (its patches are gone after the draw). */
void patch_late_end(hz_renderer *r);
/* How many of the uploaded patches (nearest first) come nearer to the eye
 * than dist, horizontally (a bound for any point they draw, whatever its
 * height or morph): every patch after that many lies entirely beyond it. */
uint32_t patch_detail_split(const hz_renderer *r, const hz_patch *p, uint32_t count, const float eye[3], float dist);
/* Draws uploaded patches [first, end) (segment bounds), flushed at the chunk
 * ends (PATCH_CHUNKS) they reach, each class with its program in prog
 * (PATCH_MORPH's never NULL; a NULL one: for a FINE class its other
 * FINE class's program or, without one, its class's without FINE; else
 * PATCH_MORPH's). Every program's frame uniforms
 * are set (terrain_program); prog[PATCH_MORPH] is bound on return. */
void patch_draw(hz_renderer *r, const prog_variant *const prog[PATCH_CLASSES], uint32_t first, uint32_t end);
void patch_destroy(hz_renderer *r);

/* ---- fx_ground.c: light map, detail, colour map, forest cover ---- */
hz_result fx_ground_ensure(hz_renderer *r, hz_err *err);
void fx_ground_bind(hz_renderer *r);
void fx_ground_destroy(hz_renderer *r);
bool fx_lightmap_matches(const hz_renderer *r, const vec3 sun);
bool fx_sun_heights_match(const hz_renderer *r, const vec3 sun);

/* ---- fx_sky.c: sky dome, clouds, sun query, lens flare ---- */
hz_result fx_sky_ensure(hz_renderer *r, const fx_frame *f, hz_err *err);
hz_result fx_flare_ensure(hz_renderer *r, const fx_frame *f, hz_err *err);
void fx_sky_draw(hz_renderer *r, const fx_frame *f, const fx_view *v);
void fx_flare_draw(hz_renderer *r, const fx_frame *f, const fx_view *v, hz_draw_stats *st);
void fx_sky_destroy(hz_renderer *r);

/* ---- fx_billboard.c: vegetation and weather ---- */
hz_result fx_billboards_ensure(hz_renderer *r, const fx_frame *f, hz_err *err);
/* CPU part of a frame: culls and batches trees (main and mirrored views) and
 * builds the weather, then uploads all instances. */
hz_result fx_billboards_prepare(hz_renderer *r, const fx_frame *f, const fx_view *main, const fx_view *mirror,
                                hz_err *err);
void fx_trees_draw(hz_renderer *r, const fx_frame *f, const fx_view *v);
void fx_weather_draw(hz_renderer *r, const fx_frame *f, const fx_view *v);
void fx_billboards_destroy(hz_renderer *r);

/* ---- fx_water.c ---- */
hz_result fx_water_ensure(hz_renderer *r, const fx_frame *f, hz_err *err);
/* Water heights visible from the main view (distinct, at most
 * FX_MAX_REFLECTIONS), nearest first, each with the NDC rectangle (x0, y0,
 * x1, y1) where its water can show and sample its reflection (over ground
 * lower than it, widened by the wave displacement); returns the count. */
uint32_t fx_water_visible(const hz_renderer *r, const fx_frame *f, const fx_view *v, float *levels,
                          float (*rects)[4]);
void fx_water_mirror_view(const fx_view *main, float level, fx_view *out);
hz_result fx_water_reflections(hz_renderer *r, const fx_frame *f, const fx_view *main, fx_scene_fn draw_scene,
                               hz_err *err);
void fx_water_draw(hz_renderer *r, const fx_frame *f, const fx_view *v);
void fx_water_destroy(hz_renderer *r);

/* ---- fx_post.c: scene target and the post chain ---- */
hz_result fx_post_ensure(hz_renderer *r, hz_err *err);
hz_result fx_scene_target(hz_renderer *r, hz_err *err);
void fx_post_run(hz_renderer *r, const fx_frame *f, GLuint out_fbo);
void fx_post_destroy(hz_renderer *r);
/* A fresh colour texture (+ FBO) of w x h, format GL_RGBA16F or GL_RGBA8. */
hz_result fx_make_target(GLuint *fbo, GLuint *tex, GLuint depth, uint32_t w, uint32_t h, GLenum format, hz_err *err);

#endif
