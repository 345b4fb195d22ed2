/* horizon effects, CPU side (SPEC R1-R9): effect names and settings, and the
 * parts of the effects that are plain C — billboard lists (cull, sort back to
 * front, batch per texture), tree scatter, rain/snow particles, procedural
 * textures, the automatic water level. No GL: the renderer (render.h) draws
 * what these build. */
#ifndef HORIZON_FX_H
#define HORIZON_FX_H

#include "horizon/camera.h"
#include "horizon/heightmap.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- effect set ------------------------------------------------------------ */

typedef enum hz_fx_bit {
    HZ_FX_SKY = 1u << 0,        /* R1: sky dome, sun-dependent gradient, animated Perlin clouds, sun disc */
    HZ_FX_FLARE = 1u << 1,      /* R2: lens flare along sun -> screen centre, hidden when the sun is covered */
    HZ_FX_SHADOWS = 1u << 2,    /* R5: the light map (hz_renderer_set_lightmap) replaces per-pixel Lambert */
    HZ_FX_DETAIL = 1u << 3,     /* R4: detail textures per ground type, splatted */
    HZ_FX_BILLBOARDS = 1u << 4, /* R3: billboard vegetation (hz_renderer_set_billboards) */
    HZ_FX_FOG = 1u << 5,        /* R6: height fog, far fade, fog on sky/water/billboards alike */
    HZ_FX_WATER = 1u << 6,      /* R9: water planes with reflection (hz_renderer_set_water) */
    HZ_FX_WEATHER = 1u << 7,    /* rain or snow particles with wind */
    HZ_FX_MOTIONBLUR = 1u << 8, /* R7: frame feedback P = (1 - f) P_now + f P_prev */
    HZ_FX_BLOOM = 1u << 9       /* R7: bright parts glow */
} hz_fx_bit;
#define HZ_FX_COUNT 10u
#define HZ_FX_ALL 0x3ffu
/* What the horizon commands turn on when --effects is not given: everything
 * but weather (a choice, not a default) and motion blur (ghosting at the
 * frame rates of a software renderer). */
#define HZ_FX_DEFAULT (HZ_FX_ALL & ~(HZ_FX_WEATHER | HZ_FX_MOTIONBLUR))

/* Name of effect number k (0 .. HZ_FX_COUNT - 1: "sky", "flare", ...), NULL past the end. */
const char *hz_fx_name(uint32_t k);
/* Parses a comma-separated list: effect names add, "-name" removes, "all",
 * "none" and "default" set the whole set; applied left to right ("all,-weather").
 * HZ_ERR_VALUE naming the bad token and the valid names. */
hz_result hz_fx_parse(const char *list, uint32_t *bits, hz_err *err);
/* Writes the set as "sky,flare,..." or "none"; returns the length it needed. */
size_t hz_fx_format(uint32_t bits, char *buf, size_t cap);

typedef enum hz_weather_kind {
    HZ_WEATHER_RAIN = 0,
    HZ_WEATHER_SNOW = 1
} hz_weather_kind;

/* Effect settings; zero fields mean the default in the comment. */
typedef struct hz_fx_settings {
    float cloud_cover;     /* sky fraction covered, 0..1; 0 -> 0.45; < 0 -> clear */
    float cloud_altitude;  /* metres above the lowest ground; 0 -> 2500 */
    vec2 wind;             /* m/s along world x and z: clouds, waves, rain and snow; all 0 -> (6, -3) */
    float flare;           /* lens flare strength; 0 -> 1 */
    float height_fog;      /* extra fog density per metre at height_fog_base; 0 -> 3 x the
                              exponential density; < 0 -> none */
    float height_fog_base; /* metres above the lowest ground where the height fog is densest (0 = there) */
    float height_fog_falloff; /* metres: the height fog thins by e every this much higher; 0 -> 200 */
    hz_weather_kind weather;
    float weather_intensity; /* 0 -> 1 (rain: ~6000 streaks around the eye, snow: ~5000 flakes) */
    float blur;            /* motion blur feedback f in [0, 0.98]; 0 -> 0.5 */
    float exposure;        /* out = (colour x exposure)^(1 / gamma); 0 -> 1 */
    float gamma;           /* 0 -> 1 */
    float bloom_threshold; /* brightness where bloom starts; 0 -> 0.8 */
    float bloom_strength;  /* 0 -> 0.35 */
    float detail_scale;    /* metres per repeat of the finest detail texture; 0 -> 3 */
    float billboard_distance; /* metres: no billboard vegetation beyond (the forest cover
                                 shows the forests farther out); 0 -> 4000 */
} hz_fx_settings;

