/* The CPU halves of the effects: effect lists, billboard culling / sorting /
 * batching, the tree field, weather particles, procedural textures, tree
 * scatter and the automatic water level. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "horizon/fx.h"

static uint32_t rng_state = 12345;
static float frand(void)
{
    rng_state = rng_state * 1664525u + 1013904223u;
    return (float)(rng_state >> 8) / 16777216.0f;
}

/* ---- effect lists ------------------------------------------------------------ */

static void test_parse(void **state)
{
    (void)state;
    uint32_t b = 123;
    hz_err err = {0};
    assert_int_equal(hz_fx_parse("all", &b, &err), HZ_OK);
    assert_int_equal(b, HZ_FX_ALL);
    assert_int_equal(hz_fx_parse("none", &b, &err), HZ_OK);
    assert_int_equal(b, 0);
    assert_int_equal(hz_fx_parse("sky,fog", &b, &err), HZ_OK);
    assert_int_equal(b, HZ_FX_SKY | HZ_FX_FOG);
    assert_int_equal(hz_fx_parse(" water , bloom ", &b, &err), HZ_OK);
    assert_int_equal(b, HZ_FX_WATER | HZ_FX_BLOOM);
    assert_int_equal(hz_fx_parse("all,-weather,-motionblur", &b, &err), HZ_OK);
    assert_int_equal(b, HZ_FX_DEFAULT);
    assert_int_equal(hz_fx_parse("default,weather", &b, &err), HZ_OK);
    assert_int_equal(b, HZ_FX_DEFAULT | HZ_FX_WEATHER);
    assert_int_equal(hz_fx_parse("sky,none,flare", &b, &err), HZ_OK);
    assert_int_equal(b, HZ_FX_FLARE);
    for (uint32_t k = 0; k < HZ_FX_COUNT; k++) {
        assert_int_equal(hz_fx_parse(hz_fx_name(k), &b, &err), HZ_OK);
        assert_int_equal(b, 1u << k);
    }
    assert_null(hz_fx_name(HZ_FX_COUNT));
    b = 77;
    const char *bad[] = {"", "sky,,fog", "sun", "sky,fgo", "-all", ",", "skyfog", "sky;fog"};
    for (size_t k = 0; k < sizeof bad / sizeof *bad; k++) {
        assert_int_equal(hz_fx_parse(bad[k], &b, &err), HZ_ERR_VALUE);
        assert_int_equal(b, 77); /* untouched on error */
    }
    assert_int_equal(hz_fx_parse("sky,fgo", &b, &err), HZ_ERR_VALUE);
    assert_non_null(strstr(err.msg, "fgo"));
    assert_non_null(strstr(err.msg, "motionblur"));
    char buf[200];
    assert_int_equal(hz_fx_format(HZ_FX_SKY | HZ_FX_BLOOM, buf, sizeof buf), strlen("sky,bloom"));
    assert_string_equal(buf, "sky,bloom");
    hz_fx_format(0, buf, sizeof buf);
    assert_string_equal(buf, "none");
    size_t need = hz_fx_format(HZ_FX_ALL, buf, 5); /* truncated, but says how much it needs */
    assert_true(need > 50 && strlen(buf) == 4);
    hz_fx_format(HZ_FX_ALL, buf, sizeof buf);
    assert_int_equal(hz_fx_parse(buf, &b, &err), HZ_OK);
    assert_int_equal(b, HZ_FX_ALL);
}

static void test_settings_defaults(void **state)
{
    (void)state;
    hz_fx_settings s = hz_fx_settings_defaults(NULL, 0.001f);
    assert_true(s.cloud_cover > 0 && s.cloud_cover < 1);
    assert_true(fabsf(s.height_fog - 0.003f) < 1e-7f);
    assert_true(s.blur == 0.5f && s.exposure == 1.0f && s.gamma == 1.0f);
    hz_fx_settings in = {.cloud_cover = -1, .blur = 5, .height_fog = -1, .gamma = 2.2f};
    s = hz_fx_settings_defaults(&in, 0.001f);
    assert_true(s.cloud_cover == 0.0f && s.blur == 0.98f && s.height_fog == 0.0f && s.gamma == 2.2f);
}

/* ---- billboards ----------------------------------------------------------------- */

static hz_camera cam_at_origin(void)
{
    return (hz_camera){.pos = {0, 10, 0}, .yaw = 0, .pitch = 0, .fov_y = 60, .aspect = 1.5f, .znear = 1, .zfar = 5000};
}

