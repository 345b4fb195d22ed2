/* The two "free" quadtree modes, which select without the restricted
 * quadtree's level constraint and then repair the cracks:
 *
 *  remedy (seed 003): each leaf is a fan of its centre and its four corners;
 *    along every edge it inserts the edge vertices of the finer neighbours
 *    (recursively, any level difference), so both sides of every edge carry
 *    the same vertices: no T-junction, whatever the levels.
 *
 *  bidirectional (seed 001): where two leaves differ by two levels or more,
 *    the fine side is coarsened when the coarse node is farther than m from
 *    the eye, otherwise the coarse node is split; repeated until neighbours
 *    differ by at most one level, then the fans skip the edge midpoints toward
 *    coarser neighbours as in the seed's quadtree (T6a). A coarsened node is
 *    frozen for the frame (never split again), which makes the repair
 *    terminate.
 *
 * Node states live in the shared flag array; a per-node frame stamp says
 * which flags were written this frame (the free traversal cannot use the
 * restricted quadtree's "the parent's neighbours are fresh" argument). */
#include "lod_internal.h"

enum { FL_FROZEN = 0x40 };

static hz_result free_begin(hz_lod *lod)
{
    if (!lod->stamp) {
        lod->stamp = calloc(lod->nodes, 1);
        if (!lod->stamp)
            return HZ_ERR_MEMORY;
        lod->epoch = 0;
    }
    if (++lod->epoch == 0) {
        memset(lod->stamp, 0, lod->nodes);
        lod->epoch = 1;
    }
    for (uint32_t l = 0; l < lod->levels; l++)
        lod->lv_n[l] = 0;
    return HZ_OK;
}

static inline bool valid(const hz_lod *lod, size_t idx)
{
    return lod->stamp[idx] == lod->epoch;
}

/* State of node (x, z) at level l: ST_NONE if it does not exist this frame
 * (or is off the map). */
static inline uint8_t state_of(const hz_lod *lod, uint32_t l, int64_t x, int64_t z)
{
    const int64_t s = half_of(lod, l);
    if (x - s < 0 || z - s < 0 || x + s > (int64_t)lod->size - 1 || z + s > (int64_t)lod->size - 1)
        return ST_NONE;
    size_t idx = node_index(lod, l, (uint32_t)x, (uint32_t)z);
    return valid(lod, idx) ? (lod->flags[idx] & ST_MASK) : ST_NONE;
}

typedef struct free_ctx {
    hz_lod *lod;
    vec4 planes[6];
    float margin;
    bool no_cull;
    split_rule rule;
    hz_node_list *culled;
    hz_lod_stats *st;
} free_ctx;

/* Stamps the node and classifies it: CULLED, or LEAF (split later). */
static hz_result visit(free_ctx *c, uint32_t l, uint32_t x, uint32_t z, bool *is_culled)
{
    hz_lod *lod = c->lod;
    const size_t idx = node_index(lod, l, x, z);
    lod->stamp[idx] = lod->epoch;
    c->st->nodes_visited++;
    *is_culled = false;
    if (!c->no_cull) {
        vec3 box[2];
        box_of(lod, idx, x, z, half_of(lod, l), box);
        if (box_outside((const vec3 *)box, (const vec4 *)c->planes, c->margin)) {
            lod->flags[idx] = ST_CULLED;
            c->st->nodes_culled++;
            *is_culled = true;
            return push_node(c->culled, x, z, half_of(lod, l), l);
        }
    }
    lod->flags[idx] = ST_LEAF;
    return HZ_OK;
}

/* The free selection, breadth-first: a node splits when the criterion says
 * so, whatever its neighbours. Leaves end up in lod->lv[level]. */