/* Turns zero fields into the defaults above (fog density needed for height_fog). */
hz_fx_settings hz_fx_settings_defaults(const hz_fx_settings *s, float fog_density);

/* ---- billboards (R3) ------------------------------------------------------- */

enum {
    HZ_BB_FACING = 1u << 0, /* fully camera-facing (particles); else turns about its axis (trees) */
    HZ_BB_BLEND = 1u << 1   /* alpha blended, sorted back to front, no depth write; else alpha test */
};

/* One billboard. Mirrored by the renderer's instance layout (40 bytes). */
typedef struct hz_billboard {
    float pos[3];     /* world metres: bottom centre (axial) or centre (facing) */
    float width;      /* metres */
    float axis[3];    /* axial: bottom -> top, metres (trees (0, h, 0); rain: along the fall);
                         facing: ignored */
    float height;     /* facing: metres; axial: ignored (|axis|) */
    uint32_t rgba;    /* tint, multiplied into the texture; R in the low byte */
    uint16_t texture; /* texture slot: one batch (draw call) per slot */
    uint16_t flags;   /* HZ_BB_* */
} hz_billboard;

typedef struct hz_bb_batch {
    uint16_t texture, flags;
    uint32_t first, count; /* range in the billboard array */
} hz_bb_batch;

/* Frustum and distance culling: copies the billboards whose bounding sphere
 * is inside cam's frustum and within max_dist metres of the eye into out
 * (cap entries). Returns how many passed, which may exceed cap (then only cap
 * were written). */
size_t hz_billboards_cull(const hz_billboard *in, size_t n, const hz_camera *cam, float max_dist,
                          hz_billboard *out, size_t cap);

/* True when no object stands on a sample within radius (at least one
 * sample spacing) of the ground point (x, z): tops as below. */
bool hz_ground_clear(const float *tops, uint32_t size, float spacing, float x, float z, float radius);

/* Keeps, in order, the axial (tree) billboards that stand clear of the
 * objects: no sample within half the billboard's width (at least one
 * sample spacing) of its foot has an object on it. tops: size * size
 * (index = j * size + i; sample (i, j) at (i, j) * spacing metres), the top
 * of an object standing on the sample or -INFINITY / NAN where none (as
 * hz_lightmap_desc.casters). Returns how many are kept (at the front of b). */
size_t hz_billboards_clear_of(hz_billboard *b, size_t n, const float *tops, uint32_t size, float spacing);

/* Scratch bytes hz_billboards_sort and hz_billboards_batch need for n. */
size_t hz_billboards_scratch_bytes(size_t n);

/* Sorts back to front: decreasing distance from eye to pos (stable; radix
 * sort). scratch: hz_billboards_scratch_bytes(n) bytes, or NULL to allocate
 * (false only when that fails). */
bool hz_billboards_sort(hz_billboard *b, size_t n, const vec3 eye, void *scratch);

/* Groups b in place, stably, into batches: first the alpha-tested ones, then
 * the blended ones, each by increasing texture slot. The order inside a batch
 * is kept (sort first for blending). Writes up to cap batches and returns how
 * many there are. scratch as above. */
size_t hz_billboards_batch(hz_billboard *b, size_t n, hz_bb_batch *batches, size_t cap, void *scratch);

