/* Light map (SPEC R5): the seed's formula I = cos(r)(1 - Ie) + Ie on lit
 * samples, Ie in shadow; the shadow of a known wall has exactly the length
 * h / tan(elevation); the sweep agrees with a brute-force ray march; threads
 * and memory layouts do not change a single byte. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "horizon/lightmap.h"

static void make_hm(hz_heightmap *hm, uint32_t n, hz_layout layout, float (*f)(uint32_t, uint32_t, void *), void *u)
{
    hz_grid g;
    assert_int_equal(hz_grid_alloc(&g, n, n, NULL), HZ_OK);
    for (uint32_t j = 0; j < n; j++)
        for (uint32_t i = 0; i < n; i++)
            g.z[(size_t)j * n + i] = f(i, j, u);
    assert_int_equal(hz_heightmap_create(hm, &g, layout, NULL), HZ_OK);
    hz_grid_free(&g);
}

/* ---- a wall on flat ground ----------------------------------------------- */

static float wall(uint32_t i, uint32_t j, void *u)
{
    (void)j, (void)u;
    return i == 64 ? 10.0f : 0.0f;
}

/* The light map's quantisation: I * 255 rounded half up. */
static uint8_t q(float I)
{
    return (uint8_t)floorf(I * 255.0f + 0.5f);
}

static void test_wall_shadow_length(void **state)
{
    (void)state;
    const uint32_t n = 129;
    hz_heightmap hm;
    make_hm(&hm, n, HZ_LAYOUT_LINEAR, wall, NULL);
    uint8_t *lm = malloc(hz_lightmap_bound(&hm));
    assert_non_null(lm);
    /* Sun in the east (+x), 30 degrees up; spacing 1 m, Ie 0.3. The shadow
     * falls to the west: samples at distance d from the wall are shadowed
     * while 10 m > d tan(30) = 0.577 d, i.e. d <= 17: i = 47..63. */
    hz_lightmap_desc d = {.hm = &hm, .spacing = 1.0f, .ambient = 0.3f};
    hz_sun_direction(90.0f, 30.0f, d.sun_dir);
    assert_true(fabsf(d.sun_dir[0] - cosf(glm_rad(30.0f))) < 1e-6f && fabsf(d.sun_dir[2]) < 1e-6f);
    hz_lightmap_stats st;
    assert_int_equal(hz_lightmap_build(&d, lm, &st, NULL), HZ_OK);
    const uint8_t lit = q(0.5f * 0.7f + 0.3f), shade = q(0.3f);
    for (uint32_t j = 0; j < n; j++) {
        for (uint32_t i = 0; i < n; i++) {
            uint8_t v = lm[(size_t)j * n + i];
            if (i >= 47 && i <= 63)
                assert_int_equal(v, shade); /* shadow (63 also faces away: the wall's west face) */
            else if (i <= 46 || i >= 66 || i == 64)
                assert_int_equal(v, lit); /* flat ground and the wall top: cos(r) = sin(30) */
            else
                assert_true(v > lit);     /* 65: the wall's east face turns toward the sun */
        }
    }
    assert_int_equal(st.shadowed, 16u * n);   /* 47..62 */
    assert_int_equal(st.facing_away, 1u * n); /* 63 */
    /* Lower sun: longer shadow. 10 / tan(10 deg) = 56.7 -> d <= 56: i = 8..63. */
    hz_sun_direction(90.0f, 10.0f, d.sun_dir);
    assert_int_equal(hz_lightmap_build(&d, lm, &st, NULL), HZ_OK);
    for (uint32_t i = 0; i < 64; i++)
        assert_int_equal(lm[(size_t)40 * n + i], i >= 8 ? shade : q(sinf(glm_rad(10.0f)) * 0.7f + 0.3f));
    /* Sun in the west: the shadow is on the east side, 65..81 (65 faces away). */
    hz_sun_direction(270.0f, 30.0f, d.sun_dir);
    assert_int_equal(hz_lightmap_build(&d, lm, &st, NULL), HZ_OK);
    for (uint32_t i = 60; i < n; i++)
        assert_int_equal(lm[(size_t)7 * n + i], (i >= 65 && i <= 81) ? shade : i == 63 ? lm[7 * n + 63] : lit);
    /* A wall along x with the sun in the north (-z): shadow toward +z. */
    free(lm);
    hz_heightmap_destroy(&hm);
}

