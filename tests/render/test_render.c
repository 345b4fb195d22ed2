/* Renderer tests: headless EGL on Mesa llvmpipe, real pixels read back.
 * Images go to HZ_TEST_TMP (render_*.png) for a human to look at. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <epoxy/gl.h>

#include "horizon/render.h"
#include "test_hills.h"

#define W 480u
#define H 270u
#define N 257u         /* heightmap side */
#define SPACING 20.0f  /* metres: 5.12 km square */

typedef struct fixture {
    hz_gl *gl;
    hz_renderer *r;
    hz_heightmap hm;  /* linear, filled by hand */
    uint32_t *idx;    /* full-resolution grid */
    uint32_t count;
    uint8_t *rgb;     /* W*H*3 */
    uint8_t *mask;    /* W*H */
} fixture;

/* ---- helpers ------------------------------------------------------------- */

static void make_heightmap(hz_heightmap *hm, uint32_t n, float spacing)
{
    float *f = malloc((size_t)n * n * sizeof *f);
    assert_non_null(f);
    float mn = INFINITY, mx = -INFINITY;
    for (uint32_t j = 0; j < n; j++)
        for (uint32_t i = 0; i < n; i++) {
            /* Same landscape whatever n: sample the 5.12 km square. */
            float s = (float)(N - 1) * SPACING / ((float)(n - 1) * spacing);
            float v = test_hills((float)i * spacing * s, (float)j * spacing * s);
            f[(size_t)j * n + i] = v;
            mn = fminf(mn, v);
            mx = fmaxf(mx, v);
        }
    uint32_t levels = 0;
    while ((1u << levels) + 1u < n)
        levels++;
    *hm = (hz_heightmap){.size = n, .levels = levels, .layout = HZ_LAYOUT_LINEAR,
                         .scale = (mx - mn) / 65535.0f, .offset = mn};
    hm->size_bytes = (size_t)n * n * sizeof(uint16_t);
    hm->h = malloc(hm->size_bytes);
    assert_non_null(hm->h);
    for (size_t k = 0; k < (size_t)n * n; k++)
        hm->h[k] = (uint16_t)lrintf((f[k] - mn) / hm->scale);
    free(f);
}

/* Two CCW-from-above triangles per cell: (a, b, c), (c, b, d). */
static uint32_t *make_grid_indices(uint32_t n, uint32_t *count)
{
    size_t cells = (size_t)(n - 1) * (n - 1);
    uint32_t *idx = malloc(cells * 6 * sizeof *idx);
    assert_non_null(idx);
    size_t k = 0;
    for (uint32_t j = 0; j + 1 < n; j++)
        for (uint32_t i = 0; i + 1 < n; i++) {
            uint32_t a = j * n + i, b = (j + 1) * n + i, c = j * n + i + 1, d = (j + 1) * n + i + 1;
            idx[k++] = a, idx[k++] = b, idx[k++] = c;
            idx[k++] = c, idx[k++] = b, idx[k++] = d;
        }
    *count = (uint32_t)k;
    return idx;
}

/* Camera at the south edge, looking north (-z) over the hills, slightly down. */
static hz_camera horizon_camera(void)
{
    return (hz_camera){.pos = {2000.0f, 700.0f, 4900.0f}, .yaw = 15.0f, .pitch = -10.0f,
                       .fov_y = 60.0f, .aspect = (float)W / (float)H, .znear = 1.0f, .zfar = 20000.0f};
}

typedef struct region_stats {
    double r, g, b;  /* means, 0..255 */
    double lum_sd;   /* standard deviation of (r+g+b)/3 */
} region_stats;

