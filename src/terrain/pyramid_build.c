/* The pyramid import: any raster (or a generated terrain) to a .hzp of
 * tiles, window by window, never the whole raster in memory.
 *
 * Two passes over the source, each a depth-first walk of the tile quadtree
 * that returns every tile's heights to its parent (level l is level l-1
 * subsampled: the same samples the in-memory cdlod draws at that spacing):
 * 1. LOD bounds: per node of every level the nested error bound (as
 *    lod_cdlod.c: the children's bound plus the largest distance of the
 *    vertices the split brings in to the coarser surface) and the height
 *    range; then the bounds are dilated across the whole map (CD_GROW per
 *    level). These arrays hold 6 bytes per P x P level-0 cells.
 * 2. Tiles: heights, no-data mask, their nodes' bounds, the bounds of the
 *    coarser nodes that bring in their samples (the per-sample morph ranges
 *    are derived from those at load), the morph targets of their corners;
 *    compressed and written in a fixed order, so an import is the same file
 *    byte for byte whatever the thread count.
 * Level-0 tiles of one level-1 tile are read and encoded in parallel. */
#include "lod_internal.h"

#include "horizon/pyramid.h"
#include "horizon/safety.h"

#include <pthread.h>
#include <stdio.h>
#include <unistd.h>

#define NEVER 65535u

typedef struct tile_res {
    uint16_t *h;    /* (c + 1)^2 */
    uint8_t *valid; /* (c + 1)^2, NULL when every sample has data */
} tile_res;

typedef struct build {
    const hz_pyr_import *d;
    hz_pyr_info info;
    hz_io_src *src;
    hz_gen_window *gen;
    pthread_mutex_t lock; /* the source, errors, figures */
    uint32_t W, H;        /* data samples */
    double scale, offset;
    uint16_t fill;        /* h16 of samples without data */
    uint16_t *nd[HZ_PYR_MAX_LEVELS], *mn[HZ_PYR_MAX_LEVELS], *mx[HZ_PYR_MAX_LEVELS];
    uint32_t side[HZ_PYR_MAX_LEVELS]; /* nodes per side at each shift */
    uint16_t *cg;         /* heights at every multiple of c0 (tile corners) */
    uint32_t cg_side, c0;
    int pass;
    hz_pyr_writer *w;
    uint64_t leaves_done, leaves_total;
    double max_err;
    uint64_t nodata;
    uint16_t hmin, hmax;
    hz_result res;
    hz_err *err;
    hz_err first;
    uint32_t threads;
} build;

static uint16_t quant(const build *b, float v, double *e)
{
    double q = floor((v - b->offset) / b->scale + 0.5);
    q = q < 0 ? 0 : (q > 65535 ? 65535 : q);
    double back = b->offset + b->scale * q;
    *e = fabs(back - v);
    return (uint16_t)q;
}

static void fail(build *b, hz_result r, const hz_err *e)
{
    pthread_mutex_lock(&b->lock);
    if (b->res == HZ_OK) {
        b->res = r;
        if (e)
            b->first = *e;
    }
    pthread_mutex_unlock(&b->lock);
}

static void progress(build *b)
{
    if (b->d->progress)
        b->d->progress(b->d->progress_user, b->pass == 1 ? "import: bounds" : "import: tiles", b->leaves_done,
                       b->leaves_total);
}

/* ---- level 0: read, quantise, mask ---- */