static hz_billboard tree(float x, float y, float z, uint16_t tex)
{
    return (hz_billboard){.pos = {x, y, z}, .width = 4, .axis = {0, 10, 0}, .texture = tex, .rgba = 0xffffffffu};
}

static void test_cull(void **state)
{
    (void)state;
    hz_camera cam = cam_at_origin(); /* looks toward -z */
    hz_billboard in[] = {
        tree(0, 5, -100, 0),      /* ahead */
        tree(0, 5, 100, 0),       /* behind */
        tree(0, 5, -900, 1),      /* ahead, beyond 800 m */
        tree(1000, 5, -100, 0),   /* far off to the side */
        tree(0, 5, -798, 1),      /* ahead, the sphere reaches within 800 m */
        tree(62, 0, -100, 0),     /* at the right edge: the sphere straddles the plane */
    };
    hz_billboard out[8];
    size_t n = hz_billboards_cull(in, 6, &cam, 800, out, 8);
    assert_int_equal(n, 3);
    assert_true(out[0].pos[2] == -100 && out[0].pos[0] == 0);
    assert_true(out[1].pos[2] == -798);
    assert_true(out[2].pos[0] == 62);
    /* Counting past cap. */
    assert_int_equal(hz_billboards_cull(in, 6, &cam, 800, out, 1), 3);
    assert_int_equal(hz_billboards_cull(in, 6, &cam, 800, NULL, 0), 3);
}

static void test_sort_back_to_front(void **state)
{
    (void)state;
    const size_t n = 5000;
    hz_billboard *b = malloc(n * sizeof *b);
    double sum = 0;
    for (size_t i = 0; i < n; i++) {
        b[i] = tree(frand() * 200 - 100, frand() * 50, frand() * 200 - 100, (uint16_t)(i % 3));
        b[i].rgba = (uint32_t)i; /* identity, to check stability and the permutation */
        if (i % 10 == 0 && i)      /* some exact ties */
            memcpy(b[i].pos, b[i - 1].pos, sizeof b[i].pos);
        sum += b[i].rgba;
    }
    vec3 eye = {3, 20, -7};
    void *scratch = malloc(hz_billboards_scratch_bytes(n));
    assert_true(hz_billboards_sort(b, n, eye, scratch));
    double sum2 = 0;
    uint8_t *seen = calloc(n, 1);
    for (size_t i = 0; i < n; i++) {
        assert_false(seen[b[i].rgba]);
        seen[b[i].rgba] = 1;
        sum2 += b[i].rgba;
        if (i == 0)
            continue;
        float d0 = glm_vec3_distance2(b[i - 1].pos, eye), d1 = glm_vec3_distance2(b[i].pos, eye);
        assert_true(d0 >= d1);
        if (d0 == d1)
            assert_true(b[i - 1].rgba < b[i].rgba); /* stable */
    }
    assert_true(sum == sum2);
    /* Batching keeps that order inside each batch; alpha-tested first. */
    for (size_t i = 0; i < n; i += 4)
        b[i].flags |= HZ_BB_BLEND;
    hz_bb_batch bt[16];
    size_t nb = hz_billboards_batch(b, n, bt, 16, scratch);
    assert_int_equal(nb, 6);
    uint32_t covered = 0;
    for (size_t k = 0; k < nb; k++) {
        assert_int_equal(bt[k].first, covered);
        covered += bt[k].count;
        assert_int_equal(bt[k].flags, k < 3 ? 0 : HZ_BB_BLEND);
        assert_int_equal(bt[k].texture, k % 3);
        for (uint32_t i = bt[k].first; i < bt[k].first + bt[k].count; i++) {
            assert_int_equal(b[i].texture, bt[k].texture);
            assert_int_equal(b[i].flags & HZ_BB_BLEND, bt[k].flags);
            if (i > bt[k].first)
                assert_true(glm_vec3_distance2(b[i - 1].pos, eye) >= glm_vec3_distance2(b[i].pos, eye));
        }
    }
    assert_int_equal(covered, n);
    assert_int_equal(hz_billboards_batch(b, n, bt, 2, NULL), 6); /* count beyond cap */
    free(seen);
    free(scratch);
    free(b);
}

static int cmp_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

