/* The interactive cameras' maths, without a window: movement directions for
 * both modes, speed modifiers, pitch clamp, view matrix, and the walk-mode /
 * clearance ground clamp on sloped terrain. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>

#include "horizon/flycam.h"

#define NEAR(a, b, eps) assert_true(fabsf((float)(a) - (float)(b)) < (eps))

/* A plane rising 0.3 m per metre toward +x and falling 0.2 toward +z, with
 * ripples: slopes in every direction. */
static float sloped(void *user, float x, float z)
{
    (void)user;
    return 100.0f + 0.3f * x - 0.2f * z + 15.0f * sinf(x * 0.01f) * cosf(z * 0.013f);
}

static hz_flycam make(hz_flycam_mode mode, float yaw, float pitch, hz_height_fn h)
{
    hz_flycam fc;
    hz_flycam_init(&fc, &(hz_flycam_desc){.start = {.pos = {0, 5000, 0}, .yaw = yaw, .pitch = pitch},
                                          .mode = mode, .speed = 10.0f, .height = h});
    return fc;
}

static void test_defaults(void **state)
{
    (void)state;
    hz_flycam_desc d = hz_flycam_desc_defaults(NULL);
    NEAR(d.speed, 50, 1e-6f);
    NEAR(d.fast_mul, 6, 1e-6f);
    NEAR(d.slow_mul, 0.15f, 1e-6f);
    NEAR(d.eye_height, 1.8f, 1e-6f);
    NEAR(d.clearance, 1, 1e-6f);
    NEAR(d.pitch_limit, 89, 1e-6f);
    assert_int_equal(d.mode, HZ_FLYCAM_VIEWER);
}

/* Yaw 90 looks toward +x: W moves toward +x by speed * dt. */
static void test_yaw90_w_moves_east(void **state)
{
    (void)state;
    for (int mode = 0; mode < 2; mode++) {
        hz_flycam fc = make((hz_flycam_mode)mode, 90, 0, NULL);
        hz_flycam_update(&fc, &(hz_flycam_input){.forward = 1}, 2.0f);
        NEAR(fc.cam.pos[0], 20, 1e-3f);
        NEAR(fc.cam.pos[1], 5000, 1e-3f);
        NEAR(fc.cam.pos[2], 0, 1e-3f);
    }
    /* Yaw 0 looks toward -z (north); D strafes toward +x (east), S back to +z. */
    hz_flycam fc = make(HZ_FLYCAM_VIEWER, 0, 0, NULL);
    hz_flycam_update(&fc, &(hz_flycam_input){.forward = 1}, 1.0f);
    NEAR(fc.cam.pos[2], -10, 1e-3f);
    hz_flycam_update(&fc, &(hz_flycam_input){.right = 1}, 1.0f);
    NEAR(fc.cam.pos[0], 10, 1e-3f);
    hz_flycam_update(&fc, &(hz_flycam_input){.forward = -1, .right = -1}, 1.0f);
    /* A diagonal is not faster than a straight move. */
    NEAR(fc.cam.pos[0], 10 - 10 / sqrtf(2), 1e-3f);
    NEAR(fc.cam.pos[2], -10 + 10 / sqrtf(2), 1e-3f);
}

/* Viewer: fixed up axis, W stays level even when looking down; E goes up +y.
 * Free: W follows the view (dives), E follows the camera's up. */
static void test_viewer_level_free_dives(void **state)
{
    (void)state;
    hz_flycam v = make(HZ_FLYCAM_VIEWER, 90, -45, NULL);
    hz_flycam_update(&v, &(hz_flycam_input){.forward = 1}, 1.0f);
    NEAR(v.cam.pos[0], 10, 1e-3f);
    NEAR(v.cam.pos[1], 5000, 1e-3f);
    hz_flycam_update(&v, &(hz_flycam_input){.up = 1}, 1.0f);
    NEAR(v.cam.pos[1], 5010, 1e-3f);
    NEAR(v.cam.pos[0], 10, 1e-3f);

    hz_flycam f = make(HZ_FLYCAM_FREE, 90, -45, NULL);
    hz_flycam_update(&f, &(hz_flycam_input){.forward = 1}, 1.0f);
    NEAR(f.cam.pos[0], 10 / sqrtf(2), 1e-3f);
    NEAR(f.cam.pos[1], 5000 - 10 / sqrtf(2), 1e-3f);
    vec3 fw, r, u;
    hz_flycam_basis(&f, fw, r, u);
    /* Camera up when looking 45 degrees down toward +x: (+x, +y)/sqrt 2. */
    NEAR(u[0], 1 / sqrtf(2), 1e-4f);
    NEAR(u[1], 1 / sqrtf(2), 1e-4f);
    NEAR(glm_vec3_dot(fw, u), 0, 1e-5f);
    NEAR(glm_vec3_dot(fw, r), 0, 1e-5f);
}

