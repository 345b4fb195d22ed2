/* Camera conventions: yaw 0 -> -z, yaw 90 -> +x, pitch > 0 up; view and
 * projection agree with the geometric frustum planes. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>

#include "horizon/camera.h"

static void near_vec(const float *a, float x, float y, float z)
{
    assert_true(fabsf(a[0] - x) < 1e-5f && fabsf(a[1] - y) < 1e-5f && fabsf(a[2] - z) < 1e-5f);
}

static void test_directions(void **state)
{
    (void)state;
    vec3 f;
    hz_camera c = {0};
    hz_camera_forward(&c, f);
    near_vec(f, 0, 0, -1);
    c.yaw = 90;
    hz_camera_forward(&c, f);
    near_vec(f, 1, 0, 0);
    c.yaw = 180;
    hz_camera_forward(&c, f);
    near_vec(f, 0, 0, 1);
    c.yaw = 0;
    c.pitch = 90; /* clamped to 89.9 */
    hz_camera_forward(&c, f);
    assert_true(f[1] > 0.9999f);
    c.pitch = -30;
    hz_camera_forward(&c, f);
    near_vec(f, 0, -0.5f, -sqrtf(3) / 2);
}

static void test_view_maps_eye_and_forward(void **state)
{
    (void)state;
    hz_camera c = {.pos = {100, 50, -20}, .yaw = 37, .pitch = -12};
    mat4 v;
    hz_camera_view(&c, v);
    vec4 eye = {100, 50, -20, 1}, out;
    glm_mat4_mulv(v, eye, out);
    near_vec(out, 0, 0, 0);
    vec3 f;
    hz_camera_forward(&c, f);
    vec4 ahead = {100 + 10 * f[0], 50 + 10 * f[1], -20 + 10 * f[2], 1};
    glm_mat4_mulv(v, ahead, out);
    assert_true(fabsf(out[0]) < 1e-4f && fabsf(out[1]) < 1e-4f && fabsf(out[2] + 10) < 1e-4f);
}

/* Points just inside / outside each side of the frustum, classified by the
 * planes and by clip space, must agree. */
/* Issue 15: a straight-down view far from the origin (pitch -90 / -89.9 at
 * 40 km, 50 km) is a proper rotation that maps the point below the eye to the
 * screen centre and the yaw's right to screen +x; glm_look lost the horizontal
 * part of the view direction there (a float's step at 50 km is 4 mm) and gave
 * a degenerate matrix. */
static void test_view_straight_down_far_from_origin(void **state)
{
    (void)state;
    const float pitches[] = {-90.0f, -89.9f, -89.95f, 90.0f};
    for (int k = 0; k < 4; k++) {
        hz_camera c = {.pos = {40000.0f, 5000.0f, 50000.0f}, .yaw = 30.0f, .pitch = pitches[k]};
        mat4 v;
        hz_camera_view(&c, v);
        /* Rows of the rotation are orthonormal. */
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++) {
                float d = v[0][a] * v[0][b] + v[1][a] * v[1][b] + v[2][a] * v[2][b];
                assert_true(fabsf(d - (a == b ? 1.0f : 0.0f)) < 1e-5f);
            }
        const float dy = pitches[k] < 0 ? -1000.0f : 1000.0f;
        vec4 below = {40000.0f, 5000.0f + dy, 50000.0f, 1.0f}, e;
        glm_mat4_mulv(v, below, e);
        assert_true(fabsf(e[0]) < 0.01f * 1000.0f && fabsf(e[1]) < 0.01f * 1000.0f);
        assert_true(e[2] < -999.0f); /* in front */
        /* The yaw's right (cos yaw, 0, sin yaw) is screen +x. */
        vec4 right = {40000.0f + 100.0f * cosf(glm_rad(30.0f)), 5000.0f + dy, 50000.0f + 100.0f * sinf(glm_rad(30.0f)),
                      1.0f};
        glm_mat4_mulv(v, right, e);
        assert_true(e[0] > 99.0f);
    }
}

static void test_planes_match_projection(void **state)
{
    (void)state;
    hz_camera c = {.pos = {10, 20, 30}, .yaw = 200, .pitch = 15, .fov_y = 50, .aspect = 1.5f, .znear = 0.5f, .zfar = 900};
    vec4 pl[6];
    hz_camera_frustum(&c, pl);
    mat4 vp;
    hz_camera_viewproj(&c, vp);
    unsigned seed = 1;
    int inside = 0, outside = 0;
    for (int k = 0; k < 20000; k++) {
        seed = seed * 1103515245u + 12345u;
        float a = (float)(seed >> 8) / 16777216.0f;
        seed = seed * 1103515245u + 12345u;
        float b = (float)(seed >> 8) / 16777216.0f;
        seed = seed * 1103515245u + 12345u;
        float d = (float)(seed >> 8) / 16777216.0f;
        vec4 p = {10 + (a - 0.5f) * 1200, 20 + (b - 0.5f) * 1200, 30 + (d - 0.5f) * 1200, 1}, q;
        glm_mat4_mulv(vp, p, q);
        float m = 1e-3f * q[3];
        int clip_in = q[0] >= -q[3] + m && q[0] <= q[3] - m && q[1] >= -q[3] + m && q[1] <= q[3] - m &&
                      q[2] >= -q[3] + m && q[2] <= q[3] - m;
        int clip_out = q[0] < -q[3] - m || q[0] > q[3] + m || q[1] < -q[3] - m || q[1] > q[3] + m ||
                       q[2] < -q[3] - m || q[2] > q[3] + m;
        int plane_in = 1;
        for (int i = 0; i < 6; i++)
            plane_in &= pl[i][0] * p[0] + pl[i][1] * p[1] + pl[i][2] * p[2] + pl[i][3] >= 0;
        if (clip_in) {
            assert_true(plane_in);
            inside++;
        }
        if (clip_out) {
            assert_false(plane_in);
            outside++;
        }
    }
    assert_true(inside > 100 && outside > 100);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_directions),
        cmocka_unit_test(test_view_maps_eye_and_forward),
        cmocka_unit_test(test_view_straight_down_far_from_origin),
        cmocka_unit_test(test_planes_match_projection),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
