/* Effects (SPEC R1-R9), headless on llvmpipe: each check asserts the
 * property the effect promises (the light-map formula, the feedback formula,
 * the mirrored shape, the hidden flare...) and, for the six scenes,
 * compares with a golden image in tests/render/golden/ with a tolerance.
 * HZ_UPDATE_GOLDEN=1 rewrites the golden images (look at them first).
 * Images go to HZ_TEST_TMP/fx_*.png. argv[1] = "gl33_": the GL 3.3 fallback
 * (no glClipControl), property checks only. */
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

#include "horizon/lightmap.h"
#include "horizon/render.h"
#include "test_hills.h"

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wconversion"
#pragma GCC diagnostic ignored "-Wsign-conversion"
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#define STB_IMAGE_IMPLEMENTATION
#define STBI_ONLY_PNG
#include <stb_image.h>
#pragma GCC diagnostic pop

#define W 320u
#define H 180u
#define NPX ((size_t)W * H)
#define N 257u
#define SPACING 20.0f

static const char *g_prefix = "";
static bool g_gl33 = false;

typedef struct fixture {
    hz_gl *gl;
    hz_renderer *r;       /* the hills */
    hz_heightmap hm;
    uint32_t *idx;
    uint32_t count;
    hz_renderer *flat;    /* a plain with a wall: shadows, water, detail */
    hz_heightmap flat_hm;
    uint8_t *a, *b, *c;   /* W*H*3 scratch images */
} fixture;

/* ---- terrain ---------------------------------------------------------------- */


/* A plain at 100 m with a 200 m wall along x = 2560 (i = 128). */
static float plain_wall(float x, float z)
{
    (void)z;
    return fabsf(x - 2560.0f) < 1.0f ? 300.0f : 100.0f;
}

static void make_hm(hz_heightmap *hm, float (*f)(float, float))
{
    float *v = malloc((size_t)N * N * sizeof *v);
    assert_non_null(v);
    float mn = INFINITY, mx = -INFINITY;
    for (uint32_t j = 0; j < N; j++)
        for (uint32_t i = 0; i < N; i++) {
            float h = f((float)i * SPACING, (float)j * SPACING);
            v[(size_t)j * N + i] = h;
            mn = fminf(mn, h), mx = fmaxf(mx, h);
        }
    *hm = (hz_heightmap){.size = N, .levels = 8, .layout = HZ_LAYOUT_LINEAR, .scale = (mx - mn) / 65535.0f,
                         .offset = mn};
    hm->size_bytes = (size_t)N * N * sizeof(uint16_t);
    hm->h = malloc(hm->size_bytes);
    assert_non_null(hm->h);
    for (size_t k = 0; k < (size_t)N * N; k++)
        hm->h[k] = (uint16_t)lrintf((v[k] - mn) / hm->scale);
    free(v);
}

static uint32_t *grid_indices(uint32_t n, uint32_t *count)
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

/* ---- images -------------------------------------------------------------------- */

static void save(const char *name, const uint8_t *rgb)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/%sfx_%s.png", HZ_TEST_TMP, g_prefix, name);
    hz_err err = {0};
    if (hz_image_write_png(path, rgb, W, H, &err) != HZ_OK)
        fail_msg("png: %s", err.msg);
}

static void draw_read(hz_renderer *r, const hz_camera *cam, const hz_scene_params *sp, const uint32_t *idx,
                      uint32_t count, uint8_t *rgb, hz_draw_stats *ds)
{
    hz_err err = {0};
    if (hz_renderer_draw(r, cam, sp, idx, count, ds, &err) != HZ_OK)
        fail_msg("draw: %s", err.msg);
    if (hz_renderer_read_rgb(r, rgb, &err) != HZ_OK)
        fail_msg("read: %s", err.msg);
}

/* Golden comparison: mean |diff| per channel < 1.5 and 99.5 % of the
 * channels within 10 (llvmpipe is deterministic for a build; the tolerance
 * absorbs other Mesa/LLVM builds' rounding). */
static void golden(const char *name, const uint8_t *rgb)
{
    save(name, rgb);
    if (g_gl33)
        return; /* the fallback's depth precision differs: properties only */
    char path[1024];
    snprintf(path, sizeof path, "%s/%s.png", HZ_GOLDEN_DIR, name);
    const char *upd = getenv("HZ_UPDATE_GOLDEN");
    if (upd && upd[0] == '1') {
        hz_err err = {0};
        if (hz_image_write_png(path, rgb, W, H, &err) != HZ_OK)
            fail_msg("golden: %s", err.msg);
        printf("updated %s\n", path);
        return;
    }
    int w, h, n;
    uint8_t *g = stbi_load(path, &w, &h, &n, 3);
    if (!g)
        fail_msg("golden image %s missing (HZ_UPDATE_GOLDEN=1 makes it)", path);
    assert_int_equal(w, W);
    assert_int_equal(h, H);
    double sum = 0;
    size_t over = 0;
    int worst = 0;
    for (size_t k = 0; k < NPX * 3; k++) {
        int d = abs((int)g[k] - (int)rgb[k]);
        sum += d;
        over += d > 10;
        worst = d > worst ? d : worst;
    }
    stbi_image_free(g);
    double mean = sum / (double)(NPX * 3);
    printf("golden %s: mean |diff| %.3f, %zu channels over 10, worst %d\n", name, mean, over, worst);
    assert_true(mean < 1.5);
    assert_true(over <= NPX * 3 / 200);
}

static double mean_abs_diff(const uint8_t *a, const uint8_t *b)
{
    double s = 0;
    for (size_t k = 0; k < NPX * 3; k++)
        s += abs((int)a[k] - (int)b[k]);
    return s / (double)(NPX * 3);
}

static const uint8_t *px(const uint8_t *rgb, int x, int y)
{
    return rgb + ((size_t)y * W + (size_t)x) * 3;
}

/* World point -> pixel (x right, y down); false if behind or off screen. */
static bool project(const hz_camera *cam, const float p[3], float *sx, float *sy)
{
    mat4 vp;
    mat4 view, proj;
    hz_camera_view(cam, view);
    hz_camera_proj_reverse_z(cam, proj);
    glm_mat4_mul(proj, view, vp);
    vec4 w = {p[0], p[1], p[2], 1.0f}, c;
    glm_mat4_mulv(vp, w, c);
    if (c[3] <= 0)
        return false;
    *sx = (c[0] / c[3] * 0.5f + 0.5f) * (float)W;
    *sy = (0.5f - c[1] / c[3] * 0.5f) * (float)H;
    return *sx >= 0 && *sy >= 0 && *sx < (float)W && *sy < (float)H;
}

static hz_camera camera(float x, float y, float z, float yaw, float pitch)
{
    return (hz_camera){.pos = {x, y, z}, .yaw = yaw, .pitch = pitch, .fov_y = 60.0f, .aspect = (float)W / (float)H,
                       .znear = 1.0f, .zfar = 20000.0f};
}

/* ---- fixture --------------------------------------------------------------------- */

static int setup(void **state)
{
    fixture *fx = calloc(1, sizeof *fx);
    hz_err err = {0};
    fx->gl = hz_gl_create_headless(&err);
    if (!fx->gl) {
        fprintf(stderr, "hz_gl_create_headless: %s\n", err.msg);
        return -1; /* a GPU test that cannot run is a failure, not a skip */
    }
    printf("GL: %s\n", hz_gl_describe(fx->gl));
    make_hm(&fx->hm, test_hills);
    make_hm(&fx->flat_hm, plain_wall);
    fx->r = hz_renderer_create(&(hz_renderer_desc){.width = W, .height = H}, &err);
    fx->flat = hz_renderer_create(&(hz_renderer_desc){.width = W, .height = H}, &err);
    if (!fx->r || !fx->flat || hz_renderer_set_heightmap(fx->r, &fx->hm, SPACING, 1.0f, &err) != HZ_OK ||
        hz_renderer_set_heightmap(fx->flat, &fx->flat_hm, SPACING, 1.0f, &err) != HZ_OK) {
        fprintf(stderr, "renderer: %s\n", err.msg);
        return -1;
    }
    fx->idx = grid_indices(N, &fx->count);
    fx->a = malloc(NPX * 3);
    fx->b = malloc(NPX * 3);
    fx->c = malloc(NPX * 3);
    *state = fx;
    return 0;
}

static int teardown(void **state)
{
    fixture *fx = *state;
    if (!fx)
        return 0;
    hz_renderer_destroy(fx->r);
    hz_renderer_destroy(fx->flat);
    hz_gl_destroy(fx->gl);
    free(fx->hm.h);
    free(fx->flat_hm.h);
    free(fx->idx);
    free(fx->a);
    free(fx->b);
    free(fx->c);
    free(fx);
    return 0;
}

