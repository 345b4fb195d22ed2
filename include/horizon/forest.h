/* horizon forests: placing trees on a terrain, the per-node run-time
 * simplification rate (SPEC F3), leaf enlargement (F4), LOD hysteresis (F6),
 * and the per-frame selection with per-tree and per-node frustum culling.
 * No GL: the render module draws what hz_forest_update selects. */
#ifndef HORIZON_FOREST_H
#define HORIZON_FOREST_H

#include "horizon/camera.h"
#include "horizon/tree.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- rate function (F3) ----------------------------------------------------- */

typedef struct hz_rate_params {
    float w[5];        /* weights of f1..f5; all 0 -> 0.2, 0.1, 0.2, 0.3, 0.2 */
    float near_m;      /* finest LOD distance, metres; 0 -> 5 */
    float far_m;       /* coarsest LOD distance, metres; 0 -> 80 */
    float h;           /* log base of f2; 0 -> 10 (k1 keeps f2 <= 0.5 whatever h) */
    uint32_t bl_max;   /* largest branch level carrying leaves; 0 -> 4 */
    float max_rate;    /* Rs is clamped to [0, max_rate]; 0 -> 0.98 */
    float max_enlarge; /* F4 factor cap; 0 -> 3 */
    /* F6 hysteresis exponents k1, k2 (> 0); 0 -> 1.5 and 1. */
    float hyst_k1, hyst_k2;
} hz_rate_params;

/* Fills zero fields with the defaults above. */
hz_rate_params hz_rate_params_defaults(const hz_rate_params *p);

/* The five factors (F3), exactly as specified:
 *  f1(BSL) = 0, 0.4, 0.8 for layers 1, 2, 3;
 *  f2 = 0 if dist <= near, k1*BL*log_h(dist) between, 0.5 beyond far, with
 *       k1 = 0.5 / (bl_max * log_h(far));
 *  f3 = k2 (LD - ld0), k2 = 1/ld0, ld0 = min(lowest ld, 0.5 * mean ld);
 *  f4 = 0 if dist <= near, k3*log10(dist) between (k3 = 1/log10(far)), 1 beyond;
 *  f5 = cos(dir) for dir in [0, pi/2], else 0 (cos_dir = cos of the angle
 *       between the view direction and the branch's growth direction). */
float hz_rate_f1(uint32_t bsl);
float hz_rate_f2(const hz_rate_params *p, uint32_t bl, float dist);
float hz_rate_f3(float LD, float ld0);
float hz_rate_f4(const hz_rate_params *p, float dist);
float hz_rate_f5(float cos_dir);

/* Rs = sum w_i f_i, clamped to [0, max_rate]. LD is the node's current leaf
 * density: initial ld times the fraction it currently keeps (1 - its last
 * rate), so density falls as leaves are removed (our reading of "initial ld
 * x current rate"). p must be defaulted. */
float hz_rate_node(const hz_rate_params *p, uint32_t bsl, uint32_t bl, float dist, float LD, float ld0,
                   float cos_dir);

/* The rate at which the node's own density is counted (LD = ld x the
 * fraction kept at that very rate): the fixed point of hz_rate_node in LD,
 * in closed form, Rs = (S - w3 + w3 ld/ld0) / (1 + w3 ld/ld0) with S the
 * other terms; clamped likewise. Reading LD from the last frame's rate
 * instead feeds the rate back on itself, so it oscillates under a still
 * camera. ld: the node's initial leaf density. */
float hz_rate_node_fixed(const hz_rate_params *p, uint32_t bsl, uint32_t bl, float dist, float ld, float ld0,
                         float cos_dir);

/* F4: remaining leaves grow by s = sqrt((1 - Rl) / (1 - Rc)) per change;
 * compounded from the full tree (R = 0) this is sqrt(1 / (1 - Rc)) =
 * sqrt(n / kept), which the shader applies to the original leaf size.
 * Capped at max_enlarge. */
float hz_enlarge(const hz_rate_params *p, uint32_t n, uint32_t kept);

/* F6: whether a node at distance dist may switch from its current rate to a
 * new one that differs by delta_rate, its rate having been unchanged for
 * held_s seconds: delta >= d1 (dist-near)^k1 and held >= d2 (dist-near)^k2
 * with d = 1/(far-near)^k. Always true within near. */
bool hz_hysteresis_allows(const hz_rate_params *p, float dist, float delta_rate, float held_s);

/* ---- forest placement ----------------------------------------------------- */

