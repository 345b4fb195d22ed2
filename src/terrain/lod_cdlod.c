/* cdlod mode: a screen-space error bound in pixels decides the selection,
 * every selected node is drawn with one static grid patch of P x P cells
 * (nodes, not triangles, per frame), and every vertex morphs continuously
 * toward the coarser level's surface, so nothing pops. Ours, after the idea
 * of Strugar's CDLOD (2010), on the seed's restricted quadtree.
 *
 * Patches: a node of half-size s is drawn as a P x P grid whose vertices are
 * 2s / P samples apart; the finest patch nodes have s = P / 2 (vertices one
 * sample apart), cells split as the full-resolution mesh is (union jack,
 * below). The grid of a node is nested in its parent's: the parent's
 * vertices are every other vertex of its children's grids.
 *
 * Per node N we precompute delta'(N), a nested upper bound of the vertical
 * distance between N's patch surface and every sample under it:
 * delta'(N) = max over children c of delta'(c) + max over the vertices v
 * that N's split introduces of |h(v) - S_N(v)| (the difference of two nested
 * piecewise-linear surfaces peaks at the vertices of the finer one; the
 * finest patches are exact). S_N(v) is the midpoint of v's two neighbours at
 * the spacing where v first appears: along x, along z, or on the coarser
 * cell's diagonal (hz_lod_morph_target2). The bounds are then dilated so
 * that they grow by at least CD_GROW from a node to the coarser nodes
 * around it.
 *
 * NOTE: the exact error of each patch (its largest distance to every sample
 * under it) is smaller and halves the triangles at a given tau, but measured
 * on the peers' fractal flight it gives more silhouette error per triangle
 * (exact tau 1.25: 425 k triangles, 0.0236 % of pixels; nested tau 2: 424 k,
 * 0.0186 %, same PSNR): the nested sums refine distant coarse nodes, whose
 * error shows on the horizon, relatively more.
 *
 * NOTE: splitting N only when the eye nears one of its quarters (a nested
 * bound per child area, the morph ranges derived from it) saves 6.5 % of the
 * triangles at a given tau but shortens the morph ranges: on that flight at
 * tau 1.5 PSNR fell from 41.02 to 40.18 dB, and at equal PSNR it needs as
 * many triangles. It also leaves more patches morphing (not still). Drawing
 * a leaf whose added vertices have all morphed with its parent's grid over
 * its area is exact, but with this split only 3 % of the leaves qualify
 * (8 % of the odd vertices drawn are fully morphed): 2 % fewer triangles.
 *
 * Selection: N splits when the distance from the eye to N's box is below its
 * range R(N) = lambda * delta'(N), lambda = K / tau (K = pixels per metre at
 * one metre). An unsplit node is then at distance >= R, so its error projects
 * to <= tau pixels. Splits a restricted quadtree needs but the error does not
 * are forced (never refused), so the split set is a pure function of the eye.
 * With a near bound (near_pixel_error) every range, the nodes' and the
 * vertices' alike, is cd_range of it: a monotone function of the error
 * alone, so what follows holds unchanged.
 *
 * Triangulation: every grid, at every spacing, is a "union jack": cell
 * (a, b) (in units of the grid's spacing) is split along its main diagonal
 * (a, b)-(a+1, b+1) when a + b is even, along the anti-diagonal otherwise.
 * That pattern is nested (the diagonal of a cell of side 2s runs through the
 * two cells of side s that split the same way), and next to every odd edge
 * vertex e the two cells of the edge row both have a diagonal from the same
 * inner vertex i to e's two even neighbours.
 *
 * Stitching: where a leaf's neighbour is one level coarser, the leaf's odd
 * edge vertices collapse onto the even vertex before them along the edge;
 * the two triangles (e0, e, i), (e, e2, i) become (e0, e2, i): exactly the
 * coarser edge, and a pure subdivision of it, so the surface does not jump
 * when the neighbour splits and e returns (at morph factor 1, on e0-e2).
 *
 * Morphing: the vertices that N's split introduces have morph range
 * R_v = lambda * min(delta'(N), delta'(M)) over the one or two nodes N, M whose
 * split introduces v (2 bytes per sample). The morph factor is
 * m = clamp((d - a R_v) / ((1 - a) R_v), 0, 1), d the eye distance of the true
 * vertex, a = morph_start; the vertex moves to mix(h, S'(v), m), S'(v) the
 * midpoint of its two neighbours each moved one level toward its own
 * target (so a vertex at m = 1 lies on the coarser surface as drawn, even
 * where that surface is itself morphing: a patch spans many samples, and
 * its far vertices may be morphing while a split brings in near ones). A vertex
 * introduced by a split is at d >= R(N) >= R_v when N splits, i.e. at m = 1,
 * on its parent's surface: it appears without popping, and it is back on it
 * before N merges. The morph depends on the vertex alone, so the same sample
 * has the same height in every node that draws it. */
