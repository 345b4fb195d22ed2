/* horizon terrain: the whole preparation pipeline in one call — read a DEM or
 * generate one, fill voids, fit to 2^n+1, quantise to a heightmap, precompute
 * the LOD data. What render, bench and view share. No GL. */
#ifndef HORIZON_TERRAIN_H
#define HORIZON_TERRAIN_H

#include "horizon/dem.h"
#include "horizon/lod.h"
#include "horizon/path.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct hz_terrain_desc {
    /* Source: a DEM file, or (when dem_path is NULL) a generated terrain. */
    const char *dem_path;
    hz_dem_format format;   /* 0 -> from the name */
    hz_dem_units units;     /* 0 -> from the name */
    uint32_t raw_width, raw_height; /* raw .r16/.r32 only; 0 -> square from the size */
    hz_gen_kind generate;   /* 0 -> perlin */
    uint32_t gen_size;      /* 0 -> 4097 */
    uint64_t seed;          /* generator seed */
    float amplitude;        /* generator relief, metres; 0 -> 1800 */
    hz_fit fit;             /* non-2^n+1 DEMs: 0 -> nearest valid size */
    hz_layout layout;       /* 0 -> blocked */
    float spacing;          /* metres between samples; 0 -> from the DEM (SRTM 90/30 m ...),
                               else 30 m for DEMs, 10 m for generated */
    float zscale;           /* 0 -> 1 */
    float propagate_c;      /* see hz_lod_desc; 0 -> 25 */
    uint64_t max_memory;    /* bytes the terrain may take while prepared (grid, heightmap, LOD
                               data), checked before allocating; 0 -> hz_mem_budget_default() */
    uint64_t max_samples;   /* refuse a (fitted) heightmap of more samples than this before
                               any work, e.g. a GPU limit; 0 -> no limit */
    hz_progress_fn progress; /* optional */
    void *progress_user;
} hz_terrain_desc;

typedef struct hz_terrain {
    hz_heightmap hm;
    hz_lod *lod;
    float spacing, zscale;
    float min_h, max_h;     /* metres, before zscale */
    hz_dem_info info;       /* for DEMs */
    uint64_t voids_filled;
    char source[160];       /* "perlin 4097 seed 1" or the file name */
    char note[256];         /* what fitting did, empty if nothing */
    double load_ms, prep_ms;
} hz_terrain;

/* NULL + err on failure (missing/corrupt file, NaN/inf, absurd parameters). */
hz_terrain *hz_terrain_create(const hz_terrain_desc *desc, hz_err *err);
void hz_terrain_destroy(hz_terrain *t);

/* Side of the map in metres ((size-1) * spacing). */
float hz_terrain_extent(const hz_terrain *t);
/* Height in metres (times zscale) of the sample nearest to world (x, z),
 * clamped to the map. */
float hz_terrain_height_at(const hz_terrain *t, float x, float z);
/* Height in metres (times zscale) of the full-resolution surface at world
 * (x, z): the two triangles of the cell, as the reference mesh draws them;
 * clamped to the map. */
float hz_terrain_surface_at(const hz_terrain *t, float x, float z);
/* The default camera: above the centre, looking toward the horizon. */
hz_camera hz_terrain_default_camera(const hz_terrain *t, uint32_t width, uint32_t height);

/* Built-in camera paths over this terrain, 60 s long:
 *  "flyover": low (clearance above the highest ground nearby) and fast
 *             (300 m/s, a jet), along the middle of the diagonal, looking
 *             slightly down;
 *  "orbit":   high circle around the centre, looking at the centre;
 *  "ground":  2 m above the ground (walking height), 5 m/s from the centre
 *             along the most open heading, looking at the horizon.
 * Fails on an unknown name (listing the valid ones). */
hz_result hz_terrain_path(const hz_terrain *t, const char *name, hz_path *out, hz_err *err);

#ifdef __cplusplus
}
#endif
#endif
