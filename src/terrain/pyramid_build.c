/* The pyramid import: any raster (or a generated terrain) to a .hzp of
 * tiles, in independent jobs, never the whole raster in memory.
 *
 * A job is a square of S = 16 T level-0 cells (the level-J tiles, J =
 * log2(S / T)). It reads its square plus a halo of one level-J node, computes
 * the LOD bounds of every node of levels 0..J there, and writes the tiles of
 * levels 0..J inside its square. Everything a tile holds depends only on the
 * samples under the tile and the ring of nodes around it (which the halo
 * covers), so jobs can run anywhere in any order (`--tiles A-B` writes jobs A
 * to B to a part file). The finish then builds the levels above J from the
 * level-J tiles of every job (1 / 4^J of the data) and writes the file: job
 * tiles in job order, then its own; one process or many, the same bytes.
 *
 * Bounds per node N of shift s (P x P cells of level s): the nested error
 * bound of lod_cdlod.c, delta(N) = ceil(max over children c of delta(c) +
 * the largest distance of the vertices N's split brings in to the midpoint of
 * their two neighbours), raised to at least CD_GROW times the children's (the
 * in-memory cdlod also raises it over its neighbours' children; here that
 * would reach outside the tile's ring), and the height range of its samples.
 * The per-sample morph ranges and the corner targets are derived from these
 * when a tile loads (stream.c). */
#include "lod_internal.h"

#include "horizon/pyramid.h"
#include "horizon/safety.h"

#include <dirent.h>
#include <errno.h>
#include <pthread.h>
#include <stdio.h>
#include <unistd.h>
#include <xxhash.h>

#define JOB_TILES 16u /* a job's side in level-0 tiles */

typedef struct narr {   /* node bounds of one shift over a rectangle of nodes */
    uint32_t x0, z0, w, h; /* first node index, nodes */
    uint16_t *d, *mn, *mx;
} narr;

typedef struct build {
    const hz_pyr_import *d;
    hz_pyr_info info;
    char *wkt;
    hz_io_src *src;
    hz_gen_window *gen;
    uint32_t W, H;
    double scale, offset;
    double zscale;        /* source units to metres */
    uint16_t fill;
    uint32_t S, J, jobs_side, threads;
    bool wrap;             /* the terrain repeats: jobs work in coordinates shifted by ext = N - 1 */
    uint32_t ext, n_ext;   /* that shift (0 without wrap); the bound for hz__morph_neighbours */
    /* the finish's level-J grid over the data's bounding box (gj_w x gj_h
     * samples; beyond it, to the padded square's edge, all is no data: the
     * sentinel at gj_w * gj_h) */
    uint16_t *gj;
    uint8_t *gjv;
    uint32_t gj_w, gj_h;
    uint64_t finish_bytes; /* the grid and nJ */
    narr nJ;               /* shift-J node bounds over the whole map */
    /* figures */
    uint64_t nodata;
    uint16_t hmin, hmax;
    double max_err;
    hz_pyr_writer *w;
} build;

static uint16_t quant(const build *b, double v, double *e)
{
    double q = floor((v - b->offset) / b->scale + 0.5);
    q = q < 0 ? 0 : (q > 65535 ? 65535 : q);
    *e = fabs(b->offset + b->scale * q - v);
    return (uint16_t)q;
}

static void narr_free(narr *a)
{
    free(a->d);
    a->d = a->mn = a->mx = NULL;
}

static bool narr_alloc(narr *a, uint32_t x0, uint32_t z0, uint32_t w, uint32_t h)
{
    *a = (narr){.x0 = x0, .z0 = z0, .w = w, .h = h};
    a->d = malloc((size_t)w * h * 3 * sizeof *a->d + 1);
    if (!a->d)
        return false;
    a->mn = a->d + (size_t)w * h, a->mx = a->mn + (size_t)w * h;
    return true;
}

static inline bool narr_has(const narr *a, int64_t x, int64_t z)
{
    return x >= a->x0 && z >= a->z0 && x < (int64_t)a->x0 + a->w && z < (int64_t)a->z0 + a->h;
}

static inline size_t narr_at(const narr *a, uint32_t x, uint32_t z)
{
    return (size_t)(z - a->z0) * a->w + (x - a->x0);
}

/* A grid of heights (and validity) at spacing 2^lv over level-0 samples
 * [ox, ox + (n-1) 2^lv] x [oz, ...]. A sample outside it reads entry
 * nx * nz, which the owner sets to (fill, no data): the finish's grid covers
 * only the data's bounding box of the padded square. */
typedef struct grid16 {
    const uint16_t *h;
    const uint8_t *v;
    uint32_t ox, oz, nx, nz, lv;
} grid16;

static inline size_t g_at(const grid16 *g, uint32_t X, uint32_t Z)
{
    const uint32_t a = (X - g->ox) >> g->lv, c = (Z - g->oz) >> g->lv;
    if (__builtin_expect(a >= g->nx || c >= g->nz, 0))
        return (size_t)g->nx * g->nz;
    return (size_t)c * g->nx + a;
}

/* Stores level-J sample (row, col) of the whole map in the finish's grid;
 * outside the data's box it is no data already. */
static inline void gj_put(build *b, uint64_t row, uint64_t col, uint16_t h, uint8_t v)
{
    if (row < b->gj_h && col < b->gj_w) {
        b->gj[row * b->gj_w + col] = h;
        b->gjv[row * b->gj_w + col] = v;
    }
}

/* Bounds of shift s nodes in a from the shift s-1 bounds in c and the heights
 * in g (spacing 2^(s-1) or finer, covering a). */
static void bounds_up(const build *b, const grid16 *g, const narr *c, narr *a, uint32_t s)
{
    const uint32_t P = b->info.patch_cells, N = b->n_ext, half = 1u << (s - 1), G = P << s;
    for (uint32_t zi = 0; zi < a->h; zi++)
        for (uint32_t xi = 0; xi < a->w; xi++) {
            const uint32_t nx = a->x0 + xi, nz = a->z0 + zi, X0 = nx * G, Z0 = nz * G;
            float dv = 0.0f;
            for (uint32_t v = 0; v <= 2 * P; v++)
                for (uint32_t u = (v & 1) ? 0 : 1; u <= 2 * P; u += (v & 1) ? 1 : 2) {
                    const uint32_t X = X0 + u * half, Z = Z0 + v * half;
                    uint32_t ni[2], nj[2];
                    if (!hz__morph_neighbours(N, X, Z, ni, nj))
                        continue;
                    const size_t k = g_at(g, X, Z), ka = g_at(g, ni[0], nj[0]), kb = g_at(g, ni[1], nj[1]);
                    if (!g->v[k] || !g->v[ka] || !g->v[kb])
                        continue;
                    dv = maxf(dv, fabsf((float)g->h[k] - 0.5f * ((float)g->h[ka] + (float)g->h[kb])));
                }
            float dc = 0.0f;
            uint16_t lo = 65535, hi = 0;
            for (uint32_t q = 0; q < 4; q++) {
                const size_t ci = narr_at(c, 2 * nx + (q & 1), 2 * nz + (q >> 1));
                dc = maxf(dc, (float)c->d[ci]);
                lo = c->mn[ci] < lo ? c->mn[ci] : lo;
                hi = c->mx[ci] > hi ? c->mx[ci] : hi;
            }
            float d = fmaxf(ceilf(dc + dv), ceilf(CD_GROW * dc));
            const size_t k = narr_at(a, nx, nz);
            a->d[k] = (uint16_t)(d >= 65534.0f ? 65534.0f : d);
            a->mn[k] = lo, a->mx[k] = hi;
        }
}

