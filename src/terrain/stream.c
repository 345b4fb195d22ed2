/* Streaming a pyramid: the tile cache, the loader thread and the cdlod
 * selection over resident tiles (see horizon/stream.h).
 *
 * Nodes are (shift s, ix, iz): P x P cells of level s, drawn from the tile of
 * level s that holds them. The selection is lod_cdlod.c's (level by level from
 * the root, splits by distance to the box against the range of the nested
 * error bound, forced splits keep the quadtree restricted), with one more
 * rule: a node splits only when the tile holding its children is resident,
 * and when every forced split that needs is possible too; otherwise it is
 * drawn as it is and the missing tile is asked for. Flags live in the tile
 * records (only nodes visited this frame are read, as in lod_node.c).
 *
 * Cache: a fixed number of slots (one GPU layer each). A request takes the
 * least recently used slot not used this frame. The loader thread reads,
 * checks and decodes a tile and builds its texels; the main thread hands them
 * to the renderer, then the tile is resident. Requests are re-ranked every
 * frame (largest range / distance first: the tile that would cut the most
 * screen error), and tiles are asked for before they are needed (PREFETCH
 * times the split range) so they usually arrive in time. */
#include "lod_internal.h"

#include "horizon/stream.h"

#include <math.h>
#include <pthread.h>
#include <stdio.h>

#define NEVER 65535u
#define PREFETCH 1.5f
#define MAX_INFLIGHT 16u
#define MAX_LOADERS 16u
/* a leaf flag (bit 6; bits 0-1 are ST_*, 2-5 the don't-care edges): the LOD
 * wanted this node split, and a tile it needs was not resident */
#define ST_LATE 0x40u

enum { SLOT_FREE = 0, SLOT_LOADING, SLOT_READY, SLOT_RESIDENT, SLOT_FAILED };

typedef struct slot {
    uint32_t level, tx, tz;
    int state;
    uint64_t used;        /* frame of last use */
    uint32_t k;           /* nodes per side */
    uint16_t *nd;         /* (k+2)^2: bounds of its nodes and of the ring around it */
    uint16_t *mn, *mx;    /* k^2 each */
    int32_t anc[HZ_PYR_MAX_LEVELS]; /* slots of its ancestors by level (-1: none) */
    uint32_t children;    /* slots of its child tiles in use (it is not evicted while > 0) */
    uint8_t *flags;       /* k^2 */
    uint16_t *texels;     /* while READY */
    uint16_t *h;          /* (c+1)^2 heights (height queries) */
    uint8_t *v;           /* (c+1)^2 validity, NULL when every sample has data */
    float prio;
    bool queued;
    double born;          /* clock of the first selection that could use it (NAN: not yet) */
    bool warm;            /* loaded at creation: there from the first frame, never slides */
} slot;

typedef struct req {
    uint32_t level, tx, tz;
    float prio;
} req;

struct hz_stream {
    hz_pyramid *pyr;
    hz_pyr_info info;
    uint32_t nslots, T;
    slot *slots;
    int32_t *hash;        /* open addressing: slot index or -1 */
    uint32_t hash_cap;
    uint64_t frame;
    /* loader */
    pthread_t th[MAX_LOADERS]; /* one for a file; several for a URL (requests in flight) */
    uint32_t nth;
    bool has_thread, quit, sync;
    pthread_mutex_t lock;
    pthread_cond_t cv, idle;
    uint32_t warm;        /* slots loaded at creation */
    uint32_t *queue;      /* slot indices to load, best first */
    uint32_t qn, busy;
    /* per frame */
    req *reqs;
    size_t nreq, req_cap;
    /* this selection's nodes per shift; once classified, their slot (-1: not
     * yet), index in it, squared distance to the eye and image (wrap) */
    struct lv_node { uint32_t x, z; int32_t slot; uint32_t li; float d2; int8_t img[2]; } *lv[HZ_PYR_MAX_LEVELS];
    size_t lv_n[HZ_PYR_MAX_LEVELS], lv_cap[HZ_PYR_MAX_LEVELS];
    hz_patch *tmp;
    size_t tmp_cap;
    hz_stream_stats st;
    char warning[640];
    uint32_t side[HZ_PYR_MAX_LEVELS]; /* nodes per side per shift */
    uint32_t node_k[HZ_PYR_MAX_LEVELS]; /* nodes per tile side per level (a power of two) */
    uint32_t node_k_log2[HZ_PYR_MAX_LEVELS];
    slot *memo[HZ_PYR_MAX_LEVELS];      /* last slot found per level (node_slot) */
    double slide;         /* seconds a tile takes to slide in; 0: off */
    double clock, now;    /* hz_stream_set_clock (NAN: monotonic); this selection's */
    double newest;        /* the latest born: nothing slides once now >= newest + slide */
};

/* ---- tile keys ---- */

static uint32_t key_hash(uint32_t l, uint32_t tx, uint32_t tz)
{
    uint64_t k = ((uint64_t)l << 48) ^ ((uint64_t)tx << 24) ^ tz;
    k *= 0x9e3779b97f4a7c15ULL;
    return (uint32_t)(k >> 32);
}

static int32_t find_slot(const hz_stream *s, uint32_t l, uint32_t tx, uint32_t tz)
{
    for (uint32_t h = key_hash(l, tx, tz) & (s->hash_cap - 1);; h = (h + 1) & (s->hash_cap - 1)) {
        const int32_t v = s->hash[h];
        if (v == -1)
            return -1;
        if (v >= 0) {
            const slot *q = &s->slots[v];
            if (q->state != SLOT_FREE && q->level == l && q->tx == tx && q->tz == tz)
                return v;
        }
    }
}

static void hash_rebuild(hz_stream *s)
{
    memset(s->memo, 0, sizeof s->memo);
    for (uint32_t h = 0; h < s->hash_cap; h++)
        s->hash[h] = -1;
    for (uint32_t k = 0; k < s->nslots; k++) {
        const slot *q = &s->slots[k];
        if (q->state == SLOT_FREE)
            continue;
        uint32_t h = key_hash(q->level, q->tx, q->tz) & (s->hash_cap - 1);
        while (s->hash[h] != -1)
            h = (h + 1) & (s->hash_cap - 1);
        s->hash[h] = (int32_t)k;
    }
}

/* ---- texels ---- */

static inline uint32_t low_bit(uint32_t v)
{
    return v ? v & (~v + 1u) : 0x80000000u;
}

static inline uint32_t log2u(uint32_t v)
{
    uint32_t r = 0;
    while (v >>= 1)
        r++;
    return r;
}

