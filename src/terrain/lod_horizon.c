/* Horizon culling of cdlod patches: the terrain hides itself.
 *
 * Seen from above the ground, a point Q of the terrain is hidden when, along
 * the vertical half-plane from the eye through Q (its azimuth), some nearer
 * ground P rises above the line from the eye to Q: the elevation slope
 * (y - eye_y) / r of P (r the horizontal distance) exceeds Q's. The ray to Q
 * then passes under P's ground, so it crossed the surface from above before
 * reaching P, through a front face, which is drawn. After Lloyd and Egbert's
 * horizon culling (2002), with distance rings instead of a front-to-back
 * traversal.
 *
 * Occluders: every patch the selection keeps, near ones split into cells of
 * two or more of its grid cells a side (nodes one or two levels finer, their
 * least samples kept per patch node: hz__horizon_prepare). Along any azimuth
 * through a cell the drawn surface lies at or above a lower bound y_lo, at horizontal
 * distances within the cell's [r_min, r_max]: the cell rises at least to the
 * slope (y_lo - eye_y) / r_min (or / r_max when y_lo is above the eye) over
 * the whole of its azimuth range. The horizon H[bin] keeps the highest such
 * slope per azimuth bin, over the bins a cell covers entirely.
 *
 * Occludees: whole patches, nearest first by distance ring. A patch whose
 * every azimuth bin it touches has a horizon above its highest slope (its
 * upper bound y_hi at r_min, or at r_max below the eye), built only from cells
 * entirely nearer (r_max in an earlier ring than the patch's r_min), is
 * hidden and dropped. A hidden patch's cells still count as occluders: they
 * lie under the horizon that hides them, so they change nothing behind.
 *
 * Bounds of the drawn surface: the samples' min/max of the node (box_of,
 * lowered for Earth curvature) widened by the morph. A vertex morphs toward
 * the midpoint of two neighbours inside the cell, each moved toward its own
 * target by at most its morph error, and a vertex with morph error e only
 * morphs beyond a * lambda * e (a = morph start, lambda = K / tau): so no
 * drawn height leaves the samples' range by more than d_far / (a lambda),
 * d_far the cell's farthest distance, about tau / a pixels of slope.
 *
 * Conditions (otherwise nothing is culled): no ground within 3 near-plane
 * distances of the eye (a crossing nearer would be clipped away; also the
 * eye above the ground), the eye over the map, and every sample drawn (a
 * hole lets a ray through the surface: hz_lod_desc.holes).
 *
 * Azimuths are pseudo-angles (the "diamond angle": monotonic, no atan2),
 * 4096 bins over the circle, about a pixel each at a 60 degree view. */
#include "lod_internal.h"

#include <float.h>
#include <string.h>
#include <stdlib.h>

#define HB 4096 /* azimuth bins over the circle */
#define QUAD_BIT 0x80000000u /* a quadrant occludee's entry: ring | index << 8 | QUAD_BIT */

/* Monotonic in the angle of (x, z), 0..4 counterclockwise from +x (the
 * "diamond angle"); branch-free selects: the corners of one box often lie
 * in different quadrants. */
static inline float diamond(float x, float z)
{
    const float t = z / (fabsf(x) + fabsf(z) + 1e-30f); /* -1 .. 1 */
    const float right = t < 0.0f ? 4.0f + t : t;
    return x >= 0.0f ? right : 2.0f - t;
}

/* Ring key of a horizontal distance: an eighth of a doubling per ring (the
 * float's exponent and three mantissa bits). Monotonic in r. */
static inline uint32_t ring_of(float r)
{
    union {
        float f;
        uint32_t u;
    } v = {.f = r < 1.0f ? 1.0f : r};
    return (v.u >> 20) - (127u << 3); /* 0 at 1 m */
}

struct hcell {
    uint32_t ring;
    int32_t b0, b1; /* bins b0 .. b1 - 1 (may run past HB: wrapped) */
    float slope;
};
typedef struct hcell hcell;

/* Box b's horizontal distances from the eye, r_min and r_max; false when the
 * eye's x, z lies inside (or on) it. */
