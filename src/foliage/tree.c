/* Tree growth (Weber & Penn 1995 style), the branch / leaf-node hierarchy
 * (SPEC F1) and its derived data. No GL. */
#include "horizon/tree.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "foliage_internal.h"

#define DEG2RAD 0.017453292519943295f

/* ---- species ---------------------------------------------------------------- */

/* Per stem level k (0 = trunk). Angles in degrees. */
typedef struct level_params {
    float length, length_v;  /* trunk: fraction of the tree scale; others: of the parent */
    uint32_t curve_res;      /* segments */
    float curve, curve_v;    /* total bend over the stem */
    float down, down_v;      /* angle to the parent stem */
    float rotate, rotate_v;  /* step around the parent between siblings */
    float children;          /* stems of level k+1 on one stem of this level */
    float taper;             /* tip radius = base * (1 - taper) */
} level_params;

typedef struct species_params {
    const char *name;
    float scale, scale_v;    /* metres */
    float base_size;         /* trunk fraction without branches */
    int shape;               /* Weber & Penn crown shape 0..7 */
    float ratio, ratio_power;/* trunk radius = ratio * height; child r = parent r (Lc/Lp)^power */
    float attraction_up;     /* bend of branches (level >= 2) toward +y per unit length */
    uint32_t levels;         /* stem levels, trunk included */
    level_params lv[4];
    float leaves;            /* per last-level stem */
    float leaf_down, leaf_down_v;
    float leaf_len, leaf_width, leaf_v; /* metres, relative variation */
    float leaf_color[3], bark_color[3];
} species_params;

static const species_params SPECIES[] = {
    {.name = "oak", .scale = 13.0f, .scale_v = 1.5f, .base_size = 0.28f, .shape = 2, .ratio = 0.030f,
     .ratio_power = 1.3f, .attraction_up = 0.25f, .levels = 4,
     .lv = {{1.0f, 0.05f, 6, 10, 20, 0, 0, 0, 0, 28, 0.6f},
            {0.55f, 0.15f, 6, -25, 40, 55, 12, 140, 30, 22, 0.8f},
            {0.40f, 0.15f, 3, -10, 40, 45, 15, 140, 30, 11, 0.9f},
            {0.38f, 0.10f, 2, 0, 30, 40, 15, 77, 20, 0, 0.95f}},
     .leaves = 26, .leaf_down = 50, .leaf_down_v = 20, .leaf_len = 0.12f, .leaf_width = 0.075f, .leaf_v = 0.2f,
     .leaf_color = {0.16f, 0.30f, 0.07f}, .bark_color = {0.28f, 0.22f, 0.16f}},
    {.name = "maple", .scale = 15.0f, .scale_v = 2.0f, .base_size = 0.30f, .shape = 7, .ratio = 0.025f,
     .ratio_power = 1.4f, .attraction_up = 0.45f, .levels = 4,
     .lv = {{1.0f, 0.05f, 6, 6, 15, 0, 0, 0, 0, 24, 0.6f},
            {0.50f, 0.15f, 6, -15, 30, 40, 10, 137, 25, 20, 0.8f},
            {0.42f, 0.15f, 3, -5, 35, 40, 12, 140, 30, 13, 0.9f},
            {0.40f, 0.10f, 2, 0, 25, 45, 15, 90, 20, 0, 0.95f}},
     .leaves = 30, .leaf_down = 55, .leaf_down_v = 20, .leaf_len = 0.13f, .leaf_width = 0.11f, .leaf_v = 0.2f,
     .leaf_color = {0.20f, 0.34f, 0.06f}, .bark_color = {0.33f, 0.29f, 0.25f}},
    {.name = "birch", .scale = 16.0f, .scale_v = 2.0f, .base_size = 0.35f, .shape = 4, .ratio = 0.018f,
     .ratio_power = 1.2f, .attraction_up = -0.25f, .levels = 4,
     .lv = {{1.0f, 0.05f, 8, 5, 10, 0, 0, 0, 0, 26, 0.7f},
            {0.40f, 0.15f, 6, 20, 30, 45, 10, 137, 25, 14, 0.8f},
            {0.45f, 0.15f, 3, 20, 35, 35, 12, 140, 30, 10, 0.9f},
            {0.45f, 0.10f, 2, 15, 25, 30, 15, 90, 20, 0, 0.95f}},
     .leaves = 24, .leaf_down = 60, .leaf_down_v = 20, .leaf_len = 0.07f, .leaf_width = 0.05f, .leaf_v = 0.2f,
     .leaf_color = {0.26f, 0.38f, 0.08f}, .bark_color = {0.78f, 0.76f, 0.72f}},
    {.name = "conifer", .scale = 20.0f, .scale_v = 3.0f, .base_size = 0.15f, .shape = 0, .ratio = 0.020f,
     .ratio_power = 1.5f, .attraction_up = -0.15f, .levels = 3,
     .lv = {{1.0f, 0.05f, 8, 2, 6, 0, 0, 0, 0, 70, 0.9f},
            {0.30f, 0.15f, 5, -10, 20, 85, 10, 137.5f, 15, 24, 0.9f},
            {0.32f, 0.15f, 2, 0, 20, 50, 15, 180, 30, 0, 0.95f},
            {0}},
     .leaves = 60, .leaf_down = 60, .leaf_down_v = 15, .leaf_len = 0.09f, .leaf_width = 0.025f, .leaf_v = 0.15f,
     .leaf_color = {0.07f, 0.20f, 0.08f}, .bark_color = {0.30f, 0.22f, 0.17f}},
};
#define NSPECIES (sizeof SPECIES / sizeof SPECIES[0])

