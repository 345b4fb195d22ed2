/* A whole frame through the library, headless: generated terrain -> LOD ->
 * renderer. Sky at the top, lit terrain at the bottom; more detail (C*C2)
 * means more triangles and an image closer to the full-resolution reference. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "horizon/metrics.h"
#include "horizon/render.h"
#include "horizon/terrain.h"

enum { W = 480, H = 270 };

typedef struct ctx {
    hz_terrain *t;
    hz_gl *gl;
    hz_renderer *r;
} ctx;

static int setup(void **state)
{
    static ctx c;
    hz_err err = {0};
    c.t = hz_terrain_create(&(hz_terrain_desc){.generate = HZ_GEN_PERLIN, .gen_size = 1025, .seed = 5}, &err);
    if (!c.t) {
        fprintf(stderr, "terrain: %s\n", err.msg);
        return -1;
    }
    c.gl = hz_gl_create_headless(&err);
    if (!c.gl) {
        fprintf(stderr, "gl: %s\n", err.msg);
        return -1;
    }
    c.r = hz_renderer_create(&(hz_renderer_desc){.width = W, .height = H}, &err);
    if (!c.r || hz_renderer_set_heightmap(c.r, &c.t->hm, c.t->spacing, c.t->zscale, &err) != HZ_OK) {
        fprintf(stderr, "renderer: %s\n", err.msg);
        return -1;
    }
    *state = &c;
    return 0;
}

static int teardown(void **state)
{
    ctx *c = *state;
    hz_renderer_destroy(c->r);
    hz_gl_destroy(c->gl);
    hz_terrain_destroy(c->t);
    return 0;
}

static uint32_t draw(ctx *c, const hz_camera *cam, float C, float C2, uint8_t *rgb, uint8_t *sky)
{
    hz_index_list il = {0};
    hz_lod_stats st;
    assert_int_equal(hz_lod_select(c->t->lod, cam, &(hz_lod_params){.c = C, .c2 = C2}, &il, NULL, NULL, &st), HZ_OK);
    hz_err err = {0};
    assert_int_equal(hz_renderer_draw(c->r, cam, NULL, il.data, (uint32_t)il.count, NULL, &err), HZ_OK);
    assert_int_equal(hz_renderer_read_rgb(c->r, rgb, &err), HZ_OK);
    if (sky)
        assert_int_equal(hz_renderer_read_sky_mask(c->r, sky, &err), HZ_OK);
    free(il.data);
    return st.triangles;
}

static void test_sky_above_lit_terrain_below(void **state)
{
    ctx *c = *state;
    hz_camera cam = hz_terrain_default_camera(c->t, W, H);
    uint8_t *rgb = malloc(W * H * 3), *sky = malloc(W * H);
    assert_true(draw(c, &cam, 25, 2.5f, rgb, sky) > 1000);
    hz_image_write_png(HZ_TEST_TMP "/frame_default.png", rgb, W, H, NULL);
    /* Top 10 % of rows: sky, blue-dominant and bright. */
    size_t sky_px = 0, n = 0;
    double b_minus_r = 0, lum_top = 0;
    for (int y = 0; y < H / 10; y++)
        for (int x = 0; x < W; x++, n++) {
            const uint8_t *p = rgb + 3 * ((size_t)y * W + x);
            sky_px += sky[(size_t)y * W + x];
            b_minus_r += (double)p[2] - p[0];
            lum_top += (p[0] + p[1] + p[2]) / 3.0;
        }
    assert_true(sky_px == n);
    assert_true(b_minus_r / (double)n > 30);
    assert_true(lum_top / (double)n > 120);
    /* Bottom 20 %: terrain, lit (not black, not sky coloured), with relief
     * visible as variation in brightness, green or brown rather than blue. */
    size_t terr = 0;
    n = 0;
    double lum = 0, lum2 = 0, g_minus_b = 0;
    for (int y = H - H / 5; y < H; y++)
        for (int x = 0; x < W; x++, n++) {
            const uint8_t *p = rgb + 3 * ((size_t)y * W + x);
            terr += !sky[(size_t)y * W + x];
            double l = (p[0] + p[1] + p[2]) / 3.0;
            lum += l;
            lum2 += l * l;
            g_minus_b += (double)p[1] - p[2];
        }
    double mean = lum / (double)n, sd = sqrt(lum2 / (double)n - mean * mean);
    assert_true(terr == n);
    assert_true(mean > 40 && mean < 220);
    assert_true(sd > 3);
    assert_true(g_minus_b / (double)n > 5);
    free(rgb);
    free(sky);
}

static void test_more_detail_closer_to_reference(void **state)
{
    ctx *c = *state;
    hz_camera cam = hz_terrain_default_camera(c->t, W, H);
    cam.pitch = -25;
    uint8_t *ref = malloc(W * H * 3), *img = malloc(W * H * 3);
    uint32_t ref_tris = draw(c, &cam, 1e30f, 1e30f, ref, NULL);
    hz_image_write_png(HZ_TEST_TMP "/frame_reference.png", ref, W, H, NULL);
    const float cs[][2] = {{3, 1}, {10, 2}, {50, 5}};
    uint32_t prev_tris = 0;
    double prev_psnr = 0;
    for (int k = 0; k < 3; k++) {
        uint32_t tris = draw(c, &cam, cs[k][0], cs[k][1], img, NULL);
        double psnr = hz_metrics_psnr(img, ref, W * H);
        fprintf(stderr, "C=%g C2=%g: %u triangles (reference %u), PSNR %.2f dB\n", (double)cs[k][0],
                (double)cs[k][1], tris, ref_tris, psnr);
        assert_true(tris > prev_tris);
        assert_true(tris < ref_tris);
        assert_true(psnr > prev_psnr);
        prev_tris = tris;
        prev_psnr = psnr;
    }
    assert_true(prev_psnr > 30);
    free(ref);
    free(img);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sky_above_lit_terrain_below),
        cmocka_unit_test(test_more_detail_closer_to_reference),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