static region_stats stats_rows(const uint8_t *rgb, uint32_t w, uint32_t y0, uint32_t y1)
{
    double s[3] = {0}, l = 0, l2 = 0;
    size_t n = 0;
    for (uint32_t y = y0; y < y1; y++)
        for (uint32_t x = 0; x < w; x++) {
            const uint8_t *p = rgb + ((size_t)y * w + x) * 3;
            double lum = (p[0] + p[1] + p[2]) / 3.0;
            s[0] += p[0], s[1] += p[1], s[2] += p[2];
            l += lum, l2 += lum * lum;
            n++;
        }
    region_stats st = {s[0] / (double)n, s[1] / (double)n, s[2] / (double)n, 0};
    double m = l / (double)n;
    st.lum_sd = sqrt(fmax(l2 / (double)n - m * m, 0.0));
    return st;
}

/* Sky is blue-dominant and bright: the pale horizon (0.72, 0.81, 0.92) up to
 * the deep zenith blue. Lit or fogged ground never is. */
static bool px_is_sky(const uint8_t *p)
{
    return p[2] > p[0] + 30 && p[2] >= p[1] && p[2] > 150;
}

static size_t count_sky_px(const uint8_t *rgb, size_t npx)
{
    size_t n = 0;
    for (size_t k = 0; k < npx; k++)
        n += px_is_sky(rgb + k * 3);
    return n;
}

static size_t count_mask(const uint8_t *mask, size_t npx)
{
    size_t n = 0;
    for (size_t k = 0; k < npx; k++)
        n += mask[k];
    return n;
}

static void draw_read(fixture *fx, const hz_camera *cam, const hz_scene_params *sp, const uint32_t *idx,
                      uint32_t count, hz_draw_stats *ds)
{
    hz_err err = {0};
    hz_result r = hz_renderer_draw(fx->r, cam, sp, idx, count, ds, &err);
    if (r != HZ_OK)
        fail_msg("draw: %s", err.msg);
    if (hz_renderer_read_rgb(fx->r, fx->rgb, &err) != HZ_OK)
        fail_msg("read: %s", err.msg);
    if (hz_renderer_read_sky_mask(fx->r, fx->mask, &err) != HZ_OK)
        fail_msg("mask: %s", err.msg);
}

/* argv[1]: file name prefix, so variants of this test do not overwrite each
 * other's pictures. */
static const char *g_prefix = "";

static void save(const char *name, const uint8_t *rgb, uint32_t w, uint32_t h)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/%s%s", HZ_TEST_TMP, g_prefix, name);
    hz_err err = {0};
    if (hz_image_write_png(path, rgb, w, h, &err) != HZ_OK)
        fail_msg("png: %s", err.msg);
    printf("wrote %s\n", path);
}

/* ---- fixture ------------------------------------------------------------- */

static int setup(void **state)
{
    fixture *fx = calloc(1, sizeof *fx);
    hz_err err = {0};
    fx->gl = hz_gl_create_headless(&err);
    if (!fx->gl) {
        fprintf(stderr, "hz_gl_create_headless: %s\n", err.msg);
        free(fx);
        return -1; /* a GPU test that cannot run is a failure, not a skip */
    }
    printf("GL: %s\n", hz_gl_describe(fx->gl));
    fx->r = hz_renderer_create(&(hz_renderer_desc){.width = W, .height = H}, &err);
    if (!fx->r) {
        fprintf(stderr, "hz_renderer_create: %s\n", err.msg);
        return -1;
    }
    make_heightmap(&fx->hm, N, SPACING);
    if (hz_renderer_set_heightmap(fx->r, &fx->hm, SPACING, 1.0f, &err) != HZ_OK) {
        fprintf(stderr, "set_heightmap: %s\n", err.msg);
        return -1;
    }
    fx->idx = make_grid_indices(N, &fx->count);
    fx->rgb = malloc((size_t)W * H * 3);
    fx->mask = malloc((size_t)W * H);
    *state = fx;
    return 0;
}

static int teardown(void **state)
{
    fixture *fx = *state;
    if (!fx)
        return 0;
    hz_renderer_destroy(fx->r);
    hz_gl_destroy(fx->gl);
    free(fx->hm.h);
    free(fx->idx);
    free(fx->rgb);
    free(fx->mask);
    free(fx);
    return 0;
}

/* ---- tests --------------------------------------------------------------- */

