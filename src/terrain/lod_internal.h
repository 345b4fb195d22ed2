/* Shared internals of the LOD modes (lod.c: precomputation + quadtree,
 * lod_free.c: remedy + bidirectional, lod_roam.c, lod_cdlod.c). No GL. */
#ifndef HZ_LOD_INTERNAL_H
#define HZ_LOD_INTERNAL_H

#include "horizon/lod.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

enum {
    DIR_W = 0, /* -x */
    DIR_E = 1, /* +x */
    DIR_N = 2, /* -z (row 0 is north) */
    DIR_S = 3  /* +z */
};

/* Flag byte: bits 0-1 state, bits 2-5 "don't care" per direction (the
 * neighbour across that edge is off the map or inside a culled node). */
enum {
    ST_NONE = 0,
    ST_LEAF = 1,
    ST_SPLIT = 2,
    ST_CULLED = 3,
    ST_MASK = 3,
    DC_SHIFT = 2
};

/* Neighbour status seen from a node. */
enum { NB_EXISTS = 0, NB_ABSENT = 1, NB_DONTCARE = 2 };

typedef struct qnode {
    uint32_t x, z;
} qnode;

typedef struct roam_state roam_state;

struct hz_lod {
    const hz_heightmap *hm;
    hz_lod_desc desc;
    uint32_t size, levels;
    float spacing, zscale;
    size_t nodes;
    size_t *level_offset; /* levels entries */
    float *d2;
    uint16_t *mn, *mx;
    uint8_t *flags;
    qnode *q[2];
    size_t qcap;

    /* remedy / bidirectional: frame stamp per node (a node's flag is valid
     * when its stamp equals epoch), allocated on first use. */
    uint8_t *stamp;
    uint8_t epoch;
    qnode *stack;        /* work list, qcap * 4 entries */
    uint32_t *stack_lv;

    /* cdlod, built on first use: per node the nested error bound delta' of
     * its fan (h16 steps, float), per sample the morph error (h16 steps). */
    float *cd_err;       /* per node of the patch levels 0..patch_level */
    uint16_t *cd_qmin;   /* per node alike, two each: the least morph error (q) of the samples its patch
                            grid draws, and of its even ones (patch_still) */
    size_t cd_nodes;
    uint16_t *morph_err;
    uint32_t patch;       /* cdlod patch cells per side (power of two) */
    uint32_t patch_level; /* finest level drawn as patches: half-size patch / 2 */
    hz_patch *patch_tmp;  /* scratch of the patch sort */
    size_t patch_tmp_cap;
    /* horizon culling's scratch (lod_horizon.c) */
    struct hcell *hz_cells, *hz_sorted;
    size_t hz_cells_cap, hz_sorted_cap;
    uint8_t *hz_hidden;
    size_t hz_hidden_cap;
    uint8_t *hz_sub; /* per patch node, its occluder cells' least samples (16 bytes) */
    /* cdlod per-level node lists (forced splits add to earlier levels). */
    qnode *lv[32];
    size_t lv_n[32], lv_cap[32];

    /* roam, built on first use. */
    roam_state *roam;

    /* The camera of the selection under way (hz_lod_select*): its eye and
     * earth_radius lower the node boxes (box_of) for Earth curvature. */
    hz_camera curv;
};

/* max without libm's NaN handling (fmaxf is a call without -ffast-math);
 * our operands are never NaN. */
static inline float maxf(float a, float b)
{
    return a > b ? a : b;
}

static inline uint32_t half_of(const hz_lod *lod, uint32_t level)
{
    return 1u << (lod->levels - 1 - level);
}

static inline uint32_t level_of(const hz_lod *lod, uint32_t half)
{
    uint32_t l = lod->levels - 1;
    while (half > 1) {
        half >>= 1;
        l--;
    }
    return l;
}

static inline size_t node_index(const hz_lod *lod, uint32_t level, uint32_t x, uint32_t z)
{
    /* Nodes of this level are 2s = 2^shift samples apart, 2^level per side
     * (shifts, not divisions: this runs for every node every frame). */
    const uint32_t shift = lod->levels - level;
    return lod->level_offset[level] + ((size_t)(z >> shift) << level) + (x >> shift);
}

/* The centre of the node of half-size s (a power of two) containing sample
 * coordinate v on one axis: v rounded down to a multiple of 2s, plus s. */
static inline uint32_t centre_of(uint32_t v, uint32_t s)
{
    return (v & ~(2 * s - 1)) + s;
}

