/* cdlod mode: a screen-space error bound in pixels decides the selection, and
 * every vertex morphs continuously toward the coarser level's surface, so
 * nothing pops. Ours, after the idea of Strugar's CDLOD (2010), on the
 * seed's restricted quadtree of fans over the full-resolution grid.
 *
 * Per node P we precompute delta'(P), a nested upper bound of the vertical
 * distance between P's fan (with or without its edge midpoints) and every
 * sample under P: delta'(P) = max over children c of delta'(c) + max over c's
 * nine vertices v of |h(v) - S_P(v)| (the difference of two piecewise linear
 * surfaces peaks at the vertices of their common refinement, which are those
 * nine points). It is then dilated so that it grows by at least CD_GROW from
 * a node to the coarser nodes around it (see cdlod_prepare), so it is
 * monotone: delta'(parent) >= CD_GROW delta'(child).
 *
 * Selection: P splits when the distance from the eye to P's box is below its
 * range R(P) = lambda * delta'(P), lambda = K / tau (K = pixels per metre at
 * one metre). An unsplit node is then at distance >= R, so its error projects
 * to <= tau pixels. Splits a restricted quadtree needs but the error does not
 * are forced (never refused), so the split set is a pure function of the eye.
 *
 * Morphing: the vertices that P's split introduces (its children's centres
 * and edge midpoints) have morph range R_v = lambda * min(delta'(P), delta'(Q))
 * over the one or two nodes P, Q whose split introduces v. The morph factor is
 * m = clamp((d - a R_v) / ((1 - a) R_v), 0, 1) with d the eye distance of the
 * true vertex, a = morph_start; the vertex moves to mix(h, S_P(v), m). Because
 * d >= dist(P) >= R(P) >= R_v whenever P (or Q) is unsplit, a vertex reaches
 * m = 1, i.e. lies exactly on the coarser surface, before its node merges or
 * its neighbour coarsens, and is still at m = 1 when a split introduces it:
 * the surface changes continuously with the eye. Forced splits only add
 * vertices at m = 1 (invisible). Cracks cannot open: a vertex's morph depends
 * on the vertex alone, and the fans skip midpoints toward coarser neighbours.
 * With a linear morph the projected error stays <= tau inside the morph band. */
#include "lod_internal.h"

#include <float.h>

/* Ranges grow at least this much per level (see the dilation below); morph
 * zones of consecutive levels then do not overlap for morph_start >= 1 / CD_GROW. */
#ifndef CD_GROW
#define CD_GROW 1.25f
#endif

/* ---- precomputation ------------------------------------------------------- */

static float hf(const hz_lod *lod, uint32_t x, uint32_t z)
{
    return (float)h16(lod, x, z);
}

/* P's fan surfaces at a point given in P-normalised coordinates (u, w) in
 * [-1, 1]^2 (x = cx + u s, z = cz + w s). c: centre, m[dir]: edge midpoints,
 * k[0..3]: corners NW, NE, SW, SE. Returns the larger deviation of the true
 * height hv from the 8-triangle fan and from the 4-triangle (corner) fan. */
typedef struct fan9 {
    float c, mw, me, mn, ms, nw, ne, sw, se;
} fan9;

static float fan_dev(const fan9 *f, float u, float w, float hv)
{
    const float a = fabsf(u), b = fabsf(w);
    const bool east = u >= 0.0f, south = w >= 0.0f;
    const float mx = east ? f->me : f->mw;             /* midpoint on the x side */
    const float mz = south ? f->ms : f->mn;            /* midpoint on the z side */
    const float k = east ? (south ? f->se : f->ne) : (south ? f->sw : f->nw); /* corner */
    float s8 = a >= b ? f->c + a * (mx - f->c) + b * (k - mx) : f->c + b * (mz - f->c) + a * (k - mz);
    float s4;
    if (a >= b) {
        /* x-side triangle (centre, two corners on that side) */
        float kp = east ? f->se : f->sw, km = east ? f->ne : f->nw; /* w = +1 / -1 */
        s4 = f->c + a * (0.5f * (kp + km) - f->c) + w * 0.5f * (kp - km);
    } else {
        float kp = south ? f->se : f->ne, km = south ? f->sw : f->nw; /* u = +1 / -1 */
        s4 = f->c + b * (0.5f * (kp + km) - f->c) + u * 0.5f * (kp - km);
    }
    return maxf(fabsf(hv - s8), fabsf(hv - s4));
}