/* The morph range (h16 steps) of level-0 sample (X, Z): the smallest bound of
 * the one or two nodes whose split brings it in, from the ancestor tile of
 * that level (its nodes and their ring). */
static uint16_t sample_q(const hz_stream *s, const slot *q, uint32_t X, uint32_t Z)
{
    const uint32_t ext = s->info.wrap ? s->info.size - 1 : 0; /* see build_texels */
    if (((X + ext) | (Z + ext)) == 0)
        return NEVER;
    const uint32_t sh = log2u(low_bit((X + ext) | (Z + ext))) + 1, top = s->info.levels - 1;
    if (sh > top || sh <= q->level || q->anc[sh] < 0)
        return NEVER;
    const slot *A = &s->slots[q->anc[sh]];
    const uint32_t G = s->info.patch_cells << sh, side = s->side[sh], kA = A->k;
    const int64_t ox = (int64_t)A->tx * kA, oz = (int64_t)A->tz * kA;
    /* on a repeating terrain the nodes across the seam are the ancestor's ring */
    const bool wrap = s->info.wrap;
    int64_t cx[2] = {X / G, X / G}, cz[2] = {Z / G, Z / G};
    if (X % G == 0)
        cx[0]--;
    if (Z % G == 0)
        cz[0]--;
    uint16_t r = NEVER;
    for (int u = 0; u < 2; u++)
        for (int v = 0; v < 2; v++) {
            if (!wrap && (cx[u] < 0 || cz[v] < 0 || cx[u] >= side || cz[v] >= side))
                continue;
            const int64_t lx = cx[u] - ox, lz = cz[v] - oz;
            if (lx < -1 || lz < -1 || lx > kA || lz > kA)
                continue;
            const uint16_t d = A->nd[(size_t)(lz + 1) * (kA + 2) + (size_t)(lx + 1)];
            r = d < r ? d : r;
        }
    return r;
}

/* Height (h16) and validity of level-0 sample (X, Z) from slot q's tile, if it holds it. */
static bool slot_h(const hz_stream *s, const slot *q, int64_t Xs, int64_t Zs, uint32_t *h, bool *valid)
{
    const int64_t per = (int64_t)s->info.size - 1;
    if (s->info.wrap)
        Xs = ((Xs % per) + per) % per, Zs = ((Zs % per) + per) % per;
    if (Xs < 0 || Zs < 0 || Xs > per || Zs > per)
        return false;
    const uint32_t X = (uint32_t)Xs, Z = (uint32_t)Zs;
    const uint32_t l = q->level, c = hz_pyr_level_cells(&s->info, l);
    const uint32_t x0 = (q->tx * c) << l, z0 = (q->tz * c) << l;
    if (X < x0 || Z < z0 || ((X - x0) & ((1u << l) - 1)) || ((Z - z0) & ((1u << l) - 1)))
        return false;
    const uint32_t a = (X - x0) >> l, b = (Z - z0) >> l;
    if (a > c || b > c)
        return false;
    *h = q->h[(size_t)b * (c + 1) + a];
    *valid = !q->v || q->v[(size_t)b * (c + 1) + a];
    return true;
}

static uint16_t *build_texels(const hz_stream *s, const slot *q, const hz_pyr_tile *t)
{
    /* A repeating terrain works in coordinates shifted by one period, so
     * that the samples on both sides of the seam are neighbours (the import
     * does the same). */
    const uint32_t ext = s->info.wrap ? s->info.size - 1 : 0;
    /* texels: (T + 3)^2, sample (a, b) at (a + 1, b + 1); the border holds the apron */
    const uint32_t c = t->cells, n = c + 1, T1 = s->T + 3, N = s->info.wrap ? 3 * ext + 1 : s->info.size, l = t->level;
    const uint32_t top = s->info.levels - 1;
    uint16_t *tex = calloc((size_t)T1 * T1 * 4, sizeof *tex);
    if (!tex)
        return NULL;
    for (uint32_t b = 0; b < n; b++)
        for (uint32_t a = 0; a < n; a++) {
            const uint32_t X = t->x0 + (a << l), Z = t->z0 + (b << l);
            const size_t k = (size_t)b * n + a;
            uint32_t t2 = 2u * t->h[k];
            uint32_t ni[2], nj[2];
            if (hz__morph_neighbours(N, X + ext, Z + ext, ni, nj)) {
                uint32_t la[2], lb[2];
                bool inside = true;
                int64_t pi[2], pj[2]; /* the neighbours, unshifted */
                for (int e = 0; e < 2; e++)
                    pi[e] = (int64_t)ni[e] - ext, pj[e] = (int64_t)nj[e] - ext;
                for (int e = 0; e < 2 && inside; e++) {
                    inside = pi[e] >= t->x0 && pj[e] >= t->z0 && ((pi[e] - t->x0) >> l) <= c &&
                             ((pj[e] - t->z0) >> l) <= c;
                    if (inside)
                        la[e] = (uint32_t)((pi[e] - t->x0) >> l), lb[e] = (uint32_t)((pj[e] - t->z0) >> l);
                }
                /* Next to a sample without data (the import's fill height, sea level
                 * or the lowest), the vertex does not morph: its target is itself.
                 * Validity is the same in every tile, so is the target. */
                if (inside && t->valid &&
                    !(t->valid[(size_t)lb[0] * n + la[0]] && t->valid[(size_t)lb[1] * n + la[1]])) {
                    t2 = 2u * t->h[k];
                } else if (inside) {
                    t2 = (uint32_t)t->h[(size_t)lb[0] * n + la[0]] + t->h[(size_t)lb[1] * n + la[1]];
                } else {
                    /* a tile corner: its neighbours are on the grid of the
                     * level of its lowest bit, where an ancestor holds them */
                    uint32_t L = log2u(low_bit((X + ext) | (Z + ext)));
                    L = L > top ? top : L;
                    uint32_t h0, h1;
                    bool v0, v1;
                    if (L > l && q->anc[L] >= 0 && slot_h(s, &s->slots[q->anc[L]], pi[0], pj[0], &h0, &v0) &&
                        slot_h(s, &s->slots[q->anc[L]], pi[1], pj[1], &h1, &v1))
                        t2 = v0 && v1 ? h0 + h1 : 2u * t->h[k];
                }
            }
            uint16_t *o = tex + ((size_t)(b + 1) * T1 + a + 1) * 4;
            o[0] = t->h[k];
            o[1] = sample_q(s, q, X, Z);
            o[2] = (uint16_t)(t2 & 0xffffu);
            o[3] = (uint16_t)((t2 >> 16) | (t->valid && !t->valid[k] ? 2u : 0u));
        }
    size_t na = 0; /* the apron: heights only (normals read them, nothing is drawn there) */
    for (uint32_t b = 0; b < n + 2; b++)
        for (uint32_t a = 0; a < n + 2; a++) {
            if (b >= 1 && b <= n && a >= 1 && a <= n)
                continue;
            tex[((size_t)b * T1 + a) * 4] = t->apron[na++];
        }
    return tex;
}

