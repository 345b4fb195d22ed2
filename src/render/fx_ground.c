/* Ground effects: the light map with shadows (R5), the detail textures per
 * ground type (R4), a user colour map, and the forest cover under billboard
 * trees. Textures only; terrain_fs.glsl does the shading. */
#include "render_internal.h"

#include "horizon/lightmap.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define DETAIL_SIZE 256u

static void set_filtering(GLenum target, bool mip, GLenum wrap)
{
    glTexParameteri(target, GL_TEXTURE_MIN_FILTER, mip ? GL_LINEAR_MIPMAP_NEAREST : GL_LINEAR);
    glTexParameteri(target, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTexParameteri(target, GL_TEXTURE_WRAP_S, (GLint)wrap);
    glTexParameteri(target, GL_TEXTURE_WRAP_T, (GLint)wrap);
}

/* Bilinear resample of an RGBA8 square image to DETAIL_SIZE (wrapping). */
static void resample_rgba(const uint8_t *src, uint32_t n, uint8_t *dst)
{
    for (uint32_t y = 0; y < DETAIL_SIZE; y++)
        for (uint32_t x = 0; x < DETAIL_SIZE; x++) {
            float u = ((float)x + 0.5f) * (float)n / (float)DETAIL_SIZE - 0.5f;
            float v = ((float)y + 0.5f) * (float)n / (float)DETAIL_SIZE - 0.5f;
            float fu = floorf(u), fv = floorf(v);
            uint32_t x0 = (uint32_t)(((int64_t)fu % (int64_t)n + (int64_t)n) % (int64_t)n);
            uint32_t y0 = (uint32_t)(((int64_t)fv % (int64_t)n + (int64_t)n) % (int64_t)n);
            uint32_t x1 = (x0 + 1) % n, y1 = (y0 + 1) % n;
            float a = u - fu, b = v - fv;
            for (int c = 0; c < 4; c++) {
                float p = src[4 * ((size_t)y0 * n + x0) + (size_t)c] * (1 - a) + src[4 * ((size_t)y0 * n + x1) + (size_t)c] * a;
                float q = src[4 * ((size_t)y1 * n + x0) + (size_t)c] * (1 - a) + src[4 * ((size_t)y1 * n + x1) + (size_t)c] * a;
                dst[4 * ((size_t)y * DETAIL_SIZE + x) + (size_t)c] = (uint8_t)(p * (1 - b) + q * b + 0.5f);
            }
        }
}

/* Luminance of an RGBA8 detail texture into channel ch of the packed one. */
static void pack_channel(uint8_t *packed, const uint8_t *rgba, int ch)
{
    for (size_t k = 0; k < (size_t)DETAIL_SIZE * DETAIL_SIZE; k++) {
        unsigned l = ((unsigned)rgba[4 * k] + rgba[4 * k + 1] + rgba[4 * k + 2] + 1) / 3;
        packed[4 * k + (size_t)ch] = (uint8_t)l;
    }
}

static hz_result upload_detail(hz_renderer *r, hz_err *err)
{
    if (!r->detail_tex)
        glGenTextures(1, &r->detail_tex);
    glBindTexture(GL_TEXTURE_2D, r->detail_tex);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, DETAIL_SIZE, DETAIL_SIZE, 0, GL_RGBA, GL_UNSIGNED_BYTE, r->detail_cpu);
    glGenerateMipmap(GL_TEXTURE_2D);
    set_filtering(GL_TEXTURE_2D, true, GL_REPEAT);
    /* NOTE: no anisotropic filtering: llvmpipe does it in software, ~1000x slower. */
    glBindTexture(GL_TEXTURE_2D, 0);
    return hz_gl_check(err, "detail texture");
}

/* The detail textures packed as one RGBA8 texture, one ground type's
 * luminance per channel (grass, rock, snow, sand): one fetch per scale gives
 * all four, where an array would need one per type (texture fetches are the
 * cost on a software rasteriser). */
