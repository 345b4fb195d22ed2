/* Where a DEM's sea goes on beyond the DEM's data (CPU). */
#include "horizon/fx.h"

#include <math.h>
#include <stdlib.h>

/* Walks from (i, j) by (di, dj) through the rectangle to the first sample
 * with data: sea when it lies below the level or there is none. */
static uint8_t edge_is_sea(const hz_heightmap *hm, const uint8_t *valid, float zscale, float level, int64_t i,
                           int64_t j, int di, int dj, const uint32_t r[4])
{
    const uint32_t n = hm->size;
    for (; i >= r[0] && i <= r[2] && j >= r[1] && j <= r[3]; i += di, j += dj) {
        if (valid && !valid[(size_t)j * n + (size_t)i])
            continue;
        return zscale * hz_heightmap_get(hm, (uint32_t)i, (uint32_t)j) < level;
    }
    return 1;
}

hz_result hz_coast_make(const hz_heightmap *hm, const uint8_t *valid, float spacing, float zscale, float level,
                        const uint32_t rect[4], hz_coast *out, hz_err *err)
{
    *out = (hz_coast){0};
    if (!hm || !hm->h || hm->size < 2)
        return hz_err_set(err, HZ_ERR_VALUE, "coast: no heightmap");
    if (!(spacing > 0.0f) || !isfinite(spacing) || !isfinite(level) || !isfinite(zscale))
        return hz_err_set(err, HZ_ERR_VALUE, "coast: spacing %g, level %g, zscale %g", (double)spacing, (double)level,
                          (double)zscale);
    const uint32_t n = hm->size;
    uint32_t r[4] = {0, 0, n - 1, n - 1};
    if (rect)
        r[0] = rect[0], r[1] = rect[1], r[2] = rect[2], r[3] = rect[3];
    if (r[0] > r[2] || r[1] > r[3] || r[2] >= n || r[3] >= n)
        return hz_err_set(err, HZ_ERR_VALUE, "coast: samples (%u, %u)-(%u, %u) are not a rectangle in a %ux%u map",
                          r[0], r[1], r[2], r[3], n, n);
    const uint32_t rows = r[3] - r[1] + 1, cols = r[2] - r[0] + 1;
    uint8_t *e = malloc(2 * (size_t)rows + 2 * (size_t)cols);
    if (!e)
        return hz_err_set(err, HZ_ERR_MEMORY, "coast: out of memory");
    for (uint32_t k = 0; k < rows; k++) {
        e[k] = edge_is_sea(hm, valid, zscale, level, r[0], r[1] + k, 1, 0, r);
        e[rows + k] = edge_is_sea(hm, valid, zscale, level, r[2], r[1] + k, -1, 0, r);
    }
    for (uint32_t k = 0; k < cols; k++) {
        e[2 * rows + k] = edge_is_sea(hm, valid, zscale, level, r[0] + k, r[1], 0, 1, r);
        e[2 * rows + cols + k] = edge_is_sea(hm, valid, zscale, level, r[0] + k, r[3], 0, -1, r);
    }
    out->x0 = r[0], out->z0 = r[1], out->x1 = r[2], out->z1 = r[3];
    out->spacing = spacing;
    out->edge = e;
    return HZ_OK;
}

void hz_coast_free(hz_coast *c)
{
    if (c) {
        free(c->edge);
        *c = (hz_coast){0};
    }
}