static void test_field_cull_matches_brute_force(void **state)
{
    (void)state;
    const size_t n = 20000;
    hz_billboard *b = malloc(n * sizeof *b), *o1 = malloc(n * sizeof *b), *o2 = malloc(n * sizeof *b);
    for (size_t i = 0; i < n; i++) {
        b[i] = tree(frand() * 10000, frand() * 300, frand() * 10000, 0);
        b[i].axis[1] = 5 + 20 * frand();
        b[i].rgba = (uint32_t)i;
    }
    hz_bb_field *f = hz_bb_field_create(b, n, 300);
    assert_non_null(f);
    assert_int_equal(hz_bb_field_count(f), n);
    uint32_t *k1 = malloc(n * 4), *k2 = malloc(n * 4);
    for (int trial = 0; trial < 40; trial++) {
        hz_camera cam = {.pos = {frand() * 10000, 50 + frand() * 800, frand() * 10000}, .yaw = frand() * 360,
                         .pitch = frand() * 60 - 45, .fov_y = 50, .aspect = 1.7f, .znear = 1, .zfar = 20000};
        float dist = 500 + frand() * 4000;
        size_t a = hz_billboards_cull(b, n, &cam, dist, o1, n), c = hz_bb_field_cull(f, &cam, dist, o2, n);
        assert_int_equal(a, c);
        for (size_t i = 0; i < a; i++)
            k1[i] = o1[i].rgba, k2[i] = o2[i].rgba;
        qsort(k1, a, 4, cmp_u32);
        qsort(k2, a, 4, cmp_u32);
        assert_memory_equal(k1, k2, a * 4);
        if (a > 2) /* a short cap still counts them all */
            assert_int_equal(hz_bb_field_cull(f, &cam, dist, o2, 2), a);
    }
    hz_bb_field_destroy(f);
    hz_bb_field_destroy(NULL);
    hz_bb_field *e = hz_bb_field_create(NULL, 0, 0);
    assert_non_null(e);
    hz_camera cam = cam_at_origin();
    assert_int_equal(hz_bb_field_cull(e, &cam, 1000, o1, n), 0);
    hz_bb_field_destroy(e);
    free(k1), free(k2), free(b), free(o1), free(o2);
}

/* ---- weather ------------------------------------------------------------------------ */

static void test_weather(void **state)
{
    (void)state;
    for (int kind = 0; kind < 2; kind++) {
        hz_weather_desc d = {.kind = (hz_weather_kind)kind, .wind = {4, -2}, .radius = 20, .seed = 3, .texture = 7};
        size_t n = hz_weather_bound(&d);
        assert_true(n > 500 && n < 20000);
        hz_billboard *a = malloc(n * sizeof *a), *b = malloc(n * sizeof *b);
        vec3 eye = {100, 50, -30};
        assert_int_equal(hz_weather_build(&d, eye, 12.5, a, n), n);
        assert_int_equal(hz_weather_build(&d, eye, 12.5, b, n), n);
        assert_memory_equal(a, b, n * sizeof *a); /* same time, same field */
        const float box_h = kind ? 20.0f : 24.0f;
        for (size_t i = 0; i < n; i++) {
            assert_true(fabsf(a[i].pos[0] - eye[0]) <= 20.001f && fabsf(a[i].pos[2] - eye[2]) <= 20.001f);
            assert_true(fabsf(a[i].pos[1] - eye[1]) <= 0.5f * box_h + 0.001f);
            assert_true(a[i].flags & HZ_BB_BLEND);
            assert_int_equal(a[i].texture, 7);
            if (kind == HZ_WEATHER_SNOW) {
                assert_true(a[i].flags & HZ_BB_FACING);
                assert_true(a[i].width > 0.01f && a[i].width < 0.1f);
            } else {
                assert_false(a[i].flags & HZ_BB_FACING);
                /* The streak points back along the motion: up and upwind. */
                assert_true(a[i].axis[1] > 0 && a[i].axis[0] < 0 && a[i].axis[2] > 0);
                assert_true(fabsf(a[i].axis[0] / a[i].axis[2] + 2.0f) < 1e-4f);
            }
        }
        /* A short step later, every particle that did not wrap moved by wind +
         * fall (rain), and the field moved down on average. */
        const double dt = 0.02;
        assert_int_equal(hz_weather_build(&d, eye, 12.5 + dt, b, n), n);
        size_t moved = 0;
        double dy = 0;
        for (size_t i = 0; i < n; i++) {
            float mx = b[i].pos[0] - a[i].pos[0], my = b[i].pos[1] - a[i].pos[1], mz = b[i].pos[2] - a[i].pos[2];
            if (fabsf(mx) > 1 || fabsf(my) > 1 || fabsf(mz) > 1)
                continue; /* wrapped */
            moved++;
            dy += my;
            if (kind == HZ_WEATHER_RAIN) {
                assert_true(fabsf(mx - 4 * (float)dt) < 1e-3f && fabsf(mz + 2 * (float)dt) < 1e-3f);
                assert_true(my < -6.5f * (float)dt + 1e-3f && my > -9.0f * (float)dt - 1e-3f);
            }
        }
        assert_true(moved > n * 9 / 10);
        assert_true(dy / (double)moved < -0.5 * dt);
        /* Moving the eye does not drag the particles along: the ones that stay
         * in both boxes keep their world positions. */
        vec3 eye2 = {105, 50, -30};
        assert_int_equal(hz_weather_build(&d, eye2, 12.5, b, n), n);
        size_t same = 0;
        for (size_t i = 0; i < n; i++)
            same += glm_vec3_distance(a[i].pos, b[i].pos) < 1e-3f;
        assert_true(same > n * 6 / 10);
        /* cap */
        assert_int_equal(hz_weather_build(&d, eye, 1.0, a, 10), 10);
        free(a);
        free(b);
    }
}