static fan9 fan_of(const hz_lod *lod, uint32_t x, uint32_t z, uint32_t s)
{
    return (fan9){hf(lod, x, z),     hf(lod, x - s, z),     hf(lod, x + s, z),
                  hf(lod, x, z - s), hf(lod, x, z + s),     hf(lod, x - s, z - s),
                  hf(lod, x + s, z - s), hf(lod, x - s, z + s), hf(lod, x + s, z + s)};
}

static void prep_progress(const hz_lod *lod, uint64_t done, uint64_t total)
{
    if (lod->desc.progress)
        lod->desc.progress(lod->desc.progress_user, "cdlod error bounds", done, total);
}

static hz_result cdlod_prepare(hz_lod *lod)
{
    if (lod->cd_err && lod->morph_err)
        return HZ_OK;
    const uint32_t n = lod->size;
    float *e = malloc(lod->nodes * sizeof *e);
    uint16_t *me = malloc((size_t)n * n * sizeof *me);
    if (!e || !me) {
        free(e);
        free(me);
        return HZ_ERR_MEMORY;
    }
    uint64_t total = lod->nodes, done = 0;
    for (uint32_t l = lod->levels; l-- > 0;) {
        const uint32_t s = half_of(lod, l), m = 1u << l;
        for (uint32_t zi = 0; zi < m; zi++) {
            const uint32_t z = zi * 2 * s + s;
            for (uint32_t xi = 0; xi < m; xi++) {
                const uint32_t x = xi * 2 * s + s;
                const fan9 f = fan_of(lod, x, z, s);
                float d = 0.0f;
                if (s == 1) {
                    /* Only the 4-fan misses samples: the edge midpoints. */
                    for (int k = 0; k < 4; k++) {
                        static const int du[4] = {-1, 1, 0, 0}, dw[4] = {0, 0, -1, 1};
                        d = maxf(d, fan_dev(&f, (float)du[k], (float)dw[k], hf(lod, x + du[k], z + dw[k])));
                    }
                } else {
                    const uint32_t h = s / 2;
                    for (int c = 0; c < 4; c++) {
                        const int sx = (c & 1) ? 1 : -1, sz = (c & 2) ? 1 : -1;
                        const uint32_t cx = x + (uint32_t)(sx * (int)h), cz = z + (uint32_t)(sz * (int)h);
                        float dc = 0.0f;
                        for (int v = 0; v < 9; v++) {
                            const int ox = v % 3 - 1, oz = v / 3 - 1;
                            const uint32_t px = cx + (uint32_t)(ox * (int)h), pz = cz + (uint32_t)(oz * (int)h);
                            const float u = ((float)px - (float)x) / (float)s, w = ((float)pz - (float)z) / (float)s;
                            dc = maxf(dc, fan_dev(&f, u, w, hf(lod, px, pz)));
                        }
                        d = maxf(d, e[node_index(lod, l + 1, cx, cz)] + dc);
                    }
                }
                e[lod->level_offset[l] + (size_t)zi * m + xi] = d;
            }
            done += m;
            if ((zi & 255) == 0 || zi + 1 == m)
                prep_progress(lod, done, total * 2);
        }
    }
    /* Dilation: a node's bound is at least CD_GROW times that of every node
     * one level finer that touches it. The vertices a split introduces morph
     * toward vertices that coarser nodes introduce; with ranges growing by
     * CD_GROW per level, those coarser vertices have not started to morph
     * (morph_start >= 1 / CD_GROW) while the finer ones move, so every vertex
     * morphs toward fixed points. Without it, a merge would snap a vertex from
     * the midpoint of its neighbours' true heights to that of their morphed
     * heights. A larger CD_GROW allows longer morph zones but splits earlier
     * (more triangles for the same error): 1.25 measured best. */
    for (uint32_t l = lod->levels - 1; l-- > 0;) {
        const uint32_t s = half_of(lod, l), m = 1u << l, cm = 2u * m;
        for (uint32_t zi = 0; zi < m; zi++)
            for (uint32_t xi = 0; xi < m; xi++) {
                float d = e[lod->level_offset[l] + (size_t)zi * m + xi];
                /* children of this node and of its 8 neighbours that touch it */
                const int64_t c0x = (int64_t)xi * 2 - 1, c0z = (int64_t)zi * 2 - 1;
                for (int64_t cz = c0z; cz <= c0z + 3; cz++)
                    for (int64_t cx = c0x; cx <= c0x + 3; cx++) {
                        if (cx < 0 || cz < 0 || cx >= (int64_t)cm || cz >= (int64_t)cm)
                            continue;
                        d = maxf(d, CD_GROW * e[lod->level_offset[l + 1] + (size_t)cz * cm + (size_t)cx]);
                    }
                e[lod->level_offset[l] + (size_t)zi * m + xi] = d;
            }
        (void)s;
    }
    /* Morph errors: the nodes whose split introduces each sample. */
    for (size_t k = 0; k < (size_t)n * n; k++)
        me[k] = UINT16_MAX;
    done = 0;
    for (uint32_t l = 0; l + 1 < lod->levels; l++) {
        const uint32_t s = half_of(lod, l), m = 1u << l, h = s / 2;
        for (uint32_t zi = 0; zi < m; zi++) {
            const uint32_t z = zi * 2 * s + s;
            for (uint32_t xi = 0; xi < m; xi++) {
                const uint32_t x = xi * 2 * s + s;
                float ef = ceilf(e[lod->level_offset[l] + (size_t)zi * m + xi]);
                const uint16_t q = ef >= 65534.0f ? 65534 : (uint16_t)ef;
                /* 5x5 points at spacing h; the ones with an odd index on
                 * either axis are introduced by this split. */
                for (uint32_t b = 0; b < 5; b++)
                    for (uint32_t a = 0; a < 5; a++) {
                        if (!(a & 1) && !(b & 1))
                            continue;
                        size_t idx = (size_t)(z - s + b * h) * n + (x - s + a * h);
                        if (q < me[idx])
                            me[idx] = q;
                    }
            }
            done += m;
        }
        prep_progress(lod, total + done, total * 2);
    }
    prep_progress(lod, total * 2, total * 2);
    lod->cd_err = e;
    lod->morph_err = me;
    return HZ_OK;
}

