/* Earth curvature on the GPU (issue 15): a curved frame's depth buffer,
 * unprojected, is the point hz_pick returns for that pixel (drawn drop metres
 * below the map point) — the shaders and the CPU agree — for the full mesh
 * (terrain_vs.glsl) and for cdlod patches (terrain_patch_vs.glsl); and the
 * far terrain of a high view falls below where a flat world draws it.
 * Headless EGL on llvmpipe. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "horizon/pick.h"
#include "horizon/render.h"
#include "horizon/terrain.h"

#define W 320u
#define H 180u

typedef struct fixture {
    hz_gl *gl;
    hz_renderer *r;
    hz_terrain *t;
    hz_index_list full;
    float *depth;
} fixture;

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
    fx->r = hz_renderer_create(&(hz_renderer_desc){.width = W, .height = H}, &err);
    /* 257 samples 400 m apart: 102 km, relief 600 m. */
    fx->t = hz_terrain_create(&(hz_terrain_desc){.generate = HZ_GEN_PERLIN, .gen_size = 257, .seed = 7,
                                                 .amplitude = 600, .spacing = 400},
                              &err);
    if (!fx->r || !fx->t || hz_renderer_set_heightmap(fx->r, &fx->t->hm, fx->t->spacing, fx->t->zscale, &err) ||
        hz_lod_full_mesh(&fx->t->hm, &fx->full) || hz_lod_prepare(fx->t->lod, HZ_LOD_CDLOD) ||
        hz_renderer_set_cdlod(fx->r, fx->t->lod, fx->t->valid, &err)) {
        fprintf(stderr, "setup: %s\n", err.msg);
        return -1;
    }
    fx->depth = malloc((size_t)W * H * sizeof *fx->depth);
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
    hz_terrain_destroy(fx->t);
    free(fx->full.data);
    free(fx->depth);
    free(fx);
    return 0;
}

static hz_camera curved_camera(const hz_terrain *t)
{
    const float e = hz_terrain_extent(t);
    return (hz_camera){.pos = {0.5f * e, 2500, 0.97f * e}, .yaw = 0, .pitch = -3, .fov_y = 40,
                       .aspect = (float)W / (float)H, .znear = 1, .zfar = 200000,
                       .earth_radius = 6371008.8f};
}

/* Draws cam's view: the full mesh, or cdlod patches selected for cam. */
static void draw(fixture *fx, const hz_camera *cam, bool patches)
{
    hz_err err = {0};
    hz_scene_params sp = {.fog_density = -1};
    hz_patch_list pl = {0};
    if (patches) {
        hz_lod_stats st;
        hz_lod_params p = {.mode = HZ_LOD_CDLOD, .pixel_error = 1, .viewport_height = H};
        assert_int_equal(hz_lod_select_patches(fx->t->lod, cam, &p, &pl, &st), HZ_OK);
        sp.patches = pl.data, sp.patch_count = (uint32_t)pl.count;
        sp.morph_scale = st.morph_scale, sp.morph_start = st.morph_start;
    }
    if (hz_renderer_draw(fx->r, cam, &sp, patches ? NULL : fx->full.data, patches ? 0 : (uint32_t)fx->full.count,
                         NULL, &err) != HZ_OK)
        fail_msg("draw: %s", err.msg);
    if (hz_renderer_read_depth(fx->r, fx->depth, &err) != HZ_OK)
        fail_msg("depth: %s", err.msg);
    free(pl.data);
}

/* The world point drawn at pixel (px, py) (top row first), from the depth:
 * in double from the projection's terms (a float inverse of a view-projection
 * 100 km from the origin cancels to a few metres). */
static bool unproject(const fixture *fx, const hz_camera *cam, uint32_t px, uint32_t py, float out[3])
{
    const double d = fx->depth[(size_t)py * W + px];
    if (d <= 0.0)
        return false; /* sky */
    const double n = cam->znear, f = cam->zfar, A = n / (f - n), B = f * n / (f - n);
    const double zv = -B / (d + A); /* view space, negative ahead */
    const double t = tan(cam->fov_y * M_PI / 360.0);
    const double xv = (2.0 * (px + 0.5) / W - 1.0) * -zv * t * cam->aspect;
    const double yv = (1.0 - 2.0 * (py + 0.5) / H) * -zv * t;
    const double pitch = cam->pitch * M_PI / 180.0, yaw = cam->yaw * M_PI / 180.0;
    const double fw[3] = {sin(yaw) * cos(pitch), sin(pitch), -cos(yaw) * cos(pitch)};
    const double r[3] = {cos(yaw), 0.0, sin(yaw)};
    const double u[3] = {r[1] * fw[2] - r[2] * fw[1], r[2] * fw[0] - r[0] * fw[2], r[0] * fw[1] - r[1] * fw[0]};
    for (int k = 0; k < 3; k++)
        out[k] = (float)(cam->pos[k] + xv * r[k] + yv * u[k] - zv * fw[k]);
    return true;
}

/* Every 4th pixel: the pick's drawn point is the depth's. A ray grazing a
 * crest may pass between the quarter-cell steps of hz_terrain_raycast's march
 * where the raster catches it: at most 1 % of the pixels may differ. */