/* ---- sky (R1) ------------------------------------------------------------------------ */

/* Dense cloud: bright and grey-white (the sky is far bluer than red). */
static bool is_cloud(const uint8_t *p)
{
    return p[0] > 150 && (int)p[2] - (int)p[0] < 45;
}

static void test_sky_only(void **state)
{
    fixture *fx = *state;
    hz_camera cam = camera(2560, 1500, 2560, 20, 25);
    hz_scene_params sp = {.effects = HZ_FX_SKY, .time = 30.0};
    hz_sun_direction(200, 35, sp.sun_dir); /* behind the camera */
    draw_read(fx->r, &cam, &sp, NULL, 0, fx->a, NULL);
    golden("sky", fx->a);
    size_t clouds = 0, blue = 0;
    for (size_t k = 0; k < NPX; k++) {
        clouds += is_cloud(fx->a + 3 * k);
        blue += fx->a[3 * k + 2] > fx->a[3 * k] + 40;
    }
    printf("sky: %.1f %% cloud, %.1f %% blue sky\n", 100.0 * (double)clouds / NPX, 100.0 * (double)blue / NPX);
    assert_true(clouds > NPX / 50 && clouds < NPX * 7 / 10);
    assert_true(blue > NPX / 5);
    /* The same time gives the same sky; a minute later the clouds moved. */
    draw_read(fx->r, &cam, &sp, NULL, 0, fx->b, NULL);
    assert_memory_equal(fx->a, fx->b, NPX * 3);
    sp.time = 90.0;
    draw_read(fx->r, &cam, &sp, NULL, 0, fx->b, NULL);
    double moved = mean_abs_diff(fx->a, fx->b);
    printf("sky: 60 s later the image changed by %.2f per channel\n", moved);
    assert_true(moved > 1.0);
    /* A clear sky has no clouds, and more cover gives more. */
    hz_fx_settings clear = {.cloud_cover = -1.0f}, overcast = {.cloud_cover = 0.85f};
    sp.fx = &clear;
    draw_read(fx->r, &cam, &sp, NULL, 0, fx->b, NULL);
    size_t c0 = 0, c1 = 0;
    for (size_t k = 0; k < NPX; k++)
        c0 += is_cloud(fx->b + 3 * k);
    sp.fx = &overcast;
    draw_read(fx->r, &cam, &sp, NULL, 0, fx->b, NULL);
    for (size_t k = 0; k < NPX; k++)
        c1 += is_cloud(fx->b + 3 * k);
    save("sky_overcast", fx->b);
    printf("sky: clear %zu cloud pixels, overcast %zu\n", c0, c1);
    assert_int_equal(c0, 0);
    assert_true(c1 > clouds);
    /* The gradient follows the sun: at dusk the zenith is darker. */
    sp.fx = &clear;
    hz_camera up = camera(2560, 1500, 2560, 20, 80);
    draw_read(fx->r, &up, &sp, NULL, 0, fx->b, NULL);
    hz_sun_direction(200, 2, sp.sun_dir);
    draw_read(fx->r, &up, &sp, NULL, 0, fx->c, NULL);
    const uint8_t *noon = px(fx->b, W / 2, H / 2), *dusk = px(fx->c, W / 2, H / 2);
    assert_true(dusk[0] + dusk[1] + dusk[2] + 60 < noon[0] + noon[1] + noon[2]);
}

/* ---- sun and flare (R2) ------------------------------------------------------------------ */

static void test_sun_with_flare(void **state)
{
    fixture *fx = *state;
    /* The sun 20 degrees right of the view and a little up; no terrain. */
    hz_camera cam = camera(2560, 1500, 2560, -20, 4);
    hz_fx_settings clear = {.cloud_cover = -1.0f};
    hz_scene_params sp = {.effects = HZ_FX_SKY, .fx = &clear};
    hz_sun_direction(0, 12, sp.sun_dir);
    hz_draw_stats ds;
    draw_read(fx->r, &cam, &sp, NULL, 0, fx->a, &ds);
    assert_true(ds.sun_visible == -1.0f); /* flare off: not measured */
    sp.effects |= HZ_FX_FLARE;
    draw_read(fx->r, &cam, &sp, NULL, 0, fx->b, &ds);
    golden("flare", fx->b);
    printf("flare: sun visible %.3f\n", (double)ds.sun_visible);
    assert_true(ds.sun_visible == 1.0f);
    /* Additive: nothing gets darker. */
    for (size_t k = 0; k < NPX * 3; k++)
        assert_true(fx->b[k] + 1 >= fx->a[k]);
    /* The sun's pixel, and where the elements lie on the sun -> centre line. */
    float sx, sy;
    const float far[3] = {2560 + 1e5f * sp.sun_dir[0], 1500 + 1e5f * sp.sun_dir[1], 2560 + 1e5f * sp.sun_dir[2]};
    assert_true(project(&cam, far, &sx, &sy));
    const float cx = W / 2.0f, cy = H / 2.0f;
    /* Element t = 1.40: a ring of radius 0.15 H, past the centre. */
    float ex = sx + (cx - sx) * 1.40f, ey = sy + (cy - sy) * 1.40f, rr = 0.86f * 0.15f * (float)H;
    int ring = 0, inside = 0;
    for (int k = 0; k < 16; k++) {
        float a = (float)k * 0.3927f;
        int x = (int)(ex + rr * cosf(a)), y = (int)(ey + rr * sinf(a));
        if (x < 0 || y < 0 || x >= (int)W || y >= (int)H)
            continue;
        ring += px(fx->b, x, y)[0] - px(fx->a, x, y)[0];
    }
    inside = px(fx->b, (int)ex, (int)ey)[0] - px(fx->a, (int)ex, (int)ey)[0];
    printf("flare: ring element adds %d (16 points), its centre %d\n", ring, inside);
    assert_true(ring > 16 * 2);
    assert_true(ring > 16 * inside);
    /* Far from the line (the corner opposite the glow's side) nothing changes much. */
    int corner_x = sx > cx ? 4 : (int)W - 5, corner_y = sy > cy ? 4 : (int)H - 5;
    const uint8_t *ca = px(fx->a, corner_x, corner_y), *cb = px(fx->b, corner_x, corner_y);
    assert_true(abs(cb[0] - ca[0]) <= 3 && abs(cb[2] - ca[2]) <= 3);
    /* Near the sun it is bright. */
    assert_true(px(fx->b, (int)sx, (int)sy)[0] >= 250);
}

static void test_flare_hidden_by_mountain(void **state)
{
    fixture *fx = *state;
    /* Low in the south, looking north at the mountain; the sun right behind it. */
    hz_camera cam = camera(2900, 900, 4400, 0, 10);
    hz_fx_settings clear = {.cloud_cover = -1.0f};
    hz_scene_params sp = {.effects = HZ_FX_SKY | HZ_FX_FLARE, .fx = &clear};
    hz_sun_direction(0, 8, sp.sun_dir);
    hz_draw_stats ds;
    draw_read(fx->r, &cam, &sp, fx->idx, fx->count, fx->a, &ds);
    golden("flare_hidden", fx->a);
    printf("flare behind the mountain: sun visible %.3f\n", (double)ds.sun_visible);
    assert_true(ds.sun_visible == 0.0f);
    sp.effects = HZ_FX_SKY;
    draw_read(fx->r, &cam, &sp, fx->idx, fx->count, fx->b, NULL);
    assert_memory_equal(fx->a, fx->b, NPX * 3); /* no trace of a flare */
    /* Higher up the sun clears the mountain and the flare is back. */
    hz_sun_direction(0, 24, sp.sun_dir);
    sp.effects = HZ_FX_SKY | HZ_FX_FLARE;
    draw_read(fx->r, &cam, &sp, fx->idx, fx->count, fx->a, &ds);
    save("flare_above_mountain", fx->a);
    assert_true(ds.sun_visible == 1.0f);
    /* Behind a cloud bank it dims (the query counts cloud cover too). */
    hz_fx_settings overcast = {.cloud_cover = 1.0f};
    sp.fx = &overcast;
    draw_read(fx->r, &cam, &sp, fx->idx, fx->count, fx->a, &ds);
    printf("flare behind overcast: sun visible %.3f\n", (double)ds.sun_visible);
    assert_true(ds.sun_visible < 0.5f);
}

/* ---- light map with shadows (R5) ----------------------------------------------------------- */