static float flat(uint32_t i, uint32_t j, void *u)
{
    (void)i, (void)j, (void)u;
    return 0.0f;
}

/* Casters of an n x n map: a 3 x 3-sample block 10 m high on samples
 * i = 64..66, j = 60..62; none elsewhere. */
static float *block_casters(uint32_t n)
{
    float *top = malloc((size_t)n * n * sizeof *top);
    assert_non_null(top);
    for (size_t k = 0; k < (size_t)n * n; k++)
        top[k] = -INFINITY;
    for (uint32_t j = 60; j <= 62; j++)
        for (uint32_t i = 64; i <= 66; i++)
            top[(size_t)j * n + i] = 10.0f;
    return top;
}

/* An object (casters) on flat ground casts the shadow a wall of its height
 * would, and only on the ground behind it: a 3 x 3-sample block 10 m high,
 * sun in the east 30 degrees up, spacing 1 m: samples d <= 17 m west of it
 * are in shadow, and so are the two under it behind its sunward edge (hidden
 * by it when drawn); its sunward samples and the ground east of it are lit,
 * and rows beside it see nothing. Without casters all is lit. */
static void test_casters_shadow(void **state)
{
    (void)state;
    const uint32_t n = 129;
    hz_heightmap hm;
    make_hm(&hm, n, HZ_LAYOUT_LINEAR, flat, NULL);
    uint8_t *lm = malloc(hz_lightmap_bound(&hm)), *bare = malloc(hz_lightmap_bound(&hm));
    float *top = block_casters(n);
    assert_true(lm && bare);
    top[5] = NAN; /* none */
    for (int t = 1; t <= 2; t++) {
        hz_lightmap_desc d = {.hm = &hm, .spacing = 1.0f, .ambient = 0.3f, .threads = (uint32_t)t};
        hz_sun_direction(90.0f, 30.0f, d.sun_dir);
        assert_int_equal(hz_lightmap_build(&d, bare, NULL, NULL), HZ_OK);
        d.casters = top;
        hz_lightmap_stats st;
        assert_int_equal(hz_lightmap_build(&d, lm, &st, NULL), HZ_OK);
        const uint8_t lit = q(0.5f * 0.7f + 0.3f), shade = q(0.3f);
        for (uint32_t j = 0; j < n; j++)
            for (uint32_t i = 0; i < n; i++) {
                const uint8_t v = lm[(size_t)j * n + i];
                assert_int_equal(bare[(size_t)j * n + i], lit);
                if (j >= 60 && j <= 62 && i >= 47 && i <= 65)
                    assert_int_equal(v, shade);
                else
                    assert_int_equal(v, lit);
            }
        assert_int_equal(st.shadowed, 3u * 19u);
    }
    free(lm);
    free(bare);
    free(top);
    hz_heightmap_destroy(&hm);
}

/* Sun heights over a rectangle: the 3 x 3 block of test_casters_shadow, sun
 * in the east 30 degrees up, spacing 1 m. West of the block, on its rows, a
 * point is in shade below 10 - d tan(30) at d metres from its west column
 * (the ground when that is lower); the block's own samples see only the
 * block's columns east of them (its sunward column: the ground); other rows
 * and the east side: the ground. The light map bytes do not change. */
