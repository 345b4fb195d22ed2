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
#include <string.h>
#include <unistd.h>

#include "horizon/metrics.h"
#include "horizon/occlusion.h"
#include "horizon/path.h"
#include "horizon/pyramid.h"
#include "horizon/render.h"
#include "horizon/stream.h"
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
    /* Above the middle of the map, looking toward the horizon (the default
     * camera before issue 15 framed the summit: rock and snow, not green). */
    const float mid = 0.5f * hz_terrain_extent(c->t);
    cam.pos[0] = cam.pos[2] = mid;
    cam.pos[1] = fmaxf(hz_terrain_height_at(c->t, mid, mid) + 0.15f * (c->t->max_h - c->t->min_h) + 0.01f * 2 * mid,
                       0.9f * c->t->max_h);
    cam.yaw = 30.0f;
    cam.pitch = -10.0f;
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

/* The plain sky's colour in direction d (sky_grid_vs.glsl), 0..255; returns the
 * sun glow's share of it. */
static double sky_reference(const float horizon[3], const float sun[3], const double d_in[3], double out[3])
{
    const double len = sqrt(d_in[0] * d_in[0] + d_in[1] * d_in[1] + d_in[2] * d_in[2]);
    const double d[3] = {d_in[0] / len, d_in[1] / len, d_in[2] / len};
    const double up = d[1] > 0 ? d[1] : 0;
    const double k = (1 - exp(-3 * up)) / (1 - exp(-3.0));
    const double zen[3] = {horizon[0] * 0.28, horizon[1] * 0.5, horizon[2] * 0.85};
    double s = d[0] * sun[0] + d[1] * sun[1] + d[2] * sun[2];
    s = s > 0 ? pow(s, 64) : 0;
    const double t = fmin(fmax(up / 0.05, 0), 1), glow = 0.25 * s * t * t * (3 - 2 * t);
    const double tint[3] = {1.0, 0.9, 0.7};
    for (int ch = 0; ch < 3; ch++)
        out[ch] = 255 * fmin(horizon[ch] + (zen[ch] - horizon[ch]) * k + tint[ch] * glow, 1.0);
    return 255 * glow;
}

/* The sky is shaded per vertex of a grid over the screen above the horizon
 * (below it, the clear colour is the horizon's): every sky pixel still has
 * the colour of its own view ray, within rounding, looking up, along the
 * horizon into the sun's glow, and down. */
static void test_sky_colour_per_ray(void **state)
{
    ctx *c = *state;
    hz_err err = {0};
    const float horizon[3] = {0.70f, 0.80f, 0.95f};
    const float views[3][2] = {{180.0f, 40.0f}, {170.0f, 8.0f}, {120.0f, -20.0f}}; /* yaw, pitch: up, level, down */
    uint8_t *rgb = malloc(W * H * 3), *sky = malloc(W * H);
    for (int v = 0; v < 3; v++) {
        hz_camera cam = hz_terrain_default_camera(c->t, W, H);
        cam.pos[1] = c->t->max_h + 400.0f; /* above every summit: sky down to the horizon somewhere */
        cam.yaw = views[v][0];
        cam.pitch = views[v][1];
        mat4 view, proj, vp, inv;
        hz_camera_view(&cam, view);
        view[3][0] = view[3][1] = view[3][2] = 0.0f;
        hz_camera_proj_reverse_z(&cam, proj);
        glm_mat4_mul(proj, view, vp);
        glm_mat4_inv(vp, inv);
        /* The sun 15 degrees up, in the heading of the view's centre. */
        vec4 centre = {0.0f, 0.0f, 0.5f, 1.0f}, f;
        glm_mat4_mulv(inv, centre, f);
        const float fh = sqrtf(f[0] * f[0] + f[2] * f[2]);
        float sun[3] = {0.96592583f * f[0] / fh, 0.25881905f, 0.96592583f * f[2] / fh};
        hz_scene_params sp = {.fog_density = -1.0f};
        memcpy(sp.sky_color, horizon, sizeof sp.sky_color);
        memcpy(sp.sun_dir, sun, sizeof sp.sun_dir);
        assert_int_equal(hz_renderer_draw(c->r, &cam, &sp, NULL, 0, NULL, &err), HZ_OK);
        assert_int_equal(hz_renderer_read_rgb(c->r, rgb, &err), HZ_OK);
        assert_int_equal(hz_renderer_read_sky_mask(c->r, sky, &err), HZ_OK);
        size_t n = 0, above = 0, glow = 0;
        double worst = 0;
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                const size_t k = (size_t)y * W + x;
                assert_true(sky[k]); /* nothing drawn but the sky */
                vec4 ndc = {2.0f * ((float)x + 0.5f) / W - 1.0f, 1.0f - 2.0f * ((float)y + 0.5f) / H, 0.5f, 1.0f}, w;
                glm_mat4_mulv(inv, ndc, w);
                const double d[3] = {w[0] / w[3], w[1] / w[3], w[2] / w[3]};
                double ref[3];
                glow += sky_reference(horizon, sun, d, ref) > 20;
                for (int ch = 0; ch < 3; ch++)
                    worst = fmax(worst, fabs(rgb[3 * k + ch] - ref[ch]));
                n++;
                above += d[1] > 0;
            }
        fprintf(stderr,
                "sky, yaw %.0f pitch %.0f: %zu of %zu pixels above the horizon, %zu in the glow, worst channel %.2f off\n",
                (double)cam.yaw, (double)cam.pitch, above, n, glow, worst);
        if (v == 0)
            assert_true(above == n);
        else
            assert_true(above > n / 10 && above < n - n / 10);
        if (v == 1)
            assert_true(glow > n / 50);
        assert_true(worst <= 2.5);
    }
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

/* Every LOD mode at a 1 px bound draws an image close to the reference. */
static void test_modes_close_to_reference(void **state)
{
    ctx *c = *state;
    hz_camera cam = hz_terrain_default_camera(c->t, W, H);
    cam.pitch = -15;
    uint8_t *ref = malloc(W * H * 3), *img = malloc(W * H * 3), *sref = malloc(W * H), *simg = malloc(W * H);
    draw(c, &cam, 1e30f, 1e30f, ref, sref);
    hz_err err = {0};
    hz_index_list il = {0};
    hz_patch_list pl = {0};
    for (int m = 0; m < HZ_LOD_MODE_COUNT; m++) {
        assert_int_equal(hz_lod_prepare(c->t->lod, (hz_lod_mode)m), HZ_OK);
        hz_lod_params p = {.mode = (hz_lod_mode)m, .pixel_error = 1.0f, .viewport_height = H};
        hz_lod_stats st;
        hz_scene_params sp = {0};
        if (m == HZ_LOD_CDLOD) {
            /* cdlod draws nodes as patches */
            assert_int_equal(hz_renderer_set_cdlod(c->r, c->t->lod, NULL, &err), HZ_OK);
            assert_int_equal(hz_lod_select_patches(c->t->lod, &cam, &p, &pl, &st), HZ_OK);
            il.count = 0;
            sp.patches = pl.data;
            sp.patch_count = (uint32_t)pl.count;
        } else {
            assert_int_equal(hz_lod_select(c->t->lod, &cam, &p, &il, NULL, NULL, &st), HZ_OK);
        }
        sp.morph_scale = st.morph_scale;
        sp.morph_start = st.morph_start;
        assert_int_equal(hz_renderer_draw(c->r, &cam, &sp, il.data, (uint32_t)il.count, NULL, &err), HZ_OK);
        assert_int_equal(hz_renderer_read_rgb(c->r, img, &err), HZ_OK);
        assert_int_equal(hz_renderer_read_sky_mask(c->r, simg, &err), HZ_OK);
        double psnr = hz_metrics_psnr(img, ref, W * H), sil = hz_metrics_silhouette(simg, sref, W * H);
        fprintf(stderr, "%-13s tau 1 px: %6u triangles, PSNR %.2f dB, silhouette %.5f\n",
                hz_lod_mode_name((hz_lod_mode)m), st.triangles, psnr, sil);
        assert_true(psnr > 38);
        assert_true(sil < 0.002);
    }
    free(il.data);
    free(pl.data);
    free(ref);
    free(img);
    free(sref);
    free(simg);
}

/* cdlod patches at tau (near_tau within near_d metres, hz_lod_params) for
 * the camera at (NULL: the default camera looking 4 degrees down), which goes
 * to cam, and the same patches expanded to triangles. */
static void cdlod_frame_near(ctx *c, float tau, float near_tau, float near_d, const hz_camera *at, bool all,
                             hz_camera *cam, hz_patch_list *pl, hz_index_list *il, hz_lod_stats *st)
{
    hz_err err = {0};
    hz_terrain *t = c->t;
    assert_int_equal(hz_lod_prepare(t->lod, HZ_LOD_CDLOD), HZ_OK);
    assert_int_equal(hz_renderer_set_cdlod(c->r, t->lod, NULL, &err), HZ_OK);
    if (at) {
        *cam = *at;
    } else {
        *cam = hz_terrain_default_camera(t, W, H);
        cam->pitch = -4;
    }
    hz_lod_params p = {.mode = HZ_LOD_CDLOD, .pixel_error = tau, .viewport_height = H, .horizon_cull = !all,
                       .near_pixel_error = near_tau, .near_distance = near_d};
    assert_int_equal(hz_lod_select_patches(t->lod, cam, &p, pl, st), HZ_OK);
    assert_int_equal(hz_lod_patches_to_indices(t->lod, pl->data, pl->count, il), HZ_OK);
    assert_int_equal(il->count, (size_t)st->triangles * 3);
}