static void test_shadow_light_map_formula(void **state)
{
    fixture *fx = *state;
    const float Ie = 0.3f;
    hz_err err = {0};
    uint8_t *lm = malloc(hz_lightmap_bound(&fx->flat_hm));
    assert_non_null(lm);
    /* Sun in the east, 20 degrees up: the 200 m wall shades the plain for
     * 200 / tan 20 = 549 m to its west. */
    hz_lightmap_desc d = {.hm = &fx->flat_hm, .spacing = SPACING, .ambient = Ie};
    hz_sun_direction(90, 20, d.sun_dir);
    assert_int_equal(hz_lightmap_build(&d, lm, NULL, &err), HZ_OK);
    assert_int_equal(hz_renderer_set_lightmap(fx->flat, lm, N, d.sun_dir, &err), HZ_OK);
    /* Straight down from 2.9 km over x = 2400: x maps to columns. */
    hz_camera cam = camera(2400, 3000, 2560, 0, -89.9f);
    hz_scene_params sp = {.effects = HZ_FX_SHADOWS, .fog_density = -1.0f, .ambient = Ie};
    glm_vec3_copy(d.sun_dir, sp.sun_dir);
    draw_read(fx->flat, &cam, &sp, fx->idx, fx->count, fx->a, NULL);
    golden("shadows", fx->a);
    /* Mean colour of the lit plain (x 1500..1850) and the shaded one (2100..2450). */
    double lit[3] = {0}, dark[3] = {0};
    size_t nl = 0, nd = 0;
    for (int y = 40; y < (int)H - 40; y++)
        for (int x = 0; x < (int)W; x++) {
            float wx = 2400.0f + ((float)x + 0.5f - W / 2.0f) * (2.0f * 2900.0f * tanf(glm_rad(30.0f)) / (float)H);
            const uint8_t *p = px(fx->a, x, y);
            if (wx > 1500 && wx < 1850) {
                for (int c = 0; c < 3; c++)
                    lit[c] += p[c];
                nl++;
            } else if (wx > 2100 && wx < 2450) {
                for (int c = 0; c < 3; c++)
                    dark[c] += p[c];
                nd++;
            }
        }
    assert_true(nl > 500 && nd > 500);
    /* The light map's values there (flat ground: cos r = sin 20). */
    const float I_lit = floorf((sinf(glm_rad(20.0f)) * (1 - Ie) + Ie) * 255 + 0.5f) / 255.0f;
    const float I_dark = floorf(Ie * 255 + 0.5f) / 255.0f;
    for (int c = 0; c < 3; c++) {
        lit[c] /= (double)nl, dark[c] /= (double)nd;
        double want = lit[c] * I_dark / I_lit;
        printf("shadows: channel %d lit %.2f shaded %.2f, formula says %.2f\n", c, lit[c], dark[c], want);
        assert_true(fabs(dark[c] - want) < 1.0 + 0.02 * want);
    }
    /* The wall's top (the ridge) is lit: brighter than the shaded valley. */
    float wx, wy;
    const float top[3] = {2560, 300, 2560};
    assert_true(project(&cam, top, &wx, &wy));
    assert_true(px(fx->a, (int)wx, (int)wy)[1] > dark[1] + 10);
    /* A sun that moved away from the light map's: no stale shadows, per-pixel
     * Lambert instead (the plain is uniform). */
    hz_sun_direction(60, 20, sp.sun_dir);
    draw_read(fx->flat, &cam, &sp, fx->idx, fx->count, fx->b, NULL);
    const uint8_t *l = px(fx->b, 60, H / 2), *s = px(fx->b, 150, H / 2); /* lit and (was) shaded plain */
    assert_true(abs(l[1] - s[1]) <= 2);
    free(lm);
}

/* ---- water (R9) ------------------------------------------------------------------------------ */

/* The object hook draws a red tower (the known shape) in every pass, with the
 * pass's matrices and clip plane. */
typedef struct tower {
    GLuint prog;
    GLint vp, clip;
    int calls[2];
} tower;

static const char *tower_vs = "#version 330 core\n"
                              "uniform mat4 u_vp; uniform vec4 u_clip;\n"
                              "const vec3 lo = vec3(2500.0, 80.0, 1440.0), hi = vec3(2620.0, 420.0, 1560.0);\n"
                              "void main() {\n"
                              "  int f = gl_VertexID / 6, k = gl_VertexID % 6;\n"
                              "  const vec2 q[6] = vec2[6](vec2(0,0), vec2(1,0), vec2(0,1), vec2(0,1), vec2(1,0), vec2(1,1));\n"
                              "  vec3 t = vec3(0.0); int ax = f / 2; float side = float(f % 2);\n"
                              "  if (ax == 0) t = vec3(side, q[k].x, q[k].y); else if (ax == 1) t = vec3(q[k].x, side, q[k].y);\n"
                              "  else t = vec3(q[k].x, q[k].y, side);\n"
                              "  vec3 p = mix(lo, hi, t);\n"
                              "  gl_ClipDistance[0] = dot(u_clip, vec4(p, 1.0));\n"
                              "  gl_Position = u_vp * vec4(p, 1.0);\n"
                              "}\n";
static const char *tower_fs = "#version 330 core\nout vec4 o; void main() { o = vec4(0.9, 0.05, 0.05, 1.0); }\n";

static void tower_hook(void *user, const hz_pass_info *pi)
{
    tower *t = user;
    t->calls[pi->pass == HZ_PASS_REFLECTION]++;
    glUseProgram(t->prog);
    glUniformMatrix4fv(t->vp, 1, GL_FALSE, (const float *)pi->viewproj);
    glUniform4fv(t->clip, 1, pi->clip_plane);
    GLuint vao;
    glGenVertexArrays(1, &vao);
    glBindVertexArray(vao);
    glDisable(GL_CULL_FACE);
    glDrawArrays(GL_TRIANGLES, 0, 36);
    glBindVertexArray(0);
    glDeleteVertexArrays(1, &vao);
    glUseProgram(0);
}

static GLuint compile(GLenum type, const char *src)
{
    GLuint s = glCreateShader(type);
    glShaderSource(s, 1, &src, NULL);
    glCompileShader(s);
    GLint ok = 0;
    glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
    if (!ok) {
        char log[512];
        glGetShaderInfoLog(s, sizeof log, NULL, log);
        fail_msg("tower shader: %s", log);
    }
    return s;
}

static bool is_red(const uint8_t *p)
{
    return p[0] > p[1] + 40 && p[0] > p[2] + 40;
}