static void test_describe(void **state)
{
    fixture *fx = *state;
    const char *d = hz_gl_describe(fx->gl);
    assert_non_null(strstr(d, " | "));
    assert_true(strlen(d) > 6);
}

static void test_horizon_view(void **state)
{
    fixture *fx = *state;
    hz_camera cam = horizon_camera();
    hz_draw_stats ds;
    draw_read(fx, &cam, NULL, fx->idx, fx->count, &ds);
    save("render_horizon.png", fx->rgb, W, H);
    printf("horizon view: %u triangles, upload %.2f ms, draw %.2f ms\n", fx->count / 3, ds.upload_ms,
           ds.draw_ms);
    assert_true(ds.draw_ms > 0.0);

    /* Top rows: sky, blue-dominant, bright, smooth. */
    region_stats top = stats_rows(fx->rgb, W, 0, H / 8);
    printf("top    rgb %.0f %.0f %.0f sd %.1f\n", top.r, top.g, top.b, top.lum_sd);
    assert_true(top.b > top.r + 30 && top.b > top.g && top.b > 150);
    assert_true(top.lum_sd < 12.0);
    /* Bottom rows: lit ground, not sky, not black, green/brown dominant. */
    region_stats bot = stats_rows(fx->rgb, W, H - H / 5, H);
    printf("bottom rgb %.0f %.0f %.0f sd %.1f\n", bot.r, bot.g, bot.b, bot.lum_sd);
    assert_true((bot.r + bot.g + bot.b) / 3.0 > 40.0);
    assert_true(bot.g > bot.b && bot.r > bot.b);
    assert_true(bot.lum_sd > 3.0); /* relief shading varies */
    size_t bot_sky = count_sky_px(fx->rgb + (size_t)(H - H / 5) * W * 3, (size_t)(H / 5) * W);
    assert_int_equal(bot_sky, 0);
    /* The depth mask agrees: top row sky, bottom row terrain. */
    assert_int_equal(count_mask(fx->mask, W), W);
    assert_int_equal(count_mask(fx->mask + (size_t)(H - 1) * W, W), 0);
    /* Roughly a third to two thirds of the frame is ground. */
    size_t sky = count_mask(fx->mask, (size_t)W * H);
    assert_true(sky > (size_t)W * H / 5 && sky < (size_t)W * H * 4 / 5);
}

static void test_look_up_sees_only_sky(void **state)
{
    fixture *fx = *state;
    hz_camera cam = horizon_camera();
    cam.pitch = 89.9f;
    draw_read(fx, &cam, NULL, fx->idx, fx->count, NULL);
    save("render_up.png", fx->rgb, W, H);
    assert_int_equal(count_mask(fx->mask, (size_t)W * H), (size_t)W * H);
    assert_int_equal(count_sky_px(fx->rgb, (size_t)W * H), (size_t)W * H);
    region_stats st = stats_rows(fx->rgb, W, 0, H);
    assert_true(st.b > st.r + 60); /* deep zenith blue */
}

static void test_look_down_sees_no_sky(void **state)
{
    fixture *fx = *state;
    hz_camera cam = horizon_camera();
    cam.pos[0] = 2560.0f, cam.pos[1] = 2500.0f, cam.pos[2] = 2560.0f;
    cam.pitch = -89.9f;
    draw_read(fx, &cam, NULL, fx->idx, fx->count, NULL);
    save("render_down.png", fx->rgb, W, H);
    assert_int_equal(count_mask(fx->mask, (size_t)W * H), 0);
    assert_int_equal(count_sky_px(fx->rgb, (size_t)W * H), 0);
    region_stats st = stats_rows(fx->rgb, W, 0, H);
    assert_true(st.lum_sd > 5.0);
}