static void test_speed_modifiers_and_scroll(void **state)
{
    (void)state;
    hz_flycam fc = make(HZ_FLYCAM_VIEWER, 90, 0, NULL);
    hz_flycam_update(&fc, &(hz_flycam_input){.forward = 1, .fast = true}, 1.0f);
    NEAR(fc.cam.pos[0], 60, 1e-3f);
    hz_flycam_update(&fc, &(hz_flycam_input){.forward = 1, .slow = true}, 1.0f);
    NEAR(fc.cam.pos[0], 61.5f, 1e-3f);
    NEAR(hz_flycam_scroll_speed(&fc, 2), 15.625f, 1e-3f);
    NEAR(hz_flycam_scroll_speed(&fc, -2), 10, 1e-3f);
    NEAR(hz_flycam_scroll_speed(&fc, -1000), 0.1f, 1e-6f);
    NEAR(hz_flycam_scroll_speed(&fc, 1000), 100000, 1e-1f);
    NEAR(hz_flycam_scroll_speed(&fc, NAN), 100000, 1e-1f);
}

static void test_look_and_pitch_clamp(void **state)
{
    (void)state;
    hz_flycam fc = make(HZ_FLYCAM_VIEWER, 350, 0, NULL);
    hz_flycam_update(&fc, &(hz_flycam_input){.yaw_deg = 20, .pitch_deg = 500}, 0.0f);
    NEAR(fc.cam.yaw, 10, 1e-3f);
    NEAR(fc.cam.pitch, 89, 1e-4f);
    hz_flycam_update(&fc, &(hz_flycam_input){.yaw_deg = -30, .pitch_deg = -1000}, 0.0f);
    NEAR(fc.cam.yaw, 340, 1e-3f);
    NEAR(fc.cam.pitch, -89, 1e-4f);
    /* Look-only updates never move. */
    NEAR(fc.cam.pos[0], 0, 1e-6f);
    NEAR(fc.cam.pos[1], 5000, 1e-6f);
    /* Straight down still moves level in the viewer (forward from yaw). */
    hz_flycam_update(&fc, &(hz_flycam_input){.forward = 1}, 1.0f);
    NEAR(fc.cam.pos[1], 5000, 1e-3f);
    NEAR(hypotf(fc.cam.pos[0], fc.cam.pos[2]), 10, 1e-3f);
}

/* The view matrix maps the eye to the origin and a point ahead onto -z. */
static void test_view_matrix(void **state)
{
    (void)state;
    hz_flycam fc = make(HZ_FLYCAM_FREE, 0, 0, NULL);
    hz_flycam_update(&fc, &(hz_flycam_input){.yaw_deg = 123, .pitch_deg = -31, .forward = 1, .right = 0.5f}, 3.0f);
    mat4 v;
    hz_flycam_view(&fc, v);
    vec4 eye = {fc.cam.pos[0], fc.cam.pos[1], fc.cam.pos[2], 1}, out;
    glm_mat4_mulv(v, eye, out);
    NEAR(out[0], 0, 1e-2f);
    NEAR(out[1], 0, 1e-2f);
    NEAR(out[2], 0, 1e-2f);
    vec3 f, r, u;
    hz_flycam_basis(&fc, f, r, u);
    vec4 ahead = {eye[0] + 100 * f[0], eye[1] + 100 * f[1], eye[2] + 100 * f[2], 1};
    glm_mat4_mulv(v, ahead, out);
    NEAR(out[0], 0, 1e-2f);
    NEAR(out[1], 0, 1e-2f);
    NEAR(out[2], -100, 1e-2f);
    /* Right maps to +x, camera up to +y. */
    vec4 right = {eye[0] + 10 * r[0], eye[1] + 10 * r[1], eye[2] + 10 * r[2], 1};
    glm_mat4_mulv(v, right, out);
    NEAR(out[0], 10, 1e-2f);
    vec4 up = {eye[0] + 10 * u[0], eye[1] + 10 * u[1], eye[2] + 10 * u[2], 1};
    glm_mat4_mulv(v, up, out);
    NEAR(out[1], 10, 1e-2f);
}

/* Walk mode on a sloped, rippled terrain: after every step, in every
 * direction, uphill and down, fast and slow, the eye is exactly eye_height
 * above the ground, never below. Q/E change the eye height, not the ground
 * clamp. */