static void test_water_reflects_known_shape(void **state)
{
    fixture *fx = *state;
    hz_err err = {0};
    tower tw = {0};
    tw.prog = glCreateProgram();
    GLuint vs = compile(GL_VERTEX_SHADER, tower_vs), fs = compile(GL_FRAGMENT_SHADER, tower_fs);
    glAttachShader(tw.prog, vs);
    glAttachShader(tw.prog, fs);
    glLinkProgram(tw.prog);
    glDeleteShader(vs);
    glDeleteShader(fs);
    tw.vp = glGetUniformLocation(tw.prog, "u_vp");
    tw.clip = glGetUniformLocation(tw.prog, "u_clip");
    /* A lake 10 m deep over the plain (water at 110 m), the tower standing in it. */
    const float level = 110.0f;
    hz_water_plane lake = {.height = level, .rect = {0, 0, 5120, 5120}};
    assert_int_equal(hz_renderer_set_water(fx->flat, &lake, 1, NULL, 0, &err), HZ_OK);
    hz_camera cam = camera(2560, 180, 3000, 0, -4);
    hz_fx_settings calm = {.cloud_cover = -1.0f};
    hz_scene_params sp = {.effects = HZ_FX_SKY | HZ_FX_WATER, .fx = &calm, .draw_objects = tower_hook,
                          .draw_objects_user = &tw};
    hz_draw_stats ds;
    draw_read(fx->flat, &cam, &sp, fx->idx, fx->count, fx->a, &ds);
    golden("water", fx->a);
    assert_int_equal(ds.reflections, 1);
    assert_true(tw.calls[0] == 1 && tw.calls[1] == 1);
    /* Above the water line: the tower; below it, its mirror image: the
     * tower's point (x, y) mirrored to (x, 2 level - y). */
    const float real_pt[3] = {2560, 300, 1500}, mirror_pt[3] = {2560, 2 * level - 300, 1500};
    float rx, ry, mx, my;
    assert_true(project(&cam, real_pt, &rx, &ry));
    assert_true(project(&cam, mirror_pt, &mx, &my));
    printf("water: tower at (%.0f, %.0f), its reflection expected at (%.0f, %.0f)\n", (double)rx, (double)ry,
           (double)mx, (double)my);
    assert_true(is_red(px(fx->a, (int)rx, (int)ry)));
    size_t red_below = 0, red_beside = 0;
    for (int dy = -3; dy <= 3; dy++)
        for (int dx = -2; dx <= 2; dx++) {
            red_below += is_red(px(fx->a, (int)mx + dx, (int)my + dy));
            red_beside += is_red(px(fx->a, (int)mx + dx + 60, (int)my + dy));
        }
    printf("water: %zu of 35 red pixels at the mirror point, %zu beside it\n", red_below, red_beside);
    assert_true(red_below >= 25);
    assert_int_equal(red_beside, 0);
    /* Without water there is no mirror image: ground or the tower's foot only. */
    sp.effects = HZ_FX_SKY;
    draw_read(fx->flat, &cam, &sp, fx->idx, fx->count, fx->b, NULL);
    assert_false(is_red(px(fx->b, (int)mx, (int)my)));
    /* The mirrored camera's own terrain selection gives the same result here
     * (the whole grid either way). */
    sp.effects = HZ_FX_SKY | HZ_FX_WATER;
    sp.reflection_indices = fx->idx;
    sp.reflection_count = fx->count;
    draw_read(fx->flat, &cam, &sp, fx->idx, fx->count, fx->b, NULL);
    assert_memory_equal(fx->a, fx->b, NPX * 3);
    /* Waves move with time. */
    sp.time = 3.0;
    draw_read(fx->flat, &cam, &sp, fx->idx, fx->count, fx->b, NULL);
    assert_true(mean_abs_diff(fx->a, fx->b) > 0.05);
    /* Two lakes at different heights with their own materials: one
     * reflection pass each; the muddy one (clarity 0.2 m) hides the ground
     * under it, the clear one (20 m) shows it. */
    hz_water_plane two[2] = {{.height = 110.0f, .rect = {0, 0, 2500, 5120}, .material = 0},
                             {.height = 106.0f, .rect = {2620, 0, 5120, 5120}, .material = 1}};
    hz_water_material mats[2] = {{.clarity = 0.2f}, {.clarity = 20.0f}};
    assert_int_equal(hz_renderer_set_water(fx->flat, two, 2, mats, 2, &err), HZ_OK);
    hz_camera down = camera(2560, 1200, 2560, 0, -89.9f);
    hz_scene_params s2 = {.effects = HZ_FX_WATER, .fog_density = -1.0f};
    draw_read(fx->flat, &down, &s2, fx->idx, fx->count, fx->b, &ds);
    save("water_two", fx->b);
    assert_int_equal(ds.reflections, 2);
    s2.effects = 0;
    draw_read(fx->flat, &down, &s2, fx->idx, fx->count, fx->c, NULL);
    const uint8_t *muddy = px(fx->b, 40, H / 2), *clear = px(fx->b, W - 40, H / 2);
    const uint8_t *ground_l = px(fx->c, 40, H / 2), *ground_r = px(fx->c, W - 40, H / 2);
    int dm = abs(muddy[1] - ground_l[1]), dc = abs(clear[1] - ground_r[1]);
    printf("water: muddy lake differs from its ground by %d, the clear one by %d\n", dm, dc);
    assert_true(dm > 2 * dc + 5);
    /* Looking from under the water there is no water pass. */
    hz_camera under = camera(2560, 105, 3000, 0, 5);
    draw_read(fx->flat, &under, &sp, fx->idx, fx->count, fx->b, &ds);
    assert_int_equal(ds.reflections, 0);
    assert_int_equal(hz_renderer_set_water(fx->flat, NULL, 0, NULL, 0, &err), HZ_OK);
    glDeleteProgram(tw.prog);
}

/* Water over samples without data is deep, whatever heights fill them: an
 * SRTM sea is nodata, and its filled heights are no sea floor to see
 * through to (nor, with the terrain masked there, is anything else). */
static void test_water_deep_without_data(void **state)
{
    fixture *fx = *state;
    hz_err err = {0};
    hz_water_plane lake = {.height = 110.0f, .rect = {0, 0, 5120, 5120}};
    hz_water_material clear = {.clarity = 20.0f};
    assert_int_equal(hz_renderer_set_water(fx->flat, &lake, 1, &clear, 1, &err), HZ_OK);
    hz_camera down = camera(2560, 1200, 2560, 0, -89.9f);
    hz_scene_params sp = {.effects = HZ_FX_WATER, .fog_density = -1.0f};
    draw_read(fx->flat, &down, &sp, fx->idx, fx->count, fx->b, NULL);
    const uint32_t n = fx->flat_hm.size;
    uint8_t *valid = malloc((size_t)n * n);
    assert_non_null(valid);
    for (size_t k = 0; k < (size_t)n * n; k++)
        valid[k] = k % n >= n / 2; /* the west half without data */
    assert_int_equal(hz_renderer_set_valid(fx->flat, valid, &err), HZ_OK);
    draw_read(fx->flat, &down, &sp, fx->idx, fx->count, fx->c, NULL);
    save("water_nodata", fx->c);
    const uint8_t *west_b = px(fx->b, 40, H / 2), *west_c = px(fx->c, 40, H / 2);
    const uint8_t *east_b = px(fx->b, W - 40, H / 2), *east_c = px(fx->c, W - 40, H / 2);
    const int d = abs(west_b[0] - west_c[0]) + abs(west_b[1] - west_c[1]) + abs(west_b[2] - west_c[2]);
    printf("water without data: west (%d %d %d) -> (%d %d %d), east (%d %d %d) -> (%d %d %d)\n", west_b[0], west_b[1],
           west_b[2], west_c[0], west_c[1], west_c[2], east_b[0], east_b[1], east_b[2], east_c[0], east_c[1], east_c[2]);
    assert_memory_equal(east_b, east_c, 3); /* with data: the same clear lake */
    assert_true(d > 20);                    /* without: the ground below no longer shows */
    /* deep: the same whatever lies under it (the wall's side against the plain) */
    const uint8_t *west_far = px(fx->c, W / 2 - 60, H / 4);
    assert_true(abs(west_far[1] - west_c[1]) <= 3);
    /* cleared: as before */
    assert_int_equal(hz_renderer_set_valid(fx->flat, NULL, &err), HZ_OK);
    draw_read(fx->flat, &down, &sp, fx->idx, fx->count, fx->c, NULL);
    assert_memory_equal(fx->b, fx->c, NPX * 3);
    free(valid);
    assert_int_equal(hz_renderer_set_water(fx->flat, NULL, 0, NULL, 0, &err), HZ_OK);
}

/* A DEM's sea at 0 m over the west half, land at 40-80 m over the east. */
static float sea_west(float x, float z)
{
    return x < 2560.0f ? 0.0f : 40.0f + 40.0f * sinf(z * 0.003f) * sinf(x * 0.002f) * sinf(x * 0.002f);
}

static int rgb_diff(const uint8_t *a, const uint8_t *b)
{
    return abs(a[0] - b[0]) + abs(a[1] - b[1]) + abs(a[2] - b[2]);
}

/* A DEM's sea (hz_water_plane.sea, hz_renderer_set_coast), on a 25.6 km map:
 * - beyond the map it goes on off the sea's edges only, never over the land
 *   the DEM stops short of;
 * - it is deep over the DEM's flat fill 0.1 m under it (no sea floor shows);
 * - with the Earth's curvature its flat cells (km wide out at sea) never dip
 *   under that fill: the water looks the same with and without the ground
 *   drawn below it. */