/* ---- loading ---- */

static void slot_clear(slot *q)
{
    free(q->nd);
    free(q->texels);
    free(q->h);
    q->nd = q->mn = q->mx = NULL;
    q->flags = NULL;
    q->texels = NULL;
    q->h = NULL;
    q->v = NULL;
}

/* Reads slot k's tile (called without the lock; the slot is LOADING and
 * owned by the loader until it leaves that state). */
static void load_one(hz_stream *s, uint32_t k)
{
    slot *q = &s->slots[k];
    hz_pyr_tile t;
    hz_err e = {0};
    hz_result r = hz_pyramid_read_tile(s->pyr, q->level, q->tx, q->tz, &t, &e);
    uint16_t *tex = NULL, *nd = NULL, *h = NULL;
    uint8_t *v = NULL;
    if (r == HZ_OK) {
        tex = build_texels(s, q, &t);
        const size_t kk = (size_t)t.nodes * t.nodes, k2 = (size_t)(t.nodes + 2) * (t.nodes + 2);
        const size_t nn = (size_t)(t.cells + 1) * (t.cells + 1);
        nd = malloc((k2 + 2 * kk) * sizeof *nd + kk);
        h = malloc(nn * sizeof *h + (t.valid ? nn : 0)); /* heights, then validity when masked */
        if (tex && nd && h) {
            memcpy(nd, t.node_delta, (k2 + 2 * kk) * sizeof *nd);
            memcpy(h, t.h, nn * sizeof *h);
            if (t.valid) {
                v = (uint8_t *)(h + nn);
                memcpy(v, t.valid, nn);
            }
        } else {
            r = hz_err_set(&e, HZ_ERR_MEMORY, "out of memory loading a tile");
        }
        hz_pyr_tile_free(&t);
    }
    pthread_mutex_lock(&s->lock);
    if (r == HZ_OK) {
        const size_t kk = (size_t)q->k * q->k, k2 = (size_t)(q->k + 2) * (q->k + 2);
        q->nd = nd, q->mn = nd + k2, q->mx = nd + k2 + kk, q->flags = (uint8_t *)(nd + k2 + 2 * kk);
        memset(q->flags, 0, kk);
        q->texels = tex;
        q->h = h;
        q->v = v;
        q->state = SLOT_READY;
    } else {
        free(tex);
        free(nd);
        free(h);
        q->state = SLOT_FAILED;
        if (!s->warning[0])
            snprintf(s->warning, sizeof s->warning, "%.500s; drawing the coarser level there", e.msg);
    }
    pthread_mutex_unlock(&s->lock);
}

static void *loader(void *arg)
{
    hz_stream *s = arg;
    pthread_mutex_lock(&s->lock);
    for (;;) {
        while (!s->quit && s->qn == 0) {
            pthread_cond_broadcast(&s->idle);
            pthread_cond_wait(&s->cv, &s->lock);
        }
        if (s->quit)
            break;
        const uint32_t k = s->queue[0];
        memmove(s->queue, s->queue + 1, (s->qn - 1) * sizeof *s->queue);
        s->qn--;
        s->slots[k].queued = false;
        s->busy++;
        if (s->qn > 0) /* the selection signals one loader: wake the next one */
            pthread_cond_signal(&s->cv);
        pthread_mutex_unlock(&s->lock);
        load_one(s, k);
        pthread_mutex_lock(&s->lock);
        s->busy--;
    }
    pthread_mutex_unlock(&s->lock);
    return NULL;
}

/* ---- creation ---- */

hz_stream *hz_stream_create(const hz_stream_desc *d, hz_err *err)
{
    hz_stream *s = calloc(1, sizeof *s);
    if (!s) {
        hz_err_set(err, HZ_ERR_MEMORY, "out of memory");
        return NULL;
    }
    pthread_mutex_init(&s->lock, NULL);
    pthread_cond_init(&s->cv, NULL);
    pthread_cond_init(&s->idle, NULL);
    if (hz_pyramid_open_with(d->path, &d->remote, &s->pyr, err) != HZ_OK) {
        hz_stream_destroy(s);
        return NULL;
    }
    s->info = *hz_pyramid_info(s->pyr);
    s->T = hz_pyr_level_cells(&s->info, 0);
    const uint64_t tile_bytes = (uint64_t)(s->T + 3) * (s->T + 3) * 8;
    const uint64_t want = d->cache_bytes ? d->cache_bytes : (256ull << 20);
    uint64_t n = want / tile_bytes, total = s->info.tiles;
    const uint64_t minimum = 8ull * s->info.levels;
    if (n < minimum)
        n = minimum;
    if (n > total)
        n = total;
    if (n > 65535) /* layer index: 16 bits */
        n = 65535;
    if (d->max_slots && n > d->max_slots) /* what the GPU's array texture holds */
        n = d->max_slots;
    s->nslots = (uint32_t)n;
    s->hash_cap = 1;
    while (s->hash_cap < 2 * s->nslots + 2)
        s->hash_cap *= 2;
    s->slots = calloc(s->nslots, sizeof *s->slots);
    s->hash = malloc(s->hash_cap * sizeof *s->hash);
    s->queue = malloc(s->nslots * sizeof *s->queue);
    if (!s->slots || !s->hash || !s->queue) {
        hz_err_set(err, HZ_ERR_MEMORY, "out of memory for a %u-tile cache", s->nslots);
        hz_stream_destroy(s);
        return NULL;
    }
    for (uint32_t l = 0; l < s->info.levels; l++) {
        s->side[l] = (s->info.size - 1) / (s->info.patch_cells << l);
        s->node_k[l] = hz_pyr_level_cells(&s->info, l) / s->info.patch_cells;
        s->node_k_log2[l] = log2u(s->node_k[l]);
    }
    hash_rebuild(s);
    /* Warm start: the coarsest levels (at most 4 tiles each) load now, so the
     * first frame already has the whole terrain, coarse. */
    for (uint32_t l = s->info.levels; l-- > 0;) {
        const uint32_t m = hz_pyr_level_tiles(&s->info, l);
        if (m > 2)
            break;
        for (uint32_t tz = 0; tz < m; tz++)
            for (uint32_t tx = 0; tx < m; tx++) {
                const uint32_t k = s->warm++;
                if (k >= s->nslots)
                    break;
                slot *q = &s->slots[k];
                *q = (slot){.level = l, .tx = tx, .tz = tz, .state = SLOT_LOADING,
                            .k = hz_pyr_level_cells(&s->info, l) / s->info.patch_cells, .warm = true};
                for (uint32_t L = 0; L < HZ_PYR_MAX_LEVELS; L++)
                    q->anc[L] = -1;
                if (l + 1 < s->info.levels) {
                    const int32_t p = find_slot(s, l + 1, tx / 2, tz / 2);
                    if (p >= 0) {
                        memcpy(q->anc, s->slots[p].anc, sizeof q->anc);
                        q->anc[l + 1] = p;
                        s->slots[p].children++;
                    }
                }
                hash_rebuild(s);
                load_one(s, k);
            }
    }
    s->slide = d->slide_seconds < 0 ? 0.0 : (d->slide_seconds > 0 ? d->slide_seconds : 0.5);
    s->clock = NAN;
    s->sync = d->synchronous;
    if (!s->sync) {
        uint32_t nl = d->loaders;
        if (!nl)
            nl = !hz_pyramid_is_remote(s->pyr) ? 1 : d->remote.connections ? d->remote.connections : 8;
        nl = nl < MAX_LOADERS ? nl : MAX_LOADERS;
        while (s->nth < nl && pthread_create(&s->th[s->nth], NULL, loader, s) == 0)
            s->nth++;
        if (s->nth == 0)
            s->sync = true; /* loads on the caller's thread: slower, same result */
        else
            s->has_thread = true;
    }
    return s;
}

