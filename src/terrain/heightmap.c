#include "horizon/heightmap.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static uint32_t log2_u32(uint32_t v)
{
    uint32_t n = 0;
    while ((1u << (n + 1)) <= v)
        n++;
    return n;
}

hz_result hz_heightmap_create(hz_heightmap *hm, const hz_grid *g, hz_layout layout, hz_err *err)
{
    memset(hm, 0, sizeof *hm);
    if (!g || !g->z || g->width != g->height || !hz_is_pow2_plus1(g->width))
        return hz_err_set(err, HZ_ERR_VALUE, "heightmap: grid must be square with side 2^n+1 (got %ux%u)",
                          g ? g->width : 0, g ? g->height : 0);
    uint32_t n = g->width;
    float lo, hi;
    uint64_t bad = hz_grid_range(g, &lo, &hi);
    if (bad)
        return hz_err_set(err, HZ_ERR_VALUE,
                          "heightmap: %llu samples are NaN or infinite (fill voids first)",
                          (unsigned long long)bad);
    hm->size = n;
    hm->levels = log2_u32(n - 1);
    hm->layout = layout == HZ_LAYOUT_DEFAULT ? HZ_LAYOUT_BLOCKED : layout;
    hm->offset = lo;
    hm->scale = (hi - lo) / 65535.0f;
    if (hm->scale < 1e-4f)
        hm->scale = 1e-4f;
    size_t count;
    if (hm->layout == HZ_LAYOUT_BLOCKED) {
        hm->blocks_per_row = (n + HZ_BLOCK - 1) / HZ_BLOCK;
        count = (size_t)hm->blocks_per_row * hm->blocks_per_row * HZ_BLOCK * HZ_BLOCK;
    } else {
        count = (size_t)n * n;
    }
    hm->size_bytes = count * sizeof(uint16_t);
    hm->h = calloc(count, sizeof(uint16_t));
    if (!hm->h)
        return hz_err_set(err, HZ_ERR_MEMORY, "heightmap: out of memory for %ux%u samples", n, n);
    float inv = 1.0f / hm->scale;
    for (uint32_t j = 0; j < n; j++) {
        const float *row = g->z + (size_t)j * n;
        for (uint32_t i = 0; i < n; i++) {
            float q = (row[i] - lo) * inv + 0.5f;
            if (q < 0.0f)
                q = 0.0f;
            if (q > 65535.0f)
                q = 65535.0f;
            hm->h[hz_heightmap_index(hm, i, j)] = (uint16_t)q;
        }
    }
    return HZ_OK;
}

void hz_heightmap_destroy(hz_heightmap *hm)
{
    if (!hm)
        return;
    free(hm->h);
    memset(hm, 0, sizeof *hm);
}

void hz_heightmap_copy_linear16(const hz_heightmap *hm, uint16_t *dst)
{
    uint32_t n = hm->size;
    if (hm->layout == HZ_LAYOUT_LINEAR) {
        memcpy(dst, hm->h, (size_t)n * n * sizeof *dst);
        return;
    }
    for (uint32_t j = 0; j < n; j++)
        for (uint32_t i = 0; i < n; i++)
            dst[(size_t)j * n + i] = hz_heightmap_get16(hm, i, j);
}

const char *hz_layout_name(hz_layout l)
{
    switch (l) {
    case HZ_LAYOUT_LINEAR: return "linear";
    case HZ_LAYOUT_BLOCKED:
    case HZ_LAYOUT_DEFAULT: return "blocked";
    }
    return "?";
}
