/* Earth curvature (issue 15): the drop formula, the lowered boxes, the radius
 * --curvature picks, frustum culling of the curved terrain in every LOD mode
 * that lists its culled nodes (none culled whose curved surface is in view,
 * checked point by point; some culled that a flat world would keep), and
 * picking on the curved surface against a brute-force ray march. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "horizon/metrics.h"
#include "horizon/pick.h"
#include "horizon/terrain.h"

static void test_drop_formula(void **state)
{
    (void)state;
    const float R = (float)HZ_EARTH_RADIUS;
    /* 1 km: 7.85 cm; d^2 / 2R exactly. */
    assert_true(fabsf(hz_curvature_drop(R, 1000.0f, 0.0f) - 1e6f / (2.0f * R)) < 1e-6f);
    assert_true(fabsf(hz_curvature_drop(R, 600.0f, 800.0f) - hz_curvature_drop(R, 0.0f, 1000.0f)) < 1e-6f);
    /* Half of a 368 km span, 184 km: 2.66 km (the "2.7 km at the edge"). */
    const float edge = hz_curvature_drop(R, 184000.0f, 0.0f);
    printf("drop at 184 km: %.1f m\n", (double)edge);
    assert_true(fabsf(edge - 2657.0f) < 2.0f);
    /* The parabola against the sphere's true sagitta R - sqrt(R^2 - d^2):
     * within 0.2 % up to 500 km. */
    for (double d = 1000; d <= 500000; d *= 2) {
        const double sag = HZ_EARTH_RADIUS - sqrt(HZ_EARTH_RADIUS * HZ_EARTH_RADIUS - d * d);
        const double p = hz_curvature_drop(R, (float)d, 0.0f);
        assert_true(fabs(p - sag) <= 2e-3 * sag);
    }
    /* Flat: nothing; a mirrored camera's negative radius: raised. */
    assert_true(hz_curvature_drop(0.0f, 1e5f, 1e5f) == 0.0f);
    assert_true(hz_curvature_drop(-R, 1000.0f, 0.0f) < 0.0f);
    hz_camera cam = {.pos = {1000, 50, -2000}, .earth_radius = R};
    assert_true(fabsf(hz_camera_drop(&cam, 1000 + 3000, -2000 + 4000) - hz_curvature_drop(R, 3000, 4000)) < 1e-6f);
    hz_camera m;
    hz_camera_mirror_y(&cam, 10.0f, &m);
    assert_true(m.earth_radius == -R);
}

/* The lowered box holds the curved image of every point of the box, and is
 * tight (its bounds are reached by the extreme corners' images). */
static void test_curve_box(void **state)
{
    (void)state;
    uint64_t seed = 99;
    for (int k = 0; k < 300; k++) {
        float r[8];
        for (int c = 0; c < 8; c++) {
            seed = seed * 6364136223846793005ull + 1442695040888963407ull;
            r[c] = (float)(seed >> 40) / (float)(1u << 24);
        }
        const float R = (k & 1 ? 1.0f : -1.0f) * (float)HZ_EARTH_RADIUS * (0.2f + r[7]);
        hz_camera cam = {.pos = {r[0] * 2e5f, 0, r[1] * 2e5f}, .earth_radius = R};
        float box[2][3] = {{r[2] * 2e5f, 100 + r[6] * 500, r[3] * 2e5f}, {0, 2500, 0}};
        box[1][0] = box[0][0] + 1.0f + r[4] * 5e4f;
        box[1][2] = box[0][2] + 1.0f + r[5] * 5e4f;
        float cb[2][3];
        memcpy(cb, box, sizeof cb);
        hz_camera_curve_box(&cam, cb);
        assert_true(cb[0][0] == box[0][0] && cb[1][2] == box[1][2]);
        float lo = INFINITY, hi = -INFINITY;
        for (int i = 0; i <= 16; i++)
            for (int j = 0; j <= 16; j++)
                for (int y = 0; y <= 1; y++) {
                    const float x = box[0][0] + (box[1][0] - box[0][0]) * (float)i / 16.0f;
                    const float z = box[0][2] + (box[1][2] - box[0][2]) * (float)j / 16.0f;
                    const float py = box[y][1] - hz_camera_drop(&cam, x, z);
                    const float tol = 1e-5f * fabsf(py) + 1e-3f;
                    assert_true(py >= cb[0][1] - tol && py <= cb[1][1] + tol);
                    lo = fminf(lo, py);
                    hi = fmaxf(hi, py);
                }
        /* Tight: the grid holds the farthest corner exactly, and the
         * nearest point within a grid step (R < 0: the roles swap). */
        const float step = fmaxf(box[1][0] - box[0][0], box[1][2] - box[0][2]) / 16.0f;
        const float slack = hz_curvature_drop(fabsf(R), 3e5f + step, 0) - hz_curvature_drop(fabsf(R), 3e5f, 0) + 1e-2f;
        const float far_err = R > 0 ? fabsf(lo - cb[0][1]) : fabsf(hi - cb[1][1]);
        const float near_err = R > 0 ? fabsf(hi - cb[1][1]) : fabsf(lo - cb[0][1]);
        assert_true(far_err < 1e-3f + 1e-5f * fabsf(lo));
        assert_true(near_err <= slack);
    }
    /* Flat: unchanged. */
    hz_camera flat = {.pos = {0, 0, 0}};
    float b[2][3] = {{1e5f, 0, 1e5f}, {2e5f, 100, 2e5f}};
    hz_camera_curve_box(&flat, b);
    assert_true(b[0][1] == 0 && b[1][1] == 100);
}