static void leaf(build *b, uint32_t tx, uint32_t tz, tile_res *out)
{
    const uint32_t c = b->c0, n = c + 1, X0 = tx * c, Z0 = tz * c;
    out->h = malloc((size_t)n * n * sizeof *out->h);
    out->valid = malloc((size_t)n * n);
    float *f = malloc((size_t)n * n * sizeof *f);
    if (!out->h || !out->valid || !f) {
        free(f);
        fail(b, HZ_ERR_MEMORY, &(hz_err){.code = HZ_ERR_MEMORY, .msg = "import: out of memory"});
        return;
    }
    for (size_t k = 0; k < (size_t)n * n; k++)
        f[k] = NAN;
    const uint32_t rw = X0 < b->W ? (b->W - X0 < n ? b->W - X0 : n) : 0;
    const uint32_t rh = Z0 < b->H ? (b->H - Z0 < n ? b->H - Z0 : n) : 0;
    if (rw > 0 && rh > 0) {
        float *win = malloc((size_t)rw * rh * sizeof *win);
        if (!win) {
            free(f);
            fail(b, HZ_ERR_MEMORY, &(hz_err){.code = HZ_ERR_MEMORY, .msg = "import: out of memory"});
            return;
        }
        if (b->gen) {
            hz_gen_window_read(b->gen, X0, Z0, rw, rh, win);
        } else {
            hz_err e = {0};
            pthread_mutex_lock(&b->lock);
            hz_result r = hz_io_src_read(b->src, X0, Z0, rw, rh, win, &e);
            pthread_mutex_unlock(&b->lock);
            if (r != HZ_OK) {
                free(win);
                free(f);
                fail(b, r, &e);
                return;
            }
        }
        for (uint32_t j = 0; j < rh; j++)
            memcpy(f + (size_t)j * n, win + (size_t)j * rw, rw * sizeof *f);
        free(win);
    }
    double emax = 0;
    uint64_t voids = 0;
    uint16_t lo = 65535, hi = 0;
    bool any_void = false;
    for (uint32_t j = 0; j < n; j++)
        for (uint32_t i = 0; i < n; i++) {
            const size_t k = (size_t)j * n + i;
            if (isnan(f[k]) || !isfinite(f[k])) {
                out->h[k] = b->fill;
                out->valid[k] = 0;
                any_void = true;
                /* count each level-0 sample once: skip the shared east/south border */
                if ((i < c || X0 + i == b->info.size - 1) && (j < c || Z0 + j == b->info.size - 1) &&
                    X0 + i < b->W && Z0 + j < b->H)
                    voids++;
                continue;
            }
            double e;
            out->h[k] = quant(b, f[k], &e);
            out->valid[k] = 1;
            emax = e > emax ? e : emax;
            lo = out->h[k] < lo ? out->h[k] : lo;
            hi = out->h[k] > hi ? out->h[k] : hi;
        }
    free(f);
    if (!any_void) {
        free(out->valid);
        out->valid = NULL;
    }
    if (b->pass == 1) {
        /* shift-0 nodes: exact (bound 0), their height range over every sample
         * drawn (filled ones too: the box must hold the surface it culls) */
        const uint32_t P = b->info.patch_cells, k = c / P, side = b->side[0];
        for (uint32_t bz = 0; bz < k; bz++)
            for (uint32_t bx = 0; bx < k; bx++) {
                uint16_t a = 65535, z = 0;
                for (uint32_t v = 0; v <= P; v++)
                    for (uint32_t u = 0; u <= P; u++) {
                        const size_t s = (size_t)(bz * P + v) * n + bx * P + u;
                        a = out->h[s] < a ? out->h[s] : a;
                        z = out->h[s] > z ? out->h[s] : z;
                    }
                if (a > z)
                    a = z = b->fill;
                const size_t q = (size_t)(tz * k + bz) * side + tx * k + bx;
                b->nd[0][q] = 0, b->mn[0][q] = a, b->mx[0][q] = z;
            }
        /* tile corners for the morph targets of every level's corners */
        for (uint32_t v = 0; v < 2; v++)
            for (uint32_t u = 0; u < 2; u++)
                b->cg[(size_t)(tz + v) * b->cg_side + tx + u] = out->h[(size_t)(v * c) * n + u * c];
        pthread_mutex_lock(&b->lock);
        b->max_err = emax > b->max_err ? emax : b->max_err;
        b->nodata += voids;
        if (lo <= hi) {
            b->hmin = lo < b->hmin ? lo : b->hmin;
            b->hmax = hi > b->hmax ? hi : b->hmax;
        }
        pthread_mutex_unlock(&b->lock);
    }
}

/* ---- pass 2: a tile's record ---- */

static uint16_t nd_at(const build *b, uint32_t s, uint32_t x, uint32_t z)
{
    return b->nd[s][(size_t)z * b->side[s] + x];
}

static uint32_t cg_h(const build *b, uint32_t X, uint32_t Z)
{
    return b->cg[(size_t)(Z / b->c0) * b->cg_side + X / b->c0];
}

