/* Forests: placement on the terrain, the per-node rate (F3), enlargement
 * (F4), hysteresis (F6) and per-frame selection with culling. No GL. */
#include "horizon/forest.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "foliage_internal.h"

/* ---- rate function ---------------------------------------------------------- */

hz_rate_params hz_rate_params_defaults(const hz_rate_params *p)
{
    hz_rate_params d = p ? *p : (hz_rate_params){0};
    if (d.w[0] == 0 && d.w[1] == 0 && d.w[2] == 0 && d.w[3] == 0 && d.w[4] == 0) {
        d.w[0] = 0.2f, d.w[1] = 0.1f, d.w[2] = 0.2f, d.w[3] = 0.3f, d.w[4] = 0.2f;
    }
    if (d.near_m <= 0)
        d.near_m = 5.0f;
    if (d.far_m <= 0)
        d.far_m = 80.0f;
    if (d.far_m <= d.near_m * 1.01f)
        d.far_m = d.near_m * 1.01f + 1.0f;
    if (d.h <= 0 || d.h == 1.0f)
        d.h = 10.0f;
    if (!d.bl_max)
        d.bl_max = 4;
    if (d.max_rate <= 0)
        d.max_rate = 0.98f;
    if (d.max_enlarge <= 0)
        d.max_enlarge = 3.0f;
    if (d.hyst_k1 <= 0)
        d.hyst_k1 = 1.5f;
    if (d.hyst_k2 <= 0)
        d.hyst_k2 = 1.0f;
    return d;
}

float hz_rate_f1(uint32_t bsl)
{
    return bsl <= 1 ? 0.0f : bsl == 2 ? 0.4f : 0.8f;
}

float hz_rate_f2(const hz_rate_params *p, uint32_t bl, float dist)
{
    if (dist <= p->near_m)
        return 0.0f;
    if (dist > p->far_m)
        return 0.5f;
    float lh = logf(p->h);
    float k1 = 0.5f / ((float)p->bl_max * (logf(p->far_m) / lh));
    return fminf(k1 * (float)bl * (logf(dist) / lh), 0.5f);
}

float hz_rate_f3(float LD, float ld0)
{
    if (!(ld0 > 0.0f))
        return 0.0f;
    return (LD - ld0) / ld0; /* k2 = 1 / ld0 */
}

float hz_rate_f4(const hz_rate_params *p, float dist)
{
    if (dist <= p->near_m)
        return 0.0f;
    if (dist >= p->far_m)
        return 1.0f;
    return log10f(dist) / log10f(p->far_m); /* k3 = 1 / log10(far) */
}

float hz_rate_f5(float cos_dir)
{
    return cos_dir > 0.0f ? fminf(cos_dir, 1.0f) : 0.0f;
}

float hz_rate_node(const hz_rate_params *p, uint32_t bsl, uint32_t bl, float dist, float LD, float ld0,
                   float cos_dir)
{
    float r = p->w[0] * hz_rate_f1(bsl) + p->w[1] * hz_rate_f2(p, bl, dist) + p->w[2] * hz_rate_f3(LD, ld0) +
              p->w[3] * hz_rate_f4(p, dist) + p->w[4] * hz_rate_f5(cos_dir);
    return fminf(fmaxf(r, 0.0f), p->max_rate);
}

float hz_rate_node_fixed(const hz_rate_params *p, uint32_t bsl, uint32_t bl, float dist, float ld, float ld0,
                         float cos_dir)
{
    /* Rs = S + w3 (r (1 - Rs) - 1) with r = ld / ld0, S the other terms:
     * Rs = (S - w3 + w3 r) / (1 + w3 r). */
    float S = p->w[0] * hz_rate_f1(bsl) + p->w[1] * hz_rate_f2(p, bl, dist) + p->w[3] * hz_rate_f4(p, dist) +
              p->w[4] * hz_rate_f5(cos_dir);
    float r = ld0 > 0.0f ? ld / ld0 : 0.0f, w3 = ld0 > 0.0f ? p->w[2] : 0.0f;
    float R = (S - w3 + w3 * r) / (1.0f + w3 * r);
    return fminf(fmaxf(R, 0.0f), p->max_rate);
}

float hz_enlarge(const hz_rate_params *p, uint32_t n, uint32_t kept)
{
    if (kept == 0 || kept >= n)
        return 1.0f;
    return fminf(sqrtf((float)n / (float)kept), p->max_enlarge);
}