const char *const *hz_tree_species_names(void)
{
    static const char *const names[] = {"oak", "maple", "birch", "conifer", NULL};
    return names;
}

static const species_params *find_species(const char *name)
{
    for (size_t k = 0; k < NSPECIES; k++)
        if (!strcmp(SPECIES[k].name, name))
            return &SPECIES[k];
    return NULL;
}

/* Weber & Penn's crown envelope, ratio r in [0, 1] (0 at the crown base). */
static float shape_ratio(int shape, float r)
{
    switch (shape) {
    case 0: return 0.2f + 0.8f * r;                       /* conical */
    case 1: return 0.2f + 0.8f * sinf(3.14159265f * r);   /* spherical */
    case 2: return 0.2f + 0.8f * sinf(1.5707963f * r);    /* hemispherical */
    case 3: return 1.0f;                                  /* cylindrical */
    case 4: return 0.5f + 0.5f * r;                       /* tapered cylindrical */
    case 5: return r <= 0.7f ? r / 0.7f : (1.0f - r) / 0.3f; /* flame */
    case 6: return 1.0f - 0.8f * r;                       /* inverse conical */
    default: return r <= 0.7f ? 0.5f + 0.5f * r / 0.7f : 0.5f + 0.5f * (1.0f - r) / 0.3f; /* tend flame */
    }
}

/* ---- growable arrays --------------------------------------------------------- */

typedef struct buf {
    void *p;
    size_t n, cap, elem;
} buf;

static void *buf_push(buf *b)
{
    if (b->n == b->cap) {
        size_t nc = b->cap ? b->cap * 2 : 256;
        void *np = realloc(b->p, nc * b->elem);
        if (!np)
            return NULL;
        b->p = np;
        b->cap = nc;
    }
    void *r = (char *)b->p + b->n * b->elem;
    memset(r, 0, b->elem);
    b->n++;
    return r;
}

typedef struct stem_pt {
    float p[3];
    float r;
} stem_pt;

typedef struct stem_rec {
    uint32_t branch, level, first_pt, npts;
} stem_rec;

typedef struct grow_ctx {
    const species_params *sp;
    hz_rng rng;
    float leaf_mul, twig_mul; /* leaf-count scaling */
    buf branches, leaves, nodes, pts, stems;
    bool oom;
    uint32_t max_leaves;
} grow_ctx;

/* Point and direction at fraction t along a polyline. */
static void polyline_at(const stem_pt *pts, uint32_t n, float t, float *pos, float *dir, float *radius)
{
    float f = t * (float)(n - 1);
    uint32_t i = (uint32_t)f;
    if (i >= n - 1)
        i = n - 2;
    float a = f - (float)i;
    for (int k = 0; k < 3; k++)
        pos[k] = pts[i].p[k] + (pts[i + 1].p[k] - pts[i].p[k]) * a;
    v3_sub(dir, pts[i + 1].p, pts[i].p);
    v3_norm(dir);
    *radius = pts[i].r + (pts[i + 1].r - pts[i].r) * a;
}