hz_result fx_ground_ensure(hz_renderer *r, hz_err *err)
{
    if (r->detail_ready)
        return HZ_OK;
    if (!r->detail_cpu) {
        uint8_t *img = malloc((size_t)DETAIL_SIZE * DETAIL_SIZE * 4);
        r->detail_cpu = malloc((size_t)DETAIL_SIZE * DETAIL_SIZE * 4);
        if (!img || !r->detail_cpu) {
            free(img);
            return hz_err_set(err, HZ_ERR_MEMORY, "renderer: out of memory for detail textures");
        }
        for (int k = 0; k < HZ_GROUND_COUNT; k++) {
            hz_texgen_detail((hz_ground)k, DETAIL_SIZE, 1, img);
            pack_channel(r->detail_cpu, img, k);
        }
        free(img);
    }
    hz_result res = upload_detail(r, err);
    r->detail_ready = res == HZ_OK;
    return res;
}

void fx_ground_bind(hz_renderer *r)
{
    glActiveTexture(GL_TEXTURE0 + FX_UNIT_LIGHTMAP);
    glBindTexture(GL_TEXTURE_2D, r->lightmap_tex);
    glActiveTexture(GL_TEXTURE0 + FX_UNIT_DETAIL);
    glBindTexture(GL_TEXTURE_2D, r->detail_tex);
    glActiveTexture(GL_TEXTURE0 + FX_UNIT_COLORMAP);
    glBindTexture(GL_TEXTURE_2D, r->colormap_tex);
    glActiveTexture(GL_TEXTURE0 + FX_UNIT_COVER);
    glBindTexture(GL_TEXTURE_2D, r->cover_tex);
    glActiveTexture(GL_TEXTURE0 + FX_UNIT_IMG_OV);
    glBindTexture(GL_TEXTURE_2D, r->img_ov_tex);
    glActiveTexture(GL_TEXTURE0 + FX_UNIT_IMG_TILES);
    glBindTexture(GL_TEXTURE_2D_ARRAY, r->img_tiles_tex);
    glActiveTexture(GL_TEXTURE0);
}

void fx_ground_destroy(hz_renderer *r)
{
    glDeleteTextures(1, &r->lightmap_tex);
    glDeleteTextures(1, &r->sunh_tex);
    r->sunh_tex = 0;
    glDeleteTextures(1, &r->detail_tex);
    glDeleteTextures(1, &r->colormap_tex);
    glDeleteTextures(1, &r->cover_tex);
    glDeleteTextures(1, &r->img_ov_tex);
    glDeleteTextures(1, &r->img_tiles_tex);
    r->img_ov_tex = r->img_tiles_tex = 0;
    r->has_imagery = false;
    r->lightmap_tex = r->detail_tex = r->colormap_tex = r->cover_tex = 0;
    r->has_lightmap = r->has_colormap = r->has_cover = r->detail_ready = false;
    free(r->detail_cpu);
    r->detail_cpu = NULL;
}

/* A finite, non-zero sun direction. */
static bool sun_ok(const float *s)
{
    return s && isfinite(s[0]) && isfinite(s[1]) && isfinite(s[2]) && (s[0] != 0.0f || s[1] != 0.0f || s[2] != 0.0f);
}

/* Within 0.25 degree. */
static bool same_sun(const vec3 sun, const vec3 built)
{
    float a = glm_vec3_norm((float *)sun), b = glm_vec3_norm((float *)built);
    if (!(a > 0.0f) || !(b > 0.0f))
        return false;
    return glm_vec3_dot((float *)sun, (float *)built) / (a * b) >= cosf(glm_rad(0.25f));
}

bool fx_lightmap_matches(const hz_renderer *r, const vec3 sun)
{
    return r->has_lightmap && same_sun(sun, r->lightmap_sun);
}

bool fx_sun_heights_match(const hz_renderer *r, const vec3 sun)
{
    return r->sunh_tex && same_sun(sun, r->sunh_sun);
}

