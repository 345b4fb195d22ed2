/* Quadtree LOD: precomputation against brute force, mesh validity on many
 * random cameras, conservative culling, layout independence, flag reuse. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "horizon/dem.h"
#include "horizon/lod.h"
#include "mesh_check.h"

static uint64_t rng_state = 0x9e3779b97f4a7c15ULL;
static float frand(float lo, float hi)
{
    return test_frand(&rng_state, lo, hi);
}

/* White noise plus a few hills: rough everywhere, stresses the restriction. */
static void make_random_grid(hz_grid *g, uint32_t n, float amp)
{
    assert_int_equal(hz_grid_alloc(g, n, n, NULL), HZ_OK);
    for (uint32_t j = 0; j < n; j++)
        for (uint32_t i = 0; i < n; i++) {
            float x = (float)i / (float)n, z = (float)j / (float)n;
            float h = amp * (0.5f + 0.25f * sinf(9.0f * x) * cosf(7.0f * z) + 0.1f * sinf(31.0f * x + 3 * z));
            g->z[(size_t)j * n + i] = h + frand(0, amp * 0.05f);
        }
}

typedef struct terrain {
    const char *name;
    hz_heightmap hm;
    hz_lod *lod;
    float spacing, zscale;
} terrain;

static void terrain_from_grid(terrain *t, const char *name, hz_grid *g, float spacing, hz_layout layout)
{
    hz_err err = {0};
    t->name = name;
    t->spacing = spacing;
    t->zscale = 1.0f;
    assert_int_equal(hz_heightmap_create(&t->hm, g, layout, &err), HZ_OK);
    t->lod = hz_lod_create(&(hz_lod_desc){.hm = &t->hm, .spacing = spacing, .zscale = 1.0f}, &err);
    assert_non_null(t->lod);
}

static void terrain_free(terrain *t)
{
    hz_lod_destroy(t->lod);
    hz_heightmap_destroy(&t->hm);
}

/* ---- brute force precomputation ---- */

static float bf_local_d2(const hz_heightmap *hm, uint32_t x, uint32_t z, uint32_t s, float spacing)
{
#define H(i, j) ((float)hz_heightmap_get16(hm, (i), (j)))
    float nw = H(x - s, z - s), ne = H(x + s, z - s), sw = H(x - s, z + s), se = H(x + s, z + s);
    float e[6] = {
        fabsf(H(x, z) - 0.5f * (nw + se)), fabsf(H(x, z) - 0.5f * (ne + sw)),
        fabsf(H(x, z - s) - 0.5f * (nw + ne)), fabsf(H(x, z + s) - 0.5f * (sw + se)),
        fabsf(H(x - s, z) - 0.5f * (nw + sw)), fabsf(H(x + s, z) - 0.5f * (ne + se)),
    };
#undef H
    float m = 0;
    for (int k = 0; k < 6; k++)
        m = fmaxf(m, e[k]);
    return m * hm->scale / (2.0f * (float)s * spacing);
}

static float bf_d2(const hz_heightmap *hm, uint32_t x, uint32_t z, uint32_t s, float spacing, float K)
{
    float d = bf_local_d2(hm, x, z, s, spacing);
    if (s > 1) {
        uint32_t h = s / 2;
        d = fmaxf(d, K * bf_d2(hm, x - h, z - h, h, spacing, K));
        d = fmaxf(d, K * bf_d2(hm, x + h, z - h, h, spacing, K));
        d = fmaxf(d, K * bf_d2(hm, x - h, z + h, h, spacing, K));
        d = fmaxf(d, K * bf_d2(hm, x + h, z + h, h, spacing, K));
    }
    return d;
}