void hz_stream_destroy(hz_stream *s)
{
    if (!s)
        return;
    if (s->has_thread) {
        pthread_mutex_lock(&s->lock);
        s->quit = true;
        pthread_cond_broadcast(&s->cv);
        pthread_mutex_unlock(&s->lock);
        for (uint32_t k = 0; k < s->nth; k++)
            pthread_join(s->th[k], NULL);
    }
    for (uint32_t k = 0; s->slots && k < s->nslots; k++)
        slot_clear(&s->slots[k]);
    free(s->slots);
    free(s->hash);
    free(s->queue);
    free(s->reqs);
    free(s->tmp);
    for (uint32_t l = 0; l < HZ_PYR_MAX_LEVELS; l++)
        free(s->lv[l]);
    hz_pyramid_close(s->pyr);
    pthread_mutex_destroy(&s->lock);
    pthread_cond_destroy(&s->cv);
    pthread_cond_destroy(&s->idle);
    free(s);
}

const hz_pyramid *hz_stream_pyramid(const hz_stream *s)
{
    return s->pyr;
}

const hz_pyr_info *hz_stream_info(const hz_stream *s)
{
    return &s->info;
}

uint32_t hz_stream_slots(const hz_stream *s)
{
    return s->nslots;
}

uint32_t hz_stream_texels(const hz_stream *s)
{
    return s->T + 3;
}

/* ---- selection ---- */

typedef struct sel {
    hz_stream *s;
    const hz_camera *cam;
    vec4 planes[6];
    float margin, lambda, hsw, spacing;
    float rho, d0; /* the near bound (cd_range) */
    bool no_cull;
    uint32_t cur; /* shift being processed */
    hz_lod_stats *st;
} sel;

static inline uint32_t tile_of(const hz_stream *s, uint32_t sh, uint32_t i, uint32_t *loc)
{
    const uint32_t k = hz_pyr_level_cells(&s->info, sh) / s->info.patch_cells;
    *loc = i % k;
    return i / k;
}

/* node_slot's miss: the hash lookup, remembered in the level's memo. */
static __attribute__((noinline)) slot *node_slot_find(hz_stream *s, uint32_t sh, uint32_t tx, uint32_t tz)
{
    const int32_t f = find_slot(s, sh, tx, tz);
    if (f < 0 || s->slots[f].state != SLOT_RESIDENT)
        return NULL;
    slot *q = &s->slots[f];
    s->memo[sh] = q;
    q->used = s->frame;
    return q;
}

/* The resident slot of node (sh, ix, iz)'s tile, or NULL. Consecutive
 * lookups mostly hit the same tile: the last slot per level is tried first. */
static inline slot *node_slot(hz_stream *s, uint32_t sh, uint32_t ix, uint32_t iz, size_t *li)
{
    const uint32_t k = s->node_k[sh], kl = s->node_k_log2[sh];
    const uint32_t tx = ix >> kl, tz = iz >> kl;
    slot *q = s->memo[sh];
    if (__builtin_expect(!q || q->tx != tx || q->tz != tz || q->level != sh || q->state != SLOT_RESIDENT, 0)) {
        q = node_slot_find(s, sh, tx, tz);
        if (!q)
            return NULL;
    }
    *li = ((size_t)(iz & (k - 1)) << kl) + (ix & (k - 1));
    return q;
}

static void want_tile(hz_stream *s, uint32_t sh, uint32_t ix, uint32_t iz, float prio)
{
    uint32_t lx, lz;
    const uint32_t tx = tile_of(s, sh, ix, &lx), tz = tile_of(s, sh, iz, &lz);
    const int32_t k = find_slot(s, sh, tx, tz);
    if (k >= 0) {
        slot *q = &s->slots[k];
        q->used = s->frame;
        if (q->state == SLOT_LOADING && q->prio < prio)
            q->prio = prio;
        return;
    }
    for (size_t r = 0; r < s->nreq; r++)
        if (s->reqs[r].level == sh && s->reqs[r].tx == tx && s->reqs[r].tz == tz) {
            if (s->reqs[r].prio < prio)
                s->reqs[r].prio = prio;
            return;
        }
    if (list_reserve((void **)&s->reqs, &s->req_cap, s->nreq + 1, sizeof *s->reqs) == HZ_OK)
        s->reqs[s->nreq++] = (req){sh, tx, tz, prio};
}

/* The node's box; on a repeating terrain, its copy nearest the eye (the
 * shift in periods goes to img, when given). */
