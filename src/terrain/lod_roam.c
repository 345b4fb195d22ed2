/* roam mode (seed 002, after Duchaineau et al. 1997): a binary triangle tree
 * over the sample grid. The two root triangles split along the diagonal; a
 * triangle (apex a, left l, right r) splits at the midpoint c of its
 * hypotenuse l-r into (c, a, l) and (c, r, a). Triangles sharing a hypotenuse
 * form a diamond and split and merge together; splitting a triangle whose base
 * neighbour is coarser first splits that neighbour (forced split), which keeps
 * the mesh conforming: no T-junction, no crack.
 *
 * Error: every diamond is identified by its split vertex, a grid sample, so
 * one bound per sample suffices: e(T) = |h(c) - (h(l) + h(r)) / 2| +
 * max(e(children)) (Duchaineau's nested wedgie thickness), stored as h16 steps
 * (rounded up, saturating at the height range, which still bounds it).
 *
 * Per frame, starting from last frame's mesh (coherence): every leaf gets the
 * priority p = e K / dist in pixels (dist to its wedgie box; 0 outside the
 * frustum); diamonds whose four children are leaves and whose p <= tau merge
 * (smallest first, cascading upward), then leaves with p > tau split (largest
 * first, their children again if they still exceed tau). A triangle budget
 * stops the splits and keeps merging the smallest diamonds while over it.
 * Leaves outside the frustum are not emitted. */
#include "lod_internal.h"

typedef struct rtri {
    uint32_t a, l, r;    /* sample indices */
    int32_t parent;
    int32_t child;       /* left child; right child = child + 1; -1 = leaf */
    int32_t ln, rn, bn;  /* neighbours across a-l, a-r, l-r (-1: map border) */
    uint32_t gen;        /* bumped when the slot is freed or its children change */
    float prio;          /* this frame's priority, pixels */
    float err_m;         /* nested error bound, metres (0: cannot split) */
    float box[2][3];     /* wedgie box: the vertices' extent, heights +- err_m */
} rtri;

typedef struct heap_item {
    float p;
    int32_t t;
    uint32_t gen;
} heap_item;

typedef struct heap {
    heap_item *a;
    size_t n, cap;
    bool max; /* max-heap (splits) or min-heap (merges) */
} heap;

struct roam_state {
    const hz_lod *lod;
    uint16_t *err;       /* per sample, h16 steps */
    rtri *t;
    size_t n, cap;       /* slots used / allocated */
    int32_t *free_pairs; /* freed child pairs (index of the left one) */
    size_t nfree, free_cap;
    size_t leaves;
    heap split, merge;
};

/* ---- error precomputation ------------------------------------------------- */

typedef struct err_ctx {
    const hz_lod *lod;
    uint16_t *err;
    uint32_t n;
    uint64_t done, total;
} err_ctx;

/* The hypotenuse l-r has a grid sample at its midpoint (both coordinate sums
 * even); the finest triangles (legs of one cell) do not. */
static inline bool can_split(uint32_t n, uint32_t l, uint32_t r)
{
    return ((l % n + r % n) & 1) == 0 && ((l / n + r / n) & 1) == 0;
}

static inline uint32_t midpoint(uint32_t n, uint32_t l, uint32_t r)
{
    return ((l / n + r / n) / 2) * n + (l % n + r % n) / 2;
}

/* Caches a new triangle's error (metres) and wedgie box. */
static void tri_setup(const roam_state *R, rtri *T)
{
    const hz_lod *lod = R->lod;
    const uint32_t n = lod->size;
    T->err_m = can_split(n, T->l, T->r) ? (float)R->err[midpoint(n, T->l, T->r)] * lod->hm->scale * lod->zscale
                                        : 0.0f;
    const uint32_t v[3] = {T->a, T->l, T->r};
    for (int k = 0; k < 3; k++) {
        const uint32_t i = v[k] % n, j = v[k] / n;
        const float p[3] = {(float)i * lod->spacing, hworld(lod, i, j), (float)j * lod->spacing};
        for (int d = 0; d < 3; d++) {
            if (k == 0 || p[d] < T->box[0][d])
                T->box[0][d] = p[d];
            if (k == 0 || p[d] > T->box[1][d])
                T->box[1][d] = p[d];
        }
    }
    T->box[0][1] -= T->err_m;
    T->box[1][1] += T->err_m;
}

