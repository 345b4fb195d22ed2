/* Screen-space error and image metrics: zero for the exact mesh, exactly the
 * projected height difference for a known error. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "horizon/lod.h"
#include "horizon/metrics.h"

static void flat_with_bump(hz_heightmap *hm, uint32_t n, uint32_t bx, uint32_t bz, float bump)
{
    hz_grid g;
    assert_int_equal(hz_grid_alloc(&g, n, n, NULL), HZ_OK);
    for (size_t k = 0; k < (size_t)n * n; k++)
        g.z[k] = 100.0f;
    g.z[(size_t)bz * n + bx] += bump;
    g.z[0] = 0.0f; /* a low corner so the quantisation range covers 0..110 */
    assert_int_equal(hz_heightmap_create(hm, &g, HZ_LAYOUT_LINEAR, NULL), HZ_OK);
    hz_grid_free(&g);
}

static void test_full_mesh_has_zero_error(void **state)
{
    (void)state;
    hz_heightmap hm;
    flat_with_bump(&hm, 65, 30, 20, 10.0f);
    hz_index_list il = {0};
    assert_int_equal(hz_lod_full_mesh(&hm, &il), HZ_OK);
    hz_camera cam = {.pos = {320, 400, 900}, .yaw = 0, .pitch = -30, .fov_y = 60, .aspect = 1.5f, .znear = 1, .zfar = 5000};
    hz_float_buf buf = {0};
    hz_px_error e;
    assert_int_equal(hz_metrics_px_error(&hm, 10, 1, il.data, il.count, &cam, 720, &buf, &e), HZ_OK);
    assert_true(e.samples > 1000);
    assert_true(e.max_px == 0.0 && e.p99_px == 0.0);
    assert_int_equal(e.uncovered, 0);
    free(il.data);
    hz_float_buf_free(&buf);
    hz_heightmap_destroy(&hm);
}

/* Two big triangles over a flat map with one raised sample that is not a
 * vertex: that sample's error is the bump, projected at its distance. */
static void test_raised_sample_error_is_exact(void **state)
{
    (void)state;
    const uint32_t n = 33, bx = 10, bz = 12;
    const float bump = 8.0f, sp = 5.0f;
    hz_heightmap hm;
    flat_with_bump(&hm, n, bx, bz, bump);
    /* One flat quad over [8, 24] x [8, 24] containing the bump (corner (0,0),
     * set low for the quantisation range, stays outside). */
    uint32_t a = 8 * n + 8, b = 24 * n + 8, c = 8 * n + 24, d = 24 * n + 24;
    uint32_t idx[6] = {a, b, c, c, b, d};
    hz_camera cam = {.pos = {80, 300, 400}, .yaw = 0, .pitch = -45, .fov_y = 60, .aspect = 1.0f, .znear = 1, .zfar = 5000};
    hz_float_buf buf = {0};
    hz_px_error e;
    assert_int_equal(hz_metrics_px_error(&hm, sp, 1, idx, 6, &cam, 1000, &buf, &e), HZ_OK);
    float true_h = hz_heightmap_get(&hm, bx, bz), flat = hz_heightmap_get(&hm, 9, 9);
    double dh = true_h - flat;
    assert_true(fabs(dh - bump) < 0.01);
    double dx = (double)bx * sp - 80, dy = true_h - 300, dz = (double)bz * sp - 400;
    double expect = dh * 1000.0 / (2.0 * sqrt(dx * dx + dy * dy + dz * dz) * tan(glm_rad(30.0f)));
    assert_true(fabs(e.max_px - expect) < 1e-3 * expect);
    assert_true(fabs(e.max_m - dh) < 1e-4);
    assert_int_equal(e.samples, 17 * 17);
    /* The rest of the map is in the frustum but has no triangle. */
    assert_true(e.uncovered > 0);
    hz_float_buf_free(&buf);
    hz_heightmap_destroy(&hm);
}