bool hz_hysteresis_allows(const hz_rate_params *p, float dist, float delta_rate, float held_s)
{
    if (dist <= p->near_m)
        return true;
    float x = fminf(dist, p->far_m) - p->near_m, span = p->far_m - p->near_m;
    float d1 = 1.0f / powf(span, p->hyst_k1), d2 = 1.0f / powf(span, p->hyst_k2);
    return fabsf(delta_rate) >= d1 * powf(x, p->hyst_k1) && held_s >= d2 * powf(x, p->hyst_k2);
}

/* ---- placement -------------------------------------------------------------- */

static float lattice2(uint64_t seed, int x, int z)
{
    uint64_t h = seed ^ ((uint64_t)(uint32_t)x * 0x9E3779B97F4A7C15ULL) ^ ((uint64_t)(uint32_t)z * 0xC2B2AE3D27D4EB4FULL);
    h = (h ^ (h >> 31)) * 0xBF58476D1CE4E5B9ULL;
    h ^= h >> 29;
    return (float)(h >> 40) / 16777216.0f;
}

/* Smooth 2D value noise in [0, 1]. */
static float vnoise2(uint64_t seed, float x, float z)
{
    float fx = floorf(x), fz = floorf(z), tx = x - fx, tz = z - fz;
    int ix = (int)fx, iz = (int)fz;
    tx = tx * tx * (3 - 2 * tx);
    tz = tz * tz * (3 - 2 * tz);
    float a = lattice2(seed, ix, iz), b = lattice2(seed, ix + 1, iz), c = lattice2(seed, ix, iz + 1),
          d = lattice2(seed, ix + 1, iz + 1);
    return (a + (b - a) * tx) * (1 - tz) + (c + (d - c) * tx) * tz;
}

hz_result hz_forest_place(const hz_forest_desc *desc, hz_forest_tree *out, uint32_t *placed, hz_err *err)
{
    *placed = 0;
    hz_forest_desc d = *desc;
    if (!d.height || d.model_count == 0)
        return hz_err_set(err, HZ_ERR_VALUE, "forest: needs a height function and at least one model");
    if (d.count == 0)
        return HZ_OK;
    if (d.count > 1000000)
        return hz_err_set(err, HZ_ERR_VALUE, "forest: %u trees is more than the 1 000 000 supported", d.count);
    if (d.density <= 0)
        d.density = 400.0f;
    if (d.max_slope_deg <= 0)
        d.max_slope_deg = 35.0f;
    if (d.scale_min <= 0)
        d.scale_min = 0.8f;
    if (d.scale_max <= 0)
        d.scale_max = 1.2f;
    if (!(d.density < 100000.0f) || !isfinite(d.center[0]) || !isfinite(d.center[1]))
        return hz_err_set(err, HZ_ERR_VALUE, "forest: bad density or centre");
    const float spacing = 100.0f / sqrtf(d.density); /* metres between trees on average */
    const float min_dist = 0.6f * spacing;
    float side = sqrtf((float)d.count) * spacing;
    const float max_tan = tanf(d.max_slope_deg * 0.0174532925f);
    /* Spatial hash of placed trees for the minimum distance. */
    const uint32_t hcap = 1u << 20;
    uint32_t *head = malloc(hcap * sizeof *head), *next = malloc(d.count * sizeof *next);
    if (!head || !next) {
        free(head);
        free(next);
        return hz_err_set(err, HZ_ERR_MEMORY, "out of memory");
    }
    memset(head, 0xff, hcap * sizeof *head);
    hz_rng rng = {d.seed * 0x9E3779B97F4A7C15ULL + 0xF0E57ULL};
    uint32_t n = 0;
    for (int round = 0; round < 4 && n < d.count; round++, side *= 1.4142f) {
        uint64_t attempts = (uint64_t)d.count * 40;
        for (uint64_t a = 0; a < attempts && n < d.count; a++) {
            /* A disc of the square's area whose rim is pushed in and out
             * by large-scale noise (lobes, bays), thinned by smaller noise
             * toward it (ragged edges, stragglers) and inside (clearings). */
            const float R = 0.5642f * side, Rmax = 1.3f * R;
            float ang = rng_unit(&rng) * 6.2831853f, rr = Rmax * sqrtf(rng_unit(&rng));
            float x = d.center[0] + rr * cosf(ang), z = d.center[1] + rr * sinf(ang);
            /* two octaves on rotated axes: value noise alone shows its grid */
            float rx = (0.8f * x - 0.6f * z) / spacing, rz = (0.6f * x + 0.8f * z) / spacing;
            float lobes = 0.6f + 0.45f * vnoise2(d.seed ^ 0x5bd1e995u, rx / 9.0f, rz / 9.0f) +
                          0.25f * vnoise2(d.seed ^ 0x27d4eb2fu, rz / 4.0f + 17.0f, rx / 4.0f - 5.0f);
            float q = rr / (R * lobes);
            float keep = 1.3f * vnoise2(d.seed, x / (5.0f * spacing), z / (5.0f * spacing)) + 0.45f - 0.9f * q * q;
            if (rng_unit(&rng) > keep)
                continue;
            if (d.extent_limit > 0 && (x < 0 || z < 0 || x > d.extent_limit || z > d.extent_limit))
                continue;
            int cx = (int)floorf(x / min_dist), cz = (int)floorf(z / min_dist);
            bool close = false;
            for (int dz = -1; dz <= 1 && !close; dz++)
                for (int dx = -1; dx <= 1 && !close; dx++) {
                    uint32_t hsh = ((uint32_t)(cx + dx) * 73856093u ^ (uint32_t)(cz + dz) * 19349663u) & (hcap - 1);
                    for (uint32_t k = head[hsh]; k != 0xffffffffu && !close; k = next[k]) {
                        float ex = out[k].pos[0] - x, ez = out[k].pos[2] - z;
                        close = ex * ex + ez * ez < min_dist * min_dist;
                    }
                }
            if (close)
                continue;
            const float e = 5.0f;
            float h = d.height(d.height_user, x, z);
            float gx = (d.height(d.height_user, x + e, z) - d.height(d.height_user, x - e, z)) / (2 * e);
            float gz = (d.height(d.height_user, x, z + e) - d.height(d.height_user, x, z - e)) / (2 * e);
            if (!isfinite(h) || sqrtf(gx * gx + gz * gz) > max_tan)
                continue;
            if ((d.min_h != 0 || d.max_h != 0) && (h < d.min_h || h > d.max_h))
                continue;
            uint32_t model = 0;
            if (d.model_count > 1) {
                float t = 0.5f;
                if (d.max_h > d.min_h)
                    t = (h - d.min_h) / (d.max_h - d.min_h);
                float w[64], ws = 0.0f;
                uint32_t mc = d.model_count < 64 ? d.model_count : 64;
                for (uint32_t m = 0; m < mc; m++) {
                    float pref = d.model_high ? d.model_high[m] : t;
                    w[m] = fmaxf(0.05f, 1.0f - 1.6f * fabsf(pref - t));
                    ws += w[m];
                }
                float u = rng_unit(&rng) * ws;
                for (model = 0; model + 1 < mc && u >= w[model]; model++)
                    u -= w[model];
            }
            hz_forest_tree *tr = &out[n];
            v3_set(tr->pos, x, h, z);
            tr->yaw = rng_unit(&rng) * 6.2831853f;
            tr->scale = d.scale_min + (d.scale_max - d.scale_min) * rng_unit(&rng);
            tr->model = model;
            uint32_t hsh = ((uint32_t)cx * 73856093u ^ (uint32_t)cz * 19349663u) & (hcap - 1);
            next[n] = head[hsh];
            head[hsh] = n;
            n++;
        }
    }
    free(head);
    free(next);
    *placed = n;
    return HZ_OK;
}