hz_result hz_renderer_set_sun_heights(hz_renderer *r, const float *heights, const uint32_t rect[4],
                                      const float sun_dir[3], hz_err *err)
{
    HZ_ASSERT(r);
    hz_result ctx = fx_check_context(r, err, "hz_renderer_set_sun_heights");
    if (ctx != HZ_OK)
        return ctx;
    if (!heights) {
        glDeleteTextures(1, &r->sunh_tex);
        r->sunh_tex = 0;
        return HZ_OK;
    }
    if (!r->has_heights || !hz_sample_rect_inside(rect, r->size))
        return hz_err_set(err, HZ_ERR_VALUE, "renderer: sun heights rectangle outside the %u-sample heightmap",
                          r->has_heights ? r->size : 0);
    if (r->max_tex > 0 && (rect[2] > (uint32_t)r->max_tex || rect[3] > (uint32_t)r->max_tex))
        return hz_err_set(err, HZ_ERR_VALUE, "renderer: sun heights of %u x %u samples exceed the GPU's %d texels",
                          rect[2], rect[3], r->max_tex);
    if (!sun_ok(sun_dir))
        return hz_err_set(err, HZ_ERR_VALUE, "renderer: sun heights without a valid sun direction");
    for (size_t k = 0; k < (size_t)rect[2] * rect[3]; k++)
        if (!isfinite(heights[k]))
            return hz_err_set(err, HZ_ERR_VALUE, "renderer: sun height %zu is not finite", k);
    hz_gl_drain();
    if (!r->sunh_tex)
        glGenTextures(1, &r->sunh_tex);
    glBindTexture(GL_TEXTURE_2D, r->sunh_tex);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_R32F, (GLsizei)rect[2], (GLsizei)rect[3], 0, GL_RED, GL_FLOAT, heights);
    set_filtering(GL_TEXTURE_2D, false, GL_CLAMP_TO_EDGE);
    glBindTexture(GL_TEXTURE_2D, 0);
    hz_result res = hz_gl_check(err, "sun heights upload (GL_R32F)");
    if (res != HZ_OK) {
        glDeleteTextures(1, &r->sunh_tex);
        r->sunh_tex = 0;
        return res;
    }
    /* Sample (i0 + a, j0 + b) at world (i0 + a, j0 + b) * spacing sits at the centre of texel (a, b). */
    r->sunh_map[0] = 1.0f / (r->spacing * (float)rect[2]);
    r->sunh_map[1] = 1.0f / (r->spacing * (float)rect[3]);
    r->sunh_map[2] = (0.5f - (float)rect[0]) / (float)rect[2];
    r->sunh_map[3] = (0.5f - (float)rect[1]) / (float)rect[3];
    memcpy(r->sunh_sun, sun_dir, sizeof r->sunh_sun);
    return HZ_OK;
}