typedef struct hz_forest_tree {
    float pos[3];      /* world metres, trunk base */
    float yaw;         /* radians about +y */
    float scale;       /* uniform */
    uint32_t model;    /* index into the forest's models */
} hz_forest_tree;

/* Height of the ground at world (x, z), metres. */
typedef float (*hz_height_fn)(void *user, float x, float z);

typedef struct hz_forest_desc {
    uint32_t count;        /* trees wanted */
    uint64_t seed;
    float center[2];       /* world x, z of the forest; required */
    float density;         /* trees per hectare; 0 -> 400 */
    float max_slope_deg;   /* steeper ground gets no tree; 0 -> 35 */
    float min_h, max_h;    /* height band in metres; both 0 -> any height */
    float extent_limit;    /* keep trees within [0, extent_limit]^2 (the map); 0 -> no limit */
    uint32_t model_count;  /* models to choose from, >= 1 */
    const float *model_high; /* optional, model_count values in [0, 1]: preference for
                                high ground (conifers 1, broadleaves 0); NULL -> uniform */
    float scale_min, scale_max; /* 0 -> 0.8 .. 1.2 */
    hz_height_fn height;   /* required */
    void *height_user;
} hz_forest_desc;

/* Places up to desc->count trees in a disc around the centre sized for the
 * density (grown when slope/height/noise reject too many), thinned by
 * low-frequency noise toward the rim (ragged edges, clearings), on ground
 * no steeper than max_slope, at least 0.6 / sqrt(density) apart. out holds
 * desc->count entries; *placed gets how many were placed (fewer only when
 * the ground does not allow more). Deterministic per seed. */
hz_result hz_forest_place(const hz_forest_desc *desc, hz_forest_tree *out, uint32_t *placed, hz_err *err);

/* ---- per-frame selection ---------------------------------------------------- */

typedef struct hz_forest hz_forest;

typedef struct hz_forest_params {
    hz_rate_params rate;
    bool simplify;       /* false: every tree in the frustum at full detail (reference) */
    bool hysteresis;     /* F6 on */
    bool enlarge;        /* F4 on */
    bool node_culling;   /* per-node frustum culling within detailed trees */
    float hull_dist;     /* trees beyond this are drawn as crown hull + trunk; 0 -> far_m / 4 */
    float impostor_dist; /* trees beyond this are image impostors; 0 -> max(far_m / 2, 2 hull_dist) */
    float fade_frac;     /* cross-fade band: the last fade_frac of each distance (dithered); 0 -> 0.15 */
    float max_dist;      /* no tree beyond (the forest cover tints the ground there); 0 -> none */
    bool fixed_rate;     /* every node uses `fixed` instead of F3 (previews, measurements) */
    float fixed;
} hz_forest_params;

/* The LOD chain of one tree: leaves (VMI prefixes), crown hull, impostor. */
typedef enum hz_tree_lod { HZ_TREE_LEAVES = 0, HZ_TREE_HULL = 1, HZ_TREE_IMPOSTOR = 2 } hz_tree_lod;

/* What to draw for one tree this frame (leaves or hull; impostor trees are
 * drawn in one pass from the distance bands below, not listed here). */
typedef struct hz_forest_draw {
    uint32_t tree;       /* index into the forest's trees */
    uint32_t model;
    bool hull;           /* crown hull + bark levels up to bark_levels */
    uint32_t bark_levels;/* bark levels to draw (1 = trunk only) */
    uint32_t node_base;  /* detailed trees: offset of this tree's nodes in counts/scales (persistent) */
    float fade;          /* 0..1: share of the next coarser state, dithered (cross-fade band);
                          * leaves also keep only (1 - fade) of their count, in steps of 1/16 */
    float dist;          /* metres from the eye to its bounding centre (draws are sorted by it) */
    /* Detailed trees: the model's leaves are interleaved by rank
     * (hz_forest_model_order) within HZ_FOREST_GROUPS groups of nodes;
     * group g's leaves start at group_first[g] (the model's) and the first
     * group_count[g] of them (this tree's) hold every kept leaf of the
     * group's nodes. prefix is the sum of group_count: the leaves drawn. And
     * the range of nodes whose count changed since the last update (lo >= hi:
     * none; a tree that was not detailed last frame is dirty throughout). */
    uint32_t prefix;
    const uint32_t *group_first, *group_count;
    uint32_t dirty_lo, dirty_hi;
} hz_forest_draw;