/* Bounds of shift 0 nodes (exact: 0) over grid g (level 0). */
static void bounds_leaf(const build *b, const grid16 *g, narr *a)
{
    const uint32_t P = b->info.patch_cells;
    for (uint32_t zi = 0; zi < a->h; zi++)
        for (uint32_t xi = 0; xi < a->w; xi++) {
            const uint32_t X0 = (a->x0 + xi) * P, Z0 = (a->z0 + zi) * P;
            uint16_t lo = 65535, hi = 0;
            for (uint32_t v = 0; v <= P; v++)
                for (uint32_t u = 0; u <= P; u++) {
                    const uint16_t h = g->h[g_at(g, X0 + u, Z0 + v)];
                    lo = h < lo ? h : lo;
                    hi = h > hi ? h : hi;
                }
            const size_t k = narr_at(a, a->x0 + xi, a->z0 + zi);
            a->d[k] = 0, a->mn[k] = lo, a->mx[k] = hi;
        }
}

/* ---- tiles ---- */

typedef struct tile_task {
    uint32_t level, tx, tz;
    void *blob;
    size_t bytes;
    hz_result res;
    hz_err err;
} tile_task;

typedef struct tile_ctx {
    const build *b;
    const grid16 *g;       /* heights at level <= the tiles' */
    const narr *nodes;     /* per shift; nodes[s] covers the tiles and their ring */
    bool shifted;          /* g and nodes are in the jobs' shifted coordinates */
    tile_task *tasks;
    size_t count;
    size_t next;
    pthread_mutex_t lock;
} tile_ctx;

/* Height of plain sample (X, Z) for a tile's apron: across the seam of a
 * repeating terrain; off the map, the edge's slope continued (one step of
 * 2^l); from grid g (plain -> grid coordinates: + gs). */
static uint16_t apron_h(const build *b, const grid16 *g, uint32_t gs, int64_t X, int64_t Z, uint32_t l)
{
    const int64_t per = (int64_t)b->info.size - 1, st = (int64_t)1 << l;
    if (b->wrap && !(g->ox <= X + gs && X + gs < g->ox + ((int64_t)g->nx - 1) * ((int64_t)1 << g->lv) + 1 &&
                     g->oz <= Z + gs && Z + gs < g->oz + ((int64_t)g->nz - 1) * ((int64_t)1 << g->lv) + 1))
        X = ((X % per) + per) % per, Z = ((Z % per) + per) % per;
    int64_t ex = 0, ez = 0; /* off the map: the edge sample and the one inside it */
    if (!b->wrap) {
        if (X < 0)
            ex = -1, X = 0;
        else if (X > per)
            ex = 1, X = per;
        if (Z < 0)
            ez = -1, Z = 0;
        else if (Z > per)
            ez = 1, Z = per;
    }
    const int h0 = g->h[g_at(g, (uint32_t)(X + gs), (uint32_t)(Z + gs))];
    if (!ex && !ez)
        return (uint16_t)h0;
    const int h1 = g->h[g_at(g, (uint32_t)(X - ex * st + gs), (uint32_t)(Z - ez * st + gs))];
    const int e = 2 * h0 - h1;
    return (uint16_t)(e < 0 ? 0 : (e > 65535 ? 65535 : e));
}

static void encode_one(const tile_ctx *c, hz_pyr_encoder *enc, tile_task *t)
{
    const build *b = c->b;
    const hz_pyr_info *in = &b->info;
    const uint32_t l = t->level, cc = hz_pyr_level_cells(in, l), n = cc + 1, k = cc / in->patch_cells;
    const uint32_t X0 = (t->tx * cc) << l, Z0 = (t->tz * cc) << l;
    const uint32_t gs = c->shifted ? b->ext : 0;                       /* samples: plain -> grid */
    const int64_t ns = c->shifted ? (int64_t)(b->ext / (in->patch_cells << l)) : 0; /* nodes */
    const int64_t side = (int64_t)((in->size - 1) / (in->patch_cells << l));
    uint16_t *h = malloc(((size_t)n * n + 4 * (size_t)cc + 8) * sizeof *h);
    uint8_t *v = malloc((size_t)n * n);
    uint16_t *nd = malloc(((size_t)(k + 2) * (k + 2) + 2 * (size_t)k * k) * sizeof *nd);
    if (!h || !v || !nd) {
        free(h);
        free(v);
        free(nd);
        t->res = hz_err_set(&t->err, HZ_ERR_MEMORY, "import: out of memory");
        return;
    }
    bool masked = false;
    for (uint32_t bz = 0; bz < n; bz++)
        for (uint32_t a = 0; a < n; a++) {
            const size_t s = g_at(c->g, X0 + gs + (a << l), Z0 + gs + (bz << l));
            h[(size_t)bz * n + a] = c->g->h[s];
            v[(size_t)bz * n + a] = c->g->v[s];
            masked |= !c->g->v[s];
        }
    /* the apron: the samples around the tile, from the grid (the jobs' halo
     * or the whole map), across the seam when repeating, extrapolated off the map */
    uint16_t *ap = h + (size_t)n * n;
    size_t na_ = 0;
    for (int64_t bz = -1; bz <= (int64_t)cc + 1; bz++)
        for (int64_t a = -1; a <= (int64_t)cc + 1; a++) {
            if (bz >= 0 && bz <= (int64_t)cc && a >= 0 && a <= (int64_t)cc)
                continue;
            ap[na_++] = apron_h(b, c->g, gs, (int64_t)X0 + a * ((int64_t)1 << l), (int64_t)Z0 + bz * ((int64_t)1 << l), l);
        }
    const narr *na = &c->nodes[l];
    const int64_t kx0 = (int64_t)t->tx * k, kz0 = (int64_t)t->tz * k;
    uint16_t *mn = nd + (size_t)(k + 2) * (k + 2), *mx = mn + (size_t)k * k;
    for (uint32_t bz = 0; bz < k + 2; bz++)
        for (uint32_t bx = 0; bx < k + 2; bx++) {
            int64_t x = kx0 + bx - 1 + ns, z = kz0 + bz - 1 + ns;
            if (b->wrap && !narr_has(na, x, z)) { /* the ring across the seam */
                x = ((kx0 + bx - 1 + side) % side) + ns;
                z = ((kz0 + bz - 1 + side) % side) + ns;
            }
            const bool has = narr_has(na, x, z);
            nd[(size_t)bz * (k + 2) + bx] = has ? na->d[narr_at(na, (uint32_t)x, (uint32_t)z)] : 0;
            if (bx >= 1 && bz >= 1 && bx <= k && bz <= k) {
                mn[(size_t)(bz - 1) * k + bx - 1] = has ? na->mn[narr_at(na, (uint32_t)x, (uint32_t)z)] : 0;
                mx[(size_t)(bz - 1) * k + bx - 1] = has ? na->mx[narr_at(na, (uint32_t)x, (uint32_t)z)] : 0;
            }
        }
    hz_pyr_tile tile = {.level = l, .tx = t->tx, .tz = t->tz, .cells = cc, .x0 = X0, .z0 = Z0, .h = h, .apron = ap,
                        .valid = masked ? v : NULL, .nodes = k, .node_delta = nd, .node_min = mn, .node_max = mx};
    t->res = hz_pyr_encoder_tile(enc, in, &tile, b->d->zstd_level, &t->blob, &t->bytes, &t->err);
    free(h);
    free(v);
    free(nd);
}