static float tri_err(err_ctx *c, uint32_t a, uint32_t l, uint32_t r)
{
    if (!can_split(c->n, l, r))
        return 0.0f;
    const uint32_t m = midpoint(c->n, l, r), n = c->n;
    const float hl = h16(c->lod, l % n, l / n), hr = h16(c->lod, r % n, r / n), hm = h16(c->lod, m % n, m / n);
    float e = fabsf(hm - 0.5f * (hl + hr)) + fmaxf(tri_err(c, m, a, l), tri_err(c, m, r, a));
    float q = ceilf(e);
    uint16_t v = q >= 65535.0f ? 65535 : (uint16_t)q;
    if (v > c->err[m])
        c->err[m] = v;
    if ((++c->done & 0xfffff) == 0 && c->lod->desc.progress)
        c->lod->desc.progress(c->lod->desc.progress_user, "roam error bounds", c->done, c->total);
    return e;
}

/* ---- triangle pool ---------------------------------------------------------- */

static int32_t alloc_pair(roam_state *R)
{
    if (R->nfree)
        return R->free_pairs[--R->nfree];
    if (list_reserve((void **)&R->t, &R->cap, R->n + 2, sizeof *R->t))
        return -1;
    int32_t k = (int32_t)R->n;
    R->t[k].gen = R->t[k + 1].gen = 0;
    R->n += 2;
    return k;
}

static void replace_link(roam_state *R, int32_t who, int32_t old, int32_t now)
{
    if (who < 0)
        return;
    rtri *w = &R->t[who];
    if (w->ln == old)
        w->ln = now;
    else if (w->rn == old)
        w->rn = now;
    else if (w->bn == old)
        w->bn = now;
}

/* New children of every split (forced ones included), for the caller to
 * prioritise. */
typedef struct born {
    int32_t *a;
    size_t n, cap;
} born;

static hz_result born_push(born *b, int32_t t)
{
    if (list_reserve((void **)&b->a, &b->cap, b->n + 1, sizeof *b->a))
        return HZ_ERR_MEMORY;
    b->a[b->n++] = t;
    return HZ_OK;
}

/* Splits leaf ti (and its diamond partner), recording the new triangles. */
static hz_result split_tri(roam_state *R, uint32_t n, int32_t ti, hz_lod_stats *st, born *nb)
{
    if (R->t[ti].child >= 0)
        return HZ_OK;
    int32_t b = R->t[ti].bn;
    if (b >= 0 && R->t[b].bn != ti) {
        /* Coarser base neighbour: split it first; one of its children then
         * shares our hypotenuse. */
        hz_result r = split_tri(R, n, b, st, nb);
        if (r != HZ_OK)
            return r;
        st->forced++;
        b = R->t[ti].bn;
    }
    int32_t tk = alloc_pair(R), bk = -1;
    if (tk < 0)
        return HZ_ERR_MEMORY;
    if (b >= 0 && (bk = alloc_pair(R)) < 0)
        return HZ_ERR_MEMORY;
    rtri *T = &R->t[ti];
    const uint32_t c = midpoint(n, T->l, T->r);
    int32_t L = tk, Rr = tk + 1;
    R->t[L] = (rtri){.a = c, .l = T->a, .r = T->l, .parent = ti, .child = -1, .bn = T->ln, .ln = Rr,
                     .gen = R->t[L].gen + 1};
    R->t[Rr] = (rtri){.a = c, .l = T->r, .r = T->a, .parent = ti, .child = -1, .bn = T->rn, .rn = L,
                      .gen = R->t[Rr].gen + 1};
    replace_link(R, T->ln, ti, L);
    replace_link(R, T->rn, ti, Rr);
    T->child = L;
    T->gen++;
    R->leaves += 1;
    if (b >= 0) {
        rtri *B = &R->t[b];
        int32_t BL = bk, BR = bk + 1;
        R->t[BL] = (rtri){.a = c, .l = B->a, .r = B->l, .parent = b, .child = -1, .bn = B->ln, .ln = BR,
                          .gen = R->t[BL].gen + 1};
        R->t[BR] = (rtri){.a = c, .l = B->r, .r = B->a, .parent = b, .child = -1, .bn = B->rn, .rn = BL,
                          .gen = R->t[BR].gen + 1};
        replace_link(R, B->ln, b, BL);
        replace_link(R, B->rn, b, BR);
        B->child = BL;
        B->gen++;
        R->leaves += 1;
        /* T's left child's right edge (c, l) is B's right child's left edge. */
        R->t[L].rn = BR;
        R->t[BR].ln = L;
        R->t[Rr].ln = BL;
        R->t[BL].rn = Rr;
        if (born_push(nb, BL) || born_push(nb, BR))
            return HZ_ERR_MEMORY;
    } else {
        R->t[L].rn = -1;
        R->t[Rr].ln = -1;
    }
    tri_setup(R, &R->t[L]);
    tri_setup(R, &R->t[Rr]);
    if (b >= 0) {
        tri_setup(R, &R->t[bk]);
        tri_setup(R, &R->t[bk + 1]);
    }
    if (born_push(nb, L) || born_push(nb, Rr))
        return HZ_ERR_MEMORY;
    return HZ_OK;
}