static void test_sun_heights(void **state)
{
    (void)state;
    const uint32_t n = 129;
    hz_heightmap hm;
    make_hm(&hm, n, HZ_LAYOUT_LINEAR, flat, NULL);
    uint8_t *lm = malloc(hz_lightmap_bound(&hm)), *ref = malloc(hz_lightmap_bound(&hm));
    float *top = block_casters(n);
    const uint32_t rect[4] = {40, 55, 40, 15};
    float *sh = malloc((size_t)rect[2] * rect[3] * sizeof *sh);
    assert_true(lm && ref && sh);
    const float t30 = tanf(glm_rad(30.0f));
    for (int t = 1; t <= 2; t++) {
        hz_lightmap_desc d = {.hm = &hm, .spacing = 1.0f, .ambient = 0.3f, .threads = (uint32_t)t, .casters = top};
        hz_sun_direction(90.0f, 30.0f, d.sun_dir);
        assert_int_equal(hz_lightmap_build(&d, ref, NULL, NULL), HZ_OK);
        d.sun_heights = sh;
        memcpy(d.sun_rect, rect, sizeof rect);
        for (size_t k = 0; k < (size_t)rect[2] * rect[3]; k++)
            sh[k] = NAN;
        assert_int_equal(hz_lightmap_build(&d, lm, NULL, NULL), HZ_OK);
        assert_memory_equal(lm, ref, hz_lightmap_bound(&hm));
        for (uint32_t j = rect[1]; j < rect[1] + rect[3]; j++)
            for (uint32_t i = rect[0]; i < rect[0] + rect[2]; i++) {
                float want = 0.0f;
                if (j >= 60 && j <= 62 && i <= 65) {
                    const uint32_t from = i < 64 ? 64 : i + 1; /* nearest block column east of i */
                    want = fmaxf(10.0f - (float)(from - i) * t30, 0.0f);
                }
                const float got = sh[(size_t)(j - rect[1]) * rect[2] + (i - rect[0])];
                if (!(fabsf(got - want) < 1e-4f))
                    fail_msg("sun height at %u,%u: %g, want %g (threads %d)", i, j, (double)got, (double)want, t);
            }
        /* Along the other axis (sun in the north) the rectangle's layout is the same. */
        hz_sun_direction(0.0f, 30.0f, d.sun_dir);
        assert_int_equal(hz_lightmap_build(&d, lm, NULL, NULL), HZ_OK);
        for (uint32_t i = 64; i <= 66; i++) {
            /* north of the block (smaller j) is its sun side: ground; j = 61 sees the row at 60 */
            assert_true(fabsf(sh[(size_t)(58 - rect[1]) * rect[2] + (i - rect[0])]) < 1e-4f);
            assert_true(fabsf(sh[(size_t)(61 - rect[1]) * rect[2] + (i - rect[0])] - (10.0f - t30)) < 1e-4f);
            assert_true(fabsf(sh[(size_t)(64 - rect[1]) * rect[2] + (i - rect[0])] - (10.0f - 2 * t30)) < 1e-4f);
        }
    }
    /* A rectangle leaving the map is refused. */
    hz_err err = {0};
    hz_lightmap_desc d = {.hm = &hm, .spacing = 1.0f, .sun_dir = {1, 1, 0}, .sun_heights = sh,
                          .sun_rect = {100, 0, 30, 10}};
    assert_int_equal(hz_lightmap_build(&d, lm, NULL, &err), HZ_ERR_VALUE);
    assert_non_null(strstr(err.msg, "rectangle"));
    d.sun_rect[0] = 0, d.sun_rect[2] = 0;
    assert_int_equal(hz_lightmap_build(&d, lm, NULL, &err), HZ_ERR_VALUE);
    free(lm);
    free(ref);
    free(top);
    free(sh);
    hz_heightmap_destroy(&hm);
}

static float wall_z(uint32_t i, uint32_t j, void *u)
{
    (void)i, (void)u;
    return j == 30 ? 10.0f : 0.0f;
}

static void test_wall_north_sun(void **state)
{
    (void)state;
    const uint32_t n = 65;
    hz_heightmap hm;
    make_hm(&hm, n, HZ_LAYOUT_BLOCKED, wall_z, NULL);
    uint8_t *lm = malloc(hz_lightmap_bound(&hm));
    hz_lightmap_desc d = {.hm = &hm, .spacing = 2.0f, .ambient = 0.25f};
    /* 45 degrees, 2 m spacing: shadowed while 10 > 2 d -> d <= 4: j = 31..34. */
    hz_sun_direction(0.0f, 45.0f, d.sun_dir);
    assert_int_equal(hz_lightmap_build(&d, lm, NULL, NULL), HZ_OK);
    for (uint32_t j = 31; j < n; j++)
        assert_int_equal(lm[(size_t)j * n + 20], j <= 34 ? q(0.25f) : q(sinf(glm_rad(45.0f)) * 0.75f + 0.25f));
    free(lm);
    hz_heightmap_destroy(&hm);
}