static void cdlod_frame_all(ctx *c, float tau, const hz_camera *at, bool all, hz_camera *cam, hz_patch_list *pl,
                            hz_index_list *il, hz_lod_stats *st)
{
    cdlod_frame_near(c, tau, 0.0f, 0.0f, at, all, cam, pl, il, st);
}

/* The same, less the patches that nearer ground hides (horizon culling on). */
static void cdlod_frame(ctx *c, float tau, const hz_camera *at, hz_camera *cam, hz_patch_list *pl,
                        hz_index_list *il, hz_lod_stats *st)
{
    cdlod_frame_all(c, tau, at, false, cam, pl, il, st);
}

/* The patch vertex shader places, stitches and morphs exactly like the CPU
 * (hz_lod_patches_to_indices, hz_lod_morph_height): a cdlod frame drawn as
 * patches with GPU morphing has the silhouette and the depth of the expanded
 * triangles drawn over a heightmap that holds the CPU-morphed heights.
 * near_tau > tau: with that near bound (within near_d metres). */
static void gpu_morph_matches_cpu(ctx *c, float tau, float near_tau, float near_d, const hz_camera *at, bool horizon)
{
    hz_err err = {0};
    hz_terrain *t = c->t;
    const uint32_t n = t->hm.size;
    hz_camera cam;
    hz_index_list il = {0};
    hz_patch_list pl = {0};
    hz_lod_stats st;
    cdlod_frame_near(c, tau, near_tau, near_d, at, false, &cam, &pl, &il, &st);
    assert_true(st.morph_scale > 0);
    assert_true(near_tau > tau ? st.morph_near < 1.0f : st.morph_near == 1.0f);
    size_t stitched = 0;
    for (size_t k = 0; k < pl.count; k++)
        stitched += pl.data[k].coarse != 0;
    assert_true(stitched > 0); /* the frame has stitched edges to compare too */
    /* The CPU-morphed heights as a heightmap of their own. */
    hz_grid g;
    assert_int_equal(hz_grid_alloc(&g, n, n, &err), HZ_OK);
    size_t moved = 0;
    for (uint32_t k = 0; k < n * n; k++) {
        g.z[k] = hz_lod_morph_height(t->lod, &cam, &st, k) / t->zscale;
        moved += hz_lod_morph_factor(t->lod, &cam, &st, k) > 0.01f;
    }
    assert_true(moved > 1000);
    hz_heightmap hm2;
    assert_int_equal(hz_heightmap_create(&hm2, &g, HZ_LAYOUT_LINEAR, &err), HZ_OK);
    hz_renderer *r2 = hz_renderer_create(&(hz_renderer_desc){.width = W, .height = H}, &err);
    assert_non_null(r2);
    assert_int_equal(hz_renderer_set_heightmap(r2, &hm2, t->spacing, t->zscale, &err), HZ_OK);

    uint8_t *rgb = malloc(W * H * 3), *gpu = malloc(W * H), *cpu = malloc(W * H), *flat = malloc(W * H);
    hz_scene_params sp = {.morph_scale = st.morph_scale, .morph_start = st.morph_start, .patches = pl.data,
                          .patch_count = (uint32_t)pl.count, .morph_near = st.morph_near,
                          .morph_near_distance = st.morph_near_distance};
    assert_int_equal(hz_renderer_draw(c->r, &cam, &sp, NULL, 0, NULL, &err), HZ_OK);
    assert_int_equal(hz_renderer_read_sky_mask(c->r, gpu, &err), HZ_OK);
    assert_int_equal(hz_renderer_read_rgb(c->r, rgb, &err), HZ_OK);
    hz_image_write_png(HZ_TEST_TMP "/frame_cdlod_morph.png", rgb, W, H, NULL);
    /* Depth too: the silhouette alone misses a morph that is wrong inside the
     * terrain (a neighbour read from the wrong tile, say). */
    float *dg = malloc(W * H * sizeof *dg), *dc = malloc(W * H * sizeof *dc), *df = malloc(W * H * sizeof *df);
    assert_int_equal(hz_renderer_read_depth(c->r, dg, &err), HZ_OK);
    /* The still patches (no vertex morphs: drawn without the morph code)
     * draw what the full shader draws: the frame with every patch marked
     * moving is the same, byte for byte and depth for depth. */
    {
        fprintf(stderr, "%u of %zu patches still\n", st.still, pl.count);
        assert_true(st.still > 0 && st.still < pl.count);
        hz_patch *all = malloc(pl.count * sizeof *all);
        memcpy(all, pl.data, pl.count * sizeof *all);
        for (size_t k = 0; k < pl.count; k++)
            all[k].still = 0;
        hz_scene_params sp2 = sp;
        sp2.patches = all;
        uint8_t *rgb2 = malloc(W * H * 3);
        float *d2 = malloc(W * H * sizeof *d2);
        assert_int_equal(hz_renderer_draw(c->r, &cam, &sp2, NULL, 0, NULL, &err), HZ_OK);
        assert_int_equal(hz_renderer_read_rgb(c->r, rgb2, &err), HZ_OK);
        assert_int_equal(hz_renderer_read_depth(c->r, d2, &err), HZ_OK);
        assert_memory_equal(rgb, rgb2, (size_t)W * H * 3);
        assert_memory_equal(dg, d2, (size_t)W * H * sizeof *d2);
        free(all);
        free(rgb2);
        free(d2);
    }
    sp.morph_scale = 0.0f; /* the same patches, unmorphed */
    assert_int_equal(hz_renderer_draw(c->r, &cam, &sp, NULL, 0, NULL, &err), HZ_OK);
    assert_int_equal(hz_renderer_read_sky_mask(c->r, flat, &err), HZ_OK);
    assert_int_equal(hz_renderer_read_depth(c->r, df, &err), HZ_OK);
    assert_int_equal(hz_renderer_draw(r2, &cam, NULL, il.data, (uint32_t)il.count, NULL, &err), HZ_OK);
    assert_int_equal(hz_renderer_read_sky_mask(r2, cpu, &err), HZ_OK);
    assert_int_equal(hz_renderer_read_depth(r2, dc, &err), HZ_OK);
    const double d_cpu = hz_metrics_silhouette(gpu, cpu, W * H), d_flat = hz_metrics_silhouette(gpu, flat, W * H);
    fprintf(stderr, "morphed silhouette vs CPU morph %.6f, vs unmorphed %.6f (%zu vertices morphing)\n", d_cpu,
            d_flat, moved);
    if (horizon) {
        assert_true(d_flat > 0.0001);     /* the morph is visible at this bound */
        assert_true(d_cpu * 20 < d_flat); /* and it is the CPU's morph */
    }
    /* Reverse-Z depth is near / distance: a relative difference is one of
     * distance. The CPU copy's heights are rounded to 16 bits (a few cm). */
    size_t ground = 0, off_cpu = 0, off_flat = 0;
    for (size_t k = 0; k < (size_t)W * H; k++) {
        if (gpu[k] || cpu[k] || flat[k]) /* sky in one of them */
            continue;
        ground++;
        off_cpu += fabsf(dg[k] - dc[k]) > 2e-4f * dc[k];
        off_flat += fabsf(dg[k] - df[k]) > 2e-4f * df[k];
    }
    fprintf(stderr, "morphed depth: %zu of %zu ground pixels off the CPU morph, %zu off the unmorphed patches\n",
            off_cpu, ground, off_flat);
    assert_true(ground > (size_t)W * H / 8);
    assert_true(off_flat * 20 > ground); /* the morph moves over 5 % of the ground */
    assert_true(off_cpu * 50 < off_flat);
    if (near_tau > tau) {
        /* The shader does apply the near bound: without it the morphs (the
         * far ranges, longer) are off the CPU's. */
        sp.morph_scale = st.morph_scale;
        sp.morph_near = 0.0f;
        assert_int_equal(hz_renderer_draw(c->r, &cam, &sp, NULL, 0, NULL, &err), HZ_OK);
        assert_int_equal(hz_renderer_read_depth(c->r, df, &err), HZ_OK);
        size_t off_far = 0;
        for (size_t k = 0; k < (size_t)W * H; k++)
            off_far += !gpu[k] && !cpu[k] && fabsf(df[k] - dc[k]) > 2e-4f * dc[k];
        fprintf(stderr, "near bound: %zu ground pixels off the CPU morph without it, %zu with it\n", off_far, off_cpu);
        assert_true(off_cpu * 20 < off_far);
    }
    free(dg);
    free(dc);
    free(df);
    hz_renderer_destroy(r2);
    hz_heightmap_destroy(&hm2);
    hz_grid_free(&g);
    free(il.data);
    free(pl.data);
    free(rgb);
    free(gpu);
    free(cpu);
    free(flat);
}

static void test_gpu_morph_matches_cpu(void **state)
{
    ctx *c = *state;
    gpu_morph_matches_cpu(c, 12.0f, 0.0f, 0.0f, NULL, true); /* from above the centre, to the horizon */
    /* Low over the map's far quarter, looking down: fine patches morph in
     * tiles other than the first of their level (256 cells a tile). */
    hz_camera at = hz_terrain_default_camera(c->t, W, H);
    const float side = c->t->spacing * (float)(c->t->hm.size - 1);
    at.pos[0] = at.pos[2] = 0.8f * side;
    at.pos[1] = hz_terrain_height_at(c->t, at.pos[0], at.pos[2]) + 300.0f;
    at.yaw = 30.0f;
    at.pitch = -25.0f;
    gpu_morph_matches_cpu(c, 2.0f, 0.0f, 0.0f, &at, false);
    /* The same with a near bound: 8 px within 400 m, 2 px from 6.4 km on. */
    gpu_morph_matches_cpu(c, 2.0f, 8.0f, 400.0f, &at, false);
}