static void test_precompute_matches_brute_force(void **state)
{
    (void)state;
    const uint32_t sizes[] = {3, 5, 17, 65, 129};
    for (size_t si = 0; si < sizeof sizes / sizeof *sizes; si++) {
        uint32_t n = sizes[si];
        hz_grid g;
        make_random_grid(&g, n, 300.0f);
        terrain t;
        terrain_from_grid(&t, "random", &g, 7.0f, HZ_LAYOUT_BLOCKED);
        const float K = 25.0f / (2.0f * 24.0f);
        size_t checked = 0;
        for (uint32_t s = 1; 2 * s < n; s *= 2)
            for (uint32_t z = s; z + s < n; z += 2 * s)
                for (uint32_t x = s; x + s < n; x += 2 * s) {
                    float d2, mn, mx;
                    assert_true(hz_lod_query_node(t.lod, x, z, s, &d2, &mn, &mx));
                    float bmn = INFINITY, bmx = -INFINITY;
                    for (uint32_t j = z - s; j <= z + s; j++)
                        for (uint32_t i = x - s; i <= x + s; i++) {
                            bmn = fminf(bmn, hz_heightmap_get(&t.hm, i, j));
                            bmx = fmaxf(bmx, hz_heightmap_get(&t.hm, i, j));
                        }
                    assert_float_equal(mn, bmn, 1e-3);
                    assert_float_equal(mx, bmx, 1e-3);
                    float bd = bf_d2(&t.hm, x, z, s, 7.0f, K);
                    assert_float_equal(d2, bd, 1e-5f * fmaxf(1.0f, bd));
                    /* The world box holds every sample of the node. */
                    vec3 box[2];
                    assert_true(hz_lod_node_box(t.lod, x, z, s, box));
                    for (uint32_t j = z - s; j <= z + s; j++)
                        for (uint32_t i = x - s; i <= x + s; i++) {
                            float y = hz_heightmap_get(&t.hm, i, j);
                            assert_true(y >= box[0][1] && y <= box[1][1]);
                            assert_true((float)i * 7.0f >= box[0][0] && (float)i * 7.0f <= box[1][0]);
                            assert_true((float)j * 7.0f >= box[0][2] && (float)j * 7.0f <= box[1][2]);
                        }
                    checked++;
                }
        assert_int_equal(checked, ((size_t)(n - 1) * (n - 1) - 1) / 3);
        /* Not a node: wrong alignment or size. */
        assert_false(hz_lod_query_node(t.lod, 0, 0, 1, NULL, NULL, NULL));
        assert_false(hz_lod_query_node(t.lod, 2, 2, 1, NULL, NULL, NULL));
        terrain_free(&t);
        hz_grid_free(&g);
    }
}

/* ---- mesh validity ---- */

static hz_camera random_camera(const terrain *t)
{
    return test_random_camera(&rng_state, &t->hm, t->spacing);
}

static void check_terrain_random_cameras(terrain *t, int cameras)
{
    hz_index_list il = {0};
    hz_node_list leaves = {0};
    for (int k = 0; k < cameras; k++) {
        hz_camera cam = random_camera(t);
        hz_lod_params p = {.c = frand(2, 60), .c2 = frand(0.5f, 10), .criterion = (k & 1) ? HZ_LOD_UNCLAMPED : HZ_LOD_CLAMPED,
                           .no_cull = (k % 5) == 0};
        hz_lod_stats st;
        assert_int_equal(hz_lod_select(t->lod, &cam, &p, &il, &leaves, NULL, &st), HZ_OK);
        assert_int_equal(il.count, (size_t)st.triangles * 3);
        vec4 planes[6];
        hz_camera_frustum(&cam, planes);
        mesh_report r = mesh_check(&t->hm, t->spacing, t->zscale, il.data, il.count,
                                   p.no_cull ? NULL : (const vec4 *)planes, &leaves);
        char label[64];
        snprintf(label, sizeof label, "%s camera %d", t->name, k);
        mesh_assert_valid(&r, true, label);
        if (p.no_cull) /* no hole anywhere: the mesh covers the whole map once */
            assert_true(fabs(r.area - (double)(t->hm.size - 1) * (double)(t->hm.size - 1)) < 1e-6);
    }
    free(il.data);
    free(leaves.data);
}

static void test_mesh_valid_synthetic(void **state)
{
    (void)state;
    const uint32_t sizes[] = {33, 257, 513};
    for (size_t si = 0; si < 3; si++) {
        hz_grid g;
        make_random_grid(&g, sizes[si], 400.0f);
        terrain t;
        terrain_from_grid(&t, "random", &g, 10.0f, HZ_LAYOUT_BLOCKED);
        check_terrain_random_cameras(&t, 60);
        terrain_free(&t);
        hz_grid_free(&g);
    }
}