static void test_empty_draw_is_sky(void **state)
{
    fixture *fx = *state;
    hz_camera cam = horizon_camera();
    draw_read(fx, &cam, NULL, NULL, 0, NULL);
    assert_int_equal(count_mask(fx->mask, (size_t)W * H), (size_t)W * H);
    assert_int_equal(count_sky_px(fx->rgb, (size_t)W * H), (size_t)W * H);
    /* Below the horizon the sky is exactly the default horizon colour. */
    const uint8_t *p = fx->rgb + ((size_t)(H - 1) * W + W / 2) * 3;
    assert_in_range(p[0], 182, 186);
    assert_in_range(p[1], 205, 209);
    assert_in_range(p[2], 233, 237);
}

/* Mean |rgb - fog| (sum of channels) over ground pixels within 6 rows below
 * the silhouette, and over the bottom 10 rows. */
static void fog_distances(fixture *fx, const hz_camera *cam, const hz_scene_params *sp, double *far_d,
                          double *near_d)
{
    const int fog[3] = {230, 140, 77};
    draw_read(fx, cam, sp, fx->idx, fx->count, NULL);
    save(sp->fog_density > 0 ? "render_fog.png" : "render_nofog.png", fx->rgb, W, H);
    double fs = 0, ns = 0;
    size_t fn = 0, nn = 0;
    for (uint32_t x = 0; x < W; x++) {
        uint32_t y = 0;
        while (y < H && fx->mask[(size_t)y * W + x])
            y++;
        for (uint32_t k = y; k < y + 6 && k < H - 10; k++, fn++)
            for (int c = 0; c < 3; c++)
                fs += abs(fx->rgb[((size_t)k * W + x) * 3 + c] - fog[c]);
        for (uint32_t k = H - 10; k < H; k++, nn++)
            for (int c = 0; c < 3; c++)
                ns += abs(fx->rgb[((size_t)k * W + x) * 3 + c] - fog[c]);
    }
    assert_true(fn > 0 && nn > 0);
    *far_d = fs / (double)fn;
    *near_d = ns / (double)nn;
}

static void test_custom_sky_and_fog(void **state)
{
    fixture *fx = *state;
    hz_camera cam = horizon_camera();
    /* Thick orange fog: far ground turns into the sky colour, near ground does not. */
    hz_scene_params sp = {.sky_color = {0.9f, 0.55f, 0.3f}, .fog_density = 1.0f / 1500.0f};
    /* The sky at and below the horizon is exactly the fog colour. */
    draw_read(fx, &cam, &sp, NULL, 0, NULL);
    const uint8_t *s = fx->rgb + ((size_t)(H - 1) * W + W / 2) * 3;
    assert_true(abs(s[0] - 230) < 2 && abs(s[1] - 140) < 2 && abs(s[2] - 77) < 2);
    /* Fogged: far ground (just below the silhouette) is close to the fog
     * colour, near ground (bottom rows) much less so. */
    double far_fog, near_fog, far_clear;
    fog_distances(fx, &cam, &sp, &far_fog, &near_fog);
    sp.fog_density = -1.0f;
    double near_clear;
    fog_distances(fx, &cam, &sp, &far_clear, &near_clear);
    printf("distance to fog colour: far %.0f near %.0f, without fog far %.0f near %.0f\n", far_fog, near_fog,
           far_clear, near_clear);
    assert_true(far_fog < 45.0);
    assert_true(near_fog > far_fog + 40.0);
    assert_true(far_clear > far_fog + 60.0);
}