/* Draws a frame (patches in sp, or count indices) and reads its depth and
 * sky mask. */
static void draw_depth_sky(ctx *c, const hz_camera *cam, const hz_scene_params *sp, const uint32_t *idx,
                           uint32_t count, hz_draw_stats *ds, float *depth, uint8_t *sky)
{
    hz_err err = {0};
    assert_int_equal(hz_renderer_draw(c->r, cam, sp, idx, count, ds, &err), HZ_OK);
    assert_int_equal(hz_renderer_read_depth(c->r, depth, &err), HZ_OK);
    assert_int_equal(hz_renderer_read_sky_mask(c->r, sky, &err), HZ_OK);
}

/* Two window depths differ beyond float rounding. */
static bool depth_differs(float a, float b)
{
    return fabsf(a - b) > 1e-6f * fmaxf(fabsf(b), 1e-3f);
}

/* A frame of many patches (the renderer draws them in 4 flushed chunks of
 * at least 64, from 8 bytes of instance data each) is the frame of the same
 * patches expanded to triangles: unmorphed, the same depth at every pixel
 * and the same sky. */
static void test_patch_chunks_draw_every_patch(void **state)
{
    ctx *c = *state;
    hz_camera cam;
    hz_index_list il = {0};
    hz_patch_list pl = {0};
    hz_lod_stats st;
    cdlod_frame(c, 0.5f, NULL, &cam, &pl, &il, &st);
    fprintf(stderr, "%zu patches\n", pl.count);
    assert_true(pl.count >= 5 * 64); /* every one of the 5 flushed chunks (terrain_patch.c) */
    float *dp = malloc(W * H * sizeof *dp), *di = malloc(W * H * sizeof *di);
    uint8_t *sp_ = malloc(W * H), *si = malloc(W * H);
    hz_scene_params sp = {.patches = pl.data, .patch_count = (uint32_t)pl.count}; /* morph_scale 0 */
    hz_draw_stats ds;
    draw_depth_sky(c, &cam, &sp, NULL, 0, &ds, dp, sp_);
    /* the upload is 8 bytes a node (an in-memory terrain) */
    assert_int_equal(ds.upload_bytes, pl.count * 8);
    draw_depth_sky(c, &cam, NULL, il.data, (uint32_t)il.count, NULL, di, si);
    size_t ground = 0, depth_off = 0, sky_off = 0;
    for (size_t k = 0; k < (size_t)W * H; k++) {
        ground += !si[k];
        sky_off += sp_[k] != si[k];
        depth_off += depth_differs(dp[k], di[k]);
    }
    fprintf(stderr, "chunked patches vs triangles: %zu of %zu ground pixels at another depth, %zu sky pixels differ\n",
            depth_off, ground, sky_off);
    assert_true(ground > (size_t)W * H / 5);
    assert_true(sky_off * 2000 <= (size_t)W * H);
    assert_true(depth_off * 1000 <= ground);
    free(dp);
    free(di);
    free(sp_);
    free(si);
    free(il.data);
    free(pl.data);
}

/* Blocks a patch marks hidden (hz_patch.hidden, what occlusion culling
 * sets) are not drawn, and only they, for patches of lod (blocks per side): patches with random masks (whole,
 * partly hidden in runs and gaps, all hidden) draw the frame of the same
 * patches expanded to triangles less the cells of the hidden blocks, the
 * same depth at every pixel and the same sky; and the masks change the
 * frame. */
static void hidden_blocks_case(ctx *c, hz_lod *lod, uint32_t blocks)
{
    hz_err err = {0};
    hz_camera cam = hz_terrain_default_camera(c->t, W, H);
    cam.pitch = -4;
    hz_index_list il = {0}, one = {0}, kept = {0};
    hz_patch_list pl = {0};
    hz_lod_stats st;
    assert_int_equal(hz_lod_prepare(lod, HZ_LOD_CDLOD), HZ_OK);
    assert_int_equal(hz_renderer_set_cdlod(c->r, lod, NULL, &err), HZ_OK);
    hz_lod_params lp = {.mode = HZ_LOD_CDLOD, .pixel_error = 0.5f, .viewport_height = H, .horizon_cull = true};
    assert_int_equal(hz_lod_select_patches(lod, &cam, &lp, &pl, &st), HZ_OK);
    assert_int_equal(hz_lod_patches_to_indices(lod, pl.data, pl.count, &il), HZ_OK);
    assert_true(pl.count >= 5 * 64); /* several flushed chunks */
    const uint32_t P = hz_lod_patch_cells(lod), B = hz_lod_patch_blocks(P), n = c->t->hm.size;
    assert_int_equal(B, blocks);
    const uint16_t all = (uint16_t)((1u << (B * B)) - 1u);
    uint64_t rng = 0x5eed5eedULL;
    size_t partial = 0, hidden_tris = 0;
    for (size_t k = 0; k < pl.count; k++) {
        hz_patch *q = &pl.data[k];
        rng = rng * 6364136223846793005ULL + 1442695040888963407ULL;
        const uint32_t kind = (uint32_t)(rng >> 60) & 3u;
        q->hidden = kind == 0 ? 0 : (kind == 1 ? 0xffffu : (uint16_t)(rng >> 20));
        partial += (q->hidden & all) != 0 && (q->hidden & all) != all;
        /* the reference: the patch's triangles outside its hidden blocks */
        one.count = 0;
        assert_int_equal(hz_lod_patches_to_indices(lod, q, 1, &one), HZ_OK);
        const uint32_t cell = (P / B) << q->shift;
        for (size_t t = 0; t < one.count; t += 3) {
            uint32_t i = 0, j = 0;
            for (int v = 0; v < 3; v++)
                i += one.data[t + v] % n, j += one.data[t + v] / n;
            const uint32_t bx = (i - 3 * q->x0) / (3 * cell), bz = (j - 3 * q->z0) / (3 * cell);
            assert_true(bx < B && bz < B);
            if (q->hidden >> (bz * B + bx) & 1u) {
                hidden_tris++;
                continue;
            }
            if (kept.count + 3 > kept.cap) {
                kept.cap = kept.cap ? 2 * kept.cap : 4096;
                kept.data = realloc(kept.data, kept.cap * sizeof *kept.data);
                assert_non_null(kept.data);
            }
            memcpy(kept.data + kept.count, one.data + t, 3 * sizeof *kept.data);
            kept.count += 3;
        }
    }
    fprintf(stderr, "%u-cell patches: %zu, %zu partly hidden; %zu of %zu triangles hidden\n", P, pl.count, partial,
            hidden_tris, il.count / 3);
    assert_true(partial > pl.count / 3 && hidden_tris * 6 > il.count / 3);
    float *dp = malloc(W * H * sizeof *dp), *di = malloc(W * H * sizeof *di);
    uint8_t *sp_ = malloc(W * H), *si = malloc(W * H);
    hz_scene_params sp = {.patches = pl.data, .patch_count = (uint32_t)pl.count}; /* morph_scale 0 */
    draw_depth_sky(c, &cam, &sp, NULL, 0, NULL, dp, sp_);
    draw_depth_sky(c, &cam, NULL, kept.data, (uint32_t)kept.count, NULL, di, si);
    size_t ground = 0, depth_off = 0, sky_off = 0, changed = 0;
    for (size_t k = 0; k < (size_t)W * H; k++) {
        ground += !si[k];
        sky_off += sp_[k] != si[k];
        depth_off += depth_differs(dp[k], di[k]);
    }
    /* the whole patches, for comparison */
    for (size_t k = 0; k < pl.count; k++)
        pl.data[k].hidden = 0;
    draw_depth_sky(c, &cam, &sp, NULL, 0, NULL, di, si);
    for (size_t k = 0; k < (size_t)W * H; k++)
        changed += depth_differs(dp[k], di[k]);
    fprintf(stderr,
            "patches with hidden blocks vs the triangles left: %zu of %zu ground pixels at another depth, %zu sky "
            "pixels differ; %zu pixels differ from the whole patches\n",
            depth_off, ground, sky_off, changed);
    assert_true(ground > (size_t)W * H / 10);
    assert_true(sky_off * 2000 <= (size_t)W * H);
    assert_true(depth_off * 1000 <= ground);
    assert_true(changed > (size_t)W * H / 10);
    free(dp);
    free(di);
    free(sp_);
    free(si);
    free(il.data);
    free(one.data);
    free(kept.data);
    free(pl.data);
}

/* 8-cell patches (4 x 4 blocks of 2 cells) and 4-cell ones (2 x 2 blocks of
 * 2 cells). */
static void test_patch_hidden_blocks_not_drawn(void **state)
{
    ctx *c = *state;
    hidden_blocks_case(c, c->t->lod, 4);
    hz_err err = {0};
    hz_lod *lod4 = hz_lod_create(
        &(hz_lod_desc){.hm = &c->t->hm, .spacing = c->t->spacing, .zscale = c->t->zscale, .patch_cells = 4}, &err);
    assert_non_null(lod4);
    hidden_blocks_case(c, lod4, 2);
    /* the terrain's own patches for the tests after this one */
    assert_int_equal(hz_renderer_set_cdlod(c->r, c->t->lod, NULL, &err), HZ_OK);
    hz_lod_destroy(lod4);
}

/* Patches over samples without data: a triangle touching one is not drawn
 * (the patch shader clips it away rather than discarding its fragments,
 * which would cost llvmpipe its early depth test). The frame is that of the
 * same patches expanded to triangles without those touching a hole, and the
 * holes show: without the mask the frame differs. */