static void test_mesh_valid_generated(void **state)
{
    (void)state;
    const hz_gen_kind kinds[] = {HZ_GEN_PERLIN, HZ_GEN_DIAMOND};
    for (int k = 0; k < 2; k++) {
        hz_grid g;
        hz_err err = {0};
        assert_int_equal(hz_generate(&(hz_gen_desc){.kind = kinds[k], .size = 1025, .seed = 7}, &g, &err), HZ_OK);
        terrain t;
        terrain_from_grid(&t, k ? "diamond" : "perlin", &g, 10.0f, HZ_LAYOUT_BLOCKED);
        check_terrain_random_cameras(&t, 40);
        terrain_free(&t);
        hz_grid_free(&g);
    }
}

static void test_mesh_valid_real_dem(void **state)
{
    (void)state;
    const char *files[] = {HZ_DATA_DIR "/N44W072.hgt", HZ_DATA_DIR "/himalaya-everest_3as_ft16.png"};
    for (int f = 0; f < 2; f++) {
        hz_grid g;
        hz_err err = {0};
        hz_dem_info info;
        hz_result r = hz_dem_load(&(hz_dem_desc){.path = files[f]}, &g, &info, &err);
        if (r != HZ_OK)
            fail_msg("cannot load %s: %s", files[f], err.msg);
        assert_int_equal(hz_grid_fill_voids(&g, NULL, &err), HZ_OK);
        assert_int_equal(hz_grid_fit_pow2(&g, HZ_FIT_AUTO, NULL, 0, &err), HZ_OK);
        terrain t;
        terrain_from_grid(&t, files[f], &g, info.spacing_hint > 0 ? info.spacing_hint : 30.0f, HZ_LAYOUT_BLOCKED);
        check_terrain_random_cameras(&t, 40);
        terrain_free(&t);
        hz_grid_free(&g);
    }
}

/* A mesh with a T-junction, a hole and a flipped triangle must be caught: the
 * checker itself can fail. */
static void test_checker_catches_bad_meshes(void **state)
{
    (void)state;
    hz_grid g;
    make_random_grid(&g, 5, 10.0f);
    hz_heightmap hm;
    assert_int_equal(hz_heightmap_create(&hm, &g, HZ_LAYOUT_LINEAR, NULL), HZ_OK);
    const uint32_t n = 5;
#define V(i, j) ((j) * n + (i))
    /* Left half as one coarse quad (0..2), right half split in cells: the
     * coarse edge x=2, z 0..2 has vertex (2,1) inside it -> T-junction. */
    uint32_t tj[] = {
        V(0, 0), V(0, 2), V(2, 0), V(2, 0), V(0, 2), V(2, 2),
        V(2, 0), V(2, 1), V(3, 0), V(3, 0), V(2, 1), V(3, 1),
        V(2, 1), V(2, 2), V(3, 1), V(3, 1), V(2, 2), V(3, 2),
    };
    mesh_report r = mesh_check(&hm, 1, 1, tj, sizeof tj / sizeof *tj, NULL, NULL);
    assert_true(r.t_junctions > 0);
    assert_int_equal(r.flipped, 0);
    uint32_t flip[] = {V(0, 0), V(2, 0), V(0, 2)};
    r = mesh_check(&hm, 1, 1, flip, 3, NULL, NULL);
    assert_int_equal(r.flipped, 1);
    /* One triangle in the middle of the map: its edges are open interior edges. */
    uint32_t hole[] = {V(1, 1), V(1, 2), V(2, 1)};
    r = mesh_check(&hm, 1, 1, hole, 3, NULL, NULL);
    assert_int_equal(r.open_interior, 3);
#undef V
    hz_heightmap_destroy(&hm);
    hz_grid_free(&g);
}