/* ---- the forest -------------------------------------------------------------- */

typedef struct model_info {
    float ld0;
    uint64_t triangles;
    uint32_t *order, *pos; /* leaves interleaved by rank (hz_forest_model_order) */
    uint32_t group_first[HZ_FOREST_GROUPS + 1];
    uint8_t *node_group;
    hz_tree_mesh hull;     /* coarse crown hull */
    float *cov;            /* per leaf: coverage of its node's prefix (F4 by coverage) */
} model_info;

struct hz_forest {
    const hz_tree **models;
    model_info *info;
    uint32_t model_count;
    hz_forest_tree *trees;
    uint32_t tree_count;
    uint32_t *state_base;   /* per tree: offset of its nodes in the state arrays */
    float *rate;            /* per (tree, node): rate in use, < 0 = never seen */
    float *since;           /* seconds: when it last changed */
    size_t state_total;
    hz_forest_draw *draws;
    uint32_t *counts;       /* per (tree, node): leaves kept, persistent */
    float *scales;          /* per (tree, node): F4 enlargement */
    uint64_t *detailed_at;  /* per tree: serial of the last update that drew its leaves */
    uint32_t *prefix;       /* per (tree, group): leaves to draw from the group's start */
    uint64_t *kept_total;   /* per tree: sum of counts */
    uint32_t *imp_list;     /* per frame: impostor trees, nearest first */
    float *imp_dist;
    uint32_t *sort_tmp;
    bool last_enlarge;
    uint64_t serial;
};

typedef struct key_leaf {
    float key;
    uint32_t leaf;
} key_leaf;

static int cmp_key(const void *a, const void *b)
{
    const key_leaf *x = a, *y = b;
    if (x->key != y->key)
        return x->key < y->key ? -1 : 1;
    return (x->leaf > y->leaf) - (x->leaf < y->leaf);
}