static void test_patches_skip_missing_data(void **state)
{
    ctx *c = *state;
    hz_err err = {0};
    hz_camera cam;
    hz_index_list il = {0};
    hz_patch_list pl = {0};
    hz_lod_stats st;
    cdlod_frame(c, 1.0f, NULL, &cam, &pl, &il, &st);
    const uint32_t n = c->t->hm.size;
    uint8_t *valid = malloc((size_t)n * n);
    for (uint32_t j = 0; j < n; j++)
        for (uint32_t i = 0; i < n; i++)
            valid[(size_t)j * n + i] = (i / 48 + 2 * (j / 48)) % 3 != 0; /* a third of 48-sample squares */
    size_t kept = 0;
    for (size_t k = 0; k < il.count; k += 3)
        if (valid[il.data[k]] && valid[il.data[k + 1]] && valid[il.data[k + 2]]) {
            memmove(il.data + kept, il.data + k, 3 * sizeof *il.data);
            kept += 3;
        }
    /* depths and sky masks: with the mask (patches, triangles), without it */
    float *dp = malloc(3 * W * H * sizeof *dp), *di = dp + W * H, *du = di + W * H;
    uint8_t *sp_ = malloc(3 * W * H), *si = sp_ + W * H, *su = si + W * H;
    hz_scene_params sp = {.patches = pl.data, .patch_count = (uint32_t)pl.count}; /* morph_scale 0 */
    draw_depth_sky(c, &cam, &sp, NULL, 0, NULL, du, su); /* without the mask */
    assert_int_equal(hz_renderer_set_cdlod(c->r, c->t->lod, valid, &err), HZ_OK);
    draw_depth_sky(c, &cam, &sp, NULL, 0, NULL, dp, sp_); /* with it */
    draw_depth_sky(c, &cam, NULL, il.data, (uint32_t)kept, NULL, di, si);
    size_t ground = 0, depth_off = 0, sky_off = 0, holes = 0, unmasked = 0;
    for (size_t k = 0; k < (size_t)W * H; k++) {
        ground += !si[k];
        unmasked += !su[k];
        sky_off += sp_[k] != si[k];
        depth_off += !si[k] && depth_differs(dp[k], di[k]);
        holes += su[k] != sp_[k] || depth_differs(du[k], dp[k]);
    }
    fprintf(stderr,
            "patches over holes vs triangles without them: %zu of %zu ground pixels at another depth, %zu sky pixels "
            "differ; the holes change %zu of the %zu ground pixels without them\n",
            depth_off, ground, sky_off, holes, unmasked);
    assert_true(unmasked > (size_t)W * H / 5);
    assert_true(holes * 4 >= unmasked); /* the holes are in view */
    assert_true(sky_off * 2000 <= (size_t)W * H);
    assert_true(depth_off * 1000 <= ground);
    assert_int_equal(hz_renderer_set_cdlod(c->r, c->t->lod, NULL, &err), HZ_OK);
    free(valid);
    free(dp);
    free(sp_);
    free(il.data);
    free(pl.data);
}

/* hz_lod_horizon_hide's arguments, run as a job. */
typedef struct late_arg {
    hz_lod *lod;
    const hz_camera *cam;
    const hz_lod_params *p;
    const hz_lod_stats *sel;
    const hz_patch_list *pl;
    size_t from;
    uint8_t *hidden;
    uint16_t *blocks;
    hz_horizon_stats *hs;
    hz_result res;
    unsigned sleep_ms; /* first (late_all: then every patch from `from` on is hidden) */
} late_arg;

static void late_hide(void *arg)
{
    late_arg *a = arg;
    a->res = hz_lod_horizon_hide(a->lod, a->cam, a->p, a->sel, a->pl->data, a->pl->count, a->from, a->hidden,
                                 a->blocks, a->hs);
}

/* After a pause, every patch from `from` on hidden. */
static void late_all(void *arg)
{
    late_arg *a = arg;
    usleep(a->sleep_ms * 1000u);
    memset(a->hidden, 0, a->pl->count);
    memset(a->hidden + a->from, 1, a->pl->count - a->from);
}

/* The renderer draws the nearest patches (hz_renderer_patch_lead), then
 * waits for the late cull's job before it reads its flags: a job that takes
 * its time and then hides every later patch leaves the frame of those
 * nearest patches alone (colour and depth), and the draw says it waited and
 * left the others out. */
static void test_late_cull_waited_for(void **state)
{
    ctx *c = *state;
    hz_err err = {0};
    hz_camera cam;
    hz_index_list il = {0};
    hz_patch_list pl = {0};
    hz_lod_stats st;
    cdlod_frame_all(c, 0.5f, NULL, true, &cam, &pl, &il, &st);
    const uint32_t n = (uint32_t)pl.count, lead = hz_renderer_patch_lead(n);
    fprintf(stderr, "%u patches, the first %u before the wait\n", n, lead);
    assert_true(lead > 0 && lead * 5 < n);
    uint8_t *hid = calloc(n, 1), *rgb = malloc(2 * W * H * 3);
    float *dep = malloc(2 * W * H * sizeof *dep);
    late_arg la = {.pl = &pl, .from = lead, .hidden = hid, .sleep_ms = 60};
    hz_job job = {0};
    hz_job_start(&job, late_all, &la);
    hz_scene_params sp = {.patches = pl.data, .patch_count = n, .patch_late_job = &job, .patch_late_hidden = hid};
    hz_draw_stats ds;
    assert_int_equal(hz_renderer_draw(c->r, &cam, &sp, NULL, 0, &ds, &err), HZ_OK);
    assert_false(job.running);
    fprintf(stderr, "late: %u left out, waited %.1f ms\n", ds.late_hidden, ds.late_wait_ms);
    assert_int_equal(ds.late_hidden, n - lead);
    assert_true(ds.late_wait_ms > 10.0);
    assert_int_equal(hz_renderer_read_rgb(c->r, rgb, &err), HZ_OK);
    assert_int_equal(hz_renderer_read_depth(c->r, dep, &err), HZ_OK);
    hz_scene_params first = {.patches = pl.data, .patch_count = lead};
    assert_int_equal(hz_renderer_draw(c->r, &cam, &first, NULL, 0, &ds, &err), HZ_OK);
    assert_int_equal(ds.late_hidden, 0);
    assert_int_equal(hz_renderer_read_rgb(c->r, rgb + W * H * 3, &err), HZ_OK);
    assert_int_equal(hz_renderer_read_depth(c->r, dep + W * H, &err), HZ_OK);
    size_t off = 0, ground = 0;
    for (size_t q = 0; q < (size_t)W * H * 3; q++)
        off += rgb[q] != rgb[W * H * 3 + q];
    for (size_t q = 0; q < (size_t)W * H; q++) {
        off += dep[q] != dep[W * H + q];
        ground += dep[q] != 0.0f;
    }
    assert_int_equal(off, 0);
    assert_true(ground > 1000); /* the nearest patches show */
    /* and the full frame has more ground: the later patches were left out */
    sp = (hz_scene_params){.patches = pl.data, .patch_count = n};
    assert_int_equal(hz_renderer_draw(c->r, &cam, &sp, NULL, 0, &ds, &err), HZ_OK);
    assert_int_equal(hz_renderer_read_depth(c->r, dep, &err), HZ_OK);
    size_t full = 0;
    for (size_t q = 0; q < (size_t)W * H; q++)
        full += dep[q] != 0.0f;
    fprintf(stderr, "ground pixels: %zu nearest patches, %zu all patches\n", ground, full);
    assert_true(full > ground + ground / 10);
    free(hid);
    free(rgb);
    free(dep);
    free(il.data);
    free(pl.data);
}

/* Horizon culling drops the patches that nearer ground hides, and only
 * those: low over the ridges, looking across them at several headings and
 * bounds, and at the summit from the default camera, the frame with the hidden patches dropped equals the frame with
 * every patch, colour and depth, pixel for pixel (morphing on: the culling
 * allows for how far a morphing vertex may leave the samples), while a
 * good share of the patches is dropped. */