static void test_wireframe_changes_pixels(void **state)
{
    fixture *fx = *state;
    hz_camera cam = horizon_camera();
    cam.pos[1] = 1400.0f;
    cam.pitch = -30.0f;
    size_t npx = (size_t)W * H;
    uint8_t *plain = malloc(npx * 3);
    assert_non_null(plain);
    draw_read(fx, &cam, NULL, fx->idx, fx->count, NULL);
    memcpy(plain, fx->rgb, npx * 3);
    hz_scene_params sp = {.wireframe = true};
    draw_read(fx, &cam, &sp, fx->idx, fx->count, NULL);
    save("render_wire.png", fx->rgb, W, H);
    size_t changed = 0, darker = 0, terrain = npx - count_mask(fx->mask, npx);
    for (size_t k = 0; k < npx; k++) {
        int d = 0, s = 0;
        for (int c = 0; c < 3; c++) {
            d += abs(fx->rgb[k * 3 + c] - plain[k * 3 + c]);
            s += fx->rgb[k * 3 + c] - plain[k * 3 + c];
        }
        changed += d > 30;
        darker += s < -30;
    }
    printf("wireframe: %zu of %zu terrain pixels changed\n", changed, terrain);
    assert_true(changed > terrain / 10);
    assert_true(darker > changed * 9 / 10);
    /* The sky is untouched, except where silhouette edges (lines just
     * outside the filled coverage) touch it. */
    for (uint32_t y = 1; y + 1 < H; y++)
        for (uint32_t x = 1; x + 1 < W; x++) {
            bool open_sky = true;
            for (int dy = -1; dy <= 1; dy++)
                for (int dx = -1; dx <= 1; dx++)
                    open_sky &= fx->mask[(size_t)((int)y + dy) * W + (size_t)((int)x + dx)] != 0;
            size_t k = (size_t)y * W + x;
            if (open_sky)
                assert_memory_equal(fx->rgb + k * 3, plain + k * 3, 3);
        }
    free(plain);
}

/* The blocked layout must upload to the same row-major grid. */
static void test_blocked_layout_same_image(void **state)
{
    fixture *fx = *state;
    hz_err err = {0};
    size_t npx = (size_t)W * H;
    hz_camera cam = horizon_camera();
    draw_read(fx, &cam, NULL, fx->idx, fx->count, NULL);
    uint8_t *ref = malloc(npx * 3);
    assert_non_null(ref);
    memcpy(ref, fx->rgb, npx * 3);

    hz_heightmap b = fx->hm;
    b.layout = HZ_LAYOUT_BLOCKED;
    b.blocks_per_row = (N + HZ_BLOCK - 1) / HZ_BLOCK;
    b.size_bytes = (size_t)b.blocks_per_row * b.blocks_per_row * HZ_BLOCK * HZ_BLOCK * sizeof(uint16_t);
    b.h = calloc(1, b.size_bytes);
    assert_non_null(b.h);
    for (uint32_t j = 0; j < N; j++)
        for (uint32_t i = 0; i < N; i++)
            b.h[hz_heightmap_index(&b, i, j)] = fx->hm.h[(size_t)j * N + i];
    if (hz_renderer_set_heightmap(fx->r, &b, SPACING, 1.0f, &err) != HZ_OK)
        fail_msg("%s", err.msg);
    draw_read(fx, &cam, NULL, fx->idx, fx->count, NULL);
    assert_memory_equal(ref, fx->rgb, npx * 3);
    free(b.h);
    free(ref);
    /* Back to the linear one for the other tests. */
    assert_int_equal(hz_renderer_set_heightmap(fx->r, &fx->hm, SPACING, 1.0f, &err), HZ_OK);
}

static void test_resize(void **state)
{
    fixture *fx = *state;
    hz_err err = {0};
    const uint32_t w2 = 200, h2 = 150;
    const size_t guard = 4096;
    uint8_t *buf = malloc((size_t)w2 * h2 * 3 + guard);
    assert_non_null(buf);
    memset(buf, 0xAB, (size_t)w2 * h2 * 3 + guard);
    assert_int_equal(hz_renderer_resize(fx->r, w2, h2, &err), HZ_OK);
    hz_camera cam = horizon_camera();
    cam.aspect = (float)w2 / (float)h2;
    assert_int_equal(hz_renderer_draw(fx->r, &cam, NULL, fx->idx, fx->count, NULL, &err), HZ_OK);
    assert_int_equal(hz_renderer_read_rgb(fx->r, buf, &err), HZ_OK);
    save("render_small.png", buf, w2, h2);
    /* Exactly w2*h2*3 bytes written. */
    for (size_t k = 0; k < guard; k++)
        assert_int_equal(buf[(size_t)w2 * h2 * 3 + k], 0xAB);
    region_stats top = stats_rows(buf, w2, 0, 10), bot = stats_rows(buf, w2, h2 - 20, h2);
    assert_true(top.b > top.r + 30);
    assert_true(bot.g > bot.b);
    /* The last pixel was written too (it is ground, never the 0xAB fill). */
    const uint8_t *last = buf + ((size_t)w2 * h2 - 1) * 3;
    assert_false(last[0] == 0xAB && last[1] == 0xAB && last[2] == 0xAB);
    free(buf);
    assert_int_equal(hz_renderer_resize(fx->r, 0, 10, &err), HZ_ERR_VALUE);
    assert_int_equal(hz_renderer_resize(fx->r, W, H, &err), HZ_OK);
}