static hz_result encode(build *b, uint32_t l, uint32_t tx, uint32_t tz, const tile_res *r, void **blob, size_t *bytes,
                        hz_err *err)
{
    const hz_pyr_info *in = &b->info;
    const uint32_t c = hz_pyr_level_cells(in, l), k = c / in->patch_cells, N = in->size;
    hz_pyr_tile t = {.level = l, .tx = tx, .tz = tz, .cells = c, .x0 = (tx * c) << l, .z0 = (tz * c) << l,
                     .h = r->h, .valid = r->valid, .nodes = k};
    t.qtab_count = hz_pyr_qtab_count(in, l, tx, tz);
    uint16_t *buf = malloc(((size_t)k * k * 3 + t.qtab_count + 1) * sizeof *buf);
    if (!buf)
        return hz_err_set(err, HZ_ERR_MEMORY, "import: out of memory");
    t.node_delta = buf, t.node_min = buf + (size_t)k * k, t.node_max = buf + 2 * (size_t)k * k;
    t.qtab = buf + 3 * (size_t)k * k;
    for (uint32_t bz = 0; bz < k; bz++)
        for (uint32_t bx = 0; bx < k; bx++) {
            const size_t q = (size_t)(tz * k + bz) * b->side[l] + tx * k + bx;
            t.node_delta[bz * k + bx] = b->nd[l][q];
            t.node_min[bz * k + bx] = b->mn[l][q];
            t.node_max[bz * k + bx] = b->mx[l][q];
        }
    uint16_t *qt = t.qtab;
    for (uint32_t s = l + 1; s < in->levels; s++) {
        uint32_t a, e, f, g;
        hz_pyr_qtab_range(in, l, tx, tz, s, &a, &e, &f, &g);
        for (uint32_t z = f; z <= g; z++)
            for (uint32_t x = a; x <= e; x++)
                *qt++ = nd_at(b, s, x, z);
    }
    for (int q = 0; q < 4; q++) {
        const uint32_t X = t.x0 + ((q & 1) ? c << l : 0), Z = t.z0 + ((q & 2) ? c << l : 0);
        uint32_t ni[2], nj[2];
        t.corner_t2[q] = hz__morph_neighbours(N, X, Z, ni, nj) ? cg_h(b, ni[0], nj[0]) + cg_h(b, ni[1], nj[1])
                                                               : 2u * cg_h(b, X, Z);
    }
    hz_result res = hz_pyr_encode_tile(in, &t, b->d->zstd_level, blob, bytes, err);
    free(buf);
    return res;
}

/* ---- the walk ---- */

typedef struct leaf_job {
    build *b;
    uint32_t tx, tz;
    tile_res r;
    void *blob;
    size_t bytes;
} leaf_job;

static void *leaf_run(void *arg)
{
    leaf_job *j = arg;
    leaf(j->b, j->tx, j->tz, &j->r);
    if (j->b->pass == 2 && j->r.h && j->b->res == HZ_OK) {
        hz_err e = {0};
        hz_result r = encode(j->b, 0, j->tx, j->tz, &j->r, &j->blob, &j->bytes, &e);
        if (r != HZ_OK)
            fail(j->b, r, &e);
    }
    return NULL;
}

static void res_free(tile_res *r)
{
    free(r->h);
    free(r->valid);
    r->h = NULL;
    r->valid = NULL;
}

static void put(build *b, uint32_t l, uint32_t tx, uint32_t tz, const void *blob, size_t bytes)
{
    if (b->res != HZ_OK)
        return;
    hz_err e = {0};
    hz_result r = hz_pyr_writer_put(b->w, l, tx, tz, blob, bytes, &e);
    if (r != HZ_OK)
        fail(b, r, &e);
}

static void walk(build *b, uint32_t l, uint32_t tx, uint32_t tz, tile_res *out);

/* The children of tile (l, tx, tz) (level l - 1), assembled into a window of
 * 2c + 1 samples per side at level l - 1. */