static void test_horizon_culling_hides_nothing(void **state)
{
    ctx *c = *state;
    hz_err err = {0};
    hz_terrain *t = c->t;
    assert_int_equal(hz_lod_prepare(t->lod, HZ_LOD_CDLOD), HZ_OK);
    assert_int_equal(hz_renderer_set_cdlod(c->r, t->lod, NULL, &err), HZ_OK);
    const float side = t->spacing * (float)(t->hm.size - 1);
    uint8_t *rgb = malloc(2 * W * H * 3);
    float *dep = malloc(2 * W * H * sizeof *dep);
    hz_patch_list pl[2] = {{0}, {0}};
    size_t all = 0, hidden = 0, views = 0, hiding = 0, late_total = 0, near_half = 0, late_blocks = 0;
    for (int k = 0; k < 16; k++) {
        hz_camera cam = hz_terrain_default_camera(t, W, H);
        if (k < 12) { /* low over the ridges, all around */
            cam.pos[0] = side * (0.2f + 0.05f * (float)k);
            cam.pos[2] = side * (0.75f - 0.04f * (float)k);
            cam.pos[1] = hz_terrain_height_at(t, cam.pos[0], cam.pos[2]) +
                         (k % 3 == 0 ? 15.0f : 60.0f + 40.0f * (float)(k % 4));
            cam.yaw = 30.0f * (float)k;
            cam.pitch = (float)(k % 5) - 3.0f;
        } else { /* the default view of the summit, from above to level */
            cam.pitch = -15.0f + 5.0f * (float)(k - 12);
        }
        const float tau = k % 2 || k >= 12 ? 1.0f : 2.5f;
        hz_lod_stats st[2];
        for (int v = 0; v < 2; v++) {
            hz_lod_params p = {.mode = HZ_LOD_CDLOD, .pixel_error = tau, .viewport_height = H, .horizon_cull = !v};
            assert_int_equal(hz_lod_select_patches(t->lod, &cam, &p, &pl[v], &st[v]), HZ_OK);
            hz_scene_params sp = {.morph_scale = st[v].morph_scale, .morph_start = st[v].morph_start,
                                  .patches = pl[v].data, .patch_count = (uint32_t)pl[v].count};
            assert_int_equal(hz_renderer_draw(c->r, &cam, &sp, NULL, 0, NULL, &err), HZ_OK);
            assert_int_equal(hz_renderer_read_rgb(c->r, rgb + (size_t)v * W * H * 3, &err), HZ_OK);
            assert_int_equal(hz_renderer_read_depth(c->r, dep + (size_t)v * W * H, &err), HZ_OK);
        }
        /* The late cull (hz_lod_horizon_hide on a job while the renderer
         * draws the nearest patches): the same frame again, every patch from
         * the renderer's lead on that the cull in the selection drops left
         * out, and hidden quadrants of others, and only those. */
        {
            const uint32_t lead = hz_renderer_patch_lead((uint32_t)pl[1].count);
            uint8_t *hid = malloc(pl[1].count + 1), *all_hid = malloc(pl[1].count + 1);
            uint16_t *blk = malloc((pl[1].count + 1) * sizeof *blk);
            hz_horizon_stats hs, hs0;
            const hz_lod_params lp = {.mode = HZ_LOD_CDLOD, .pixel_error = tau, .viewport_height = H};
            late_arg la = {.lod = t->lod, .cam = &cam, .p = &lp, .sel = &st[1], .pl = &pl[1], .from = lead,
                           .hidden = hid, .blocks = blk, .hs = &hs, .res = HZ_ERR_VALUE};
            hz_job job = {0};
            hz_job_start(&job, late_hide, &la);
            hz_scene_params sp = {.morph_scale = st[1].morph_scale, .morph_start = st[1].morph_start,
                                  .patches = pl[1].data, .patch_count = (uint32_t)pl[1].count,
                                  .patch_late_job = &job, .patch_late_hidden = hid, .patch_late_blocks = blk};
            hz_draw_stats ds;
            assert_int_equal(hz_renderer_draw(c->r, &cam, &sp, NULL, 0, &ds, &err), HZ_OK);
            assert_false(job.running); /* the renderer waited */
            assert_int_equal(la.res, HZ_OK);
            uint8_t *late_rgb = malloc(W * H * 3);
            float *late_dep = malloc(W * H * sizeof *late_dep);
            assert_int_equal(hz_renderer_read_rgb(c->r, late_rgb, &err), HZ_OK);
            assert_int_equal(hz_renderer_read_depth(c->r, late_dep, &err), HZ_OK);
            size_t late_off = 0;
            for (size_t q = 0; q < (size_t)W * H * 3; q++)
                late_off += late_rgb[q] != rgb[(size_t)W * H * 3 + q];
            for (size_t q = 0; q < (size_t)W * H; q++)
                late_off += late_dep[q] != dep[(size_t)W * H + q];
            assert_int_equal(late_off, 0);
            /* from 0 on, the late cull hides what the selection's drops */
            assert_int_equal(hz_lod_horizon_hide(t->lod, &cam, la.p, &st[1], pl[1].data, pl[1].count, 0, all_hid,
                                                 NULL, &hs0),
                             HZ_OK);
            assert_int_equal(hs0.patches, st[0].hidden);
            assert_int_equal(hs0.triangles, st[1].triangles - st[0].triangles);
            size_t before = 0, marked = 0, with_blocks = 0;
            for (size_t i = 0; i < pl[1].count; i++) {
                assert_true(hid[i] == (i >= lead && all_hid[i]));
                assert_true(blk[i] == 0 || (i >= lead && !hid[i])); /* quadrants only of the drawn, late */
                before += i < lead && all_hid[i];
                marked += hid[i];
                with_blocks += blk[i] != 0;
            }
            assert_true(hs.quadrants >= with_blocks && hs.quadrants <= 3 * with_blocks);
            late_blocks += with_blocks;
            assert_int_equal(hs.patches, marked);
            assert_int_equal(ds.late_hidden, marked);
            assert_int_equal(marked + before, st[0].hidden);
            late_total += marked;
            /* from the middle on: none of the nearer half, whatever hides it */
            const size_t half = pl[1].count / 2;
            assert_int_equal(hz_lod_horizon_hide(t->lod, &cam, la.p, &st[1], pl[1].data, pl[1].count, half, hid,
                                                 NULL, &hs0),
                             HZ_OK);
            for (size_t i = 0; i < pl[1].count; i++) {
                assert_true(hid[i] == (i >= half && all_hid[i]));
                near_half += i < half && all_hid[i];
            }
            free(late_rgb);
            free(late_dep);
            free(hid);
            free(all_hid);
            free(blk);
        }
        /* the same selection, less the hidden patches, in the same order */
        assert_int_equal(st[1].hidden, 0);
        assert_int_equal(pl[0].count + st[0].hidden, pl[1].count);
        assert_int_equal(st[0].leaves + st[0].hidden, st[1].leaves);
        size_t j = 0;
        for (size_t i = 0; i < pl[1].count && j < pl[0].count; i++)
            j += pl[1].data[i].x0 == pl[0].data[j].x0 && pl[1].data[i].z0 == pl[0].data[j].z0 &&
                 pl[1].data[i].level == pl[0].data[j].level;
        assert_int_equal(j, pl[0].count);
        size_t off = 0;
        for (size_t q = 0; q < (size_t)W * H * 3; q++)
            off += rgb[q] != rgb[(size_t)W * H * 3 + q];
        for (size_t q = 0; q < (size_t)W * H; q++)
            off += dep[q] != dep[(size_t)W * H + q];
        fprintf(stderr, "view %d (tau %.1f, %.0f m up): %u of %zu patches hidden, %zu values differ\n", k,
                (double)tau, (double)(cam.pos[1] - hz_terrain_height_at(t, cam.pos[0], cam.pos[2])), st[0].hidden,
                pl[1].count, off);
        if (off)
            hz_image_write_png(HZ_TEST_TMP "/frame_horizon_culled.png", rgb, W, H, NULL);
        assert_int_equal(off, 0);
        all += pl[1].count;
        hidden += st[0].hidden;
        views++;
        hiding += st[0].hidden > 0;
    }
    fprintf(stderr, "horizon culling: %zu of %zu patches hidden over %zu views (%zu by the late cull, which hid "
            "quadrants of %zu more)\n", hidden, all, views, late_total, late_blocks);
    assert_true(late_blocks * 20 >= late_total); /* the quadrants hide some more */
    assert_true(late_total * 2 >= hidden); /* most lie beyond the lead */
    assert_true(near_half > 0);          /* (the `from` test above had some to leave) */
    assert_true(hiding >= views / 2);
    assert_true(hidden * 10 >= all); /* at least a tenth */
    free(pl[0].data);
    free(pl[1].data);
    free(rgb);
    free(dep);
}

/* The plain sky skips the cells of its grid that a CPU occlusion buffer
 * certainly covers: with the frame's own terrain triangles as occluders,
 * looking level at the ridges, a good part of the grid is skipped and the
 * frame is the same, pixel for pixel. */
static void test_sky_skips_covered_cells(void **state)
{
    ctx *c = *state;
    hz_err err = {0};
    hz_camera cam = hz_terrain_default_camera(c->t, W, H);
    cam.pos[1] = hz_terrain_height_at(c->t, cam.pos[0], cam.pos[2]) + 20.0f; /* low, among the hills */
    cam.pitch = 0;
    hz_index_list il = {0};
    hz_lod_stats st;
    assert_int_equal(hz_lod_select(c->t->lod, &cam, &(hz_lod_params){.c = 8, .c2 = 8}, &il, NULL, NULL, &st), HZ_OK);
    uint8_t *a = malloc(W * H * 3), *b = malloc(W * H * 3), *sky = malloc(W * H);
    hz_draw_stats da, db;
    assert_int_equal(hz_renderer_draw(c->r, &cam, NULL, il.data, (uint32_t)il.count, &da, &err), HZ_OK);
    assert_int_equal(hz_renderer_read_rgb(c->r, a, &err), HZ_OK);
    assert_int_equal(hz_renderer_read_sky_mask(c->r, sky, &err), HZ_OK);
    hz_occlusion o;
    assert_true(hz_occlusion_init(&o, 0, 0));
    hz_occlusion_begin(&o, &cam);
    const uint32_t n = c->t->hm.size;
    float *tri = malloc(il.count * 3 * sizeof *tri);
    for (size_t k = 0; k < il.count; k++) {
        const float x = (float)(il.data[k] % n) * c->t->spacing, z = (float)(il.data[k] / n) * c->t->spacing;
        tri[3 * k] = x;
        tri[3 * k + 1] = hz_terrain_height_at(c->t, x, z);
        tri[3 * k + 2] = z;
    }
    hz_occlusion_rasterize(&o, tri, il.count / 3, NULL);
    hz_scene_params sp = {.sky_occluders = &o};
    assert_int_equal(hz_renderer_draw(c->r, &cam, &sp, il.data, (uint32_t)il.count, &db, &err), HZ_OK);
    assert_int_equal(hz_renderer_read_rgb(c->r, b, &err), HZ_OK);
    size_t sky_px = 0, off = 0;
    for (size_t k = 0; k < (size_t)W * H; k++) {
        sky_px += sky[k];
        off += memcmp(a + 3 * k, b + 3 * k, 3) != 0;
    }
    fprintf(stderr, "sky cells drawn: %u of %u with the terrain as occluders (%u without); %zu sky pixels, %zu differ\n",
            db.sky_cells, HZ_SKY_COLS * HZ_SKY_ROWS, da.sky_cells, sky_px, off);
    assert_int_equal(da.sky_cells, HZ_SKY_COLS * HZ_SKY_ROWS);
    assert_true(db.sky_cells * 10 <= da.sky_cells * 9); /* a tenth of the grid skipped at least */
    assert_true(sky_px * 20 >= (size_t)W * H);           /* and sky left to draw */
    assert_int_equal(off, 0);
    hz_occlusion_free(&o);
    free(tri);
    free(a);
    free(b);
    free(sky);
    free(il.data);
}