static void test_errors(void **state)
{
    fixture *fx = *state;
    hz_err err = {0};
    hz_camera cam = horizon_camera();
    hz_renderer_destroy(NULL);
    hz_gl_destroy(NULL);

    assert_int_equal(hz_renderer_draw(fx->r, &cam, NULL, fx->idx, 4, NULL, &err), HZ_ERR_VALUE);
    assert_non_null(strstr(err.msg, "multiple of 3"));
    assert_int_equal(hz_renderer_draw(fx->r, &cam, NULL, NULL, 3, NULL, &err), HZ_ERR_VALUE);

    /* A heightmap bigger than the texture buffer limit fails cleanly before
     * touching the samples. */
    hz_heightmap big = {.size = 65537, .levels = 16, .layout = HZ_LAYOUT_LINEAR, .scale = 1, .h = NULL};
    assert_int_equal(hz_renderer_set_heightmap(fx->r, &big, 1.0f, 1.0f, &err), HZ_ERR_UNSUPPORTED);
    assert_non_null(strstr(err.msg, "GL_MAX_TEXTURE_BUFFER_SIZE"));
    printf("%s\n", err.msg);
    hz_heightmap bad = fx->hm;
    bad.size_bytes = 10;
    assert_int_equal(hz_renderer_set_heightmap(fx->r, &bad, SPACING, 1.0f, &err), HZ_ERR_VALUE);
    assert_int_equal(hz_renderer_set_heightmap(fx->r, &fx->hm, 0.0f, 1.0f, &err), HZ_ERR_VALUE);

    /* A fresh renderer has no heights: drawing triangles is refused, sky alone works. */
    hz_renderer *r2 = hz_renderer_create(&(hz_renderer_desc){.width = 64, .height = 32}, &err);
    assert_non_null(r2);
    assert_int_equal(hz_renderer_draw(r2, &cam, NULL, fx->idx, 3, NULL, &err), HZ_ERR_VALUE);
    assert_non_null(strstr(err.msg, "set_heightmap"));
    assert_int_equal(hz_renderer_draw(r2, &cam, NULL, NULL, 0, NULL, &err), HZ_OK);
    hz_renderer_destroy(r2);

    /* to_default_framebuffer on a surfaceless context: there is no
     * framebuffer 0, so drawing and reading fail with a GL error, not a crash. */
    hz_renderer *r3 = hz_renderer_create(
        &(hz_renderer_desc){.width = 64, .height = 32, .to_default_framebuffer = true}, &err);
    assert_non_null(r3);
    assert_int_equal(hz_renderer_draw(r3, &cam, NULL, NULL, 0, NULL, &err), HZ_ERR_GL);
    assert_non_null(strstr(err.msg, "GL_INVALID_FRAMEBUFFER_OPERATION"));
    uint8_t small[64 * 32 * 3];
    assert_int_equal(hz_renderer_read_rgb(r3, small, &err), HZ_ERR_GL);
    hz_renderer_destroy(r3);

    /* Too-large target: a clean error, the old target still works. */
    assert_int_not_equal(hz_renderer_resize(fx->r, 1u << 20, 16, &err), HZ_OK);
    printf("%s\n", err.msg);
    assert_int_equal(hz_renderer_resize(fx->r, W, H, &err), HZ_OK);

    assert_int_equal(hz_image_write_png("/nonexistent-dir/x.png", fx->rgb, W, H, &err), HZ_ERR_IO);
    assert_non_null(strstr(err.msg, "/nonexistent-dir/x.png"));
}