static void test_full_mesh_valid(void **state)
{
    (void)state;
    hz_grid g;
    make_random_grid(&g, 65, 100.0f);
    hz_heightmap hm;
    assert_int_equal(hz_heightmap_create(&hm, &g, HZ_LAYOUT_LINEAR, NULL), HZ_OK);
    hz_index_list il = {0};
    assert_int_equal(hz_lod_full_mesh(&hm, &il), HZ_OK);
    assert_int_equal(il.count, 64 * 64 * 6);
    mesh_report r = mesh_check(&hm, 1, 1, il.data, il.count, NULL, NULL);
    assert_int_equal(r.open_interior + r.t_junctions + r.flipped + r.degenerate + r.edges_over_two, 0);
    assert_true(fabs(r.area - 64.0 * 64.0) < 1e-9);
    free(il.data);
    hz_heightmap_destroy(&hm);
    hz_grid_free(&g);
}

/* ---- culling ---- */

/* Independent of the plane code: box corners in eye space, in double, against
 * the analytic frustum (|x| <= -z tan(fov/2) aspect, near <= -z <= far ...).
 * True if all corners are beyond one side. */
static int box_outside_eye(const hz_camera *c, const vec3 box[2])
{
    double yaw = glm_rad(c->yaw), pitch = glm_rad(c->pitch);
    double f[3] = {sin(yaw) * cos(pitch), sin(pitch), -cos(yaw) * cos(pitch)};
    double r[3] = {cos(yaw), 0, sin(yaw)};
    double u[3] = {r[1] * f[2] - r[2] * f[1], r[2] * f[0] - r[0] * f[2], r[0] * f[1] - r[1] * f[0]};
    double tv = tan(glm_rad(c->fov_y) / 2), th = tv * c->aspect;
    int out[6] = {1, 1, 1, 1, 1, 1};
    for (int k = 0; k < 8; k++) {
        double p[3] = {box[k & 1][0] - c->pos[0], box[(k >> 1) & 1][1] - c->pos[1], box[(k >> 2) & 1][2] - c->pos[2]};
        double x = p[0] * r[0] + p[1] * r[1] + p[2] * r[2];
        double y = p[0] * u[0] + p[1] * u[1] + p[2] * u[2];
        double depth = p[0] * f[0] + p[1] * f[1] + p[2] * f[2];
        out[0] &= x < -depth * th;
        out[1] &= x > depth * th;
        out[2] &= y < -depth * tv;
        out[3] &= y > depth * tv;
        out[4] &= depth < c->znear;
        out[5] &= depth > c->zfar;
    }
    return out[0] | out[1] | out[2] | out[3] | out[4] | out[5];
}

static void test_culling_conservative(void **state)
{
    (void)state;
    hz_grid g;
    make_random_grid(&g, 513, 600.0f);
    terrain t;
    terrain_from_grid(&t, "random", &g, 10.0f, HZ_LAYOUT_BLOCKED);
    hz_index_list il = {0};
    hz_node_list culled = {0};
    size_t total_culled = 0;
    for (int k = 0; k < 100; k++) {
        hz_camera cam = random_camera(&t);
        hz_lod_stats st;
        hz_lod_params p = {.c = frand(5, 50), .c2 = frand(1, 6)};
        assert_int_equal(hz_lod_select(t.lod, &cam, &p, &il, NULL, &culled, &st), HZ_OK);
        assert_int_equal(culled.count, st.nodes_culled);
        for (size_t c = 0; c < culled.count; c++) {
            const hz_lod_node *nd = &culled.data[c];
            vec3 box[2];
            assert_true(hz_lod_node_box(t.lod, nd->x, nd->z, nd->half, box));
            /* The culled box is entirely outside: nothing inside it is visible. */
            assert_true(box_outside_eye(&cam, (const vec3 *)box));
        }
        total_culled += culled.count;
    }
    assert_true(total_culled > 100); /* the cameras really exercised culling */
    free(il.data);
    free(culled.data);
    terrain_free(&t);
    hz_grid_free(&g);
}

/* cdlod culls whole subtrees: a node inside the frustum passes that on to
 * its children, which are then not tested. Every patch it keeps must still
 * touch the frustum (its box grown by the cull's margin is not outside);
 * that it keeps every patch the frustum cuts, the mesh checks show. */