static inline bool radii(const vec3 box[2], const float eye[3], float *rmin, float *rmax)
{
    const float x0 = box[0][0] - eye[0], x1 = box[1][0] - eye[0];
    const float z0 = box[0][2] - eye[2], z1 = box[1][2] - eye[2];
    if (x0 <= 0.0f && x1 >= 0.0f && z0 <= 0.0f && z1 >= 0.0f)
        return false;
    const float dx = x0 > 0.0f ? x0 : (x1 < 0.0f ? -x1 : 0.0f);
    const float dz = z0 > 0.0f ? z0 : (z1 < 0.0f ? -z1 : 0.0f);
    const float fx = maxf(fabsf(x0), fabsf(x1)), fz = maxf(fabsf(z0), fabsf(z1));
    *rmin = sqrtf(dx * dx + dz * dz);
    *rmax = sqrtf(fx * fx + fz * fz);
    return true;
}

/* The pseudo-angle range, in bins, of a box not around the eye from its
 * four corners' pseudo-angles: relative to the first (the box spans under
 * half a turn), so a range across the wrap stays one range. */
static inline void azimuths(float q0, float q1, float q2, float q3, float *p0, float *p1)
{
    const float q[3] = {q1, q2, q3};
    float lo = 0.0f, hi = 0.0f;
    for (int k = 0; k < 3; k++) {
        float d = q[k] - q0;
        d -= d > 2.0f ? 4.0f : (d < -2.0f ? -4.0f : 0.0f);
        lo = d < lo ? d : lo;
        hi = d > hi ? d : hi;
    }
    *p0 = (q0 + lo) * (HB / 4.0f);
    *p1 = (q0 + hi) * (HB / 4.0f);
}

/* The slope to y at horizontal distances r_min .. r_max: the least (lo) or
 * the greatest (hi) over that range. */
static inline float slope_lo(float dy, float rmin, float rmax)
{
    return dy / (dy < 0.0f ? rmin : rmax);
}

static inline float slope_hi(float dy, float rmin, float rmax)
{
    return dy / (dy > 0.0f ? rmin : rmax);
}

/* Whether the eye may cull: over the map, and more than 3 near distances
 * above every sample within 3 near distances (the highest sample of the, at
 * most four, nodes of the finest level at least that wide around it), so no
 * ground lies within 3 near distances of the eye: a ray meets the ground
 * beyond the near plane (up to 70 degrees off the view axis), where it is
 * drawn, not clipped away. (It also puts the eye above the ground.) */
static bool eye_ok(const hz_lod *lod, const hz_camera *cam)
{
    const float sp = lod->spacing, ext = (float)(lod->size - 1) * sp;
    if (!(cam->pos[0] >= 0.0f && cam->pos[2] >= 0.0f && cam->pos[0] <= ext && cam->pos[2] <= ext))
        return false;
    const float near3 = 3.0f * (cam->znear > 0.0f ? cam->znear : 1.0f), reach = near3 / sp + 1.0f; /* samples */
    uint32_t l = lod->levels - 1;
    while (l > 0 && (float)half_of(lod, l) < reach)
        l--;
    const uint32_t s = half_of(lod, l), top = lod->size - 2;
    float hi = -FLT_MAX;
    for (int k = 0; k < 4; k++) {
        const float x = cam->pos[0] / sp + ((k & 1) ? reach : -reach), z = cam->pos[2] / sp + ((k & 2) ? reach : -reach);
        const uint32_t i = x <= 0.0f ? 0 : (x >= (float)top ? top : (uint32_t)x);
        const uint32_t j = z <= 0.0f ? 0 : (z >= (float)top ? top : (uint32_t)z);
        const uint32_t cx = centre_of(i, s), cz = centre_of(j, s);
        const float h = (lod->hm->offset + lod->hm->scale * (float)lod->mx[node_index(lod, l, cx, cz)]) * lod->zscale;
        hi = h > hi ? h : hi;
    }
    return cam->pos[1] - near3 > hi + 0.01f * near3; /* (a morphing vertex there moves far less) */
}

/* The view's azimuths in bins, [f0, f1] unwrapped (f0 in 0 .. HB): the
 * pyramid's four edge rays span them unless it holds the vertical (then, or
 * past half a turn, false: every azimuth). Widened by two bins. */