static void compare(fixture *fx, const hz_camera *cam, float rel_tol, const char *what)
{
    uint32_t n = 0, far = 0, bad = 0;
    double worst = 0, sum = 0;
    for (uint32_t py = 2; py < H; py += 4)
        for (uint32_t px = 2; px < W; px += 4) {
            float q[3];
            const bool drawn = unproject(fx, cam, px, py, q);
            hz_pick_result r = hz_pick(fx->t, NULL, cam, (float)px + 0.5f, (float)py + 0.5f, W, H);
            if (!drawn || !r.hit)
                continue;
            const float dx = q[0] - r.pos[0], dy = q[1] - (r.pos[1] - r.drop), dz = q[2] - r.pos[2];
            const double err = sqrt(dx * dx + dy * dy + dz * dz) / r.distance;
            worst = fmax(worst, err);
            sum += err;
            n++;
            far += r.distance > 30000.0f;
            if (err > rel_tol) {
                bad++;
                printf("%s: pixel %u,%u drawn at %.1f m, picked at %.1f m\n", what, px, py,
                       (double)sqrt((q[0] - cam->pos[0]) * (q[0] - cam->pos[0]) +
                                    (q[1] - cam->pos[1]) * (q[1] - cam->pos[1]) +
                                    (q[2] - cam->pos[2]) * (q[2] - cam->pos[2])),
                       (double)r.distance);
            }
        }
    printf("%s: %u pixels (%u beyond 30 km), %u off; pick vs depth: mean %.2g, worst %.2g of the distance\n", what,
           n, far, bad, sum / n, worst);
    assert_true(n > 1000 && far > 200);
    assert_true(bad <= n / 100);
}

static void test_pick_matches_depth_full_mesh(void **state)
{
    fixture *fx = *state;
    hz_camera cam = curved_camera(fx->t);
    draw(fx, &cam, false);
    /* The same triangles: only depth and float rounding apart. */
    compare(fx, &cam, 2e-4f, "full mesh");
}

static void test_pick_matches_depth_patches(void **state)
{
    fixture *fx = *state;
    hz_camera cam = curved_camera(fx->t);
    draw(fx, &cam, true);
    /* The LOD surface is within a pixel of the full one, which at grazing
     * angles moves the hit along the ray by up to a few per cent. */
    compare(fx, &cam, 0.05f, "cdlod patches");
}

/* A high view: the far ground is drawn lower with curvature (the depth
 * buffer's points sit d^2/2R below the flat ones), so more sky shows. */
static void test_far_terrain_sinks(void **state)
{
    fixture *fx = *state;
    const float e = hz_terrain_extent(fx->t);
    hz_camera cam = {.pos = {0.5f * e, 8000, 1.02f * e}, .yaw = 0, .pitch = -4.5f, .fov_y = 10,
                     .aspect = (float)W / (float)H, .znear = 1, .zfar = 300000, .earth_radius = 6371008.8f};
    size_t sky[2] = {0, 0};
    for (int c = 0; c < 2; c++) {
        hz_camera k = cam;
        k.earth_radius = c ? 0.0f : cam.earth_radius;
        draw(fx, &k, true);
        for (size_t i = 0; i < (size_t)W * H; i++)
            sky[c] += fx->depth[i] <= 0.0f;
    }
    printf("sky pixels: curved %zu, flat %zu\n", sky[0], sky[1]);
    assert_true(sky[0] > sky[1] + W * 4); /* the far edge (785 m lower) sinks by several rows */
}

/* A sea over the whole map (the water effect): drawn curved, it stays at its
 * level minus the drop everywhere (the plane is a grid that bends; four
 * dropped corners would sink its middle by kilometres). */
static void test_water_follows_the_sphere(void **state)
{
    fixture *fx = *state;
    hz_err err = {0};
    const float e = hz_terrain_extent(fx->t);
    const float level = fx->t->max_h * fx->t->zscale + 50.0f; /* over every hill */
    const hz_water_plane sea = {.height = level};
    assert_int_equal(hz_renderer_set_water(fx->r, &sea, 1, NULL, 0, &err), HZ_OK);
    hz_camera cam = {.pos = {0.5f * e, level + 400, 0.9f * e}, .yaw = 0, .pitch = -4, .fov_y = 40,
                     .aspect = (float)W / (float)H, .znear = 1, .zfar = 200000, .earth_radius = 6371008.8f};
    hz_scene_params sp = {.fog_density = -1, .effects = HZ_FX_WATER};
    if (hz_renderer_draw(fx->r, &cam, &sp, fx->full.data, (uint32_t)fx->full.count, NULL, &err) != HZ_OK)
        fail_msg("draw: %s", err.msg);
    assert_int_equal(hz_renderer_read_depth(fx->r, fx->depth, &err), HZ_OK);
    uint32_t n = 0;
    double worst = 0;
    for (uint32_t py = 2; py < H; py += 4)
        for (uint32_t px = 2; px < W; px += 4) {
            float q[3];
            if (!unproject(fx, &cam, px, py, q))
                continue;
            const float dx = q[0] - cam.pos[0], dz = q[2] - cam.pos[2];
            const float d = sqrtf(dx * dx + dz * dz);
            /* The grid's cells stay within ~1e-4 rad of the sphere. */
            const float off = fabsf(q[1] - (level - hz_camera_drop(&cam, q[0], q[2])));
            worst = fmax(worst, off / fmax(d, 1.0));
            if (off > 0.5f + 2e-4f * d)
                fail_msg("pixel %u,%u: water %.1f m off its curved level at %.0f m", px, py, (double)off, (double)d);
            n++;
        }
    printf("water: %u pixels on the curved sea level (worst %.2g rad)\n", n, worst);
    assert_true(n > 1500);
    assert_int_equal(hz_renderer_set_water(fx->r, NULL, 0, NULL, 0, &err), HZ_OK);
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_pick_matches_depth_full_mesh),
                                       cmocka_unit_test(test_pick_matches_depth_patches),
                                       cmocka_unit_test(test_far_terrain_sinks),
                                       cmocka_unit_test(test_water_follows_the_sphere)};
    return cmocka_run_group_tests(tests, setup, teardown);
}
