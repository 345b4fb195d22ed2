/* horizon grid: a plain float elevation grid as read from a file or generated,
 * before it becomes a hz_heightmap. No GL. */
#ifndef HORIZON_GRID_H
#define HORIZON_GRID_H

#include "horizon/core.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Row-major elevations in metres. Row 0 is the north edge (first row of the
 * file), column 0 the west edge. Sample (i, j) = z[j * width + i], i = column.
 * NaN marks a void (no data). */
typedef struct hz_grid {
    uint32_t width, height;
    float *z;
} hz_grid;

/* Allocates a width x height grid filled with 0. Fails on 0 sizes, sizes over
 * 65537 per side, or out of memory. */
hz_result hz_grid_alloc(hz_grid *g, uint32_t width, uint32_t height, hz_err *err);
void hz_grid_free(hz_grid *g);

/* Min/max of all finite samples; returns the number of non-finite samples
 * (NaN or inf). If there is no finite sample, *min = *max = 0. */
uint64_t hz_grid_range(const hz_grid *g, float *min, float *max);

/* Replaces every NaN sample by a value interpolated from the nearest valid
 * samples (iterative neighbour averaging, so large voids fill smoothly).
 * *filled (may be NULL) receives the count. Fails if the grid has no valid
 * sample or contains +-inf. */
hz_result hz_grid_fill_voids(hz_grid *g, uint64_t *filled, hz_err *err);

/* How to make a grid square with side 2^n + 1. */
typedef enum hz_fit {
    HZ_FIT_AUTO = 0, /* hz_grid_fit (the terrain's default): keep every sample — the smallest
                        2^n+1 square >= max(width, height), the data at its north-west corner,
                        the padding masked (not drawn) and filled smoothly from the data's edges.
                        hz_grid_fit_pow2 (legacy): same as HZ_FIT_NEAREST */
    HZ_FIT_CROP,     /* largest 2^n+1 that fits in min(width, height); centred crop */
    HZ_FIT_PAD,      /* smallest 2^n+1 >= max(width, height); centred, edge values extended
                        and drawn */
    HZ_FIT_REFUSE,   /* fail unless already square 2^n+1 */
    HZ_FIT_NEAREST   /* nearest valid side: crop if that is closer, else pad (the old default) */
} hz_fit;

/* What hz_grid_fit did. */
typedef struct hz_grid_fit_info {
    uint8_t *valid;          /* side*side, row-major like the grid: 1 = a sample of the input,
                                0 = a void (nodata, NaN in the input) or masked padding;
                                NULL when every sample is valid. Free with free(). */
    uint64_t valid_count;    /* samples with valid = 1 (side*side when valid is NULL) */
    int64_t x0, y0;          /* where the input's sample (0, 0) is in the fitted grid
                                (negative when cropped) */
    uint32_t data_w, data_h; /* columns and rows of the input inside the fitted grid */
} hz_grid_fit_info;

/* Makes *g a square 2^n+1 grid with every sample finite: marks the input's
 * voids (NaN) and, for HZ_FIT_AUTO, the padding invalid in fi->valid, then
 * fills them all (hz_grid_fill_voids) so LOD bounds stay plausible. Other
 * modes fill the voids and call hz_grid_fit_pow2. note as there. */
hz_result hz_grid_fit(hz_grid *g, hz_fit fit, hz_grid_fit_info *fi, char *note, size_t note_cap, hz_err *err);

/* Makes *g square 2^n+1 (n >= 1, side >= 3) in place (reallocates). Writes a one-line
 * description of what was done to note (may be NULL; empty when nothing was
 * done). Crop keeps the centre; pad extends edge samples outward (so the padded
 * border is flat continuation of the edge). */
hz_result hz_grid_fit_pow2(hz_grid *g, hz_fit fit, char *note, size_t note_cap, hz_err *err);

/* The side hz_grid_fit would make a width x height grid with fit; 0 when
 * it would refuse. Lets callers check the memory before the work. */
uint32_t hz_grid_fit_side(uint32_t width, uint32_t height, hz_fit fit);

/* True if n = 2^k + 1 for some k >= 1. */
bool hz_is_pow2_plus1(uint32_t n);

#ifdef __cplusplus
}
#endif
#endif