/* The group of a node (hz_forest_model_order): crown layer x the axis its
 * branch grows along, with its sign. */
static uint32_t node_group(const hz_tree *t, const hz_tree_node *nd)
{
    uint32_t layer = nd->bsl < 1 ? 0 : nd->bsl > 3 ? 2 : nd->bsl - 1;
    const float *d = t->branches[nd->branch].dir;
    uint32_t ax = fabsf(d[0]) >= fabsf(d[1]) && fabsf(d[0]) >= fabsf(d[2]) ? 0 : fabsf(d[1]) >= fabsf(d[2]) ? 1 : 2;
    return layer * 6 + ax * 2 + (d[ax] < 0.0f);
}

/* Interleaves a model's leaves by rank within their node, in groups. */
static bool model_order(const hz_tree *t, model_info *mi)
{
    uint32_t n = t->leaf_count;
    mi->order = malloc((n ? n : 1) * sizeof *mi->order);
    mi->pos = malloc((n ? n : 1) * sizeof *mi->pos);
    mi->node_group = malloc(t->node_count ? t->node_count : 1);
    key_leaf *kl = malloc((n ? n : 1) * sizeof *kl);
    if (!mi->order || !mi->pos || !mi->node_group || !kl) {
        free(kl);
        return false;
    }
    for (uint32_t k = 0; k < n; k++)
        kl[k] = (key_leaf){(float)HZ_FOREST_GROUPS, k}; /* leaves of no node go last */
    uint32_t in_group[HZ_FOREST_GROUPS] = {0};
    for (uint32_t nd = 0; nd < t->node_count; nd++) {
        uint32_t g = node_group(t, &t->nodes[nd]);
        mi->node_group[nd] = (uint8_t)g;
        in_group[g] += t->nodes[nd].count;
        for (uint32_t i = 0; i < t->nodes[nd].count; i++)
            kl[t->nodes[nd].first + i].key = (float)g + ((float)i + 0.5f) / (float)t->nodes[nd].count;
    }
    mi->group_first[0] = 0;
    for (uint32_t g = 0; g < HZ_FOREST_GROUPS; g++)
        mi->group_first[g + 1] = mi->group_first[g] + in_group[g];
    qsort(kl, n, sizeof *kl, cmp_key);
    for (uint32_t p = 0; p < n; p++) {
        mi->order[p] = kl[p].leaf;
        mi->pos[kl[p].leaf] = p;
    }
    free(kl);
    return true;
}

hz_forest *hz_forest_create(const hz_tree *const *models, uint32_t model_count, const hz_forest_tree *trees,
                            uint32_t tree_count, hz_err *err)
{
    if (model_count == 0) {
        hz_err_set(err, HZ_ERR_VALUE, "forest: no tree models");
        return NULL;
    }
    for (uint32_t k = 0; k < tree_count; k++)
        if (trees[k].model >= model_count) {
            hz_err_set(err, HZ_ERR_VALUE, "forest: tree %u uses model %u of %u", k, trees[k].model, model_count);
            return NULL;
        }
    hz_forest *f = calloc(1, sizeof *f);
    if (!f)
        goto oom;
    f->model_count = model_count;
    f->tree_count = tree_count;
    const size_t tc = tree_count ? tree_count : 1;
    f->models = malloc(model_count * sizeof *f->models);
    f->info = calloc(model_count, sizeof *f->info);
    f->trees = malloc(tc * sizeof *f->trees);
    f->state_base = malloc(tc * sizeof *f->state_base);
    f->draws = malloc(tc * sizeof *f->draws);
    f->detailed_at = calloc(tc, sizeof *f->detailed_at);
    f->prefix = calloc(tc * HZ_FOREST_GROUPS, sizeof *f->prefix);
    f->kept_total = calloc(tc, sizeof *f->kept_total);
    f->imp_list = malloc(tc * sizeof *f->imp_list);
    f->imp_dist = malloc(tc * sizeof *f->imp_dist);
    f->sort_tmp = malloc(2 * tc * sizeof *f->sort_tmp);
    if (!f->models || !f->info || !f->trees || !f->state_base || !f->draws || !f->detailed_at || !f->prefix ||
        !f->kept_total || !f->imp_list || !f->imp_dist || !f->sort_tmp)
        goto oom;
    memcpy(f->models, models, model_count * sizeof *f->models);
    if (tree_count)
        memcpy(f->trees, trees, tree_count * sizeof *f->trees);
    for (uint32_t m = 0; m < model_count; m++) {
        const hz_tree *t = models[m];
        double sum = 0.0, mn = INFINITY;
        for (uint32_t n = 0; n < t->node_count; n++) {
            sum += t->nodes[n].ld;
            mn = fmin(mn, t->nodes[n].ld);
        }
        double mean = t->node_count ? sum / t->node_count : 0.0;
        f->info[m].ld0 = t->node_count ? (float)fmin(mn, 0.5 * mean) : 0.0f;
        f->info[m].triangles = hz_tree_triangles(t);
        if (!model_order(t, &f->info[m]))
            goto oom;
        f->info[m].cov = malloc((t->leaf_count ? t->leaf_count : 1) * sizeof *f->info[m].cov);
        if (!f->info[m].cov)
            goto oom;
        if (hz_tree_prefix_coverage(t, f->info[m].cov, err) != HZ_OK) {
            hz_forest_destroy(f);
            return NULL;
        }
        if (t->hull.index_count && hz_mesh_simplify(&t->hull, HZ_FOREST_HULL_TRIANGLES, &f->info[m].hull, err) != HZ_OK) {
            hz_forest_destroy(f);
            return NULL;
        }
    }
    size_t total = 0;
    for (uint32_t k = 0; k < tree_count; k++) {
        f->state_base[k] = (uint32_t)total;
        total += models[trees[k].model]->node_count;
        if (total > 0xffffffffu) {
            hz_err_set(err, HZ_ERR_VALUE, "forest: too many nodes in all");
            hz_forest_destroy(f);
            return NULL;
        }
    }
    f->state_total = total;
    f->rate = malloc((total ? total : 1) * sizeof *f->rate);
    f->since = malloc((total ? total : 1) * sizeof *f->since);
    f->counts = calloc(total ? total : 1, sizeof *f->counts);
    f->scales = malloc((total ? total : 1) * sizeof *f->scales);
    if (!f->rate || !f->since || !f->counts || !f->scales)
        goto oom;
    hz_forest_reset(f);
    return f;
oom:
    hz_forest_destroy(f);
    hz_err_set(err, HZ_ERR_MEMORY, "forest: out of memory");
    return NULL;
}

