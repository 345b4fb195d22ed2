/* horizon renderer: the only module that talks to GL (through libepoxy).
 * Turns the LOD's index list into one indexed draw over a vertex-less grid:
 * gl_VertexID is the sample index, the vertex shader fetches the 16-bit height. */
#ifndef HORIZON_RENDER_H
#define HORIZON_RENDER_H

#include "horizon/camera.h"
#include "horizon/climate.h"
#include "horizon/fx.h"
#include "horizon/heightmap.h"
#include "horizon/imagery.h"
#include "horizon/lod.h"

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
/* Which samples of that heightmap have data (size * size bytes, 0 = none,
 * e.g. hz_terrain.valid), or NULL: all. Water is deep over samples without
 * data (an SRTM sea is nodata: its filled heights are no sea floor). Set
 * again after every hz_renderer_set_heightmap, which clears it. */
hz_result hz_renderer_set_valid(hz_renderer *r, const uint8_t *valid, hz_err *err);

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
    /* With HZ_FX_FOG: extra height fog, optical depth along a ray from e to p
     * (world, y up) = fog_density |p - e| + height_fog.x |p - e| exp(-(e.y -
     * height_fog.y) / height_fog.z) (1 - exp(-dy)) / dy, dy = (p.y - e.y) /
     * height_fog.z; and everything beyond fog_far.x fades fully to the fog
     * colour at fog_far.y metres (0, 0: no fade). Zero without HZ_FX_FOG.
     * The fog colour along a unit direction d is sky_color, and with
     * HZ_FX_FOG above the horizon the sky behind it: mix(sky_color,
     * zenith_color, (1 - exp(-3 d.y)) / (1 - exp(-3))). */
    vec3 height_fog;
    vec2 fog_far;
    vec3 zenith_color;
    uint32_t effects;        /* the frame's HZ_FX_* set */
    double time;             /* the frame's effect time, seconds */
    /* With HZ_FX_SHADOWS and sun heights for this sun
     * (hz_renderer_set_sun_heights), else 0: a GL_R32F 2D texture of the
     * sun heights; world x, z map to its coordinates as
     * uv = (x, z) * sun_heights_map.xy + sun_heights_map.zw (texel centres
     * on the samples; clamped at the edges). A point (x, y, z) is in the
     * terrain's and the casters' shade when y is below the filtered value.
     * sun_heights_spacing: metres between its samples. */
    uint32_t sun_heights_tex;
    vec4 sun_heights_map;
    float sun_heights_spacing;
} hz_pass_info;

/* Draws extra opaque objects (trees, buildings...) into a scene pass, after
 * the terrain. Must leave: program 0, VAO 0, blending off, depth writes on.
 * In HZ_PASS_REFLECTION the view matrix includes the mirror (determinant -1):
 * front faces are clockwise there (glFrontFace(GL_CW) is set), and
 * GL_CLIP_DISTANCE0 is enabled for clip_plane. */
typedef void (*hz_draw_hook_fn)(void *user, const hz_pass_info *pass);

/* cdlod patches: builds the GPU side of lod's patch terrain (a texture
 * array of height tiles, the pyramid of the heightmap, each texel with the
 * sample's height, morph range and morph target; 8 bytes per texel, about
 * 11 bytes per sample in all) and the static patch grid. The heightmap must
 * be the one given to hz_renderer_set_heightmap. valid (size * size, 0 =
 * no data there, e.g. hz_terrain.valid) may be NULL; triangles touching a
 * sample without data are not drawn. Frames then pass
 * hz_scene_params.patches. */
hz_result hz_renderer_set_cdlod(hz_renderer *r, hz_lod *lod, const uint8_t *valid, hz_err *err);

/* Streamed terrains (horizon/stream.h): a tile cache of `slots` layers of
 * texels x texels RGBA16UI, filled by hz_renderer_stream_upload with the
 * texels hz_stream_next_upload hands out; frames then draw the patches of
 * hz_stream_select (hz_scene_params.patches). Replaces any heightmap's tiles. */
typedef struct hz_pyr_info hz_pyr_info;
hz_result hz_renderer_set_stream(hz_renderer *r, const hz_pyr_info *info, uint32_t slots, uint32_t texels, hz_err *err);
hz_result hz_renderer_stream_upload(hz_renderer *r, uint32_t slot, const uint16_t *texels, hz_err *err);

#define HZ_MAX_HISTORY 8u /* motion blur history slots */

/* The plain sky is shaded per vertex of a grid of HZ_SKY_COLS x HZ_SKY_ROWS
 * screen cells spanning the sky's side of the horizon. */
#define HZ_SKY_COLS 48
#define HZ_SKY_ROWS 27