static void *encode_worker(void *arg)
{
    tile_ctx *c = arg;
    hz_pyr_encoder *enc = hz_pyr_encoder_new(); /* NULL: each tile makes its own */
    for (;;) {
        pthread_mutex_lock(&c->lock);
        const size_t k = c->next++;
        pthread_mutex_unlock(&c->lock);
        if (k >= c->count)
            break;
        encode_one(c, enc, &c->tasks[k]);
    }
    hz_pyr_encoder_free(enc);
    return NULL;
}

/* Encodes the tasks on every thread; results in task order. */
static hz_result encode_all(tile_ctx *c, hz_err *err)
{
    pthread_mutex_init(&c->lock, NULL);
    c->next = 0;
    pthread_t th[16];
    uint32_t started = 0;
    for (uint32_t t = 1; t < c->b->threads && t < 16; t++)
        if (pthread_create(&th[started], NULL, encode_worker, c) == 0)
            started++;
    encode_worker(c);
    for (uint32_t t = 0; t < started; t++)
        pthread_join(th[t], NULL);
    pthread_mutex_destroy(&c->lock);
    for (size_t k = 0; k < c->count; k++)
        if (c->tasks[k].res != HZ_OK) {
            if (err)
                *err = c->tasks[k].err;
            return c->tasks[k].res;
        }
    return HZ_OK;
}

/* ---- a job ---- */

typedef struct job_out {
    tile_task *tasks;      /* in write order */
    size_t count;
    /* level-J data of the job's square, for the finish */
    uint16_t *hJ;
    uint8_t *vJ;
    narr nJ;
    uint64_t nodata;
    uint16_t hmin, hmax;
    double max_err;
} job_out;

static void job_out_free(job_out *o)
{
    for (size_t k = 0; k < o->count; k++)
        free(o->tasks[k].blob);
    free(o->tasks);
    free(o->hJ);
    free(o->vJ);
    narr_free(&o->nJ);
    memset(o, 0, sizeof *o);
}

typedef struct gen_rows {
    const build *b;
    uint32_t x0, z0, w, h;
    float *out;
    uint32_t next;
    pthread_mutex_t lock;
} gen_rows;

static void *gen_worker(void *arg)
{
    gen_rows *g = arg;
    for (;;) {
        pthread_mutex_lock(&g->lock);
        const uint32_t j = g->next;
        g->next += 16;
        pthread_mutex_unlock(&g->lock);
        if (j >= g->h)
            return NULL;
        const uint32_t n = g->h - j < 16 ? g->h - j : 16;
        hz_gen_window_read(g->b->gen, g->x0, g->z0 + j, g->w, n, g->out + (size_t)j * g->w);
    }
}

/* Reads the source block [x0, x0 + w) x [z0, z0 + h) (plain, inside the
 * data) into f (row stride fw). */
static hz_result read_block(build *b, uint32_t x0, uint32_t z0, uint32_t w, uint32_t h, float *f, size_t fw,
                            hz_err *err)
{
    float *t = malloc((size_t)w * h * sizeof *t);
    if (!t)
        return hz_err_set(err, HZ_ERR_MEMORY, "import: out of memory for a %ux%u window", w, h);
    if (b->gen) {
        gen_rows g = {.b = b, .x0 = x0, .z0 = z0, .w = w, .h = h, .out = t};
        pthread_mutex_init(&g.lock, NULL);
        pthread_t th[16];
        uint32_t started = 0;
        for (uint32_t k = 1; k < b->threads && k < 16; k++)
            if (pthread_create(&th[started], NULL, gen_worker, &g) == 0)
                started++;
        gen_worker(&g);
        for (uint32_t k = 0; k < started; k++)
            pthread_join(th[k], NULL);
        pthread_mutex_destroy(&g.lock);
    } else {
        hz_result r = hz_io_src_read(b->src, x0, z0, w, h, t, err);
        if (r != HZ_OK) {
            free(t);
            return r;
        }
        if (b->zscale != 1.0)
            for (size_t k = 0; k < (size_t)w * h; k++)
                t[k] = (float)((double)t[k] * b->zscale);
    }
    for (uint32_t j = 0; j < h; j++)
        memcpy(f + (size_t)j * fw, t + (size_t)j * w, w * sizeof *f);
    free(t);
    return HZ_OK;
}

/* Runs of consecutive source samples along one axis of a block starting at
 * a0 (shifted coordinates when wrapping): plain start, length, block offset. */
typedef struct run1 {
    uint32_t src, len, dst;
} run1;

static uint32_t runs_of(const build *b, uint32_t a0, uint32_t n, uint32_t data, run1 *out)
{
    uint32_t count = 0;
    for (uint32_t k = 0; k < n;) {
        int64_t p = (int64_t)a0 + k - b->ext;
        if (b->wrap) {
            const int64_t per = b->info.size - 1;
            p = ((p % per) + per) % per;
        }
        if (p < 0 || p >= data) { /* off the data: no run */
            k++;
            continue;
        }
        uint32_t len = 1;
        while (k + len < n && (uint64_t)p + len < data) {
            int64_t q = (int64_t)a0 + k + len - b->ext;
            if (b->wrap) {
                const int64_t per = b->info.size - 1;
                q = ((q % per) + per) % per;
            }
            if (q != p + len)
                break;
            len++;
        }
        out[count++] = (run1){(uint32_t)p, len, k};
        k += len;
    }
    return count;
}

/* Samples [x0, x0 + w) x [z0, z0 + h) of the map (shifted by ext when the
 * terrain wraps: the source is read modulo its period, so the last row and
 * column repeat the first), quantised; outside the data and nodata are
 * invalid (height: fill). */