static int cmp_d(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Rough terrain under two big triangles, all samples in view: the reported
 * 99th percentile and max are those of the per-sample errors computed here by
 * hand and sorted (the metric selects instead of sorting). The surface map
 * and the change between two surfaces are checked on the same data. */
static void test_percentile_and_surface(void **state)
{
    (void)state;
    const uint32_t n = 129;
    const float sp = 4.0f;
    hz_grid g;
    assert_int_equal(hz_grid_alloc(&g, n, n, NULL), HZ_OK);
    uint64_t x = 88172645463325252ULL;
    for (size_t k = 0; k < (size_t)n * n; k++) {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        g.z[k] = (float)(x % 1000) * 0.05f;
    }
    hz_heightmap hm;
    assert_int_equal(hz_heightmap_create(&hm, &g, HZ_LAYOUT_LINEAR, NULL), HZ_OK);
    hz_grid_free(&g);
    const uint32_t a = 0, b = (n - 1) * n, c = n - 1, d = n * n - 1;
    uint32_t idx[6] = {a, b, c, c, b, d};
    hz_camera cam = {.pos = {256, 900, 256}, .pitch = -89.9f, .fov_y = 90, .aspect = 1.0f, .znear = 1, .zfar = 5000};
    hz_float_buf buf = {0};
    hz_px_error e;
    assert_int_equal(hz_metrics_px_error(&hm, sp, 1, idx, 6, &cam, 800, &buf, &e), HZ_OK);
    assert_int_equal(e.samples, (size_t)n * n);
    /* By hand: the planes through the triangles' corners. */
    double *err = malloc((size_t)n * n * sizeof *err);
    const double k = 800.0 / (2.0 * tan(glm_rad(45.0f)));
    const double ha = hz_heightmap_get(&hm, 0, 0), hb = hz_heightmap_get(&hm, 0, n - 1),
                 hc = hz_heightmap_get(&hm, n - 1, 0), hd = hz_heightmap_get(&hm, n - 1, n - 1);
    float *surf = malloc((size_t)n * n * sizeof *surf);
    assert_int_equal(hz_metrics_surface(&hm, 1.0f, idx, 6, NULL, NULL, surf), HZ_OK);
    for (uint32_t j = 0; j < n; j++)
        for (uint32_t i = 0; i < n; i++) {
            const double u = (double)i / (n - 1), v = (double)j / (n - 1);
            const double lod = u + v <= 1.0 ? ha + u * (hc - ha) + v * (hb - ha)
                                            : hd + (1 - u) * (hb - hd) + (1 - v) * (hc - hd);
            assert_true(fabs(surf[(size_t)j * n + i] - lod) < 1e-3);
            const double h = hz_heightmap_get(&hm, i, j);
            const double dx = (double)i * sp - 256.0, dy = h - 900.0, dz = (double)j * sp - 256.0;
            err[(size_t)j * n + i] = fabs(lod - h) * k / sqrt(dx * dx + dy * dy + dz * dz);
        }
    qsort(err, (size_t)n * n, sizeof *err, cmp_d);
    const double p99 = err[(size_t)floor(0.99 * (double)((size_t)n * n - 1))];
    assert_true(fabs(e.p99_px - p99) < 1e-4 * p99);
    assert_true(fabs(e.max_px - err[(size_t)n * n - 1]) < 1e-4 * e.max_px);
    /* Raising the whole surface by 2 m moves every sample by 2 m. */
    float *surf2 = malloc((size_t)n * n * sizeof *surf2);
    for (size_t q = 0; q < (size_t)n * n; q++)
        surf2[q] = surf[q] + 2.0f;
    hz_pop_stats ps;
    hz_metrics_surface_change(&hm, sp, 1.0f, surf, surf2, &cam, 800, &ps);
    assert_int_equal(ps.samples, (size_t)n * n);
    const double nearest = 2.0 * k / (900.0 - 50.0); /* no sample is closer than ~850 m */
    assert_true(ps.max_px > 0.9 * 2.0 * k / 950.0 && ps.max_px < nearest);
    assert_true(ps.mean_px > 0 && ps.mean_px <= ps.max_px);
    free(surf);
    free(surf2);
    free(err);
    hz_float_buf_free(&buf);
    hz_heightmap_destroy(&hm);
}

static void test_image_metrics(void **state)
{
    (void)state;
    uint8_t a[12] = {10, 20, 30, 40, 50, 60, 70, 80, 90, 100, 110, 120}, b[12];
    memcpy(b, a, sizeof a);
    assert_true(isinf(hz_metrics_psnr(a, b, 4)));
    b[0] += 3; /* mse = 9/12 */
    assert_true(fabs(hz_metrics_psnr(a, b, 4) - 10 * log10(255.0 * 255.0 / 0.75)) < 1e-9);
    /* LOD changes by +5 on one value, reference by +2: popping = 3 / 12. */
    uint8_t a1[12], r1[12];
    memcpy(a1, a, 12);
    memcpy(r1, a, 12);
    a1[5] += 5;
    r1[5] += 2;
    assert_true(fabs(hz_metrics_popping(a, a1, a, r1, 4) - 3.0 / 12.0) < 1e-12);
    uint8_t s1[4] = {1, 1, 0, 0}, s2[4] = {1, 0, 0, 1};
    assert_true(fabs(hz_metrics_silhouette(s1, s2, 4) - 0.5) < 1e-12);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_full_mesh_has_zero_error),
        cmocka_unit_test(test_raised_sample_error_is_exact),
        cmocka_unit_test(test_percentile_and_surface),
        cmocka_unit_test(test_image_metrics),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