static void test_radius_auto(void **state)
{
    (void)state;
    const float R = (float)HZ_EARTH_RADIUS;
    assert_true(hz_curvature_radius(HZ_CURVATURE_AUTO, 49999.0f, 0) == 0.0f);
    assert_true(hz_curvature_radius(HZ_CURVATURE_AUTO, HZ_CURVATURE_AUTO_EXTENT, 0) == 0.0f);
    assert_true(hz_curvature_radius(HZ_CURVATURE_AUTO, 50001.0f, 0) == R);
    assert_true(hz_curvature_radius(HZ_CURVATURE_AUTO, 368000.0f, 6372000.0f) == 6372000.0f);
    assert_true(hz_curvature_radius(HZ_CURVATURE_ON, 100.0f, 0) == R);
    assert_true(hz_curvature_radius(HZ_CURVATURE_OFF, 1e6f, 0) == 0.0f);
    /* WGS84 Gaussian radius sqrt(M N): b at the equator, a^2 / b at the poles. */
    assert_true(fabs(hz_wgs84_radius(0) - 6356752.3) < 1.0);
    assert_true(fabs(hz_wgs84_radius(90) - 6399593.6) < 1.0);
    assert_true(fabs(hz_wgs84_radius(-37.5) - hz_wgs84_radius(37.5)) < 1e-6);
    assert_true(hz_wgs84_radius(37.5) > 6.37e6 && hz_wgs84_radius(37.5) < 6.375e6);
}

/* ---- culling ------------------------------------------------------------- */

static hz_terrain *wide_terrain(void)
{
    hz_err err = {0};
    /* 513 samples, 400 m apart: 205 km, relief 600 m. */
    hz_terrain *t = hz_terrain_create(&(hz_terrain_desc){.generate = HZ_GEN_PERLIN, .gen_size = 513, .seed = 3,
                                                         .amplitude = 600, .spacing = 400},
                                      &err);
    if (!t)
        fail_msg("%s", err.msg);
    return t;
}

/* Signed distance of p inside the frustum (the smallest over the planes). */
static float inside_by(const vec4 planes[6], const float p[3])
{
    float m = INFINITY;
    for (int k = 0; k < 6; k++)
        m = fminf(m, planes[k][0] * p[0] + planes[k][1] * p[1] + planes[k][2] * p[2] + planes[k][3]);
    return m;
}

static bool box_out(const vec4 planes[6], const float box[2][3])
{
    for (int k = 0; k < 6; k++) {
        const float *pl = planes[k];
        float d = pl[3];
        for (int a = 0; a < 3; a++)
            d += pl[a] * box[pl[a] > 0][a];
        if (d < 0)
            return true;
    }
    return false;
}

/* The cameras: one whose view the far hills sink into, a jet at 10 km
 * looking a degree down (the near ground below the view, more of it with
 * curvature), a low one looking at the horizon with a telephoto (the far
 * terrain sinks below the view: beyond the horizon), and one looking down
 * over the middle. */