static void grow_stem(grow_ctx *g, uint32_t k, uint32_t parent, const float *start, const float *dir0,
                      float length, float radius)
{
    const species_params *sp = g->sp;
    const level_params *lp = &sp->lv[k];
    if (g->oom || length <= 1e-3f)
        return;
    uint32_t res = lp->curve_res ? lp->curve_res : 1;
    uint32_t first_pt = (uint32_t)g->pts.n;
    float d[3], side[3], p[3];
    v3_copy(d, dir0);
    v3_copy(p, start);
    v3_perp(side, d);
    v3_rotate(side, side, d, rng_unit(&g->rng) * 6.2831853f);
    const float seg = length / (float)res;
    const float up[3] = {0, 1, 0};
    for (uint32_t i = 0; i <= res; i++) {
        stem_pt *sp_ = buf_push(&g->pts);
        if (!sp_) {
            g->oom = true;
            return;
        }
        v3_copy(sp_->p, p);
        sp_->r = radius * (1.0f - lp->taper * (float)i / (float)res);
        if (i == res)
            break;
        float bend = (lp->curve + rng_sym(&g->rng) * lp->curve_v) / (float)res * DEG2RAD;
        v3_rotate(d, d, side, bend);
        if (k >= 1 && sp->attraction_up != 0.0f) {
            v3_madd(d, d, up, sp->attraction_up * seg / (length + 1.0f));
            v3_norm(d);
        }
        v3_madd(p, p, d, seg);
    }
    uint32_t npts = res + 1;
    uint32_t self = (uint32_t)g->branches.n;
    hz_tree_branch *b = buf_push(&g->branches);
    stem_rec *sr = buf_push(&g->stems);
    if (!b || !sr) {
        g->oom = true;
        return;
    }
    b->parent = parent;
    b->level = k + 1;
    b->leaf_node = HZ_TREE_NONE;
    b->length = length;
    b->radius = radius;
    const stem_pt *pts = (const stem_pt *)g->pts.p + first_pt;
    v3_copy(b->base, pts[0].p);
    v3_copy(b->tip, pts[npts - 1].p);
    v3_sub(b->dir, b->tip, b->base);
    v3_norm(b->dir);
    *sr = (stem_rec){self, k + 1, first_pt, npts};

    if (k + 1 < sp->levels) {
        /* Children: level k+1 stems. */
        const level_params *cp = &sp->lv[k + 1];
        float n_f = lp->children * (k + 2 == sp->levels ? g->twig_mul : 1.0f);
        /* Stochastic rounding keeps small multipliers meaningful. */
        float nf = n_f * (0.85f + 0.3f * rng_unit(&g->rng));
        uint32_t n = (uint32_t)nf + (rng_unit(&g->rng) < nf - floorf(nf) ? 1u : 0u);
        float rot = rng_unit(&g->rng) * 360.0f;
        for (uint32_t c = 0; c < n && !g->oom; c++) {
            float t;
            if (k == 0)
                t = sp->base_size + (1.0f - sp->base_size) * ((float)c + 0.5f + 0.4f * rng_sym(&g->rng)) / (float)n;
            else
                t = 0.12f + 0.85f * ((float)c + 0.5f + 0.4f * rng_sym(&g->rng)) / (float)n;
            t = fminf(fmaxf(t, 0.0f), 0.98f);
            float cl;
            if (k == 0) {
                float r = (1.0f - t) / fmaxf(1.0f - sp->base_size, 1e-3f);
                cl = length * cp->length * shape_ratio(sp->shape, fminf(fmaxf(r, 0.0f), 1.0f));
            } else {
                cl = cp->length * (length - 0.6f * t * length);
            }
            cl *= 1.0f + cp->length_v * rng_sym(&g->rng);
            /* Deeper stems get fewer children when short (Weber & Penn). */
            if (k >= 1 && rng_unit(&g->rng) < 0.5f * t)
                continue;
            pts = (const stem_pt *)g->pts.p + first_pt; /* the array may have moved */
            float cpos[3], pdir[3], pr;
            polyline_at(pts, npts, t, cpos, pdir, &pr);
            rot += cp->rotate + cp->rotate_v * rng_sym(&g->rng);
            float axis[3];
            v3_perp(axis, pdir);
            v3_rotate(axis, axis, pdir, rot * DEG2RAD);
            float down = cp->down + cp->down_v * rng_sym(&g->rng);
            float cdir[3];
            v3_rotate(cdir, pdir, axis, down * DEG2RAD);
            float cr = radius * powf(fmaxf(cl, 1e-4f) / length, sp->ratio_power);
            cr = fminf(cr, pr * 0.9f);
            grow_stem(g, k + 1, self, cpos, cdir, cl, cr);
        }
    } else {
        /* Last level: leaves, one leaf node for this stem. */
        float mf = sp->leaves * g->leaf_mul * (0.8f + 0.4f * rng_unit(&g->rng));
        uint32_t m = (uint32_t)mf + (rng_unit(&g->rng) < mf - floorf(mf) ? 1u : 0u);
        if (m == 0)
            m = 1;
        if (g->leaves.n + m > g->max_leaves) {
            g->oom = true;
            return;
        }
        uint32_t node_index = (uint32_t)g->nodes.n;
        hz_tree_node *nd = buf_push(&g->nodes);
        if (!nd) {
            g->oom = true;
            return;
        }
        nd->branch = self;
        nd->first = (uint32_t)g->leaves.n;
        nd->count = m;
        ((hz_tree_branch *)g->branches.p)[self].leaf_node = node_index;
        float rot = rng_unit(&g->rng) * 360.0f;
        for (uint32_t i = 0; i < m; i++) {
            hz_tree_leaf *lf = buf_push(&g->leaves);
            if (!lf) {
                g->oom = true;
                return;
            }
            pts = (const stem_pt *)g->pts.p + first_pt;
            float t = 0.1f + 0.9f * ((float)i + 0.5f) / (float)m;
            float lp_[3], sdir[3], pr;
            polyline_at(pts, npts, t, lp_, sdir, &pr);
            rot += 137.5f + 15.0f * rng_sym(&g->rng);
            float axis[3];
            v3_perp(axis, sdir);
            v3_rotate(axis, axis, sdir, rot * DEG2RAD);
            float ldir[3];
            v3_rotate(ldir, sdir, axis, (sp->leaf_down + sp->leaf_down_v * rng_sym(&g->rng)) * DEG2RAD);
            float len = sp->leaf_len * (1.0f + sp->leaf_v * rng_sym(&g->rng));
            float wid = sp->leaf_width * (1.0f + sp->leaf_v * rng_sym(&g->rng));
            float across[3];
            v3_cross(across, ldir, sdir);
            if (v3_len(across) < 1e-4f)
                v3_perp(across, ldir);
            v3_norm(across);
            /* Twist the blade a little about its own axis. */
            v3_rotate(across, across, ldir, 0.5f * rng_sym(&g->rng));
            v3_scale(lf->u, ldir, 0.5f * len);
            v3_scale(lf->v, across, 0.5f * wid);
            v3_madd(lf->c, lp_, ldir, 0.5f * len + 0.01f);
        }
    }
}

