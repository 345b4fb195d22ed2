/* horizon light map (SPEC R5): per-sample brightness with terrain shadows,
 * computed on the CPU, stored as one byte per sample and multiplied into the
 * ground colour by the renderer. No GL.
 *
 * Seed 000, ch. 9: with ambient Ie and r the angle between the surface normal
 * and the direction to the sun,
 *     I = cos(r) * (1 - Ie) + Ie   if cos(r) > 0 and nothing blocks the sun,
 *     I = Ie                       otherwise (facing away, or in shadow).
 * A sample is in shadow when the terrain between it and the sun rises above
 * the ray toward the sun. */
#ifndef HORIZON_LIGHTMAP_H
#define HORIZON_LIGHTMAP_H

#include "horizon/heightmap.h"

#include <cglm/cglm.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct hz_lightmap_desc {
    const hz_heightmap *hm; /* required */
    float spacing;          /* metres between samples; required, > 0 */
    float zscale;           /* height multiplier; 0 -> 1 */
    vec3 sun_dir;           /* toward the sun, world (y up); any length > 0; required */
    float ambient;          /* Ie in [0, 1); 0 -> 0.3 */
    uint32_t threads;       /* worker threads; 0 -> 2 (each sweep line is split in bands) */
    bool no_shadows;        /* Lambert + ambient only */
    const float *casters;   /* optional, size * size (index = j * size + i): the top (world metres)
                               of an object standing on sample (i, j), or -INFINITY / NAN: none.
                               Objects cast shadows on the terrain at the map's resolution (the
                               samples under an object, which it hides, are in its shade but for
                               its sunward edge). NULL: none */
    /* Optional output for shading objects: over the rectangle of samples
     * sun_rect = {i0, j0, w, h} (inside the map), w * h floats, row-major
     * (index = (j - j0) * w + (i - i0)): the sun height of each sample, the
     * height (world metres) below which a point straight above it is in
     * shade. That is the sweep's shadow surface from the sun's side: the
     * ground itself, or the highest sun ray passing over it from the
     * terrain and the casters on the sun's side, whichever is higher. The
     * sample's own caster is left out, so an object's sunward wall and roof
     * are not shaded by the object itself. Without shadows (no_shadows, or
     * the sun at the zenith) it is the ground. NULL: not written. */
    float *sun_heights;
    uint32_t sun_rect[4];
} hz_lightmap_desc;

typedef struct hz_lightmap_stats {
    double ms;             /* wall time of the build */
    uint64_t shadowed;     /* samples facing the sun but blocked by terrain */
    uint64_t facing_away;  /* samples with cos(r) <= 0 */
    uint32_t threads;      /* threads actually used */
} hz_lightmap_stats;

/* True when rect = {i0, j0, w, h} is non-empty and inside a size x size map
 * (what hz_lightmap_desc.sun_rect must be). */
bool hz_sample_rect_inside(const uint32_t rect[4], uint32_t size);

/* Bytes needed for a light map of this heightmap: size * size (one byte per
 * sample, I * 255 rounded, row-major: index = j * size + i like the grid). */
size_t hz_lightmap_bound(const hz_heightmap *hm);

/* Computes the light map into out (hz_lightmap_bound(desc->hm) bytes, caller
 * owned). The normal of sample (i, j) comes from central differences of its
 * neighbours (one-sided at the borders), like the terrain vertex shader.
 * A sun below the horizon (sun_dir.y <= 0) gives Ie everywhere; a sun at the
 * zenith casts no shadows. stats may be NULL.
 * Errors: HZ_ERR_VALUE for a missing heightmap, bad spacing/zscale/ambient,
 * a zero/NaN sun direction or a sun_rect (with sun_heights) that is empty or
 * leaves the map; HZ_ERR_MEMORY. */
hz_result hz_lightmap_build(const hz_lightmap_desc *desc, uint8_t *out, hz_lightmap_stats *stats, hz_err *err);

/* The unit sun direction for an azimuth (degrees clockwise from north = -z,
 * so 90 = east = +x) and an elevation (degrees above the horizon). */
void hz_sun_direction(float azimuth_deg, float elevation_deg, vec3 dest);

#ifdef __cplusplus
}
#endif
#endif