static hz_result free_select(free_ctx *c)
{
    hz_lod *lod = c->lod;
    const uint32_t n = lod->size;
    if (lv_push(lod, 0, (n - 1) / 2, (n - 1) / 2))
        return HZ_ERR_MEMORY;
    for (uint32_t l = 0; l < lod->levels; l++) {
        const uint32_t s = half_of(lod, l);
        const bool can_split = l + 1 < lod->levels;
        size_t keep = 0;
        for (size_t k = 0; k < lod->lv_n[l]; k++) {
            const uint32_t x = lod->lv[l][k].x, z = lod->lv[l][k].z;
            bool culled;
            if (visit(c, l, x, z, &culled))
                return HZ_ERR_MEMORY;
            if (culled)
                continue;
            const size_t idx = node_index(lod, l, x, z);
            if (can_split && split_rule_test(lod, &c->rule, x, z, s, idx)) {
                lod->flags[idx] = ST_SPLIT;
                const uint32_t h = s / 2;
                if (lv_push(lod, l + 1, x - h, z - h) || lv_push(lod, l + 1, x + h, z - h) ||
                    lv_push(lod, l + 1, x - h, z + h) || lv_push(lod, l + 1, x + h, z + h))
                    return HZ_ERR_MEMORY;
            } else {
                lod->lv[l][keep++] = lod->lv[l][k]; /* leaves stay in the list */
            }
        }
        lod->lv_n[l] = keep;
    }
    return HZ_OK;
}

static void stats_leaf(hz_lod_stats *st, uint32_t l, uint32_t tris)
{
    st->triangles += tris;
    st->leaves++;
    if (l > st->max_level)
        st->max_level = l;
}

/* ---- remedy ---------------------------------------------------------------- */

/* Offsets per side: the side's outward normal (dx, dz). */
static const int side_dx[4] = {-1, 1, 0, 0}, side_dz[4] = {0, 0, -1, 1};

/* The two children of node (x, z, level l) on its side `side`, first and
 * second along the side (north to south for W/E, west to east for N/S), and
 * the side's midpoint. */
static void side_children(const hz_lod *lod, uint32_t l, uint32_t x, uint32_t z, int side, qnode ch[2],
                          qnode *mid)
{
    const uint32_t s = half_of(lod, l), h = s / 2;
    if (side == DIR_W || side == DIR_E) {
        const uint32_t cx = side == DIR_W ? x - h : x + h;
        ch[0] = (qnode){cx, z - h};
        ch[1] = (qnode){cx, z + h};
        *mid = (qnode){side == DIR_W ? x - s : x + s, z};
    } else {
        const uint32_t cz = side == DIR_N ? z - h : z + h;
        ch[0] = (qnode){x - h, cz};
        ch[1] = (qnode){x + h, cz};
        *mid = (qnode){x, side == DIR_N ? z - s : z + s};
    }
}

static hz_result ring_push(uint32_t **ring, size_t *k, size_t *cap, uint32_t v)
{
    if (list_reserve((void **)ring, cap, *k + 1, sizeof(uint32_t)))
        return HZ_ERR_MEMORY;
    (*ring)[(*k)++] = v;
    return HZ_OK;
}

/* Appends, in order along the edge, the vertices that the finer nodes of the
 * subtree at (x, z, level l) have on its side `side` (excluding the side's two
 * corners). `forward` orders them from the side's first corner (north for
 * W/E sides, west for N/S sides) to its last, or back. */
static hz_result collect_side(hz_lod *lod, uint32_t l, uint32_t x, uint32_t z, int side, bool forward,
                              uint32_t **ring, size_t *k, size_t *cap)
{
    if (state_of(lod, l, x, z) != ST_SPLIT)
        return HZ_OK;
    qnode ch[2], mid;
    side_children(lod, l, x, z, side, ch, &mid);
    const qnode a = forward ? ch[0] : ch[1], b = forward ? ch[1] : ch[0];
    hz_result r = collect_side(lod, l + 1, a.x, a.z, side, forward, ring, k, cap);
    if (r == HZ_OK)
        r = ring_push(ring, k, cap, mid.z * lod->size + mid.x);
    if (r == HZ_OK)
        r = collect_side(lod, l + 1, b.x, b.z, side, forward, ring, k, cap);
    return r;
}

/* The selection both free modes start from: the tree split by the rule,
 * frustum-culled unless p->no_cull. */
static hz_result free_start(hz_lod *lod, const hz_camera *cam, const hz_lod_params *p, hz_node_list *culled,
                            hz_lod_stats *st, free_ctx *c)
{
    if (free_begin(lod))
        return HZ_ERR_MEMORY;
    *c = (free_ctx){.lod = lod, .margin = frustum_margin(cam), .no_cull = p->no_cull, .culled = culled, .st = st,
                    .rule = split_rule_make(cam, p)};
    hz_camera_frustum(cam, c->planes);
    return free_select(c);
}