/* Tube meshes of every stem, trunk level first. */
static hz_result build_bark(hz_tree *t, const stem_rec *stems, size_t nstems, const stem_pt *pts, hz_err *err)
{
    static const uint32_t sides_by_level[HZ_TREE_MAX_LEVELS] = {10, 6, 4, 3, 3, 3};
    uint64_t nv = 0, ni = 0;
    for (size_t s = 0; s < nstems; s++) {
        uint32_t sides = sides_by_level[stems[s].level - 1];
        nv += (uint64_t)stems[s].npts * sides;
        ni += (uint64_t)(stems[s].npts - 1) * sides * 6;
    }
    if (nv > UINT32_MAX / 2 || ni > UINT32_MAX / 2)
        return hz_err_set(err, HZ_ERR_VALUE, "tree: bark mesh too large");
    t->bark.pos = malloc((size_t)nv * 3 * sizeof(float));
    t->bark.nrm = malloc((size_t)nv * 3 * sizeof(float));
    t->bark.idx = malloc((size_t)ni * sizeof(uint32_t));
    if (!t->bark.pos || !t->bark.nrm || !t->bark.idx)
        return hz_err_set(err, HZ_ERR_MEMORY, "out of memory");
    uint32_t v = 0, i = 0;
    for (uint32_t level = 1; level <= t->levels; level++) {
        for (size_t s = 0; s < nstems; s++) {
            if (stems[s].level != level)
                continue;
            const stem_pt *p = pts + stems[s].first_pt;
            uint32_t n = stems[s].npts, sides = sides_by_level[level - 1];
            float d[3], a[3], b[3];
            v3_sub(d, p[1].p, p[0].p);
            v3_norm(d);
            v3_perp(a, d);
            for (uint32_t k = 0; k < n; k++) {
                float dk[3];
                if (k + 1 < n)
                    v3_sub(dk, p[k + 1].p, p[k].p);
                else
                    v3_sub(dk, p[k].p, p[k - 1].p);
                v3_norm(dk);
                /* Parallel transport: keep a perpendicular to the current axis. */
                v3_madd(a, a, dk, -v3_dot(a, dk));
                if (v3_len(a) < 1e-5f)
                    v3_perp(a, dk);
                v3_norm(a);
                v3_cross(b, dk, a);
                for (uint32_t j = 0; j < sides; j++) {
                    float ang = 6.2831853f * (float)j / (float)sides, nrm[3];
                    for (int c = 0; c < 3; c++)
                        nrm[c] = a[c] * cosf(ang) + b[c] * sinf(ang);
                    uint32_t vi = v + k * sides + j;
                    v3_madd(&t->bark.pos[vi * 3], p[k].p, nrm, p[k].r);
                    v3_copy(&t->bark.nrm[vi * 3], nrm);
                }
            }
            for (uint32_t k = 0; k + 1 < n; k++)
                for (uint32_t j = 0; j < sides; j++) {
                    uint32_t j1 = (j + 1) % sides;
                    uint32_t a0 = v + k * sides + j, a1 = v + k * sides + j1;
                    uint32_t b0 = a0 + sides, b1 = a1 + sides;
                    /* Outward facing, counter-clockwise seen from outside. */
                    t->bark.idx[i++] = a0, t->bark.idx[i++] = a1, t->bark.idx[i++] = b1;
                    t->bark.idx[i++] = a0, t->bark.idx[i++] = b1, t->bark.idx[i++] = b0;
                }
            v += n * sides;
        }
        t->bark_level_end[level - 1] = i;
    }
    t->bark.vertex_count = v;
    t->bark.index_count = i;
    return HZ_OK;
}