static void test_sea_coast(void **state)
{
    fixture *fx = *state;
    hz_err err = {0};
    const float sp_m = 100.0f, ext = 256.0f * sp_m;
    hz_heightmap hm;
    make_hm(&hm, sea_west);
    hz_renderer *r = hz_renderer_create(&(hz_renderer_desc){.width = W, .height = H}, &err);
    assert_non_null(r);
    assert_int_equal(hz_renderer_set_heightmap(r, &hm, sp_m, 1.0f, &err), HZ_OK);
    hz_coast coast;
    assert_int_equal(hz_coast_make(&hm, NULL, sp_m, 1.0f, 0.1f, NULL, &coast, &err), HZ_OK);
    hz_water_plane sea = {.height = 0.1f, .sea = true};
    assert_int_equal(hz_renderer_set_water(r, &sea, 1, NULL, 0, &err), HZ_OK);
    hz_scene_params sp = {.effects = HZ_FX_WATER, .fog_density = -1.0f};

    /* From 30 km up: the map and 4 km around it. */
    hz_camera top = camera(ext / 2, 30000.0f, ext / 2, 0, -89.9f);
    top.zfar = 200000.0f;
    const float pts[4][3] = {{-2000.0f, 0, ext / 2},      /* west of the sea */
                             {ext + 2000.0f, 0, ext / 2}, /* east of the land */
                             {ext * 0.25f, 0, -2000.0f},  /* north of the sea */
                             {ext * 0.75f, 0, -2000.0f}}; /* north of the land */
    int pix[4][2];
    for (int k = 0; k < 4; k++) {
        float sx, sy;
        assert_true(project(&top, pts[k], &sx, &sy));
        pix[k][0] = (int)sx, pix[k][1] = (int)sy;
    }
    draw_read(r, &top, &sp, fx->idx, fx->count, fx->a, NULL); /* without a coast: sea all round */
    assert_int_equal(hz_renderer_set_coast(r, &coast, &err), HZ_OK);
    draw_read(r, &top, &sp, fx->idx, fx->count, fx->b, NULL);
    save("sea_coast", fx->b);
    assert_int_equal(hz_renderer_set_water(r, NULL, 0, NULL, 0, &err), HZ_OK);
    draw_read(r, &top, &sp, fx->idx, fx->count, fx->c, NULL); /* no water: the background */
    for (int k = 0; k < 4; k++) {
        const uint8_t *all = px(fx->a, pix[k][0], pix[k][1]), *cst = px(fx->b, pix[k][0], pix[k][1]),
                      *none = px(fx->c, pix[k][0], pix[k][1]);
        printf("sea beyond the map, point %d: everywhere (%d %d %d), coast (%d %d %d), no water (%d %d %d)\n", k,
               all[0], all[1], all[2], cst[0], cst[1], cst[2], none[0], none[1], none[2]);
        assert_true(rgb_diff(all, none) > 30); /* without a coast, water everywhere */
        if (k % 2 == 0)
            assert_true(rgb_diff(cst, all) <= 3); /* off the sea: water */
        else
            assert_memory_equal(cst, none, 3); /* off the land: none */
    }
    if (g_gl33) {
        /* Without glClipControl the depth buffer cannot tell 0.1 m apart at
         * these distances: the rest needs the GL 4.5 path's reverse Z. */
        hz_coast_free(&coast);
        hz_renderer_destroy(r);
        free(hm.h);
        return;
    }
    /* Deep over the fill: a pixel over the sea inside the map looks like the
     * open sea beyond it, not like ground under 0.1 m of water. */
    float sx, sy;
    assert_true(project(&top, (const float[3]){ext * 0.2f, 0, ext / 2}, &sx, &sy));
    const uint8_t *inside = px(fx->b, (int)sx, (int)sy), *open = px(fx->b, pix[0][0], pix[0][1]);
    printf("sea inside the map (%d %d %d), open sea (%d %d %d)\n", inside[0], inside[1], inside[2], open[0], open[1],
           open[2]);
    assert_true(rgb_diff(inside, open) <= 6);
    hz_water_plane lake = sea;
    lake.sea = false;
    assert_int_equal(hz_renderer_set_water(r, &lake, 1, NULL, 0, &err), HZ_OK);
    draw_read(r, &top, &sp, fx->idx, fx->count, fx->c, NULL);
    assert_true(rgb_diff(px(fx->c, (int)sx, (int)sy), inside) > 20); /* a lake shows its floor */

    /* Curved: 1.5 km over the sea near its coast, looking west across it to
     * the open sea (flat cells of 1-4 km sag 0.1-0.6 m there). The ground
     * drawn only where the land is, then everywhere. */
    assert_int_equal(hz_renderer_set_water(r, &sea, 1, NULL, 0, &err), HZ_OK);
    hz_camera low = camera(ext * 0.45f, 1500.0f, ext / 2, 270.0f, -6.0f); /* yaw 270: west */
    low.zfar = 200000.0f;
    low.earth_radius = (float)HZ_EARTH_RADIUS;
    float wx, wy;
    assert_true(project(&(hz_camera){.pos = {ext * 0.45f, 1500.0f, ext / 2}, .yaw = 270.0f, .pitch = -6.0f, .fov_y = 60.0f,
                                     .aspect = (float)W / (float)H, .znear = 1.0f, .zfar = 200000.0f},
                        (const float[3]){ext * 0.1f, 0, ext / 2}, &wx, &wy)); /* looking at the sea */
    uint32_t land_count = 0;
    uint32_t *land = malloc((size_t)fx->count * sizeof *land);
    assert_non_null(land);
    for (uint32_t k = 0; k + 2 < fx->count; k += 3) {
        uint32_t lo = N;
        for (int v = 0; v < 3; v++)
            lo = fx->idx[k + v] % N < lo ? fx->idx[k + v] % N : lo;
        if (lo >= 127) /* cells from the last sea column on */
            for (int v = 0; v < 3; v++)
                land[land_count++] = fx->idx[k + v];
    }
    draw_read(r, &low, &sp, land, land_count, fx->a, NULL);
    draw_read(r, &low, &sp, fx->idx, fx->count, fx->b, NULL);
    save("sea_curved", fx->b);
    size_t differ = 0;
    for (size_t k = 0; k < NPX; k++)
        differ += rgb_diff(fx->a + 3 * k, fx->b + 3 * k) > 6;
    printf("sea with curvature: %zu of %zu pixels differ with the ground drawn under it\n", differ, NPX);
    assert_true(differ <= NPX / 1000);
    free(land);
    hz_coast_free(&coast);
    hz_renderer_destroy(r);
    free(hm.h);
}

/* The reflection pass is drawn only where water can show: a plane under
 * the ground needs none (and changes nothing), and a small lake's pixels are
 * those of the same water in a lake covering the map, whose mirror image is
 * drawn everywhere: nothing its waves sample was left out. */
static void test_water_only_where_it_shows(void **state)
{
    fixture *fx = *state;
    hz_err err = {0};
    hz_camera cam = camera(2560, 180, 3000, 0, -4);
    hz_fx_settings calm = {.cloud_cover = -1.0f};
    hz_scene_params sp = {.effects = HZ_FX_SKY | HZ_FX_WATER, .fx = &calm, .time = 3.0};
    hz_draw_stats ds;
    /* Under the plain (100 m) everywhere. */
    hz_water_plane under = {.height = 90.0f, .rect = {0, 0, 5120, 5120}};
    assert_int_equal(hz_renderer_set_water(fx->flat, &under, 1, NULL, 0, &err), HZ_OK);
    draw_read(fx->flat, &cam, &sp, fx->idx, fx->count, fx->a, &ds);
    assert_int_equal(ds.reflections, 0);
    sp.effects = HZ_FX_SKY;
    draw_read(fx->flat, &cam, &sp, fx->idx, fx->count, fx->b, NULL);
    size_t seen = 0; /* the water effect's terrain variant may round a channel the other way */
    for (size_t k = 0; k < NPX * 3; k++)
        seen += abs(fx->a[k] - fx->b[k]) > 2;
    assert_int_equal(seen, 0);
    /* A small lake in front of the wall, and one over the whole map. */
    sp.effects = HZ_FX_SKY | HZ_FX_WATER;
    hz_water_plane small = {.height = 110.0f, .rect = {2000, 1800, 3100, 2700}};
    hz_water_plane big = {.height = 110.0f, .rect = {0, 0, 5120, 5120}};
    assert_int_equal(hz_renderer_set_water(fx->flat, &small, 1, NULL, 0, &err), HZ_OK);
    draw_read(fx->flat, &cam, &sp, fx->idx, fx->count, fx->a, &ds);
    assert_int_equal(ds.reflections, 1);
    save("water_small", fx->a);
    assert_int_equal(hz_renderer_set_water(fx->flat, &big, 1, NULL, 0, &err), HZ_OK);
    draw_read(fx->flat, &cam, &sp, fx->idx, fx->count, fx->b, NULL);
    sp.effects = HZ_FX_SKY;
    draw_read(fx->flat, &cam, &sp, fx->idx, fx->count, fx->c, NULL);
    size_t lake = 0, off = 0;
    int worst = 0;
    for (size_t p = 0; p < NPX; p++) {
        const uint8_t *a = fx->a + p * 3, *b = fx->b + p * 3, *c = fx->c + p * 3;
        if (abs(a[0] - c[0]) + abs(a[1] - c[1]) + abs(a[2] - c[2]) < 6)
            continue; /* not the small lake's water */
        lake++;
        int d = abs(a[0] - b[0]) + abs(a[1] - b[1]) + abs(a[2] - b[2]);
        worst = d > worst ? d : worst;
        off += d > 6;
    }
    printf("water: %zu pixels of the small lake, %zu differ from the big lake's (worst %d)\n", lake, off, worst);
    assert_true(lake > NPX / 20);
    assert_int_equal(off, 0);
    assert_int_equal(hz_renderer_set_water(fx->flat, NULL, 0, NULL, 0, &err), HZ_OK);
}

