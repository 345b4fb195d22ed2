#include "mesh_check.h"

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <cmocka.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct edge_slot {
    uint64_t key; /* 0 = empty; (min+1) << 32 | (max+1) */
    uint32_t count;
} edge_slot;

static uint64_t hash64(uint64_t x)
{
    x ^= x >> 33;
    x *= 0xff51afd7ed558ccdULL;
    x ^= x >> 33;
    x *= 0xc4ceb9fe1a85ec53ULL;
    x ^= x >> 33;
    return x;
}

static uint32_t gcd_u32(uint32_t a, uint32_t b)
{
    while (b) {
        uint32_t t = a % b;
        a = b;
        b = t;
    }
    return a;
}

static void world(const hz_heightmap *hm, float sp, float zs, uint32_t v, float out[3])
{
    uint32_t n = hm->size, x = v % n, z = v / n;
    out[0] = (float)x * sp;
    out[1] = hz_heightmap_get(hm, x, z) * zs;
    out[2] = (float)z * sp;
}

static int outside_same_plane(const float a[3], const float b[3], const vec4 *planes)
{
    for (int p = 0; p < 6; p++) {
        const float *pl = planes[p];
        float da = pl[0] * a[0] + pl[1] * a[1] + pl[2] * a[2] + pl[3];
        float db = pl[0] * b[0] + pl[1] * b[1] + pl[2] * b[2] + pl[3];
        if (da < 0 && db < 0)
            return 1;
    }
    return 0;
}

mesh_report mesh_check(const hz_heightmap *hm, float spacing, float zscale, const uint32_t *idx,
                       size_t count, const vec4 *planes, const hz_node_list *leaves)
{
    mesh_report r = {0};
    const uint32_t n = hm->size;
    r.triangles = count / 3;
    size_t cap = 16;
    while (cap < count * 2)
        cap *= 2;
    edge_slot *tab = calloc(cap, sizeof *tab);
    uint8_t *used = calloc((size_t)n * n, 1);
    for (size_t t = 0; t < count; t += 3) {
        const uint32_t v[3] = {idx[t], idx[t + 1], idx[t + 2]};
        int64_t x0 = v[0] % n, z0 = v[0] / n, x1 = v[1] % n, z1 = v[1] / n, x2 = v[2] % n, z2 = v[2] / n;
        /* Up-facing (counter-clockwise from +y) <=> this cross product > 0. */
        int64_t cr = (z1 - z0) * (x2 - x0) - (x1 - x0) * (z2 - z0);
        if (cr == 0)
            r.degenerate++;
        else if (cr < 0)
            r.flipped++;
        r.area += (double)llabs(cr) * 0.5;
        for (int e = 0; e < 3; e++) {
            uint32_t a = v[e], b = v[(e + 1) % 3];
            used[a] = 1;
            uint32_t lo = a < b ? a : b, hi = a < b ? b : a;
            uint64_t key = ((uint64_t)(lo + 1) << 32) | (hi + 1);
            size_t h = hash64(key) & (cap - 1);
            while (tab[h].key && tab[h].key != key)
                h = (h + 1) & (cap - 1);
            tab[h].key = key;
            tab[h].count++;
        }
    }
    for (size_t h = 0; h < cap; h++) {
        if (!tab[h].key)
            continue;
        r.edges++;
        uint32_t a = (uint32_t)(tab[h].key >> 32) - 1, b = (uint32_t)(tab[h].key & 0xffffffffu) - 1;
        int64_t ax = a % n, az = a / n, bx = b % n, bz = b / n;
        if (tab[h].count > 2)
            r.edges_over_two++;
        if (tab[h].count == 1) {
            int border = (ax == bx && (ax == 0 || ax == n - 1)) || (az == bz && (az == 0 || az == n - 1));
            if (!border) {
                float wa[3], wb[3];
                world(hm, spacing, zscale, a, wa);
                world(hm, spacing, zscale, b, wb);
                if (!planes || !outside_same_plane(wa, wb, planes))
                    r.open_interior++;
            }
        }
        /* Lattice points strictly inside the edge must not be mesh vertices. */
        int64_t dx = bx - ax, dz = bz - az;
        uint32_t g = gcd_u32((uint32_t)llabs(dx), (uint32_t)llabs(dz));
        for (uint32_t k = 1; k < g; k++) {
            int64_t px = ax + dx / g * k, pz = az + dz / g * k;
            if (used[(size_t)pz * n + (size_t)px]) {
                r.t_junctions++;
                break;
            }
        }
    }
    if (leaves && leaves->count) {
        /* Raster the leaf level into unit cells, compare 4-neighbours. */
        uint32_t m = n - 1;
        uint8_t *lv = malloc((size_t)m * m);
        memset(lv, 0xff, (size_t)m * m);
        for (size_t k = 0; k < leaves->count; k++) {
            const hz_lod_node *nd = &leaves->data[k];
            for (uint32_t z = nd->z - nd->half; z < nd->z + nd->half; z++)
                memset(lv + (size_t)z * m + (nd->x - nd->half), (int)nd->level, 2 * nd->half);
        }
        for (uint32_t z = 0; z < m; z++)
            for (uint32_t x = 0; x < m; x++) {
                int a = lv[(size_t)z * m + x];
                if (a == 0xff)
                    continue;
                if (x + 1 < m) {
                    int b = lv[(size_t)z * m + x + 1];
                    if (b != 0xff && abs(a - b) > 1)
                        r.level_jumps++;
                }
                if (z + 1 < m) {
                    int b = lv[(size_t)(z + 1) * m + x];
                    if (b != 0xff && abs(a - b) > 1)
                        r.level_jumps++;
                }
            }
        free(lv);
    }
    free(tab);
    free(used);
    return r;
}