static void node_box_img(const sel *c, const slot *q, size_t li, uint32_t sh, uint32_t ix, uint32_t iz, vec3 box[2],
                         int img[2])
{
    const float G = (float)(c->s->info.patch_cells << sh) * c->spacing;
    const hz_pyr_info *in = &c->s->info;
    box[0][0] = (float)ix * G, box[1][0] = (float)(ix + 1) * G;
    box[0][2] = (float)iz * G, box[1][2] = (float)(iz + 1) * G;
    box[0][1] = (float)(in->h_offset + in->h_scale * q->mn[li]);
    box[1][1] = (float)(in->h_offset + in->h_scale * q->mx[li]);
    int w[2] = {0, 0};
    if (in->wrap) {
        const float E = (float)(in->size - 1) * c->spacing;
        for (int a = 0; a < 2; a++) {
            const int k = a ? 2 : 0;
            const float e = c->cam->pos[k];
            float best = INFINITY;
            for (int t = -1; t <= 1; t++) {
                const float lo = box[0][k] + (float)t * E, hi = box[1][k] + (float)t * E;
                const float d = e < lo ? lo - e : (e > hi ? e - hi : 0.0f);
                if (d < best) {
                    best = d;
                    w[a] = t;
                }
            }
            box[0][k] += (float)w[a] * E;
            box[1][k] += (float)w[a] * E;
        }
    }
    if (img)
        img[0] = w[0], img[1] = w[1];
    hz_camera_curve_box(c->cam, box); /* as drawn: lowered by the Earth curvature */
}


static hz_result lv_add(hz_stream *s, uint32_t sh, uint32_t x, uint32_t z)
{
    if (list_reserve((void **)&s->lv[sh], &s->lv_cap[sh], s->lv_n[sh] + 1, sizeof *s->lv[sh]) != HZ_OK)
        return HZ_ERR_MEMORY;
    s->lv[sh][s->lv_n[sh]] = (struct lv_node){.x = x, .z = z, .slot = -1};
    s->lv_n[sh]++;
    return HZ_OK;
}

/* The four same-level neighbours of (sh, ix, iz) (NB_*, as neighbour_of,
 * by dir): its parent is looked up once. */
static void neighbours(hz_stream *s, uint32_t sh, uint32_t ix, uint32_t iz, uint8_t nb[4])
{
    const uint32_t side = s->side[sh], top = s->info.levels - 1;
    if (sh == top) { /* the root: the map's edge, or, repeating, its own copy (always split) */
        for (int d = 0; d < 4; d++)
            nb[d] = s->info.wrap ? NB_EXISTS : NB_DONTCARE;
        return;
    }
    const uint32_t px = ix / 2, pz = iz / 2;
    const uint32_t pside = s->side[sh + 1]; /* across the seam of a repeating terrain */
    size_t pl;
    slot *ps = NULL;
    bool looked = false;
    for (int dir = 0; dir < 4; dir++) {
        if (!s->info.wrap) {
            const bool edge = dir == DIR_W ? ix == 0 : dir == DIR_E ? ix + 1 == side : dir == DIR_N ? iz == 0
                                                                                                  : iz + 1 == side;
            if (edge) {
                nb[dir] = NB_DONTCARE;
                continue;
            }
        }
        bool sibling;
        uint32_t qx = px, qz = pz;
        switch (dir) {
        case DIR_W: sibling = ix & 1; qx = px - 1; break;
        case DIR_E: sibling = !(ix & 1); qx = px + 1; break;
        case DIR_N: sibling = iz & 1; qz = pz - 1; break;
        default:    sibling = !(iz & 1); qz = pz + 1; break;
        }
        if (sibling) {
            nb[dir] = NB_EXISTS;
            continue;
        }
        if (!looked) {
            ps = node_slot(s, sh + 1, px, pz, &pl);
            looked = true;
        }
        if (!ps || (ps->flags[pl] & (1u << (DC_SHIFT + dir)))) {
            nb[dir] = NB_DONTCARE;
            continue;
        }
        qx = (qx + pside) % pside, qz = (qz + pside) % pside;
        size_t ql;
        slot *qs = node_slot(s, sh + 1, qx, qz, &ql);
        if (!qs) {
            nb[dir] = NB_DONTCARE;
            continue;
        }
        const uint8_t qf = qs->flags[ql] & ST_MASK;
        nb[dir] = qf == ST_SPLIT ? NB_EXISTS : (qf == ST_CULLED ? NB_DONTCARE : NB_ABSENT);
    }
}

/* Marks node (sh, ix, iz) culled or a leaf; its slot, index and box go to
 * qo, lio and box. */
static hz_result classify_at(sel *c, uint32_t sh, uint32_t ix, uint32_t iz, bool *culled, slot **qo, size_t *lio,
                             vec3 box[2], int img[2])
{
    size_t li = 0;
    slot *q = node_slot(c->s, sh, ix, iz, &li);
    *culled = false;
    *qo = q;
    *lio = li;
    if (!q) /* cannot happen: a node is only pushed when its tile is resident */
        return HZ_ERR_VALUE;
    c->st->nodes_visited++;
    node_box_img(c, q, li, sh, ix, iz, box, img);
    /* On a repeating terrain a node of half a period or more has no one
     * copy nearest the eye: it is never culled, and always split. */
    const bool whole = c->s->info.wrap && sh + 1 >= c->s->info.levels - 1;
    if (!c->no_cull && !whole && box_outside((const vec3 *)box, (const vec4 *)c->planes, c->margin)) {
        q->flags[li] = ST_CULLED;
        c->st->nodes_culled++;
        *culled = true;
        return HZ_OK;
    }
    q->flags[li] = ST_LEAF;
    return HZ_OK;
}


/* Remembers a classified node's slot, index, squared distance and image in its
 * entry of the level list (emit reads them back). */
static void lv_note(sel *c, struct lv_node *e, const slot *q, size_t li, const vec3 box[2], const int img[2])
{
    e->slot = (int32_t)(q - c->s->slots);
    e->li = (uint32_t)li;
    e->d2 = box_distance2(box, c->cam->pos);
    e->img[0] = (int8_t)img[0], e->img[1] = (int8_t)img[1];
}

/* Can node (sh, ix, iz), a leaf, split with every forced split it needs?
 * Asks for every tile missing for that (at priority prio): the tile of a
 * forced split is not always one its own node prefetches (a flat neighbour
 * has a short range), and without asking the node would stay coarser.
 * child: at depth 0, whether the caller found the children's tile resident.
 * nb (may be NULL) receives the node's four neighbours. */
static bool can_split(hz_stream *s, uint32_t sh, uint32_t ix, uint32_t iz, uint32_t depth, float prio, bool child,
                      uint8_t *nb)
{
    if (sh == 0 || depth > HZ_PYR_MAX_LEVELS)
        return false;
    size_t li;
    bool ok = true;
    if (depth == 0 ? !child : !node_slot(s, sh - 1, 2 * ix, 2 * iz, &li)) {
        want_tile(s, sh - 1, 2 * ix, 2 * iz, prio);
        ok = false;
    }
    uint8_t own[4];
    if (!nb)
        nb = own;
    neighbours(s, sh, ix, iz, nb);
    for (int dir = 0; dir < 4; dir++) {
        if (nb[dir] != NB_ABSENT)
            continue;
        uint32_t qx = ix / 2, qz = iz / 2;
        const uint32_t pside = s->side[sh + 1];
        switch (dir) {
        case DIR_W: qx = (qx + pside - 1) % pside; break;
        case DIR_E: qx = (qx + 1) % pside; break;
        case DIR_N: qz = (qz + pside - 1) % pside; break;
        default: qz = (qz + 1) % pside; break;
        }
        if (!can_split(s, sh + 1, qx, qz, depth + 1, prio, false, NULL))
            ok = false;
    }
    return ok;
}