void hz_forest_destroy(hz_forest *f)
{
    if (!f)
        return;
    for (uint32_t m = 0; m < f->model_count && f->info; m++) {
        free(f->info[m].order);
        free(f->info[m].pos);
        free(f->info[m].node_group);
        free(f->info[m].hull.pos);
        free(f->info[m].hull.nrm);
        free(f->info[m].hull.idx);
        free(f->info[m].cov);
    }
    free(f->models);
    free(f->info);
    free(f->trees);
    free(f->state_base);
    free(f->rate);
    free(f->since);
    free(f->draws);
    free(f->counts);
    free(f->scales);
    free(f->detailed_at);
    free(f->prefix);
    free(f->kept_total);
    free(f->imp_list);
    free(f->imp_dist);
    free(f->sort_tmp);
    free(f);
}

void hz_forest_reset(hz_forest *f)
{
    for (size_t k = 0; k < f->state_total; k++) {
        f->rate[k] = -1.0f;
        f->since[k] = 0.0f;
        f->scales[k] = 1.0f;
    }
    /* Every tree is re-evaluated in full when next drawn with leaves. */
    for (uint32_t k = 0; k < f->tree_count; k++)
        f->detailed_at[k] = 0;
    f->serial += 2;
}

uint32_t hz_forest_tree_count(const hz_forest *f)
{
    return f->tree_count;
}
const hz_forest_tree *hz_forest_trees(const hz_forest *f)
{
    return f->trees;
}
const hz_tree *hz_forest_model(const hz_forest *f, uint32_t k)
{
    return k < f->model_count ? f->models[k] : NULL;
}
uint32_t hz_forest_model_count(const hz_forest *f)
{
    return f->model_count;
}
const uint32_t *hz_forest_model_order(const hz_forest *f, uint32_t k)
{
    return k < f->model_count ? f->info[k].order : NULL;
}
const uint32_t *hz_forest_model_groups(const hz_forest *f, uint32_t k)
{
    return k < f->model_count ? f->info[k].group_first : NULL;
}

const uint32_t *hz_forest_model_pos(const hz_forest *f, uint32_t k)
{
    return k < f->model_count ? f->info[k].pos : NULL;
}
const hz_tree_mesh *hz_forest_model_hull(const hz_forest *f, uint32_t k)
{
    return k < f->model_count ? &f->info[k].hull : NULL;
}