uint64_t test_rnd(uint64_t *state)
{
    uint64_t z = (*state += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

float test_frand(uint64_t *state, float lo, float hi)
{
    return lo + (hi - lo) * (float)(test_rnd(state) >> 40) / (float)(1u << 24);
}

hz_camera test_random_camera(uint64_t *state, const hz_heightmap *hm, float spacing)
{
    float ext = (float)(hm->size - 1) * spacing;
    float lo = hm->offset, hi = hm->offset + 65535.0f * hm->scale;
    hz_camera c = {0};
    c.pos[0] = test_frand(state, -0.2f * ext, 1.2f * ext);
    c.pos[2] = test_frand(state, -0.2f * ext, 1.2f * ext);
    c.pos[1] = test_frand(state, lo, hi + (hi - lo) * 2.0f + 50.0f);
    /* Aimed at a random point of the terrain (within +-20 degrees), so
     * nearly every camera sees some of it: a camera that sees nothing
     * checks nothing. */
    const uint32_t ti = (uint32_t)test_frand(state, 0, (float)(hm->size - 1)),
                   tj = (uint32_t)test_frand(state, 0, (float)(hm->size - 1));
    const float dx = (float)ti * spacing - c.pos[0], dz = (float)tj * spacing - c.pos[2];
    const float dy = hz_heightmap_get(hm, ti, tj) - c.pos[1];
    c.yaw = glm_deg(atan2f(dx, -dz)) + test_frand(state, -20, 20);
    c.pitch = glm_deg(atan2f(dy, sqrtf(dx * dx + dz * dz) + 1e-3f)) + test_frand(state, -20, 20);
    c.pitch = c.pitch < -89.0f ? -89.0f : (c.pitch > 89.0f ? 89.0f : c.pitch);
    c.fov_y = test_frand(state, 30, 90);
    c.aspect = 16.0f / 9.0f;
    c.znear = 1.0f;
    c.zfar = ext * test_frand(state, 0.3f, 2.0f);
    /* far enough to reach the point it looks at */
    const float reach = 1.3f * sqrtf(dx * dx + dy * dy + dz * dz);
    c.zfar = c.zfar < reach ? reach : c.zfar;
    return c;
}

void mesh_assert_valid(const mesh_report *r, bool levels, const char *label)
{
    if (r->edges_over_two || r->open_interior || r->t_junctions || r->degenerate || r->flipped ||
        (levels && r->level_jumps))
        fprintf(stderr, "%s: tris %zu over2 %zu open %zu tj %zu degen %zu flip %zu jumps %zu\n", label, r->triangles,
                r->edges_over_two, r->open_interior, r->t_junctions, r->degenerate, r->flipped, r->level_jumps);
    assert_int_equal(r->edges_over_two, 0);
    assert_int_equal(r->open_interior, 0);
    assert_int_equal(r->t_junctions, 0);
    assert_int_equal(r->degenerate, 0);
    assert_int_equal(r->flipped, 0);
    if (levels)
        assert_int_equal(r->level_jumps, 0);
}