/* A static set of billboards (vegetation) bucketed into square cells so a
 * frame only visits the cells near the eye and inside the frustum. */
typedef struct hz_bb_field hz_bb_field;
/* Copies b. cell: metres; 0 -> 256. NULL on out of memory. */
hz_bb_field *hz_bb_field_create(const hz_billboard *b, size_t n, float cell);
void hz_bb_field_destroy(hz_bb_field *f);
size_t hz_bb_field_count(const hz_bb_field *f);
/* hz_billboards_cull over the field, visiting only cells that can pass. */
size_t hz_bb_field_cull(const hz_bb_field *f, const hz_camera *cam, float max_dist, hz_billboard *out, size_t cap);

/* ---- vegetation scatter -------------------------------------------------------- */

typedef struct hz_scatter_desc {
    float density;      /* trees per hectare inside forests; 0 -> 12 */
    float cover;        /* fraction of suitable ground that is forest; 0 -> 0.45 */
    float min_size, max_size; /* tree height in metres; 0 -> 9 and 24 */
    float water_level;  /* metres: no trees below it + 2 m; give -INFINITY for none */
    float tree_line;    /* fraction of the height range above which no trees grow; 0 -> 0.6 */
    float max_slope;    /* 1 - n.y; 0 -> 0.25 */
    uint32_t max_count; /* 0 -> 500000: density is lowered to fit */
    uint64_t seed;
    uint16_t texture0;  /* first texture slot; trees use texture0 .. texture0 + kinds - 1 */
    uint16_t kinds;     /* 0 -> 2 (conifer, broadleaf) */
} hz_scatter_desc;

/* Forest density in [0, 1] at world (x, z): the smooth noise the scatter and
 * the ground colour share (1 = dense forest). */
float hz_forest_density(const hz_scatter_desc *d, float x, float z);

/* Scatters axial, alpha-tested tree billboards over the heightmap (world
 * metres: spacing, zscale as for the renderer), deterministic for the seed.
 * *out is malloc'd (free it). HZ_ERR_VALUE on bad parameters, HZ_ERR_MEMORY. */
hz_result hz_trees_scatter(const hz_heightmap *hm, float spacing, float zscale, const hz_scatter_desc *d,
                           hz_billboard **out, size_t *count, hz_err *err);

/* Forest cover as an R8 image of side `side` over the whole map (row-major,
 * row = z), 255 = dense forest, for the ground colour under the trees. Same
 * rules as the scatter (slope, tree line, water). out: side * side bytes. */
void hz_forest_cover_map(const hz_heightmap *hm, float spacing, float zscale, const hz_scatter_desc *d, uint32_t side,
                         uint8_t *out);

/* ---- weather particles ---------------------------------------------------------- */

typedef struct hz_weather_desc {
    hz_weather_kind kind;
    float intensity;    /* 0 -> 1 */
    vec2 wind;          /* m/s along x and z */
    float radius;       /* metres: particles fill a box of 2 radius around the eye; 0 -> 35 */
    uint64_t seed;
    uint16_t texture;   /* billboard texture slot */
} hz_weather_desc;

/* Particles hz_weather_build writes for this desc. */
size_t hz_weather_bound(const hz_weather_desc *d);

/* Rain streaks (axial, along the fall velocity) or snow flakes (facing), all
 * blended, in a box around eye at time t seconds. Each particle moves on a
 * straight line (wind + fall speed; snow also sways) and wraps inside the box,
 * so the field is a pure function of (desc, eye, t): the same time gives the
 * same frame. Writes min(bound, cap) and returns that count. */
size_t hz_weather_build(const hz_weather_desc *d, const vec3 eye, double t, hz_billboard *out, size_t cap);

/* ---- procedural textures (RGBA8, row-major, top row first) ------------------------ */

typedef enum hz_ground {
    HZ_GROUND_GRASS = 0,
    HZ_GROUND_ROCK = 1,
    HZ_GROUND_SNOW = 2,
    HZ_GROUND_SAND = 3,
    HZ_GROUND_COUNT = 4
} hz_ground;