static hz_result read_rect(build *b, uint32_t x0, uint32_t z0, uint32_t w, uint32_t h, uint16_t *q, uint8_t *v,
                           double *max_err, hz_err *err)
{
    *max_err = 0;
    float *f = malloc((size_t)w * h * sizeof *f);
    run1 *rx = malloc(((size_t)w + 1) * sizeof *rx), *rz = malloc(((size_t)h + 1) * sizeof *rz);
    if (!f || !rx || !rz) {
        free(f), free(rx), free(rz);
        return hz_err_set(err, HZ_ERR_MEMORY, "import: out of memory for a %ux%u window", w, h);
    }
    for (size_t k = 0; k < (size_t)w * h; k++)
        f[k] = NAN;
    const uint32_t nx = runs_of(b, x0, w, b->W, rx), nz = runs_of(b, z0, h, b->H, rz);
    hz_result r = HZ_OK;
    for (uint32_t j = 0; j < nz && r == HZ_OK; j++)
        for (uint32_t i = 0; i < nx && r == HZ_OK; i++)
            r = read_block(b, rx[i].src, rz[j].src, rx[i].len, rz[j].len, f + (size_t)rz[j].dst * w + rx[i].dst, w,
                           err);
    free(rx);
    free(rz);
    if (r != HZ_OK) {
        free(f);
        return r;
    }
    for (size_t k = 0; k < (size_t)w * h; k++) {
        const float x = f[k];
        if (!isfinite(x)) {
            q[k] = b->fill;
            v[k] = 0;
        } else {
            double e;
            q[k] = quant(b, x, &e);
            v[k] = 1;
            *max_err = e > *max_err ? e : *max_err;
        }
    }
    free(f);
    return HZ_OK;
}

static hz_result run_job(build *b, uint32_t job, job_out *o, hz_err *err)
{
    memset(o, 0, sizeof *o);
    const hz_pyr_info *in = &b->info;
    const uint32_t N = in->size, P = in->patch_cells, S = b->S, J = b->J;
    const uint32_t jx = job % b->jobs_side, jz = job / b->jobs_side;
    const uint32_t halo = P << J;
    const uint32_t X0 = jx * S, Z0 = jz * S;
    /* shifted by ext when wrapping: the halo then reads across the seam */
    const uint32_t E = b->ext, XE = X0 + E, ZE = Z0 + E;
    const uint32_t RX0 = b->wrap ? XE - halo : (X0 >= halo ? X0 - halo : 0);
    const uint32_t RZ0 = b->wrap ? ZE - halo : (Z0 >= halo ? Z0 - halo : 0);
    const uint32_t RX1 = b->wrap ? XE + S + halo : (X0 + S + halo <= N - 1 ? X0 + S + halo : N - 1);
    const uint32_t RZ1 = b->wrap ? ZE + S + halo : (Z0 + S + halo <= N - 1 ? Z0 + S + halo : N - 1);
    const uint32_t RW = RX1 - RX0 + 1, RH = RZ1 - RZ0 + 1;
    /* A window wholly in the padding of a narrow map (most jobs of a UTM zone
     * strip) has no sample: its grid is empty (every read is g_at's outside
     * entry, no data) and its node bounds are known, so it reads nothing and
     * holds no window. Its tiles are the same as when computed. */
    const bool empty = !b->wrap && (RX0 >= b->W || RZ0 >= b->H);
    const size_t cells = empty ? 0 : (size_t)RW * RH;
    uint16_t *q = malloc((cells + 1) * sizeof *q); /* + g_at's outside entry */
    uint8_t *v = malloc(cells + 1);
    narr nodes[HZ_PYR_MAX_LEVELS] = {0};
    hz_result r = HZ_OK;
    if (!q || !v) {
        r = hz_err_set(err, HZ_ERR_MEMORY, "import: out of memory for a %ux%u job window", RW, RH);
        goto done;
    }
    if (!empty)
        r = read_rect(b, RX0, RZ0, RW, RH, q, v, &o->max_err, err);
    if (r != HZ_OK)
        goto done;
    q[cells] = b->fill, v[cells] = 0;
    /* figures over the job's own square (each sample once) */
    o->hmin = 65535, o->hmax = 0;
    for (uint32_t Z = Z0; !empty && Z <= Z0 + S; Z++) {
        if (Z == Z0 + S && Z != N - 1)
            break;
        for (uint32_t X = X0; X <= X0 + S; X++) {
            if (X == X0 + S && X != N - 1)
                break;
            const size_t k = (size_t)(Z + E - RZ0) * RW + (X + E - RX0);
            if (!v[k]) {
                o->nodata += X < b->W && Z < b->H;
                continue;
            }
            o->hmin = q[k] < o->hmin ? q[k] : o->hmin;
            o->hmax = q[k] > o->hmax ? q[k] : o->hmax;
        }
    }
    grid16 g0 = {.h = q, .v = v, .ox = RX0, .oz = RZ0, .nx = empty ? 0 : RW, .nz = empty ? 0 : RH, .lv = 0};
    for (uint32_t s = 0; s <= J; s++) {
        const uint32_t G = P << s;
        if (!narr_alloc(&nodes[s], RX0 / G, RZ0 / G, (RW - 1) / G, (RH - 1) / G)) {
            r = hz_err_set(err, HZ_ERR_MEMORY, "import: out of memory");
            goto done;
        }
        if (empty) /* what bounds_leaf and bounds_up give with no valid sample */
            for (size_t k = 0; k < (size_t)nodes[s].w * nodes[s].h; k++)
                nodes[s].d[k] = 0, nodes[s].mn[k] = nodes[s].mx[k] = b->fill;
        else if (s == 0)
            bounds_leaf(b, &g0, &nodes[0]);
        else
            bounds_up(b, &g0, &nodes[s - 1], &nodes[s], s);
    }
    /* the tiles of levels 0..J inside the square */
    size_t count = 0;
    for (uint32_t l = 0; l <= J; l++)
        count += (size_t)1 << (2 * (J - l));
    o->tasks = calloc(count, sizeof *o->tasks);
    if (!o->tasks) {
        r = hz_err_set(err, HZ_ERR_MEMORY, "import: out of memory");
        goto done;
    }
    for (uint32_t l = 0; l <= J; l++) {
        const uint32_t per = 1u << (J - l);
        for (uint32_t tz = 0; tz < per; tz++)
            for (uint32_t tx = 0; tx < per; tx++)
                o->tasks[o->count++] = (tile_task){.level = l, .tx = jx * per + tx, .tz = jz * per + tz};
    }
    tile_ctx tc = {.b = b, .g = &g0, .nodes = nodes, .tasks = o->tasks, .count = o->count, .shifted = true};
    r = encode_all(&tc, err);
    if (r != HZ_OK)
        goto done;
    /* level-J data of the square for the finish */
    const uint32_t nJ = (S >> J) + 1;
    o->hJ = malloc((size_t)nJ * nJ * sizeof *o->hJ);
    o->vJ = malloc((size_t)nJ * nJ);
    const uint32_t kJ = S / (P << J);
    if (!o->hJ || !o->vJ || !narr_alloc(&o->nJ, X0 / (P << J), Z0 / (P << J), kJ, kJ)) {
        r = hz_err_set(err, HZ_ERR_MEMORY, "import: out of memory");
        goto done;
    }
    for (uint32_t bz = 0; bz < nJ; bz++)
        for (uint32_t a = 0; a < nJ; a++) {
            const size_t s = g_at(&g0, XE + (a << J), ZE + (bz << J));
            o->hJ[(size_t)bz * nJ + a] = q[s];
            o->vJ[(size_t)bz * nJ + a] = v[s];
        }
    for (uint32_t zi = 0; zi < kJ; zi++)
        for (uint32_t xi = 0; xi < kJ; xi++) {
            const uint32_t sJ = E / (P << J);
            const size_t src = narr_at(&nodes[J], o->nJ.x0 + sJ + xi, o->nJ.z0 + sJ + zi), dst = (size_t)zi * kJ + xi;
            o->nJ.d[dst] = nodes[J].d[src], o->nJ.mn[dst] = nodes[J].mn[src], o->nJ.mx[dst] = nodes[J].mx[src];
        }
done:
    for (uint32_t s = 0; s <= J; s++)
        narr_free(&nodes[s]);
    free(q);
    free(v);
    if (r != HZ_OK)
        job_out_free(o);
    return r;
}