static void test_cdlod_culling_effective(void **state)
{
    (void)state;
    hz_grid g;
    make_random_grid(&g, 1025, 600.0f);
    terrain t;
    terrain_from_grid(&t, "random", &g, 10.0f, HZ_LAYOUT_BLOCKED);
    hz_patch_list pl = {0};
    size_t kept = 0, culled = 0;
    for (int k = 0; k < 60; k++) {
        hz_camera cam = random_camera(&t);
        hz_lod_stats st;
        hz_lod_params p = {.mode = HZ_LOD_CDLOD, .pixel_error = frand(0.5f, 4.0f)};
        assert_int_equal(hz_lod_select_patches(t.lod, &cam, &p, &pl, &st), HZ_OK);
        /* the cull's conservative margin (lod_internal.h frustum_margin), twice */
        const float grow = 2.0f * (1e-4f * (cam.zfar + fabsf(cam.pos[0]) + fabsf(cam.pos[1]) + fabsf(cam.pos[2])) +
                                   1e-2f) + 1.0f;
        for (size_t c = 0; c < pl.count; c++) {
            vec3 box[2];
            assert_true(hz_lod_patch_box(t.lod, &pl.data[c], &cam, &st, box));
            for (int a = 0; a < 3; a++) {
                box[0][a] -= grow;
                box[1][a] += grow;
            }
            assert_false(box_outside_eye(&cam, (const vec3 *)box));
        }
        kept += pl.count;
        culled += st.nodes_culled;
    }
    assert_true(kept > 1000 && culled > 100); /* the cameras saw terrain and culled some */
    free(pl.data);
    terrain_free(&t);
    hz_grid_free(&g);
}

/* ---- layouts, flags, detail ---- */

static void test_layouts_identical(void **state)
{
    (void)state;
    hz_grid g;
    make_random_grid(&g, 257, 300.0f);
    terrain a, b;
    terrain_from_grid(&a, "linear", &g, 10.0f, HZ_LAYOUT_LINEAR);
    terrain_from_grid(&b, "blocked", &g, 10.0f, HZ_LAYOUT_BLOCKED);
    assert_int_equal(a.hm.layout, HZ_LAYOUT_LINEAR);
    assert_int_equal(b.hm.layout, HZ_LAYOUT_BLOCKED);
    for (uint32_t j = 0; j < 257; j++)
        for (uint32_t i = 0; i < 257; i++)
            assert_int_equal(hz_heightmap_get16(&a.hm, i, j), hz_heightmap_get16(&b.hm, i, j));
    hz_index_list la = {0}, lb = {0};
    for (int k = 0; k < 30; k++) {
        hz_camera cam = random_camera(&a);
        hz_lod_params p = {.c = frand(5, 50), .c2 = frand(1, 6)};
        assert_int_equal(hz_lod_select(a.lod, &cam, &p, &la, NULL, NULL, NULL), HZ_OK);
        assert_int_equal(hz_lod_select(b.lod, &cam, &p, &lb, NULL, NULL, NULL), HZ_OK);
        assert_int_equal(la.count, lb.count);
        assert_memory_equal(la.data, lb.data, la.count * sizeof *la.data);
    }
    free(la.data);
    free(lb.data);
    terrain_free(&a);
    terrain_free(&b);
    hz_grid_free(&g);
}

/* The flag array is never cleared: selecting after many other frames must give
 * exactly what a fresh LOD object gives. */
static void test_stale_flags_harmless(void **state)
{
    (void)state;
    hz_grid g;
    make_random_grid(&g, 513, 500.0f);
    terrain used, fresh;
    terrain_from_grid(&used, "used", &g, 10.0f, HZ_LAYOUT_BLOCKED);
    hz_index_list a = {0}, b = {0};
    for (int k = 0; k < 40; k++) {
        hz_camera cam = random_camera(&used);
        hz_lod_params p = {.c = frand(5, 50), .c2 = frand(1, 6), .no_cull = (k % 7) == 0};
        assert_int_equal(hz_lod_select(used.lod, &cam, &p, &a, NULL, NULL, NULL), HZ_OK);
        terrain_from_grid(&fresh, "fresh", &g, 10.0f, HZ_LAYOUT_BLOCKED);
        assert_int_equal(hz_lod_select(fresh.lod, &cam, &p, &b, NULL, NULL, NULL), HZ_OK);
        assert_int_equal(a.count, b.count);
        assert_memory_equal(a.data, b.data, a.count * sizeof *a.data);
        terrain_free(&fresh);
    }
    free(a.data);
    free(b.data);
    terrain_free(&used);
    hz_grid_free(&g);
}