static bool children(build *b, uint32_t l, uint32_t tx, uint32_t tz, uint16_t *win, uint8_t *wvalid, bool *masked)
{
    const hz_pyr_info *in = &b->info;
    const uint32_t c = hz_pyr_level_cells(in, l), cc = hz_pyr_level_cells(in, l - 1), cs = 2 * c / cc;
    const uint32_t wn = 2 * c + 1, n = cc + 1;
    *masked = false;
    leaf_job jobs[4] = {0};
    for (uint32_t q = 0; q < cs * cs; q++)
        jobs[q] = (leaf_job){.b = b, .tx = tx * cs + q % cs, .tz = tz * cs + q / cs};
    if (l == 1) {
        pthread_t th[4];
        bool started[4] = {0};
        const uint32_t nt = b->threads < cs * cs ? b->threads : cs * cs;
        for (uint32_t q = 0; q < cs * cs; q += nt) {
            for (uint32_t t = 1; t < nt && q + t < cs * cs; t++)
                started[q + t] = pthread_create(&th[q + t], NULL, leaf_run, &jobs[q + t]) == 0;
            leaf_run(&jobs[q]);
            for (uint32_t t = 1; t < nt && q + t < cs * cs; t++) {
                if (started[q + t])
                    pthread_join(th[q + t], NULL);
                else
                    leaf_run(&jobs[q + t]);
            }
        }
        for (uint32_t q = 0; q < cs * cs; q++) {
            if (b->pass == 2 && jobs[q].blob)
                put(b, 0, jobs[q].tx, jobs[q].tz, jobs[q].blob, jobs[q].bytes);
            free(jobs[q].blob);
        }
        pthread_mutex_lock(&b->lock);
        b->leaves_done += cs * cs;
        pthread_mutex_unlock(&b->lock);
        progress(b);
    } else {
        for (uint32_t q = 0; q < cs * cs && b->res == HZ_OK; q++)
            walk(b, l - 1, jobs[q].tx, jobs[q].tz, &jobs[q].r);
    }
    bool ok = b->res == HZ_OK;
    for (uint32_t q = 0; q < cs * cs; q++) {
        if (ok && jobs[q].r.h) {
            const uint32_t ox = (q % cs) * cc, oz = (q / cs) * cc;
            for (uint32_t j = 0; j < n; j++)
                for (uint32_t i = 0; i < n; i++) {
                    const size_t d = (size_t)(oz + j) * wn + ox + i, s = (size_t)j * n + i;
                    win[d] = jobs[q].r.h[s];
                    wvalid[d] = jobs[q].r.valid ? jobs[q].r.valid[s] : 1;
                    *masked |= !wvalid[d];
                }
        } else {
            ok = false;
        }
        res_free(&jobs[q].r);
    }
    return ok;
}