typedef struct hz_forest_frame {
    hz_forest_draw *draws;
    uint32_t draw_count;
    /* Leaves kept per node (prefix length) and F4 enlargement, for every node
     * of every tree (draws[].node_base): persistent, only changed nodes are
     * rewritten. */
    uint32_t *counts;
    float *scales;
    uint32_t node_total; /* entries in counts/scales */
    /* Distance bands (metres from the eye to a tree's bounding centre):
     * leaves fade to hulls over hull_band, hulls to impostors over
     * impostor_band; nothing beyond max_dist. impostors false: no impostors
     * (unsimplified). */
    float hull_band[2], impostor_band[2], max_dist;
    bool impostors;
    /* Trees from impostor_band[0] on, in the frustum, nearest first (the
     * impostor pass draws these; its shader fades them in over the band). */
    const uint32_t *impostor_trees;
    uint32_t impostor_count;
    bool enlarge;        /* F4 on: the drawer scales kept leaves by hz_enlarge */
    float max_enlarge;
    /* figures */
    uint32_t trees, trees_in_frustum, trees_detailed, trees_hull, trees_impostor, trees_fading;
    uint64_t upload_bytes;     /* node counts the drawer must upload (dirty ranges) */
    uint32_t nodes_considered, nodes_culled, nodes_changed, nodes_held;
    uint64_t triangles_full;   /* trees in the frustum at full detail */
    uint64_t triangles_drawn;  /* leaves kept * 2 + bark + hulls */
    uint64_t leaves_drawn;
    double select_ms;
    uint64_t serial;     /* increases with every update (lets drawers cache per frame) */
} hz_forest_frame;

/* The forest keeps the trees and per-node state (rates, timers) for F6.
 * models and trees are copied by pointer/retained: the models must outlive
 * the forest; trees are copied. */
hz_forest *hz_forest_create(const hz_tree *const *models, uint32_t model_count, const hz_forest_tree *trees,
                            uint32_t tree_count, hz_err *err);
void hz_forest_destroy(hz_forest *f);
uint32_t hz_forest_tree_count(const hz_forest *f);
const hz_forest_tree *hz_forest_trees(const hz_forest *f);
const hz_tree *hz_forest_model(const hz_forest *f, uint32_t k);
uint32_t hz_forest_model_count(const hz_forest *f);
/* Model -> world transform of tree k (column-major 4x4, cglm layout). */
void hz_forest_tree_matrix(const hz_forest *f, uint32_t k, float m[16]);

/* Selects this frame's drawing: frustum culling per tree (bounding sphere)
 * and, for detailed trees, per node; per node the rate Rs (F3) under the
 * hysteresis (F6) and the enlargement (F4). now_s: the frame time in seconds
 * (for F6 timers). The frame's arrays are owned by the forest and valid
 * until the next update. */
hz_result hz_forest_update(hz_forest *f, const hz_camera *cam, const hz_forest_params *params, double now_s,
                           hz_forest_frame *frame, hz_err *err);
/* Forgets the per-node state (as after a teleport). */
void hz_forest_reset(hz_forest *f);

/* The model's leaves interleaved by rank in groups: nodes are grouped by
 * their crown layer (F3 f1) and the axis their branch grows along (F3 f5's
 * direction), whose rates are alike; within a group, leaves are sorted by
 * (rank within its node + 0.5) / node size, so that the first p positions of
 * a group hold a prefix of each of its nodes. A tree then draws, per group,
 * the range that holds its kept leaves: little more than those, where one
 * range over every node (whose kept fractions spread by the node's layer and
 * direction) drew about 1.6 times as many. order[p] is the leaf (index into
 * t->leaves) at position p, pos the inverse (pos[order[p]] == p); groups:
 * HZ_FOREST_GROUPS + 1 group starts (the last = the leaves in nodes). */
#define HZ_FOREST_GROUPS 18u
const uint32_t *hz_forest_model_order(const hz_forest *f, uint32_t k);
const uint32_t *hz_forest_model_groups(const hz_forest *f, uint32_t k);
const uint32_t *hz_forest_model_pos(const hz_forest *f, uint32_t k);
/* The model's crown hull as drawn in the forest: simplified to about
 * HZ_FOREST_HULL_TRIANGLES (its look comes from the impostor texture). */
#define HZ_FOREST_HULL_TRIANGLES 320u
const hz_tree_mesh *hz_forest_model_hull(const hz_forest *f, uint32_t k);

#ifdef __cplusplus
}
#endif
#endif