/* ---- hills vs a brute-force ray march ------------------------------------- */

static float lattice(int x, int z)
{
    uint32_t h = (uint32_t)x * 374761393u + (uint32_t)z * 668265263u;
    h = (h ^ (h >> 13)) * 1274126177u;
    h ^= h >> 16;
    return (float)(h & 0xffffu) / 32767.5f - 1.0f;
}

static float vnoise(float x, float z)
{
    float fx = floorf(x), fz = floorf(z);
    int ix = (int)fx, iz = (int)fz;
    float tx = x - fx, tz = z - fz;
    tx = tx * tx * (3 - 2 * tx);
    tz = tz * tz * (3 - 2 * tz);
    float a = lattice(ix, iz), b = lattice(ix + 1, iz), c = lattice(ix, iz + 1), e = lattice(ix + 1, iz + 1);
    return a + (b - a) * tx + (c - a) * tz + (a - b - c + e) * tx * tz;
}

static float hills(uint32_t i, uint32_t j, void *u)
{
    (void)u;
    float h = 0, amp = 60, f = 1.0f / 24.0f;
    for (int o = 0; o < 4; o++, amp *= 0.5f, f *= 2.0f)
        h += amp * vnoise((float)i * f + 3.0f * (float)o, (float)j * f);
    return h;
}

typedef struct bf_map {
    const hz_heightmap *hm;
    uint32_t n;
    float spacing;
} bf_map;

static float H(const bf_map *m, uint32_t i, uint32_t j)
{
    return hz_heightmap_get(m->hm, i, j);
}

/* Reference 1, the sweep's model: the ray is tested where it crosses each
 * grid line of the major axis, terrain linearly interpolated along the line.
 * One ray per sample, no shared state. */
static bool shadow_lines(const bf_map *m, uint32_t i, uint32_t j, const vec3 s)
{
    const uint32_t n = m->n;
    bool mx = fabsf(s[0]) >= fabsf(s[2]);
    float smaj = mx ? s[0] : s[2], smin = mx ? s[2] : s[0];
    int dir = smaj > 0 ? 1 : -1;
    float r = smin / fabsf(smaj), rise = m->spacing * s[1] / fabsf(smaj);
    float h = H(m, i, j);
    int maj = mx ? (int)i : (int)j;
    float mn = mx ? (float)j : (float)i;
    for (int k = 1;; k++) {
        int line = maj + dir * k;
        float qq = mn + r * (float)k;
        if (line < 0 || line >= (int)n || qq < 0 || qq > (float)(n - 1))
            return false;
        uint32_t q0 = (uint32_t)qq, q1 = q0 + 1 < n ? q0 + 1 : q0;
        float f = qq - (float)q0;
        float a = mx ? H(m, (uint32_t)line, q0) : H(m, q0, (uint32_t)line);
        float b = mx ? H(m, (uint32_t)line, q1) : H(m, q1, (uint32_t)line);
        if (a + (b - a) * f > h + rise * (float)k + 1e-3f)
            return true;
    }
}

/* Reference 2, continuous: small steps along the ray over the bilinear surface. */
static bool shadow_bilinear(const bf_map *m, uint32_t i, uint32_t j, const vec3 s)
{
    const uint32_t n = m->n;
    float hl = sqrtf(s[0] * s[0] + s[2] * s[2]);
    float dx = s[0] / hl, dz = s[2] / hl, tanv = s[1] / hl;
    float h = H(m, i, j);
    for (float t = 0.1f;; t += 0.1f) {
        float x = (float)i + dx * t, z = (float)j + dz * t;
        if (x < 0 || z < 0 || x > (float)(n - 1) || z > (float)(n - 1))
            return false;
        uint32_t x0 = (uint32_t)x, z0 = (uint32_t)z;
        uint32_t x1 = x0 + 1 < n ? x0 + 1 : x0, z1 = z0 + 1 < n ? z0 + 1 : z0;
        float fx = x - (float)x0, fz = z - (float)z0;
        float a = H(m, x0, z0), b = H(m, x1, z0), c = H(m, x0, z1), e = H(m, x1, z1);
        float ter = a + (b - a) * fx + (c - a) * fz + (a - b - c + e) * fx * fz;
        if (ter > h + t * m->spacing * tanv + 1e-3f)
            return true;
    }
}