/* ---- textures --------------------------------------------------------------------------- */

static void test_detail_textures(void **state)
{
    (void)state;
    const uint32_t S = 128;
    uint8_t *t[HZ_GROUND_COUNT];
    for (int k = 0; k < HZ_GROUND_COUNT; k++) {
        t[k] = malloc((size_t)S * S * 4);
        hz_texgen_detail((hz_ground)k, S, 1, t[k]);
        double mean[3] = {0}, sd = 0, seam = 0, inner = 0;
        for (size_t p = 0; p < (size_t)S * S; p++)
            for (int c = 0; c < 3; c++)
                mean[c] += t[k][4 * p + (size_t)c];
        for (int c = 0; c < 3; c++) {
            mean[c] /= (double)S * S;
            assert_true(fabs(mean[c] - 128.0) < 1.0); /* modulation averages to 1 */
        }
        for (size_t p = 0; p < (size_t)S * S; p++)
            sd += pow(t[k][4 * p + 1] - mean[1], 2);
        sd = sqrt(sd / ((double)S * S));
        /* Tileable: the wrap-around seam is no rougher than neighbouring
         * columns/rows inside the texture. */
        for (uint32_t y = 0; y < S; y++) {
            seam += abs(t[k][4 * ((size_t)y * S + S - 1) + 1] - t[k][4 * ((size_t)y * S) + 1]);
            seam += abs(t[k][4 * ((size_t)(S - 1) * S + y) + 1] - t[k][4 * (size_t)y + 1]);
            inner += abs(t[k][4 * ((size_t)y * S + S / 2 - 1) + 1] - t[k][4 * ((size_t)y * S + S / 2) + 1]);
            inner += abs(t[k][4 * ((size_t)(S / 2 - 1) * S + y) + 1] - t[k][4 * ((size_t)(S / 2) * S + y) + 1]);
        }
        printf("detail %d: sd %.1f, seam %.2f vs inner %.2f per texel\n", k, sd, seam / (2.0 * S), inner / (2.0 * S));
        assert_true(sd > 3.0);                  /* there is detail */
        assert_true(seam < 1.6 * inner + 1.0);  /* no seam */
    }
    /* Different kinds look different. */
    assert_memory_not_equal(t[0], t[1], (size_t)S * S * 4);
    for (int k = 0; k < HZ_GROUND_COUNT; k++)
        free(t[k]);
}

static void test_sprites(void **state)
{
    (void)state;
    const uint32_t w = 64, h = 128;
    uint8_t *s = malloc((size_t)w * h * 4);
    for (int k = HZ_SPRITE_CONIFER; k <= HZ_SPRITE_BROADLEAF; k++) {
        hz_texgen_sprite((hz_sprite)k, w, h, 1, s);
        size_t cov = 0;
        for (size_t p = 0; p < (size_t)w * h; p++)
            cov += s[4 * p + 3] >= 128;
        double frac = (double)cov / ((double)w * h);
        printf("sprite %d: %.0f %% opaque\n", k, 100 * frac);
        assert_true(frac > 0.15 && frac < 0.7);
        assert_int_equal(s[4 * ((size_t)(h - 3) * w + w / 2) + 3], 255); /* trunk at the bottom centre */
        assert_int_equal(s[3], 0);                                    /* top-left corner clear */
        assert_int_equal(s[4 * ((size_t)(h - 1) * w) + 3], 0);        /* bottom-left clear */
        /* Green-dominant where opaque. */
        const uint8_t *c = s + 4 * ((size_t)(h / 2) * w + w / 2);
        assert_true(c[1] > c[0] && c[1] > c[2]);
    }
    hz_texgen_sprite(HZ_SPRITE_RAIN, 8, 64, 1, s);
    assert_true(s[4 * (32 * 8 + 4) + 3] > 200 && s[4 * (32 * 8 + 0) + 3] < 100);
    hz_texgen_sprite(HZ_SPRITE_SNOW, 16, 16, 1, s);
    assert_true(s[4 * (8 * 16 + 8) + 3] > 200 && s[3] == 0);
    free(s);
}