void hz_tree_finish(hz_tree *t)
{
    /* Node spheres from the leaf corners; leaf density per branch metre. */
    for (uint32_t n = 0; n < t->node_count; n++) {
        hz_tree_node *nd = &t->nodes[n];
        float lo[3] = {FLT_MAX, FLT_MAX, FLT_MAX}, hi[3] = {-FLT_MAX, -FLT_MAX, -FLT_MAX};
        for (uint32_t k = nd->first; k < nd->first + nd->count; k++) {
            const hz_tree_leaf *l = &t->leaves[k];
            for (int c = 0; c < 3; c++) {
                float e = fabsf(l->u[c]) + fabsf(l->v[c]);
                lo[c] = fminf(lo[c], l->c[c] - e);
                hi[c] = fmaxf(hi[c], l->c[c] + e);
            }
        }
        for (int c = 0; c < 3; c++)
            nd->center[c] = 0.5f * (lo[c] + hi[c]);
        float r = 0.0f;
        for (uint32_t k = nd->first; k < nd->first + nd->count; k++) {
            const hz_tree_leaf *l = &t->leaves[k];
            for (int s = 0; s < 4; s++) {
                float q[3];
                v3_madd(q, l->c, l->u, (s & 1) ? 1.0f : -1.0f);
                v3_madd(q, q, l->v, (s & 2) ? 1.0f : -1.0f);
                r = fmaxf(r, v3_dist(q, nd->center));
            }
        }
        nd->radius = r * 1.0001f + 1e-5f;
        float len = nd->branch < t->branch_count ? t->branches[nd->branch].length : 1.0f;
        nd->ld = (float)nd->count / fmaxf(len, 1e-3f);
    }
    /* Crown sphere: leaf centres. */
    double sc[3] = {0, 0, 0};
    for (uint32_t k = 0; k < t->leaf_count; k++)
        for (int c = 0; c < 3; c++)
            sc[c] += t->leaves[k].c[c];
    for (int c = 0; c < 3; c++)
        t->crown_center[c] = t->leaf_count ? (float)(sc[c] / t->leaf_count) : 0.0f;
    float cr = 0.0f;
    for (uint32_t k = 0; k < t->leaf_count; k++)
        cr = fmaxf(cr, v3_dist(t->leaves[k].c, t->crown_center) + v3_len(t->leaves[k].u) + v3_len(t->leaves[k].v));
    t->crown_radius = cr;
    /* Bounding-sphere layers: node distance from the crown centre relative to
     * the farthest node: outer quarter = 1, middle = 2, inner = 3. */
    float dmax = 1e-6f;
    for (uint32_t n = 0; n < t->node_count; n++)
        dmax = fmaxf(dmax, v3_dist(t->nodes[n].center, t->crown_center));
    for (uint32_t n = 0; n < t->node_count; n++) {
        float d = v3_dist(t->nodes[n].center, t->crown_center) / dmax;
        t->nodes[n].bsl = d > 0.75f ? 1u : d > 0.45f ? 2u : 3u;
    }
    /* Whole-tree bounds. */
    float lo[3] = {FLT_MAX, FLT_MAX, FLT_MAX}, hi[3] = {-FLT_MAX, -FLT_MAX, -FLT_MAX};
    for (uint32_t v = 0; v < t->bark.vertex_count; v++)
        for (int c = 0; c < 3; c++) {
            lo[c] = fminf(lo[c], t->bark.pos[v * 3 + c]);
            hi[c] = fmaxf(hi[c], t->bark.pos[v * 3 + c]);
        }
    for (uint32_t n = 0; n < t->node_count; n++)
        for (int c = 0; c < 3; c++) {
            lo[c] = fminf(lo[c], t->nodes[n].center[c] - t->nodes[n].radius);
            hi[c] = fmaxf(hi[c], t->nodes[n].center[c] + t->nodes[n].radius);
        }
    if (lo[0] > hi[0])
        for (int c = 0; c < 3; c++)
            lo[c] = hi[c] = 0.0f;
    for (int c = 0; c < 3; c++)
        t->bound_center[c] = 0.5f * (lo[c] + hi[c]);
    float br = 0.0f;
    for (uint32_t v = 0; v < t->bark.vertex_count; v++)
        br = fmaxf(br, v3_dist(&t->bark.pos[v * 3], t->bound_center));
    for (uint32_t n = 0; n < t->node_count; n++)
        br = fmaxf(br, v3_dist(t->nodes[n].center, t->bound_center) + t->nodes[n].radius);
    t->bound_radius = br;
    t->height = hi[1];
}

static void grow_free(grow_ctx *g)
{
    free(g->branches.p);
    free(g->leaves.p);
    free(g->nodes.p);
    free(g->pts.p);
    free(g->stems.p);
}