typedef struct hz_scene_params {
    vec3 sun_dir;       /* unit vector toward the sun; all 0 -> default (afternoon sun) */
    vec3 sky_color;     /* horizon colour the fog fades to; all 0 -> pale blue */
    float fog_density;  /* per metre, f = exp(-density * dist); 0 -> 3/zfar, < 0 -> no fog */
    float ambient;      /* Ie, 0 -> 0.3 */
    bool wireframe;     /* draw lines on top of shaded terrain */
    float morph_scale;  /* cdlod geomorphing (hz_lod_stats.morph_scale / morph_start of the
                           frame's selection); 0 = no morphing. Patches only (hz_renderer_set_cdlod) */
    float morph_start;
    float morph_near;          /* hz_lod_stats.morph_near / morph_near_distance: the near */
    float morph_near_distance; /* bound's ranges (hz_lod_morph_range); either 0 = none */
    hz_draw_hook_fn draw_objects; /* optional: called in every scene pass after the terrain */
    void *draw_objects_user;
    bool objects_first; /* draw_objects draws opaque occluders (buildings): call it before the
                           terrain and the sky instead, so that what it hides costs no shading */
    /* Effects (fx.h). 0: none, the plain renderer (gradient sky, Lambert,
     * exponential fog per fog_density). */
    uint32_t effects;
    const hz_fx_settings *fx;  /* NULL -> defaults */
    double time;        /* seconds: clouds, waves and weather are functions of it,
                           so a given time always gives the same frame */
    uint32_t history;   /* motion blur slot < HZ_MAX_HISTORY: frames drawn with
                           different slots never blend into each other (a reference view) */
    bool reset_history; /* motion blur starts afresh (after a camera cut) */
    /* Terrain for the water reflection pass. The reflection is rendered with
     * the camera mirrored at the water plane (hz_camera_mirror_y), which sees
     * terrain the main camera's culled selection lacks (hill tops above the
     * top of the screen). Give an LOD selection made for the mirrored camera
     * (any C; coarser is cheaper), or NULL to reuse the main indices (then
     * what the main frustum culled is missing from reflections). */
    const uint32_t *reflection_indices;
    uint32_t reflection_count;
    /* cdlod: the main view's terrain as patches (hz_lod_select_patches;
     * needs hz_renderer_set_cdlod) instead of an index list (then count
     * must be 0). Reflections still draw reflection_indices. */
    const hz_patch *patches;
    uint32_t patch_count;
    /* Optional, with patches: horizon culling still running (hz_lod_horizon_hide
     * on patch_late_job, from hz_renderer_patch_lead(patch_count) on). The
     * renderer draws the nearest patches first, then waits for the job and
     * leaves out the later patches whose patch_late_hidden[k] is set, and the
     * blocks patch_late_blocks[k] marks (hz_patch.hidden's bits; may be NULL):
     * the cull runs while the first patches are drawn. The caller waits for
     * the job too after the draw (it may have failed before waiting). */
    hz_job *patch_late_job;
    const uint8_t *patch_late_hidden;
    const uint16_t *patch_late_blocks;
    /* Without terrain effects, a colour map or imagery, an in-memory terrain
     * reads its colour lit from a map baked per sample by the same shading
     * (one texture fetch a pixel instead of the normal map, the colour and
     * Lambert), baked again when the sun, ambient or climate change and then
     * hold still for a frame. true: shade every pixel instead. */
    bool no_lit_map;
    /* With the lit map and cdlod patches: read it per vertex and interpolate
     * the colour over the triangles (Gouraud, as fixed-function lighting
     * does) instead of once per pixel. Cheaper per pixel (on llvmpipe about a
     * tenth of the frame), with less detail between the vertices. */
    bool lit_per_vertex;
    /* Otherwise patches of the finest level (shift 0: a vertex on every
     * sample of the map) read it per vertex where the map is smooth over
     * them, the rest per pixel. Interpolated over the triangles instead of
     * bilinearly, the colour then differs by at most 2 of 255 inside the
     * cells where the map is magnified (the renderer checks each patch's
     * block of the map when it bakes it; far away the mip level estimated
     * per vertex may differ a little from the pixel's), at a fraction of the
     * cost. true: every patch per pixel. */
    bool lit_pixel;
    /* Optional: a CPU occlusion buffer built for this frame's camera
     * (horizon/occlusion.h, e.g. from the big near occluders of a city).
     * The plain sky skips the cells of its grid that the buffer's occluders
     * certainly cover, which the frame then covers too: at street level
     * most of the sky is behind walls. NULL: the whole grid is drawn. */
    const struct hz_occlusion *sky_occluders;
} hz_scene_params;