hz_result hz_renderer_set_lightmap(hz_renderer *r, const uint8_t *lm, uint32_t size, const float sun_dir[3],
                                   hz_err *err)
{
    HZ_ASSERT(r);
    hz_result ctx = fx_check_context(r, err, "hz_renderer_set_lightmap");
    if (ctx != HZ_OK)
        return ctx;
    if (!lm) {
        r->has_lightmap = false;
        return HZ_OK;
    }
    if (!r->has_heights || size != r->size)
        return hz_err_set(err, HZ_ERR_VALUE, "renderer: light map of %u samples per side for a heightmap of %u", size,
                          r->has_heights ? r->size : 0);
    if (!sun_ok(sun_dir))
        return hz_err_set(err, HZ_ERR_VALUE, "renderer: light map without a valid sun direction");
    hz_gl_drain();
    /* Too big for one texture: every second sample. */
    uint32_t step = 1, texels = size;
    while (r->max_tex > 0 && texels > (uint32_t)r->max_tex) {
        step *= 2;
        texels = (size - 1) / step + 1;
    }
    const uint8_t *src = lm;
    uint8_t *tmp = NULL;
    if (step > 1) {
        tmp = malloc((size_t)texels * texels);
        if (!tmp)
            return hz_err_set(err, HZ_ERR_MEMORY, "renderer: out of memory for the light map");
        for (uint32_t j = 0; j < texels; j++)
            for (uint32_t i = 0; i < texels; i++)
                tmp[(size_t)j * texels + i] = lm[(size_t)j * step * size + (size_t)i * step];
        src = tmp;
    }
    if (!r->lightmap_tex)
        glGenTextures(1, &r->lightmap_tex);
    glBindTexture(GL_TEXTURE_2D, r->lightmap_tex);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_R8, (GLsizei)texels, (GLsizei)texels, 0, GL_RED, GL_UNSIGNED_BYTE, src);
    glGenerateMipmap(GL_TEXTURE_2D);
    set_filtering(GL_TEXTURE_2D, true, GL_CLAMP_TO_EDGE);
    glBindTexture(GL_TEXTURE_2D, 0);
    free(tmp);
    hz_result res = hz_gl_check(err, "light map upload (GL_R8)");
    if (res != HZ_OK) {
        r->has_lightmap = false;
        return res;
    }
    /* Sample i sits at the centre of texel i / step. */
    r->lm_xform[0] = 1.0f / (r->spacing * (float)step * (float)texels);
    r->lm_xform[1] = 0.5f / (float)texels;
    memcpy(r->lightmap_sun, sun_dir, sizeof r->lightmap_sun);
    r->has_lightmap = true;
    return HZ_OK;
}

hz_result hz_renderer_set_detail_texture(hz_renderer *r, hz_ground ground, const uint8_t *rgba, uint32_t size,
                                         hz_err *err)
{
    HZ_ASSERT(r);
    if ((unsigned)ground >= HZ_GROUND_COUNT || !rgba || size < 4 || size > 8192 || (size & (size - 1)))
        return hz_err_set(err, HZ_ERR_VALUE, "renderer: detail texture needs a ground type < %u and a square "
                          "power-of-two size (got %u)", (unsigned)HZ_GROUND_COUNT, size);
    hz_result ctx = fx_check_context(r, err, "hz_renderer_set_detail_texture");
    if (ctx != HZ_OK)
        return ctx;
    hz_gl_drain();
    hz_result res = fx_ground_ensure(r, err);
    if (res != HZ_OK)
        return res;
    uint8_t *img = malloc((size_t)DETAIL_SIZE * DETAIL_SIZE * 4);
    if (!img)
        return hz_err_set(err, HZ_ERR_MEMORY, "renderer: out of memory for a detail texture");
    resample_rgba(rgba, size, img);
    pack_channel(r->detail_cpu, img, (int)ground);
    free(img);
    return upload_detail(r, err);
}

static hz_result upload_2d(GLuint *tex, GLenum ifmt, GLenum fmt, const uint8_t *px, uint32_t w, uint32_t h,
                           int max_tex, hz_err *err, const char *what)
{
    if (w == 0 || h == 0 || (max_tex > 0 && (w > (uint32_t)max_tex || h > (uint32_t)max_tex)))
        return hz_err_set(err, HZ_ERR_VALUE, "renderer: %s of %ux%u (the GPU takes up to %d)", what, w, h, max_tex);
    hz_gl_drain();
    if (!*tex)
        glGenTextures(1, tex);
    glBindTexture(GL_TEXTURE_2D, *tex);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
    glTexImage2D(GL_TEXTURE_2D, 0, (GLint)ifmt, (GLsizei)w, (GLsizei)h, 0, fmt, GL_UNSIGNED_BYTE, px);
    glGenerateMipmap(GL_TEXTURE_2D);
    set_filtering(GL_TEXTURE_2D, true, GL_CLAMP_TO_EDGE);

    glBindTexture(GL_TEXTURE_2D, 0);
    return hz_gl_check(err, what);
}