/* 1025^2 full-resolution grid (2 M triangles) at 1280x720: timing for the
 * record and a second, larger picture. */
static void test_full_res_1025(void **state)
{
    (void)state;
    hz_err err = {0};
    const uint32_t n = 1025, w = 1280, h = 720;
    hz_heightmap hm;
    make_heightmap(&hm, n, SPACING * (float)(N - 1) / (float)(n - 1));
    float spacing = SPACING * (float)(N - 1) / (float)(n - 1);
    uint32_t count = 0;
    uint32_t *idx = make_grid_indices(n, &count);
    uint8_t *rgb = malloc((size_t)w * h * 3);
    assert_non_null(rgb);
    hz_renderer *r = hz_renderer_create(&(hz_renderer_desc){.width = w, .height = h}, &err);
    assert_non_null(r);
    assert_int_equal(hz_renderer_set_heightmap(r, &hm, spacing, 1.0f, &err), HZ_OK);
    hz_camera cam = horizon_camera();
    cam.aspect = (float)w / (float)h;
    double best_draw = 1e30, best_up = 1e30;
    for (int k = 0; k < 3; k++) {
        hz_draw_stats ds;
        if (hz_renderer_draw(r, &cam, NULL, idx, count, &ds, &err) != HZ_OK)
            fail_msg("%s", err.msg);
        best_draw = fmin(best_draw, ds.draw_ms);
        best_up = fmin(best_up, ds.upload_ms);
    }
    printf("1025^2 full res, %u triangles at %ux%u: upload %.2f ms, draw %.2f ms (best of 3)\n", count / 3, w,
           h, best_up, best_draw);
    assert_int_equal(hz_renderer_read_rgb(r, rgb, &err), HZ_OK);
    save("render_1025.png", rgb, w, h);
    region_stats top = stats_rows(rgb, w, 0, h / 8), bot = stats_rows(rgb, w, h - h / 5, h);
    assert_true(top.b > top.r + 30);
    assert_true(bot.g > bot.b && bot.r > bot.b);
    hz_renderer_destroy(r);
    free(rgb);
    free(idx);
    free(hm.h);
}

/* Runs last: it leaves the fixture's renderer orphaned. A second context
 * becomes current; the first renderer refuses to work in it; destroying the
 * first (not current) context must not break the second. */
static void test_two_contexts(void **state)
{
    fixture *fx = *state;
    hz_err err = {0};
    hz_gl *gl2 = hz_gl_create_headless(&err);
    assert_non_null(gl2);
    hz_camera cam = horizon_camera();
    assert_int_equal(hz_renderer_draw(fx->r, &cam, NULL, fx->idx, fx->count, NULL, &err), HZ_ERR_GL);
    assert_non_null(strstr(err.msg, "different OpenGL context"));
    assert_int_equal(hz_renderer_read_rgb(fx->r, fx->rgb, &err), HZ_ERR_GL);

    hz_gl_destroy(fx->gl);
    fx->gl = gl2; /* teardown destroys it */
    hz_renderer *r2 = hz_renderer_create(&(hz_renderer_desc){.width = W, .height = H}, &err);
    assert_non_null(r2);
    assert_int_equal(hz_renderer_set_heightmap(r2, &fx->hm, SPACING, 1.0f, &err), HZ_OK);
    assert_int_equal(hz_renderer_draw(r2, &cam, NULL, fx->idx, fx->count, NULL, &err), HZ_OK);
    assert_int_equal(hz_renderer_read_rgb(r2, fx->rgb, &err), HZ_OK);
    region_stats top = stats_rows(fx->rgb, W, 0, H / 8), bot = stats_rows(fx->rgb, W, H - H / 5, H);
    assert_true(top.b > top.r + 30);
    assert_true(bot.g > bot.b);
    hz_renderer_destroy(r2);

    /* No context at all: clean errors, no abort inside libepoxy. */
    hz_gl_destroy(gl2);
    fx->gl = NULL;
    assert_null(hz_renderer_create(NULL, &err));
    assert_non_null(strstr(err.msg, "no current OpenGL context"));
    assert_int_equal(hz_renderer_draw(fx->r, &cam, NULL, NULL, 0, NULL, &err), HZ_ERR_GL);
    /* teardown's hz_renderer_destroy(fx->r) without its context only frees memory. */
}