static void test_walk_mode_ground_clamp(void **state)
{
    (void)state;
    hz_flycam fc;
    hz_flycam_init(&fc, &(hz_flycam_desc){.start = {.pos = {500, 0, 500}, .yaw = 0}, .walk = true,
                                          .speed = 7.0f, .eye_height = 1.7f, .height = sloped});
    assert_true(fc.walk);
    NEAR(fc.cam.pos[1], sloped(NULL, 500, 500) + 1.7f, 1e-3f);
    uint32_t seed = 12345;
    for (int k = 0; k < 2000; k++) {
        seed = seed * 1664525u + 1013904223u;
        hz_flycam_input in = {.forward = (float)((seed >> 8) % 3) - 1.0f,
                              .right = (float)((seed >> 12) % 3) - 1.0f,
                              .yaw_deg = (float)((seed >> 16) % 41) - 20.0f,
                              .pitch_deg = (float)((seed >> 20) % 21) - 10.0f,
                              .fast = (seed >> 28) & 1, .slow = (seed >> 29) & 1};
        hz_flycam_update(&fc, &in, 0.1f);
        float g = sloped(NULL, fc.cam.pos[0], fc.cam.pos[2]);
        assert_true(fc.cam.pos[1] >= g + 1.7f - 1e-3f);
        NEAR(fc.cam.pos[1], g + 1.7f, 2e-3f);
        NEAR(hz_flycam_ground(&fc), g, 1e-4f);
    }
    /* E raises the eye height while walking. */
    hz_flycam_update(&fc, &(hz_flycam_input){.up = 1}, 0.1f);
    NEAR(fc.eye_height, 2.4f, 1e-3f);
    NEAR(fc.cam.pos[1], sloped(NULL, fc.cam.pos[0], fc.cam.pos[2]) + 2.4f, 2e-3f);
    /* Q never takes it below 0.1 m. */
    hz_flycam_update(&fc, &(hz_flycam_input){.up = -1}, 100.0f);
    NEAR(fc.eye_height, 0.1f, 1e-5f);
    assert_string_equal(hz_flycam_mode_name(&fc), "walk");
}

/* Not walking, the viewer may fly high but never below ground + clearance;
 * the free camera is not clamped; switching back to the viewer clamps. */
static void test_clearance_and_mode_switch(void **state)
{
    (void)state;
    hz_flycam fc;
    hz_flycam_init(&fc, &(hz_flycam_desc){.start = {.pos = {0, 400, 0}, .yaw = 90, .pitch = -60}, .speed = 50.0f,
                                          .height = sloped});
    assert_string_equal(hz_flycam_mode_name(&fc), "viewer");
    for (int k = 0; k < 200; k++) {
        hz_flycam_update(&fc, &(hz_flycam_input){.up = -1, .forward = 0.3f}, 0.5f);
        assert_true(fc.cam.pos[1] >= sloped(NULL, fc.cam.pos[0], fc.cam.pos[2]) + 1.0f - 1e-3f);
    }
    NEAR(fc.cam.pos[1], sloped(NULL, fc.cam.pos[0], fc.cam.pos[2]) + 1.0f, 1e-3f);

    float yaw = fc.cam.yaw, pitch = fc.cam.pitch;
    hz_flycam_set_mode(&fc, HZ_FLYCAM_FREE);
    assert_string_equal(hz_flycam_mode_name(&fc), "free");
    NEAR(fc.cam.yaw, yaw, 1e-6f);
    NEAR(fc.cam.pitch, pitch, 1e-6f);
    /* Free camera: dive below the ground. */
    hz_flycam_update(&fc, &(hz_flycam_input){.forward = 1}, 10.0f);
    assert_true(fc.cam.pos[1] < sloped(NULL, fc.cam.pos[0], fc.cam.pos[2]));
    /* Walk mode is a viewer thing. */
    hz_flycam_set_walk(&fc, true);
    assert_false(fc.walk);
    vec3 before;
    glm_vec3_copy(fc.cam.pos, before);
    hz_flycam_set_mode(&fc, HZ_FLYCAM_VIEWER);
    NEAR(fc.cam.pos[0], before[0], 1e-6f);
    NEAR(fc.cam.pos[2], before[2], 1e-6f);
    NEAR(fc.cam.pos[1], sloped(NULL, fc.cam.pos[0], fc.cam.pos[2]) + 1.0f, 1e-3f);
    hz_flycam_set_walk(&fc, true);
    NEAR(fc.cam.pos[1], sloped(NULL, fc.cam.pos[0], fc.cam.pos[2]) + 1.8f, 1e-3f);
    /* Without a height function nothing is clamped, and the ground is NAN. */
    hz_flycam nog = make(HZ_FLYCAM_VIEWER, 0, 0, NULL);
    hz_flycam_set_walk(&nog, true);
    hz_flycam_update(&nog, &(hz_flycam_input){.up = -1}, 1.0f);
    assert_true(isnan(hz_flycam_ground(&nog)));
    NEAR(nog.cam.pos[1], 5000, 1e-3f);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_defaults),
        cmocka_unit_test(test_yaw90_w_moves_east),
        cmocka_unit_test(test_viewer_level_free_dives),
        cmocka_unit_test(test_speed_modifiers_and_scroll),
        cmocka_unit_test(test_look_and_pitch_clamp),
        cmocka_unit_test(test_view_matrix),
        cmocka_unit_test(test_walk_mode_ground_clamp),
        cmocka_unit_test(test_clearance_and_mode_switch),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