static bool children_leaves(const roam_state *R, int32_t t)
{
    int32_t c = R->t[t].child;
    return c >= 0 && R->t[c].child < 0 && R->t[c + 1].child < 0;
}

/* Merges the diamond of t (t and its base neighbour, whose children are all leaves). */
static void merge_diamond(roam_state *R, int32_t t)
{
    int32_t pair[2] = {t, R->t[t].bn};
    for (int k = 0; k < 2; k++) {
        int32_t p = pair[k];
        if (p < 0)
            continue;
        rtri *P = &R->t[p];
        int32_t L = P->child, Rr = L + 1;
        P->ln = R->t[L].bn;
        P->rn = R->t[Rr].bn;
        replace_link(R, P->ln, L, p);
        replace_link(R, P->rn, Rr, p);
        R->t[L].gen++;
        R->t[Rr].gen++;
        R->t[L].child = R->t[Rr].child = -2; /* freed */
        P->child = -1;
        P->gen++;
        R->free_pairs[R->nfree++] = L;
        R->leaves -= 1;
    }
}

/* ---- heaps ------------------------------------------------------------------- */

static inline bool heap_before(const heap *h, float a, float b)
{
    return h->max ? a > b : a < b;
}

static hz_result heap_push(heap *h, float p, int32_t t, uint32_t gen)
{
    if (list_reserve((void **)&h->a, &h->cap, h->n + 1, sizeof *h->a))
        return HZ_ERR_MEMORY;
    size_t i = h->n++;
    while (i > 0) {
        size_t up = (i - 1) / 2;
        if (!heap_before(h, p, h->a[up].p))
            break;
        h->a[i] = h->a[up];
        i = up;
    }
    h->a[i] = (heap_item){p, t, gen};
    return HZ_OK;
}

static heap_item heap_pop(heap *h)
{
    heap_item top = h->a[0], last = h->a[--h->n];
    size_t i = 0;
    for (;;) {
        size_t c = 2 * i + 1;
        if (c >= h->n)
            break;
        if (c + 1 < h->n && heap_before(h, h->a[c + 1].p, h->a[c].p))
            c++;
        if (!heap_before(h, h->a[c].p, last.p))
            break;
        h->a[i] = h->a[c];
        i = c;
    }
    if (h->n)
        h->a[i] = last;
    return top;
}

/* ---- per frame ---------------------------------------------------------------- */

typedef struct frame_ctx {
    const hz_lod *lod;
    roam_state *R;
    vec4 planes[6];
    float margin;
    bool no_cull;
    float k, hsw; /* pixels per metre at 1 m; metres per h16 step */
    vec3 eye;
} frame_ctx;

/* The wedgie box as drawn: lowered by the Earth curvature (lod->curv). */
static void drawn_box(const hz_lod *lod, const rtri *T, vec3 box[2])
{
    memcpy(box, T->box, sizeof T->box);
    hz_camera_curve_box(&lod->curv, box);
}

static float priority(const frame_ctx *c, rtri *T, bool *outside)
{
    vec3 box[2];
    drawn_box(c->lod, T, box);
    *outside = !c->no_cull && box_outside((const vec3 *)box, (const vec4 *)c->planes, c->margin);
    if (*outside || T->err_m <= 0.0f)
        return 0.0f;
    const float d = box_distance((const vec3 *)box, c->eye);
    return T->err_m * c->k / fmaxf(d, 1e-3f);
}