static inline uint16_t h16(const hz_lod *lod, uint32_t x, uint32_t z)
{
    return hz_heightmap_get16(lod->hm, x, z);
}

/* World metres (zscale applied) of a sample. */
static inline float hworld(const hz_lod *lod, uint32_t x, uint32_t z)
{
    return (lod->hm->offset + lod->hm->scale * (float)h16(lod, x, z)) * lod->zscale;
}

/* The node's box on the flat world. */
static inline void box_flat(const hz_lod *lod, size_t i, uint32_t x, uint32_t z, uint32_t s, vec3 box[2])
{
    const hz_heightmap *hm = lod->hm;
    box[0][0] = (float)(x - s) * lod->spacing;
    box[1][0] = (float)(x + s) * lod->spacing;
    box[0][2] = (float)(z - s) * lod->spacing;
    box[1][2] = (float)(z + s) * lod->spacing;
    box[0][1] = (hm->offset + hm->scale * lod->mn[i]) * lod->zscale;
    box[1][1] = (hm->offset + hm->scale * lod->mx[i]) * lod->zscale;
}

/* The node's box as drawn for the selection's camera: lowered by the Earth
 * curvature's drop over it (nothing on a flat world, where no call is made:
 * this runs for every node every frame). */
static inline void box_of(const hz_lod *lod, size_t i, uint32_t x, uint32_t z, uint32_t s, vec3 box[2])
{
    box_flat(lod, i, x, z, s, box);
    if (lod->curv.earth_radius != 0.0f)
        hz_camera_curve_box(&lod->curv, box);
}

/* Box outside the frustum? p-vertex test against each plane (conservative:
 * a box is only dropped when it is entirely behind one plane, by more than
 * margin metres, so float rounding never drops a box that touches the frustum). */
static inline bool box_outside(const vec3 box[2], const vec4 planes[6], float margin)
{
    for (int p = 0; p < 6; p++) {
        const float *pl = planes[p];
        float dp = pl[0] * box[pl[0] > 0.0f][0] + pl[1] * box[pl[1] > 0.0f][1] + pl[2] * box[pl[2] > 0.0f][2];
        if (dp < -pl[3] - margin)
            return true;
    }
    return false;
}

/* Where the box lies against the frustum: -1 outside (as box_outside), 1
 * inside every plane by more than margin metres (so are boxes nested in
 * it), 0 across. */
static inline int box_frustum(const vec3 box[2], const vec4 planes[6], float margin)
{
    int inside = 1;
    for (int p = 0; p < 6; p++) {
        const float *pl = planes[p];
        const float dp = pl[0] * box[pl[0] > 0.0f][0] + pl[1] * box[pl[1] > 0.0f][1] + pl[2] * box[pl[2] > 0.0f][2];
        if (dp < -pl[3] - margin)
            return -1;
        const float dn = pl[0] * box[pl[0] <= 0.0f][0] + pl[1] * box[pl[1] <= 0.0f][1] + pl[2] * box[pl[2] <= 0.0f][2];
        inside &= dn > -pl[3] + margin;
    }
    return inside;
}

/* Squared distance from p to the nearest point of the box (0 inside). */
static inline float box_distance2(const vec3 box[2], const float p[3])
{
    float d2 = 0.0f;
    for (int k = 0; k < 3; k++) {
        float v = p[k] < box[0][k] ? box[0][k] - p[k] : (p[k] > box[1][k] ? p[k] - box[1][k] : 0.0f);
        d2 += v * v;
    }
    return d2;
}

/* Distance from p to the nearest point of the box (0 inside). */
static inline float box_distance(const vec3 box[2], const float p[3])
{
    return sqrtf(box_distance2(box, p));
}

static inline hz_result list_reserve(void **data, size_t *cap, size_t need, size_t elem)
{
    if (need <= *cap)
        return HZ_OK;
    size_t n = *cap ? *cap : 1024;
    while (n < need)
        n *= 2;
    void *p = realloc(*data, n * elem);
    if (!p)
        return HZ_ERR_MEMORY;
    *data = p;
    *cap = n;
    return HZ_OK;
}

static inline hz_result push_node(hz_node_list *list, uint32_t x, uint32_t z, uint32_t s, uint32_t level)
{
    if (!list)
        return HZ_OK;
    if (list_reserve((void **)&list->data, &list->cap, list->count + 1, sizeof *list->data))
        return HZ_ERR_MEMORY;
    list->data[list->count++] = (hz_lod_node){x, z, s, level};
    return HZ_OK;
}

