/* Camera paths: CSV parsing, interpolation hits its keyframes, bad files refused. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "horizon/path.h"

static const char *write_file(const char *name, const char *text)
{
    static char path[512];
    snprintf(path, sizeof path, "%s/%s", HZ_TEST_TMP, name);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
    return path;
}

static void test_csv_hits_keyframes(void **state)
{
    (void)state;
    const char *p = write_file("p.csv", "t,x,y,z,yaw,pitch\n"
                                        "0, 0, 10, 0, 350, -5\n"
                                        "# a comment\n"
                                        "1, 100, 20, -50, 10, 0\n"
                                        "3, 300, 15, -60, 90, 5\n"
                                        "4.5, 310, 30, 0, 180, -20\n");
    hz_path path;
    hz_err err = {0};
    assert_int_equal(hz_path_load_csv(p, &path, &err), HZ_OK);
    assert_int_equal(path.count, 4);
    assert_true(fabsf(hz_path_duration(&path) - 4.5f) < 1e-6f);
    for (size_t i = 0; i < path.count; i++) {
        hz_camera c = {0};
        hz_path_sample(&path, path.keys[i].t, &c);
        assert_true(fabsf(c.pos[0] - path.keys[i].x) < 1e-3f);
        assert_true(fabsf(c.pos[1] - path.keys[i].y) < 1e-3f);
        assert_true(fabsf(c.pos[2] - path.keys[i].z) < 1e-3f);
        assert_true(fabsf(fmodf(c.yaw - path.keys[i].yaw + 720.0f, 360.0f)) < 1e-3f);
        assert_true(fabsf(c.pitch - path.keys[i].pitch) < 1e-4f);
    }
    /* Yaw goes the short way: 350 -> 10 passes through 0, not 180. */
    hz_camera c = {0};
    hz_path_sample(&path, 0.5f, &c);
    float y = fmodf(c.yaw + 360.0f, 360.0f);
    assert_true(y > 355.0f || y < 5.0f);
    /* Between keys the position stays between neighbouring values here. */
    hz_path_sample(&path, 2.0f, &c);
    assert_true(c.pos[0] > 100 && c.pos[0] < 300);
    /* Clamped outside the time range. */
    hz_path_sample(&path, 99.0f, &c);
    assert_true(fabsf(c.pos[0] - 310) < 1e-4f);
    hz_path_free(&path);
}

static void test_csv_errors(void **state)
{
    (void)state;
    hz_path path;
    hz_err err = {0};
    assert_int_equal(hz_path_load_csv(HZ_TEST_TMP "/nope.csv", &path, &err), HZ_ERR_IO);
    assert_int_equal(hz_path_load_csv(write_file("one.csv", "0,1,2,3,4,5\n"), &path, &err), HZ_ERR_VALUE);
    assert_int_equal(hz_path_load_csv(write_file("bad.csv", "0,1,2,3,4,5\n1,2,x,4,5,6\n"), &path, &err),
                     HZ_ERR_FORMAT);
    assert_non_null(strstr(err.msg, "line 2"));
    assert_int_equal(hz_path_load_csv(write_file("order.csv", "0,1,2,3,4,5\n0,2,3,4,5,6\n"), &path, &err),
                     HZ_ERR_VALUE);
    assert_int_equal(hz_path_load_csv(write_file("nan.csv", "0,1,2,3,4,5\n1,nan,3,4,5,6\n"), &path, &err),
                     HZ_ERR_VALUE);
    assert_int_equal(hz_path_load_csv(write_file("short.csv", "0,1,2,3,4,5\n1,2,3\n"), &path, &err),
                     HZ_ERR_FORMAT);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_csv_hits_keyframes),
        cmocka_unit_test(test_csv_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