typedef struct hz_draw_stats {
    double upload_ms;   /* index / patch upload */
    size_t upload_bytes; /* bytes uploaded for the terrain this frame (indices or patch instances) */
    double draw_ms;     /* every pass and effect of the frame, bracketed by glFinish */
    float sun_visible;  /* HZ_FX_FLARE: fraction of the sun disc not covered (depth
                           and clouds), -1 when the sun is off screen or flare is off */
    uint32_t billboards;      /* vegetation billboards drawn (main pass) */
    uint32_t particles;       /* weather particles drawn */
    uint32_t reflections;     /* water reflection passes rendered */
    uint32_t far_patches;     /* cdlod patches entirely beyond the ground detail's fade, drawn
                                 without its texture fetches (HZ_FX_DETAIL) */
    bool lit_map;             /* the terrain read its lit map (hz_scene_params.no_lit_map) */
    bool lit_per_vertex;      /* ... per vertex of its patches (hz_scene_params.lit_per_vertex) */
    uint32_t lit_vertex_patches; /* patches that read it per vertex (all with lit_per_vertex; else the
                                    full-resolution ones over smooth map, unless
                                    hz_scene_params.lit_pixel) */
    double lit_bake_ms;       /* this frame baked the lit map first: its time (in upload_ms) */
    uint32_t sky_cells;       /* cells of the plain sky's grid drawn in the main pass (of
                                 HZ_SKY_COLS x HZ_SKY_ROWS; fewer with sky_occluders) */
    uint32_t late_hidden;     /* patches left out after waiting for patch_late_job */
    double late_wait_ms;      /* how long the draw waited for it */
} hz_draw_stats;

/* How many of count patches the renderer draws before it waits for
 * hz_scene_params.patch_late_job: its two nearest chunks, 15 % of them
 * (all of them when they are too few to draw in chunks). On llvmpipe a
 * cull of 1-2 ms started with the frame is done by then: the rasterisers
 * idle while the first chunk is binned, and the second makes up for the
 * cores the cull shares with them once they start. */
uint32_t hz_renderer_patch_lead(uint32_t count);

/* Draws sky then terrain triangles (count indices, a multiple of 3, into the
 * row-major sample grid: index = j * size + i), then the effects in
 * params->effects. params may be NULL (defaults). stats may be NULL. */
hz_result hz_renderer_draw(hz_renderer *r, const hz_camera *cam, const hz_scene_params *params,
                           const uint32_t *indices, uint32_t count, hz_draw_stats *stats,
                           hz_err *err);

/* Reads the last frame as RGB8, top row first, width*height*3 bytes. */
hz_result hz_renderer_read_rgb(hz_renderer *r, uint8_t *rgb, hz_err *err);

/* Reads the last frame's sky mask, top row first, width*height bytes: 1 where
 * nothing that writes depth was drawn (sky), 0 elsewhere: terrain, objects,
 * and with effects tree billboards and water planes (not clouds, particles
 * or the flare). Internal FBO only (fails with to_default_framebuffer). */
hz_result hz_renderer_read_sky_mask(hz_renderer *r, uint8_t *mask, hz_err *err);

/* Reads the last frame's depth buffer, top row first, width*height floats:
 * window depth, reverse-Z (near 1, far and sky 0). With glClipControl (GL
 * 4.5) it is NDC z of hz_camera_proj_reverse_z, which unprojects it to the
 * world point drawn (lowered by the Earth curvature, when the camera has one);
 * on the GL 3.3 fallback it is (NDC z + 1) / 2. Internal FBO only. */
hz_result hz_renderer_read_depth(hz_renderer *r, float *depth, hz_err *err);


/* ---- effect resources (used with the matching HZ_FX_* bit) -------------- */

/* HZ_FX_SHADOWS: the light map (hz_lightmap_build: size * size bytes, I * 255,
 * row-major like the heightmap), computed for sun_dir. size must equal the
 * heightmap's. While a frame's sun differs from sun_dir by more than 0.25
 * degree the renderer ignores it (per-pixel Lambert, no shadows): recompute
 * it when the sun moves. lm NULL removes it. Maps larger than the GPU's
 * texture limit are uploaded at half resolution. */
hz_result hz_renderer_set_lightmap(hz_renderer *r, const uint8_t *lm, uint32_t size, const float sun_dir[3],
                                   hz_err *err);

/* HZ_FX_SHADOWS for objects: the light map's sun heights
 * (hz_lightmap_desc.sun_heights) over the samples rect = {i0, j0, w, h} of
 * the heightmap, computed for sun_dir, w * h floats. Handed to the objects
 * hook in hz_pass_info while a frame's sun is within 0.25 degree of sun_dir
 * and the frame has HZ_FX_SHADOWS. heights NULL removes them. Errors:
 * HZ_ERR_VALUE for a rectangle outside the heightmap, over the GPU's texture
 * size, a non-finite height or a bad sun; HZ_ERR_GL. */
hz_result hz_renderer_set_sun_heights(hz_renderer *r, const float *heights, const uint32_t rect[4],
                                      const float sun_dir[3], hz_err *err);