/* The object hook runs once per frame in the main pass, after the terrain,
 * with the camera's matrices; what it draws lands in the frame (here: a
 * scissored red clear in the lower-left corner). */
typedef struct hook_log {
    int calls;
    hz_pass pass;
    mat4 viewproj;
    uint32_t w, h;
    float fog;
} hook_log;

static void paint_hook(void *user, const hz_pass_info *pi)
{
    hook_log *lg = user;
    lg->calls++;
    lg->pass = pi->pass;
    glm_mat4_copy((vec4 *)pi->viewproj, lg->viewproj);
    lg->w = pi->width;
    lg->h = pi->height;
    lg->fog = pi->fog_density;
    glEnable(GL_SCISSOR_TEST);
    glScissor(0, 0, 40, 30);
    glClearColor(1.0f, 0.0f, 0.0f, 1.0f);
    glClear(GL_COLOR_BUFFER_BIT);
    glDisable(GL_SCISSOR_TEST);
}

static void test_object_hook(void **state)
{
    fixture *fx = *state;
    hz_camera cam = horizon_camera();
    hook_log lg = {0};
    hz_scene_params sp = {.draw_objects = paint_hook, .draw_objects_user = &lg, .fog_density = 0.001f};
    draw_read(fx, &cam, &sp, fx->idx, fx->count, NULL);
    assert_int_equal(lg.calls, 1);
    assert_int_equal(lg.pass, HZ_PASS_MAIN);
    assert_int_equal(lg.w, W);
    assert_int_equal(lg.h, H);
    assert_true(fabsf(lg.fog - 0.001f) < 1e-9f);
    mat4 view, proj, vp;
    hz_camera_view(&cam, view);
    hz_camera_proj_reverse_z(&cam, proj);
    glm_mat4_mul(proj, view, vp);
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++)
            assert_true(fabsf(vp[i][j] - lg.viewproj[i][j]) < 1e-6f * (1.0f + fabsf(vp[i][j])));
    /* Bottom-left 40x30 is red (the image is top row first), the pixel next to it is not. */
    const uint8_t *in = fx->rgb + ((size_t)(H - 1) * W + 5) * 3;
    assert_true(in[0] == 255 && in[1] == 0 && in[2] == 0);
    const uint8_t *out = fx->rgb + ((size_t)(H - 1) * W + 45) * 3;
    assert_false(out[0] == 255 && out[1] == 0 && out[2] == 0);
    /* Without the hook, the corner is terrain again. */
    draw_read(fx, &cam, NULL, fx->idx, fx->count, NULL);
    assert_false(in[0] == 255 && in[1] == 0 && in[2] == 0);
}

int main(int argc, char **argv)
{
    if (argc > 1)
        g_prefix = argv[1];
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_describe),
        cmocka_unit_test(test_horizon_view),
        cmocka_unit_test(test_look_up_sees_only_sky),
        cmocka_unit_test(test_look_down_sees_no_sky),
        cmocka_unit_test(test_empty_draw_is_sky),
        cmocka_unit_test(test_custom_sky_and_fog),
        cmocka_unit_test(test_object_hook),
        cmocka_unit_test(test_wireframe_changes_pixels),
        cmocka_unit_test(test_blocked_layout_same_image),
        cmocka_unit_test(test_resize),
        cmocka_unit_test(test_errors),
        cmocka_unit_test(test_full_res_1025),
        cmocka_unit_test(test_two_contexts),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