void hz_forest_tree_matrix(const hz_forest *f, uint32_t k, float m[16])
{
    const hz_forest_tree *t = &f->trees[k];
    float c = cosf(t->yaw) * t->scale, s = sinf(t->yaw) * t->scale;
    /* column-major: rotation about +y, uniform scale, translation */
    const float mm[16] = {c, 0, -s, 0, 0, t->scale, 0, 0, s, 0, c, 0, t->pos[0], t->pos[1], t->pos[2], 1};
    memcpy(m, mm, sizeof mm);
}

static void xform_point(const float m[16], const float *p, float *o)
{
    for (int r = 0; r < 3; r++)
        o[r] = m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r];
}

static bool sphere_visible(const vec4 planes[6], const float *c, float r)
{
    for (int k = 0; k < 6; k++)
        if (planes[k][0] * c[0] + planes[k][1] * c[1] + planes[k][2] * c[2] + planes[k][3] < -r)
            return false;
    return true;
}

/* Steps in which a fading tree's leaves thin out over the cross-fade band. */
#define FADE_STEPS 16.0f

/* 0 below the band, 1 beyond it, linear between. */
static float band_fade(const float band[2], float d)
{
    if (d <= band[0])
        return 0.0f;
    if (d >= band[1])
        return 1.0f;
    return (d - band[0]) / (band[1] - band[0]);
}

/* Per-node rates of one detailed tree, in model space (the tree's rotation
 * and uniform scale keep angles; distances scale). Only nodes whose kept
 * count changes are written; their range goes to dr->dirty_lo/hi. */
static void tree_nodes(hz_forest *f, uint32_t k, const hz_forest_params *P, const vec4 planes[6], const float *eye,
                       float drop, float spread, double now_s, bool fresh, hz_forest_draw *dr, hz_forest_frame *fr)
{
    const hz_forest_tree *tr = &f->trees[k];
    const hz_tree *t = f->models[tr->model];
    const model_info *mi = &f->info[tr->model];
    /* eye and frustum planes in model space */
    float cy = cosf(tr->yaw), sy = sinf(tr->yaw), s = tr->scale, inv = 1.0f / s;
    float d[3] = {eye[0] - tr->pos[0], eye[1] - tr->pos[1], eye[2] - tr->pos[2]};
    /* world = R(yaw) * s * model with R columns (c,0,-s), (0,1,0), (s,0,c) */
    float em[3] = {(cy * d[0] - sy * d[2]) * inv, d[1] * inv, (sy * d[0] + cy * d[2]) * inv};
    vec4 mp[6];
    for (int p = 0; p < 6; p++) {
        const float *w = planes[p];
        /* n . (R s x + t) + w = (s R^T n) . x + (n . t + w) */
        mp[p][0] = s * (cy * w[0] - sy * w[2]);
        mp[p][1] = s * w[1];
        mp[p][2] = s * (sy * w[0] + cy * w[2]);
        /* Earth curvature: the tree drawn `drop` lower, give or take `spread`
         * over its crown (the planes widened by it). */
        mp[p][3] = w[0] * tr->pos[0] + w[1] * (tr->pos[1] - drop) + w[2] * tr->pos[2] + w[3] + fabsf(w[1]) * spread;
    }
    const uint32_t sb = f->state_base[k];
    const float ld0 = mi->ld0;
    uint32_t lo = fresh ? 0 : UINT32_MAX, hi = fresh ? t->node_count : 0;
    int64_t kept_delta = 0;
    /* In the cross-fade band, where the dither shows only (1 - fade) of the
     * leaves' pixels, the leaves also thin out by rank to that share (F4
     * enlarges what is left to the coverage the node had): in FADE_STEPS
     * steps, so that the counts change a few times per band. */
    const float keep = P->simplify ? 1.0f - floorf(dr->fade * FADE_STEPS) / FADE_STEPS : 1.0f;
    for (uint32_t n = 0; n < t->node_count; n++) {
        const hz_tree_node *nd = &t->nodes[n];
        uint32_t *cnt = &f->counts[sb + n];
        float *sc = &f->scales[sb + n];
        fr->nodes_considered++;
        uint32_t kept;
        if (!P->simplify) {
            kept = nd->count;
        } else {
            if (P->node_culling && !fresh && !sphere_visible((const vec4 *)mp, nd->center, nd->radius)) {
                /* Out of view: keeps its count (the GPU clips it) and costs no rate. */
                fr->nodes_culled++;
                continue;
            }
            float los[3];
            v3_sub(los, nd->center, em);
            float len = v3_len(los);
            if (len > 0)
                v3_scale(los, los, 1.0f / len);
            float nd_dist = len * s;
            const hz_tree_branch *br = &t->branches[nd->branch];
            float *cur = &f->rate[sb + n], *since = &f->since[sb + n];
            float Rs = P->fixed_rate ? fminf(fmaxf(P->fixed, 0.0f), 0.999f)
                                     : hz_rate_node_fixed(&P->rate, nd->bsl, br->level, nd_dist, nd->ld, ld0,
                                                          v3_dot(los, br->dir));
            if (*cur < 0.0f) {
                *cur = Rs;
                *since = (float)now_s;
            } else if (Rs != *cur) {
                if (!P->hysteresis || hz_hysteresis_allows(&P->rate, nd_dist, Rs - *cur, (float)(now_s - *since))) {
                    *cur = Rs;
                    *since = (float)now_s;
                    fr->nodes_changed++;
                } else {
                    fr->nodes_held++;
                }
            }
            kept = (uint32_t)ceilf((1.0f - *cur) * keep * (float)nd->count - 1e-4f);
            if (kept < 1)
                kept = 1;
            if (kept > nd->count)
                kept = nd->count;
        }
        /* F4 by coverage: the prefix grows to cover what its node covered. */
        float scale = P->simplify && P->enlarge ? hz_enlarge_coverage(P->rate.max_enlarge, mi->cov[nd->first + kept - 1])
                                                : 1.0f;
        if (kept != *cnt || fresh || scale != *sc) {
            kept_delta += (int64_t)kept - (int64_t)*cnt;
            *cnt = kept;
            if (n < lo)
                lo = n;
            if (n + 1 > hi)
                hi = n + 1;
        }
        *sc = scale;
    }
    if (fresh) {
        uint64_t sum = 0;
        for (uint32_t n = 0; n < t->node_count; n++)
            sum += f->counts[sb + n];
        f->kept_total[k] = sum;
    } else {
        f->kept_total[k] = (uint64_t)((int64_t)f->kept_total[k] + kept_delta);
    }
    uint32_t *gc = f->prefix + (size_t)k * HZ_FOREST_GROUPS;
    if (lo < hi) {
        /* Per group, the range that holds its nodes' kept leaves. */
        memset(gc, 0, HZ_FOREST_GROUPS * sizeof *gc);
        for (uint32_t n = 0; n < t->node_count; n++) {
            uint32_t c = f->counts[sb + n], g = mi->node_group[n];
            if (c) {
                uint32_t p = mi->pos[t->nodes[n].first + c - 1] + 1 - mi->group_first[g];
                if (p > gc[g])
                    gc[g] = p;
            }
        }
        fr->upload_bytes += (uint64_t)(hi - lo) * (sizeof(uint32_t) + sizeof(float));
    }
    dr->dirty_lo = lo < hi ? lo : 0;
    dr->dirty_hi = lo < hi ? hi : 0;
    dr->group_first = mi->group_first;
    dr->group_count = gc;
    dr->prefix = 0;
    for (uint32_t g = 0; g < HZ_FOREST_GROUPS; g++)
        dr->prefix += gc[g];
}