static inline hz_result push_tri(hz_index_list *out, uint32_t a, uint32_t b, uint32_t c)
{
    if (list_reserve((void **)&out->data, &out->cap, out->count + 3, sizeof(uint32_t)))
        return HZ_ERR_MEMORY;
    out->data[out->count++] = a;
    out->data[out->count++] = b;
    out->data[out->count++] = c;
    return HZ_OK;
}

/* Appends node (x, z) to the level-l list lod->lv[l]. */
static inline hz_result lv_push(hz_lod *lod, uint32_t l, uint32_t x, uint32_t z)
{
    if (list_reserve((void **)&lod->lv[l], &lod->lv_cap[l], lod->lv_n[l] + 1, sizeof(qnode)))
        return HZ_ERR_MEMORY;
    lod->lv[l][lod->lv_n[l]++] = (qnode){x, z};
    return HZ_OK;
}

/* The per-frame split test shared by the quadtree modes: C/C2 (clamped or
 * not) or, with a pixel error, the projected d2 error. */
typedef struct split_rule {
    float ex, ey, ez;  /* eye */
    float R;           /* earth radius, 0 = flat */
    float C, C2;
    bool unclamped;
    float k_over_tau;  /* > 0: pixel mode */
} split_rule;

static inline split_rule split_rule_make(const hz_camera *cam, const hz_lod_params *p)
{
    split_rule r = {.ex = cam->pos[0], .ey = cam->pos[1], .ez = cam->pos[2], .R = cam->earth_radius};
    r.C = p->c > 0 ? p->c : 25.0f;
    r.C2 = p->c2 > 0 ? p->c2 : 2.5f;
    r.unclamped = p->criterion == HZ_LOD_UNCLAMPED;
    if (p->pixel_error > 0) {
        float h = (float)(p->viewport_height ? p->viewport_height : 720u);
        float fov = cam->fov_y > 0 ? cam->fov_y : 60.0f;
        r.k_over_tau = h / (2.0f * tanf(glm_rad(fov) * 0.5f)) / p->pixel_error;
    }
    return r;
}

/* Screen-space constant K = viewport_height / (2 tan(fov/2)): pixels per
 * metre of error at one metre of distance. */
static inline float pixel_k(const hz_camera *cam, const hz_lod_params *p)
{
    float h = (float)(p->viewport_height ? p->viewport_height : 720u);
    float fov = cam->fov_y > 0 ? cam->fov_y : 60.0f;
    return h / (2.0f * tanf(glm_rad(fov) * 0.5f));
}

static inline bool split_rule_test(const hz_lod *lod, const split_rule *r, uint32_t x, uint32_t z, uint32_t s,
                                   size_t idx)
{
    const float sp = lod->spacing;
    const float cx = (float)x * sp - r->ex;
    const float cz = (float)z * sp - r->ez;
    const float cy = hworld(lod, x, z) - hz_curvature_drop(r->R, cx, cz) - r->ey; /* as drawn */
    const float dist = sqrtf(cx * cx + cy * cy + cz * cz);
    const float d = 2.0f * (float)s * sp;
    if (r->k_over_tau > 0)
        return dist < d * lod->d2[idx] * r->k_over_tau;
    const float rr = r->C2 * lod->d2[idx];
    return dist < d * r->C * (r->unclamped ? rr : fmaxf(rr, 1.0f));
}

static inline float frustum_margin(const hz_camera *cam)
{
    return 1e-4f * ((cam->zfar > 0 ? cam->zfar : 1e5f) + fabsf(cam->pos[0]) + fabsf(cam->pos[1]) +
                    fabsf(cam->pos[2])) +
           1e-2f;
}

/* cdlod: error bounds grow at least this much per level (the dilation in
 * lod_cdlod.c and in the pyramid import); morph zones of consecutive levels
 * then do not overlap for morph_start >= 1 / CD_GROW (HZ_LOD_MORPH_START_MIN). */
#define CD_GROW 1.25f