hz_result hz__lod_select_remedy(hz_lod *lod, const hz_camera *cam, const hz_lod_params *p, hz_index_list *out,
                                hz_node_list *leaves, hz_node_list *culled, hz_lod_stats *st)
{
    free_ctx c;
    hz_result r = free_start(lod, cam, p, culled, st, &c);
    if (r != HZ_OK)
        return r;
    const uint32_t n = lod->size;
    uint32_t *ring = NULL;
    size_t cap = 0;
    for (uint32_t l = 0; l < lod->levels && r == HZ_OK; l++) {
        const uint32_t s = half_of(lod, l);
        for (size_t q = 0; q < lod->lv_n[l] && r == HZ_OK; q++) {
            const uint32_t x = lod->lv[l][q].x, z = lod->lv[l][q].z;
            size_t k = 0;
            /* Counter-clockwise from above: NW, west edge (north to south),
             * SW, south edge (west to east), SE, east edge (south to north),
             * NE, north edge (east to west). The neighbour across a side sees
             * it as its opposite side. */
            r = ring_push(&ring, &k, &cap, (z - s) * n + (x - s));
            if (r == HZ_OK)
                r = collect_side(lod, l, x - 2 * s, z, DIR_E, true, &ring, &k, &cap);
            if (r == HZ_OK)
                r = ring_push(&ring, &k, &cap, (z + s) * n + (x - s));
            if (r == HZ_OK)
                r = collect_side(lod, l, x, z + 2 * s, DIR_N, true, &ring, &k, &cap);
            if (r == HZ_OK)
                r = ring_push(&ring, &k, &cap, (z + s) * n + (x + s));
            if (r == HZ_OK)
                r = collect_side(lod, l, x + 2 * s, z, DIR_W, false, &ring, &k, &cap);
            if (r == HZ_OK)
                r = ring_push(&ring, &k, &cap, (z - s) * n + (x + s));
            if (r == HZ_OK)
                r = collect_side(lod, l, x, z - 2 * s, DIR_S, false, &ring, &k, &cap);
            if (r != HZ_OK || list_reserve((void **)&out->data, &out->cap, out->count + 3 * k, sizeof(uint32_t))) {
                r = HZ_ERR_MEMORY;
                break;
            }
            const uint32_t cidx = z * n + x;
            for (size_t t = 0; t < k; t++) {
                out->data[out->count++] = cidx;
                out->data[out->count++] = ring[t];
                out->data[out->count++] = ring[(t + 1) % k];
            }
            stats_leaf(st, l, (uint32_t)k);
            if (push_node(leaves, x, z, s, l))
                r = HZ_ERR_MEMORY;
        }
    }
    free(ring);
    return r;
}

/* ---- bidirectional ----------------------------------------------------------- */

/* Deepest level of the existing nodes of the subtree at (x, z, l) that touch
 * its side `side`. */
static uint32_t side_depth(const hz_lod *lod, uint32_t l, uint32_t x, uint32_t z, int side)
{
    if (state_of(lod, l, x, z) != ST_SPLIT)
        return l;
    qnode ch[2], mid;
    side_children(lod, l, x, z, side, ch, &mid);
    uint32_t a = side_depth(lod, l + 1, ch[0].x, ch[0].z, side), b = side_depth(lod, l + 1, ch[1].x, ch[1].z, side);
    return a > b ? a : b;
}

/* Removes a subtree: its nodes stop existing this frame. */
static void unstamp_children(hz_lod *lod, uint32_t l, uint32_t x, uint32_t z)
{
    if (l + 1 >= lod->levels)
        return;
    const uint32_t h = half_of(lod, l) / 2;
    const uint32_t cx[4] = {x - h, x + h, x - h, x + h}, cz[4] = {z - h, z - h, z + h, z + h};
    for (int k = 0; k < 4; k++) {
        size_t ci = node_index(lod, l + 1, cx[k], cz[k]);
        if (!valid(lod, ci))
            continue;
        if ((lod->flags[ci] & ST_MASK) == ST_SPLIT)
            unstamp_children(lod, l + 1, cx[k], cz[k]);
        lod->stamp[ci] = 0;
    }
}

typedef struct work {
    qnode *a;
    uint8_t *lv;
    size_t n, cap, lcap;
} work;

