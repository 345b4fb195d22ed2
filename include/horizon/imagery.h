/* horizon imagery: an orthophoto (any raster GDAL reads: GeoTIFF/COG, JPEG
 * or PNG with a world file, VRT, ...) resampled by its georeference onto a
 * terrain's grid, ready to drape. No GL.
 *
 * The image is warped (GDAL, through PROJ) into the terrain's CRS over the
 * terrain's whole footprint: the pixel-corner extent of its sample grid, so
 * world x in [-s/2, (n - 1/2) s] and likewise z, s the spacing and n the
 * samples per side. The result is cut into square tiles with a border of
 * their neighbours' texels (so bilinear filtering and the first mip levels
 * are seamless across tiles) plus an overview of the whole footprint at a
 * quarter of the resolution for far views; a small image is the overview
 * alone. Texels outside the image, or transparent in it, have alpha 0. */
#ifndef HORIZON_IMAGERY_H
#define HORIZON_IMAGERY_H

#include "horizon/core.h"
#include "horizon/georef.h"

#ifdef __cplusplus
extern "C" {
#endif

#define HZ_IMAGERY_TILE 1024u     /* texels per tile side, border excluded */
#define HZ_IMAGERY_BORDER 4u      /* texels of the neighbours around each tile */
#define HZ_IMAGERY_MAX_SIDE 32768u /* the largest max_side accepted */
#define HZ_IMAGERY_MAX_BANDS 16   /* an image with more bands is refused (every band is warped) */
#define HZ_IMAGERY_MAX_READ 4e9   /* image pixels the drape may read (without overviews, all of them) */

typedef struct hz_imagery_desc {
    const char *path;          /* the image (a file GDAL opens) */
    const hz_georef *target;   /* the terrain's georeference: CRS and sample grid */
    uint32_t samples;          /* samples per side of the terrain grid (the grid is square) */
    double spacing;            /* metres between the terrain's samples (world units) */
    uint32_t max_side;         /* texels per side over the whole footprint at most; 0 -> 8192 */
    uint64_t max_bytes;        /* refuse before reading if the textures would need more; 0 -> no limit */
    hz_progress_fn progress;   /* optional */
    void *progress_user;
} hz_imagery_desc;

typedef struct hz_imagery {
    uint32_t side;             /* texels per side over the footprint */
    uint32_t tiles;            /* tiles per side (0: the overview holds everything) */
    uint32_t tile, border;     /* HZ_IMAGERY_TILE, HZ_IMAGERY_BORDER when tiled */
    uint8_t *tile_rgba;        /* tiles * tiles layers of (tile + 2 border)^2 RGBA8, layer ty * tiles + tx,
                                  rows north to south (growing world z); NULL when not tiled */
    uint32_t overview_side;    /* side of the overview */
    uint8_t *overview_rgba;    /* overview_side^2 RGBA8, the whole footprint */
    double origin_x, origin_z; /* world metres of the footprint's north-west corner (-s/2, -s/2) */
    double extent;             /* world metres per side of the footprint (n s) */
    double native_m;           /* the image's own pixel size on the ground, metres */
    double coverage;           /* fraction of the footprint the image covers (alpha > 0) */
    char note[256];            /* what was assumed (a missing CRS), empty if nothing */
} hz_imagery;

/* Reads and resamples d->path. Errors (with err): a missing or unreadable
 * file, an image without a georeference, a terrain without one, a sample
 * type other than 8-bit, an image that does not overlap the terrain, more
 * memory than d->max_bytes. An image without a CRS (a world file alone) is
 * taken to be in the terrain's CRS, said in out->note. */
hz_result hz_imagery_load(const hz_imagery_desc *d, hz_imagery *out, hz_err *err);
void hz_imagery_free(hz_imagery *im);

/* Bytes the textures of an image of this side take (tiles with their first
 * mip levels and borders, plus the overview with all its levels). */
uint64_t hz_imagery_bytes(uint32_t side);

/* The texel (fractional, over the whole footprint at `side` texels) under
 * world (x, z); the inverse gives a texel centre's world position. */
void hz_imagery_world_to_texel(const hz_imagery *im, double x, double z, double *tx, double *ty);
void hz_imagery_texel_to_world(const hz_imagery *im, double tx, double ty, double *x, double *z);

#ifdef __cplusplus
}
#endif
#endif