/* cdlod: where a vertex starts morphing, as a fraction of its range:
 * params' value (0 -> CD_MORPH_START), clamped to [HZ_LOD_MORPH_START_MIN, _MAX].
 * The morph keeps the error under tau whatever its width, but outside the
 * zone every vertex is at its true height, so a narrow zone draws the same
 * surface closer to the truth on average; it also crosses the zone faster.
 * On the peers' 4097^2 flight (120 frames): 0.95 at tau 1.45 has the image
 * error of 0.8 at tau 1.35 with 10 % fewer triangles (529 246 against
 * 590 516; PSNR 41.11 against 41.02 dB; silhouette 0.0155 % both; image
 * popping 0.723 against 0.735). At tau 1.5 (499 636 triangles), 0.98 against
 * 0.95: PSNR 41.02 against 40.93 dB, silhouette 0.0157 % against 0.0160 %,
 * image popping 0.714 against 0.721, but the surface moves up to 1.5 px a
 * frame (median frame, 50 m a frame) against 0.84, and 0.21 px against 0.09
 * per 2 m step in test_cdlod_no_popping. The default keeps the slower drift. */
#define CD_MORPH_START ((float)HZ_LOD_MORPH_START_DEFAULT)

static inline float cd_morph_start(float asked)
{
    const float a = asked > 0.0f ? asked : CD_MORPH_START;
    const float lo = (float)HZ_LOD_MORPH_START_MIN, hi = (float)HZ_LOD_MORPH_START_MAX;
    return a < lo ? lo : (a > hi ? hi : a);
}

/* cdlod's near bound (hz_lod_params.near_pixel_error): the bound at distance
 * d is tau(d) = tau_n for d <= d0, tau_n sqrt(d0 / d) beyond, never below
 * tau. An error e (metres) has the range R' where e K = R' tau(R'), K pixels
 * per metre at one metre; d tau(d) grows with d, so R' is unique. With
 * R = e K / tau (the range at tau) and rho = tau / tau_n:
 *   R' = rho R                 while rho R <= d0,
 *   R' = (rho R)^2 / d0        while that is below R,
 *   R' = R                     beyond (from d0 / rho^2 on).
 * R' / R never falls as R grows (tau(d) never rises with d), so ranges grow
 * from level to level at least as much as the error bounds do. */
static inline void cd_near(const hz_lod_params *p, float *rho, float *d0)
{
    const float tau = p->pixel_error > 0 ? p->pixel_error : 1.0f;
    *rho = p->near_pixel_error > tau ? tau / p->near_pixel_error : 1.0f;
    *d0 = p->near_distance > 0 ? p->near_distance : HZ_LOD_NEAR_DISTANCE_DEFAULT;
}

static inline float cd_range(float R, float rho, float d0)
{
    if (!(rho < 1.0f && d0 > 0.0f))
        return R; /* no near bound */
    const float rn = rho * R, far = rn * (rn > d0 ? rn / d0 : 1.0f);
    return far < R ? far : R;
}

/* The morph start of a vertex whose range R at tau became Rp (cd_range).
 * Its error projects to tau(Rp) = tau R / Rp at Rp, so across a zone of the
 * same width it would drift (R / Rp)^2 times as fast as at tau: the zone
 * widens by that factor, down to HZ_LOD_MORPH_START_MIN (where consecutive
 * levels' zones would overlap). A function of the vertex's error alone, as
 * the range is; a start times range grows with the error. */
static inline float cd_morph_start_at(float a, float R, float Rp)
{
    if (Rp >= R || !(Rp > 0.0f))
        return a;
    const float q = R / Rp, w = 1.0f - (1.0f - a) * q * q, lo = (float)HZ_LOD_MORPH_START_MIN;
    return w > lo ? w : lo;
}

/* The two neighbours sample (i, j) of an n x n map collapses between, at the
 * spacing where it first appears: along x, along z, or on the diagonal
 * (union jack by the coarser cell's parity) of the coarser cell it centres.
 * False for a sample on every level's grid (the map's corners). */
bool hz__morph_neighbours(uint32_t n, uint32_t i, uint32_t j, uint32_t ni[2], uint32_t nj[2]);

/* Non-degenerate triangles of a P x P patch: 2 P^2, less one per stitched
 * odd edge vertex (each collapses one triangle of its cell). */
uint32_t hz__patch_triangles(uint32_t P, uint8_t coarse);
/* Patches nearest first: a counting sort on the distance's logarithm (32
 * steps per doubling, 3 %), O(patches); tmp is scratch kept by the caller. */
hz_result hz__sort_patches(hz_patch_list *out, hz_patch **tmp, size_t *tmp_cap);

/* Horizon culling (lod_horizon.c): hidden[k] = 1 for each of patches
 * [0, count) (nearest first) that nearer ground hides, 0 for the others;
 * with quads, for each patch from `from` on not hidden whole, bit q of
 * quads[k] for each quadrant q (x half q & 1, z half q >> 1: the child
 * node) that is hidden. lambda = K / tau, morph_start as the selection's;
 * morphing false when the patches are drawn unmorphed. Hides nothing when
 * the eye is not above the ground nearby. Uses lod's scratch: one call at a
 * time per hz_lod. */