hz_result hz__lod_cdlod_prepare(hz_lod *lod)
{
    return cdlod_prepare(lod);
}

const uint16_t *hz_lod_morph_errors(hz_lod *lod)
{
    return cdlod_prepare(lod) == HZ_OK ? lod->morph_err : NULL;
}

/* ---- morphing (the vertex shader does the same) ------------------------- */

static inline uint32_t low_bit(uint32_t v)
{
    return v ? v & (~v + 1u) : 0x80000000u;
}

float hz_lod_morph_factor(hz_lod *lod, const hz_camera *cam, const hz_lod_stats *stats, uint32_t index)
{
    if (!stats || stats->morph_scale <= 0.0f || cdlod_prepare(lod) != HZ_OK)
        return 0.0f;
    const uint16_t q = lod->morph_err[index];
    if (q == UINT16_MAX)
        return 0.0f;
    const uint32_t n = lod->size, i = index % n, j = index / n;
    const float R = stats->morph_scale * (float)q;
    if (R <= 0.0f)
        return 1.0f;
    const float dx = (float)i * lod->spacing - cam->pos[0];
    const float dy = hworld(lod, i, j) - cam->pos[1];
    const float dz = (float)j * lod->spacing - cam->pos[2];
    const float d = sqrtf(dx * dx + dy * dy + dz * dz);
    const float a = stats->morph_start;
    const float m = (d - a * R) / ((1.0f - a) * R);
    return m < 0.0f ? 0.0f : (m > 1.0f ? 1.0f : m);
}