hz_result hz_renderer_set_colormap(hz_renderer *r, const uint8_t *rgb, uint32_t w, uint32_t h, hz_err *err)
{
    HZ_ASSERT(r);
    hz_result ctx = fx_check_context(r, err, "hz_renderer_set_colormap");
    if (ctx != HZ_OK)
        return ctx;
    if (!rgb) {
        r->has_colormap = false;
        return HZ_OK;
    }
    hz_result res = upload_2d(&r->colormap_tex, GL_RGB8, GL_RGB, rgb, w, h, r->max_tex, err, "colour map");
    r->has_colormap = res == HZ_OK;
    return res;
}

hz_result hz_renderer_set_imagery(hz_renderer *r, const hz_imagery *im, hz_err *err)
{
    HZ_ASSERT(r);
    hz_result ctx = fx_check_context(r, err, "hz_renderer_set_imagery");
    if (ctx != HZ_OK)
        return ctx;
    r->has_imagery = false;
    if (!im)
        return HZ_OK;
    if (!im->overview_rgba || !im->overview_side || !(im->extent > 0) || (im->tiles && !im->tile_rgba))
        return hz_err_set(err, HZ_ERR_VALUE, "renderer: empty imagery");
    hz_result res = upload_2d(&r->img_ov_tex, GL_RGBA8, GL_RGBA, im->overview_rgba, im->overview_side,
                              im->overview_side, r->max_tex, err, "imagery overview");
    if (res != HZ_OK)
        return res;
    glDeleteTextures(1, &r->img_tiles_tex);
    r->img_tiles_tex = 0;
    if (im->tiles) {
        const GLsizei L = (GLsizei)(im->tile + 2 * im->border), layers = (GLsizei)(im->tiles * im->tiles);
        GLint max_layers = 0;
        glGetIntegerv(GL_MAX_ARRAY_TEXTURE_LAYERS, &max_layers);
        if (layers > max_layers || (r->max_tex > 0 && L > r->max_tex))
            return hz_err_set(err, HZ_ERR_VALUE,
                              "renderer: imagery of %u tiles exceeds the GPU's %d texture layers (lower --imagery-max)",
                              (unsigned)layers, max_layers);
        /* Mip levels 0..2 only: the border holds 4 texels, 1 at level 2;
         * the shader takes the overview beyond. */
        glGenTextures(1, &r->img_tiles_tex);
        glBindTexture(GL_TEXTURE_2D_ARRAY, r->img_tiles_tex);
        glTexStorage3D(GL_TEXTURE_2D_ARRAY, 3, GL_RGBA8, L, L, layers);
        glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
        glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
        glTexSubImage3D(GL_TEXTURE_2D_ARRAY, 0, 0, 0, 0, L, L, layers, GL_RGBA, GL_UNSIGNED_BYTE, im->tile_rgba);
        glGenerateMipmap(GL_TEXTURE_2D_ARRAY);
        glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MAX_LEVEL, 2);
        set_filtering(GL_TEXTURE_2D_ARRAY, true, GL_CLAMP_TO_EDGE);
        glBindTexture(GL_TEXTURE_2D_ARRAY, 0);
        res = hz_gl_check(err, "imagery tiles");
        if (res != HZ_OK)
            return res;
    }
    /* uv = (world.xz - origin) * 1 / extent; w: tiles per side */
    r->img_map[0] = (float)im->origin_x;
    r->img_map[1] = (float)im->origin_z;
    r->img_map[2] = (float)(1.0 / im->extent);
    r->img_map[3] = (float)im->tiles;
    r->img_tile[0] = (float)im->tile;
    r->img_tile[1] = (float)im->border;
    r->has_imagery = true;
    return HZ_OK;
}

hz_result hz_renderer_set_forest_cover(hz_renderer *r, const uint8_t *cover, uint32_t side, hz_err *err)
{
    HZ_ASSERT(r);
    hz_result ctx = fx_check_context(r, err, "hz_renderer_set_forest_cover");
    if (ctx != HZ_OK)
        return ctx;
    if (!cover) {
        r->has_cover = false;
        return HZ_OK;
    }
    hz_result res = upload_2d(&r->cover_tex, GL_R8, GL_RED, cover, side, side, r->max_tex, err, "forest cover");
    r->has_cover = res == HZ_OK;
    return res;
}