/* Copies a job's level-J data into the finish's whole-map grid. */
static void gather(build *b, const job_out *o, uint32_t job)
{
    const uint32_t jx = job % b->jobs_side, jz = job / b->jobs_side, P = b->info.patch_cells;
    const uint32_t nJ = (b->S >> b->J) + 1, kJ = b->S / (P << b->J);
    for (uint32_t bz = 0; bz < nJ; bz++)
        for (uint32_t a = 0; a < nJ; a++)
            gj_put(b, (uint64_t)jz * (nJ - 1) + bz, (uint64_t)jx * (nJ - 1) + a, o->hJ[(size_t)bz * nJ + a],
                   o->vJ[(size_t)bz * nJ + a]);
    for (uint32_t zi = 0; zi < kJ; zi++)
        for (uint32_t xi = 0; xi < kJ; xi++) {
            const size_t dst = narr_at(&b->nJ, jx * kJ + xi, jz * kJ + zi), src = (size_t)zi * kJ + xi;
            b->nJ.d[dst] = o->nJ.d[src], b->nJ.mn[dst] = o->nJ.mn[src], b->nJ.mx[dst] = o->nJ.mx[src];
        }
    b->nodata += o->nodata;
    if (o->hmin <= o->hmax) {
        b->hmin = o->hmin < b->hmin ? o->hmin : b->hmin;
        b->hmax = o->hmax > b->hmax ? o->hmax : b->hmax;
    }
    b->max_err = o->max_err > b->max_err ? o->max_err : b->max_err;
}

/* The levels above J from the gathered grid; tiles go to the writer. */
static hz_result finish_levels(build *b, hz_err *err)
{
    const hz_pyr_info *in = &b->info;
    const uint32_t P = in->patch_cells, N = in->size, top = in->levels - 1;
    narr nodes[HZ_PYR_MAX_LEVELS] = {0};
    nodes[b->J] = b->nJ;
    grid16 g = {.h = b->gj, .v = b->gjv, .ox = 0, .oz = 0, .nx = b->gj_w, .nz = b->gj_h, .lv = b->J};
    hz_result r = HZ_OK;
    for (uint32_t s = b->J + 1; s <= top && r == HZ_OK; s++) {
        const uint32_t side = (N - 1) / (P << s);
        if (!narr_alloc(&nodes[s], 0, 0, side, side))
            r = hz_err_set(err, HZ_ERR_MEMORY, "import: out of memory");
        else
            bounds_up(b, &g, &nodes[s - 1], &nodes[s], s);
    }
    size_t count = 0;
    for (uint32_t l = b->J + 1; l <= top; l++)
        count += (size_t)hz_pyr_level_tiles(in, l) * hz_pyr_level_tiles(in, l);
    tile_task *tasks = r == HZ_OK ? calloc(count + 1, sizeof *tasks) : NULL;
    if (r == HZ_OK && !tasks)
        r = hz_err_set(err, HZ_ERR_MEMORY, "import: out of memory");
    size_t n = 0;
    for (uint32_t l = b->J + 1; r == HZ_OK && l <= top; l++) {
        const uint32_t m = hz_pyr_level_tiles(in, l);
        for (uint32_t tz = 0; tz < m; tz++)
            for (uint32_t tx = 0; tx < m; tx++)
                tasks[n++] = (tile_task){.level = l, .tx = tx, .tz = tz};
    }
    if (r == HZ_OK) {
        tile_ctx tc = {.b = b, .g = &g, .nodes = nodes, .tasks = tasks, .count = n};
        r = encode_all(&tc, err);
    }
    for (size_t k = 0; r == HZ_OK && k < n; k++)
        r = hz_pyr_writer_put(b->w, tasks[k].level, tasks[k].tx, tasks[k].tz, tasks[k].blob, tasks[k].bytes, err);
    for (size_t k = 0; tasks && k < n; k++)
        free(tasks[k].blob);
    free(tasks);
    for (uint32_t s = b->J + 1; s <= top; s++)
        narr_free(&nodes[s]);
    return r;
}

/* ---- part files (--tiles / --finish) ---- */

enum { PART_HDR = 128 };
static const char PART_MAGIC[8] = {'H', 'Z', 'P', 'A', 'R', 'T', '0', '1'};

static void w32(uint8_t *p, uint32_t v) { for (int k = 0; k < 4; k++) p[k] = (uint8_t)(v >> (8 * k)); }
static void w64(uint8_t *p, uint64_t v) { for (int k = 0; k < 8; k++) p[k] = (uint8_t)(v >> (8 * k)); }
static uint32_t r32(const uint8_t *p) { uint32_t v = 0; for (int k = 3; k >= 0; k--) v = (v << 8) | p[k]; return v; }
static uint64_t r64(const uint8_t *p) { uint64_t v = 0; for (int k = 7; k >= 0; k--) v = (v << 8) | p[k]; return v; }

/* What must agree between the jobs and the finish. */
static uint64_t setup_hash(const build *b)
{
    const hz_pyr_info *in = &b->info;
    uint8_t buf[128] = {0};
    w32(buf, in->size), w32(buf + 4, in->data_w), w32(buf + 8, in->data_h), w32(buf + 12, in->tile_cells);
    w32(buf + 16, in->patch_cells);
    memcpy(buf + 24, &in->spacing, 8), memcpy(buf + 32, &b->scale, 8), memcpy(buf + 40, &b->offset, 8);
    memcpy(buf + 100, &b->zscale, 8);
    buf[108] = b->wrap;
    memcpy(buf + 48, in->geotransform, 48);
    return XXH64(buf, sizeof buf, XXH64(b->wkt ? b->wkt : "", b->wkt ? strlen(b->wkt) : 0, 0));
}

static void part_name(char *out, size_t cap, const char *base, uint32_t a, uint32_t z)
{
    snprintf(out, cap, "%s.part-%06u-%06u", base, a, z);
}

