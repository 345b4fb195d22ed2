/* horizon heightmap (SPEC T1): a square (2^n+1)^2 grid of 16-bit heights with
 * scale/offset, stored linearly or in 32x32 blocks behind one accessor. No GL.
 *
 * World convention (used everywhere): y up; sample (i, j) (i = column, j = row)
 * lies at x = i*spacing, z = j*spacing, y = height*zscale (metres). */
#ifndef HORIZON_HEIGHTMAP_H
#define HORIZON_HEIGHTMAP_H

#include "horizon/grid.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum hz_layout {
    HZ_LAYOUT_DEFAULT = 0, /* -> blocked */
    HZ_LAYOUT_LINEAR,      /* row-major */
    HZ_LAYOUT_BLOCKED      /* 32x32-sample tiles, tiles row-major, samples row-major in a tile */
} hz_layout;

#define HZ_BLOCK_SHIFT 5u
#define HZ_BLOCK 32u

typedef struct hz_heightmap {
    uint32_t size;        /* samples per side, 2^n + 1 */
    uint32_t levels;      /* n: the root node has half-size 2^(n-1) */
    hz_layout layout;
    uint32_t blocks_per_row; /* blocked layout only */
    float scale, offset;  /* metres = offset + scale * h16 */
    uint16_t *h;          /* storage, layout dependent; size_bytes bytes */
    size_t size_bytes;
} hz_heightmap;

/* Quantises a square 2^n+1 grid (no NaN/inf) into a heightmap. The 16-bit
 * quantisation step is (max-min)/65535 (at least 1e-4 m); the max error is half
 * a step. Fails with a message on non-finite samples or bad sizes. */
hz_result hz_heightmap_create(hz_heightmap *hm, const hz_grid *g, hz_layout layout, hz_err *err);
void hz_heightmap_destroy(hz_heightmap *hm);

/* Storage index of sample (i, j) for the heightmap's layout. */
static inline size_t hz_heightmap_index(const hz_heightmap *hm, uint32_t i, uint32_t j)
{
    if (hm->layout == HZ_LAYOUT_LINEAR)
        return (size_t)j * hm->size + i;
    size_t block = (size_t)(j >> HZ_BLOCK_SHIFT) * hm->blocks_per_row + (i >> HZ_BLOCK_SHIFT);
    return (block << (2 * HZ_BLOCK_SHIFT)) + ((j & (HZ_BLOCK - 1)) << HZ_BLOCK_SHIFT) + (i & (HZ_BLOCK - 1));
}

/* Raw 16-bit value of sample (i, j); i, j < size. */
static inline uint16_t hz_heightmap_get16(const hz_heightmap *hm, uint32_t i, uint32_t j)
{
    return hm->h[hz_heightmap_index(hm, i, j)];
}

/* Height of sample (i, j) in metres (before zscale). */
static inline float hz_heightmap_get(const hz_heightmap *hm, uint32_t i, uint32_t j)
{
    return hm->offset + hm->scale * (float)hz_heightmap_get16(hm, i, j);
}

/* Copies the heights as row-major uint16 into dst (size*size values), e.g. for
 * a GPU upload. */
void hz_heightmap_copy_linear16(const hz_heightmap *hm, uint16_t *dst);

const char *hz_layout_name(hz_layout l);

#ifdef __cplusplus
}
#endif
#endif