static hz_camera cull_camera(const hz_terrain *t, int k)
{
    const float e = hz_terrain_extent(t);
    hz_camera c = {.fov_y = 10, .aspect = 16.0f / 9.0f, .znear = 1, .zfar = 400000, .earth_radius = 6371008.8f};
    if (k == 0) {
        /* Low, a telephoto a degree down: the far hills, above the view on a
         * flat world, sink into it (boxes that were not lowered would cull them). */
        c.pos[0] = 1000, c.pos[1] = 100, c.pos[2] = 0.5f * e, c.yaw = 90, c.pitch = -1, c.fov_y = 2;
    } else if (k == 1) {
        c.pos[0] = 1000, c.pos[1] = 10000, c.pos[2] = 0.5f * e, c.yaw = 90, c.pitch = -1;
    } else if (k == 2) {
        c.pos[0] = 1000, c.pos[1] = 1200, c.pos[2] = 0.5f * e, c.yaw = 90, c.pitch = 1.5f, c.fov_y = 4;
    } else {
        c.pos[0] = 0.5f * e, c.pos[1] = 3000, c.pos[2] = 0.2f * e, c.yaw = 180, c.pitch = -12, c.fov_y = 60;
    }
    return c;
}

static void check_culled(const hz_terrain *t, const hz_camera *cam, const hz_node_list *culled, uint32_t *flat_kept)
{
    vec4 planes[6];
    hz_camera_frustum(cam, planes);
    vec4 flat_planes[6];
    hz_camera flat = *cam;
    flat.earth_radius = 0;
    hz_camera_frustum(&flat, flat_planes);
    const hz_heightmap *hm = &t->hm;
    for (size_t n = 0; n < culled->count; n++) {
        const hz_lod_node *nd = &culled->data[n];
        const uint32_t s = nd->half, step = s > 16 ? s / 16 : 1;
        for (uint32_t z = nd->z - s; z <= nd->z + s; z += step)
            for (uint32_t x = nd->x - s; x <= nd->x + s; x += step) {
                const float p[3] = {(float)x * t->spacing, 0, (float)z * t->spacing};
                const float drawn[3] = {p[0], hz_heightmap_get(hm, x, z) * t->zscale - hz_camera_drop(cam, p[0], p[2]),
                                        p[2]};
                if (inside_by((const vec4 *)planes, drawn) > 1.0f)
                    fail_msg("node (%u, %u, half %u) culled, but its sample (%u, %u) is drawn %.1f m inside the "
                             "frustum", nd->x, nd->z, nd->half, x, z, (double)inside_by((const vec4 *)planes, drawn));
            }
        float box[2][3];
        assert_true(hz_lod_node_box(t->lod, nd->x, nd->z, nd->half, box));
        *flat_kept += !box_out((const vec4 *)flat_planes, box);
    }
}

static void test_cull_curved(void **state)
{
    (void)state;
    hz_terrain *t = wide_terrain();
    static const hz_lod_mode modes[] = {HZ_LOD_QUADTREE, HZ_LOD_REMEDY, HZ_LOD_BIDIRECTIONAL, HZ_LOD_CDLOD};
    hz_index_list out = {0};
    hz_node_list culled = {0};
    uint32_t flat_kept_total = 0;
    for (size_t m = 0; m < sizeof modes / sizeof *modes; m++) {
        assert_int_equal(hz_lod_prepare(t->lod, modes[m]), HZ_OK);
        for (int k = 0; k < 4; k++) {
            hz_camera cam = cull_camera(t, k);
            hz_lod_params p = {.mode = modes[m], .pixel_error = 2, .viewport_height = 720};
            hz_lod_stats st;
            assert_int_equal(hz_lod_select(t->lod, &cam, &p, &out, NULL, &culled, &st), HZ_OK);
            uint32_t flat_kept = 0;
            check_culled(t, &cam, &culled, &flat_kept);
            printf("%s camera %d: %zu culled, %u of them kept by flat culling, %u triangles\n",
                   hz_lod_mode_name(modes[m]), k, culled.count, flat_kept, st.triangles);
            flat_kept_total += flat_kept;
            if (k == 1 || k == 2)
                assert_true(flat_kept > 0); /* the curvature culls what a flat world would draw */
        }
    }
    assert_true(flat_kept_total > 0);
    free(out.data);
    free(culled.data);
    hz_terrain_destroy(t);
}

/* The metrics count the samples in view where they are drawn: with the
 * curved selection, every sample in the curved view is covered (a flat
 * frustum test would count the near ground the curvature took out of view
 * as uncovered), and the far ground the curvature sank is not counted. */