static void test_detail_grows_with_c(void **state)
{
    (void)state;
    hz_grid g;
    make_random_grid(&g, 1025, 800.0f);
    terrain t;
    terrain_from_grid(&t, "random", &g, 10.0f, HZ_LAYOUT_BLOCKED);
    hz_camera cam = {.pos = {5120, 1500, 5120}, .yaw = 30, .pitch = -20, .fov_y = 60, .aspect = 16.0f / 9,
                     .znear = 1, .zfar = 20000};
    hz_index_list il = {0};
    uint32_t prev = 0;
    const float cs[][2] = {{5, 1}, {25, 2.5f}, {50, 5}, {100, 10}};
    for (int k = 0; k < 4; k++) {
        hz_lod_stats st;
        hz_lod_params p = {.c = cs[k][0], .c2 = cs[k][1]};
        assert_int_equal(hz_lod_select(t.lod, &cam, &p, &il, NULL, NULL, &st), HZ_OK);
        assert_true(st.triangles > prev);
        prev = st.triangles;
    }
    /* A camera looking away from the map culls everything but what is behind. */
    hz_camera away = {.pos = {-5000, 500, 5120}, .yaw = -90, .pitch = 0, .fov_y = 60, .aspect = 1.5f,
                      .znear = 1, .zfar = 20000};
    hz_lod_stats st;
    assert_int_equal(hz_lod_select(t.lod, &away, NULL, &il, NULL, NULL, &st), HZ_OK);
    assert_int_equal(st.triangles, 0);
    assert_int_equal(st.nodes_culled, 1);
    free(il.data);
    terrain_free(&t);
    hz_grid_free(&g);
}

static void test_bad_input(void **state)
{
    (void)state;
    hz_err err = {0};
    hz_grid g;
    assert_int_equal(hz_grid_alloc(&g, 6, 6, NULL), HZ_OK);
    hz_heightmap hm;
    assert_int_not_equal(hz_heightmap_create(&hm, &g, HZ_LAYOUT_LINEAR, &err), HZ_OK);
    assert_non_null(strstr(err.msg, "2^n+1"));
    hz_grid_free(&g);
    assert_int_equal(hz_grid_alloc(&g, 5, 5, NULL), HZ_OK);
    g.z[7] = NAN;
    assert_int_equal(hz_heightmap_create(&hm, &g, HZ_LAYOUT_LINEAR, &err), HZ_ERR_VALUE);
    g.z[7] = 1;
    assert_int_equal(hz_heightmap_create(&hm, &g, HZ_LAYOUT_LINEAR, &err), HZ_OK);
    assert_null(hz_lod_create(&(hz_lod_desc){.hm = &hm, .zscale = -1}, &err));
    assert_null(hz_lod_create(&(hz_lod_desc){.hm = &hm, .zscale = NAN}, &err));
    hz_heightmap_destroy(&hm);
    hz_grid_free(&g);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_precompute_matches_brute_force),
        cmocka_unit_test(test_checker_catches_bad_meshes),
        cmocka_unit_test(test_full_mesh_valid),
        cmocka_unit_test(test_mesh_valid_synthetic),
        cmocka_unit_test(test_mesh_valid_generated),
        cmocka_unit_test(test_mesh_valid_real_dem),
        cmocka_unit_test(test_culling_conservative),
        cmocka_unit_test(test_cdlod_culling_effective),
        cmocka_unit_test(test_layouts_identical),
        cmocka_unit_test(test_stale_flags_harmless),
        cmocka_unit_test(test_detail_grows_with_c),
        cmocka_unit_test(test_bad_input),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