hz_result hz__horizon_hidden(hz_lod *lod, const hz_camera *cam, float lambda, float morph_start, bool morphing,
                             const hz_patch *patches, size_t count, uint8_t *hidden, uint16_t *quads, size_t from);

/* Builds the occluder cells' minima (16 bytes per patch node), once. */
hz_result hz__horizon_prepare(hz_lod *lod);

/* Mode entry points (lod.c dispatches). */
hz_result hz__lod_select_quadtree(hz_lod *lod, const hz_camera *cam, const hz_lod_params *p, hz_index_list *out,
                                  hz_node_list *leaves, hz_node_list *culled, hz_lod_stats *st);
hz_result hz__lod_select_remedy(hz_lod *lod, const hz_camera *cam, const hz_lod_params *p, hz_index_list *out,
                                hz_node_list *leaves, hz_node_list *culled, hz_lod_stats *st);
hz_result hz__lod_select_bidir(hz_lod *lod, const hz_camera *cam, const hz_lod_params *p, hz_index_list *out,
                               hz_node_list *leaves, hz_node_list *culled, hz_lod_stats *st);
hz_result hz__lod_select_roam(hz_lod *lod, const hz_camera *cam, const hz_lod_params *p, hz_index_list *out,
                              hz_lod_stats *st);
hz_result hz__lod_select_cdlod(hz_lod *lod, const hz_camera *cam, const hz_lod_params *p, hz_index_list *out,
                               hz_node_list *leaves, hz_node_list *culled, hz_lod_stats *st);
void hz__lod_roam_free(hz_lod *lod);
hz_result hz__lod_roam_prepare(hz_lod *lod);
hz_result hz__lod_cdlod_prepare(hz_lod *lod);
size_t hz__lod_roam_bytes(const hz_lod *lod);

/* Status of the same-level neighbour of node (x, z, s) at level l across dir.
 * The neighbour exists iff its parent split this frame. Its parent is either
 * our parent P (a sibling: exists) or P's neighbour Q across the same edge.
 * Q's flag is only read when P saw Q exist (P's don't-care bit clear), so Q was
 * visited this frame and its flag is fresh: the flag array never needs
 * clearing. A culled Q means nothing is drawn there: don't care. */
static inline uint8_t neighbour_of(const hz_lod *lod, uint32_t l, uint32_t x, uint32_t z, uint32_t s, int dir)
{
    const uint32_t n = lod->size;
    switch (dir) {
    case DIR_W: if (x == s) return NB_DONTCARE; break;
    case DIR_E: if (x + s == n - 1) return NB_DONTCARE; break;
    case DIR_N: if (z == s) return NB_DONTCARE; break;
    default:    if (z + s == n - 1) return NB_DONTCARE; break;
    }
    if (l == 0)
        return NB_DONTCARE;
    const uint32_t ps = 2 * s;
    const uint32_t px = centre_of(x, ps);
    const uint32_t pz = centre_of(z, ps);
    bool sibling;
    uint32_t qx = px, qz = pz;
    switch (dir) {
    case DIR_W: sibling = x > px; qx = px - 2 * ps; break;
    case DIR_E: sibling = x < px; qx = px + 2 * ps; break;
    case DIR_N: sibling = z > pz; qz = pz - 2 * ps; break;
    default:    sibling = z < pz; qz = pz + 2 * ps; break;
    }
    if (sibling)
        return NB_EXISTS;
    uint8_t pf = lod->flags[node_index(lod, l - 1, px, pz)];
    if (pf & (1u << (DC_SHIFT + dir)))
        return NB_DONTCARE;
    uint8_t qf = lod->flags[node_index(lod, l - 1, qx, qz)] & ST_MASK;
    if (qf == ST_SPLIT)
        return NB_EXISTS;
    if (qf == ST_CULLED)
        return NB_DONTCARE;
    return NB_ABSENT;
}

/* Fan emission with the skip rule (T6a): nb[dir] == NB_ABSENT skips that edge
 * midpoint. Counter-clockwise seen from above. Returns triangles written
 * (dst needs room for 8 * 3 indices). */
uint32_t hz__emit_fan(uint32_t *dst, uint32_t n, uint32_t x, uint32_t z, uint32_t s, const uint8_t nb[4]);

#endif