static void test_metrics_curved(void **state)
{
    (void)state;
    hz_terrain *t = wide_terrain();
    hz_index_list out = {0};
    hz_float_buf buf = {0};
    for (int k = 1; k <= 2; k++) {
        hz_camera cam = cull_camera(t, k);
        hz_lod_params p = {.mode = HZ_LOD_QUADTREE, .pixel_error = 2, .viewport_height = 720};
        assert_int_equal(hz_lod_select(t->lod, &cam, &p, &out, NULL, NULL, NULL), HZ_OK);
        hz_px_error e, flat_e;
        assert_int_equal(hz_metrics_px_error(&t->hm, t->spacing, t->zscale, out.data, out.count, &cam, 720, &buf, &e),
                         HZ_OK);
        hz_camera flat = cam;
        flat.earth_radius = 0;
        assert_int_equal(
            hz_metrics_px_error(&t->hm, t->spacing, t->zscale, out.data, out.count, &flat, 720, &buf, &flat_e),
            HZ_OK);
        printf("camera %d: curved metrics %llu samples, %llu uncovered; flat frustum: %llu samples, %llu uncovered\n",
               k, (unsigned long long)e.samples, (unsigned long long)e.uncovered,
               (unsigned long long)flat_e.samples, (unsigned long long)flat_e.uncovered);
        assert_true(e.uncovered == 0);
        assert_true(flat_e.uncovered > 0);
    }
    free(out.data);
    hz_float_buf_free(&buf);
    hz_terrain_destroy(t);
}

/* ---- picking ------------------------------------------------------------- */

/* Brute force: the first point along the ray, 1 m steps, below the curved
 * surface. */
static bool march(const hz_terrain *t, const hz_camera *cam, const float o[3], const float d[3], float t_max,
                  float *hit)
{
    const float e = hz_terrain_extent(t);
    for (float s = 0; s < t_max; s += 1.0f) {
        const float x = o[0] + s * d[0], z = o[2] + s * d[2];
        if (x < 0 || z < 0 || x > e || z > e)
            continue;
        if (o[1] + s * d[1] <= hz_terrain_surface_at(t, x, z) - hz_camera_drop(cam, x, z)) {
            *hit = s;
            return true;
        }
    }
    return false;
}

static void test_pick_curved(void **state)
{
    (void)state;
    hz_terrain *t = wide_terrain();
    const float e = hz_terrain_extent(t);
    hz_camera cam = {.pos = {0.5f * e, 2500, 0.95f * e}, .yaw = 0, .pitch = -2, .fov_y = 40, .aspect = 16.0f / 9.0f,
                     .znear = 1, .zfar = 400000, .earth_radius = 6371008.8f};
    int hits = 0, differ = 0;
    for (int py = 380; py < 720; py += 40)
        for (int px = 40; px < 1280; px += 300) {
            hz_pick_result r = hz_pick(t, NULL, &cam, (float)px, (float)py, 1280, 720);
            float o[3], d[3], s;
            hz_camera_pixel_ray(&cam, (float)px, (float)py, 1280, 720, o, d);
            const bool b = march(t, &cam, o, d, 1.5f * cam.zfar, &s);
            assert_int_equal(r.hit, b);
            if (!b)
                continue;
            hits++;
            /* The same point: within the march's 1 m step (plus float rounding at ~100 km). */
            if (fabsf(r.distance - s) > 1.0f + 2e-5f * s)
                fail_msg("pixel %d,%d: picked at %.2f m, the march hits at %.2f m", px, py, (double)r.distance,
                         (double)s);
            /* pos is on the map (the height there), drawn drop metres below. */
            const float hx = o[0] + r.distance * d[0], hz = o[2] + r.distance * d[2];
            assert_true(fabsf(r.pos[1] - hz_terrain_surface_at(t, hx, hz)) < 0.5f);
            assert_true(fabsf(r.drop - hz_camera_drop(&cam, hx, hz)) < 1e-3f * r.drop + 1e-3f);
            /* A flat pick of the same pixel lands elsewhere (far pixels): the test sees curvature. */
            hz_camera flat = cam;
            flat.earth_radius = 0;
            hz_pick_result f = hz_pick(t, NULL, &flat, (float)px, (float)py, 1280, 720);
            differ += !f.hit || fabsf(f.distance - r.distance) > 100.0f;
        }
    printf("%d curved picks agree with the march; %d differ from a flat pick by > 100 m\n", hits, differ);
    assert_true(hits >= 20);
    assert_true(differ >= 5);
    hz_terrain_destroy(t);
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_drop_formula), cmocka_unit_test(test_curve_box),
                                       cmocka_unit_test(test_radius_auto), cmocka_unit_test(test_cull_curved),
                                       cmocka_unit_test(test_metrics_curved),
                                       cmocka_unit_test(test_pick_curved)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