/* HZ_FX_BILLBOARDS: the static vegetation (copied, bucketed in cells, culled
 * per frame to fx->billboard_distance). n = 0 removes it. */
hz_result hz_renderer_set_billboards(hz_renderer *r, const hz_billboard *b, size_t n, hz_err *err);

/* Billboard texture slot (< HZ_MAX_BB_TEXTURES), RGBA8 w x h, top row first;
 * mipmapped. Slots 0..3 start with the procedural HZ_SPRITE_* sprites (0
 * conifer, 1 broadleaf, 2 rain, 3 snow). */
#define HZ_MAX_BB_TEXTURES 16u
hz_result hz_renderer_set_billboard_texture(hz_renderer *r, uint32_t slot, const uint8_t *rgba, uint32_t w,
                                            uint32_t h, hz_err *err);

/* HZ_FX_DETAIL: replaces a ground type's detail texture (RGBA8, square power of
 * two, tileable, RGB around 128 as hz_texgen_detail makes; A = height-like
 * value for blending). The procedural ones are the default. */
hz_result hz_renderer_set_detail_texture(hz_renderer *r, hz_ground ground, const uint8_t *rgba, uint32_t size,
                                         hz_err *err);

/* A colour map for the whole terrain (RGB8, w x h, top row = north edge z = 0,
 * covering the heightmap) instead of the height/slope classes; NULL removes it. */
hz_result hz_renderer_set_colormap(hz_renderer *r, const uint8_t *rgb, uint32_t w, uint32_t h, hz_err *err);

/* Drapes imagery (hz_imagery_load) over the terrain by its georeference:
 * mip-mapped tiles near the camera, the overview far away; where the image
 * has no data the ground keeps its own colours. Copied to the GPU: im may be
 * freed after. NULL removes it. Errors when the GPU cannot hold it. */
hz_result hz_renderer_set_imagery(hz_renderer *r, const hz_imagery *im, hz_err *err);

/* HZ_FX_BILLBOARDS: forest cover (R8 side x side over the map, 255 = forest,
 * hz_forest_cover_map) darkens the ground under the trees so forests read at
 * any distance. NULL removes it. */
hz_result hz_renderer_set_forest_cover(hz_renderer *r, const uint8_t *cover, uint32_t side, hz_err *err);

/* The ground's climate (horizon/climate.h): snow, alpine and forest zones by
 * absolute height (metres above sea level, the heightmap's metres before
 * zscale), dry ground by aridity. NULL or never called: temperate at 45
 * degrees (snow above ~3000 m). */
void hz_renderer_set_climate(hz_renderer *r, const hz_climate *c);

/* HZ_FX_WATER: water planes, drawn grouped by material. One reflection pass is
 * rendered per distinct height among the visible planes (at most 4; further
 * heights reuse the nearest one). Copied. count 0 removes them. */
typedef struct hz_water_material {
    vec3 deep;        /* colour of deep water; all 0 -> (0.04, 0.12, 0.16) */
    float clarity;    /* metres: light through water falls by e every this much; 0 -> 2.5 */
    float waves;      /* normal perturbation strength; 0 -> 1 */
    float reflectivity; /* scales the Fresnel reflection; 0 -> 1 */
} hz_water_material;

typedef struct hz_water_plane {
    float height;     /* world metres */
    float rect[4];    /* x0, z0, x1, z1 world metres; all 0 -> the map and the view distance
                         around it (a sea to the horizon) */
    uint32_t material; /* index into the materials */
    bool sea;         /* a DEM's sea: the ground below the plane is the DEM's flat fill, not a sea
                         floor (drawn deep), and beyond the data the sea follows the coast of
                         hz_renderer_set_coast. A single sea plane shows wherever the colour
                         target's alpha is 0 after the opaque passes: the terrain writes 1 where
                         it stands above the sea, the sky 0, so draw_objects hooks must write
                         alpha 1 (the target needs alpha bits; without, the depth test decides) */
} hz_water_plane;

hz_result hz_renderer_set_water(hz_renderer *r, const hz_water_plane *planes, uint32_t count,
                                const hz_water_material *materials, uint32_t material_count, hz_err *err);

/* Where the planes with .sea go on beyond the heightmap's data (hz_coast_make
 * at their level): past each edge of c's rectangle, water only off the edge's
 * sea samples, so a coast runs straight out and land beyond the data is not
 * flooded. NULL (and after hz_renderer_set_heightmap): sea everywhere beyond
 * the map. Copied. */
hz_result hz_renderer_set_coast(hz_renderer *r, const hz_coast *c, hz_err *err);

/* Writes RGB8 (top row first) as PNG. */
hz_result hz_image_write_png(const char *path, const uint8_t *rgb, uint32_t width,
                             uint32_t height, hz_err *err);

#ifdef __cplusplus
}
#endif
#endif