/* Splits (sh, ix, iz) and, first, the coarser neighbours it needs split.
 * known: its four neighbours as can_split found them, or NULL. */
static hz_result split_node(sel *c, uint32_t sh, uint32_t ix, uint32_t iz, bool forced, const uint8_t *known)
{
    hz_stream *s = c->s;
    uint8_t f = ST_SPLIT, all[4];
    if (!known) {
        neighbours(s, sh, ix, iz, all);
        known = all;
    }
    for (int dir = 0; dir < 4; dir++) {
        const uint8_t nb = known[dir];
        if (nb == NB_ABSENT) {
            uint32_t qx = ix / 2, qz = iz / 2;
            const uint32_t pside = s->side[sh + 1];
            switch (dir) {
            case DIR_W: qx = (qx + pside - 1) % pside; break;
            case DIR_E: qx = (qx + 1) % pside; break;
            case DIR_N: qz = (qz + pside - 1) % pside; break;
            default: qz = (qz + 1) % pside; break;
            }
            hz_result r = split_node(c, sh + 1, qx, qz, true, NULL);
            if (r != HZ_OK)
                return r;
        } else if (nb == NB_DONTCARE) {
            f |= (uint8_t)(1u << (DC_SHIFT + dir));
        }
    }
    size_t li;
    slot *q = node_slot(s, sh, ix, iz, &li);
    if (!q)
        return HZ_ERR_VALUE;
    q->flags[li] = f;
    if (forced)
        c->st->forced++;
    for (uint32_t k = 0; k < 4; k++) {
        const uint32_t cx = 2 * ix + (k & 1), cz = 2 * iz + (k >> 1);
        if (lv_add(s, sh - 1, cx, cz) != HZ_OK)
            return HZ_ERR_MEMORY;
        if (sh - 1 > c->cur) {
            bool culled;
            slot *cq;
            size_t cl;
            vec3 cb[2];
            int ci[2];
            hz_result r = classify_at(c, sh - 1, cx, cz, &culled, &cq, &cl, cb, ci);
            if (r != HZ_OK)
                return r;
            lv_note(c, &s->lv[sh - 1][s->lv_n[sh - 1] - 1], cq, cl, (const vec3 *)cb, ci);
        }
    }
    return HZ_OK;
}

static void release(hz_stream *s, slot *q)
{
    if (q->level + 1 < s->info.levels && q->anc[q->level + 1] >= 0) {
        slot *p = &s->slots[q->anc[q->level + 1]];
        if (p->children > 0)
            p->children--;
    }
    slot_clear(q);
    q->state = SLOT_FREE;
}

/* The next requests to load, best first; cancels waiting ones that fell out. */
static void issue_requests(hz_stream *s)
{
    pthread_mutex_lock(&s->lock);
    /* re-rank what waits: drop waiting loads nobody asked for this frame */
    uint32_t keep = 0;
    for (uint32_t k = 0; k < s->qn; k++) {
        slot *q = &s->slots[s->queue[k]];
        if (q->used == s->frame) {
            s->queue[keep++] = s->queue[k];
        } else {
            q->queued = false;
            release(s, q);
        }
    }
    bool rehash = keep != s->qn;
    s->qn = keep;
    /* best first */
    for (size_t a = 1; a < s->nreq; a++) {
        req v = s->reqs[a];
        size_t b = a;
        while (b > 0 && s->reqs[b - 1].prio < v.prio) {
            s->reqs[b] = s->reqs[b - 1];
            b--;
        }
        s->reqs[b] = v;
    }
    const uint32_t top = s->info.levels - 1;
    for (size_t r = 0; r < s->nreq && s->qn + s->busy < MAX_INFLIGHT; r++) {
        const req *rq = &s->reqs[r];
        /* its parent must be resident: the loader derives the morph data
         * from the ancestors, which stay while a child is in use */
        int32_t parent = -1;
        if (rq->level < top) {
            parent = find_slot(s, rq->level + 1, rq->tx / 2, rq->tz / 2);
            if (parent < 0 || s->slots[parent].state != SLOT_RESIDENT)
                continue;
        }
        /* a free slot, else the least recently used resident (or failed)
         * one, not used this frame, with no child in use */
        int64_t best = -1;
        for (uint32_t k = 0; k < s->nslots; k++) {
            const slot *q = &s->slots[k];
            if (q->state == SLOT_FREE) {
                best = k;
                break;
            }
            if ((q->state == SLOT_RESIDENT || q->state == SLOT_FAILED) && q->used != s->frame && q->children == 0 &&
                (int64_t)k != parent && (best < 0 || q->used < s->slots[best].used))
                best = k;
        }
        if (best < 0)
            break;
        slot *q = &s->slots[best];
        if (q->state == SLOT_RESIDENT)
            s->st.evicted++;
        if (q->state != SLOT_FREE)
            release(s, q);
        *q = (slot){.level = rq->level, .tx = rq->tx, .tz = rq->tz, .state = SLOT_LOADING, .used = s->frame,
                    .prio = rq->prio, .queued = true, .k = hz_pyr_level_cells(&s->info, rq->level) / s->info.patch_cells};
        for (uint32_t L = 0; L < HZ_PYR_MAX_LEVELS; L++)
            q->anc[L] = -1;
        if (parent >= 0) {
            slot *p = &s->slots[parent];
            memcpy(q->anc, p->anc, sizeof q->anc);
            q->anc[rq->level + 1] = parent;
            p->children++;
        }
        s->queue[s->qn++] = (uint32_t)best;
        s->st.requested++;
        rehash = true;
    }
    if (rehash)
        hash_rebuild(s);
    if (s->qn > 0)
        pthread_cond_signal(&s->cv);
    pthread_mutex_unlock(&s->lock);
    if (s->sync) {
        while (s->qn > 0) {
            const uint32_t k = s->queue[0];
            memmove(s->queue, s->queue + 1, (s->qn - 1) * sizeof *s->queue);
            s->qn--;
            s->slots[k].queued = false;
            load_one(s, k);
        }
    }
}