/* With the ground detail on, the patches entirely beyond its fade are drawn
 * by a variant without its texture fetches: the picture is that of the same
 * patches expanded to triangles, whose shader works the detail out (faded to
 * nothing there) for every pixel. */
static void test_far_patches_keep_the_detail_colour(void **state)
{
    ctx *c = *state;
    hz_err err = {0};
    hz_camera cam;
    hz_index_list il = {0};
    hz_patch_list pl = {0};
    hz_lod_stats st;
    /* 60 m over the middle of the map, looking north along the ground: full
     * detail near, the fade (450 m to 2.7 km at the default 3 m scale) and
     * beyond it in view. */
    hz_camera at = hz_terrain_default_camera(c->t, W, H);
    at.pos[0] = at.pos[2] = 0.5f * c->t->spacing * (float)(c->t->hm.size - 1);
    at.pos[1] = hz_terrain_height_at(c->t, at.pos[0], at.pos[2]) + 60.0f;
    at.yaw = 0;
    at.pitch = -4;
    cdlod_frame_all(c, 1.0f, &at, true, &cam, &pl, &il, &st); /* the far patches too, hidden or not */
    uint8_t *a = malloc(W * H * 3), *b = malloc(W * H * 3), *sky = malloc(W * H);
    /* A high sun: the ground bright enough for its detail to show. */
    hz_scene_params sp = {.patches = pl.data, .patch_count = (uint32_t)pl.count, .effects = HZ_FX_DETAIL,
                          .sun_dir = {0.3f, 0.9f, 0.3f}};
    hz_draw_stats ds;
    assert_int_equal(hz_renderer_draw(c->r, &cam, &sp, NULL, 0, &ds, &err), HZ_OK);
    assert_int_equal(hz_renderer_read_rgb(c->r, a, &err), HZ_OK);
    hz_image_write_png(HZ_TEST_TMP "/frame_far_detail.png", a, W, H, NULL);
    hz_scene_params si = {.effects = HZ_FX_DETAIL, .sun_dir = {0.3f, 0.9f, 0.3f}};
    assert_int_equal(hz_renderer_draw(c->r, &cam, &si, il.data, (uint32_t)il.count, NULL, &err), HZ_OK);
    assert_int_equal(hz_renderer_read_rgb(c->r, b, &err), HZ_OK);
    assert_int_equal(hz_renderer_read_sky_mask(c->r, sky, &err), HZ_OK);
    size_t ground = 0, off = 0;
    for (size_t k = 0; k < (size_t)W * H; k++) {
        if (sky[k])
            continue;
        ground++;
        int d = 0;
        for (int ch = 0; ch < 3; ch++)
            d = abs(a[3 * k + ch] - b[3 * k + ch]) > d ? abs(a[3 * k + ch] - b[3 * k + ch]) : d;
        off += d > 0;
    }
    fprintf(stderr, "%u of %zu patches beyond the detail's fade; %zu of %zu ground pixels differ\n", ds.far_patches,
            pl.count, off, ground);
    assert_true(ds.far_patches * 4 >= pl.count); /* a good part of the frame is far */
    assert_true(ds.far_patches < pl.count);      /* and some is near */
    assert_true(ground > (size_t)W * H / 5);
    /* Not one level off: with the split at half the fade distance, 6 951
     * pixels of the fade band differ by one or two levels. */
    assert_true(off * 10000 <= ground);
    free(a);
    free(b);
    free(sky);
    free(il.data);
    free(pl.data);
}

/* Issue 15: the default camera frames the highest ground, wherever it is:
 * a cone in the south-west corner of a 257^2 map (the old camera above the
 * middle, looking north-north-east, never saw it) sits near the middle of the
 * image, the eye above it; the flyover passes over it. */
static void test_default_camera_frames_the_summit(void **state)
{
    (void)state;
    hz_err err = {0};
    hz_grid g;
    const uint32_t n = 257;
    assert_int_equal(hz_grid_alloc(&g, n, n, &err), HZ_OK);
    const float ci = 0.2f * (float)(n - 1), cj = 0.8f * (float)(n - 1);
    for (uint32_t j = 0; j < n; j++)
        for (uint32_t i = 0; i < n; i++) {
            const float d = hypotf((float)i - ci, (float)j - cj);
            g.z[(size_t)j * n + i] = 100.0f + fmaxf(0.0f, 900.0f - 30.0f * d) + 5.0f * sinf(0.3f * (float)i);
        }
    const char *path = HZ_TEST_TMP "/cone_sw.png";
    assert_int_equal(hz_dem_write_png16(path, &g, 0.0f, 1200.0f, &err), HZ_OK);
    hz_grid_free(&g);
    hz_terrain *t = hz_terrain_create(&(hz_terrain_desc){.dem_path = path, .spacing = 10.0f,
                                                        .height_min = 0.0f, .height_max = 1200.0f},
                                      &err);
    assert_non_null(t);
    float fx, fz, fh;
    hz_terrain_focus(t, &fx, &fz, &fh);
    assert_true(fabsf(fx - ci * 10.0f) < 15.0f && fabsf(fz - cj * 10.0f) < 15.0f);
    assert_true(fabsf(fh - 1000.0f) < 10.0f); /* the height range mapped 0..65535 to 0..1200 m */
    hz_camera cam = hz_terrain_default_camera(t, W, H);
    assert_true(cam.pos[1] > fh);
    mat4 vp;
    hz_camera_viewproj(&cam, vp);
    vec4 top = {fx, fh, fz, 1.0f}, clip;
    glm_mat4_mulv(vp, top, clip);
    assert_true(clip[3] > 0.0f);
    const float sx = clip[0] / clip[3], sy = clip[1] / clip[3];
    fprintf(stderr, "summit on screen at (%.2f, %.2f), camera %.0f,%.0f,%.0f yaw %.1f pitch %.1f\n", (double)sx,
            (double)sy, (double)cam.pos[0], (double)cam.pos[1], (double)cam.pos[2], (double)cam.yaw,
            (double)cam.pitch);
    assert_true(fabsf(sx) < 0.3f && sy > -0.1f && sy < 0.8f);
    hz_path fly;
    assert_int_equal(hz_terrain_path(t, "flyover", &fly, &err), HZ_OK);
    float closest = INFINITY;
    for (int k = 0; k <= 600; k++) {
        hz_camera pc;
        hz_path_sample(&fly, 60.0f * (float)k / 600.0f, &pc);
        closest = fminf(closest, hypotf(pc.pos[0] - fx, pc.pos[2] - fz));
    }
    assert_true(closest < 100.0f);
    hz_path_free(&fly);
    hz_terrain_destroy(t);
}

/* Uploads every decoded tile waiting. */
static void upload_ready(hz_stream *s, hz_renderer *r)
{
    uint32_t slot;
    const uint16_t *tex;
    hz_err err = {0};
    while (hz_stream_next_upload(s, &slot, &tex)) {
        assert_int_equal(hz_renderer_stream_upload(r, slot, tex, &err), HZ_OK);
        hz_stream_uploaded(s, slot);
    }
}

/* Selects at the stream's clock t and draws; returns the patches with a
 * tile that just arrived (slide 255). */
static uint32_t stream_frame(hz_stream *s, hz_renderer *r, const hz_camera *cam, double t, uint8_t *sky,
                             uint8_t *rgb, uint32_t *sliding)
{
    hz_patch_list pl = {0};
    hz_lod_stats st;
    hz_err err = {0};
    hz_stream_set_clock(s, t);
    assert_int_equal(hz_stream_select(s, cam, &(hz_lod_params){.mode = HZ_LOD_CDLOD, .pixel_error = 1.0f,
                                                               .viewport_height = H},
                                      &pl, &st),
                     HZ_OK);
    uint32_t fresh = 0, part = 0;
    for (size_t k = 0; k < pl.count; k++) {
        fresh += pl.data[k].slide == 255;
        part += pl.data[k].slide > 0;
    }
    hz_scene_params sp = {.patches = pl.data, .patch_count = (uint32_t)pl.count, .morph_scale = st.morph_scale,
                          .morph_start = st.morph_start};
    assert_int_equal(hz_renderer_draw(r, cam, &sp, NULL, 0, NULL, &err), HZ_OK);
    assert_int_equal(hz_renderer_read_sky_mask(r, sky, &err), HZ_OK);
    if (rgb)
        assert_int_equal(hz_renderer_read_rgb(r, rgb, &err), HZ_OK);
    free(pl.data);
    if (sliding)
        *sliding = part;
    return fresh;
}

/* Mean absolute difference of two RGB frames, 0..255, beyond one level: a
 * channel one level off is the same colour rounded the other way (the fog
 * factor, interpolated from the vertices, moves in the fifth decimal when
 * the tessellation changes), not a change anyone sees. */