float hz_lod_morph_height(hz_lod *lod, const hz_camera *cam, const hz_lod_stats *stats, uint32_t index)
{
    const uint32_t n = lod->size, i = index % n, j = index / n;
    const float h = hworld(lod, i, j);
    const float m = hz_lod_morph_factor(lod, cam, stats, index);
    if (m <= 0.0f)
        return h;
    const uint32_t bi = low_bit(i), bj = low_bit(j);
    float target;
    if (bi == bj) {
        /* A child's centre: on its parent's diagonal, between the parent's
         * centre and the opposite corner. */
        const uint32_t s = bi, ps = 2 * s;
        const uint32_t pcx = centre_of(i, ps), pcz = centre_of(j, ps);
        const int dx = pcx > i ? 1 : -1, dz = pcz > j ? 1 : -1;
        target = 0.5f * (hworld(lod, (uint32_t)((int)i + dx * (int)s), (uint32_t)((int)j + dz * (int)s)) +
                         hworld(lod, (uint32_t)((int)i - dx * (int)s), (uint32_t)((int)j - dz * (int)s)));
    } else if (bi < bj) {
        target = 0.5f * (hworld(lod, i - bi, j) + hworld(lod, i + bi, j));
    } else {
        target = 0.5f * (hworld(lod, i, j - bj) + hworld(lod, i, j + bj));
    }
    return h + m * (target - h);
}

/* ---- selection ------------------------------------------------------------ */

typedef struct cd_ctx {
    hz_lod *lod;
    vec4 planes[6];
    float margin;
    bool no_cull;
    hz_node_list *culled;
    hz_lod_stats *st;
    uint32_t cur_level;
} cd_ctx;