#include "lod_internal.h"

#include <float.h>


/* ---- precomputation ------------------------------------------------------- */

static inline bool cell_main_diagonal(uint32_t a, uint32_t b)
{
    return ((a + b) & 1u) == 0;
}

static bool morph_neighbours(const hz_lod *lod, uint32_t i, uint32_t j, uint32_t ni[2], uint32_t nj[2])
{
    return hz__morph_neighbours(lod->size, i, j, ni, nj);
}

uint32_t hz_lod_morph_target2(const hz_lod *lod, uint32_t i, uint32_t j)
{
    uint32_t ni[2], nj[2];
    if (!morph_neighbours(lod, i, j, ni, nj))
        return 2u * h16(lod, i, j);
    return (uint32_t)h16(lod, ni[0], nj[0]) + h16(lod, ni[1], nj[1]);
}

static void prep_progress(const hz_lod *lod, uint64_t done, uint64_t total)
{
    if (lod->desc.progress)
        lod->desc.progress(lod->desc.progress_user, "cdlod error bounds", done, total);
}

static inline size_t cd_index(const hz_lod *lod, uint32_t l, uint32_t xi, uint32_t zi)
{
    return lod->level_offset[l] + ((size_t)zi << l) + xi;
}

/* The same for the node of level l centred at sample (x, z). */
static inline size_t cd_node(const hz_lod *lod, uint32_t l, uint32_t x, uint32_t z)
{
    const uint32_t shift = lod->levels - l;
    return cd_index(lod, l, x >> shift, z >> shift);
}