/* A tileable detail texture (size a power of two >= 16): RGB around 128 so the
 * renderer modulates the ground colour by 2 x texel (mean ~1); A = a height-
 * like value for blending between ground types. */
void hz_texgen_detail(hz_ground kind, uint32_t size, uint64_t seed, uint8_t *rgba);

typedef enum hz_sprite {
    HZ_SPRITE_CONIFER = 0,
    HZ_SPRITE_BROADLEAF = 1,
    HZ_SPRITE_RAIN = 2,
    HZ_SPRITE_SNOW = 3,
    HZ_SPRITE_COUNT = 4
} hz_sprite;

/* Billboard sprite of w x h (trees: alpha cut-out, bottom centre = trunk foot;
 * rain: a soft vertical streak; snow: a soft flake). */
void hz_texgen_sprite(hz_sprite kind, uint32_t w, uint32_t h, uint64_t seed, uint8_t *rgba);

/* Share of an RGBA8 sprite's n texels that an alpha test at 0.5 keeps. */
double hz_sprite_coverage(const uint8_t *rgba, size_t n);
/* The next mip level of an alpha-tested sprite (w x h -> halved, at least
 * 1): a 2x2 box filter, colour weighted by alpha, whose alpha is then scaled
 * so that the alpha test keeps the share cover0 of its texels (level 0's
 * hz_sprite_coverage), after Castano, "Computing alpha mipmaps": plain
 * averaging lets a sparse crown (leaves, needles) thin out and vanish with
 * the distance. out holds the halved size x 4 bytes. */
void hz_sprite_mip_next(const uint8_t *in, uint32_t w, uint32_t h, double cover0, uint8_t *out, uint32_t *ow,
                        uint32_t *oh);

/* ---- water -------------------------------------------------------------------------- */

/* A water level for a heightmap that has none given (metres, zscale applied):
 * a flat area among the lowest tenth of the heights (at least 0.5 % of the
 * samples within 0.5 m of each other, e.g. a sea in a DEM, often nodata
 * filled flat along its coast) gives a sea 0.1 m above it (*is_sea true);
 * otherwise lakes fill the lowest `fraction` (0 -> 0.04) of the samples with
 * valid[k] != 0 (valid: size x size, row-major, or NULL for all: the filled
 * heights of nodata and padding are no ground to flood). is_sea may be NULL. */
float hz_water_level_auto(const hz_heightmap *hm, const uint8_t *valid, float zscale, float fraction, bool *is_sea);

/* Where a DEM's sea goes on beyond the DEM's data. A DEM ends where its data
 * ends, not where the sea does: beyond each edge of the data's rectangle the
 * coast is carried straight out, sea where the edge is sea and land where it
 * is land. edge holds one byte per sample along each edge (1 = sea): the
 * west edge's rows z0..z1, then the east's, then the north edge's columns
 * x0..x1 (z = z0), then the south's. An edge sample is sea when the first
 * sample with data inward from it, along its row or column, lies below the
 * level (or none has data: a missing tile of open sea). */
typedef struct hz_coast {
    uint32_t x0, z0, x1, z1; /* the data's rectangle in samples, inclusive */
    float spacing;           /* metres between samples: world x = spacing * sample */
    uint8_t *edge;           /* 2 (z1 - z0 + 1) + 2 (x1 - x0 + 1) bytes */
} hz_coast;

/* The coast of heightmap hm (valid: size x size bytes, 0 = no data, or NULL
 * for all; spacing: metres between its samples) at water level `level`
 * (metres, zscale applied) around rect (x0, z0, x1, z1 samples, inclusive;
 * NULL -> the whole map). Free with hz_coast_free. */
hz_result hz_coast_make(const hz_heightmap *hm, const uint8_t *valid, float spacing, float zscale, float level,
                        const uint32_t rect[4], hz_coast *out, hz_err *err);
void hz_coast_free(hz_coast *c);

#ifdef __cplusplus
}
#endif
#endif