/* Culling test; sets the flag to CULLED (and lists it) or LEAF. */
static hz_result classify(cd_ctx *c, uint32_t l, uint32_t x, uint32_t z, size_t idx, vec3 box[2], bool *is_culled)
{
    hz_lod *lod = c->lod;
    *is_culled = false;
    c->st->nodes_visited++;
    box_of(lod, idx, x, z, half_of(lod, l), box);
    if (!c->no_cull) {
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

/* Splits node (x, z) at level l (it exists and is a leaf), first forcing the
 * coarser neighbours it needs. Children at the level being processed are left
 * to the main loop; children at earlier levels are classified here. */
static hz_result split_node(cd_ctx *c, uint32_t l, uint32_t x, uint32_t z, bool forced)
{
    hz_lod *lod = c->lod;
    const uint32_t s = half_of(lod, l);
    uint8_t f = ST_SPLIT;
    for (int dir = 0; dir < 4; dir++) {
        uint8_t nb = hz__neighbour(lod, l, x, z, s, dir);
        if (nb == NB_ABSENT) {
            /* The same-level neighbour's parent Q is a leaf: split it first. */
            const uint32_t ps = 2 * s;
            uint32_t qx = centre_of(x, ps), qz = centre_of(z, ps);
            switch (dir) {
            case DIR_W: qx -= 2 * ps; break;
            case DIR_E: qx += 2 * ps; break;
            case DIR_N: qz -= 2 * ps; break;
            default: qz += 2 * ps; break;
            }
            hz_result r = split_node(c, l - 1, qx, qz, true);
            if (r != HZ_OK)
                return r;
        } else if (nb == NB_DONTCARE) {
            f |= (uint8_t)(1u << (DC_SHIFT + dir));
        }
    }
    lod->flags[node_index(lod, l, x, z)] = f;
    if (forced)
        c->st->forced++;
    const uint32_t h = s / 2;
    const uint32_t cx[4] = {x - h, x + h, x - h, x + h}, cz[4] = {z - h, z - h, z + h, z + h};
    for (int k = 0; k < 4; k++) {
        if (l + 1 < c->cur_level) {
            bool culled;
            vec3 box[2];
            hz_result r = classify(c, l + 1, cx[k], cz[k], node_index(lod, l + 1, cx[k], cz[k]), box, &culled);
            if (r != HZ_OK)
                return r;
        }
        if (lv_push(lod, l + 1, cx[k], cz[k]))
            return HZ_ERR_MEMORY;
    }
    return HZ_OK;
}

hz_result hz__lod_select_cdlod(hz_lod *lod, const hz_camera *cam, const hz_lod_params *p, hz_index_list *out,
                               hz_node_list *leaves, hz_node_list *culled, hz_lod_stats *st)
{
    if (cdlod_prepare(lod) != HZ_OK)
        return HZ_ERR_MEMORY;
    const uint32_t n = lod->size;
    const float tau = p->pixel_error > 0 ? p->pixel_error : 1.0f;
    const float lambda = pixel_k(cam, p) / tau;
    const float hsw = lod->hm->scale * lod->zscale; /* metres per h16 step */
    /* The dilation grows ranges by CD_GROW per level: morph zones of
     * consecutive levels do not overlap for a >= 1 / CD_GROW. */
    float a = p->morph_start > 0.0f ? p->morph_start : 1.0f / CD_GROW;
    a = a < 1.0f / CD_GROW ? 1.0f / CD_GROW : (a > 0.95f ? 0.95f : a);
    cd_ctx c = {.lod = lod, .margin = frustum_margin(cam), .no_cull = p->no_cull, .culled = culled, .st = st};
    hz_camera_frustum(cam, c.planes);
    st->morph_scale = lambda * hsw;
    st->morph_start = a;

    for (uint32_t l = 0; l < lod->levels; l++)
        lod->lv_n[l] = 0;
    if (lv_push(lod, 0, (n - 1) / 2, (n - 1) / 2))
        return HZ_ERR_MEMORY;
    for (uint32_t l = 0; l < lod->levels; l++) {
        c.cur_level = l;
        const bool can_split = l + 1 < lod->levels;
        for (size_t k = 0; k < lod->lv_n[l]; k++) {
            const uint32_t x = lod->lv[l][k].x, z = lod->lv[l][k].z;
            const size_t idx = node_index(lod, l, x, z);
            bool is_culled;
            vec3 box[2];
            if (classify(&c, l, x, z, idx, box, &is_culled) != HZ_OK)
                return HZ_ERR_MEMORY;
            if (is_culled || !can_split)
                continue;
            /* distance to the box < range, compared squared */
            const float range = lambda * lod->cd_err[idx] * hsw;
            if (box_distance2((const vec3 *)box, cam->pos) < range * range) {
                hz_result r = split_node(&c, l, x, z, false);
                if (r != HZ_OK)
                    return r;
            }
        }
    }
    /* Emit the leaves, now that every neighbour is final. */
    for (uint32_t l = 0; l < lod->levels; l++) {
        const uint32_t s = half_of(lod, l);
        if (list_reserve((void **)&out->data, &out->cap, out->count + lod->lv_n[l] * 24, sizeof(uint32_t)))
            return HZ_ERR_MEMORY;
        for (size_t k = 0; k < lod->lv_n[l]; k++) {
            const uint32_t x = lod->lv[l][k].x, z = lod->lv[l][k].z;
            if ((lod->flags[node_index(lod, l, x, z)] & ST_MASK) != ST_LEAF)
                continue;
            uint8_t nb[4];
            for (int dir = 0; dir < 4; dir++)
                nb[dir] = hz__neighbour(lod, l, x, z, s, dir);
            uint32_t tris = hz__emit_fan(out->data + out->count, n, x, z, s, nb);
            out->count += 3 * tris;
            st->triangles += tris;
            st->leaves++;
            if (l > st->max_level)
                st->max_level = l;
            if (push_node(leaves, x, z, s, l))
                return HZ_ERR_MEMORY;
        }
    }
    return HZ_OK;
}