static bool view_span(const hz_camera *cam, int32_t *f0, int32_t *f1)
{
    const double pitch = glm_rad(glm_clamp(cam->pitch, -89.9f, 89.9f)), yaw = glm_rad(cam->yaw);
    const double f[3] = {sin(yaw) * cos(pitch), sin(pitch), -cos(yaw) * cos(pitch)};
    const double r[3] = {cos(yaw), 0.0, sin(yaw)};
    const double u[3] = {r[1] * f[2] - r[2] * f[1], r[2] * f[0] - r[0] * f[2], r[0] * f[1] - r[1] * f[0]};
    const double ty = tan(glm_rad(cam->fov_y > 0 ? cam->fov_y : 60.0f) * 0.5);
    const double tx = ty * (cam->aspect > 0 ? cam->aspect : 16.0 / 9.0);
    /* the vertical inside: in view space (r.y, u.y, f.y) for up, negated for down */
    for (int sgn = -1; sgn <= 1; sgn += 2) {
        const double z = sgn * f[1];
        if (z > 0.0 && fabs(sgn * r[1]) <= tx * z * 1.01 && fabs(sgn * u[1]) <= ty * z * 1.01)
            return false;
    }
    const float pc = diamond((float)f[0], (float)f[2]);
    float lo = 0.0f, hi = 0.0f;
    for (int k = 0; k < 4; k++) {
        const double sx = (k & 1) ? tx : -tx, sy = (k & 2) ? ty : -ty;
        const double dx = f[0] + r[0] * sx + u[0] * sy, dz = f[2] + r[2] * sx + u[2] * sy;
        if (dx * dx + dz * dz < 1e-6)
            return false;
        float d = diamond((float)dx, (float)dz) - pc;
        d -= d > 2.0f ? 4.0f : (d < -2.0f ? -4.0f : 0.0f);
        lo = d < lo ? d : lo;
        hi = d > hi ? d : hi;
    }
    if (hi - lo >= 1.9f)
        return false;
    float a = (pc + lo) * (HB / 4.0f);
    a -= a < 0.0f ? (float)HB : 0.0f;
    *f0 = (int32_t)floorf(a) - 2;
    *f1 = (int32_t)floorf(a + (hi - lo) * (HB / 4.0f)) + 3;
    return true;
}

/* Bins [*b0, *b1) within the view's [f0, f1) (both under half a turn):
 * false when none. */
static inline bool clip_span(int32_t *b0, int32_t *b1, int32_t f0, int32_t f1)
{
    int32_t k = *b0 - f0;
    k = (k >= 0 ? k + HB / 2 : k - HB / 2 + 1) / HB; /* the turn that brings b0 nearest f0 */
    int32_t a = *b0 - k * HB, b = *b1 - k * HB;
    a = a > f0 ? a : f0;
    b = b < f1 ? b : f1;
    if (b <= a)
        return false;
    *b0 = a;
    *b1 = b;
    return true;
}

/* The occluder cells of a patch node: its n x n cells' (n = 1 << hz_off)
 * least samples as fractions of the node's range, rounded down (a byte each,
 * 16 a node: one cache line per patch instead of a line per cell). */
static uint32_t sub_off(uint32_t P)
{
    uint32_t off = 0; /* cells of two grid cells a side (or more), at most 4 x 4 a patch */
    while ((2u << off) <= P / 2 && off < 2)
        off++;
    return off;
}

hz_result hz__horizon_prepare(hz_lod *lod)
{
    if (lod->hz_sub)
        return HZ_OK;
    const uint32_t off = sub_off(lod->patch), n = 1u << off, lp = lod->patch_level;
    const size_t nodes = lod->level_offset[lp + 1];
    uint8_t *sub = malloc(nodes * 16);
    if (!sub)
        return HZ_ERR_MEMORY;
    for (uint32_t l = 0; l <= lp; l++) {
        const uint32_t s = half_of(lod, l), m = 1u << l, cl = l + off, hs = half_of(lod, cl);
        for (uint32_t zi = 0; zi < m; zi++)
            for (uint32_t xi = 0; xi < m; xi++) {
                const size_t i = lod->level_offset[l] + ((size_t)zi << l) + xi;
                const uint32_t lo = lod->mn[i], range = lod->mx[i] - lo;
                uint8_t *o = sub + i * 16;
                for (uint32_t b = 0; b < n; b++)
                    for (uint32_t a = 0; a < n; a++) {
                        const uint32_t x = xi * 2 * s + hs + 2 * hs * a, z = zi * 2 * s + hs + 2 * hs * b;
                        const uint32_t v = lod->mn[node_index(lod, cl, x, z)] - lo;
                        o[b * n + a] = range ? (uint8_t)(v * 255u / range) : 0;
                    }
            }
    }
    lod->hz_sub = sub;
    return HZ_OK;
}