/* The least morph of a slot's new vertices now (0..255): 255 when it just
 * arrived, 0 once it has slid in. */
static uint8_t slide_of(hz_stream *s, slot *q)
{
    if (s->slide <= 0)
        return 0;
    if (isnan(q->born)) {
        q->born = s->now;
        s->newest = s->now;
    }
    const double f = 1.0 - (s->now - q->born) / s->slide;
    return f <= 0 ? 0 : (f >= 1 ? 255 : (uint8_t)lrint(255.0 * f));
}

/* The least morph along the edge dir of leaf (sh, ix, iz): shared with a
 * leaf of the same level across it (both take the larger), none toward a
 * finer neighbour (its vertices there are its coarse ones, unmorphed), its
 * own otherwise (a coarser neighbour stitches that edge away, or nothing is
 * drawn there). */
static uint8_t slide_edge(hz_stream *s, uint32_t sh, uint32_t ix, uint32_t iz, int dir, uint8_t nb, uint8_t own)
{
    if (nb != NB_EXISTS)
        return own;
    const int64_t side = s->side[sh];
    int64_t nx = ix, nz = iz;
    switch (dir) {
    case DIR_W: nx--; break;
    case DIR_E: nx++; break;
    case DIR_N: nz--; break;
    default: nz++; break;
    }
    if (s->info.wrap)
        nx = (nx + side) % side, nz = (nz + side) % side;
    if (nx < 0 || nz < 0 || nx >= side || nz >= side)
        return own;
    size_t li;
    slot *q = node_slot(s, sh, (uint32_t)nx, (uint32_t)nz, &li);
    if (!q)
        return own;
    const uint8_t f = q->flags[li] & ST_MASK;
    if (f == ST_SPLIT)
        return 0;
    if (f != ST_LEAF)
        return own;
    const uint8_t other = slide_of(s, q);
    return other > own ? other : own;
}

static hz_result emit(sel *c, hz_patch_list *out)
{
    hz_stream *s = c->s;
    const uint32_t P = s->info.patch_cells, top = s->info.levels - 1;
    /* A tile is born the first time one of its nodes is drawn. Once every
     * drawn tile is older than slide seconds nothing slides, and emit skips
     * the per-leaf slide values (most frames). */
    if (s->slide > 0)
        for (uint32_t sh = 0; sh <= top; sh++)
            for (size_t k = 0; k < s->lv_n[sh]; k++) {
                const struct lv_node *e = &s->lv[sh][k];
                slot *q = e->slot >= 0 ? &s->slots[e->slot] : NULL;
                if (q && isnan(q->born) && (q->flags[e->li] & ST_MASK) == ST_LEAF)
                    slide_of(s, q);
            }
    const bool sliding = s->slide > 0 && s->now < s->newest + s->slide;
    out->count = 0;
    for (uint32_t sh = top + 1; sh-- > 0;) {
        if (list_reserve((void **)&out->data, &out->cap, out->count + s->lv_n[sh], sizeof *out->data) != HZ_OK)
            return HZ_ERR_MEMORY;
        for (size_t k = 0; k < s->lv_n[sh]; k++) {
            const struct lv_node *e = &s->lv[sh][k];
            const uint32_t ix = e->x, iz = e->z;
            if (e->slot < 0)
                continue; /* never classified: not drawn */
            slot *q = &s->slots[e->slot];
            const size_t li = e->li;
            if ((q->flags[li] & ST_MASK) != ST_LEAF)
                continue;
            uint8_t coarse = 0, nb[4];
            neighbours(s, sh, ix, iz, nb);
            for (int dir = 0; dir < 4; dir++)
                if (nb[dir] == NB_ABSENT)
                    coarse |= (uint8_t)(1u << dir);
            const int img[2] = {e->img[0], e->img[1]};
            const uint32_t lx = ix & (q->k - 1), lz = iz & (q->k - 1); /* k: a power of two */
            const int64_t per = (int64_t)s->info.size - 1;
            out->data[out->count++] = (hz_patch){
                .x0 = (uint32_t)(int32_t)(((int64_t)ix * P << sh) + img[0] * per),
                .z0 = (uint32_t)(int32_t)(((int64_t)iz * P << sh) + img[1] * per), .shift = (uint8_t)sh, .coarse = coarse,
                .level = (uint16_t)(top - sh), .dist = sqrtf(e->d2),
                .layer1 = (uint32_t)(q - s->slots) + 1, .ox = (uint16_t)(lx * P), .oz = (uint16_t)(lz * P)};
            if (sliding) {
                hz_patch *pt = &out->data[out->count - 1];
                pt->slide = slide_of(s, q);
                for (int dir = 0; dir < 4; dir++)
                    pt->slide_edge[dir] = slide_edge(s, sh, ix, iz, dir, nb[dir], pt->slide);
            }
            c->st->triangles += hz__patch_triangles(P, coarse);
            c->st->leaves++;
            s->st.drawn++;
            if (q->flags[li] & ST_LATE)
                s->st.late++;
            if (top - sh > c->st->max_level)
                c->st->max_level = top - sh;
        }
    }
    return hz__sort_patches(out, &s->tmp, &s->tmp_cap);
}