static void walk(build *b, uint32_t l, uint32_t tx, uint32_t tz, tile_res *out)
{
    memset(out, 0, sizeof *out);
    const hz_pyr_info *in = &b->info;
    if (l == 0) { /* only when the whole map is one level-0 tile */
        leaf_job j = {.b = b, .tx = tx, .tz = tz};
        leaf_run(&j);
        if (b->pass == 2 && j.blob)
            put(b, 0, tx, tz, j.blob, j.bytes);
        free(j.blob);
        *out = j.r;
        b->leaves_done++;
        progress(b);
        return;
    }
    const uint32_t c = hz_pyr_level_cells(in, l), wn = 2 * c + 1, n = c + 1, P = in->patch_cells, k = c / P;
    const uint32_t N = in->size, half = 1u << (l - 1);
    uint16_t *win = malloc((size_t)wn * wn * sizeof *win);
    uint8_t *wv = malloc((size_t)wn * wn);
    bool masked = false;
    if (!win || !wv || !children(b, l, tx, tz, win, wv, &masked)) {
        free(win);
        free(wv);
        if (b->res == HZ_OK)
            fail(b, HZ_ERR_MEMORY, &(hz_err){.code = HZ_ERR_MEMORY, .msg = "import: out of memory"});
        return;
    }
    const uint32_t OX = (tx * c) << l, OZ = (tz * c) << l;
    if (b->pass == 1) {
        /* The nested bound of each shift-l node: its children's plus the
         * largest distance of the vertices its split brings in (odd at
         * level l - 1) to the midpoint of their two neighbours. */
        for (uint32_t bz = 0; bz < k; bz++)
            for (uint32_t bx = 0; bx < k; bx++) {
                float dv = 0.0f;
                for (uint32_t v = 0; v <= 2 * P; v++) {
                    const uint32_t wz = bz * 2 * P + v;
                    for (uint32_t u = (v & 1) ? 0 : 1; u <= 2 * P; u += (v & 1) ? 1 : 2) {
                        const uint32_t wx = bx * 2 * P + u;
                        const uint32_t X = OX + wx * half, Z = OZ + wz * half;
                        uint32_t ni[2], nj[2];
                        if (!hz__morph_neighbours(N, X, Z, ni, nj))
                            continue;
                        const size_t s = (size_t)wz * wn + wx;
                        const size_t a = (size_t)((nj[0] - OZ) / half) * wn + (ni[0] - OX) / half;
                        const size_t e = (size_t)((nj[1] - OZ) / half) * wn + (ni[1] - OX) / half;
                        if (!wv[s] || !wv[a] || !wv[e])
                            continue;
                        const float t = 0.5f * ((float)win[a] + (float)win[e]);
                        dv = maxf(dv, fabsf((float)win[s] - t));
                    }
                }
                const uint32_t cx = (tx * k + bx) * 2, cz = (tz * k + bz) * 2;
                float dc = 0.0f;
                uint16_t lo = 65535, hi = 0;
                for (uint32_t q = 0; q < 4; q++) {
                    const size_t ci = (size_t)(cz + q / 2) * b->side[l - 1] + cx + q % 2;
                    dc = maxf(dc, (float)b->nd[l - 1][ci]);
                    lo = b->mn[l - 1][ci] < lo ? b->mn[l - 1][ci] : lo;
                    hi = b->mx[l - 1][ci] > hi ? b->mx[l - 1][ci] : hi;
                }
                const size_t q = (size_t)(tz * k + bz) * b->side[l] + tx * k + bx;
                const float d = ceilf(dc + dv);
                b->nd[l][q] = (uint16_t)(d >= 65534.0f ? 65534.0f : d);
                b->mn[l][q] = lo, b->mx[l][q] = hi;
            }
    }
    out->h = malloc((size_t)n * n * sizeof *out->h);
    out->valid = masked ? malloc((size_t)n * n) : NULL;
    if (!out->h || (masked && !out->valid)) {
        free(win);
        free(wv);
        res_free(out);
        fail(b, HZ_ERR_MEMORY, &(hz_err){.code = HZ_ERR_MEMORY, .msg = "import: out of memory"});
        return;
    }
    bool any = false;
    for (uint32_t j = 0; j < n; j++)
        for (uint32_t i = 0; i < n; i++) {
            const size_t s = (size_t)(2 * j) * wn + 2 * i;
            out->h[(size_t)j * n + i] = win[s];
            if (out->valid) {
                out->valid[(size_t)j * n + i] = wv[s];
                any |= !wv[s];
            }
        }
    if (out->valid && !any) {
        free(out->valid);
        out->valid = NULL;
    }
    free(win);
    free(wv);
    if (b->pass == 2 && b->res == HZ_OK) {
        void *blob = NULL;
        size_t bytes = 0;
        hz_err e = {0};
        hz_result r = encode(b, l, tx, tz, out, &blob, &bytes, &e);
        if (r != HZ_OK)
            fail(b, r, &e);
        else
            put(b, l, tx, tz, blob, bytes);
        free(blob);
    }
}

/* Every node's bound at least CD_GROW times that of each node one level
 * finer that touches it (lod_cdlod.c explains why). */
static void dilate(build *b)
{
    for (uint32_t s = 1; s < b->info.levels; s++) {
        const uint32_t m = b->side[s], cm = b->side[s - 1];
        for (uint32_t zi = 0; zi < m; zi++)
            for (uint32_t xi = 0; xi < m; xi++) {
                float d = b->nd[s][(size_t)zi * m + xi];
                const int64_t c0x = (int64_t)xi * 2 - 1, c0z = (int64_t)zi * 2 - 1;
                for (int64_t cz = c0z; cz <= c0z + 3; cz++)
                    for (int64_t cx = c0x; cx <= c0x + 3; cx++) {
                        if (cx < 0 || cz < 0 || cx >= (int64_t)cm || cz >= (int64_t)cm)
                            continue;
                        d = maxf(d, CD_GROW * (float)b->nd[s - 1][(size_t)cz * cm + (size_t)cx]);
                    }
                d = ceilf(d);
                b->nd[s][(size_t)zi * m + xi] = (uint16_t)(d >= 65534.0f ? 65534.0f : d);
            }
    }
}

