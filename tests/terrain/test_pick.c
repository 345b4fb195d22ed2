/* Picking: a pixel's ray meets the terrain exactly on its full-resolution
 * surface (the hit is on it, the ray above it before), the camera's centre
 * pixel looks along its forward axis, and a box standing in front of the
 * ground is picked instead of the ground behind it. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>

#include "horizon/pick.h"

static hz_terrain *terrain(void)
{
    hz_err err = {0};
    hz_terrain *t = hz_terrain_create(&(hz_terrain_desc){.generate = HZ_GEN_PERLIN, .gen_size = 129, .seed = 5,
                                                         .amplitude = 300},
                                      &err);
    if (!t)
        fail_msg("%s", err.msg);
    return t;
}

static void test_terrain_ray(void **state)
{
    (void)state;
    hz_terrain *t = terrain();
    const float e = hz_terrain_extent(t);
    uint64_t seed = 12345;
    int hits = 0;
    for (int k = 0; k < 200; k++) {
        seed = seed * 6364136223846793005ull + 1442695040888963407ull;
        float u = (float)(seed >> 40) / (float)(1u << 24);
        seed = seed * 6364136223846793005ull + 1442695040888963407ull;
        float v = (float)(seed >> 40) / (float)(1u << 24);
        float o[3] = {u * e, 900, v * e};
        float d[3] = {cosf(6.28f * u) * 0.5f, -0.6f - 0.6f * v, sinf(6.28f * v) * 0.5f};
        float l = sqrtf(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        for (int c = 0; c < 3; c++)
            d[c] /= l;
        float th;
        if (!hz_terrain_raycast(t, o, d, 1e5f, &th))
            continue;
        hits++;
        float p[3] = {o[0] + th * d[0], o[1] + th * d[1], o[2] + th * d[2]};
        float s = hz_terrain_surface_at(t, p[0], p[2]);
        if (fabsf(p[1] - s) > 1e-2f)
            fail_msg("hit %g m off the surface", (double)(p[1] - s));
        /* Above the surface all the way to the hit (sampled every 0.5 m). */
        for (float q = 0; q < th - 0.05f; q += 0.5f)
            assert_true(o[1] + q * d[1] >= hz_terrain_surface_at(t, o[0] + q * d[0], o[2] + q * d[2]) - 1e-3f);
    }
    assert_true(hits > 150);
    /* Straight down onto a sample: its height. */
    float o[3] = {50 * t->spacing, 2000, 60 * t->spacing}, d[3] = {0, -1, 0}, th;
    assert_true(hz_terrain_raycast(t, o, d, 1e5f, &th));
    assert_true(fabsf(2000 - th - hz_heightmap_get(&t->hm, 50, 60) * t->zscale) < 1e-2f);
    /* Pointing up, or starting outside the map and leaving: no hit. */
    d[1] = 1;
    assert_false(hz_terrain_raycast(t, o, d, 1e5f, &th));
    float o2[3] = {-100, 2000, -100}, d2[3] = {-0.7f, -0.1f, -0.7f};
    assert_false(hz_terrain_raycast(t, o2, d2, 1e5f, &th));
    hz_terrain_destroy(t);
}

static void test_pick_box(void **state)
{
    (void)state;
    hz_terrain *t = terrain();
    const float e = hz_terrain_extent(t);
    const float gx = 0.5f * e, gz = 0.5f * e, gy = hz_terrain_surface_at(t, gx, gz);
    hz_camera cam = {.pos = {gx, gy + 200, gz + 400}, .yaw = 0, .pitch = -26.57f, .fov_y = 60, .aspect = 16.0f / 9.0f,
                     .znear = 1, .zfar = 10000};
    /* The centre pixel's ray is the forward axis. */
    float ro[3], rd[3];
    hz_camera_pixel_ray(&cam, 640, 360, 1280, 720, ro, rd);
    vec3 f;
    hz_camera_forward(&cam, f);
    assert_true(fabsf(rd[0] - f[0]) < 1e-4f && fabsf(rd[1] - f[1]) < 1e-4f && fabsf(rd[2] - f[2]) < 1e-4f);
    hz_pick_result r = hz_pick(t, NULL, &cam, 640, 360, 1280, 720);
    assert_true(r.hit && r.terrain);
    /* A 40 m box on the line of sight, halfway: picked, with its node. */
    hz_scene *s = hz_scene_create(NULL);
    hz_vertex v[8];
    for (int k = 0; k < 8; k++)
        v[k] = (hz_vertex){{k & 1 ? 20.0f : -20.0f, k & 2 ? 40.0f : 0.0f, k & 4 ? 20.0f : -20.0f}, {0, 1, 0}};
    static const uint32_t ix[36] = {0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4,
                                    2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5};
    uint32_t m = hz_scene_add_mesh(s, v, 8, ix, 36, NULL);
    uint32_t n = hz_scene_add_node(s, 0, "tower");
    hz_scene_set_mesh(s, n, m, 0);
    const float bx = gx, bz = gz + 0.5f * r.distance * -f[2];
    /* Stand it so the ray's midpoint is inside its height. */
    float mid_y = cam.pos[1] + 0.5f * r.distance * f[1];
    hz_scene_set_translation(s, n, (float[3]){bx, mid_y - 20, bz});
    hz_scene_update(s);
    hz_pick_result r2 = hz_pick(t, s, &cam, 640, 360, 1280, 720);
    assert_true(r2.hit && !r2.terrain);
    assert_int_equal(r2.node, n);
    assert_true(r2.distance < r.distance);
    assert_true(fabsf(r2.pos[2] - (bz + 20)) < 1e-2f); /* its near (south) face */
    hz_scene_destroy(s);
    hz_terrain_destroy(t);
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_terrain_ray), cmocka_unit_test(test_pick_box)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