/* The highest slope over bins [b0, b1) (b1 - b0 <= HB), wrapped: at most two
 * contiguous runs, so the loops vectorise. */
static inline void horizon_raise(float *H, int32_t b0, int32_t b1, float slope)
{
    const int32_t n = b1 - b0;
    b0 &= HB - 1;
    const int32_t e = b0 + n > HB ? HB : b0 + n;
    for (int32_t b = b0; b < e; b++)
        H[b] = H[b] > slope ? H[b] : slope;
    for (int32_t b = 0; b < b0 + n - HB; b++)
        H[b] = H[b] > slope ? H[b] : slope;
}

/* The lowest horizon over bins [b0, b1), as horizon_raise walks them. */
static inline float horizon_low(const float *H, int32_t b0, int32_t b1)
{
    const int32_t n = b1 - b0;
    b0 &= HB - 1;
    const int32_t e = b0 + n > HB ? HB : b0 + n;
    float m = FLT_MAX;
    for (int32_t b = b0; b < e; b++)
        m = H[b] < m ? H[b] : m;
    for (int32_t b = 0; b < b0 + n - HB; b++)
        m = H[b] < m ? H[b] : m;
    return m;
}

hz_result hz__horizon_hidden(hz_lod *lod, const hz_camera *cam, float lambda, float morph_start, bool morphing,
                             const hz_patch *patches, size_t count, uint8_t *hidden, uint16_t *quads, size_t from)
{
    if (count)
        memset(hidden, 0, count);
    if (quads && count)
        memset(quads, 0, count * sizeof *quads);
    if (count == 0 || !eye_ok(lod, cam))
        return HZ_OK;
    if (hz__horizon_prepare(lod) != HZ_OK)
        return HZ_ERR_MEMORY;
    const uint32_t P = lod->patch, off = sub_off(P);
    const float hsw = lod->hm->scale * lod->zscale, hof = lod->hm->offset * lod->zscale;
    const size_t most = count * ((size_t)1 << (2 * off)) + 5 * count;
    if (list_reserve((void **)&lod->hz_cells, &lod->hz_cells_cap, most, sizeof(hcell)) ||
        list_reserve((void **)&lod->hz_sorted, &lod->hz_sorted_cap, most, sizeof(hcell)))
        return HZ_ERR_MEMORY;
    /* The morph's reach below and above the samples: d_far / (a lambda),
     * with a margin for the float rounding. */
    const float kb = morphing ? 1.01f / (morph_start * lambda) : 0.0f;
    const float *eye = cam->pos;
    int32_t f0 = 0, f1 = 0;
    const bool clip = view_span(cam, &f0, &f1);
    hcell *c = lod->hz_cells;
    uint32_t per_ring[256] = {0};
    /* c[0 .. patches): the occludees, their highest slope, ring of r_min
     * (UINT32_MAX: around the eye, drawn); then the occluder cells, their
     * lowest slope, ring of r_max. */
    size_t nc = count;
    for (size_t k = 0; k < count; k++) {
        const hz_patch *p = &patches[k];
        const uint32_t s = half_of(lod, p->level);
        const size_t ni = node_index(lod, p->level, p->x0 + s, p->z0 + s);
        vec3 box[2];
        box_of(lod, ni, p->x0 + s, p->z0 + s, s, box);
        float rmin, rmax;
        hcell *e = &c[k];
        e->ring = UINT32_MAX;
        if (!radii((const vec3 *)box, eye, &rmin, &rmax))
            continue;
        const float x0 = box[0][0] - eye[0], x1 = box[1][0] - eye[0];
        const float z0 = box[0][2] - eye[2], z1 = box[1][2] - eye[2];
        float p0, p1;
        azimuths(diamond(x0, z0), diamond(x1, z0), diamond(x0, z1), diamond(x1, z1), &p0, &p1);
        const float dy = maxf(fabsf(box[0][1] - eye[1]), fabsf(box[1][1] - eye[1]));
        const float dfar = sqrtf(rmax * rmax + dy * dy);
        e->ring = ring_of(rmin);
        e->b0 = (int32_t)floorf(p0);
        e->b1 = (int32_t)floorf(p1) + 1;
        /* A patch still or morphing simply (hz_patch.simple) is drawn within
         * its samples' heights: a vertex lies between its sample and the
         * midpoint of two samples beside it in the same cell. No morph to
         * allow for. */
        const float kp = p->simple ? 0.0f : kb;
        e->slope = slope_hi(box[1][1] + kp * dfar - eye[1], rmin, rmax);
        if (clip && !clip_span(&e->b0, &e->b1, f0, f1))
            e->b0 = e->b1 = 0; /* outside the view's azimuths: hidden */
        /* Its quadrants too (the child nodes' boxes), from `from` on: their
         * entries carry count + 4 k + quadrant. */
        if (quads && k >= from && p->level + 1u < lod->levels && count < (1u << 20)) {
            const uint32_t cs = s / 2;
            for (uint32_t qd = 0; qd < 4; qd++) {
                const uint32_t cx = p->x0 + cs + (qd & 1) * s, cz = p->z0 + cs + (qd >> 1) * s;
                vec3 qb[2];
                box_of(lod, node_index(lod, p->level + 1, cx, cz), cx, cz, cs, qb);
                float q0, q1, a0, a1;
                if (!radii((const vec3 *)qb, eye, &q0, &q1))
                    continue;
                const float X0 = qb[0][0] - eye[0], X1 = qb[1][0] - eye[0];
                const float Z0 = qb[0][2] - eye[2], Z1 = qb[1][2] - eye[2];
                azimuths(diamond(X0, Z0), diamond(X1, Z0), diamond(X0, Z1), diamond(X1, Z1), &a0, &a1);
                const float qdy = maxf(fabsf(qb[0][1] - eye[1]), fabsf(qb[1][1] - eye[1]));
                hcell *qe = &c[nc++];
                *qe = (hcell){.ring = ring_of(q0), .b0 = (int32_t)floorf(a0), .b1 = (int32_t)floorf(a1) + 1,
                              .slope = slope_hi(qb[1][1] + kp * sqrtf(q1 * q1 + qdy * qdy) - eye[1], q0, q1)};
                if (clip && !clip_span(&qe->b0, &qe->b1, f0, f1))
                    qe->b0 = qe->b1 = 0;
                qe->ring = (qe->ring > 255 ? 255 : qe->ring) | (uint32_t)(count + 4 * k + qd) << 8 | QUAD_BIT;
            }
        }
        /* The occluders: the patch's cells, 4 x 4 from 64 bins wide, 2 x 2
         * from 16, else the patch (on the peers' flight at tau 1.5: 15 %
         * of the triangles hidden for 1.1 ms; 4 x 4 everywhere, 16 % for
         * 3 ms; the patches alone, 11 %). A cell covering no bin whole hides
         * nothing. */
        const int32_t span = e->b1 - e->b0;
        const uint32_t o = span >= 64 ? off : (span >= 16 && off ? 1 : 0), n = 1u << o;
        if (n == 1) {
            int32_t b0 = (int32_t)ceilf(p0), b1 = (int32_t)floorf(p1);
            if (b1 > b0 && (!clip || clip_span(&b0, &b1, f0, f1)))
                c[nc++] = (hcell){.ring = ring_of(rmax), .b0 = b0, .b1 = b1,
                                  .slope = slope_lo(box[0][1] - kp * dfar - eye[1], rmin, rmax)};
            continue;
        }
        float q[25]; /* the cells' corners' pseudo-angles, (n + 1)^2 */
        const float step = (x1 - x0) / (float)n;
        for (uint32_t b = 0; b <= n; b++)
            for (uint32_t a = 0; a <= n; a++)
                q[b * (n + 1) + a] = diamond(x0 + step * (float)a, z0 + step * (float)b);
        const uint8_t *qs = lod->hz_sub + ni * 16;
        const uint32_t N = 1u << off, kk = N / n;
        const uint32_t lo = lod->mn[ni], range = lod->mx[ni] - lo;
        for (uint32_t b = 0; b < n; b++)
            for (uint32_t a = 0; a < n; a++) {
                vec3 cb[2];
                cb[0][0] = box[0][0] + step * (float)a;
                cb[1][0] = cb[0][0] + step;
                cb[0][2] = box[0][2] + step * (float)b;
                cb[1][2] = cb[0][2] + step;
                /* the cell's least sample (rounded down) and the patch's most */
                uint32_t qm = 255; /* the least of the k x k stored cells it spans */
                for (uint32_t bb = b * kk; bb < (b + 1) * kk; bb++)
                    for (uint32_t aa = a * kk; aa < (a + 1) * kk; aa++)
                        qm = qs[bb * N + aa] < qm ? qs[bb * N + aa] : qm;
                cb[0][1] = hof + hsw * (float)(lo + qm * range / 255u);
                cb[1][1] = hof + hsw * (float)lod->mx[ni];
                hz_camera_curve_box(cam, cb);
                float cmin, cmax, c0, c1;
                if (!radii((const vec3 *)cb, eye, &cmin, &cmax))
                    continue;
                const uint32_t i = b * (n + 1) + a;
                azimuths(q[i], q[i + 1], q[i + n + 1], q[i + n + 2], &c0, &c1);
                int32_t b0 = (int32_t)ceilf(c0), b1 = (int32_t)floorf(c1);
                if (b1 <= b0 || (clip && !clip_span(&b0, &b1, f0, f1)))
                    continue;
                const float slope = slope_lo(cb[0][1] - kp * sqrtf(cmax * cmax + dy * dy) - eye[1], cmin, cmax);
                c[nc++] = (hcell){.ring = ring_of(cmax), .b0 = b0, .b1 = b1, .slope = slope};
            }
    }
    /* Counting sort by ring; each ring's occludees are tested before its
     * cells go in: they see only the cells of earlier rings. The sorted
     * entries keep in ring the occludee's index (UINT32_MAX: a cell). */
    for (size_t k = 0; k < nc; k++) {
        if (c[k].ring == UINT32_MAX)
            continue;
        const uint32_t ring = (c[k].ring & QUAD_BIT) ? (c[k].ring & 255u) : c[k].ring;
        per_ring[ring > 255 ? 255 : ring]++;
    }
    uint32_t start[256], acc = 0;
    for (int r = 0; r < 256; r++) {
        start[r] = acc;
        acc += per_ring[r];
    }
    hcell *srt = lod->hz_sorted;
    for (size_t k = 0; k < nc; k++) {
        if (c[k].ring == UINT32_MAX)
            continue;
        const bool quad = (c[k].ring & QUAD_BIT) != 0;
        uint32_t ring = quad ? (c[k].ring & 255u) : c[k].ring;
        ring = ring > 255 ? 255 : ring;
        hcell e = c[k];
        e.ring = k < count ? (uint32_t)k : (quad ? (c[k].ring & ~QUAD_BIT) >> 8 : UINT32_MAX);
        srt[start[ring]++] = e;
    }
    float H[HB];
    for (int b = 0; b < HB; b++)
        H[b] = -FLT_MAX;
    size_t pos = 0;
    for (int r = 0; r < 256; r++) {
        const size_t end = pos + per_ring[r];
        for (size_t k = pos; k < end; k++)
            if (srt[k].ring != UINT32_MAX) {
                const bool h = horizon_low(H, srt[k].b0, srt[k].b1) > srt[k].slope;
                if (srt[k].ring < count)
                    hidden[srt[k].ring] = h;
                else
                    quads[(srt[k].ring - count) >> 2] |= (uint16_t)(h << ((srt[k].ring - count) & 3));
            }
        for (size_t k = pos; k < end; k++)
            if (srt[k].ring == UINT32_MAX)
                horizon_raise(H, srt[k].b0, srt[k].b1, srt[k].slope);
        pos = end;
    }
    for (size_t k = 0; quads && k < count; k++)
        if (hidden[k])
            quads[k] = 0; /* hidden whole */
    return HZ_OK;
}