/* Alpha-tested sprite mipmaps keep the coverage: a sparse crown (needles at
 * random, densest in the middle) stays as covered at every level, where
 * plain averaging thins it out level by level. Colours stay those of the
 * opaque texels. */
static void test_sprite_mips_keep_coverage(void **state)
{
    (void)state;
    const uint32_t w = 64, h = 128;
    uint8_t *a = calloc((size_t)w * h * 4, 1), *b = calloc((size_t)w * h * 4, 1);
    uint32_t rng = 12345;
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            uint8_t *p = a + ((size_t)y * w + x) * 4;
            /* needles: opaque at random, densest in the middle of a crown */
            float dx = ((float)x - 32.0f) / 32.0f, dy = ((float)y - 64.0f) / 64.0f;
            float dens = fmaxf(0.0f, 0.6f * (1.0f - (dx * dx + dy * dy)));
            rng = rng * 1664525u + 1013904223u;
            bool on = (float)(rng >> 8) / 16777216.0f < dens;
            p[0] = 40, p[1] = on ? 160 : 0, p[2] = 30, p[3] = on ? 255 : 0;
        }
    const double c0 = hz_sprite_coverage(a, (size_t)w * h);
    assert_true(c0 > 0.1 && c0 < 0.4);
    uint32_t lw = w, lh = h;
    int levels = 0;
    while (lw > 1 || lh > 1) {
        uint32_t nw, nh;
        hz_sprite_mip_next(a, lw, lh, c0, b, &nw, &nh);
        assert_int_equal(nw, lw > 1 ? lw / 2 : 1);
        assert_int_equal(nh, lh > 1 ? lh / 2 : 1);
        double c = hz_sprite_coverage(b, (size_t)nw * nh);
        print_message("level %d: %ux%u coverage %.3f (level 0: %.3f)\n", levels + 1, nw, nh, c, c0);
        if ((size_t)nw * nh >= 64) /* small levels cannot hit a share closely */
            assert_true(fabs(c - c0) < 0.2 * c0);
        else /* within a texel's share */
            assert_true(fabs(c - c0) <= 1.0 / (double)((size_t)nw * nh));
        for (size_t i = 0; i < (size_t)nw * nh; i++)
            if (b[i * 4 + 3] >= 128)
                assert_true(b[i * 4 + 1] == 160 && b[i * 4] == 40);
        uint8_t *t = a;
        a = b;
        b = t;
        lw = nw, lh = nh;
        levels++;
    }
    assert_int_equal(levels, 7);
    free(a);
    free(b);
}

/* ---- scatter and water ----------------------------------------------------------------------- */

static void make_hm(hz_heightmap *hm, uint32_t n, float sea_frac)
{
    hz_grid g;
    assert_int_equal(hz_grid_alloc(&g, n, n, NULL), HZ_OK);
    for (uint32_t j = 0; j < n; j++)
        for (uint32_t i = 0; i < n; i++) {
            float x = (float)i / (float)(n - 1), z = (float)j / (float)(n - 1);
            float h = 400.0f * x + 150.0f * sinf(9.0f * z) * sinf(7.0f * x) + 160.0f;
            if (x < sea_frac)
                h = 0.0f; /* a flat sea along the west edge */
            g.z[(size_t)j * n + i] = h;
        }
    assert_int_equal(hz_heightmap_create(hm, &g, HZ_LAYOUT_BLOCKED, NULL), HZ_OK);
    hz_grid_free(&g);
}

/* The coast beyond a DEM's data: each edge sample is sea when the first
 * sample with data inward from it is below the level, or none has data. A
 * 9x9 map whose data is the rectangle (1, 1)-(7, 6): sea (0 m) in columns
 * 1-3, land (50 m) from column 4, a missing tile (no data) over columns 1-2 of
 * rows 5-6, and the land's edge samples in rows 1-2 of column 7 without data
 * (a reprojected footprint's corner), beyond which the scan finds land. */