/* Sorts ids[0..n) by key, ascending: LSD radix sort on the float bits
 * (keys are non-negative distances), 2 passes of 16 bits. tmp: 2n. */
static void sort_by_dist(uint32_t *ids, const float *key, uint32_t n, uint32_t *tmp)
{
    static uint32_t hist[65536];
    uint32_t *k0 = tmp, *idx2 = tmp + n;
    for (int pass = 0; pass < 2; pass++) {
        memset(hist, 0, sizeof hist);
        for (uint32_t i = 0; i < n; i++) {
            uint32_t b;
            memcpy(&b, &key[ids[i]], 4);
            k0[i] = b;
            hist[(b >> (16 * pass)) & 0xffff]++;
        }
        uint32_t sum = 0;
        for (uint32_t h = 0; h < 65536; h++) {
            uint32_t c = hist[h];
            hist[h] = sum;
            sum += c;
        }
        for (uint32_t i = 0; i < n; i++)
            idx2[hist[(k0[i] >> (16 * pass)) & 0xffff]++] = ids[i];
        memcpy(ids, idx2, n * sizeof *ids);
    }
}

static int cmp_draw(const void *a, const void *b)
{
    const hz_forest_draw *x = a, *y = b;
    return (x->dist > y->dist) - (x->dist < y->dist);
}