static hz_result roam_init(hz_lod *lod)
{
    roam_state *R = calloc(1, sizeof *R);
    if (!R)
        return HZ_ERR_MEMORY;
    const uint32_t n = lod->size, N = n - 1;
    R->err = calloc((size_t)n * n, sizeof *R->err);
    if (!R->err) {
        free(R);
        return HZ_ERR_MEMORY;
    }
    err_ctx ec = {.lod = lod, .err = R->err, .n = n, .total = (uint64_t)4 * N * N};
    const uint32_t A = 0, B = N, C = N * n + N, D = N * n;
    tri_err(&ec, B, A, C);
    tri_err(&ec, D, C, A);
    if (lod->desc.progress)
        lod->desc.progress(lod->desc.progress_user, "roam error bounds", ec.total, ec.total);
    R->split.max = true;
    R->lod = lod;
    lod->roam = R;
    int32_t k = alloc_pair(R);
    if (k < 0)
        return HZ_ERR_MEMORY;
    R->t[k] = (rtri){.a = B, .l = A, .r = C, .parent = -1, .child = -1, .ln = -1, .rn = -1, .bn = k + 1};
    R->t[k + 1] = (rtri){.a = D, .l = C, .r = A, .parent = -1, .child = -1, .ln = -1, .rn = -1, .bn = k};
    tri_setup(R, &R->t[k]);
    tri_setup(R, &R->t[k + 1]);
    R->leaves = 2;
    return HZ_OK;
}

hz_result hz__lod_roam_prepare(hz_lod *lod)
{
    return lod->roam ? HZ_OK : roam_init(lod);
}

void hz__lod_roam_free(hz_lod *lod)
{
    roam_state *R = lod->roam;
    if (!R)
        return;
    free(R->err);
    free(R->t);
    free(R->free_pairs);
    free(R->split.a);
    free(R->merge.a);
    free(R);
    lod->roam = NULL;
}

size_t hz__lod_roam_bytes(const hz_lod *lod)
{
    const roam_state *R = lod->roam;
    if (!R)
        return 0;
    return (size_t)lod->size * lod->size * sizeof(uint16_t) + R->cap * sizeof(rtri) +
           R->free_cap * sizeof(int32_t);
}