/* Compares the light map's shadow decisions (samples facing the sun only)
 * with both references; returns the agreement fractions. */
static void compare(const hz_heightmap *hm, float spacing, float az, float el, double *lines_ok, double *bil_ok,
                    size_t *facing)
{
    const uint32_t n = hm->size;
    const float Ie = 0.3f;
    uint8_t *lm = malloc(hz_lightmap_bound(hm));
    assert_non_null(lm);
    hz_lightmap_desc d = {.hm = hm, .spacing = spacing, .ambient = Ie};
    hz_sun_direction(az, el, d.sun_dir);
    assert_int_equal(hz_lightmap_build(&d, lm, NULL, NULL), HZ_OK);
    bf_map m = {hm, n, spacing};
    size_t ok1 = 0, ok2 = 0, cnt = 0, more = 0;
    uint8_t *refs = calloc((size_t)n * n, 1), *mism = calloc((size_t)n * n, 1); /* refs: 0 away, 1 lit, 2 shadow */
    assert_true(refs && mism);
    for (uint32_t j = 0; j < n; j++)
        for (uint32_t i = 0; i < n; i++) {
            /* cos(r) as the light map computes it. */
            uint32_t il = i ? i - 1 : 0, ir = i + 1 < n ? i + 1 : n - 1, jd = j ? j - 1 : 0, ju = j + 1 < n ? j + 1 : n - 1;
            float gx = (H(&m, ir, j) - H(&m, il, j)) / ((float)(ir - il) * spacing);
            float gz = (H(&m, i, ju) - H(&m, i, jd)) / ((float)(ju - jd) * spacing);
            float c = (-gx * d.sun_dir[0] + d.sun_dir[1] - gz * d.sun_dir[2]) / sqrtf(gx * gx + 1 + gz * gz);
            uint8_t v = lm[(size_t)j * n + i];
            if (c <= 0.0f) {
                assert_int_equal(v, q(Ie));
                continue;
            }
            cnt++;
            bool sweep_shadow = v == q(Ie) && q(c * (1 - Ie) + Ie) != q(Ie);
            if (!sweep_shadow && v != q(Ie))
                assert_true(abs((int)v - (int)q(c * (1 - Ie) + Ie)) <= 1); /* lit: exactly the formula */
            if (q(c * (1 - Ie) + Ie) == q(Ie)) {
                ok1++, ok2++; /* grazing: indistinguishable */
                continue;
            }
            bool ref = shadow_lines(&m, i, j, d.sun_dir);
            refs[(size_t)j * n + i] = ref ? 2 : 1;
            mism[(size_t)j * n + i] = sweep_shadow != ref;
            ok1 += sweep_shadow == ref;
            more += sweep_shadow && !ref;
            ok2 += sweep_shadow == shadow_bilinear(&m, i, j, d.sun_dir);
        }
    /* The sweep errs toward shadow (it interpolates a max). */
    /* Where they disagree, the reference changes its mind within a sample:
     * the sweep only moves shadow edges, by at most one sample. */
    size_t off_edge = 0;
    for (uint32_t j = 1; j + 1 < n; j++)
        for (uint32_t i = 1; i + 1 < n; i++) {
            if (!mism[(size_t)j * n + i])
                continue;
            bool edge = false;
            for (int dj = -1; dj <= 1; dj++)
                for (int di = -1; di <= 1; di++)
                    edge |= refs[(size_t)(j + dj) * n + i + di] != refs[(size_t)j * n + i];
            off_edge += !edge;
        }
    printf("  disagreements: %zu sweep-only shadow, %zu ray-only shadow, %zu not on a shadow edge\n", more,
           cnt - ok1 - more, off_edge);
    assert_true(off_edge <= (cnt - ok1) / 20);
    free(mism);
    free(refs);
    *lines_ok = (double)ok1 / (double)cnt;
    *bil_ok = (double)ok2 / (double)cnt;
    *facing = cnt;
    free(lm);
}