static hz_result cdlod_prepare(hz_lod *lod)
{
    if (lod->cd_err && lod->morph_err)
        return HZ_OK;
    const uint32_t n = lod->size, lp = lod->patch_level, P = lod->patch;
    const size_t cd_nodes = lod->level_offset[lp] + ((size_t)1 << (2 * lp));
    float *e = malloc(cd_nodes * sizeof *e);
    uint16_t *me = malloc((size_t)n * n * sizeof *me);
    uint16_t *qmin = malloc(2 * cd_nodes * sizeof *qmin);
    if (!e || !me || !qmin) {
        free(e);
        free(me);
        free(qmin);
        return HZ_ERR_MEMORY;
    }
    const uint64_t total = cd_nodes;
    uint64_t done = 0;
    for (uint32_t l = lp + 1; l-- > 0;) {
        const uint32_t s = half_of(lod, l), m = 1u << l;
        const uint32_t h = 2 * s / P / 2; /* the children's vertex spacing */
        for (uint32_t zi = 0; zi < m; zi++) {
            for (uint32_t xi = 0; xi < m; xi++) {
                float d = 0.0f;
                if (l < lp) {
                    const uint32_t x0 = xi * 2 * s, z0 = zi * 2 * s;
                    /* the vertices this split introduces: odd on either axis
                     * of the children's grid (2P + 1 per side) */
                    float dv = 0.0f;
                    for (uint32_t b = 0; b <= 2 * P; b++) {
                        const uint32_t z = z0 + b * h;
                        for (uint32_t a = (b & 1) ? 0 : 1; a <= 2 * P; a += (b & 1) ? 1 : 2) {
                            const uint32_t x = x0 + a * h;
                            const float t = 0.5f * (float)hz_lod_morph_target2(lod, x, z);
                            dv = maxf(dv, fabsf((float)h16(lod, x, z) - t));
                        }
                    }
                    float dc = 0.0f;
                    for (uint32_t c = 0; c < 4; c++)
                        dc = maxf(dc, e[cd_index(lod, l + 1, 2 * xi + (c & 1), 2 * zi + (c >> 1))]);
                    d = dc + dv;
                }
                e[cd_index(lod, l, xi, zi)] = d;
            }
            done += m;
            if ((zi & 63) == 0 || zi + 1 == m)
                prep_progress(lod, done, total * 2);
        }
    }
    /* Dilation: a node's bound is at least CD_GROW times that of every node
     * one level finer that touches it. The vertices a split introduces morph
     * toward vertices that coarser nodes introduce; with ranges growing by
     * CD_GROW per level, those coarser vertices have not started to morph
     * (morph_start >= 1 / CD_GROW) while the finer ones move, so every vertex
     * morphs toward fixed points. A larger CD_GROW allows longer morph zones
     * but splits earlier (more triangles for the same error). */
    for (uint32_t l = lp; l-- > 0;) {
        const uint32_t m = 1u << l, cm = 2u * m;
        for (uint32_t zi = 0; zi < m; zi++)
            for (uint32_t xi = 0; xi < m; xi++) {
                float d = e[cd_index(lod, l, xi, zi)];
                /* children of this node and of its 8 neighbours that touch it */
                const int64_t c0x = (int64_t)xi * 2 - 1, c0z = (int64_t)zi * 2 - 1;
                for (int64_t cz = c0z; cz <= c0z + 3; cz++)
                    for (int64_t cx = c0x; cx <= c0x + 3; cx++) {
                        if (cx < 0 || cz < 0 || cx >= (int64_t)cm || cz >= (int64_t)cm)
                            continue;
                        d = maxf(d, CD_GROW * e[cd_index(lod, l + 1, (uint32_t)cx, (uint32_t)cz)]);
                    }
                e[cd_index(lod, l, xi, zi)] = d;
            }
    }
    /* Whole h16 steps, as the per-sample morph ranges store them: a split
     * must see the same range as the vertices it brings in, or they would
     * arrive short of the coarser surface. */
    for (size_t k = 0; k < cd_nodes; k++)
        e[k] = e[k] >= 65534.0f ? 65534.0f : ceilf(e[k]);
    /* Morph errors: the nodes whose split introduces each sample. */
    for (size_t k = 0; k < (size_t)n * n; k++)
        me[k] = UINT16_MAX;
    done = 0;
    for (uint32_t l = 0; l < lp; l++) {
        const uint32_t s = half_of(lod, l), m = 1u << l;
        const uint32_t h = 2 * s / P / 2;
        for (uint32_t zi = 0; zi < m; zi++) {
            for (uint32_t xi = 0; xi < m; xi++) {
                const uint32_t x0 = xi * 2 * s, z0 = zi * 2 * s;
                const uint16_t q = (uint16_t)e[cd_index(lod, l, xi, zi)];
                for (uint32_t b = 0; b <= 2 * P; b++) {
                    const size_t row = (size_t)(z0 + b * h) * n;
                    for (uint32_t a = (b & 1) ? 0 : 1; a <= 2 * P; a += (b & 1) ? 1 : 2) {
                        const size_t idx = row + x0 + a * h;
                        if (q < me[idx])
                            me[idx] = q;
                    }
                }
            }
            done += m;
        }
        prep_progress(lod, total + done, total * 2);
    }
    /* Per node, the least morph error of the (P + 1)^2 samples its patch
     * draws (stitched vertices are among them): while the node's farthest
     * point is nearer than morph_start times that range, none of its
     * vertices morphs (emit_patches marks the patch still). Then the same
     * over its even vertices (those of the next coarser grid, which every
     * odd vertex morphs toward): while none of them morphs, the patch
     * morphs simply (hz_patch.simple). */
    for (uint32_t l = 0; l <= lp; l++) {
        const uint32_t s = half_of(lod, l), m = 1u << l, h = 2 * s / P;
        for (uint32_t zi = 0; zi < m; zi++)
            for (uint32_t xi = 0; xi < m; xi++) {
                const uint32_t x0 = xi * 2 * s, z0 = zi * 2 * s;
                uint16_t q = UINT16_MAX, qe = UINT16_MAX;
                for (uint32_t b = 0; b <= P; b++) {
                    const uint16_t *row = me + (size_t)(z0 + b * h) * n + x0;
                    for (uint32_t a = 0; a <= P; a++) {
                        q = row[a * h] < q ? row[a * h] : q;
                        if (!((a | b) & 1))
                            qe = row[a * h] < qe ? row[a * h] : qe;
                    }
                }
                qmin[2 * cd_index(lod, l, xi, zi)] = q;
                qmin[2 * cd_index(lod, l, xi, zi) + 1] = qe;
            }
    }
    prep_progress(lod, total * 2, total * 2);
    lod->cd_qmin = qmin;
    lod->cd_err = e;
    lod->cd_nodes = cd_nodes;
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

const hz_heightmap *hz_lod_query_heightmap(const hz_lod *lod)
{
    return lod->hm;
}

float hz_lod_patch_error(hz_lod *lod, const hz_patch *p)
{
    if (cdlod_prepare(lod) != HZ_OK || p->level > lod->patch_level)
        return 0.0f;
    const uint32_t s = half_of(lod, p->level);
    return lod->cd_err[cd_node(lod, p->level, p->x0 + s, p->z0 + s)];
}

uint32_t hz_lod_patch_cells(const hz_lod *lod)
{
    return lod->patch;
}

/* ---- morphing (the vertex shader does the same) ------------------------- */

/* The morph range in metres of an error of q h16 steps in the frame of st
 * (hz_lod_morph_range), and where its zone starts, as a fraction of it
 * (cd_morph_start_at: wider for an error the near bound loosens). */
static float morph_zone(const hz_lod_stats *st, float q, float *start)
{
    const float R = hz_lod_morph_range(st, q);
    *start = cd_morph_start_at(st->morph_start, st->morph_scale * q, R);
    return R;
}

float hz_lod_morph_factor(hz_lod *lod, const hz_camera *cam, const hz_lod_stats *stats, uint32_t index)
{
    if (!stats || stats->morph_scale <= 0.0f || cdlod_prepare(lod) != HZ_OK)
        return 0.0f;
    const uint16_t q = lod->morph_err[index];
    if (q == UINT16_MAX)
        return 0.0f;
    const uint32_t n = lod->size, i = index % n, j = index / n;
    float a;
    const float R = morph_zone(stats, (float)q, &a);
    if (R <= 0.0f)
        return 1.0f;
    const float dx = (float)i * lod->spacing - cam->pos[0];
    const float dz = (float)j * lod->spacing - cam->pos[2];
    /* To the point as drawn (lowered by the Earth curvature), as the shader does. */
    const float dy = hworld(lod, i, j) - hz_curvature_drop(cam->earth_radius, dx, dz) - cam->pos[1];
    const float d = sqrtf(dx * dx + dy * dy + dz * dz);
    const float m = (d - a * R) / ((1.0f - a) * R);
    return m < 0.0f ? 0.0f : (m > 1.0f ? 1.0f : m);
}

float hz_lod_morph_range(const hz_lod_stats *stats, float q)
{
    /* morph_near 0 or morph_near_distance 0 (stats filled by hand): none */
    const float rho = stats->morph_near > 0.0f ? stats->morph_near : 1.0f;
    return cd_range(stats->morph_scale * q, rho, stats->morph_near_distance);
}

/* A vertex moved toward its true-height target (one level of morphing). */
static float morph1(hz_lod *lod, const hz_camera *cam, const hz_lod_stats *stats, uint32_t index)
{
    const uint32_t n = lod->size, i = index % n, j = index / n;
    const float h = hworld(lod, i, j);
    const float m = hz_lod_morph_factor(lod, cam, stats, index);
    if (m <= 0.0f)
        return h;
    const float t = (lod->hm->offset + lod->hm->scale * 0.5f * (float)hz_lod_morph_target2(lod, i, j)) * lod->zscale;
    return h + m * (t - h);
}

float hz_lod_morph_height(hz_lod *lod, const hz_camera *cam, const hz_lod_stats *stats, uint32_t index)
{
    const uint32_t n = lod->size, i = index % n, j = index / n;
    const float h = hworld(lod, i, j);
    const float m = hz_lod_morph_factor(lod, cam, stats, index);
    uint32_t ni[2], nj[2];
    if (m <= 0.0f || !morph_neighbours(lod, i, j, ni, nj))
        return h;
    /* Toward the midpoint of the neighbours as they are drawn (themselves
     * morphed one level): a vertex a split brings in (m = 1) then lies on
     * the coarser node's drawn surface even while that surface morphs. */
    const float target =
        0.5f * (morph1(lod, cam, stats, nj[0] * n + ni[0]) + morph1(lod, cam, stats, nj[1] * n + ni[1]));
    return h + m * (target - h);
}

/* The box of the square of patch vertices with corner (x0, z0) and half
 * side s samples (a node of lod), as drawn for cam in the frame of stats.
 * Every vertex of the square, morphed or not, is a mix of samples of the
 * square and of its corners as drawn or moved one level: a vertex inside it
 * or on an edge collapses between two vertices of the square (a power of
 * two cells on a corner aligned to its size), but a corner, which a coarser
 * node brings in, collapses toward samples beyond it. A corner that does
 * not morph for this eye stays on its sample, as does every vertex of a
 * still patch (hz_patch.still). */
static bool square_box(hz_lod *lod, uint32_t x0, uint32_t z0, uint32_t s, bool still, const hz_camera *cam,
                       const hz_lod_stats *stats, vec3 box[2])
{
    if (!hz_lod_node_box(lod, x0 + s, z0 + s, s, box))
        return false;
    const uint32_t n = lod->size;
    for (uint32_t c = 0; c < 4 && !still; c++) {
        const uint32_t idx = (z0 + (c >> 1) * 2 * s) * n + x0 + (c & 1) * 2 * s;
        if (hz_lod_morph_factor(lod, cam, stats, idx) <= 0.0f)
            continue;
        const float y[2] = {hz_lod_morph_height(lod, cam, stats, idx), morph1(lod, cam, stats, idx)};
        for (int k = 0; k < 2; k++) {
            box[0][1] = fminf(box[0][1], y[k]);
            box[1][1] = fmaxf(box[1][1], y[k]);
        }
    }
    return true;
}

bool hz_lod_patch_box(hz_lod *lod, const hz_patch *p, const hz_camera *cam, const hz_lod_stats *stats, vec3 box[2])
{
    if (p->level >= lod->levels)
        return false;
    const uint32_t s = half_of(lod, p->level);
    return square_box(lod, p->x0, p->z0, s, p->still != 0, cam, stats, box);
}

uint32_t hz_lod_patch_blocks(uint32_t patch_cells)
{
    return patch_cells >= 8 ? 4 : (patch_cells >= 2 ? patch_cells / 2 : 1);
}

bool hz_lod_patch_block_box(hz_lod *lod, const hz_patch *p, uint32_t per_side, uint32_t bx, uint32_t bz,
                            const hz_camera *cam, const hz_lod_stats *stats, vec3 box[2])
{
    const uint32_t B = hz_lod_patch_blocks(lod->patch);
    if (p->level >= lod->levels || per_side == 0 || per_side > B || (per_side & (per_side - 1)) || bx >= per_side ||
        bz >= per_side)
        return false;
    /* a block is P / per_side >= 2 cells: a node of half P / (2 per_side) vertices */
    const uint32_t side = 2 * half_of(lod, p->level) / per_side;
    return square_box(lod, p->x0 + bx * side, p->z0 + bz * side, side / 2, p->still != 0, cam, stats, box);
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

/* A node's entry in its level's list (lod->lv): x with bit 31 set when its
 * box lies inside the frustum, so that its children's boxes (nested in it)
 * need no test. */
#define CD_INSIDE 0x80000000u

/* Culling test; sets the flag to CULLED (and lists it) or LEAF. *inside:
 * given, the node is known to lie inside the frustum (its parent does);
 * returned, whether it does. */
static hz_result classify(cd_ctx *c, uint32_t l, uint32_t x, uint32_t z, size_t idx, vec3 box[2], bool *is_culled,
                          bool *inside)
{
    hz_lod *lod = c->lod;
    *is_culled = false;
    c->st->nodes_visited++;
    box_of(lod, idx, x, z, half_of(lod, l), box);
    if (!c->no_cull && !*inside) {
        const int where = box_frustum((const vec3 *)box, (const vec4 *)c->planes, c->margin);
        if (where < 0) {
            lod->flags[idx] = ST_CULLED;
            c->st->nodes_culled++;
            *is_culled = true;
            return push_node(c->culled, x, z, half_of(lod, l), l);
        }
        *inside = where > 0;
    }
    lod->flags[idx] = ST_LEAF;
    return HZ_OK;
}

/* Splits node (x, z) at level l (it exists and is a leaf), first forcing the
 * coarser neighbours it needs. Children at the level being processed are left
 * to the main loop; children at earlier levels are classified here. */
static hz_result split_node(cd_ctx *c, uint32_t l, uint32_t x, uint32_t z, bool forced, bool inside)
{
    hz_lod *lod = c->lod;
    const uint32_t s = half_of(lod, l);
    uint8_t f = ST_SPLIT;
    for (int dir = 0; dir < 4; dir++) {
        uint8_t nb = neighbour_of(lod, l, x, z, s, dir);
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
            /* Q, a leaf of the level before, may lie inside the frustum,
             * but that was not kept: its children are tested (forced
             * splits are few) */
            hz_result r = split_node(c, l - 1, qx, qz, true, false);
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
        bool in = inside;
        if (l + 1 < c->cur_level) {
            bool culled;
            vec3 box[2];
            hz_result r = classify(c, l + 1, cx[k], cz[k], node_index(lod, l + 1, cx[k], cz[k]), box, &culled, &in);
            if (r != HZ_OK)
                return r;
        }
        if (lv_push(lod, l + 1, cx[k] | (in ? CD_INSIDE : 0u), cz[k]))
            return HZ_ERR_MEMORY;
    }
    return HZ_OK;
}

/* The selection proper; leaves end in lod->lv[] with their flags final. */
static hz_result cdlod_select(hz_lod *lod, const hz_camera *cam, const hz_lod_params *p, hz_node_list *culled,
                              hz_lod_stats *st)
{
    if (cdlod_prepare(lod) != HZ_OK)
        return HZ_ERR_MEMORY;
    const uint32_t n = lod->size, lp = lod->patch_level;
    const float tau = p->pixel_error > 0 ? p->pixel_error : 1.0f;
    const float lambda = pixel_k(cam, p) / tau;
    const float hsw = lod->hm->scale * lod->zscale; /* metres per h16 step */
    const float a = cd_morph_start(p->morph_start);
    lod->curv = *cam; /* box_of lowers the boxes for Earth curvature */
    cd_ctx c = {.lod = lod, .margin = frustum_margin(cam), .no_cull = p->no_cull, .culled = culled, .st = st};
    hz_camera_frustum(cam, c.planes);
    st->morph_scale = lambda * hsw;
    st->morph_start = a;
    cd_near(p, &st->morph_near, &st->morph_near_distance);
    const float rho = st->morph_near, d0 = st->morph_near_distance;

    for (uint32_t l = 0; l < lod->levels; l++)
        lod->lv_n[l] = 0;
    if (lv_push(lod, 0, (n - 1) / 2, (n - 1) / 2))
        return HZ_ERR_MEMORY;
    for (uint32_t l = 0; l <= lp; l++) {
        c.cur_level = l;
        const bool can_split = l < lp;
        for (size_t k = 0; k < lod->lv_n[l]; k++) {
            const uint32_t x = lod->lv[l][k].x & ~CD_INSIDE, z = lod->lv[l][k].z;
            const size_t idx = node_index(lod, l, x, z);
            bool is_culled, inside = (lod->lv[l][k].x & CD_INSIDE) != 0;
            vec3 box[2];
            if (classify(&c, l, x, z, idx, box, &is_culled, &inside) != HZ_OK)
                return HZ_ERR_MEMORY;
            if (is_culled || !can_split)
                continue;
            /* distance to the box < range, compared squared */
            const float range = cd_range(lambda * lod->cd_err[cd_node(lod, l, x, z)] * hsw, rho, d0);
            if (box_distance2((const vec3 *)box, cam->pos) < range * range) {
                hz_result r = split_node(&c, l, x, z, false, inside);
                if (r != HZ_OK)
                    return r;
            }
        }
    }
    return HZ_OK;
}

/* Whether no vertex of node (l, x, z)'s patch morphs for the eye (even:
 * none of its even vertices): its box's farthest point (the box as drawn,
 * lowered for the Earth's curvature, holds every vertex before morphing,
 * where the shader measures the distance) is nearer than the smallest
 * range's morph start, with a margin for the shader's float rounding. */
static uint8_t patch_still(const hz_lod *lod, const hz_lod_stats *st, uint32_t l, uint32_t x, uint32_t z,
                           vec3 box[2], const vec3 eye, bool even)
{
    if (st->morph_scale <= 0.0f)
        return 1;
    const uint16_t q = lod->cd_qmin[2 * cd_node(lod, l, x, z) + even];
    if (q == UINT16_MAX)
        return 1; /* nothing here ever morphs */
    float d2 = 0.0f;
    for (int a = 0; a < 3; a++) {
        const float lo = box[0][a] - eye[a], hi = box[1][a] - eye[a];
        d2 += lo * lo > hi * hi ? lo * lo : hi * hi;
    }
    float frac;
    const float R = morph_zone(st, (float)q, &frac);
    const float start = frac * R - 0.01f;
    return start > 0.0f && d2 * 1.002f < start * start; /* d * 1.001 + 0.01 < the start, squared */
}

/* The leaves of the last cdlod_select as patches, nearest first. */
static hz_result emit_patches(hz_lod *lod, const hz_camera *cam, hz_patch_list *out, hz_lod_stats *st)
{
    const uint32_t lp = lod->patch_level, P = lod->patch;
    uint32_t tris[16]; /* hz__patch_triangles per stitching */
    for (uint32_t c = 0; c < 16; c++)
        tris[c] = hz__patch_triangles(P, (uint8_t)c);
    for (uint32_t l = 0; l <= lp; l++) {
        const uint32_t s = half_of(lod, l);
        uint32_t shift = 0;
        while ((P << shift) < 2 * s)
            shift++;
        if (list_reserve((void **)&out->data, &out->cap, out->count + lod->lv_n[l], sizeof *out->data))
            return HZ_ERR_MEMORY;
        size_t w = out->count;
        uint32_t still = 0, simple = 0, leaves = 0, triangles = 0;
        for (size_t k = 0; k < lod->lv_n[l]; k++) {
            const uint32_t x = lod->lv[l][k].x & ~CD_INSIDE, z = lod->lv[l][k].z;
            const size_t idx = node_index(lod, l, x, z);
            if ((lod->flags[idx] & ST_MASK) != ST_LEAF)
                continue;
            uint8_t coarse = 0;
            for (int dir = 0; dir < 4; dir++)
                if (neighbour_of(lod, l, x, z, s, dir) == NB_ABSENT)
                    coarse |= (uint8_t)(1u << dir);
            vec3 box[2];
            box_of(lod, idx, x, z, s, box);
            const uint8_t st1 = patch_still(lod, st, l, x, z, box, cam->pos, false);
            out->data[w++] = (hz_patch){.x0 = x - s, .z0 = z - s, .shift = (uint8_t)shift, .coarse = coarse,
                                        .level = (uint16_t)l, .dist = box_distance((const vec3 *)box, cam->pos),
                                        .still = st1,
                                        .simple = st1 || patch_still(lod, st, l, x, z, box, cam->pos, true)};
            simple += out->data[w - 1].simple;
            triangles += tris[coarse];
            still += st1;
            leaves++;
        }
        out->count = w;
        st->triangles += triangles;
        st->still += still;
        st->simple += simple;
        st->leaves += leaves;
        if (leaves && l > st->max_level)
            st->max_level = l;
    }
    /* Nearest first, so the depth test rejects hidden fragments early: a
     * counting sort on the distance's logarithm (32 steps per doubling, 3 %),
     * O(nodes); a comparison sort took half the selection's time. */
    return hz__sort_patches(out, &lod->patch_tmp, &lod->patch_tmp_cap);
}

/* Horizon culling of the selection's patches (st: its stats): hidden[k]
 * for each of [0, count). */
static hz_result horizon_hidden(hz_lod *lod, const hz_camera *cam, const hz_lod_params *p, const hz_lod_stats *st,
                                const hz_patch *patches, size_t count, uint8_t *hidden, uint16_t *quads, size_t from)
{
    if (p->no_cull || lod->desc.holes) { /* a hole lets a ray through the surface */
        memset(hidden, 0, count);
        if (quads)
            memset(quads, 0, count * sizeof *quads);
        return HZ_OK;
    }
    const float tau = p->pixel_error > 0 ? p->pixel_error : 1.0f;
    /* the near bound: a morph moves a vertex at most d / (a K / tau_n),
     * a the least morph start (cd_morph_start_at at R / Rp = 1 / rho) */
    const float rho = st->morph_near;
    return hz__horizon_hidden(lod, cam, pixel_k(cam, p) / tau * rho, cd_morph_start_at(st->morph_start, 1.0f, rho),
                              st->morph_scale > 0.0f, patches, count, hidden, quads, from);
}

hz_result hz_lod_select_patches(hz_lod *lod, const hz_camera *cam, const hz_lod_params *params, hz_patch_list *out,
                                hz_lod_stats *stats)
{
    double t0 = hz_time_ms();
    hz_lod_params p = params ? *params : (hz_lod_params){0};
    hz_lod_stats st = {0};
    out->count = 0;
    hz_result r = cdlod_select(lod, cam, &p, NULL, &st);
    if (r == HZ_OK)
        r = emit_patches(lod, cam, out, &st);
    if (r == HZ_OK && p.horizon_cull) {
        hz_horizon_stats hs;
        if (list_reserve((void **)&lod->hz_hidden, &lod->hz_hidden_cap, out->count, 1))
            r = HZ_ERR_MEMORY;
        else
            r = hz_lod_horizon_hide(lod, cam, &p, &st, out->data, out->count, 0, lod->hz_hidden, NULL, &hs);
        size_t w = 0; /* drop the hidden ones, keeping the order */
        for (size_t k = 0; r == HZ_OK && k < out->count; k++)
            if (!lod->hz_hidden[k])
                out->data[w++] = out->data[k];
        if (r == HZ_OK) {
            out->count = w;
            hz_lod_stats_hide(&st, &hs);
        }
    }
    st.ms = hz_time_ms() - t0;
    if (stats)
        *stats = st;
    return r;
}

void hz_lod_stats_hide(hz_lod_stats *st, const hz_horizon_stats *hs)
{
    st->triangles -= hs->triangles;
    st->still -= hs->still;
    st->simple -= hs->simple;
    st->leaves -= hs->patches;
    st->hidden += hs->patches;
}

hz_result hz_lod_horizon_hide(hz_lod *lod, const hz_camera *cam, const hz_lod_params *params,
                              const hz_lod_stats *selected, const hz_patch *patches, size_t count, size_t from,
                              uint8_t *hidden, uint16_t *blocks, hz_horizon_stats *stats)
{
    HZ_ASSERT(lod && cam && selected && (patches || !count) && (hidden || !count));
    const double t0 = hz_time_ms();
    hz_lod_params p = params ? *params : (hz_lod_params){0};
    hz_horizon_stats hs = {0};
    const uint32_t P = lod->patch, B = hz_lod_patch_blocks(P);
    if (B < 2)
        blocks = NULL; /* a patch drawn whole: no quadrants to leave out */
    hz_result r = horizon_hidden(lod, cam, &p, selected, patches, count, hidden, blocks, from);
    if (r != HZ_OK) {
        memset(hidden, 0, count);
        if (blocks)
            memset(blocks, 0, count * sizeof *blocks);
    }
    for (size_t k = 0; k < count; k++) {
        if (k < from) {
            hidden[k] = 0; /* drawn before the cull was done */
            if (blocks)
                blocks[k] = 0;
            continue;
        }
        const uint8_t coarse = patches[k].coarse;
        if (hidden[k]) {
            hs.patches++;
            hs.triangles += hz__patch_triangles(P, coarse);
            hs.still += patches[k].still;
            hs.simple += patches[k].simple;
            continue;
        }
        const uint16_t quads = blocks ? blocks[k] : 0;
        uint16_t mask = 0;
        for (uint32_t q = 0; q < 4; q++) {
            if (!(quads >> q & 1u))
                continue;
            /* the quadrant's blocks, and its triangles: P^2 / 2, less one per
             * odd vertex of a stitched patch edge along it (P / 4 an edge) */
            const uint32_t qx = q & 1u, qz = q >> 1, h = B / 2;
            for (uint32_t bz = qz * h; bz < (qz + 1) * h; bz++)
                for (uint32_t bx = qx * h; bx < (qx + 1) * h; bx++)
                    mask |= (uint16_t)(1u << (B * bz + bx));
            const uint32_t edges = ((coarse >> qx) & 1u) + ((coarse >> (2 + qz)) & 1u);
            hs.triangles += P * P / 2 - edges * (P / 4);
            hs.quadrants++;
        }
        if (blocks)
            blocks[k] = mask;
    }
    hs.ms = hz_time_ms() - t0;
    if (stats)
        *stats = hs;
    return r;
}

hz_result hz_lod_patches_to_indices(const hz_lod *lod, const hz_patch *patches, size_t count, hz_index_list *out)
{
    return hz_patches_to_indices(lod->size, lod->patch, patches, count, out);
}

hz_result hz_patches_to_indices(uint32_t n, uint32_t P, const hz_patch *patches, size_t count, hz_index_list *out)
{
    for (size_t k = 0; k < count; k++) {
        const hz_patch *p = &patches[k];
        if (list_reserve((void **)&out->data, &out->cap, out->count + (size_t)6 * P * P, sizeof(uint32_t)))
            return HZ_ERR_MEMORY;
        const uint32_t st = 1u << p->shift;
        uint32_t *o = out->data + out->count;
        /* Vertex (u, w) after stitching, as the vertex shader moves it. */
#define VID(u_, w_)                                                                                              \
    ({                                                                                                           \
        uint32_t uu = (u_), ww = (w_);                                                                           \
        if ((uu & 1) && ((ww == 0 && (p->coarse & 4)) || (ww == P && (p->coarse & 8))))                          \
            uu--;                                                                                                \
        if ((ww & 1) && ((uu == 0 && (p->coarse & 1)) || (uu == P && (p->coarse & 2))))                          \
            ww--;                                                                                                \
        (p->z0 + ww * st) * n + p->x0 + uu * st;                                                                 \
    })
        for (uint32_t w = 0; w < P; w++)
            for (uint32_t u = 0; u < P; u++) {
                const uint32_t a = VID(u, w), b = VID(u, w + 1), c = VID(u + 1, w), d = VID(u + 1, w + 1);
                uint32_t tri[6];
                hz_lod_cell_triangles(cell_main_diagonal(u, w), a, b, c, d, tri);
                for (int t = 0; t < 6; t += 3)
                    if (tri[t] != tri[t + 1] && tri[t + 1] != tri[t + 2] && tri[t] != tri[t + 2]) {
                        *o++ = tri[t];
                        *o++ = tri[t + 1];
                        *o++ = tri[t + 2];
                    }
            }
#undef VID
        out->count = (size_t)(o - out->data);
    }
    return HZ_OK;
}

hz_result hz__lod_select_cdlod(hz_lod *lod, const hz_camera *cam, const hz_lod_params *p, hz_index_list *out,
                               hz_node_list *leaves, hz_node_list *culled, hz_lod_stats *st)
{
    hz_patch_list pl = {0};
    hz_result r = cdlod_select(lod, cam, p, culled, st);
    if (r == HZ_OK)
        r = emit_patches(lod, cam, &pl, st);
    if (r == HZ_OK)
        r = hz_lod_patches_to_indices(lod, pl.data, pl.count, out);
    for (size_t k = 0; r == HZ_OK && leaves && k < pl.count; k++) {
        const hz_patch *q = &pl.data[k];
        const uint32_t s = half_of(lod, q->level);
        r = push_node(leaves, q->x0 + s, q->z0 + s, s, q->level);
    }
    free(pl.data);
    return r;
}