/* ---- motion blur and the chain (R7, R8) ------------------------------------------------------------ */

static void test_motion_blur_feedback(void **state)
{
    fixture *fx = *state;
    hz_camera a = camera(2000, 1300, 4700, 15, -12), b = a;
    b.pos[0] += 60.0f; /* the camera moved 60 m to the east */
    b.yaw += 3.0f;
    hz_fx_settings set = {.blur = 0.6f};
    hz_scene_params still = {.effects = 0}, blur = {.effects = HZ_FX_MOTIONBLUR, .fx = &set, .history = 3,
                                                    .reset_history = true};
    uint8_t *plain_a = fx->a, *plain_b = fx->b, *out = fx->c;
    draw_read(fx->r, &a, &still, fx->idx, fx->count, plain_a, NULL);
    draw_read(fx->r, &b, &still, fx->idx, fx->count, plain_b, NULL);
    /* First frame of a history: the frame itself. */
    draw_read(fx->r, &a, &blur, fx->idx, fx->count, out, NULL);
    for (size_t k = 0; k < NPX * 3; k++)
        assert_true(abs((int)out[k] - (int)plain_a[k]) <= 1);
    /* The next frame from the moved camera: P = (1 - f) P_now + f P_prev. */
    blur.reset_history = false;
    draw_read(fx->r, &b, &blur, fx->idx, fx->count, out, NULL);
    golden("motionblur", out);
    size_t off = 0;
    double moved = 0;
    for (size_t k = 0; k < NPX * 3; k++) {
        double want = 0.4 * plain_b[k] + 0.6 * plain_a[k];
        off += fabs(out[k] - want) > 1.5;
        moved += abs((int)out[k] - (int)plain_b[k]);
    }
    printf("motion blur: %zu of %zu channels off the formula by more than 1.5; differs from the still frame by "
           "%.2f per channel\n", off, NPX * 3, moved / (double)(NPX * 3));
    assert_true(off <= NPX * 3 / 1000);
    assert_true(moved / (double)(NPX * 3) > 2.0);
    /* A still camera: the feedback of identical frames is the frame. */
    hz_scene_params s2 = blur;
    s2.history = 4;
    s2.reset_history = true;
    draw_read(fx->r, &b, &s2, fx->idx, fx->count, out, NULL);
    s2.reset_history = false;
    draw_read(fx->r, &b, &s2, fx->idx, fx->count, out, NULL);
    draw_read(fx->r, &b, &s2, fx->idx, fx->count, out, NULL);
    for (size_t k = 0; k < NPX * 3; k++)
        assert_true(abs((int)out[k] - (int)plain_b[k]) <= 1);
    /* Slots do not mix: slot 5 saw only a, slot 6 starts with b. */
    s2.history = 5;
    s2.reset_history = true;
    draw_read(fx->r, &a, &s2, fx->idx, fx->count, out, NULL);
    s2.history = 6;
    draw_read(fx->r, &b, &s2, fx->idx, fx->count, out, NULL);
    for (size_t k = 0; k < NPX * 3; k++)
        assert_true(abs((int)out[k] - (int)plain_b[k]) <= 1);
}

static void test_exposure_gamma_bloom(void **state)
{
    fixture *fx = *state;
    hz_camera cam = camera(2000, 1300, 4700, 15, -12);
    hz_scene_params sp = {0};
    draw_read(fx->r, &cam, &sp, fx->idx, fx->count, fx->a, NULL);
    hz_fx_settings e2 = {.exposure = 2.0f};
    sp.fx = &e2;
    draw_read(fx->r, &cam, &sp, fx->idx, fx->count, fx->b, NULL);
    for (size_t k = 0; k < NPX * 3; k++)
        assert_true(abs((int)fx->b[k] - (fx->a[k] * 2 > 255 ? 255 : fx->a[k] * 2)) <= 2);
    hz_fx_settings g2 = {.gamma = 2.0f};
    sp.fx = &g2;
    draw_read(fx->r, &cam, &sp, fx->idx, fx->count, fx->b, NULL);
    for (size_t k = 0; k < NPX * 3; k++)
        assert_true(fabs(fx->b[k] - 255.0 * sqrt(fx->a[k] / 255.0)) <= 2.5);
    /* Bloom: light spills around the sun, dark ground stays. */
    hz_camera sun_cam = camera(2560, 1500, 2560, -20, 4);
    hz_fx_settings clear = {.cloud_cover = -1.0f};
    hz_scene_params s = {.effects = HZ_FX_SKY, .fx = &clear};
    hz_sun_direction(0, 12, s.sun_dir);
    draw_read(fx->r, &sun_cam, &s, fx->idx, fx->count, fx->a, NULL);
    s.effects |= HZ_FX_BLOOM;
    draw_read(fx->r, &sun_cam, &s, fx->idx, fx->count, fx->b, NULL);
    save("bloom", fx->b);
    float sx, sy;
    const float far[3] = {2560 + 1e5f * s.sun_dir[0], 1500 + 1e5f * s.sun_dir[1], 2560 + 1e5f * s.sun_dir[2]};
    assert_true(project(&sun_cam, far, &sx, &sy));
    int gain = 0;
    for (int k = 0; k < 8; k++) {
        int x = (int)(sx + 6 * cosf((float)k * 0.785f)), y = (int)(sy + 6 * sinf((float)k * 0.785f));
        gain += px(fx->b, x, y)[1] - px(fx->a, x, y)[1];
    }
    printf("bloom: +%d around the sun (8 points 6 px away)\n", gain);
    assert_true(gain > 8 * 3);
    const uint8_t *ga = px(fx->a, W / 2, H - 3), *gb = px(fx->b, W / 2, H - 3);
    assert_true(abs(ga[1] - gb[1]) <= 2);
}

/* ---- billboards, weather, detail, fog ------------------------------------------------------------------ */

static void test_billboards(void **state)
{
    fixture *fx = *state;
    hz_err err = {0};
    hz_camera cam = camera(2000, 900, 4700, 0, -3);
    /* Three big conifers straight ahead, one behind the camera. */
    hz_billboard t[4];
    const float xs[4] = {1900, 2000, 2100, 2000}, zs[4] = {4300, 4250, 4300, 5000};
    for (int k = 0; k < 4; k++)
        t[k] = (hz_billboard){.pos = {xs[k], 700, zs[k]}, .width = 40, .axis = {0, 120, 0}, .rgba = 0xffffffffu,
                              .texture = HZ_SPRITE_CONIFER};
    assert_int_equal(hz_renderer_set_billboards(fx->r, t, 4, &err), HZ_OK);
    hz_scene_params sp = {.effects = HZ_FX_BILLBOARDS};
    hz_draw_stats ds;
    draw_read(fx->r, &cam, &sp, fx->idx, fx->count, fx->a, &ds);
    save("billboards", fx->a);
    assert_int_equal(ds.billboards, 3);
    sp.effects = 0;
    draw_read(fx->r, &cam, &sp, fx->idx, fx->count, fx->b, NULL);
    /* Inside each tree's box about the middle third of the width is trunk or
     * needles (cut-out), outside nothing changed. */
    for (int k = 0; k < 3; k++) {
        const float mid[3] = {xs[k], 760, zs[k]};
        float x, y;
        assert_true(project(&cam, mid, &x, &y));
        const uint8_t *p = px(fx->a, (int)x, (int)y);
        assert_true(p[1] > p[2] && p[1] < 120); /* dark green */
        assert_true(mean_abs_diff(fx->a, fx->b) > 0.2);
    }
    assert_memory_equal(px(fx->a, 0, 0), px(fx->b, 0, 0), 3 * W * 20); /* the sky rows */
    /* A bad slot is refused; removing them leaves the terrain alone. */
    t[0].texture = 99;
    assert_int_equal(hz_renderer_set_billboards(fx->r, t, 4, &err), HZ_ERR_VALUE);
    assert_int_equal(hz_renderer_set_billboards(fx->r, NULL, 0, &err), HZ_OK);
    sp.effects = HZ_FX_BILLBOARDS;
    draw_read(fx->r, &cam, &sp, fx->idx, fx->count, fx->a, &ds);
    assert_int_equal(ds.billboards, 0);
}

