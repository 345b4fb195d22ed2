/* horizon terrain: the whole preparation pipeline in one call — read a DEM or
 * generate one, fill voids, fit to 2^n+1, quantise to a heightmap, precompute
 * the LOD data. What render, bench and view share. No GL. */
#ifndef HORIZON_TERRAIN_H
#define HORIZON_TERRAIN_H

#include "horizon/dem.h"
#include "horizon/georef.h"
#include "horizon/lod.h"
#include "horizon/path.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct hz_terrain_desc {
    /* Source: a DEM file, or (when dem_path is NULL) a generated terrain. */
    const char *dem_path;
    const char *const *dem_paths; /* optional: dem_path_count files or folders mosaicked as one
                                     terrain (used instead of dem_path when the count is > 0) */
    uint32_t dem_path_count;
    const char *crs;        /* metric CRS geographic DEMs are reprojected to ("EPSG:32632");
                               NULL -> the UTM zone of the centre (projected DEMs keep theirs) */
    hz_dem_format format;   /* 0 -> from the name */
    hz_dem_units units;     /* 0 -> from the name */
    uint32_t raw_width, raw_height; /* raw .r16/.r32 only; 0 -> square from the size */
    hz_gen_kind generate;   /* 0 -> perlin */
    uint32_t gen_size;      /* 0 -> 4097 */
    uint64_t seed;          /* generator seed */
    float amplitude;        /* generator relief, metres; 0 -> 1800 */
    hz_fit fit;             /* non-2^n+1 DEMs: 0 -> keep every sample (HZ_FIT_AUTO: padded, masked) */
    bool fill_voids;        /* false: nodata samples are holes (masked, not drawn); true: voids
                               enclosed by data are drawn with their filled heights (nodata
                               connected to the grid's edge — padding, the area outside a
                               reprojected footprint, ocean at a mosaic's edge — stays masked) */
    hz_layout layout;       /* 0 -> blocked */
    float spacing;          /* metres between samples; 0 -> from the DEM: a georeferenced one's own
                               (geographic ones: the finer of its two spacings at the centre),
                               else the name (SRTM 90/30 m, "_10m" ...), else 30 m for DEMs, 10 m
                               for generated. A georeferenced DEM is resampled to it. */
    float zscale;           /* 0 -> 1 */
    /* Normalised DEMs: when height_min < height_max, a stored value v (as stored:
       the units are not applied) becomes height_min + v / full_scale *
       (height_max - height_min) metres, full_scale being the top of the file's
       sample type (hz_dem_info.full_scale: 65535 for 16-bit PNGs). Both 0 -> the
       heights as the file and units say. Refused for generated terrains and
       Terrarium files, and with units other than auto or raw. */
    float height_min, height_max;
    float height_offset;    /* metres added to every height (after height_min/max, before
                               zscale); 0 -> none */
    float propagate_c;      /* see hz_lod_desc; 0 -> 25 */
    uint32_t patch_cells;   /* cdlod patch grid cells per side (hz_lod_desc); 0 -> 8 */
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
    /* Where the DEM is in the heightmap: data_w x data_h samples from (data_x, data_y)
     * (0, 0 with the default fit; the whole map for generated terrains). */
    uint32_t data_x, data_y, data_w, data_h;
    /* Validity over the heightmap, row-major (j * hm.size + i): 1 = a real sample,
     * 0 = nodata or padding (filled with plausible heights for the LOD bounds, not
     * to be drawn). NULL when every sample is valid. */
    uint8_t *valid;
    uint64_t valid_count;   /* samples with valid = 1 */
    uint64_t file_samples;  /* samples the file(s) hold, nodata included (0 for generated) */
    /* Where the heightmap lies on Earth: local metres (world x, z) <-> CRS <->
     * lon/lat, origin = the centre of heightmap sample (0, 0). NULL for
     * generated terrains and files without a georeference. */
    hz_georef *georef;
} hz_terrain;

/* NULL + err on failure (missing/corrupt file, NaN/inf, absurd parameters). */
hz_terrain *hz_terrain_create(const hz_terrain_desc *desc, hz_err *err);
void hz_terrain_destroy(hz_terrain *t);

/* Drops the triangles of an index list (3 vertex ids j * hm.size + i each) that
 * touch an invalid sample (t->valid); keeps the order of the rest. Returns the
 * new count (count when t->valid is NULL). */
size_t hz_terrain_filter_triangles(const hz_terrain *t, uint32_t *idx, size_t count);

/* Side of the map in metres ((size-1) * spacing). */
float hz_terrain_extent(const hz_terrain *t);
/* Height in metres (times zscale) of the sample nearest to world (x, z),
 * clamped to the map. */
float hz_terrain_height_at(const hz_terrain *t, float x, float z);
/* True when the sample nearest to world (x, z) is real data (not nodata, not
 * padding) and (x, z) lies on the map (half a sample of margin). */
bool hz_terrain_valid_at(const hz_terrain *t, float x, float z);
/* Height in metres (times zscale) of the full-resolution surface at world
 * (x, z): the two triangles of the cell, as the reference mesh draws them;
 * clamped to the map. */
float hz_terrain_surface_at(const hz_terrain *t, float x, float z);
/* The highest real sample (nodata and padding excluded; on maps over 1025^2
 * among every k-th sample, k = size / 1024): world x, z and the height in
 * metres (times zscale). */
void hz_terrain_focus(const hz_terrain *t, float *x, float *z, float *h);
/* World x, z of the middle of the DEM's samples (of the data, not of a padded
 * map). */
void hz_terrain_data_centre(const hz_terrain *t, float *x, float *z);
/* The default camera: frames the highest ground (hz_terrain_focus) from
 * 3x the relief away (within 8 - 35 % of the map's side), back toward the
 * map's middle, above the summit, looking at it. */
hz_camera hz_terrain_default_camera(const hz_terrain *t, uint32_t width, uint32_t height);

/* Built-in camera paths over this terrain, 60 s long:
 *  "flyover": low (clearance above the highest ground nearby) and fast
 *             (300 m/s, a jet), along a diagonal (NW to SE) over the
 *             highest ground (hz_terrain_focus), inside the DEM, looking
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