static void test_matches_ray_march(void **state)
{
    (void)state;
    const uint32_t n = 129;
    hz_heightmap hm;
    make_hm(&hm, n, HZ_LAYOUT_LINEAR, hills, NULL);
    static const float cases[][2] = {{90, 25}, {0, 35}, {225, 20}, {315, 40}, {30, 25}, {200, 15}, {110, 30}};
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        double a1, a2;
        size_t cnt;
        compare(&hm, 5.0f, cases[k][0], cases[k][1], &a1, &a2, &cnt);
        bool exact_dir = fmodf(cases[k][0], 45.0f) == 0.0f;
        printf("sun az %3.0f el %2.0f: %zu samples face the sun; agreement with the line ray march %.4f, "
               "with the bilinear ray march %.4f\n",
               (double)cases[k][0], (double)cases[k][1], cnt, a1, a2);
        assert_true(cnt > n * n / 4);
        if (exact_dir)
            assert_true(a1 == 1.0); /* axis and diagonal suns: the sweep is exact */
        else
            assert_true(a1 >= 0.96);
        assert_true(a2 >= 0.95);
    }
    hz_heightmap_destroy(&hm);
}

/* Threads and layouts change nothing. */
static void test_threads_and_layouts_identical(void **state)
{
    (void)state;
    const uint32_t n = 513;
    hz_heightmap lin, blk;
    make_hm(&lin, n, HZ_LAYOUT_LINEAR, hills, NULL);
    make_hm(&blk, n, HZ_LAYOUT_BLOCKED, hills, NULL);
    size_t bytes = hz_lightmap_bound(&lin);
    assert_int_equal(bytes, (size_t)n * n);
    uint8_t *a = malloc(bytes), *b = malloc(bytes);
    static const float az[] = {20, 135, 250, 333};
    for (size_t k = 0; k < 4; k++) {
        hz_lightmap_desc d = {.hm = &lin, .spacing = 4.0f, .threads = 1};
        hz_sun_direction(az[k], 25.0f, d.sun_dir);
        hz_lightmap_stats s1, s2;
        assert_int_equal(hz_lightmap_build(&d, a, &s1, NULL), HZ_OK);
        assert_int_equal(s1.threads, 1);
        for (uint32_t t = 2; t <= 5; t++) {
            d.threads = t;
            d.hm = t & 1 ? &blk : &lin;
            memset(b, 0xAB, bytes);
            assert_int_equal(hz_lightmap_build(&d, b, &s2, NULL), HZ_OK);
            assert_int_equal(s2.threads, t);
            assert_memory_equal(a, b, bytes);
            assert_int_equal(s1.shadowed, s2.shadowed);
        }
        assert_true(s1.shadowed > 1000); /* the hills do cast shadows */
    }
    free(a);
    free(b);
    hz_heightmap_destroy(&lin);
    hz_heightmap_destroy(&blk);
}

static float tilted(uint32_t i, uint32_t j, void *u)
{
    (void)j, (void)u;
    return 0.5f * (float)i; /* rises toward +x: slope 0.5 with spacing 1 */
}