static void test_coast(void **state)
{
    (void)state;
    const uint32_t n = 9;
    hz_grid g;
    assert_int_equal(hz_grid_alloc(&g, n, n, NULL), HZ_OK);
    uint8_t valid[81];
    for (uint32_t j = 0; j < n; j++)
        for (uint32_t i = 0; i < n; i++) {
            g.z[j * n + i] = i >= 4 ? 50.0f : 0.0f;
            const bool in = i >= 1 && i <= 7 && j >= 1 && j <= 6;
            valid[j * n + i] = in && !(i <= 2 && j >= 5) && !(i == 7 && j <= 2);
        }
    hz_heightmap hm;
    assert_int_equal(hz_heightmap_create(&hm, &g, HZ_LAYOUT_LINEAR, NULL), HZ_OK);
    hz_grid_free(&g);
    hz_coast c;
    hz_err err = {0};
    const uint32_t rect[4] = {1, 1, 7, 6};
    assert_int_equal(hz_coast_make(&hm, valid, 10.0f, 1.0f, 0.1f, rect, &c, &err), HZ_OK);
    assert_int_equal(c.x0, 1);
    assert_int_equal(c.z1, 6);
    assert_float_equal(c.spacing, 10.0f, 0.0f);
    /* west: rows 1-6 (rows 5, 6 start in the missing tile, then sea); east: land */
    static const uint8_t west[6] = {1, 1, 1, 1, 1, 1}, east[6] = {0, 0, 0, 0, 0, 0};
    /* north (row 1) and south (row 6): columns 1-7, sea up to column 3 */
    static const uint8_t north[7] = {1, 1, 1, 0, 0, 0, 0}, south[7] = {1, 1, 1, 0, 0, 0, 0};
    assert_memory_equal(c.edge, west, 6);
    assert_memory_equal(c.edge + 6, east, 6);
    assert_memory_equal(c.edge + 12, north, 7);
    assert_memory_equal(c.edge + 19, south, 7);
    hz_coast_free(&c);
    /* the level decides: at 60 m everything is sea; zscale applies */
    assert_int_equal(hz_coast_make(&hm, valid, 10.0f, 1.0f, 60.0f, rect, &c, &err), HZ_OK);
    for (uint32_t k = 0; k < 26; k++)
        assert_int_equal(c.edge[k], 1);
    hz_coast_free(&c);
    assert_int_equal(hz_coast_make(&hm, valid, 10.0f, 2.0f, 60.0f, rect, &c, &err), HZ_OK);
    assert_int_equal(c.edge[6], 0); /* east: 100 m land */
    hz_coast_free(&c);
    /* a column without any data is open sea; the whole map without a mask */
    for (uint32_t j = 0; j < n; j++)
        valid[j * n + 5] = 0;
    const uint32_t col[4] = {5, 1, 5, 6};
    assert_int_equal(hz_coast_make(&hm, valid, 10.0f, 1.0f, 0.1f, col, &c, &err), HZ_OK);
    assert_int_equal(c.edge[12], 1);
    hz_coast_free(&c);
    assert_int_equal(hz_coast_make(&hm, NULL, 10.0f, 1.0f, 0.1f, NULL, &c, &err), HZ_OK);
    assert_int_equal(c.x1, 8);
    assert_int_equal(c.edge[0], 1);  /* west: sea */
    assert_int_equal(c.edge[9], 0);  /* east: land */
    assert_int_equal(c.edge[18 + 3], 1);
    assert_int_equal(c.edge[18 + 4], 0);
    hz_coast_free(&c);
    /* not a rectangle of the map */
    const uint32_t bad[2][4] = {{3, 1, 2, 6}, {1, 1, 9, 6}};
    for (int k = 0; k < 2; k++) {
        assert_int_equal(hz_coast_make(&hm, valid, 10.0f, 1.0f, 0.1f, bad[k], &c, &err), HZ_ERR_VALUE);
        assert_null(c.edge);
    }
    assert_int_equal(hz_coast_make(&hm, valid, 0.0f, 1.0f, 0.1f, rect, &c, &err), HZ_ERR_VALUE);
    assert_int_equal(hz_coast_make(&hm, valid, 10.0f, 1.0f, NAN, rect, &c, &err), HZ_ERR_VALUE);
    hz_heightmap_destroy(&hm);
}