static hz_result work_push(work *w, uint32_t l, uint32_t x, uint32_t z)
{
    if (list_reserve((void **)&w->a, &w->cap, w->n + 1, sizeof *w->a) ||
        list_reserve((void **)&w->lv, &w->lcap, w->n + 1, 1))
        return HZ_ERR_MEMORY;
    w->a[w->n] = (qnode){x, z};
    w->lv[w->n++] = (uint8_t)l;
    return HZ_OK;
}

/* The existing leaf that covers the same-level position (x, z, l): walks up
 * while the node does not exist. Returns false if off the map. */
static bool leaf_at(const hz_lod *lod, uint32_t l, int64_t x, int64_t z, uint32_t *ol, uint32_t *ox, uint32_t *oz)
{
    const int64_t s = half_of(lod, l);
    if (x - s < 0 || z - s < 0 || x + s > (int64_t)lod->size - 1 || z + s > (int64_t)lod->size - 1)
        return false;
    uint32_t cx = (uint32_t)x, cz = (uint32_t)z;
    for (int64_t lv = l; lv >= 0; lv--) {
        const uint32_t hs = half_of(lod, (uint32_t)lv);
        cx = centre_of(cx, hs);
        cz = centre_of(cz, hs);
        uint8_t stt = state_of(lod, (uint32_t)lv, cx, cz);
        if (stt == ST_LEAF) {
            *ol = (uint32_t)lv;
            *ox = cx;
            *oz = cz;
            return true;
        }
        if (stt != ST_NONE)
            return false; /* split (finer there) or culled */
    }
    return false;
}

static hz_result bidir_repair(free_ctx *c, float m_dist)
{
    hz_lod *lod = c->lod;
    work w = {0};
    hz_result r = HZ_OK;
    for (uint32_t l = 0; l < lod->levels && r == HZ_OK; l++)
        for (size_t k = 0; k < lod->lv_n[l] && r == HZ_OK; k++)
            r = work_push(&w, l, lod->lv[l][k].x, lod->lv[l][k].z);
    const float ex = c->rule.ex, ey = c->rule.ey, ez = c->rule.ez;
    const float sp = lod->spacing;
    /* Each node is split at most once and coarsened at most once (then
     * frozen): the loop ends. The cap only guards against a bug. */
    size_t guard = (size_t)lod->nodes * 4 + 1024;
    while (w.n > 0 && r == HZ_OK && guard-- > 0) {
        w.n--;
        const uint32_t l = w.lv[w.n], x = w.a[w.n].x, z = w.a[w.n].z;
        const size_t idx = node_index(lod, l, x, z);
        if (!valid(lod, idx) || (lod->flags[idx] & ST_MASK) != ST_LEAF)
            continue;
        const uint32_t s = half_of(lod, l);
        for (int side = 0; side < 4 && r == HZ_OK; side++) {
            const int64_t nx = (int64_t)x + side_dx[side] * 2 * (int64_t)s;
            const int64_t nz = (int64_t)z + side_dz[side] * 2 * (int64_t)s;
            if (state_of(lod, l, nx, nz) != ST_SPLIT)
                continue;
            const int facing = side ^ 1; /* W<->E, N<->S */
            if (side_depth(lod, l, (uint32_t)nx, (uint32_t)nz, facing) < l + 2)
                continue;
            const float dx = (float)x * sp - ex, dz = (float)z * sp - ez;
            const float dy = hworld(lod, x, z) - hz_curvature_drop(lod->curv.earth_radius, dx, dz) - ey;
            const float dist = sqrtf(dx * dx + dy * dy + dz * dz);
            if (dist > m_dist || (lod->flags[idx] & FL_FROZEN)) {
                /* Coarsen the fine side: the neighbour's two children on the
                 * facing side become frozen leaves. */
                qnode ch[2], mid;
                side_children(lod, l, (uint32_t)nx, (uint32_t)nz, facing, ch, &mid);
                for (int t = 0; t < 2 && r == HZ_OK; t++) {
                    if (state_of(lod, l + 1, ch[t].x, ch[t].z) != ST_SPLIT)
                        continue;
                    unstamp_children(lod, l + 1, ch[t].x, ch[t].z);
                    lod->flags[node_index(lod, l + 1, ch[t].x, ch[t].z)] = ST_LEAF | FL_FROZEN;
                    c->st->merged++;
                    r = work_push(&w, l + 1, ch[t].x, ch[t].z);
                }
                if (r == HZ_OK)
                    r = work_push(&w, l, x, z); /* re-check our other sides */
                break;
            }
            /* Split the coarse side. */
            lod->flags[idx] = ST_SPLIT;
            c->st->forced++;
            const uint32_t h = s / 2;
            const uint32_t cx[4] = {x - h, x + h, x - h, x + h}, cz[4] = {z - h, z - h, z + h, z + h};
            for (int k = 0; k < 4 && r == HZ_OK; k++) {
                bool culled;
                r = visit(c, l + 1, cx[k], cz[k], &culled);
                if (r == HZ_OK && !culled)
                    r = work_push(&w, l + 1, cx[k], cz[k]);
            }
            /* Coarser leaves next to us may now be two levels coarser than
             * our children. */
            for (int sd = 0; sd < 4 && r == HZ_OK; sd++) {
                uint32_t ll, lx, lz;
                if (leaf_at(lod, l, (int64_t)x + side_dx[sd] * 2 * (int64_t)s, (int64_t)z + side_dz[sd] * 2 * (int64_t)s,
                            &ll, &lx, &lz) &&
                    ll < l)
                    r = work_push(&w, ll, lx, lz);
            }
            break;
        }
    }
    free(w.a);
    free(w.lv);
    return r;
}