static void test_special_suns(void **state)
{
    (void)state;
    const uint32_t n = 65;
    hz_heightmap hm;
    make_hm(&hm, n, HZ_LAYOUT_LINEAR, tilted, NULL);
    uint8_t *lm = malloc(hz_lightmap_bound(&hm));
    hz_lightmap_desc d = {.hm = &hm, .spacing = 1.0f, .ambient = 0.2f};
    hz_lightmap_stats st;
    /* Below the horizon: Ie everywhere. */
    hz_sun_direction(90, -5, d.sun_dir);
    assert_int_equal(hz_lightmap_build(&d, lm, &st, NULL), HZ_OK);
    for (size_t k = 0; k < (size_t)n * n; k++)
        assert_int_equal(lm[k], q(0.2f));
    /* Zenith: no shadow, I = n.y (1 - Ie) + Ie = (1/sqrt(1.25)) 0.8 + 0.2. */
    d.sun_dir[0] = 0, d.sun_dir[1] = 2, d.sun_dir[2] = 0;
    assert_int_equal(hz_lightmap_build(&d, lm, &st, NULL), HZ_OK);
    assert_int_equal(st.shadowed, 0);
    for (size_t k = 0; k < (size_t)n * n; k++)
        assert_int_equal(lm[k], q(0.8f / sqrtf(1.25f) + 0.2f));
    /* Sun in the east, 20 degrees: the slope (rising toward +x, 26.6 deg)
     * faces away from it: all Ie, and none counted as shadowed. */
    hz_sun_direction(90, 20, d.sun_dir);
    assert_int_equal(hz_lightmap_build(&d, lm, &st, NULL), HZ_OK);
    assert_int_equal(st.facing_away, (uint64_t)n * n);
    assert_int_equal(st.shadowed, 0);
    /* Sun in the east, 30 degrees: grazing light up the slope, nothing shadowed. */
    hz_sun_direction(90, 30, d.sun_dir);
    assert_int_equal(hz_lightmap_build(&d, lm, &st, NULL), HZ_OK);
    assert_int_equal(st.shadowed, 0);
    assert_int_equal(st.facing_away, 0);
    for (size_t k = 0; k < (size_t)n * n; k++)
        assert_int_equal(lm[k], q((0.5f - 0.5f * cosf(glm_rad(30.0f))) / sqrtf(1.25f) * 0.8f + 0.2f));
    free(lm);
    hz_heightmap_destroy(&hm);
}

static void test_errors(void **state)
{
    (void)state;
    hz_heightmap hm;
    make_hm(&hm, 33, HZ_LAYOUT_LINEAR, hills, NULL);
    uint8_t lm[33 * 33];
    hz_err err = {0};
    hz_lightmap_desc d = {.hm = &hm, .spacing = 1.0f, .sun_dir = {0, 1, 0}};
    assert_int_equal(hz_lightmap_build(&d, lm, NULL, &err), HZ_OK);
    d.sun_dir[1] = 0;
    assert_int_equal(hz_lightmap_build(&d, lm, NULL, &err), HZ_ERR_VALUE);
    assert_non_null(strstr(err.msg, "sun direction"));
    d.sun_dir[1] = NAN;
    assert_int_equal(hz_lightmap_build(&d, lm, NULL, &err), HZ_ERR_VALUE);
    d.sun_dir[1] = 1;
    d.spacing = -1;
    assert_int_equal(hz_lightmap_build(&d, lm, NULL, &err), HZ_ERR_VALUE);
    d.spacing = 1;
    d.ambient = 1.5f;
    assert_int_equal(hz_lightmap_build(&d, lm, NULL, &err), HZ_ERR_VALUE);
    assert_non_null(strstr(err.msg, "ambient"));
    d.ambient = 0;
    assert_int_equal(hz_lightmap_build(&d, NULL, NULL, &err), HZ_ERR_VALUE);
    assert_int_equal(hz_lightmap_build(NULL, lm, NULL, &err), HZ_ERR_VALUE);
    d.threads = 1000; /* clamped, not an error */
    assert_int_equal(hz_lightmap_build(&d, lm, NULL, &err), HZ_OK);
    hz_heightmap_destroy(&hm);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_wall_shadow_length),
        cmocka_unit_test(test_wall_north_sun),
        cmocka_unit_test(test_casters_shadow),
        cmocka_unit_test(test_sun_heights),
        cmocka_unit_test(test_matches_ray_march),
        cmocka_unit_test(test_threads_and_layouts_identical),
        cmocka_unit_test(test_special_suns),
        cmocka_unit_test(test_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