hz_result hz__lod_select_roam(hz_lod *lod, const hz_camera *cam, const hz_lod_params *p, hz_index_list *out,
                              hz_lod_stats *st)
{
    if (!lod->roam && roam_init(lod) != HZ_OK)
        return HZ_ERR_MEMORY;
    roam_state *R = lod->roam;
    const uint32_t n = lod->size;
    const float tau = p->pixel_error > 0 ? p->pixel_error : 1.0f;
    const size_t budget = p->roam_budget ? p->roam_budget : SIZE_MAX;
    frame_ctx c = {.lod = lod, .R = R, .margin = frustum_margin(cam), .no_cull = p->no_cull,
                   .k = pixel_k(cam, p), .hsw = lod->hm->scale * lod->zscale};
    glm_vec3_copy((float *)cam->pos, c.eye);
    hz_camera_frustum(cam, c.planes);
    /* A freed pair can be handed out again; make room for every slot. */
    if (list_reserve((void **)&R->free_pairs, &R->free_cap, R->n / 2 + 2, sizeof(int32_t)))
        return HZ_ERR_MEMORY;

    /* Priorities of everything alive; candidate queues. */
    R->split.n = R->merge.n = 0;
    /* Only leaves (split candidates) and parents of two leaves (merge
     * candidates) need this frame's priority. */
    for (size_t i = 0; i < R->n; i++) {
        rtri *T = &R->t[i];
        if (T->child == -1 || (T->child >= 0 && children_leaves(R, (int32_t)i))) {
            bool outside;
            T->prio = priority(&c, T, &outside);
        }
    }
    for (size_t i = 0; i < R->n; i++) {
        rtri *T = &R->t[i];
        if (T->child == -1) {
            if (T->prio > tau && heap_push(&R->split, T->prio, (int32_t)i, T->gen))
                return HZ_ERR_MEMORY;
        } else if (T->child >= 0 && children_leaves(R, (int32_t)i)) {
            int32_t b = T->bn;
            if (b >= 0 && (b < (int32_t)i || !children_leaves(R, b)))
                continue; /* the diamond is listed once, and only when whole */
            float dp = fmaxf(T->prio, b >= 0 ? R->t[b].prio : 0.0f);
            if (heap_push(&R->merge, dp, (int32_t)i, T->gen))
                return HZ_ERR_MEMORY;
        }
    }

    /* Merges first (smallest priority first; they also free room under a
     * budget), then splits (largest first). */
    while (R->merge.n) {
        heap_item it = heap_pop(&R->merge);
        if (it.p > tau && R->leaves <= budget)
            break;
        rtri *T = &R->t[it.t];
        if (T->gen != it.gen || !children_leaves(R, it.t) || (T->bn >= 0 && !children_leaves(R, T->bn)))
            continue;
        const int32_t partner = R->t[it.t].bn;
        merge_diamond(R, it.t);
        st->merged++;
        /* The parent diamonds may have become mergeable: cascade this frame. */
        const int32_t pars[2] = {R->t[it.t].parent, partner >= 0 ? R->t[partner].parent : -1};
        for (int q = 0; q < 2; q++) {
            const int32_t par = pars[q];
            if (par < 0 || !children_leaves(R, par))
                continue;
            const int32_t pb = R->t[par].bn;
            if (pb >= 0 && !children_leaves(R, pb))
                continue;
            /* Their priorities are from the frame they last became leaves'
             * parents: refresh them for this eye before merging on them. */
            bool outside;
            R->t[par].prio = priority(&c, &R->t[par], &outside);
            if (pb >= 0)
                R->t[pb].prio = priority(&c, &R->t[pb], &outside);
            float dp = fmaxf(R->t[par].prio, pb >= 0 ? R->t[pb].prio : 0.0f);
            if (heap_push(&R->merge, dp, par, R->t[par].gen))
                return HZ_ERR_MEMORY;
        }
    }

    born nb = {0};
    hz_result res = HZ_OK;
    while (R->split.n && res == HZ_OK) {
        heap_item it = heap_pop(&R->split);
        rtri *T = &R->t[it.t];
        if (T->gen != it.gen || T->child != -1)
            continue;
        /* Forced splits can add a chain of triangles: keep a margin. */
        if (R->leaves + 4 + 4 * (size_t)lod->levels > budget)
            break;
        if (list_reserve((void **)&R->free_pairs, &R->free_cap, R->n / 2 + 8, sizeof(int32_t))) {
            res = HZ_ERR_MEMORY;
            break;
        }
        nb.n = 0;
        res = split_tri(R, n, it.t, st, &nb);
        /* Refine further this frame where the new triangles still exceed tau. */
        for (size_t k = 0; k < nb.n && res == HZ_OK; k++) {
            rtri *C = &R->t[nb.a[k]];
            bool outside;
            C->prio = priority(&c, C, &outside);
            if (C->prio > tau)
                res = heap_push(&R->split, C->prio, nb.a[k], C->gen);
        }
    }
    free(nb.a);
    if (res != HZ_OK)
        return res;

    /* Emit the leaves inside the frustum, counter-clockwise from above. */
    if (list_reserve((void **)&out->data, &out->cap, out->count + R->leaves * 3, sizeof(uint32_t)))
        return HZ_ERR_MEMORY;
    for (size_t i = 0; i < R->n; i++) {
        const rtri *T = &R->t[i];
        if (T->child != -1)
            continue;
        st->nodes_visited++;
        if (!p->no_cull) {
            vec3 box[2];
            drawn_box(lod, T, box);
            if (box_outside((const vec3 *)box, (const vec4 *)c.planes, c.margin)) {
                st->nodes_culled++;
                continue;
            }
        }
        const int64_t x0 = T->a % n, z0 = T->a / n, x1 = T->l % n, z1 = T->l / n, x2 = T->r % n, z2 = T->r / n;
        const int64_t cr = (z1 - z0) * (x2 - x0) - (x1 - x0) * (z2 - z0);
        out->data[out->count++] = T->a;
        out->data[out->count++] = cr > 0 ? T->l : T->r;
        out->data[out->count++] = cr > 0 ? T->r : T->l;
        st->triangles++;
    }
    st->leaves = st->triangles;
    return HZ_OK;
}