static hz_result write_part(build *b, uint32_t a, uint32_t z, hz_err *err)
{
    char name[4200];
    part_name(name, sizeof name, b->d->out, a, z);
    hz_outfile of;
    FILE *f = hz_outfile_open(&of, name, err);
    if (!f)
        return HZ_ERR_IO;
    uint8_t h[PART_HDR] = {0};
    if (fwrite(h, 1, PART_HDR, f) != PART_HDR) {
        fclose(f);
        hz_outfile_discard(&of);
        return hz_err_set(err, HZ_ERR_IO, "cannot write '%s'", name);
    }
    uint64_t nodata = 0, tiles = 0;
    uint16_t hmin = 65535, hmax = 0;
    double max_err = 0;
    hz_result r = HZ_OK;
    if (b->d->progress)
        b->d->progress(b->d->progress_user, "import: jobs", 0, z - a + 1);
    for (uint32_t job = a; job <= z && r == HZ_OK; job++) {
        job_out o;
        r = run_job(b, job, &o, err);
        if (r != HZ_OK)
            break;
        for (size_t k = 0; k < o.count && r == HZ_OK; k++) {
            uint8_t rec[16];
            w32(rec, o.tasks[k].level), w32(rec + 4, o.tasks[k].tx), w32(rec + 8, o.tasks[k].tz);
            w32(rec + 12, (uint32_t)o.tasks[k].bytes);
            if (fwrite(rec, 1, 16, f) != 16 || fwrite(o.tasks[k].blob, 1, o.tasks[k].bytes, f) != o.tasks[k].bytes)
                r = hz_err_set(err, HZ_ERR_IO, "cannot write '%s'", name);
            tiles++;
        }
        nodata += o.nodata;
        if (o.hmin <= o.hmax) {
            hmin = o.hmin < hmin ? o.hmin : hmin;
            hmax = o.hmax > hmax ? o.hmax : hmax;
        }
        max_err = o.max_err > max_err ? o.max_err : max_err;
        job_out_free(&o);
        if (b->d->progress)
            b->d->progress(b->d->progress_user, "import: jobs", job - a + 1, z - a + 1);
    }
    if (r == HZ_OK) {
        memcpy(h, PART_MAGIC, 8);
        w32(h + 8, a), w32(h + 12, z), w64(h + 16, setup_hash(b)), w64(h + 24, tiles), w64(h + 32, nodata);
        h[40] = (uint8_t)hmin, h[41] = (uint8_t)(hmin >> 8), h[42] = (uint8_t)hmax, h[43] = (uint8_t)(hmax >> 8);
        memcpy(h + 48, &max_err, 8);
        w64(h + PART_HDR - 8, XXH64(h, PART_HDR - 8, 0));
        if (fseek(f, 0, SEEK_SET) != 0 || fwrite(h, 1, PART_HDR, f) != PART_HDR)
            r = hz_err_set(err, HZ_ERR_IO, "cannot write '%s'", name);
    }
    if (r != HZ_OK) {
        fclose(f);
        hz_outfile_discard(&of);
        return r;
    }
    return hz_outfile_close(&of, f, err);
}

typedef struct part {
    char *path;
    uint32_t a, z;
} part;

static int cmp_part(const void *x, const void *y)
{
    const part *p = x, *q = y;
    return (p->a > q->a) - (p->a < q->a);
}

/* Reads every part of out (in job order) into the writer and the gathered grid. */
static hz_result read_parts(build *b, uint32_t jobs, hz_err *err)
{
    const char *out = b->d->out;
    const char *slash = strrchr(out, '/');
    char dir[4096];
    snprintf(dir, sizeof dir, "%.*s", slash ? (int)(slash - out) : 1, slash ? out : ".");
    const char *base = slash ? slash + 1 : out;
    DIR *dp = opendir(dir);
    if (!dp)
        return hz_err_set(err, HZ_ERR_IO, "--finish: cannot list '%s': %s", dir, strerror(errno));
    part *parts = NULL;
    size_t np = 0, cap = 0;
    hz_result r = HZ_OK;
    struct dirent *e;
    const size_t bl = strlen(base);
    while ((e = readdir(dp))) {
        unsigned a, z;
        char tail;
        if (strncmp(e->d_name, base, bl) || sscanf(e->d_name + bl, ".part-%6u-%6u%c", &a, &z, &tail) != 2)
            continue;
        if (np == cap) {
            cap = cap ? 2 * cap : 16;
            part *np2 = realloc(parts, cap * sizeof *parts);
            if (!np2) {
                r = hz_err_set(err, HZ_ERR_MEMORY, "out of memory");
                break;
            }
            parts = np2;
        }
        char full[8400];
        snprintf(full, sizeof full, "%s/%s", dir, e->d_name);
        parts[np].path = strdup(full);
        parts[np].a = a, parts[np].z = z;
        np++;
    }
    closedir(dp);
    if (r == HZ_OK && np > 1)
        qsort(parts, np, sizeof *parts, cmp_part);
    uint32_t expect = 0;
    for (size_t k = 0; r == HZ_OK && k < np; k++) {
        if (parts[k].a > expect && parts[k].z < jobs)
            r = hz_err_set(err, HZ_ERR_VALUE, "--finish: jobs %u..%u of '%s' are missing (run --tiles %u-%u)",
                           expect, parts[k].a - 1, out, expect, parts[k].a - 1);
        else if (parts[k].a != expect || parts[k].z < parts[k].a || parts[k].z >= jobs)
            r = hz_err_set(err, HZ_ERR_VALUE,
                           "--finish: the parts of '%s' overlap or exceed jobs 0..%u (at job %u: %s)", out,
                           jobs - 1, expect, parts[k].path);
        else
            expect = parts[k].z + 1;
    }
    if (r == HZ_OK && expect != jobs)
        r = hz_err_set(err, HZ_ERR_VALUE, "--finish: jobs %u..%u of '%s' are missing (run --tiles %u-%u)", expect,
                       jobs - 1, out, expect, jobs - 1);
    const uint64_t want = setup_hash(b);
    uint8_t *blob = NULL;
    size_t blob_cap = 0;
    const uint32_t kJ = b->S / (b->info.patch_cells << b->J);
    for (size_t k = 0; r == HZ_OK && k < np; k++) {
        FILE *f = fopen(parts[k].path, "rb");
        uint8_t h[PART_HDR];
        if (!f || fread(h, 1, PART_HDR, f) != PART_HDR || memcmp(h, PART_MAGIC, 8) ||
            r64(h + PART_HDR - 8) != XXH64(h, PART_HDR - 8, 0)) {
            r = hz_err_set(err, HZ_ERR_FORMAT, "--finish: '%s' is not a complete part file", parts[k].path);
        } else if (r64(h + 16) != want) {
            r = hz_err_set(err, HZ_ERR_VALUE, "--finish: '%s' was made from other inputs or settings", parts[k].path);
        } else {
            const uint64_t tiles = r64(h + 24);
            b->nodata += r64(h + 32);
            const uint16_t hmin = (uint16_t)(h[40] | h[41] << 8), hmax = (uint16_t)(h[42] | h[43] << 8);
            if (hmin <= hmax) {
                b->hmin = hmin < b->hmin ? hmin : b->hmin;
                b->hmax = hmax > b->hmax ? hmax : b->hmax;
            }
            double me;
            memcpy(&me, h + 48, 8);
            b->max_err = me > b->max_err ? me : b->max_err;
            for (uint64_t t = 0; r == HZ_OK && t < tiles; t++) {
                uint8_t rec[16];
                if (fread(rec, 1, 16, f) != 16) {
                    r = hz_err_set(err, HZ_ERR_FORMAT, "--finish: '%s' is truncated", parts[k].path);
                    break;
                }
                const uint32_t l = r32(rec), tx = r32(rec + 4), tz = r32(rec + 8), n = r32(rec + 12);
                if (n == 0 || n > (64u << 20) || l > b->J) {
                    r = hz_err_set(err, HZ_ERR_FORMAT, "--finish: '%s' has a bad tile record", parts[k].path);
                    break;
                }
                if (n > blob_cap) {
                    uint8_t *nb = realloc(blob, n);
                    if (!nb) {
                        r = hz_err_set(err, HZ_ERR_MEMORY, "out of memory");
                        break;
                    }
                    blob = nb, blob_cap = n;
                }
                if (fread(blob, 1, n, f) != n) {
                    r = hz_err_set(err, HZ_ERR_FORMAT, "--finish: '%s' is truncated", parts[k].path);
                    break;
                }
                r = hz_pyr_writer_put(b->w, l, tx, tz, blob, n, err);
                if (r == HZ_OK && l == b->J) {
                    /* its level-J data for the levels above */
                    hz_pyr_tile pt;
                    r = hz_pyr_decode_blob(&b->info, l, tx, tz, blob, n, &pt, err);
                    if (r == HZ_OK) {
                        const uint32_t c = pt.cells, nn = c + 1;
                        for (uint32_t bz = 0; bz < nn; bz++)
                            for (uint32_t a = 0; a < nn; a++)
                                gj_put(b, (uint64_t)tz * c + bz, (uint64_t)tx * c + a, pt.h[(size_t)bz * nn + a],
                                       pt.valid ? pt.valid[(size_t)bz * nn + a] : 1);
                        for (uint32_t zi = 0; zi < kJ; zi++)
                            for (uint32_t xi = 0; xi < kJ; xi++) {
                                const size_t dst = narr_at(&b->nJ, tx * kJ + xi, tz * kJ + zi);
                                b->nJ.d[dst] = pt.node_delta[(size_t)(zi + 1) * (kJ + 2) + xi + 1];
                                b->nJ.mn[dst] = pt.node_min[(size_t)zi * kJ + xi];
                                b->nJ.mx[dst] = pt.node_max[(size_t)zi * kJ + xi];
                            }
                        hz_pyr_tile_free(&pt);
                    }
                }
            }
        }
        if (f)
            fclose(f);
    }
    free(blob);
    if (r == HZ_OK)
        for (size_t k = 0; k < np; k++)
            unlink(parts[k].path);
    for (size_t k = 0; k < np; k++)
        free(parts[k].path);
    free(parts);
    return r;
}