/* Collects the final leaves into lod->lv (depth-first from the root). */
static hz_result gather_leaves(hz_lod *lod, uint32_t l, uint32_t x, uint32_t z)
{
    uint8_t stt = state_of(lod, l, x, z);
    if (stt == ST_LEAF)
        return lv_push(lod, l, x, z);
    if (stt != ST_SPLIT)
        return HZ_OK;
    const uint32_t h = half_of(lod, l) / 2;
    hz_result r = gather_leaves(lod, l + 1, x - h, z - h);
    if (r == HZ_OK)
        r = gather_leaves(lod, l + 1, x + h, z - h);
    if (r == HZ_OK)
        r = gather_leaves(lod, l + 1, x - h, z + h);
    if (r == HZ_OK)
        r = gather_leaves(lod, l + 1, x + h, z + h);
    return r;
}

hz_result hz__lod_select_bidir(hz_lod *lod, const hz_camera *cam, const hz_lod_params *p, hz_index_list *out,
                               hz_node_list *leaves, hz_node_list *culled, hz_lod_stats *st)
{
    free_ctx c;
    hz_result r = free_start(lod, cam, p, culled, st, &c);
    if (r != HZ_OK)
        return r;
    const float m_dist = p->bidir_distance > 0 ? p->bidir_distance : 0.25f * (cam->zfar > 0 ? cam->zfar : 1e5f);
    r = bidir_repair(&c, m_dist);
    if (r != HZ_OK)
        return r;
    for (uint32_t l = 0; l < lod->levels; l++)
        lod->lv_n[l] = 0;
    const uint32_t n = lod->size;
    r = gather_leaves(lod, 0, (n - 1) / 2, (n - 1) / 2);
    for (uint32_t l = 0; l < lod->levels && r == HZ_OK; l++) {
        const uint32_t s = half_of(lod, l);
        if (list_reserve((void **)&out->data, &out->cap, out->count + lod->lv_n[l] * 24, sizeof(uint32_t)))
            return HZ_ERR_MEMORY;
        for (size_t q = 0; q < lod->lv_n[l] && r == HZ_OK; q++) {
            const uint32_t x = lod->lv[l][q].x, z = lod->lv[l][q].z;
            uint8_t nb[4];
            for (int side = 0; side < 4; side++) {
                const int64_t nx = (int64_t)x + side_dx[side] * 2 * (int64_t)s;
                const int64_t nz = (int64_t)z + side_dz[side] * 2 * (int64_t)s;
                if (nx < (int64_t)s || nz < (int64_t)s || nx + s > n - 1 || nz + s > n - 1)
                    nb[side] = NB_DONTCARE; /* map border */
                else
                    nb[side] = state_of(lod, l, nx, nz) == ST_NONE ? NB_ABSENT : NB_EXISTS;
            }
            uint32_t tris = hz__emit_fan(out->data + out->count, n, x, z, s, nb);
            out->count += 3 * tris;
            stats_leaf(st, l, tris);
            r = push_node(leaves, x, z, s, l);
        }
    }
    return r;
}