hz_result hz_forest_update(hz_forest *f, const hz_camera *cam, const hz_forest_params *params, double now_s,
                           hz_forest_frame *fr, hz_err *err)
{
    (void)err;
    double t0 = hz_time_ms();
    hz_forest_params P = params ? *params : (hz_forest_params){.simplify = true, .enlarge = true};
    P.rate = hz_rate_params_defaults(&P.rate);
    const float hull_dist = P.hull_dist > 0 ? P.hull_dist : 0.25f * P.rate.far_m;
    const float imp_dist = P.impostor_dist > 0 ? P.impostor_dist : fmaxf(0.5f * P.rate.far_m, 2.0f * hull_dist);
    const float ff = P.fade_frac > 0 ? fminf(P.fade_frac, 0.9f) : 0.15f;
    const bool enlarge = P.simplify && P.enlarge;
    /* Switching enlargement re-derives every scale. */
    if (enlarge != f->last_enlarge) {
        for (uint32_t k = 0; k < f->tree_count; k++)
            f->detailed_at[k] = 0;
        f->last_enlarge = enlarge;
    }
    const uint64_t serial = ++f->serial;
    *fr = (hz_forest_frame){.draws = f->draws,
                            .counts = f->counts,
                            .scales = f->scales,
                            .node_total = (uint32_t)f->state_total,
                            .hull_band = {hull_dist * (1.0f - ff), hull_dist},
                            .impostor_band = {imp_dist * (1.0f - ff), imp_dist},
                            .max_dist = P.max_dist > 0 ? P.max_dist : INFINITY,
                            .impostors = P.simplify,
                            .enlarge = enlarge,
                            .max_enlarge = P.rate.max_enlarge,
                            .trees = f->tree_count,
                            .serial = serial};
    vec4 planes[6];
    hz_camera_frustum(cam, planes);
    const float *eye = cam->pos;
    uint64_t leaves = 0;
    for (uint32_t k = 0; k < f->tree_count; k++) {
        const hz_forest_tree *tr = &f->trees[k];
        const hz_tree *t = f->models[tr->model];
        float m[16], c[3];
        hz_forest_tree_matrix(f, k, m);
        xform_point(m, t->bound_center, c);
        /* Earth curvature: the tree is drawn `drop` lower. */
        const float drop = hz_camera_drop(cam, c[0], c[2]);
        float cc[3] = {c[0], c[1], c[2]}, rad = t->bound_radius * tr->scale;
        hz_camera_curve_sphere(cam, cc, &rad);
        if (!sphere_visible((const vec4 *)planes, cc, rad))
            continue;
        float dist = v3_dist(c, eye);
        if (dist > fr->max_dist)
            continue;
        fr->trees_in_frustum++;
        fr->triangles_full += f->info[tr->model].triangles;
        const bool has_hull = t->hull.index_count > 0;
        if (P.simplify && dist >= fr->impostor_band[0]) {
            f->imp_dist[k] = dist;
            f->imp_list[fr->impostor_count++] = k;
        }
        if (P.simplify && dist >= fr->impostor_band[1]) {
            fr->trees_impostor++;
            fr->triangles_drawn += 2;
            continue;
        }
        hz_forest_draw *dr = &fr->draws[fr->draw_count++];
        *dr = (hz_forest_draw){.tree = k, .model = tr->model, .bark_levels = t->levels,
                               .node_base = f->state_base[k], .dist = dist};
        if (P.simplify && has_hull && dist >= fr->hull_band[1]) {
            dr->hull = true;
            dr->bark_levels = 1;
            dr->fade = band_fade(fr->impostor_band, dist);
            fr->trees_hull++;
            fr->trees_fading += dr->fade > 0;
            fr->triangles_drawn += f->info[tr->model].hull.index_count / 3 + t->bark_level_end[0] / 3 +
                                   (dr->fade > 0 ? 2 : 0);
            continue;
        }
        fr->trees_detailed++;
        if (P.simplify) {
            dr->fade = band_fade(has_hull ? fr->hull_band : fr->impostor_band, dist);
            fr->trees_fading += dr->fade > 0;
            if (dr->fade > 0)
                fr->triangles_drawn += has_hull ? f->info[tr->model].hull.index_count / 3 : 2;
            if (dist > 0.5f * hull_dist && t->levels > 2)
                dr->bark_levels = t->levels - 1; /* twigs are sub-pixel there */
        }
        fr->triangles_drawn += t->bark_level_end[dr->bark_levels - 1] / 3;
        bool fresh = f->detailed_at[k] + 1 != serial;
        tree_nodes(f, k, &P, (const vec4 *)planes, eye, drop, rad - t->bound_radius * tr->scale, now_s, fresh, dr,
                   fr);
        f->detailed_at[k] = serial;
        leaves += f->kept_total[k];
    }
    fr->leaves_drawn = leaves;
    fr->triangles_drawn += 2 * leaves;
    /* Nearest first, so that the depth test spares what is hidden. */
    qsort(fr->draws, fr->draw_count, sizeof *fr->draws, cmp_draw);
    sort_by_dist(f->imp_list, f->imp_dist, fr->impostor_count, f->sort_tmp);
    fr->impostor_trees = f->imp_list;
    fr->select_ms = hz_time_ms() - t0;
    return HZ_OK;
}