/* ---- the import ---- */

static uint32_t cpu_count(void)
{
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    return n < 1 ? 1 : (n > 16 ? 16 : (uint32_t)n);
}

/* Opens the source and fixes the geometry and the quantisation. */
static hz_result setup(build *b, const hz_pyr_import *d, hz_err *err)
{
    hz_pyr_info *in = &b->info;
    const uint32_t T = d->tile_cells ? d->tile_cells : 256, P = d->patch_cells ? d->patch_cells : 8;
    if (T < 16 || T > 4096 || (T & (T - 1)) || P < 2 || P > 64 || (P & (P - 1)) || P > T)
        return hz_err_set(err, HZ_ERR_VALUE,
                          "import: --tile %u must be a power of two in 16..4096 (patch cells %u: a power of two in "
                          "2..min(64, tile))", T, P);
    if (!(d->max_error >= 0.0 && d->max_error <= 1000.0))
        return hz_err_set(err, HZ_ERR_VALUE, "import: --max-error %g must be in [0, 1000] metres", d->max_error);
    if (!(d->zscale >= 0.0 && d->zscale <= 1000.0))
        return hz_err_set(err, HZ_ERR_VALUE, "import: --zscale %g must be in (0, 1000]", d->zscale);
    b->zscale = d->zscale > 0 ? d->zscale : 1.0;
    double lo = 0, hi = 0, sx = 0, sy = 0;
    bool integer = false;
    double int_offset = 0;
    hz_result r;
    if (d->generate) {
        hz_gen_desc gd = d->gen;
        gd.periodic = d->wrap;
        r = hz_gen_window_open(&gd, &b->gen, err);
        if (r != HZ_OK)
            return r;
        b->W = b->H = d->gen.size;
        lo = 0, hi = hz_gen_window_amplitude(b->gen);
        sx = sy = d->spacing > 0 ? d->spacing : 10.0;
    } else {
        if (d->input_count == 0)
            return hz_err_set(err, HZ_ERR_VALUE, "import: no input (give rasters, folders or --generate perlin)");
        hz_dem_desc dd = {.paths = d->inputs, .path_count = d->input_count, .metric = true, .crs = d->crs,
                          .spacing = d->spacing};
        r = hz_io_src_open(&dd, &b->src, err);
        if (r != HZ_OK)
            return r;
        hz_io_src_size(b->src, &b->W, &b->H);
        const hz_georef *g = hz_io_src_georef(b->src);
        if (g) {
            hz_georef_spacing(g, &sx, &sy);
            hz_georef_geotransform(g, in->geotransform);
            const char *w = hz_georef_wkt(g);
            b->wkt = w ? strdup(w) : NULL;
        } else {
            sx = sy = d->spacing > 0 ? d->spacing : 1.0;
        }
        integer = hz_io_src_integer16(b->src, &int_offset);
        if (!integer || d->max_error > 0) {
            r = hz_io_src_range(b->src, &lo, &hi, err);
            if (r != HZ_OK)
                return r;
            lo *= b->zscale, hi *= b->zscale;
        }
    }
    if (b->W > 1048577u || b->H > 1048577u)
        return hz_err_set(err, HZ_ERR_VALUE, "import: %ux%u samples; sides up to 1048577", b->W, b->H);
    if (integer && d->max_error == 0.0) {
        /* exact: one step per source unit, the type's whole range */
        b->scale = b->zscale;
        b->offset = int_offset * b->zscale;
    } else {
        const double range = hi > lo ? hi - lo : 1.0;
        b->scale = range / 65535.0;
        if (d->max_error > 0 && 2.0 * d->max_error > b->scale)
            b->scale = 2.0 * d->max_error;
        b->offset = lo;
    }
    double e;
    b->fill = quant(b, b->offset <= 0.0 && b->offset + 65535.0 * b->scale >= 0.0 ? 0.0 : b->offset, &e);
    uint32_t side = b->W > b->H ? b->W : b->H, N = P + 1;
    while (N < side)
        N = 2 * (N - 1) + 1;
    while (N - 1 < T && N - 1 < P * 2) /* at least two levels */
        N = 2 * (N - 1) + 1;
    in->version = HZ_PYR_VERSION;
    in->size = N;
    in->data_w = b->W, in->data_h = b->H;
    in->tile_cells = T, in->patch_cells = P;
    uint32_t L = 0;
    while (((uint64_t)P << L) < N - 1)
        L++;
    in->levels = L + 1;
    if (in->levels > HZ_PYR_MAX_LEVELS)
        return hz_err_set(err, HZ_ERR_VALUE, "import: %u levels exceed %u", in->levels, HZ_PYR_MAX_LEVELS);
    if (d->wrap && (b->W != N || b->H != N))
        return hz_err_set(err, HZ_ERR_VALUE,
                          "import --wrap: the terrain must be square with 2^k+1 samples per side (this one is "
                          "%ux%u); its last row and column are taken as its first", b->W, b->H);
    b->wrap = d->wrap;
    in->wrap = d->wrap;
    b->ext = d->wrap ? N - 1 : 0;
    b->n_ext = d->wrap ? 3 * (N - 1) + 1 : N;
    in->spacing = sx < sy ? sx : sy;
    in->h_scale = b->scale, in->h_offset = b->offset;
    in->wkt = b->wkt ? b->wkt : "";
    /* jobs */
    const uint32_t c0 = hz_pyr_level_cells(in, 0);
    b->S = (N - 1) < JOB_TILES * c0 ? N - 1 : JOB_TILES * c0;
    b->J = 0;
    while ((c0 << b->J) < b->S)
        b->J++;
    b->jobs_side = (N - 1) / b->S;
    b->threads = d->threads ? d->threads : cpu_count();
    return HZ_OK;
}