static double rgb_diff(const uint8_t *a, const uint8_t *b)
{
    double s = 0;
    for (size_t k = 0; k < (size_t)W * H * 3; k++) {
        const int d = abs((int)a[k] - (int)b[k]);
        s += d > 1 ? d - 1 : 0;
    }
    return s / ((double)W * H * 3);
}

/* Per-channel differences of two RGB frames over the ground (sky mask 0):
 * the mean and how many pixels differ by more than over in some channel. */
static double ground_diff(const uint8_t *a, const uint8_t *b, const uint8_t *sky, int over, size_t *ground,
                          size_t *off)
{
    double sum = 0;
    *ground = *off = 0;
    for (size_t k = 0; k < (size_t)W * H; k++) {
        if (sky[k])
            continue;
        int m = 0;
        for (int ch = 0; ch < 3; ch++) {
            const int d = abs((int)a[3 * k + ch] - (int)b[3 * k + ch]);
            sum += d;
            m = d > m ? d : m;
        }
        ++*ground;
        *off += m > over;
    }
    return *ground ? sum / (3.0 * (double)*ground) : 0.0;
}

/* The plain terrain reads its colour from the lit map, baked per sample by
 * the shading it replaces: the frame is that of per-pixel shading (the map
 * holds the full-resolution surface's colour, the mesh a LOD's), for index
 * lists and patches alike. When the sun moves, the next frame is shaded per
 * pixel and the one after bakes the map again: it matches per-pixel shading
 * in the new light, not the old map. */
static void test_lit_map_matches_per_pixel_shading(void **state)
{
    ctx *c = *state;
    hz_err err = {0};
    hz_camera cam;
    hz_index_list il = {0};
    hz_patch_list pl = {0};
    hz_lod_stats st;
    cdlod_frame(c, 1.0f, NULL, &cam, &pl, &il, &st);
    uint8_t *pix = malloc(W * H * 3), *lit = malloc(W * H * 3), *sky = malloc(W * H);
    /* Unit vectors, neither the default sun. */
    const float suns[2][3] = {{-0.48f, 0.60f, 0.64f}, {0.60f, 0.48f, -0.64f}};
    hz_scene_params base = {0};
    memcpy(base.sun_dir, suns[0], sizeof base.sun_dir);
    /* Whatever the frames before drew, the map holds sun 0 after these two. */
    for (int k = 0; k < 2; k++)
        assert_int_equal(hz_renderer_draw(c->r, &cam, &base, il.data, (uint32_t)il.count, NULL, &err), HZ_OK);
    for (int s = 0; s < 2; s++) {
        for (int patches = 0; patches < 2; patches++) {
            hz_scene_params sp = {.no_lit_map = true};
            memcpy(sp.sun_dir, suns[s], sizeof sp.sun_dir);
            if (patches) {
                sp.patches = pl.data;
                sp.patch_count = (uint32_t)pl.count;
                sp.morph_scale = st.morph_scale;
                sp.morph_start = st.morph_start;
            }
            const uint32_t *idx = patches ? NULL : il.data;
            const uint32_t cnt = patches ? 0 : (uint32_t)il.count;
            hz_draw_stats ds;
            assert_int_equal(hz_renderer_draw(c->r, &cam, &sp, idx, cnt, &ds, &err), HZ_OK);
            assert_false(ds.lit_map);
            assert_int_equal(hz_renderer_read_rgb(c->r, pix, &err), HZ_OK);
            assert_int_equal(hz_renderer_read_sky_mask(c->r, sky, &err), HZ_OK);
            sp.no_lit_map = false;
            const bool moved = s == 1 && !patches;
            if (moved) {
                /* The sun moved since the last frame: per pixel, no bake. */
                assert_int_equal(hz_renderer_draw(c->r, &cam, &sp, idx, cnt, &ds, &err), HZ_OK);
                assert_false(ds.lit_map);
                assert_true(ds.lit_bake_ms == 0.0);
            }
            assert_int_equal(hz_renderer_draw(c->r, &cam, &sp, idx, cnt, &ds, &err), HZ_OK);
            assert_true(ds.lit_map);
            /* Baked once the new sun held still, then read as it is. */
            assert_true((ds.lit_bake_ms > 0.0) == moved);
            assert_int_equal(hz_renderer_read_rgb(c->r, lit, &err), HZ_OK);
            size_t ground, off8;
            const double mean = ground_diff(pix, lit, sky, 8, &ground, &off8);
            fprintf(stderr, "lit map, sun %d, %s: mean difference %.3f of 255, %zu of %zu ground pixels off by > 8\n",
                    s, patches ? "patches" : "indices", mean, off8, ground);
            assert_true(ground > (size_t)W * H / 4);
            assert_true(mean < 1.0);
            assert_true(off8 * 200 < ground);
        }
    }
    /* The other sun's map is another picture (what the bounds above tell apart). */
    hz_scene_params sp = {.no_lit_map = true};
    memcpy(sp.sun_dir, suns[0], sizeof sp.sun_dir);
    assert_int_equal(hz_renderer_draw(c->r, &cam, &sp, il.data, (uint32_t)il.count, NULL, &err), HZ_OK);
    assert_int_equal(hz_renderer_read_rgb(c->r, pix, &err), HZ_OK);
    size_t ground, off8;
    const double mean = ground_diff(pix, lit, sky, 8, &ground, &off8);
    fprintf(stderr, "per-pixel sun 0 against the lit map of sun 1: mean difference %.3f, %zu pixels off by > 8\n",
            mean, off8);
    assert_true(mean > 5.0);
    free(pix);
    free(lit);
    free(sky);
    free(il.data);
    free(pl.data);
}

/* --lit-map vertex: the patches read the lit map per vertex and interpolate
 * it. The frame is close to the per-pixel read of the same map (the colour
 * is the map's, at the right samples and mip levels) but not equal to it
 * (Gouraud between the vertices); index lists keep the per-pixel read. */
static void test_lit_map_per_vertex(void **state)
{
    ctx *c = *state;
    hz_err err = {0};
    hz_camera cam;
    hz_index_list il = {0};
    hz_patch_list pl = {0};
    hz_lod_stats st;
    cdlod_frame(c, 1.0f, NULL, &cam, &pl, &il, &st);
    uint8_t *pix = malloc(W * H * 3), *vtx = malloc(W * H * 3), *sky = malloc(W * H);
    hz_scene_params sp = {.patches = pl.data, .patch_count = (uint32_t)pl.count, .morph_scale = st.morph_scale,
                          .morph_start = st.morph_start};
    hz_draw_stats ds;
    for (int k = 0; k < 2; k++) /* the map baked for this light */
        assert_int_equal(hz_renderer_draw(c->r, &cam, &sp, NULL, 0, &ds, &err), HZ_OK);
    assert_true(ds.lit_map);
    assert_false(ds.lit_per_vertex);
    assert_int_equal(hz_renderer_read_rgb(c->r, pix, &err), HZ_OK);
    assert_int_equal(hz_renderer_read_sky_mask(c->r, sky, &err), HZ_OK);
    sp.lit_per_vertex = true;
    assert_int_equal(hz_renderer_draw(c->r, &cam, &sp, NULL, 0, &ds, &err), HZ_OK);
    assert_true(ds.lit_map);
    assert_true(ds.lit_per_vertex);
    assert_int_equal(hz_renderer_read_rgb(c->r, vtx, &err), HZ_OK);
    size_t ground, off8, off2;
    const double mean = ground_diff(pix, vtx, sky, 8, &ground, &off8);
    ground_diff(pix, vtx, sky, 2, &ground, &off2);
    fprintf(stderr, "lit map per vertex against per pixel: mean difference %.3f of 255, %zu / %zu / %zu ground "
            "pixels off by > 2 / > 8 / any\n", mean, off2, off8, ground);
    assert_true(ground > (size_t)W * H / 4);
    /* (The mip level by the patch's vertex spacing instead of the distance
     * gives a mean of 1.12 and 3 % off by > 8; a transposed lookup or a mip
     * level two too coarse fail too.) */
    assert_true(mean < 1.0);
    assert_true(off8 * 50 < ground);
    assert_true(off2 * 100 > ground); /* interpolated, not read per pixel */
    /* An index list is drawn reading the map per pixel, option or not. */
    hz_scene_params si = {.lit_per_vertex = true};
    assert_int_equal(hz_renderer_draw(c->r, &cam, &si, il.data, (uint32_t)il.count, &ds, &err), HZ_OK);
    assert_true(ds.lit_map);
    assert_false(ds.lit_per_vertex);
    assert_int_equal(hz_renderer_read_rgb(c->r, vtx, &err), HZ_OK);
    si.lit_per_vertex = false;
    assert_int_equal(hz_renderer_draw(c->r, &cam, &si, il.data, (uint32_t)il.count, &ds, &err), HZ_OK);
    assert_int_equal(hz_renderer_read_rgb(c->r, pix, &err), HZ_OK);
    assert_memory_equal(pix, vtx, (size_t)W * H * 3);
    free(pix);
    free(vtx);
    free(sky);
    free(il.data);
    free(pl.data);
}

/* The frame with the default lit map read (full-resolution patches over
 * smooth blocks per vertex) against every patch per pixel, on renderer r and
 * terrain t: the patches of the finest level and those drawn per vertex,
 * and the difference over the ground (mean, pixels off by > 4, by any). */