/* One growth pass with the given leaf/twig multipliers. */
static hz_tree *grow_once(const species_params *sp, uint64_t seed, float leaf_mul, float twig_mul, hz_err *err)
{
    grow_ctx g = {.sp = sp, .rng = {seed * 0x2545F4914F6CDD1DULL + 0x1234567ULL}, .leaf_mul = leaf_mul,
                  .twig_mul = twig_mul, .max_leaves = 2500000};
    g.branches.elem = sizeof(hz_tree_branch);
    g.leaves.elem = sizeof(hz_tree_leaf);
    g.nodes.elem = sizeof(hz_tree_node);
    g.pts.elem = sizeof(stem_pt);
    g.stems.elem = sizeof(stem_rec);
    float height = sp->scale + sp->scale_v * rng_sym(&g.rng);
    const float origin[3] = {0, 0, 0}, up[3] = {0, 1, 0};
    grow_stem(&g, 0, HZ_TREE_NONE, origin, up, height * sp->lv[0].length, height * sp->ratio);
    hz_tree *t = NULL;
    if (g.oom) {
        hz_err_set(err, HZ_ERR_MEMORY, "tree: out of memory (or more than %u leaves) growing %s", g.max_leaves,
                   sp->name);
        goto fail;
    }
    t = calloc(1, sizeof *t);
    if (!t) {
        hz_err_set(err, HZ_ERR_MEMORY, "out of memory");
        goto fail;
    }
    snprintf(t->species, sizeof t->species, "%s", sp->name);
    t->levels = sp->levels;
    t->branches = g.branches.p;
    t->branch_count = (uint32_t)g.branches.n;
    t->leaves = g.leaves.p;
    t->leaf_count = (uint32_t)g.leaves.n;
    t->nodes = g.nodes.p;
    t->node_count = (uint32_t)g.nodes.n;
    g.branches.p = g.leaves.p = g.nodes.p = NULL;
    memcpy(t->leaf_color, sp->leaf_color, sizeof t->leaf_color);
    memcpy(t->bark_color, sp->bark_color, sizeof t->bark_color);
    if (build_bark(t, g.stems.p, g.stems.n, g.pts.p, err) != HZ_OK) {
        hz_tree_destroy(t);
        t = NULL;
        goto fail;
    }
    hz_tree_finish(t);
fail:
    grow_free(&g);
    return t;
}

hz_tree *hz_tree_grow(const hz_tree_desc *desc, hz_err *err)
{
    hz_tree_desc d = desc ? *desc : (hz_tree_desc){0};
    const char *name = d.species ? d.species : "oak";
    const species_params *sp = find_species(name);
    if (!sp) {
        hz_err_set(err, HZ_ERR_VALUE, "tree: unknown species '%s' (known: oak, maple, birch, conifer)", name);
        return NULL;
    }
    if (d.leaves > 2000000) {
        hz_err_set(err, HZ_ERR_VALUE, "tree: %u leaves is more than the 2 000 000 supported", d.leaves);
        return NULL;
    }
    hz_tree *t = grow_once(sp, d.seed, 1.0f, 1.0f, err);
    if (t && d.leaves > 0) {
        /* Scale the number of twigs (and, for small trees, leaves per twig)
         * toward the target, then regrow with the same seed. */
        float f = (float)d.leaves / (float)(t->leaf_count ? t->leaf_count : 1);
        float leaf_mul = 1.0f, twig_mul = f;
        if (f < 0.25f) {
            leaf_mul = sqrtf(f / 0.25f);
            twig_mul = f / leaf_mul;
        }
        for (int pass = 0; pass < 6 && t; pass++) {
            float ratio = (float)t->leaf_count / (float)d.leaves;
            if (ratio > 0.92f && ratio < 1.08f)
                break;
            if (pass > 0)
                twig_mul *= fminf(fmaxf(1.0f / fmaxf(ratio, 1e-3f), 0.25f), 4.0f);
            hz_tree_destroy(t);
            t = grow_once(sp, d.seed, leaf_mul, twig_mul, err);
        }
    }
    if (t && t->leaf_count == 0) {
        hz_err_set(err, HZ_ERR_VALUE, "tree: %s grew no leaves (asked for %u)", name, d.leaves);
        hz_tree_destroy(t);
        t = NULL;
    }
    if (t)
        t->seed = d.seed;
    return t;
}

void hz_tree_destroy(hz_tree *t)
{
    if (!t)
        return;
    free(t->branches);
    free(t->nodes);
    free(t->leaves);
    free(t->bark.pos);
    free(t->bark.nrm);
    free(t->bark.idx);
    free(t->hull.pos);
    free(t->hull.nrm);
    free(t->hull.idx);
    free(t);
}

uint64_t hz_tree_triangles(const hz_tree *t)
{
    return 2ull * t->leaf_count + t->bark.index_count / 3;
}

size_t hz_tree_memory_bytes(const hz_tree *t)
{
    return sizeof *t + (size_t)t->branch_count * sizeof *t->branches + (size_t)t->node_count * sizeof *t->nodes +
           (size_t)t->leaf_count * sizeof *t->leaves + (size_t)t->bark.vertex_count * 24 +
           (size_t)t->bark.index_count * 4 + (size_t)t->hull.vertex_count * 24 + (size_t)t->hull.index_count * 4;
}

static bool finite3(const float *v)
{
    return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]);
}

/* Finite and within HZ_TREE_MAX_COORD metres (false for NaN). */
static bool bounded3(const float *v)
{
    for (int c = 0; c < 3; c++)
        if (!(fabsf(v[c]) <= HZ_TREE_MAX_COORD))
            return false;
    return true;
}