uint32_t hz_pyramid_jobs(const hz_pyr_import *d, hz_err *err)
{
    build b = {0};
    uint32_t n = 0;
    if (setup(&b, d, err) == HZ_OK)
        n = b.jobs_side * b.jobs_side;
    hz_io_src_close(b.src);
    hz_gen_window_close(b.gen);
    free(b.wkt);
    return n;
}

hz_result hz_pyramid_import(const hz_pyr_import *d, hz_pyr_import_stats *stats, hz_err *err)
{
    HZ_ASSERT(d && d->out);
    const double t0 = hz_time_ms();
    build b = {.d = d, .hmin = 65535, .hmax = 0};
    hz_result r = setup(&b, d, err);
    hz_pyr_info *in = &b.info;
    const uint32_t jobs = b.jobs_side * b.jobs_side;
    uint32_t ja = 0, jz = jobs ? jobs - 1 : 0;
    if (r == HZ_OK && d->tiles) {
        unsigned a, z;
        char tail;
        if (d->finish)
            r = hz_err_set(err, HZ_ERR_VALUE, "import: --tiles and --finish are separate steps");
        else if (sscanf(d->tiles, "%u-%u%c", &a, &z, &tail) != 2 || a > z || z >= jobs)
            r = hz_err_set(err, HZ_ERR_VALUE, "import: --tiles '%s': expected A-B with 0 <= A <= B <= %u (%u jobs)",
                           d->tiles, jobs - 1, jobs);
        else
            ja = a, jz = z;
    }
    if (r == HZ_OK && d->tiles) {
        r = write_part(&b, ja, jz, err);
        goto done;
    }
    /* the whole pyramid, or the finish of the parts */
    /* the level-J grid over the data's box: beyond it (the padding of a
     * narrow map to its square) every sample is no data */
    const uint64_t gj_n = ((uint64_t)(in->size - 1) >> b.J) + 1;
    const uint64_t gj_w = b.wrap || !b.W ? gj_n : (((uint64_t)b.W - 1) >> b.J) + 1;
    const uint64_t gj_h = b.wrap || !b.H ? gj_n : (((uint64_t)b.H - 1) >> b.J) + 1;
    const uint32_t sideJ = r == HZ_OK ? (in->size - 1) / (in->patch_cells << b.J) : 0;
    const uint64_t need = (gj_w * gj_h + 1) * 3 + (uint64_t)sideJ * sideJ * 6 * 2;
    if (r == HZ_OK && need > hz_mem_budget_default())
        r = hz_err_set(err, HZ_ERR_MEMORY, "import: the finish of a %ux%u map needs %.0f MB, more than the memory "
                                           "budget", in->size, in->size, (double)need / 1e6);
    if (r == HZ_OK) {
        b.gj_w = (uint32_t)(gj_w < gj_n ? gj_w : gj_n), b.gj_h = (uint32_t)(gj_h < gj_n ? gj_h : gj_n);
        const size_t cells = (size_t)b.gj_w * b.gj_h;
        b.gj = malloc((cells + 1) * sizeof *b.gj);
        b.gjv = malloc(cells + 1);
        if (!b.gj || !b.gjv || !narr_alloc(&b.nJ, 0, 0, sideJ, sideJ))
            r = hz_err_set(err, HZ_ERR_MEMORY, "import: out of memory");
        else
            b.gj[cells] = b.fill, b.gjv[cells] = 0;
        b.finish_bytes = (cells + 1) * 3 + (uint64_t)sideJ * sideJ * 6;
    }
    if (r == HZ_OK)
        r = hz_pyr_writer_open(d->out, in, &b.w, err);
    if (r == HZ_OK && d->finish) {
        r = read_parts(&b, jobs, err);
    } else {
        if (r == HZ_OK && d->progress) /* the start: a long first job is timed from here */
            d->progress(d->progress_user, "import", 0, jobs);
        for (uint32_t job = 0; r == HZ_OK && job < jobs; job++) {
            job_out o;
            r = run_job(&b, job, &o, err);
            for (size_t k = 0; r == HZ_OK && k < o.count; k++)
                r = hz_pyr_writer_put(b.w, o.tasks[k].level, o.tasks[k].tx, o.tasks[k].tz, o.tasks[k].blob,
                                      o.tasks[k].bytes, err);
            if (r == HZ_OK)
                gather(&b, &o, job);
            job_out_free(&o);
            if (r == HZ_OK && d->progress)
                d->progress(d->progress_user, "import", job + 1, jobs);
        }
    }
    if (r == HZ_OK)
        r = finish_levels(&b, err);
    if (b.w) {
        if (r == HZ_OK) {
            in->h_min = b.hmin <= b.hmax ? b.hmin : 0;
            in->h_max = b.hmin <= b.hmax ? b.hmax : 0;
            in->max_error = b.max_err;
            in->nodata = b.nodata;
            r = hz_pyr_writer_finish(b.w, in, err);
        } else {
            hz_pyr_writer_abort(b.w);
        }
        b.w = NULL;
    }
done:
    if (r == HZ_OK && stats) {
        *stats = (hz_pyr_import_stats){.samples = (uint64_t)in->size * in->size, .max_error = b.max_err,
                                       .finish_bytes = b.finish_bytes};
        hz_pyramid *p = NULL;
        hz_err e2 = {0};
        if (!d->tiles && hz_pyramid_open(d->out, &p, &e2) == HZ_OK) {
            stats->tiles = hz_pyramid_info(p)->tiles;
            stats->bytes = hz_pyramid_info(p)->file_bytes;
            hz_pyramid_close(p);
        }
    }
    if (stats)
        stats->ms = hz_time_ms() - t0;
    free(b.gj);
    free(b.gjv);
    narr_free(&b.nJ);
    free(b.wkt);
    hz_io_src_close(b.src);
    hz_gen_window_close(b.gen);
    return r;
}