static uint32_t cpu_count(void)
{
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    return n < 1 ? 1 : (n > 4 ? 4 : (uint32_t)n);
}

hz_result hz_pyramid_import(const hz_pyr_import *d, hz_pyr_import_stats *stats, hz_err *err)
{
    HZ_ASSERT(d && d->out);
    const double t0 = hz_time_ms();
    build b = {.d = d, .hmin = 65535, .hmax = 0};
    pthread_mutex_init(&b.lock, NULL);
    hz_result r = HZ_OK;
    hz_pyr_info *in = &b.info;
    char *wkt_copy = NULL;
    const uint32_t T = d->tile_cells ? d->tile_cells : 256, P = d->patch_cells ? d->patch_cells : 8;
    if (T < 16 || T > 4096 || (T & (T - 1)) || P < 2 || P > 64 || (P & (P - 1)) || P > T) {
        r = hz_err_set(err, HZ_ERR_VALUE, "import: --tile %u must be a power of two in 16..4096 and the patch "
                                          "cells %u a power of two in 2..min(64, tile)", T, P);
        goto done;
    }
    if (!(d->max_error >= 0.0 && d->max_error <= 1000.0)) {
        r = hz_err_set(err, HZ_ERR_VALUE, "import: --max-error %g must be in [0, 1000] metres", d->max_error);
        goto done;
    }
    /* the source */
    double lo = 0, hi = 0, sx = 0, sy = 0;
    bool integer = false;
    if (d->generate) {
        r = hz_gen_window_open(&d->gen, &b.gen, err);
        if (r != HZ_OK)
            goto done;
        b.W = b.H = d->gen.size;
        lo = 0, hi = hz_gen_window_amplitude(b.gen);
        sx = sy = d->spacing > 0 ? d->spacing : 10.0;
    } else {
        if (d->input_count == 0) {
            r = hz_err_set(err, HZ_ERR_VALUE, "import: no input (give rasters, folders or --generate perlin)");
            goto done;
        }
        hz_dem_desc dd = {.paths = d->inputs, .path_count = d->input_count, .metric = true, .crs = d->crs,
                          .spacing = d->spacing};
        r = hz_io_src_open(&dd, &b.src, err);
        if (r != HZ_OK)
            goto done;
        hz_io_src_size(b.src, &b.W, &b.H);
        const hz_georef *g = hz_io_src_georef(b.src);
        if (g) {
            hz_georef_spacing(g, &sx, &sy);
            hz_georef_geotransform(g, in->geotransform);
            const char *w = hz_georef_wkt(g);
            wkt_copy = w ? strdup(w) : NULL;
        } else {
            sx = sy = d->spacing > 0 ? d->spacing : 1.0;
        }
        integer = hz_io_src_is_integer16(b.src);
        r = hz_io_src_range(b.src, &lo, &hi, err);
        if (r != HZ_OK)
            goto done;
    }
    if (b.W > 1048577u || b.H > 1048577u) {
        r = hz_err_set(err, HZ_ERR_VALUE, "import: %ux%u samples; sides up to 1048577", b.W, b.H);
        goto done;
    }
    /* quantisation: whole metres of 16-bit integers stay exact */
    if (integer && d->max_error == 0.0 && hi - lo <= 65535.0) {
        b.scale = 1.0;
        b.offset = floor(lo);
    } else {
        const double range = hi > lo ? hi - lo : 1.0;
        b.scale = range / 65535.0;
        if (d->max_error > 0 && 2.0 * d->max_error > b.scale)
            b.scale = 2.0 * d->max_error;
        b.offset = lo;
    }
    {
        double e;
        b.fill = quant(&b, (float)(lo > 0 ? lo : (hi < 0 ? hi : 0.0)), &e); /* sea level when in range */
    }
    /* geometry */
    uint32_t side = b.W > b.H ? b.W : b.H, N = P + 1;
    while (N < side)
        N = 2 * (N - 1) + 1;
    in->version = HZ_PYR_VERSION;
    in->size = N;
    in->data_w = b.W, in->data_h = b.H;
    in->tile_cells = T, in->patch_cells = P;
    uint32_t L = 0;
    while (((uint64_t)P << L) < N - 1)
        L++;
    in->levels = L + 1;
    if (in->levels > HZ_PYR_MAX_LEVELS) {
        r = hz_err_set(err, HZ_ERR_VALUE, "import: %u levels exceed %u", in->levels, HZ_PYR_MAX_LEVELS);
        goto done;
    }
    in->spacing = sx < sy ? sx : sy;
    in->h_scale = b.scale, in->h_offset = b.offset;
    in->wkt = wkt_copy ? wkt_copy : "";
    b.c0 = hz_pyr_level_cells(in, 0);
    b.cg_side = (N - 1) / b.c0 + 1;
    uint64_t node_bytes = 0;
    for (uint32_t s = 0; s < in->levels; s++) {
        b.side[s] = (N - 1) / (P << s);
        node_bytes += (uint64_t)b.side[s] * b.side[s] * 6;
    }
    const uint64_t budget = hz_mem_budget_default();
    if (node_bytes + (uint64_t)b.cg_side * b.cg_side * 2 > budget) {
        r = hz_err_set(err, HZ_ERR_MEMORY, "import: the LOD bounds of a %ux%u map take %.0f MB, more than the memory "
                                           "budget (%.0f MB)", N, N, (double)node_bytes / 1e6, (double)budget / 1e6);
        goto done;
    }
    for (uint32_t s = 0; s < in->levels; s++) {
        const size_t m = (size_t)b.side[s] * b.side[s];
        b.nd[s] = malloc(m * 3 * sizeof(uint16_t));
        if (!b.nd[s]) {
            r = hz_err_set(err, HZ_ERR_MEMORY, "import: out of memory for the LOD bounds");
            goto done;
        }
        b.mn[s] = b.nd[s] + m, b.mx[s] = b.nd[s] + 2 * m;
    }
    b.cg = calloc((size_t)b.cg_side * b.cg_side, sizeof *b.cg);
    if (!b.cg) {
        r = hz_err_set(err, HZ_ERR_MEMORY, "import: out of memory");
        goto done;
    }
    b.threads = d->threads ? d->threads : cpu_count();
    const uint64_t m0 = hz_pyr_level_tiles(in, 0);
    b.leaves_total = m0 * m0;
    const uint32_t top = in->levels - 1;
    for (b.pass = 1; b.pass <= 2 && r == HZ_OK; b.pass++) {
        if (b.pass == 2) {
            dilate(&b);
            in->h_min = b.hmin <= b.hmax ? b.hmin : 0;
            in->h_max = b.hmin <= b.hmax ? b.hmax : 0;
            in->max_error = b.max_err;
            in->nodata = b.nodata;
            r = hz_pyr_writer_open(d->out, in, &b.w, err);
            if (r != HZ_OK)
                break;
        }
        b.leaves_done = 0;
        tile_res root;
        walk(&b, top, 0, 0, &root);
        res_free(&root);
        if (b.res != HZ_OK) {
            r = b.res;
            if (err)
                *err = b.first;
        }
    }
    if (b.w) {
        if (r == HZ_OK) {
            r = hz_pyr_writer_finish(b.w, in, err);
        } else {
            hz_pyr_writer_abort(b.w);
        }
        b.w = NULL;
    }
    if (r == HZ_OK && stats) {
        *stats = (hz_pyr_import_stats){.samples = (uint64_t)N * N, .max_error = b.max_err};
        hz_pyramid *p = NULL;
        hz_err e2 = {0};
        if (hz_pyramid_open(d->out, &p, &e2) == HZ_OK) {
            stats->tiles = hz_pyramid_info(p)->tiles;
            stats->bytes = hz_pyramid_info(p)->file_bytes;
            hz_pyramid_close(p);
        }
    }
done:
    if (stats)
        stats->ms = hz_time_ms() - t0;
    for (uint32_t s = 0; s < HZ_PYR_MAX_LEVELS; s++)
        free(b.nd[s]);
    free(b.cg);
    free(wkt_copy);
    if (b.src)
        hz_io_src_close(b.src);
    if (b.gen)
        hz_gen_window_close(b.gen);
    pthread_mutex_destroy(&b.lock);
    return r;
}