static hz_result check_mesh(const hz_tree_mesh *m, const char *what, hz_err *err)
{
    if (m->index_count % 3)
        return hz_err_set(err, HZ_ERR_FORMAT, "tree: %s index count %u is not a multiple of 3", what, m->index_count);
    if ((m->vertex_count && (!m->pos || !m->nrm)) || (m->index_count && !m->idx))
        return hz_err_set(err, HZ_ERR_FORMAT, "tree: %s has counts but no data", what);
    for (uint32_t k = 0; k < m->index_count; k++)
        if (m->idx[k] >= m->vertex_count)
            return hz_err_set(err, HZ_ERR_FORMAT, "tree: %s index %u = %u is out of range (%u vertices)", what, k,
                              m->idx[k], m->vertex_count);
    for (uint32_t v = 0; v < m->vertex_count; v++)
        if (!bounded3(&m->pos[v * 3]) || !finite3(&m->nrm[v * 3]))
            return hz_err_set(err, HZ_ERR_FORMAT, "tree: %s vertex %u is not finite or lies beyond %.0f m", what, v,
                              (double)HZ_TREE_MAX_COORD);
    return HZ_OK;
}

hz_result hz_tree_validate(const hz_tree *t, hz_err *err)
{
    if (!t->branch_count || !t->branches)
        return hz_err_set(err, HZ_ERR_FORMAT, "tree: no branches");
    if (t->levels < 1 || t->levels > HZ_TREE_MAX_LEVELS)
        return hz_err_set(err, HZ_ERR_FORMAT, "tree: %u levels (1..%u supported)", t->levels, HZ_TREE_MAX_LEVELS);
    if (t->branches[0].parent != HZ_TREE_NONE || t->branches[0].level != 1)
        return hz_err_set(err, HZ_ERR_FORMAT, "tree: branch 0 is not the trunk (level 1, no parent)");
    for (uint32_t b = 0; b < t->branch_count; b++) {
        const hz_tree_branch *br = &t->branches[b];
        if (b > 0) {
            if (br->parent == HZ_TREE_NONE || br->parent >= b)
                return hz_err_set(err, HZ_ERR_FORMAT, "tree: branch %u has parent %u (must be an earlier branch)", b,
                                  br->parent);
            if (br->level != t->branches[br->parent].level + 1)
                return hz_err_set(err, HZ_ERR_FORMAT, "tree: branch %u has level %u but its parent has level %u", b,
                                  br->level, t->branches[br->parent].level);
        }
        if (br->level > t->levels)
            return hz_err_set(err, HZ_ERR_FORMAT, "tree: branch %u level %u exceeds the tree's %u levels", b,
                              br->level, t->levels);
        if (br->leaf_node != HZ_TREE_NONE &&
            (br->leaf_node >= t->node_count || t->nodes[br->leaf_node].branch != b))
            return hz_err_set(err, HZ_ERR_FORMAT, "tree: branch %u names leaf node %u which does not point back", b,
                              br->leaf_node);
        if (!bounded3(br->base) || !bounded3(br->tip) || !finite3(br->dir) || !isfinite(br->length) ||
            !isfinite(br->radius) || br->length < 0.0f || br->radius < 0.0f)
            return hz_err_set(err, HZ_ERR_FORMAT,
                              "tree: branch %u has non-finite or negative geometry, or ends beyond %.0f m", b,
                              (double)HZ_TREE_MAX_COORD);
    }
    /* Leaf nodes tile the leaf array in order: every leaf in exactly one. */
    uint32_t next = 0;
    for (uint32_t n = 0; n < t->node_count; n++) {
        const hz_tree_node *nd = &t->nodes[n];
        if (nd->branch >= t->branch_count || t->branches[nd->branch].leaf_node != n)
            return hz_err_set(err, HZ_ERR_FORMAT, "tree: leaf node %u has branch %u which does not carry it", n,
                              nd->branch);
        if (nd->first != next || nd->count == 0 || nd->count > 65535 || nd->count > t->leaf_count - next)
            return hz_err_set(err, HZ_ERR_FORMAT,
                              "tree: leaf node %u covers leaves [%u, %u) but the next unassigned leaf is %u "
                              "(nodes must tile the %u leaves, 1..65535 each)",
                              n, nd->first, nd->first + nd->count, next, t->leaf_count);
        next += nd->count;
        if (nd->bsl < 1 || nd->bsl > 3 || !finite3(nd->center) || !isfinite(nd->radius) || !isfinite(nd->ld))
            return hz_err_set(err, HZ_ERR_FORMAT, "tree: leaf node %u has bad derived data", n);
    }
    if (next != t->leaf_count)
        return hz_err_set(err, HZ_ERR_FORMAT, "tree: leaf nodes cover %u of %u leaves", next, t->leaf_count);
    for (uint32_t k = 0; k < t->leaf_count; k++)
        if (!bounded3(t->leaves[k].c) || !bounded3(t->leaves[k].u) || !bounded3(t->leaves[k].v))
            return hz_err_set(err, HZ_ERR_FORMAT, "tree: leaf %u is not finite or lies beyond %.0f m", k,
                              (double)HZ_TREE_MAX_COORD);
    hz_result r = check_mesh(&t->bark, "bark", err);
    if (r != HZ_OK)
        return r;
    uint32_t prev = 0;
    for (uint32_t l = 0; l < t->levels; l++) {
        if (t->bark_level_end[l] < prev || t->bark_level_end[l] > t->bark.index_count || t->bark_level_end[l] % 3)
            return hz_err_set(err, HZ_ERR_FORMAT, "tree: bark level ranges are not increasing multiples of 3");
        prev = t->bark_level_end[l];
    }
    if (t->levels && t->bark_level_end[t->levels - 1] != t->bark.index_count)
        return hz_err_set(err, HZ_ERR_FORMAT, "tree: bark level ranges do not end at the index count");
    return check_mesh(&t->hull, "hull", err);
}