static void fine_frame(hz_renderer *r, hz_terrain *t, float pitch, uint32_t *fine, uint32_t *drawn, double *mean,
                       size_t *off4, size_t *any, size_t *ground)
{
    hz_err err = {0};
    assert_int_equal(hz_lod_prepare(t->lod, HZ_LOD_CDLOD), HZ_OK);
    assert_int_equal(hz_renderer_set_cdlod(r, t->lod, NULL, &err), HZ_OK);
    hz_camera cam = hz_terrain_default_camera(t, W, H);
    cam.pitch = pitch; /* the near ground, where the finest level lies, fills much of the view */
    hz_patch_list pl = {0};
    hz_lod_stats st;
    hz_lod_params p = {.mode = HZ_LOD_CDLOD, .pixel_error = 1.0f, .viewport_height = H};
    assert_int_equal(hz_lod_select_patches(t->lod, &cam, &p, &pl, &st), HZ_OK);
    uint32_t still = 0, both = 0;
    *fine = 0;
    for (size_t k = 0; k < pl.count; k++) {
        both += pl.data[k].still && pl.data[k].shift == 0;
        still += pl.data[k].still != 0;
        *fine += pl.data[k].shift == 0;
    }
    fprintf(stderr, "%zu patches, %u still, %u finest, %u both\n", pl.count, still, *fine, both);
    /* the frame has every kind: finest still and morphing, coarser still */
    assert_true(both > 0 && still > both && *fine > both);
    uint8_t *pix = malloc(W * H * 3), *fin = malloc(W * H * 3), *sky = malloc(W * H);
    hz_scene_params sp = {.patches = pl.data, .patch_count = (uint32_t)pl.count, .morph_scale = st.morph_scale,
                          .morph_start = st.morph_start, .lit_pixel = true};
    hz_draw_stats ds;
    for (int k = 0; k < 2; k++) /* the map baked for this light */
        assert_int_equal(hz_renderer_draw(r, &cam, &sp, NULL, 0, &ds, &err), HZ_OK);
    assert_true(ds.lit_map);
    assert_int_equal(ds.lit_vertex_patches, 0);
    assert_int_equal(hz_renderer_read_rgb(r, pix, &err), HZ_OK);
    assert_int_equal(hz_renderer_read_sky_mask(r, sky, &err), HZ_OK);
    sp.lit_pixel = false;
    assert_int_equal(hz_renderer_draw(r, &cam, &sp, NULL, 0, &ds, &err), HZ_OK);
    assert_true(ds.lit_map);
    assert_false(ds.lit_per_vertex);
    *drawn = ds.lit_vertex_patches;
    assert_int_equal(hz_renderer_read_rgb(r, fin, &err), HZ_OK);
    *mean = ground_diff(pix, fin, sky, 4, ground, off4);
    ground_diff(pix, fin, sky, 0, ground, any);
    fprintf(stderr, "%u of them per vertex; against per pixel: mean difference %.3f of 255, %zu / %zu / %zu ground "
            "pixels off by > 4 / any / in all\n", *drawn, *mean, *off4, *any, *ground);
    assert_true(*ground > (size_t)W * H / 4);
    /* --lit-map vertex: every patch */
    sp.lit_per_vertex = true;
    assert_int_equal(hz_renderer_draw(r, &cam, &sp, NULL, 0, &ds, &err), HZ_OK);
    assert_int_equal(ds.lit_vertex_patches, (uint32_t)pl.count);
    free(pix);
    free(fin);
    free(sky);
    free(pl.data);
}

/* By default the patches of the finest level (a vertex on every sample),
 * still or morphing, read the lit map per vertex where it is smooth, the
 * others per pixel: the frame is the per-pixel read's but for the
 * interpolation inside the cells, within 2 levels of 255 (lit_pixel: every
 * patch per pixel). On the rough fixture few patches qualify; drawn 20 times
 * flatter (the same patches), its map is smooth and every finest patch does. */
static void test_lit_map_fine_patches_per_vertex(void **state)
{
    ctx *c = *state;
    hz_err err = {0};
    uint32_t fine, drawn;
    double mean;
    size_t off4, any, ground;
    fine_frame(c->r, c->t, -12.0f, &fine, &drawn, &mean, &off4, &any, &ground);
    assert_true(drawn < fine / 2);
    assert_true(mean < 0.1);
    assert_true(off4 * 1000 < ground);
    assert_int_equal(hz_renderer_set_heightmap(c->r, &c->t->hm, c->t->spacing, c->t->zscale * 0.05f, &err), HZ_OK);
    fine_frame(c->r, c->t, -40.0f, &fine, &drawn, &mean, &off4, &any, &ground);
    assert_int_equal(hz_renderer_set_heightmap(c->r, &c->t->hm, c->t->spacing, c->t->zscale, &err), HZ_OK);
    assert_int_equal(drawn, fine);
    assert_true(mean < 0.1);
    assert_true(off4 * 1000 < ground);
    assert_true(any * 100 > ground); /* interpolated there, not read per pixel */
}

/* A streamed tile that arrives slides in instead of popping: the first
 * frame that draws it looks (nearly) like the frame before, and once it
 * has slid in, like the finer level. */
static void test_stream_tiles_slide_in(void **state)
{
    ctx *c = *state;
    (void)c;
    hz_err err = {0};
    char hzp[512];
    snprintf(hzp, sizeof hzp, "%s/slide.hzp", HZ_TEST_TMP);
    hz_pyr_import d = {.out = hzp, .generate = true,
                       .gen = {.kind = HZ_GEN_PERLIN, .size = 2049, .seed = 5, .amplitude = 1500.0f},
                       .spacing = 10.0, .tile_cells = 64};
    hz_pyr_import_stats ist;
    assert_int_equal(hz_pyramid_import(&d, &ist, &err), HZ_OK);
    hz_stream *s = hz_stream_create(&(hz_stream_desc){.path = hzp, .cache_bytes = 256u << 20, .synchronous = true,
                                                      .slide_seconds = 0.5f},
                                    &err);
    assert_non_null(s);
    hz_renderer *r = hz_renderer_create(&(hz_renderer_desc){.width = W, .height = H}, &err);
    assert_non_null(r);
    assert_int_equal(hz_renderer_set_stream(r, hz_stream_info(s), hz_stream_slots(s), hz_stream_texels(s), &err),
                     HZ_OK);
    upload_ready(s, r);
    const float x = 3000.0f, z = 3000.0f;
    const float g = hz_stream_height_at(s, x, z);
    assert_true(isfinite(g));
    hz_camera cam = {.pos = {x, g + 150.0f, z}, .yaw = 135.0f, .pitch = -6.0f, .fov_y = 60.0f,
                     .aspect = (float)W / (float)H, .znear = 1.0f, .zfar = 40000.0f};
    uint8_t *sky = malloc(W * H), *a = malloc(W * H * 3), *b = malloc(W * H * 3), *m = malloc(W * H * 3);
    double t = 0.0, pop_slide = 0.0, pop_full = 0.0;
    uint32_t arrivals = 0, mid_sliding = 0;
    stream_frame(s, r, &cam, t, sky, a, NULL); /* the coarse levels; asks for the next */
    for (int round = 0; round < 4; round++) {
        upload_ready(s, r); /* a level of tiles arrives */
        t += 10.0;
        const uint32_t fresh = stream_frame(s, r, &cam, t, sky, b, NULL);
        arrivals += fresh;
        uint32_t part = 0;
        stream_frame(s, r, &cam, t + 0.25, sky, m, &part);
        mid_sliding += part;
        if (round == 0)
            hz_image_write_png(HZ_TEST_TMP "/frame_stream_sliding.png", m, W, H, NULL);
        uint8_t *settled = malloc(W * H * 3);
        stream_frame(s, r, &cam, t + 1.0, sky, settled, NULL);
        const double d_slide = rgb_diff(a, b), d_full = rgb_diff(a, settled);
        fprintf(stderr, "round %d: %u patches arrived; image change at arrival %.4f, once slid in %.4f (of 255)\n",
                round, fresh, d_slide, d_full);
        pop_slide += d_slide;
        pop_full += d_full;
        memcpy(a, settled, W * H * 3);
        free(settled);
    }
    assert_true(arrivals > 0);
    assert_true(mid_sliding > 0);            /* half way, patches are part morphed */
    assert_true(pop_full > 0.025);           /* the finer levels change the image (0.056 here) */
    assert_true(pop_slide * 10 < pop_full);  /* but not at once: they slide in */
    free(sky);
    free(a);
    free(b);
    free(m);
    hz_renderer_destroy(r);
    hz_stream_destroy(s);
    remove(hzp);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sky_above_lit_terrain_below),
        cmocka_unit_test(test_sky_colour_per_ray),
        cmocka_unit_test(test_more_detail_closer_to_reference),
        cmocka_unit_test(test_modes_close_to_reference),
        cmocka_unit_test(test_gpu_morph_matches_cpu),
        cmocka_unit_test(test_patch_chunks_draw_every_patch),
        cmocka_unit_test(test_patch_hidden_blocks_not_drawn),
        cmocka_unit_test(test_far_patches_keep_the_detail_colour),
        cmocka_unit_test(test_patches_skip_missing_data),
        cmocka_unit_test(test_horizon_culling_hides_nothing),
        cmocka_unit_test(test_late_cull_waited_for),
        cmocka_unit_test(test_sky_skips_covered_cells),
        cmocka_unit_test(test_default_camera_frames_the_summit),
        cmocka_unit_test(test_lit_map_matches_per_pixel_shading),
        cmocka_unit_test(test_lit_map_per_vertex),
        cmocka_unit_test(test_lit_map_fine_patches_per_vertex),
        cmocka_unit_test(test_stream_tiles_slide_in),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
