/* Issue 14, defect 5: inputs that reached undefined behaviour in the
 * effects' CPU code. In the sanitizer build (make test's second run) UBSan
 * aborts on the conversion itself, so these fail there if the clamps go;
 * here they check the results stay sane. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "horizon/fx.h"
#include "horizon/heightmap.h"

/* An eye at +-3e38 (a path CSV used to allow it): the cell range of the
 * billboard field overflowed int (billboard.c, float -> int). */
static void test_bb_field_far_eye(void **state)
{
    (void)state;
    hz_billboard b[64];
    for (int k = 0; k < 64; k++)
        b[k] = (hz_billboard){.pos = {(float)(k % 8) * 50.0f, 0, (float)(k / 8) * 50.0f}, .width = 4,
                              .axis = {0, 10, 0}, .rgba = 0xffffffffu};
    hz_bb_field *f = hz_bb_field_create(b, 64, 100);
    assert_non_null(f);
    hz_billboard out[64];
    const float eyes[][3] = {{3e38f, 100, -3e38f}, {-3e38f, 0, 3e38f}, {1e20f, 0, 1e20f}, {200, 100, 200}};
    for (size_t e = 0; e < 4; e++) {
        hz_camera cam = {.pos = {eyes[e][0], eyes[e][1], eyes[e][2]}, .yaw = 45, .pitch = -10, .fov_y = 60,
                         .aspect = 1.5f, .znear = 1, .zfar = 5000};
        size_t n = hz_bb_field_cull(f, &cam, 4000.0f, out, 64);
        if (e < 3)
            assert_int_equal(n, 0); /* nothing is near an eye that far away */
        else
            assert_true(n > 0);
    }
    hz_bb_field_destroy(f);
}

/* A heightmap whose relief overflows float with the height scale: the
 * suitability was NaN and NaN -> uint8 undefined (scatter.c). */
static void test_cover_absurd_relief(void **state)
{
    (void)state;
    hz_grid g;
    assert_int_equal(hz_grid_alloc(&g, 33, 33, NULL), HZ_OK);
    for (uint32_t k = 0; k < 33u * 33u; k++)
        g.z[k] = (float)(k % 33) * 3000.0f;
    hz_heightmap hm;
    assert_int_equal(hz_heightmap_create(&hm, &g, HZ_LAYOUT_LINEAR, NULL), HZ_OK);
    hz_grid_free(&g);
    hm.scale = 1e36f; /* relief beyond float range once scaled */
    uint8_t cover[16 * 16];
    memset(cover, 0xab, sizeof cover);
    hz_scatter_desc d = {.seed = 1};
    hz_forest_cover_map(&hm, 10.0f, 1e4f, &d, 16, cover);
    for (size_t k = 0; k < sizeof cover; k++)
        assert_true(cover[k] == 0); /* no meaningful forest on such ground */
    hz_heightmap_destroy(&hm);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bb_field_far_eye),
        cmocka_unit_test(test_cover_absurd_relief),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