hz_result hz_tree_apply_order(hz_tree *t, const uint32_t *node_orders, hz_err *err)
{
    uint32_t maxc = 0;
    for (uint32_t n = 0; n < t->node_count; n++)
        if (t->nodes[n].count > maxc)
            maxc = t->nodes[n].count;
    hz_tree_leaf *tmp = malloc((size_t)maxc * sizeof *tmp);
    uint8_t *seen = malloc(maxc ? maxc : 1);
    if (!tmp || !seen) {
        free(tmp);
        free(seen);
        return hz_err_set(err, HZ_ERR_MEMORY, "out of memory");
    }
    const uint32_t *o = node_orders;
    for (uint32_t n = 0; n < t->node_count; n++) {
        const hz_tree_node *nd = &t->nodes[n];
        memset(seen, 0, nd->count);
        for (uint32_t k = 0; k < nd->count; k++) {
            if (o[k] >= nd->count || seen[o[k]]) {
                free(tmp);
                free(seen);
                return hz_err_set(err, HZ_ERR_VALUE, "tree: order of leaf node %u is not a permutation", n);
            }
            seen[o[k]] = 1;
            tmp[k] = t->leaves[nd->first + o[k]];
        }
        memcpy(t->leaves + nd->first, tmp, nd->count * sizeof *tmp);
        o += nd->count;
    }
    free(tmp);
    free(seen);
    return HZ_OK;
}

/* ---- viewpoints --------------------------------------------------------------- */

bool hz_sphere_views(uint32_t count, float *dirs)
{
    int subdiv = count == 12 ? 0 : count == 42 ? 1 : count == 162 ? 2 : -1;
    if (subdiv < 0)
        return false;
    const float p = 1.6180339887f;
    float v[162][3];
    uint32_t nv = 0;
    const float base[12][3] = {{-1, p, 0}, {1, p, 0}, {-1, -p, 0}, {1, -p, 0}, {0, -1, p}, {0, 1, p},
                               {0, -1, -p}, {0, 1, -p}, {p, 0, -1}, {p, 0, 1}, {-p, 0, -1}, {-p, 0, 1}};
    static const uint8_t faces[20][3] = {{0, 11, 5}, {0, 5, 1}, {0, 1, 7}, {0, 7, 10}, {0, 10, 11},
                                         {1, 5, 9}, {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                         {3, 9, 4}, {3, 4, 2}, {3, 2, 6}, {3, 6, 8}, {3, 8, 9},
                                         {4, 9, 5}, {2, 4, 11}, {6, 2, 10}, {8, 6, 7}, {9, 8, 1}};
    for (int k = 0; k < 12; k++) {
        v3_copy(v[nv], base[k]);
        v3_norm(v[nv]);
        nv++;
    }
    /* Subdivision points: each face split into (2^subdiv)^2 triangles; the
     * new vertices are the normalised lattice points, deduplicated. */
    int m = 1 << subdiv;
    for (int f = 0; f < 20 && subdiv > 0; f++) {
        const float *A = v[faces[f][0]], *B = v[faces[f][1]], *C = v[faces[f][2]];
        for (int i = 0; i <= m; i++)
            for (int j = 0; j <= m - i; j++) {
                int k = m - i - j;
                if ((i == m) || (j == m) || (k == m))
                    continue; /* an original vertex */
                float q[3];
                for (int c = 0; c < 3; c++)
                    q[c] = ((float)i * A[c] + (float)j * B[c] + (float)k * C[c]) / (float)m;
                v3_norm(q);
                bool dup = false;
                for (uint32_t e = 12; e < nv && !dup; e++)
                    dup = v3_dist(v[e], q) < 1e-4f;
                if (!dup && nv < 162) {
                    v3_copy(v[nv], q);
                    nv++;
                }
            }
    }
    if (nv != count)
        return false;
    memcpy(dirs, v, (size_t)count * 3 * sizeof(float));
    return true;
}
