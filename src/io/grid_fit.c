/* hz_grid_fit: a 2^n+1 square for the LOD that keeps every sample of the
 * input and says which samples are real (the validity mask). */
#include "horizon/grid.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static uint32_t pow2p1_at_least(uint32_t n)
{
    uint64_t s = 3;
    while (s < n)
        s = (s - 1) * 2 + 1;
    return (uint32_t)s;
}

/* 1 where g is not NaN; NULL (and *count = n) when nothing is NaN. */
static hz_result nan_mask(const hz_grid *g, uint8_t **mask, uint64_t *count, hz_err *err)
{
    size_t n = (size_t)g->width * g->height;
    size_t k = 0;
    while (k < n && !isnan(g->z[k]))
        k++;
    *mask = NULL;
    *count = n;
    if (k == n)
        return HZ_OK;
    uint8_t *m = malloc(n);
    if (!m)
        return hz_err_set(err, HZ_ERR_MEMORY, "out of memory for the validity mask (%zu bytes)", n);
    uint64_t c = 0;
    for (k = 0; k < n; k++) {
        m[k] = (uint8_t)!isnan(g->z[k]);
        c += m[k];
    }
    *mask = m;
    *count = c;
    return HZ_OK;
}

static hz_result fit_keep(hz_grid *g, hz_grid_fit_info *fi, char *note, size_t note_cap, hz_err *err)
{
    const uint32_t w = g->width, h = g->height;
    const uint32_t s = pow2p1_at_least(w > h ? w : h);
    if (s != w || s != h) {
        hz_grid out;
        hz_result r = hz_grid_alloc(&out, s, s, err);
        if (r != HZ_OK)
            return r;
        for (uint32_t j = 0; j < s; j++) {
            float *dst = out.z + (size_t)j * s;
            if (j < h) {
                memcpy(dst, g->z + (size_t)j * w, w * sizeof(float));
                for (uint32_t i = w; i < s; i++)
                    dst[i] = NAN;
            } else {
                for (uint32_t i = 0; i < s; i++)
                    dst[i] = NAN;
            }
        }
        hz_grid_free(g);
        *g = out;
        if (note && note_cap)
            snprintf(note, note_cap,
                     "%ux%u shown whole on a %ux%u grid (data at the north-west corner; the padding is not drawn)", w,
                     h, s, s);
    }
    hz_result r = nan_mask(g, &fi->valid, &fi->valid_count, err);
    if (r != HZ_OK)
        return r;
    r = hz_grid_fill_voids(g, NULL, err);
    if (r != HZ_OK) {
        free(fi->valid);
        fi->valid = NULL;
    }
    return r;
}

hz_result hz_grid_fit(hz_grid *g, hz_fit fit, hz_grid_fit_info *fi, char *note, size_t note_cap, hz_err *err)
{
    HZ_ASSERT(g && g->z && fi);
    memset(fi, 0, sizeof *fi);
    if (note && note_cap)
        note[0] = 0;
    const uint32_t w = g->width, h = g->height;
    fi->data_w = w;
    fi->data_h = h;
    if (fit == HZ_FIT_AUTO)
        return fit_keep(g, fi, note, note_cap, err);
    uint8_t *m0 = NULL;
    uint64_t c0 = 0;
    hz_result r = nan_mask(g, &m0, &c0, err);
    if (r != HZ_OK)
        return r;
    if (m0 && (r = hz_grid_fill_voids(g, NULL, err)) != HZ_OK) {
        free(m0);
        return r;
    }
    if ((r = hz_grid_fit_pow2(g, fit == HZ_FIT_NEAREST ? HZ_FIT_AUTO : fit, note, note_cap, err)) != HZ_OK) {
        free(m0);
        return r;
    }
    const uint32_t s = g->width;
    /* The same placement as hz_grid_fit_pow2: centred crop or centred pad. */
    int64_t x0 = s >= w ? (int64_t)(s - w) / 2 : -(int64_t)((w - s) / 2);
    int64_t y0 = s >= h ? (int64_t)(s - h) / 2 : -(int64_t)((h - s) / 2);
    if (s < w || s < h) { /* a crop is square: both sides come from min(w, h) */
        x0 = -(int64_t)((w - s) / 2);
        y0 = -(int64_t)((h - s) / 2);
    }
    fi->x0 = x0;
    fi->y0 = y0;
    fi->data_w = s < w ? s : w;
    fi->data_h = s < h ? s : h;
    fi->valid_count = (uint64_t)s * s;
    if (!m0)
        return HZ_OK;
    /* Voids stay invalid; the edge-extended padding of HZ_FIT_PAD is drawn. */
    uint8_t *m = malloc((size_t)s * s);
    if (!m) {
        free(m0);
        return hz_err_set(err, HZ_ERR_MEMORY, "out of memory for the validity mask");
    }
    uint64_t c = 0;
    for (uint32_t j = 0; j < s; j++)
        for (uint32_t i = 0; i < s; i++) {
            int64_t si = (int64_t)i - x0, sj = (int64_t)j - y0;
            uint8_t v = 1;
            if (si >= 0 && sj >= 0 && si < (int64_t)w && sj < (int64_t)h)
                v = m0[(size_t)sj * w + (size_t)si];
            m[(size_t)j * s + i] = v;
            c += v;
        }
    free(m0);
    fi->valid = m;
    fi->valid_count = c;
    return HZ_OK;
}