static void test_weather(void **state)
{
    fixture *fx = *state;
    hz_camera cam = camera(2000, 1300, 4700, 15, -12);
    hz_fx_settings snow = {.weather = HZ_WEATHER_SNOW, .weather_intensity = 2.0f};
    hz_scene_params sp = {.effects = HZ_FX_WEATHER, .fx = &snow, .time = 4.0};
    hz_draw_stats ds;
    draw_read(fx->r, &cam, &sp, fx->idx, fx->count, fx->a, &ds);
    save("snow", fx->a);
    assert_true(ds.particles > 1000);
    draw_read(fx->r, &cam, &sp, fx->idx, fx->count, fx->b, NULL);
    assert_memory_equal(fx->a, fx->b, NPX * 3); /* same time, same flakes */
    sp.effects = 0;
    draw_read(fx->r, &cam, &sp, fx->idx, fx->count, fx->c, NULL);
    size_t brighter = 0;
    for (size_t k = 0; k < NPX; k++)
        brighter += fx->a[3 * k] + fx->a[3 * k + 1] + fx->a[3 * k + 2] > fx->c[3 * k] + fx->c[3 * k + 1] + fx->c[3 * k + 2] + 30;
    printf("snow: %zu pixels brighter\n", brighter);
    assert_true(brighter > 100 && brighter < NPX / 2);
    sp.effects = HZ_FX_WEATHER;
    sp.time = 4.5;
    draw_read(fx->r, &cam, &sp, fx->idx, fx->count, fx->b, NULL);
    assert_true(mean_abs_diff(fx->a, fx->b) > 0.1); /* they fell */
    hz_fx_settings rain = {.weather = HZ_WEATHER_RAIN};
    sp.fx = &rain;
    draw_read(fx->r, &cam, &sp, fx->idx, fx->count, fx->b, &ds);
    save("rain", fx->b);
    assert_true(ds.particles > 1000);
}

/* Normalised correlation of luminance with itself shifted by (dx, 0). */
static double correlation(const uint8_t *rgb, int dx, int x0, int x1, int y0, int y1)
{
    double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
    size_t n = 0;
    for (int y = y0; y < y1; y++)
        for (int x = x0; x < x1; x++) {
            const uint8_t *p = px(rgb, x, y), *q = px(rgb, x + dx, y);
            double a = p[0] + p[1] + p[2], b = q[0] + q[1] + q[2];
            sa += a, sb += b, saa += a * a, sbb += b * b, sab += a * b;
            n++;
        }
    double ma = sa / (double)n, mb = sb / (double)n;
    double cov = sab / (double)n - ma * mb, va = saa / (double)n - ma * ma, vb = sbb / (double)n - mb * mb;
    return cov / sqrt(va * vb + 1e-9);
}

static void test_detail_without_tiling(void **state)
{
    fixture *fx = *state;
    /* Straight down from 60 m above the plain: 2.6 px per metre. A 12 m
     * detail texture repeats every 31 px. */
    hz_camera cam = camera(1000, 160, 2000, 0, -89.9f);
    const float px_per_m = (float)H / (2.0f * 60.0f * tanf(glm_rad(30.0f)));
    hz_fx_settings set = {.detail_scale = 12.0f};
    hz_scene_params sp = {.effects = HZ_FX_DETAIL, .fx = &set, .fog_density = -1.0f};
    draw_read(fx->flat, &cam, &sp, fx->idx, fx->count, fx->a, NULL);
    save("detail", fx->a);
    sp.effects = 0;
    draw_read(fx->flat, &cam, &sp, fx->idx, fx->count, fx->b, NULL);
    /* Detail is there... */
    double sd_a = 0, sd_b = 0, ma = 0, mb = 0;
    for (size_t k = 0; k < NPX; k++)
        ma += fx->a[3 * k + 1], mb += fx->b[3 * k + 1];
    ma /= NPX, mb /= NPX;
    for (size_t k = 0; k < NPX; k++)
        sd_a += pow(fx->a[3 * k + 1] - ma, 2), sd_b += pow(fx->b[3 * k + 1] - mb, 2);
    sd_a = sqrt(sd_a / NPX), sd_b = sqrt(sd_b / NPX);
    printf("detail: green sd %.1f with, %.1f without; mean %.1f vs %.1f\n", sd_a, sd_b, ma, mb);
    assert_true(sd_a > 2.0 * sd_b + 2.0);
    assert_true(fabs(ma - mb) < 0.12 * mb); /* modulation about 1: the colour stays */
    /* ...and does not repeat: one period away the image is not itself. */
    int period = (int)lrintf(12.0f * px_per_m);
    double c_period = correlation(fx->a, period, 10, (int)W - period - 10, 10, (int)H - 10);
    double c_near = correlation(fx->a, 1, 10, (int)W - period - 10, 10, (int)H - 10);
    printf("detail: correlation %.3f at the repeat (%d px), %.3f at 1 px\n", c_period, period, c_near);
    assert_true(c_period < 0.5);
    assert_true(c_near > c_period);
}

static void test_fog_far_fade_and_height(void **state)
{
    fixture *fx = *state;
    /* View distance 2.5 km over 5 km of hills: the far clip cuts terrain. */
    hz_camera cam = camera(2000, 900, 4900, 10, -2);
    cam.zfar = 2500.0f;
    uint8_t *mask = malloc(NPX);
    assert_non_null(mask);
    double edge[2];
    for (int pass = 0; pass < 2; pass++) {
        hz_scene_params sp = {.effects = pass ? HZ_FX_FOG : 0};
        draw_read(fx->r, &cam, &sp, fx->idx, fx->count, pass ? fx->a : fx->b, NULL);
        hz_err err = {0};
        assert_int_equal(hz_renderer_read_sky_mask(fx->r, mask, &err), HZ_OK);
        const uint8_t *img = pass ? fx->a : fx->b;
        /* Step across the silhouette in every column: sky above, terrain below. */
        double s = 0;
        size_t n = 0;
        for (int x = 0; x < (int)W; x++)
            for (int y = 1; y + 1 < (int)H; y++)
                if (mask[(size_t)(y - 1) * W + (size_t)x] && !mask[(size_t)y * W + (size_t)x]) {
                    const uint8_t *above = px(img, x, y - 1), *below = px(img, x, y + 1);
                    for (int c = 0; c < 3; c++)
                        s += abs(above[c] - below[c]);
                    n++;
                    break;
                }
        edge[pass] = n ? s / (double)n : 0;
    }
    save("fog", fx->a);
    printf("fog: silhouette step %.1f without the fog effect, %.1f with (far fade)\n", edge[0], edge[1]);
    assert_true(edge[1] < 12.0);
    assert_true(edge[1] < 0.5 * edge[0]);
    /* Height fog: low ground fogs more than high ground at the same distance. */
    hz_camera c2 = camera(2560, 2600, 6000, 0, -25);
    hz_fx_settings thick = {.height_fog = 0.004f, .height_fog_falloff = 150.0f};
    hz_scene_params sp = {.effects = HZ_FX_FOG, .fx = &thick};
    draw_read(fx->r, &c2, &sp, fx->idx, fx->count, fx->a, NULL);
    sp.fx = NULL;
    sp.effects = HZ_FX_FOG;
    hz_fx_settings none = {.height_fog = -1.0f};
    sp.fx = &none;
    draw_read(fx->r, &c2, &sp, fx->idx, fx->count, fx->b, NULL);
    save("height_fog", fx->a);
    assert_true(mean_abs_diff(fx->a, fx->b) > 2.0);
    free(mask);
}