hz_result hz_stream_select(hz_stream *s, const hz_camera *cam, const hz_lod_params *params, hz_patch_list *out,
                           hz_lod_stats *stats)
{
    const double t0 = hz_time_ms();
    hz_lod_params p = params ? *params : (hz_lod_params){0};
    hz_lod_stats st = {0};
    s->frame++;
    s->nreq = 0;
    s->now = isnan(s->clock) ? hz_time_ms() / 1000.0 : s->clock;
    memset(s->memo, 0, sizeof s->memo);
    out->count = 0;
    const hz_pyr_info *in = &s->info;
    const uint32_t top = in->levels - 1;
    const float tau = p.pixel_error > 0 ? p.pixel_error : 1.0f;
    sel c = {.s = s, .cam = cam, .margin = frustum_margin(cam), .lambda = pixel_k(cam, &p) / tau,
             .hsw = (float)in->h_scale, .spacing = (float)in->spacing, .no_cull = p.no_cull, .st = &st};
    const float a = cd_morph_start(p.morph_start);
    hz_camera_frustum(cam, c.planes);
    st.morph_scale = c.lambda * c.hsw;
    st.morph_start = a;
    cd_near(&p, &c.rho, &c.d0);
    st.morph_near = c.rho;
    st.morph_near_distance = c.d0;
    for (uint32_t l = 0; l <= top; l++)
        s->lv_n[l] = 0;
    hz_result r = HZ_OK;
    size_t li;
    if (!node_slot(s, top, 0, 0, &li)) {
        want_tile(s, top, 0, 0, 1e30f);
    } else {
        r = lv_add(s, top, 0, 0);
        for (uint32_t sh = top + 1; r == HZ_OK && sh-- > 0;) {
            c.cur = sh;
            for (size_t k = 0; r == HZ_OK && k < s->lv_n[sh]; k++) {
                const uint32_t ix = s->lv[sh][k].x, iz = s->lv[sh][k].z;
                bool culled;
                slot *q;
                vec3 box[2];
                int img[2];
                r = classify_at(&c, sh, ix, iz, &culled, &q, &li, box, img);
                if (r == HZ_OK && q)
                    lv_note(&c, &s->lv[sh][k], q, li, (const vec3 *)box, img);
                if (r != HZ_OK || culled || sh == 0)
                    continue;
                const float d2 = s->lv[sh][k].d2;
                const float range = cd_range(
                    c.lambda * (float)q->nd[((li >> s->node_k_log2[sh]) + 1) * (q->k + 2) + (li & (q->k - 1)) + 1] *
                        c.hsw,
                    c.rho, c.d0);
                const bool whole = in->wrap && sh + 1 >= top;
                const bool near = d2 < PREFETCH * PREFETCH * range * range;
                size_t cl;
                /* the children's tile (most often the memo's) */
                const bool child = (near || whole) && node_slot(s, sh - 1, 2 * ix, 2 * iz, &cl);
                if (near && !child) {
                    const float d = sqrtf(d2);
                    want_tile(s, sh - 1, 2 * ix, 2 * iz, range / (d + 1e-3f));
                }
                if (d2 < range * range || whole) {
                    uint8_t nb[4];
                    if (can_split(s, sh, ix, iz, 0, range / (sqrtf(d2) + 1e-3f), child, nb))
                        r = split_node(&c, sh, ix, iz, false, nb);
                    else
                        q->flags[li] |= ST_LATE; /* counted in emit if it stays a leaf */
                }
            }
        }
        if (r == HZ_OK)
            r = emit(&c, out);
    }
    issue_requests(s);
    st.ms = hz_time_ms() - t0;
    if (stats)
        *stats = st;
    return r;
}

void hz_stream_set_clock(hz_stream *s, double seconds)
{
    s->clock = seconds;
}

bool hz_stream_next_upload(hz_stream *s, uint32_t *slot_out, const uint16_t **texels)
{
    bool got = false;
    pthread_mutex_lock(&s->lock);
    for (uint32_t k = 0; k < s->nslots; k++)
        if (s->slots[k].state == SLOT_READY && s->slots[k].texels) {
            *slot_out = k;
            *texels = s->slots[k].texels;
            got = true;
            break;
        }
    pthread_mutex_unlock(&s->lock);
    return got;
}

void hz_stream_uploaded(hz_stream *s, uint32_t k)
{
    pthread_mutex_lock(&s->lock);
    if (k < s->nslots && s->slots[k].state == SLOT_READY) {
        free(s->slots[k].texels);
        s->slots[k].texels = NULL;
        s->slots[k].state = SLOT_RESIDENT;
        s->slots[k].born = s->slots[k].warm ? -1e300 : NAN; /* NAN: set by the first selection that sees it */
        s->st.loaded++;
    }
    pthread_mutex_unlock(&s->lock);
}

void hz_stream_tile_key(const hz_stream *s, uint32_t k, uint32_t *level, uint32_t *tx, uint32_t *tz)
{
    const slot *q = &s->slots[k < s->nslots ? k : 0];
    *level = q->level;
    *tx = q->tx;
    *tz = q->tz;
}

void hz_stream_wait(hz_stream *s)
{
    if (!s->has_thread)
        return;
    pthread_mutex_lock(&s->lock);
    while (s->qn > 0 || s->busy > 0)
        pthread_cond_wait(&s->idle, &s->lock);
    pthread_mutex_unlock(&s->lock);
}

hz_stream_stats hz_stream_take_stats(hz_stream *s)
{
    pthread_mutex_lock(&s->lock);
    hz_stream_stats st = s->st;
    st.resident = 0;
    st.failed = 0;
    for (uint32_t k = 0; k < s->nslots; k++) {
        st.resident += s->slots[k].state == SLOT_RESIDENT;
        st.failed += s->slots[k].state == SLOT_FAILED;
    }
    st.pending = s->qn + s->busy;
    st.cache_bytes = (uint64_t)st.resident * (s->T + 3) * (s->T + 3) * 8;
    memset(&s->st, 0, sizeof s->st);
    pthread_mutex_unlock(&s->lock);
    return st;
}

void hz_stream_wrap_camera(const hz_stream *s, hz_camera *cam)
{
    if (!s->info.wrap)
        return;
    const double E = (double)(s->info.size - 1) * s->info.spacing;
    for (int k = 0; k <= 2; k += 2)
        cam->pos[k] = (float)((double)cam->pos[k] - floor((double)cam->pos[k] / E) * E);
}

const char *hz_stream_warning(hz_stream *s)
{
    return s->warning[0] ? s->warning : NULL;
}

float hz_stream_height_at(hz_stream *s, float x, float z)
{
    const hz_pyr_info *in = &s->info;
    double fx = x / in->spacing, fz = z / in->spacing;
    if (in->wrap) {
        const double per = (double)(in->size - 1);
        fx -= floor(fx / per) * per, fz -= floor(fz / per) * per;
    }
    if (!(fx >= 0 && fz >= 0 && fx <= in->size - 1 && fz <= in->size - 1))
        return NAN;
    const uint32_t X = (uint32_t)(fx + 0.5), Z = (uint32_t)(fz + 0.5);
    for (uint32_t l = 0; l < in->levels; l++) {
        const uint32_t c = hz_pyr_level_cells(in, l), span = c << l;
        const uint32_t tx = X / span < hz_pyr_level_tiles(in, l) ? X / span : hz_pyr_level_tiles(in, l) - 1;
        const uint32_t tz = Z / span < hz_pyr_level_tiles(in, l) ? Z / span : hz_pyr_level_tiles(in, l) - 1;
        const int32_t k = find_slot(s, l, tx, tz);
        if (k < 0 || s->slots[k].state != SLOT_RESIDENT || !s->slots[k].h)
            continue;
        const uint32_t a = ((X - tx * span) + (1u << l) / 2) >> l, b = ((Z - tz * span) + (1u << l) / 2) >> l;
        const uint32_t aa = a > c ? c : a, bb = b > c ? c : b;
        return (float)(in->h_offset + in->h_scale * s->slots[k].h[(size_t)bb * (c + 1) + aa]);
    }
    return NAN;
}