static void test_trees_and_water(void **state)
{
    (void)state;
    hz_heightmap hm;
    make_hm(&hm, 513, 0.1f);
    const float spacing = 20.0f;
    bool sea = false;
    float level = hz_water_level_auto(&hm, NULL, 1.0f, 0, &sea);
    assert_true(sea);
    printf("auto water level with a sea: %.2f m\n", (double)level);
    assert_true(fabsf(level - 0.1f) < 0.01f); /* just above the sea: no coastal land drowned */
    hz_heightmap no_sea;
    make_hm(&no_sea, 257, 0.0f);
    float lake = hz_water_level_auto(&no_sea, NULL, 2.0f, 0.1f, &sea);
    assert_false(sea);
    /* 10 % of the samples lie below it, 90 % above. */
    size_t below = 0;
    for (uint32_t j = 0; j < 257; j++)
        for (uint32_t i = 0; i < 257; i++)
            below += 2.0f * hz_heightmap_get(&no_sea, i, j) <= lake;
    printf("auto lake level: %.1f m, %.3f below\n", (double)lake, (double)below / (257.0 * 257.0));
    assert_true(fabs((double)below / (257.0 * 257.0) - 0.1) < 0.01);
    /* A sea counts even where it is nodata (filled flat along its coast); lakes
     * fill 4 % of the samples with data only: the lowest tenth masked, the
     * level rises to the 4 % of the rest. */
    uint8_t *valid = malloc(513u * 513u);
    for (size_t k = 0; k < 513u * 513u; k++)
        valid[k] = (float)(k % 513) / 512.0f >= 0.1f;
    assert_true(fabsf(hz_water_level_auto(&hm, valid, 1.0f, 0, &sea) - 0.1f) < 0.01f && sea);
    uint8_t *vl = malloc(257u * 257u);
    size_t nvalid = 0, under = 0;
    for (size_t k = 0; k < 257u * 257u; k++)
        nvalid += vl[k] = 2.0f * hz_heightmap_get(&no_sea, (uint32_t)(k % 257), (uint32_t)(k / 257)) > lake;
    float masked = hz_water_level_auto(&no_sea, vl, 2.0f, 0, &sea);
    assert_false(sea);
    for (size_t k = 0; k < 257u * 257u; k++)
        under += vl[k] && 2.0f * hz_heightmap_get(&no_sea, (uint32_t)(k % 257), (uint32_t)(k / 257)) <= masked;
    printf("auto lake level over the valid samples: %.1f m, %.3f of them below\n", (double)masked,
           (double)under / (double)nvalid);
    assert_true(masked > lake && fabs((double)under / (double)nvalid - 0.04) < 0.005);
    free(valid);
    free(vl);

    hz_scatter_desc td = {.water_level = level, .seed = 9, .texture0 = 4};
    hz_billboard *t1 = NULL, *t2 = NULL;
    size_t n1 = 0, n2 = 0;
    hz_err err = {0};
    assert_int_equal(hz_trees_scatter(&hm, spacing, 1.0f, &td, &t1, &n1, &err), HZ_OK);
    assert_int_equal(hz_trees_scatter(&hm, spacing, 1.0f, &td, &t2, &n2, &err), HZ_OK);
    assert_int_equal(n1, n2);
    assert_memory_equal(t1, t2, n1 * sizeof *t1);
    const float ext = 512 * spacing, area_ha = ext * ext / 10000.0f;
    printf("trees: %zu on %.0f ha (%.1f per ha)\n", n1, (double)area_ha, (double)n1 / (double)area_ha);
    assert_true(n1 > (size_t)(area_ha * 0.5f) && n1 < (size_t)(area_ha * 12.0f));
    for (size_t i = 0; i < n1; i++) {
        const hz_billboard *b = &t1[i];
        assert_true(b->pos[0] >= 0 && b->pos[0] <= ext && b->pos[2] >= 0 && b->pos[2] <= ext);
        assert_true(b->pos[1] > level + 1.0f);                    /* never in the sea */
        assert_true(b->axis[1] >= 9.0f && b->axis[1] <= 24.0f);
        assert_true(b->texture == 4 || b->texture == 5);
        assert_int_equal(b->flags, 0);                             /* upright, alpha tested */
        /* Standing on the ground (sunk by at most 5 % of the height). */
        uint32_t i0 = (uint32_t)(b->pos[0] / spacing), j0 = (uint32_t)(b->pos[2] / spacing);
        float g = hz_heightmap_get(&hm, i0 < 512 ? i0 : 511, j0 < 512 ? j0 : 511);
        assert_true(fabsf(b->pos[1] + 0.05f * b->axis[1] - g) < 40.0f);
    }
    free(t2); /* the determinism copy; t2 is filled again below */
    t2 = NULL;
    /* The cap lowers the density instead of cutting off part of the map. */
    td.max_count = 500;
    assert_int_equal(hz_trees_scatter(&hm, spacing, 1.0f, &td, &t2, &n2, &err), HZ_OK);
    assert_true(n2 <= 500 && n2 > 100);
    float maxz = 0;
    for (size_t i = 0; i < n2; i++)
        maxz = fmaxf(maxz, t2[i].pos[2]);
    assert_true(maxz > 0.8f * ext);
    free(t2);
    /* Forest cover map: same rules, no trees where it is 0. */
    const uint32_t side = 128;
    uint8_t *cover = malloc(side * side);
    td.max_count = 0;
    hz_forest_cover_map(&hm, spacing, 1.0f, &td, side, cover);
    size_t in_zero = 0;
    for (size_t i = 0; i < n1; i++) {
        uint32_t u = (uint32_t)(t1[i].pos[0] / ext * (float)side), v = (uint32_t)(t1[i].pos[2] / ext * (float)side);
        in_zero += cover[(v < side ? v : side - 1) * side + (u < side ? u : side - 1)] == 0;
    }
    assert_true(in_zero < n1 / 50);
    for (uint32_t v = 0; v < side; v++) /* no forest in the sea */
        assert_int_equal(cover[v * side + 2], 0);
    free(cover);
    free(t1);
    /* Density is a fraction, and roughly `cover` of the land is forest. */
    double acc = 0;
    for (int k = 0; k < 4000; k++) {
        float d = hz_forest_density(&td, frand() * 100000, frand() * 100000);
        assert_true(d >= 0 && d <= 1);
        acc += d;
    }
    printf("mean forest density %.3f for cover 0.45\n", acc / 4000);
    assert_true(acc / 4000 > 0.25 && acc / 4000 < 0.65);
    /* Bad input. */
    assert_int_equal(hz_trees_scatter(&hm, -1.0f, 1.0f, &td, &t2, &n2, &err), HZ_ERR_VALUE);
    td.density = NAN;
    assert_int_equal(hz_trees_scatter(&hm, spacing, 1.0f, &td, &t2, &n2, &err), HZ_ERR_VALUE);
    hz_heightmap_destroy(&hm);
    hz_heightmap_destroy(&no_sea);
}