static void test_everything_together(void **state)
{
    fixture *fx = *state;
    hz_err err = {0};
    uint8_t *lm = malloc(hz_lightmap_bound(&fx->hm));
    hz_lightmap_desc d = {.hm = &fx->hm, .spacing = SPACING};
    hz_sun_direction(30, 14, d.sun_dir);
    assert_int_equal(hz_lightmap_build(&d, lm, NULL, &err), HZ_OK);
    assert_int_equal(hz_renderer_set_lightmap(fx->r, lm, N, d.sun_dir, &err), HZ_OK);
    hz_water_plane lake = {.height = 420.0f};
    assert_int_equal(hz_renderer_set_water(fx->r, &lake, 1, NULL, 0, &err), HZ_OK);
    hz_scatter_desc td = {.water_level = 420.0f, .density = 6};
    hz_billboard *trees;
    size_t nt;
    assert_int_equal(hz_trees_scatter(&fx->hm, SPACING, 1.0f, &td, &trees, &nt, &err), HZ_OK);
    assert_int_equal(hz_renderer_set_billboards(fx->r, trees, nt, &err), HZ_OK);
    free(trees);
    hz_camera cam = camera(1500, 1100, 4900, 30, -8);
    hz_scene_params sp = {.effects = HZ_FX_ALL, .time = 2.0};
    glm_vec3_copy(d.sun_dir, sp.sun_dir);
    hz_draw_stats ds;
    draw_read(fx->r, &cam, &sp, fx->idx, fx->count, fx->a, &ds);
    save("all", fx->a);
    printf("all effects: %.1f ms, %u billboards, %u particles, %u reflections, sun %.2f\n", ds.draw_ms, ds.billboards,
           ds.particles, ds.reflections, (double)ds.sun_visible);
    assert_true(ds.billboards > 0 && ds.particles > 0);
    /* The sky mask still tells sky from ground. */
    uint8_t *mask = malloc(NPX);
    assert_int_equal(hz_renderer_read_sky_mask(fx->r, mask, &err), HZ_OK);
    size_t sky = 0;
    for (size_t k = 0; k < NPX; k++)
        sky += mask[k];
    assert_true(sky > NPX / 10 && sky < NPX * 9 / 10);
    free(mask);
    /* Resize keeps every target consistent. */
    assert_int_equal(hz_renderer_resize(fx->r, 200, 120, &err), HZ_OK);
    cam.aspect = 200.0f / 120.0f;
    assert_int_equal(hz_renderer_draw(fx->r, &cam, &sp, fx->idx, fx->count, NULL, &err), HZ_OK);
    assert_int_equal(hz_renderer_resize(fx->r, W, H, &err), HZ_OK);
    assert_int_equal(hz_renderer_set_water(fx->r, NULL, 0, NULL, 0, &err), HZ_OK);
    assert_int_equal(hz_renderer_set_billboards(fx->r, NULL, 0, &err), HZ_OK);
    assert_int_equal(hz_renderer_set_lightmap(fx->r, NULL, 0, NULL, &err), HZ_OK);
    free(lm);
}

static void test_errors(void **state)
{
    fixture *fx = *state;
    hz_err err = {0};
    hz_camera cam = camera(2000, 1300, 4700, 15, -12);
    hz_scene_params sp = {.history = HZ_MAX_HISTORY};
    assert_int_equal(hz_renderer_draw(fx->r, &cam, &sp, NULL, 0, NULL, &err), HZ_ERR_VALUE);
    assert_non_null(strstr(err.msg, "history"));
    sp = (hz_scene_params){.effects = 1u << 20};
    assert_int_equal(hz_renderer_draw(fx->r, &cam, &sp, NULL, 0, NULL, &err), HZ_ERR_VALUE);
    sp = (hz_scene_params){.time = NAN};
    assert_int_equal(hz_renderer_draw(fx->r, &cam, &sp, NULL, 0, NULL, &err), HZ_ERR_VALUE);
    sp = (hz_scene_params){.reflection_indices = fx->idx, .reflection_count = 4};
    assert_int_equal(hz_renderer_draw(fx->r, &cam, &sp, NULL, 0, NULL, &err), HZ_ERR_VALUE);
    uint8_t lm[16] = {0};
    const float sun[3] = {0, 1, 0}, zero[3] = {0, 0, 0};
    assert_int_equal(hz_renderer_set_lightmap(fx->r, lm, 4, sun, &err), HZ_ERR_VALUE);
    assert_non_null(strstr(err.msg, "light map"));
    uint8_t *big = calloc((size_t)N * N, 1);
    assert_int_equal(hz_renderer_set_lightmap(fx->r, big, N, zero, &err), HZ_ERR_VALUE);
    free(big);
    hz_water_plane bad = {.height = 10, .rect = {5, 5, 1, 1}};
    assert_int_equal(hz_renderer_set_water(fx->r, &bad, 1, NULL, 0, &err), HZ_ERR_VALUE);
    bad = (hz_water_plane){.height = NAN};
    assert_int_equal(hz_renderer_set_water(fx->r, &bad, 1, NULL, 0, &err), HZ_ERR_VALUE);
    bad = (hz_water_plane){.height = 1, .material = 3};
    assert_int_equal(hz_renderer_set_water(fx->r, &bad, 1, NULL, 0, &err), HZ_ERR_VALUE);
    hz_water_material m = {.clarity = -1};
    bad.material = 0;
    assert_int_equal(hz_renderer_set_water(fx->r, &bad, 1, &m, 1, &err), HZ_ERR_VALUE);
    uint8_t edge[8] = {1, 1, 1, 1, 1, 1, 1, 1};
    const hz_coast coasts[3] = {{.x0 = 2, .x1 = 1, .z1 = 1, .spacing = 20, .edge = edge},
                                {.x1 = 1, .z1 = 1, .spacing = 0, .edge = edge},
                                {.x1 = 1, .z1 = 1, .spacing = 20, .edge = NULL}};
    for (int k = 0; k < 3; k++) {
        assert_int_equal(hz_renderer_set_coast(fx->r, &coasts[k], &err), HZ_ERR_VALUE);
        assert_non_null(strstr(err.msg, "coast"));
    }
    hz_renderer *bare = hz_renderer_create(&(hz_renderer_desc){.width = 16, .height = 16}, &err);
    assert_non_null(bare);
    const hz_coast ok = {.x1 = 1, .z1 = 1, .spacing = 20, .edge = edge};
    assert_int_equal(hz_renderer_set_coast(bare, &ok, &err), HZ_ERR_VALUE); /* no terrain yet */
    hz_renderer_destroy(bare);
    assert_int_equal(hz_renderer_set_coast(fx->r, &ok, &err), HZ_OK);
    assert_int_equal(hz_renderer_set_coast(fx->r, NULL, &err), HZ_OK);
    uint8_t tex[16 * 16 * 4] = {0};
    assert_int_equal(hz_renderer_set_billboard_texture(fx->r, HZ_MAX_BB_TEXTURES, tex, 16, 16, &err), HZ_ERR_VALUE);
    assert_int_equal(hz_renderer_set_detail_texture(fx->r, HZ_GROUND_ROCK, tex, 12, &err), HZ_ERR_VALUE);
    assert_int_equal(hz_renderer_set_detail_texture(fx->r, HZ_GROUND_ROCK, tex, 16, &err), HZ_OK);
    assert_int_equal(hz_renderer_set_colormap(fx->r, tex, 0, 16, &err), HZ_ERR_VALUE);
    /* A user colour map replaces the classes (and can be removed again). */
    uint8_t cm[4 * 4 * 3];
    for (size_t k = 0; k < sizeof cm; k += 3)
        cm[k] = 200, cm[k + 1] = 40, cm[k + 2] = 200;
    assert_int_equal(hz_renderer_set_colormap(fx->r, cm, 4, 4, &err), HZ_OK);
    hz_scene_params none = {.fog_density = -1.0f};
    hz_camera down = camera(2560, 3000, 2560, 0, -89.9f);
    draw_read(fx->r, &down, &none, fx->idx, fx->count, fx->a, NULL);
    const uint8_t *p = px(fx->a, W / 2, H / 2);
    assert_true(p[0] > p[1] + 40 && p[2] > p[1] + 40); /* purple ground */
    assert_int_equal(hz_renderer_set_colormap(fx->r, NULL, 0, 0, &err), HZ_OK);
}

int main(int argc, char **argv)
{
    if (argc > 1) {
        g_prefix = argv[1];
        g_gl33 = strstr(argv[1], "gl33") != NULL;
    }
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sky_only),
        cmocka_unit_test(test_sun_with_flare),
        cmocka_unit_test(test_flare_hidden_by_mountain),
        cmocka_unit_test(test_shadow_light_map_formula),
        cmocka_unit_test(test_water_reflects_known_shape),
        cmocka_unit_test(test_water_deep_without_data),
        cmocka_unit_test(test_sea_coast),
        cmocka_unit_test(test_water_only_where_it_shows),
        cmocka_unit_test(test_motion_blur_feedback),
        cmocka_unit_test(test_exposure_gamma_bloom),
        cmocka_unit_test(test_billboards),
        cmocka_unit_test(test_weather),
        cmocka_unit_test(test_detail_without_tiling),
        cmocka_unit_test(test_fog_far_fade_and_height),
        cmocka_unit_test(test_everything_together),
        cmocka_unit_test(test_errors),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