/* Trees clear of the buildings: an 8 m block on samples 10..12 of a 5 m
 * grid drops the trees standing in it, beside it within a sample, or whose
 * crown reaches over it; the rest keep their order. */
static void test_billboards_clear_of(void **state)
{
    (void)state;
    enum { N = 32 };
    float tops[N * N];
    for (int k = 0; k < N * N; k++)
        tops[k] = -INFINITY;
    for (int j = 10; j <= 12; j++)
        for (int i = 10; i <= 12; i++)
            tops[j * N + i] = 8.0f;
    tops[3] = NAN; /* none */
    const float x[6] = {55, 63, 80, 80, -100, 15}, w[6] = {4, 4, 4, 50, 4, 4};
    hz_billboard b[6];
    for (int k = 0; k < 6; k++)
        b[k] = (hz_billboard){.pos = {x[k], 0, k == 5 ? 0.0f : 55.0f}, .width = w[k], .axis = {0, 10, 0},
                              .texture = (uint16_t)k};
    assert_int_equal(hz_billboards_clear_of(b, 6, tops, N, 5.0f), 3);
    assert_int_equal(b[0].texture, 2); /* 4 samples east of the block, 2 m crown */
    assert_int_equal(b[1].texture, 4); /* off the grid */
    assert_int_equal(b[2].texture, 5); /* on the NAN sample's row */
    assert_int_equal(hz_billboards_clear_of(b, 3, NULL, N, 5.0f), 3);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_parse),
        cmocka_unit_test(test_settings_defaults),
        cmocka_unit_test(test_cull),
        cmocka_unit_test(test_billboards_clear_of),
        cmocka_unit_test(test_sort_back_to_front),
        cmocka_unit_test(test_field_cull_matches_brute_force),
        cmocka_unit_test(test_weather),
        cmocka_unit_test(test_detail_textures),
        cmocka_unit_test(test_sprites),
        cmocka_unit_test(test_sprite_mips_keep_coverage),
        cmocka_unit_test(test_coast), cmocka_unit_test(test_trees_and_water),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
