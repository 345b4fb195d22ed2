/* horizon renderer: sky + vertex-less terrain in one indexed draw.
 *
 * The heights live on the GPU once, as a GL_R16 texture buffer in row-major
 * order. There is no vertex buffer: the per-frame index buffer holds sample
 * indices and the vertex shader turns gl_VertexID into (i, j, height).
 * Depth is reverse-Z (glClipControl ZERO_TO_ONE, clear 0, GL_GREATER) into a
 * 32-bit float buffer, so far horizons do not z-fight. */
#include "render_internal.h"

#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gl_util.h"
#include "hz_shaders.h" /* generated from shaders/<name>.glsl */
#include "horizon/occlusion.h"

#define DEFAULT_WIDTH 1280u
#define DEFAULT_HEIGHT 720u

/* ---- GL error helpers --------------------------------------------------- */

static const char *fbo_status_name(GLenum s)
{
    switch (s) {
    case GL_FRAMEBUFFER_COMPLETE: return "GL_FRAMEBUFFER_COMPLETE";
    case GL_FRAMEBUFFER_UNDEFINED: return "GL_FRAMEBUFFER_UNDEFINED";
    case GL_FRAMEBUFFER_INCOMPLETE_ATTACHMENT: return "GL_FRAMEBUFFER_INCOMPLETE_ATTACHMENT";
    case GL_FRAMEBUFFER_INCOMPLETE_MISSING_ATTACHMENT: return "GL_FRAMEBUFFER_INCOMPLETE_MISSING_ATTACHMENT";
    case GL_FRAMEBUFFER_INCOMPLETE_DRAW_BUFFER: return "GL_FRAMEBUFFER_INCOMPLETE_DRAW_BUFFER";
    case GL_FRAMEBUFFER_INCOMPLETE_READ_BUFFER: return "GL_FRAMEBUFFER_INCOMPLETE_READ_BUFFER";
    case GL_FRAMEBUFFER_UNSUPPORTED: return "GL_FRAMEBUFFER_UNSUPPORTED";
    case GL_FRAMEBUFFER_INCOMPLETE_MULTISAMPLE: return "GL_FRAMEBUFFER_INCOMPLETE_MULTISAMPLE";
    case GL_FRAMEBUFFER_INCOMPLETE_LAYER_TARGETS: return "GL_FRAMEBUFFER_INCOMPLETE_LAYER_TARGETS";
    }
    return "unknown framebuffer status";
}

static const char *const terrain_names[] = {
    "u_size",    "u_spacing", "u_hscale", "u_hoffset",     "u_viewproj",    "u_sun_dir",    "u_sky_horizon",
    "u_eye",     "u_fog_density", "u_ambient", "u_hrange", "u_wire",        "u_morph_scale", "u_morph_start",
    "u_normal_tex", "u_nrm_scale", "u_map",   "u_tile",     "u_top",         "u_base",       "u_climate",
    "u_img_map", "u_img_tile", "u_tile_shift", "u_water_mask", "u_lit_lod", "u_lit_top",
    "u_morph_near", "u_morph_near_d0", NULL};

/* Whether the frame's colour target keeps alpha (the renderer's own is
 * RGBA8; a window's may have none). */
static bool target_has_alpha(hz_renderer *r)
{
    if (!r->to_default)
        return true;
    if (r->default_alpha < 0) {
        GLint bits = 0;
        glBindFramebuffer(GL_FRAMEBUFFER, 0);
        glGetFramebufferAttachmentParameteriv(GL_FRAMEBUFFER, GL_BACK_LEFT, GL_FRAMEBUFFER_ATTACHMENT_ALPHA_SIZE, &bits);
        r->default_alpha = bits > 0;
    }
    return r->default_alpha > 0;
}

/* The effect bits the terrain shader depends on: without any of them the
 * plain shader gives the same image. */
static uint32_t terrain_fx_bits(const fx_frame *f)
{
    return f->bits & (HZ_FX_SKY | HZ_FX_SHADOWS | HZ_FX_DETAIL | HZ_FX_BILLBOARDS | HZ_FX_FOG | HZ_FX_WATER);
}

hz_result fx_terrain_select(hz_renderer *r, const fx_frame *f, bool patches, hz_err *err)
{
    uint32_t key = terrain_fx_bits(f);
    if (f->lit)
        key |= FX_VARIANT_LIT;
    if (r->has_colormap)
        key |= FX_VARIANT_COLORMAP;
    if (r->has_cover && (f->bits & HZ_FX_BILLBOARDS))
        key |= FX_VARIANT_COVER;
    if (r->has_imagery)
        key |= FX_VARIANT_IMAGERY;
    r->terrain_cur = prog_cache_get(&r->terrain, key, hz_shader_terrain_vs, hz_shader_terrain_fs, "terrain", 2,
                                    terrain_names, err);
    if (!r->terrain_cur)
        return HZ_ERR_GL;
    /* Only the water reflection passes clip (discard) below the plane: a
     * shader that may discard loses the early depth test on llvmpipe. */
    r->terrain_clip_cur = NULL;
    if (f->bits & HZ_FX_WATER) {
        r->terrain_clip_cur = prog_cache_get(&r->terrain, key | FX_VARIANT_CLIP, hz_shader_terrain_vs,
                                             hz_shader_terrain_fs, "terrain (reflection)", 2, terrain_names, err);
        if (!r->terrain_clip_cur)
            return HZ_ERR_GL;
    }
    r->terrain_patch_cur = r->terrain_patch_far = r->terrain_patch_still = r->terrain_patch_far_still = NULL;
    r->terrain_patch_fine = r->terrain_patch_fine_still = NULL;
    r->terrain_patch_simple = r->terrain_patch_fine_simple = r->terrain_patch_far_simple = NULL;
    if (patches) {
        /* --lit-map vertex: the patches read the lit map per vertex (in
         * memory only: a streamed terrain has no lit map). */
        const bool vlit = f->lit && f->sp.lit_per_vertex && !r->streamed;
        const uint32_t pkey = key | FX_VARIANT_PATCH | (r->tile_masked ? FX_VARIANT_MASK : 0u) |
                              (r->streamed ? FX_VARIANT_STREAM : 0u) | (vlit ? FX_VARIANT_VLIT : 0u);
        /* llvmpipe runs the morph code for every vertex, morphing or not
         * (both sides of a branch, masked): still patches get a variant
         * without it. Streamed tiles slide in by morphing: always with it. */
        const bool still = !r->streamed;
        r->terrain_patch_cur = prog_cache_get(&r->terrain, pkey, hz_shader_terrain_patch_vs,
                                              hz_shader_terrain_fs, "terrain (patches)", 2, terrain_names, err);
        if (!r->terrain_patch_cur)
            return HZ_ERR_GL;
        if (still) {
            r->terrain_patch_still =
                prog_cache_get(&r->terrain, pkey | FX_VARIANT_STILL, hz_shader_terrain_patch_vs,
                               hz_shader_terrain_fs, "terrain (still patches)", 2, terrain_names, err);
            if (!r->terrain_patch_still)
                return HZ_ERR_GL;
            /* Most morphing patches morph toward still vertices: their
             * targets are stored, not read from the neighbours, morphed. */
            r->terrain_patch_simple =
                prog_cache_get(&r->terrain, pkey | FX_VARIANT_SIMPLE, hz_shader_terrain_patch_vs,
                               hz_shader_terrain_fs, "terrain (simply morphing patches)", 2, terrain_names, err);
            if (!r->terrain_patch_simple)
                return HZ_ERR_GL;
            /* A patch of the finest level has a vertex on every sample of
             * the lit map: where the map is smooth (litmap_smooth_at), read
             * per vertex and interpolated, the colour differs from the
             * per-pixel read by at most 2 of 255 where the map is magnified
             * (a little more where the levels' estimates differ, far away),
             * and costs a fraction. */
            if (f->lit && !vlit && !f->sp.lit_pixel) {
                r->terrain_patch_fine_still = prog_cache_get(
                    &r->terrain, pkey | FX_VARIANT_STILL | FX_VARIANT_VLIT | FX_VARIANT_FINE,
                    hz_shader_terrain_patch_vs, hz_shader_terrain_fs, "terrain (full-resolution still patches)", 2,
                    terrain_names, err);
                r->terrain_patch_fine =
                    r->terrain_patch_fine_still
                        ? prog_cache_get(&r->terrain, pkey | FX_VARIANT_VLIT | FX_VARIANT_FINE,
                                         hz_shader_terrain_patch_vs, hz_shader_terrain_fs,
                                         "terrain (full-resolution patches)", 2, terrain_names, err)
                        : NULL;
                if (!r->terrain_patch_fine)
                    return HZ_ERR_GL;
                r->terrain_patch_fine_simple = prog_cache_get(
                    &r->terrain, pkey | FX_VARIANT_SIMPLE | FX_VARIANT_VLIT | FX_VARIANT_FINE,
                    hz_shader_terrain_patch_vs, hz_shader_terrain_fs, "terrain (full-resolution simply morphing patches)",
                    2, terrain_names, err);
                if (!r->terrain_patch_fine_simple)
                    return HZ_ERR_GL;
            }
        }
        if (key & HZ_FX_DETAIL) {
            r->terrain_patch_far =
                prog_cache_get(&r->terrain, pkey | FX_VARIANT_DETAIL_FAR, hz_shader_terrain_patch_vs,
                               hz_shader_terrain_fs, "terrain (far patches)", 2, terrain_names, err);
            if (!r->terrain_patch_far)
                return HZ_ERR_GL;
            if (still) {
                r->terrain_patch_far_still = prog_cache_get(
                    &r->terrain, pkey | FX_VARIANT_DETAIL_FAR | FX_VARIANT_STILL, hz_shader_terrain_patch_vs,
                    hz_shader_terrain_fs, "terrain (far still patches)", 2, terrain_names, err);
                if (!r->terrain_patch_far_still)
                    return HZ_ERR_GL;
                r->terrain_patch_far_simple = prog_cache_get(
                    &r->terrain, pkey | FX_VARIANT_DETAIL_FAR | FX_VARIANT_SIMPLE, hz_shader_terrain_patch_vs,
                    hz_shader_terrain_fs, "terrain (far simply morphing patches)", 2, terrain_names, err);
                if (!r->terrain_patch_far_simple)
                    return HZ_ERR_GL;
            }
        }
    }
    return HZ_OK;
}

static hz_result make_programs(hz_renderer *r, hz_err *err)
{
    r->sky_prog = link_program(hz_shader_sky_grid_vs, hz_shader_sky_fs, "sky", 0, 0, err);
    if (!r->sky_prog)
        return HZ_ERR_GL;
    /* NOTE: terrain_vs.glsl stays free of effect code (it is the LOD's); the
     * effects live in terrain_fs.glsl and the common block. */
    r->terrain_plain = prog_cache_get(&r->terrain, 0, hz_shader_terrain_vs, hz_shader_terrain_fs, "terrain", 2,
                                      terrain_names, err);
    if (!r->terrain_plain)
        return HZ_ERR_GL;

    GLuint p = r->sky_prog;
    r->su.inv_viewproj_rot = glGetUniformLocation(p, "u_inv_viewproj_rot");
    r->su.horizon = glGetUniformLocation(p, "u_sky_horizon");
    r->su.zenith = glGetUniformLocation(p, "u_sky_zenith");
    r->su.sun_dir = glGetUniformLocation(p, "u_sun_dir");
    r->su.sky_z = glGetUniformLocation(p, "u_sky_z");

    return hz_gl_check(err, "shader setup");
}

/* ---- render target ------------------------------------------------------- */

static hz_result fbo_alloc(hz_renderer *r, uint32_t w, uint32_t h, hz_err *err)
{
    GLint max_rb = 0;
    glGetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &max_rb);
    if (max_rb > 0 && (w > (uint32_t)max_rb || h > (uint32_t)max_rb))
        return hz_err_set(err, HZ_ERR_UNSUPPORTED, "GL: target %ux%u exceeds GL_MAX_RENDERBUFFER_SIZE %d", w, h,
                          max_rb);
    if (!r->fbo)
        glGenFramebuffers(1, &r->fbo);
    if (!r->color_rb)
        glGenRenderbuffers(1, &r->color_rb);
    if (!r->depth_rb)
        glGenRenderbuffers(1, &r->depth_rb);

    glBindRenderbuffer(GL_RENDERBUFFER, r->color_rb);
    glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, (GLsizei)w, (GLsizei)h);
    glBindRenderbuffer(GL_RENDERBUFFER, r->depth_rb);
    glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT32F, (GLsizei)w, (GLsizei)h);
    glBindRenderbuffer(GL_RENDERBUFFER, 0);
    hz_result res = hz_gl_check(err, "render target allocation (glRenderbufferStorage RGBA8 + DEPTH32F)");
    if (res != HZ_OK)
        return res;

    glBindFramebuffer(GL_FRAMEBUFFER, r->fbo);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, r->color_rb);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, r->depth_rb);
    GLenum status = glCheckFramebufferStatus(GL_FRAMEBUFFER);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    if (status != GL_FRAMEBUFFER_COMPLETE)
        return hz_err_set(err, HZ_ERR_GL, "GL: framebuffer %ux%u incomplete: %s (0x%04x)", w, h,
                          fbo_status_name(status), (unsigned)status);
    return hz_gl_check(err, "framebuffer setup");
}

/* ---- public API ---------------------------------------------------------- */

hz_renderer *hz_renderer_create(const hz_renderer_desc *desc, hz_err *err)
{
    hz_renderer_desc d = desc ? *desc : (hz_renderer_desc){0};
    if (d.width == 0 || d.height == 0) {
        d.width = DEFAULT_WIDTH;
        d.height = DEFAULT_HEIGHT;
    }
    if (d.width > INT_MAX || d.height > INT_MAX) {
        hz_err_set(err, HZ_ERR_VALUE, "renderer: bad target size %ux%u", d.width, d.height);
        return NULL;
    }
    void *ctx = hz_gl_current_context();
    if (!ctx) {
        hz_err_set(err, HZ_ERR_GL, "renderer: no current OpenGL context (create one with hz_gl_create_headless, "
                   "or make the window's context current)");
        return NULL;
    }
    const char *version = (const char *)glGetString(GL_VERSION);
    if (!version) {
        hz_err_set(err, HZ_ERR_GL, "renderer: glGetString(GL_VERSION) returned NULL");
        return NULL;
    }
    int ver = epoxy_gl_version();
    if (epoxy_is_desktop_gl() == false || ver < 33) {
        hz_err_set(err, HZ_ERR_UNSUPPORTED, "renderer: needs desktop OpenGL 3.3 core or newer, context is \"%s\"",
                   version);
        return NULL;
    }

    hz_renderer *r = calloc(1, sizeof *r);
    if (!r) {
        hz_err_set(err, HZ_ERR_MEMORY, "out of memory");
        return NULL;
    }
    r->ctx = ctx;
    r->climate = hz_climate_of_kind(HZ_CLIMATE_TEMPERATE, 45.0);
    r->zscale = 1.0f;
    r->width = d.width;
    r->height = d.height;
    r->to_default = d.to_default_framebuffer;
    r->default_alpha = -1;
    /* Without glClipControl the reverse-Z projection still works (depth
     * lands in [0.5, 1]) but loses precision and the far-plane clip. */
    r->clip_control = ver >= 45 || epoxy_has_gl_extension("GL_ARB_clip_control");
    hz_gl_drain();
    glGetIntegerv(GL_MAX_TEXTURE_BUFFER_SIZE, &r->max_tbo);
    glGetIntegerv(GL_MAX_TEXTURE_SIZE, &r->max_tex);

    if (make_programs(r, err) != HZ_OK)
        goto fail;
    glGenVertexArrays(1, &r->vao);
    glGenBuffers(1, &r->ibo);
    glGenBuffers(1, &r->ibo2);
    glGenBuffers(1, &r->ubo);
    glBindBuffer(GL_UNIFORM_BUFFER, r->ubo);
    glBufferData(GL_UNIFORM_BUFFER, sizeof(fx_common_ubo), NULL, GL_DYNAMIC_DRAW);
    glBindBuffer(GL_UNIFORM_BUFFER, 0);
    glGenBuffers(1, &r->height_buf);
    glGenTextures(1, &r->height_tex);
    glGenBuffers(1, &r->valid_buf);
    glGenTextures(1, &r->valid_tex);
    glGenBuffers(1, &r->coast_buf);
    glGenTextures(1, &r->coast_tex);
    r->coast_rect[2] = -1;
    if (hz_gl_check(err, "renderer object creation") != HZ_OK)
        goto fail;
    if (!r->to_default && fbo_alloc(r, r->width, r->height, err) != HZ_OK)
        goto fail;
    return r;

fail:
    hz_renderer_destroy(r);
    return NULL;
}

void hz_renderer_destroy(hz_renderer *r)
{
    if (!r)
        return;
    if (hz_gl_current_context() != r->ctx) {
        /* Deleting our names here would hit another context's objects; ours
         * die with their own context. */
        hz_bb_field_destroy(r->field);
        free(r->bb_buf);
        free(r->bb_scratch);
        free(r->bb_gpu);
        free(r->detail_cpu);
        free(r->planes);
        free(r->mats);
        free(r->wet_min);
        free(r);
        return;
    }
    /* glDelete* ignore 0 names. */
    fx_ground_destroy(r);
    fx_sky_destroy(r);
    fx_billboards_destroy(r);
    fx_water_destroy(r);
    fx_post_destroy(r);
    glDeleteBuffers(1, &r->ibo2);
    glDeleteBuffers(1, &r->ubo);
    glDeleteProgram(r->sky_prog);
    prog_cache_clear(&r->terrain);
    glDeleteVertexArrays(1, &r->vao);
    glDeleteBuffers(1, &r->ibo);
    glDeleteTextures(1, &r->height_tex);
    glDeleteBuffers(1, &r->height_buf);
    glDeleteTextures(1, &r->valid_tex);
    glDeleteBuffers(1, &r->valid_buf);
    glDeleteTextures(1, &r->coast_tex);
    glDeleteBuffers(1, &r->coast_buf);
    glDeleteTextures(1, &r->normal_tex);
    litmap_destroy(r);
    patch_destroy(r);
    glDeleteFramebuffers(1, &r->fbo);
    glDeleteRenderbuffers(1, &r->color_rb);
    glDeleteRenderbuffers(1, &r->depth_rb);
    free(r->wet_min);
    free(r);
}

hz_result hz_renderer_resize(hz_renderer *r, uint32_t width, uint32_t height, hz_err *err)
{
    HZ_ASSERT(r);
    if (width == 0 || height == 0 || width > INT_MAX || height > INT_MAX)
        return hz_err_set(err, HZ_ERR_VALUE, "renderer: bad target size %ux%u", width, height);
    hz_result ctx_res = fx_check_context(r, err, "hz_renderer_resize");
    if (ctx_res != HZ_OK)
        return ctx_res;
    if (!r->to_default) {
        hz_gl_drain();
        hz_result res = fbo_alloc(r, width, height, err);
        if (res != HZ_OK)
            return res;
    }
    r->width = width;
    r->height = height;
    glViewport(0, 0, (GLsizei)width, (GLsizei)height);
    return HZ_OK;
}

/* Row-major copy of the heights into dst (size*size values), any layout.
 * Also returns the raw min/max. */
static void copy_rows(const hz_heightmap *hm, uint16_t *dst, uint16_t *lo, uint16_t *hi)
{
    const uint32_t n = hm->size;
    uint16_t mn = UINT16_MAX, mx = 0;
    for (uint32_t j = 0; j < n; j++) {
        uint16_t *row = dst + (size_t)j * n;
        if (hm->layout == HZ_LAYOUT_LINEAR) {
            memcpy(row, hm->h + (size_t)j * n, (size_t)n * sizeof *row);
        } else {
            /* Blocked: each 32-sample run of a row is contiguous. */
            for (uint32_t i = 0; i < n; i += HZ_BLOCK) {
                uint32_t len = n - i < HZ_BLOCK ? n - i : HZ_BLOCK;
                memcpy(row + i, hm->h + hz_heightmap_index(hm, i, j), (size_t)len * sizeof *row);
            }
        }
        for (uint32_t i = 0; i < n; i++) {
            mn = row[i] < mn ? row[i] : mn;
            mx = row[i] > mx ? row[i] : mx;
        }
    }
    *lo = mn;
    *hi = mx;
}

/* Per-sample normals (central differences, one-sided at the borders, as the
 * vertex shader's), bilinearly filtered per fragment: the shading is that of
 * the full-resolution surface whatever the LOD, so detail does not pop with
 * the triangles. 2 bytes/sample. Maps larger than GL_MAX_TEXTURE_SIZE keep
 * per-vertex normals. */
static hz_result make_normal_texture(hz_renderer *r, const hz_heightmap *hm, hz_err *err)
{
    const uint32_t n = hm->size;
    litmap_invalidate(r); /* baked from the last map's normals */
    if (r->normal_tex) {
        glDeleteTextures(1, &r->normal_tex);
        r->normal_tex = 0;
    }
    if (r->max_tex <= 0 || n > (uint32_t)r->max_tex)
        return HZ_OK;
    int8_t *nx = malloc((size_t)n * n * 2);
    if (!nx)
        return hz_err_set(err, HZ_ERR_MEMORY, "renderer: out of memory for the %ux%u normal map", n, n);
    for (uint32_t j = 0; j < n; j++) {
        const uint32_t jd = j ? j - 1 : 0, ju = j + 1 < n ? j + 1 : n - 1;
        for (uint32_t i = 0; i < n; i++) {
            const uint32_t il = i ? i - 1 : 0, ir = i + 1 < n ? i + 1 : n - 1;
            const float dx = r->hscale *
                             ((float)hz_heightmap_get16(hm, ir, j) - (float)hz_heightmap_get16(hm, il, j)) /
                             ((float)(ir - il) * r->spacing);
            const float dz = r->hscale *
                             ((float)hz_heightmap_get16(hm, i, ju) - (float)hz_heightmap_get16(hm, i, jd)) /
                             ((float)(ju - jd) * r->spacing);
            const float inv = 1.0f / sqrtf(dx * dx + 1.0f + dz * dz);
            int8_t *o = nx + ((size_t)j * n + i) * 2;
            o[0] = (int8_t)lrintf(-dx * inv * 127.0f);
            o[1] = (int8_t)lrintf(-dz * inv * 127.0f);
        }
    }
    glGenTextures(1, &r->normal_tex);
    glBindTexture(GL_TEXTURE_2D, r->normal_tex);
    /* Mipmapped: a pixel far away reads the normal averaged over what it
     * covers (the resolution that shows), from a small level that stays in
     * cache, instead of aliasing over the full-resolution map. Trilinear:
     * the two levels around the pixel's footprint blend, so that the far
     * band's shading does not jump between levels where the LOD mesh's
     * slopes differ from the full-resolution surface's. At equal image error
     * against the full-resolution mesh (PSNR) this allows a larger pixel
     * error: on the peers' 4097^2 flight 41.1 dB at 1.35 px against 1.15 px
     * with the nearest level, 22 % fewer triangles for 3 ms of shading. */
    GLsizei mips = 1;
    while ((n >> mips) > 0)
        mips++;
    glTexStorage2D(GL_TEXTURE_2D, mips, GL_RG8_SNORM, (GLsizei)n, (GLsizei)n);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, (GLsizei)n, (GLsizei)n, GL_RG, GL_BYTE, nx);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glGenerateMipmap(GL_TEXTURE_2D);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    glBindTexture(GL_TEXTURE_2D, 0);
    free(nx);
    hz_result res = hz_gl_check(err, "normal map upload (GL_RG8_SNORM)");
    if (res != HZ_OK) {
        glDeleteTextures(1, &r->normal_tex);
        r->normal_tex = 0;
        hz_gl_drain();
        return HZ_OK; /* per-vertex normals still work */
    }
    return HZ_OK;
}

/* The lowest sample of each block of the map and its neighbours (at most
 * 128 blocks per side, blocks sharing their edge samples), in world height:
 * where a water plane above it may show. */
static hz_result make_wet_grid(hz_renderer *r, const hz_heightmap *hm, hz_err *err)
{
    free(r->wet_min);
    r->wet_min = NULL;
    const uint32_t cells = hm->size > 1 ? hm->size - 1 : 1;
    uint32_t bs = 64;
    while ((cells + bs - 1) / bs > 128)
        bs *= 2;
    const uint32_t n = (cells + bs - 1) / bs, last = hm->size ? hm->size - 1 : 0; /* last sample */
    uint16_t *lo = malloc((size_t)n * n * sizeof *lo);
    if (!lo)
        return hz_err_set(err, HZ_ERR_MEMORY, "renderer: out of memory for the water grid");
    /* Block (bi, bj) holds samples bi * bs .. (bi + 1) * bs (its edges too). */
    for (uint32_t bj = 0; bj < n; bj++)
        for (uint32_t bi = 0; bi < n; bi++) {
            uint16_t m = UINT16_MAX;
            const uint32_t i1 = (bi + 1) * bs < last ? (bi + 1) * bs : last;
            const uint32_t j1 = (bj + 1) * bs < last ? (bj + 1) * bs : last;
            for (uint32_t j = bj * bs; j <= j1; j++)
                for (uint32_t i = bi * bs; i <= i1; i++) {
                    const uint16_t h = hz_heightmap_get16(hm, i, j);
                    m = h < m ? h : m;
                }
            lo[(size_t)bj * n + bi] = m;
        }
    r->wet_min = malloc((size_t)n * n * sizeof *r->wet_min);
    if (!r->wet_min) {
        free(lo);
        return hz_err_set(err, HZ_ERR_MEMORY, "renderer: out of memory for the water grid");
    }
    /* Each block takes the lowest of its neighbours too: a coarse LOD
     * triangle reaching over from a lower block may dip below the plane. */
    for (uint32_t j = 0; j < n; j++)
        for (uint32_t i = 0; i < n; i++) {
            uint16_t m = UINT16_MAX;
            for (uint32_t b = j ? j - 1 : 0; b <= j + 1 && b < n; b++)
                for (uint32_t a = i ? i - 1 : 0; a <= i + 1 && a < n; a++)
                    m = lo[(size_t)b * n + a] < m ? lo[(size_t)b * n + a] : m;
            r->wet_min[(size_t)j * n + i] = r->hoffset + r->hscale * (float)m;
        }
    free(lo);
    r->wet_n = n;
    r->wet_block = bs;
    return HZ_OK;
}

/* bytes bytes into buf, seen through tex as a GL_R8 texture buffer. */
static hz_result upload_r8_buffer(GLuint buf, GLuint tex, const uint8_t *data, size_t bytes, const char *what,
                                  hz_err *err)
{
    glBindBuffer(GL_TEXTURE_BUFFER, buf);
    glBufferData(GL_TEXTURE_BUFFER, (GLsizeiptr)bytes, data, GL_STATIC_DRAW);
    glBindTexture(GL_TEXTURE_BUFFER, tex);
    glTexBuffer(GL_TEXTURE_BUFFER, GL_R8, buf);
    glBindTexture(GL_TEXTURE_BUFFER, 0);
    glBindBuffer(GL_TEXTURE_BUFFER, 0);
    return hz_gl_check(err, what);
}

hz_result hz_renderer_set_valid(hz_renderer *r, const uint8_t *valid, hz_err *err)
{
    HZ_ASSERT(r);
    r->has_valid = false;
    if (!valid)
        return HZ_OK;
    if (!r->has_heights)
        return hz_err_set(err, HZ_ERR_VALUE, "renderer: hz_renderer_set_valid needs the heightmap set first");
    hz_result res = fx_check_context(r, err, "hz_renderer_set_valid");
    if (res != HZ_OK)
        return res;
    res = upload_r8_buffer(r->valid_buf, r->valid_tex, valid, (size_t)r->size * r->size,
                           "validity texture buffer upload (GL_R8)", err);
    r->has_valid = res == HZ_OK;
    return res;
}

hz_result hz_renderer_set_coast(hz_renderer *r, const hz_coast *c, hz_err *err)
{
    HZ_ASSERT(r);
    r->coast_rect[0] = 0, r->coast_rect[2] = -1;
    if (!c)
        return HZ_OK;
    if (!r->has_heights && !r->streamed)
        return hz_err_set(err, HZ_ERR_VALUE, "renderer: hz_renderer_set_coast needs the terrain set first");
    if (!c->edge || c->x0 > c->x1 || c->z0 > c->z1 || !(c->spacing > 0.0f) || !isfinite(c->spacing))
        return hz_err_set(err, HZ_ERR_VALUE, "renderer: coast (%u, %u)-(%u, %u) at %g m is not a rectangle", c->x0,
                          c->z0, c->x1, c->z1, (double)c->spacing);
    hz_result res = fx_check_context(r, err, "hz_renderer_set_coast");
    if (res != HZ_OK)
        return res;
    const size_t bytes = 2 * ((size_t)(c->z1 - c->z0) + 1) + 2 * ((size_t)(c->x1 - c->x0) + 1);
    res = upload_r8_buffer(r->coast_buf, r->coast_tex, c->edge, bytes, "coast texture buffer upload (GL_R8)", err);
    if (res == HZ_OK) {
        r->coast_rect[0] = (int32_t)c->x0, r->coast_rect[1] = (int32_t)c->z0, r->coast_rect[2] = (int32_t)c->x1,
        r->coast_rect[3] = (int32_t)c->z1;
        r->coast_spacing = c->spacing;
    }
    return res;
}

hz_result hz_renderer_set_heightmap(hz_renderer *r, const hz_heightmap *hm, float spacing,
                                    float zscale, hz_err *err)
{
    HZ_ASSERT(r && hm);
    if (hm->size < 2)
        return hz_err_set(err, HZ_ERR_VALUE, "renderer: heightmap size %u is too small", hm->size);
    const uint64_t samples = (uint64_t)hm->size * hm->size;
    if (r->max_tbo <= 0 || samples > (uint64_t)r->max_tbo)
        return hz_err_set(err, HZ_ERR_UNSUPPORTED,
                          "renderer: heightmap %ux%u = %llu samples exceeds GL_MAX_TEXTURE_BUFFER_SIZE %d texels",
                          hm->size, hm->size, (unsigned long long)samples, r->max_tbo);
    if (samples > (uint64_t)INT_MAX)
        return hz_err_set(err, HZ_ERR_UNSUPPORTED, "renderer: heightmap %ux%u exceeds the 2^31 vertex id range",
                          hm->size, hm->size);
    if (!(spacing > 0.0f) || !isfinite(spacing) || !isfinite(zscale) || !isfinite(hm->scale) ||
        !isfinite(hm->offset))
        return hz_err_set(err, HZ_ERR_VALUE, "renderer: bad spacing %g / zscale %g / scale %g / offset %g",
                          (double)spacing, (double)zscale, (double)hm->scale, (double)hm->offset);
    if (!hm->h || hm->size_bytes < samples * sizeof(uint16_t))
        return hz_err_set(err, HZ_ERR_VALUE, "renderer: heightmap storage too small (%zu bytes for %ux%u)",
                          hm->size_bytes, hm->size, hm->size);
    if (hm->layout == HZ_LAYOUT_BLOCKED || hm->layout == HZ_LAYOUT_DEFAULT) {
        /* The blocked layout stores whole 32x32 tiles. */
        size_t bpr = hm->blocks_per_row;
        if (bpr * HZ_BLOCK < hm->size ||
            hm->size_bytes < bpr * bpr * HZ_BLOCK * HZ_BLOCK * sizeof(uint16_t))
            return hz_err_set(err, HZ_ERR_VALUE, "renderer: blocked heightmap has %zu blocks per row for size %u",
                              bpr, hm->size);
    }

    hz_result ctx_res = fx_check_context(r, err, "hz_renderer_set_heightmap");
    if (ctx_res != HZ_OK)
        return ctx_res;
    hz_gl_drain();
    const GLsizeiptr bytes = (GLsizeiptr)(samples * sizeof(uint16_t));
    r->has_heights = false;
    r->has_valid = false;
    r->coast_rect[0] = 0, r->coast_rect[2] = -1;
    glBindBuffer(GL_TEXTURE_BUFFER, r->height_buf);
    glBufferData(GL_TEXTURE_BUFFER, bytes, NULL, GL_STATIC_DRAW);
    hz_result res = hz_gl_check(err, "height buffer allocation");
    if (res != HZ_OK) {
        glBindBuffer(GL_TEXTURE_BUFFER, 0);
        return res;
    }
    uint16_t *dst = glMapBufferRange(GL_TEXTURE_BUFFER, 0, bytes, GL_MAP_WRITE_BIT | GL_MAP_INVALIDATE_BUFFER_BIT);
    if (!dst) {
        res = hz_gl_check(err, "glMapBufferRange(height buffer)");
        glBindBuffer(GL_TEXTURE_BUFFER, 0);
        return res != HZ_OK ? res : hz_err_set(err, HZ_ERR_GL, "GL: glMapBufferRange(height buffer) returned NULL");
    }
    uint16_t lo, hi;
    copy_rows(hm, dst, &lo, &hi);
    GLboolean intact = glUnmapBuffer(GL_TEXTURE_BUFFER);
    glBindTexture(GL_TEXTURE_BUFFER, r->height_tex);
    glTexBuffer(GL_TEXTURE_BUFFER, GL_R16, r->height_buf);
    glBindTexture(GL_TEXTURE_BUFFER, 0);
    glBindBuffer(GL_TEXTURE_BUFFER, 0);
    res = hz_gl_check(err, "height texture buffer upload (GL_R16)");
    if (res != HZ_OK)
        return res;
    if (!intact)
        return hz_err_set(err, HZ_ERR_GL, "GL: height buffer contents lost during upload (glUnmapBuffer)");

    r->size = hm->size;
    r->spacing = spacing;
    r->hscale = hm->scale * zscale;
    r->hoffset = hm->offset * zscale;
    r->zscale = zscale > 0 ? zscale : 1.0f;
    res = make_normal_texture(r, hm, err);
    if (res != HZ_OK)
        return res;
    res = make_wet_grid(r, hm, err);
    if (res != HZ_OK)
        return res;
    float a = r->hoffset + r->hscale * (float)lo, b = r->hoffset + r->hscale * (float)hi;
    r->hmin = a < b ? a : b;
    r->hmax = a < b ? b : a;
    r->has_heights = true;

    /* Warm-up: llvmpipe (and many drivers) compile shaders lazily at the first
     * draw, which would otherwise land in the first frame's draw_ms (~1 s on
     * llvmpipe). One triangle in the corner, looking down at it. */
    const uint32_t tri[3] = {0, r->size, 1};
    hz_camera cam = {.pos = {spacing * 0.5f, r->hmax + 10.0f * spacing, spacing * 0.5f}, .pitch = -89.0f};
    return hz_renderer_draw(r, &cam, NULL, tri, 3, NULL, err);
}

static bool vec3_is_zero(const float *v)
{
    return v[0] == 0.0f && v[1] == 0.0f && v[2] == 0.0f;
}

/* Zero fields -> defaults (render.h). */
static hz_scene_params params_defaults(const hz_scene_params *p, float zfar)
{
    hz_scene_params d = p ? *p : (hz_scene_params){0};
    if (vec3_is_zero(d.sun_dir)) {
        /* Afternoon sun: from the west-south-west, about 30 degrees up
         * (x east, z south), low enough to model the relief. */
        d.sun_dir[0] = -0.78f;
        d.sun_dir[1] = 0.50f;
        d.sun_dir[2] = 0.36f;
    }
    glm_vec3_normalize(d.sun_dir);
    if (vec3_is_zero(d.sky_color)) {
        d.sky_color[0] = 0.72f;
        d.sky_color[1] = 0.81f;
        d.sky_color[2] = 0.92f;
    }
    if (d.fog_density == 0.0f)
        d.fog_density = 3.0f / zfar;
    else if (d.fog_density < 0.0f)
        d.fog_density = 0.0f;
    if (d.ambient == 0.0f)
        d.ambient = 0.3f;
    return d;
}

/* Matrices of a view: the sky needs only the view rotation. */
static void view_matrices(fx_view *v)
{
    mat4 view_rot, vp_rot;
    glm_mat4_mul(v->proj, v->view, v->viewproj);
    glm_mat4_copy(v->view, view_rot);
    view_rot[3][0] = view_rot[3][1] = view_rot[3][2] = 0.0f;
    glm_mat4_mul(v->proj, view_rot, vp_rot);
    glm_mat4_inv(vp_rot, v->inv_vp_rot);
}

static float smoothstepf(float e0, float e1, float x)
{
    float t = (x - e0) / (e1 - e0);
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    return t * t * (3 - 2 * t);
}

void fx_upload_common(hz_renderer *r, const fx_frame *f, const fx_view *v)
{
    fx_common_ubo u;
    memset(&u, 0, sizeof u);
    const hz_scene_params *sp = &f->sp;
    for (int k = 0; k < 3; k++) {
        u.sun[k] = sp->sun_dir[k];
        u.sun_color[k] = f->sun_color[k];
        u.horizon[k] = sp->sky_color[k];
        u.zenith[k] = f->zenith[k];
        u.eye[k] = v->eye[k];
    }
    u.sun[3] = glm_rad(0.35f); /* a little larger than the real 0.27 degrees: visible at 720 lines */
    u.sun_color[3] = sp->ambient;
    u.horizon[3] = f->glow;
    u.eye[3] = (float)f->time;
    u.fog[0] = sp->fog_density;
    if (f->bits & HZ_FX_FOG) {
        u.fog[1] = f->fx.height_fog;
        u.fog[2] = f->ground_lo + f->fx.height_fog_base;
        u.fog[3] = f->fx.height_fog_falloff;
        u.fog_far[0] = 0.8f * f->zfar;
        u.fog_far[1] = f->zfar;
    }
    memcpy(u.clip, v->clip, sizeof u.clip);
    u.cloud[0] = f->fx.cloud_cover;
    u.cloud[1] = (r->has_heights ? r->hmax : 0.0f) + f->fx.cloud_altitude;
    u.cloud[2] = f->fx.wind[0];
    u.cloud[3] = f->fx.wind[1];
    /* Two layers: the big shapes drift with the wind, the small ones faster
     * and slightly across it, so the clouds change shape as they move. */
    const double t = f->time;
    u.cloud_off[0] = (float)(-f->fx.wind[0] * t);
    u.cloud_off[1] = (float)(-f->fx.wind[1] * t);
    u.cloud_off[2] = (float)(-1.7 * f->fx.wind[0] * t + 0.4 * f->fx.wind[1] * t + 937.0);
    u.cloud_off[3] = (float)(-1.7 * f->fx.wind[1] * t - 0.4 * f->fx.wind[0] * t + 1571.0);
    u.map[0] = r->has_heights ? (float)(r->size - 1) * r->spacing : 1.0f;
    u.map[1] = r->n_planes ? r->planes[0].height : -1e9f;
    u.map[2] = f->fx.detail_scale;
    u.lm[0] = r->lm_xform[0];
    u.lm[1] = r->lm_xform[1];
    u.lm[2] = (f->bits & HZ_FX_SHADOWS) ? 1.0f : 0.0f;
    u.bits[0] = (int32_t)f->bits;
    u.bits[1] = (v->clip[0] != 0.0f || v->clip[1] != 0.0f || v->clip[2] != 0.0f || v->clip[3] != 0.0f) ? 1 : 0;
    u.bits[2] = v->pass == HZ_PASS_REFLECTION;
    glBindBuffer(GL_UNIFORM_BUFFER, r->ubo);
    glBufferSubData(GL_UNIFORM_BUFFER, 0, sizeof u, &u);
    glBindBuffer(GL_UNIFORM_BUFFER, 0);
    glBindBufferBase(GL_UNIFORM_BUFFER, FX_UBO_BINDING, r->ubo);
}

static void draw_plain_sky(hz_renderer *r, const fx_frame *f, const fx_view *v)
{
    glUseProgram(r->sky_prog);
    glUniformMatrix4fv(r->su.inv_viewproj_rot, 1, GL_FALSE, (const float *)v->inv_vp_rot);
    glUniform3fv(r->su.horizon, 1, f->sp.sky_color);
    glUniform3fv(r->su.zenith, 1, f->zenith);
    glUniform3fv(r->su.sun_dir, 1, f->sp.sun_dir);
    /* the far plane: depth 0 in reverse-Z ([0, 1] clip depth, or [-1, 1] without glClipControl) */
    glUniform1f(r->su.sky_z, r->clip_control ? 0.0f : -1.0f);
    const struct hz_occlusion *occ = v->pass == HZ_PASS_MAIN ? f->sp.sky_occluders : NULL;
    /* The grid as sky_grid_vs.glsl lays it out: the rows span the screen on
     * the sky's side of the horizon when the camera has no roll. */
    float a = 0, b = 0, c = 0;
    if (occ) {
        vec4 w[3];
        const vec4 p[3] = {{0, 0, 0.5f, 1}, {1, 0, 0.5f, 1}, {0, 1, 0.5f, 1}};
        for (int k = 0; k < 3; k++)
            glm_mat4_mulv((vec4 *)v->inv_vp_rot, (float *)p[k], w[k]);
        a = w[0][1] / w[0][3];
        b = w[1][1] / w[1][3] - a;
        c = w[2][1] / w[2][3] - a;
    }
    if (!occ || !isfinite(a) || !isfinite(b) || !(fabsf(c) > 0 && isfinite(c))) {
        glDrawArrays(GL_TRIANGLES, 0, 6 * SKY_CELLS); /* the whole grid */
        if (v->pass == HZ_PASS_MAIN)
            r->sky_cells = SKY_CELLS;
        return;
    }
    float lo = -1.0f, hi = 1.0f;
    if (fabsf(b) <= 1e-4f * fabsf(c)) {
        const float yh = fminf(fmaxf(-a / c, -1.0f), 1.0f);
        if (c > 0)
            lo = yh;
        else
            hi = yh;
    }
    /* Runs of cells not certainly covered; a cell's rectangle is widened
     * by a thousandth of the screen against rounding between here and the
     * shader. */
    const float m = 2e-3f;
    GLsizei runs = 0;
    uint32_t drawn = 0;
    for (int k = 0; k < SKY_CELLS; k++) {
        const int cx = k % HZ_SKY_COLS, cy = k / HZ_SKY_COLS;
        const float x0 = 2.0f * (float)cx / HZ_SKY_COLS - 1.0f, x1 = 2.0f * (float)(cx + 1) / HZ_SKY_COLS - 1.0f;
        const float y0 = lo + (hi - lo) * (float)cy / HZ_SKY_ROWS, y1 = lo + (hi - lo) * (float)(cy + 1) / HZ_SKY_ROWS;
        if (hz_occlusion_rect_covered(occ, x0 - m, y0 - m, x1 + m, y1 + m))
            continue;
        drawn++;
        if (runs > 0 && r->sky_first[runs - 1] + r->sky_count[runs - 1] == 6 * k) {
            r->sky_count[runs - 1] += 6;
        } else {
            r->sky_first[runs] = 6 * k;
            r->sky_count[runs++] = 6;
        }
    }
    if (runs > 0)
        glMultiDrawArrays(GL_TRIANGLES, r->sky_first, r->sky_count, runs);
    r->sky_cells = drawn;
}

/* The objects hook (city, forests, user objects). */
static void draw_objects(hz_renderer *r, const fx_frame *f, const fx_view *v)
{
    const hz_scene_params *sp = &f->sp;
    const bool mirrored = v->pass == HZ_PASS_REFLECTION;
    if (sp->draw_objects) {
        hz_pass_info pi = {.pass = v->pass, .cam = &v->cam, .fog_density = sp->fog_density,
                           .ambient = sp->ambient, .width = v->w, .height = v->h, .effects = f->bits,
                           .time = f->time};
        glm_mat4_copy((vec4 *)v->view, pi.view);
        glm_mat4_copy((vec4 *)v->proj, pi.proj);
        glm_mat4_copy((vec4 *)v->viewproj, pi.viewproj);
        memcpy(pi.clip_plane, v->clip, sizeof pi.clip_plane);
        memcpy(pi.sun_dir, sp->sun_dir, sizeof pi.sun_dir);
        memcpy(pi.sky_color, sp->sky_color, sizeof pi.sky_color);
        memcpy(pi.zenith_color, f->zenith, sizeof pi.zenith_color);
        if (f->bits & HZ_FX_FOG) {
            pi.height_fog[0] = f->fx.height_fog;
            pi.height_fog[1] = f->ground_lo + f->fx.height_fog_base;
            pi.height_fog[2] = f->fx.height_fog_falloff;
            pi.fog_far[0] = 0.8f * f->zfar;
            pi.fog_far[1] = f->zfar;
        }
        if ((f->bits & HZ_FX_SHADOWS) && fx_sun_heights_match(r, sp->sun_dir)) {
            pi.sun_heights_tex = r->sunh_tex;
            glm_vec4_copy(r->sunh_map, pi.sun_heights_map);
            pi.sun_heights_spacing = r->spacing;
        }
        glEnable(GL_DEPTH_TEST);
        glDepthFunc(GL_GREATER);
        glDepthMask(GL_TRUE);
        glFrontFace(mirrored ? GL_CW : GL_CCW);
        if (mirrored)
            glEnable(GL_CLIP_DISTANCE0);
        glUseProgram(0);
        glBindVertexArray(0);
        sp->draw_objects(sp->draw_objects_user, &pi);
        glDisable(GL_CLIP_DISTANCE0);
        glBindVertexArray(r->vao);
    }
}

/* Makes tp the current terrain program, with its textures and uniforms for
 * view v (patches: the main view's cdlod patches, morphing on). */
static void terrain_program(hz_renderer *r, const fx_frame *f, const fx_view *v, const prog_variant *tp, bool patches)
{
    const hz_scene_params *sp = &f->sp;
    const GLint *tl = tp->loc;
    glUseProgram(tp->prog);
    glActiveTexture(GL_TEXTURE0 + FX_UNIT_HEIGHTS);
    glBindTexture(GL_TEXTURE_BUFFER, r->height_tex);
    if (tp->key)
        fx_ground_bind(r);
    glUniform1i(tl[TL_SIZE], (GLint)r->size);
    glUniform1f(tl[TL_SPACING], r->spacing);
    glUniform1f(tl[TL_HSCALE], r->hscale);
    glUniform1f(tl[TL_HOFFSET], r->hoffset);
    glUniformMatrix4fv(tl[TL_VIEWPROJ], 1, GL_FALSE, (const float *)v->viewproj);
    hz_gl_set_curvature(tp->prog, &v->cam);
    glUniform3fv(tl[TL_SUN], 1, sp->sun_dir);
    glUniform3fv(tl[TL_HORIZON], 1, sp->sky_color);
    glUniform3fv(tl[TL_EYE], 1, v->eye);
    glUniform1f(tl[TL_FOG], sp->fog_density);
    glUniform1f(tl[TL_AMBIENT], sp->ambient);
    glUniform2f(tl[TL_HRANGE], r->hmin, r->hmax);
    /* Lines in world units (metres times zscale), as v_world.y. */
    glUniform4f(tl[TL_CLIMATE], r->climate.snow_line * r->zscale, r->climate.tree_line * r->zscale,
                r->climate.aridity, r->zscale);
    glUniform1i(tl[TL_WIRE], 0);
    glUniform1f(tl[TL_WATER_MASK], v->pass == HZ_PASS_MAIN ? f->water_mask : -1e30f);
    glUniform4fv(tl[TL_IMG_MAP], 1, r->img_map);
    glUniform2fv(tl[TL_IMG_TILE], 1, r->img_tile);
    /* cdlod geomorphing (patches, main view only); reflections are unmorphed. */
    glUniform1f(tl[TL_MORPH_SCALE], patches ? sp->morph_scale : 0.0f);
    glUniform1f(tl[TL_MORPH_START], sp->morph_start);
    /* the near bound (hz_lod_morph_range): none unless both are set */
    const bool near = sp->morph_near > 0.0f && sp->morph_near < 1.0f && sp->morph_near_distance > 0.0f;
    glUniform1f(tl[TL_MORPH_NEAR], near ? sp->morph_near : 1.0f);
    glUniform1f(tl[TL_MORPH_NEAR_D0], near ? sp->morph_near_distance : 1.0f);
    if (tp->key & FX_VARIANT_LIT) {
        glActiveTexture(GL_TEXTURE0 + FX_UNIT_LIT);
        glBindTexture(GL_TEXTURE_2D, r->lit_tex);
    }
    glActiveTexture(GL_TEXTURE0 + FX_UNIT_NORMALS);
    glBindTexture(GL_TEXTURE_2D, r->normal_tex);
    glUniform1i(tl[TL_NORMAL_TEX], r->normal_tex != 0);
    glUniform2f(tl[TL_NRM_SCALE], 1.0f / (r->spacing * (float)r->size), 0.5f / (float)r->size);
    if (tp->key & FX_VARIANT_VLIT) {
        /* Samples a pixel covers at one metre, across the view's height, and
         * the lit map's last mip level. */
        const float fov = v->cam.fov_y > 0.0f ? v->cam.fov_y : 60.0f;
        glUniform1f(tl[TL_LIT_LOD], 2.0f * tanf(glm_rad(fov) * 0.5f) / ((float)v->h * r->spacing));
        GLint top = 0;
        while ((r->size >> (top + 1)) > 0)
            top++;
        glUniform1i(tl[TL_LIT_TOP], top);
    }
}

static void draw_scene_base(hz_renderer *r, const fx_frame *f, const fx_view *v, GLuint ibo, uint32_t count)
{
    const hz_scene_params *sp = &f->sp;
    const bool mirrored = v->pass == HZ_PASS_REFLECTION;
    fx_upload_common(r, f, v);
    glViewport(0, 0, (GLsizei)v->w, (GLsizei)v->h);
    glBindVertexArray(r->vao);

    /* The sky (plain or the effects') goes after the terrain, only where the
     * depth is still far: no sky shading under the terrain. */
    const bool fx_sky = (f->bits & HZ_FX_SKY) != 0;

    /* Objects first when they are occluders: at street level buildings hide
     * most of the terrain and sky, whose hidden fragments the depth test
     * then rejects before shading. */
    if (sp->draw_objects && sp->objects_first)
        draw_objects(r, f, v);
    glBindVertexArray(r->vao);
    /* The main view of a cdlod frame draws patches; every other pass indices. */
    const bool patches = v->pass == HZ_PASS_MAIN && r->terrain_patch_cur && r->n_inst > 0;
    if (patches)
        count = 0;
    if (count > 0 || patches) {
        glEnable(GL_DEPTH_TEST);
        glDepthFunc(GL_GREATER);
        glDepthMask(GL_TRUE);
        /* The LOD emits CCW-from-above triangles: a camera under the
         * surface sees nothing, which is fine. The mirror flips the winding. */
        glEnable(GL_CULL_FACE);
        glCullFace(GL_BACK);
        glFrontFace(mirrored ? GL_CW : GL_CCW);
        const prog_variant *tp =
            patches ? r->terrain_patch_cur
                    : (mirrored && r->terrain_clip_cur ? r->terrain_clip_cur
                                                       : (r->terrain_cur ? r->terrain_cur : r->terrain_plain));
        terrain_program(r, f, v, tp, patches);
        if (patches) {
            /* Still patches (no vertex morphs) without the morph code,
             * simply morphing ones with the simple morph; patches beyond the
             * ground detail's fade with its far variants. */
            const uint32_t near = r->n_inst_near;
            const prog_variant *const near_prog[PATCH_CLASSES] = {
                [PATCH_STILL_FINE] = r->terrain_patch_fine_still, [PATCH_STILL] = r->terrain_patch_still,
                [PATCH_SIMPLE_FINE] = r->terrain_patch_fine_simple, [PATCH_SIMPLE] = r->terrain_patch_simple,
                [PATCH_MORPH_FINE] = r->terrain_patch_fine, [PATCH_MORPH] = tp};
            for (uint32_t c = 0; c < PATCH_MORPH; c++)
                if (near_prog[c])
                    terrain_program(r, f, v, near_prog[c], true);
            patch_draw(r, near_prog, 0, near); /* binds tp again */
            if (near < r->n_inst) {
                const prog_variant *const far_prog[PATCH_CLASSES] = {[PATCH_STILL] = r->terrain_patch_far_still,
                                                                     [PATCH_SIMPLE] = r->terrain_patch_far_simple,
                                                                     [PATCH_MORPH] = r->terrain_patch_far};
                for (uint32_t c = 0; c < PATCH_CLASSES; c++)
                    if (far_prog[c])
                        terrain_program(r, f, v, far_prog[c], true);
                patch_draw(r, far_prog, near, r->n_inst);
            }
        } else {
            glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, ibo);
            glDrawElements(GL_TRIANGLES, (GLsizei)count, GL_UNSIGNED_INT, (const void *)0);
        }
    }
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_GEQUAL);
    glDepthMask(GL_FALSE);
    glDisable(GL_CULL_FACE);
    if (fx_sky)
        fx_sky_draw(r, f, v);
    else
        draw_plain_sky(r, f, v);
    if (count > 0 || patches) {
        const prog_variant *tp =
            patches ? r->terrain_patch_cur : (r->terrain_cur ? r->terrain_cur : r->terrain_plain);
        const GLint *tl = tp->loc;
        if (sp->wireframe && !mirrored) {
            glUseProgram(tp->prog);
            glActiveTexture(GL_TEXTURE0 + FX_UNIT_HEIGHTS);
            glBindTexture(GL_TEXTURE_BUFFER, r->height_tex);
            glEnable(GL_CULL_FACE);
            glFrontFace(GL_CCW);
            /* Second pass as lines, pulled toward the eye: with reverse-Z
             * nearer means larger depth, hence the positive offset. */
            glPolygonMode(GL_FRONT_AND_BACK, GL_LINE);
            glEnable(GL_POLYGON_OFFSET_LINE);
            glPolygonOffset(1.0f, 1.0f);
            glDepthFunc(GL_GEQUAL);
            glDepthMask(GL_FALSE);
            glUniform1i(tl[TL_WIRE], 1);
            const prog_variant *const wire_prog[PATCH_CLASSES] = {[PATCH_MORPH] = tp};
            if (patches)
                patch_draw(r, wire_prog, 0, r->n_inst);
            else
                glDrawElements(GL_TRIANGLES, (GLsizei)count, GL_UNSIGNED_INT, (const void *)0);
            glPolygonMode(GL_FRONT_AND_BACK, GL_FILL);
            glDisable(GL_POLYGON_OFFSET_LINE);
            glDepthMask(GL_TRUE);
        }
        glActiveTexture(GL_TEXTURE0 + FX_UNIT_LIT);
        glBindTexture(GL_TEXTURE_2D, 0);
        glActiveTexture(GL_TEXTURE0 + FX_UNIT_NORMALS);
        glBindTexture(GL_TEXTURE_2D, 0);
        glActiveTexture(GL_TEXTURE0 + FX_UNIT_TILES);
        glBindTexture(GL_TEXTURE_2D_ARRAY, 0);
        glActiveTexture(GL_TEXTURE0 + FX_UNIT_HEIGHTS);
        glBindTexture(GL_TEXTURE_BUFFER, 0);
    }
    if (sp->draw_objects && !sp->objects_first)
        draw_objects(r, f, v);
    glFrontFace(GL_CCW);
}

/* Uploads count indices into ibo (orphaning: the driver hands us fresh
 * storage instead of waiting for the previous frame's draw). */
static hz_result upload_indices(GLuint ibo, size_t *cap, const uint32_t *idx, uint32_t count, hz_err *err)
{
    size_t bytes = (size_t)count * sizeof(uint32_t);
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, ibo);
    /* Headroom: the LOD's count varies per frame. Orphaning (glBufferData
     * NULL) hands us fresh storage of the capacity every frame, so the
     * capacity follows the count down too: one huge draw (a full-resolution
     * reference) must not make every later small frame allocate its size. */
    if (bytes > *cap || bytes < *cap / 4)
        *cap = bytes + bytes / 4;
    glBufferData(GL_ELEMENT_ARRAY_BUFFER, (GLsizeiptr)*cap, NULL, GL_STREAM_DRAW);
    glBufferSubData(GL_ELEMENT_ARRAY_BUFFER, 0, (GLsizeiptr)bytes, idx);
    hz_result res = hz_gl_check(err, "index buffer upload");
    if (res != HZ_OK)
        *cap = 0;
    return res;
}

/* The chain of scene passes drawn after the terrain and the objects, in
 * order; each is one effect module behind one function. */
typedef struct fx_scene_pass {
    const char *name;
    uint32_t bit;
    void (*draw)(hz_renderer *r, const fx_frame *f, const fx_view *v);
} fx_scene_pass;

static const fx_scene_pass scene_passes[] = {
    {"billboards", HZ_FX_BILLBOARDS, fx_trees_draw}, /* alpha-tested, opaque */
    {"water", HZ_FX_WATER, fx_water_draw},           /* blended over the terrain below */
    {"weather", HZ_FX_WEATHER, fx_weather_draw},     /* blended, sorted back to front */
};

static hz_result draw_frame(hz_renderer *r, const hz_camera *cam, const hz_scene_params *params,
                            const uint32_t *indices, uint32_t count, hz_draw_stats *stats, hz_err *err)
{
    HZ_ASSERT(r && cam);
    if (stats)
        *stats = (hz_draw_stats){.sun_visible = -1.0f};
    if (count % 3 != 0)
        return hz_err_set(err, HZ_ERR_VALUE, "renderer: index count %u is not a multiple of 3", count);
    if (count > 0 && !indices)
        return hz_err_set(err, HZ_ERR_VALUE, "renderer: %u indices but no index array", count);
    if (count > 0 && !r->has_heights)
        return hz_err_set(err, HZ_ERR_VALUE, "renderer: draw with %u indices before hz_renderer_set_heightmap",
                          count);
    if (count > (uint32_t)INT_MAX)
        return hz_err_set(err, HZ_ERR_UNSUPPORTED, "renderer: %u indices exceed one glDrawElements call", count);
    if (params && params->history >= HZ_MAX_HISTORY)
        return hz_err_set(err, HZ_ERR_VALUE, "renderer: motion blur history slot %u (must be < %u)", params->history,
                          HZ_MAX_HISTORY);
    if (params && (params->effects & ~HZ_FX_ALL))
        return hz_err_set(err, HZ_ERR_VALUE, "renderer: unknown effect bits 0x%x", params->effects & ~HZ_FX_ALL);
    if (params && params->reflection_count % 3 != 0)
        return hz_err_set(err, HZ_ERR_VALUE, "renderer: reflection index count %u is not a multiple of 3",
                          params->reflection_count);
    if (params && params->reflection_count > 0 && (!params->reflection_indices || !r->has_heights))
        return hz_err_set(err, HZ_ERR_VALUE, "renderer: reflection indices without an array or heights");
    if (params && !isfinite(params->time))
        return hz_err_set(err, HZ_ERR_VALUE, "renderer: effect time is not finite");
    const uint32_t npatch = params ? params->patch_count : 0;
    if (npatch > 0 && (!params->patches || count > 0))
        return hz_err_set(err, HZ_ERR_VALUE, "renderer: %u patches %s", npatch,
                          params->patches ? "and an index list in one frame" : "but no patch array");

    hz_result ctx_res = fx_check_context(r, err, "hz_renderer_draw");
    if (ctx_res != HZ_OK)
        return ctx_res;
    const float zfar = cam->zfar > 0.0f ? cam->zfar : 100000.0f;

    /* Resolve the frame: defaults, and the effects whose resources exist. */
    fx_frame fr;
    memset(&fr, 0, sizeof fr);
    fr.sp = params_defaults(params, zfar);
    fr.fx = hz_fx_settings_defaults(params ? params->fx : NULL, fr.sp.fog_density);
    fr.bits = fr.sp.effects & HZ_FX_ALL;
    fr.time = params ? params->time : 0.0;
    fr.zfar = zfar;
    fr.ground_lo = r->has_heights ? r->hmin : 0.0f;
    fr.water_mask = -1e30f;
    if ((fr.bits & HZ_FX_SHADOWS) && !fx_lightmap_matches(r, fr.sp.sun_dir))
        fr.bits &= ~HZ_FX_SHADOWS; /* no light map for this sun: per-pixel Lambert */
    if ((fr.bits & HZ_FX_WATER) && (r->n_planes == 0 || !(r->has_heights || r->streamed)))
        fr.bits &= ~HZ_FX_WATER;
    fr.post = (fr.bits & (HZ_FX_MOTIONBLUR | HZ_FX_BLOOM)) || fr.fx.exposure != 1.0f || fr.fx.gamma != 1.0f;
    /* Zenith derived from the horizon colour: the default pale blue gives a
     * deep blue (0.20, 0.40, 0.78); a custom colour keeps its hue. */
    const float *sky = fr.sp.sky_color, *sun = fr.sp.sun_dir;
    fr.zenith[0] = sky[0] * 0.28f, fr.zenith[1] = sky[1] * 0.5f, fr.zenith[2] = sky[2] * 0.85f;
    fr.sun_color[0] = fr.sun_color[1] = fr.sun_color[2] = 1.0f;
    if (fr.bits & HZ_FX_SKY) {
        /* The sky follows the sun: the zenith darkens toward dusk, the
         * horizon warms toward a low sun, the sunlight reddens. */
        float day = 0.25f + 0.75f * smoothstepf(-0.1f, 0.3f, sun[1]);
        glm_vec3_scale(fr.zenith, day, fr.zenith);
        fr.glow = 1.0f - smoothstepf(0.05f, 0.45f, sun[1]);
        float noon = smoothstepf(0.0f, 0.4f, sun[1]);
        fr.sun_color[0] = 1.0f;
        fr.sun_color[1] = 0.62f + 0.35f * noon;
        fr.sun_color[2] = 0.38f + 0.52f * noon;
    }
    /* A sea cannot be depth-tested exactly against the ground: the flat cells
     * of a curved plane sag under ground at its level, or flood low land when
     * lifted over the sphere. The terrain marks in alpha where it stands above
     * the sea (and every opaque pass writes 1, the sky 0), and the sea, deep
     * and opaque, shows elsewhere. Needs a target with alpha. */
    if ((fr.bits & HZ_FX_WATER) && r->n_planes == 1 && r->planes[0].sea && target_has_alpha(r))
        fr.water_mask = r->planes[0].height;
    fr.refl_idx = params && params->reflection_count ? params->reflection_indices : indices;
    fr.refl_count = params && params->reflection_count ? params->reflection_count : count;
    fr.refl_ibo = params && params->reflection_count ? r->ibo2 : r->ibo;

    hz_gl_drain();
    /* Effect resources on first use (shaders, textures). */
    hz_result res = HZ_OK;
    if (fr.bits & (HZ_FX_SHADOWS | HZ_FX_DETAIL | HZ_FX_BILLBOARDS))
        res = fx_ground_ensure(r, err);
    if (res == HZ_OK && (fr.bits & (HZ_FX_SKY | HZ_FX_FLARE)))
        res = fx_sky_ensure(r, &fr, err);
    if (res == HZ_OK && (fr.bits & HZ_FX_FLARE))
        res = fx_flare_ensure(r, &fr, err);
    if (res == HZ_OK && (fr.bits & (HZ_FX_BILLBOARDS | HZ_FX_WEATHER)))
        res = fx_billboards_ensure(r, &fr, err);
    if (res == HZ_OK && (fr.bits & HZ_FX_WATER))
        res = fx_water_ensure(r, &fr, err);
    if (res == HZ_OK && fr.post)
        res = fx_post_ensure(r, err);
    if (res != HZ_OK)
        return res;
    /* The lit map, baked first when the lighting changed (timed as upload). */
    const double bake_ms =
        litmap_prepare(r, &fr, terrain_fx_bits(&fr) == 0 && !r->has_colormap && !r->has_imagery, &fr.lit);
    res = fx_terrain_select(r, &fr, npatch > 0, err);
    if (res != HZ_OK)
        return res;

    fx_view mv;
    memset(&mv, 0, sizeof mv);
    mv.pass = HZ_PASS_MAIN;
    mv.cam = *cam;
    mv.w = r->width;
    mv.h = r->height;
    hz_camera_view(cam, mv.view);
    hz_camera_proj_reverse_z(cam, mv.proj);
    view_matrices(&mv);
    glm_vec3_copy((float *)cam->pos, mv.eye);

    /* CPU work of the frame's effects: indices, billboards, particles. */
    double t0 = hz_time_ms();
    glBindVertexArray(r->vao);
    if (count > 0 && upload_indices(r->ibo, &r->ibo_cap, indices, count, err) != HZ_OK) {
        glBindVertexArray(0);
        return HZ_ERR_GL;
    }
    r->n_inst = r->n_inst_near = r->fine_patches = 0;
    uint32_t near = npatch;
    if (npatch > 0 && r->terrain_patch_far) {
        /* 0.1 % more: the shader's distance is rounded. */
        const float fade = FX_DETAIL_FADE_FAR * fr.fx.detail_scale * 1.001f;
        near = patch_detail_split(r, params->patches, npatch, cam->pos, fade);
    }
    if (npatch > 0 && patch_upload_late(r, params->patches, npatch, near, params->patch_late_job,
                                        params->patch_late_hidden, params->patch_late_blocks, err) != HZ_OK) {
        glBindVertexArray(0);
        return HZ_ERR_GL;
    }
    r->n_inst_near = near;
    float levels[FX_MAX_REFLECTIONS];
    /* A streamed terrain's mirror image would be the sky alone (its reflection
     * pass draws no patches): the water reflects the sky's colour instead. */
    r->n_refl = (fr.bits & HZ_FX_WATER) && !r->streamed ? fx_water_visible(r, &fr, &mv, levels, r->refl_rect) : 0;
    for (uint32_t k = 0; k < r->n_refl; k++)
        r->refl_level[k] = levels[k];
    if (r->n_refl && params && params->reflection_count &&
        upload_indices(r->ibo2, &r->ibo2_cap, params->reflection_indices, params->reflection_count, err) != HZ_OK) {
        glBindVertexArray(0);
        return HZ_ERR_GL;
    }
    double t1 = hz_time_ms();
    glFinish(); /* start the clock with an idle GPU */
    double t2 = hz_time_ms();
    /* The effects' CPU work counts in draw_ms. */
    if (fr.bits & (HZ_FX_BILLBOARDS | HZ_FX_WEATHER)) {
        fx_view mirror;
        if (r->n_refl)
            fx_water_mirror_view(&mv, r->refl_level[0], &mirror);
        if (fx_billboards_prepare(r, &fr, &mv, r->n_refl ? &mirror : NULL, err) != HZ_OK) {
            glBindVertexArray(0);
            return HZ_ERR_MEMORY;
        }
    }

    if (r->clip_control)
        glClipControl(GL_LOWER_LEFT, GL_ZERO_TO_ONE);
    glDisable(GL_BLEND);
    glDisable(GL_SCISSOR_TEST);
    glPolygonMode(GL_FRONT_AND_BACK, GL_FILL);
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    glClearDepth(0.0); /* reverse-Z: 0 is infinitely far */

    if (r->n_refl && fx_water_reflections(r, &fr, &mv, draw_scene_base, err) != HZ_OK) {
        glBindVertexArray(0);
        return HZ_ERR_GL;
    }

    /* The main pass: into the chain's scene texture, or straight out. */
    const GLuint out_fbo = r->to_default ? 0 : r->fbo;
    if (fr.post) {
        if (fx_scene_target(r, err) != HZ_OK) {
            glBindVertexArray(0);
            return HZ_ERR_GL;
        }
        glBindFramebuffer(GL_FRAMEBUFFER, r->scene_fbo);
        r->depth_fbo = r->scene_fbo;
    } else {
        glBindFramebuffer(GL_FRAMEBUFFER, out_fbo);
        r->depth_fbo = r->fbo;
    }
    glViewport(0, 0, (GLsizei)r->width, (GLsizei)r->height);
    glDepthMask(GL_TRUE);
    glClearColor(fr.sp.sky_color[0], fr.sp.sky_color[1], fr.sp.sky_color[2], 0.0f); /* alpha 0: no ground */
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    draw_scene_base(r, &fr, &mv, r->ibo, count);
    for (size_t k = 0; k < sizeof scene_passes / sizeof scene_passes[0]; k++)
        if (fr.bits & scene_passes[k].bit)
            scene_passes[k].draw(r, &fr, &mv);
    /* The flare goes last, over everything (seed 000, ch. 7). */
    if (fr.bits & HZ_FX_FLARE)
        fx_flare_draw(r, &fr, &mv, stats);
    if (fr.post)
        fx_post_run(r, &fr, out_fbo);

    glDisable(GL_BLEND);
    glDepthMask(GL_TRUE);
    glEnable(GL_DEPTH_TEST);
    glFrontFace(GL_CCW);
    glUseProgram(0);
    glBindVertexArray(0);
    glBindFramebuffer(GL_FRAMEBUFFER, out_fbo);
    /* Leave the clip convention as GL's default for any other drawing code
     * sharing the context (a window's UI). */
    if (r->clip_control)
        glClipControl(GL_LOWER_LEFT, GL_NEGATIVE_ONE_TO_ONE);
    glFinish();
    double t3 = hz_time_ms();
    if (stats) {
        stats->upload_ms = t1 - t0 + bake_ms;
        stats->upload_bytes = (size_t)count * sizeof(uint32_t) + (npatch ? r->inst_bytes + r->cmd_bytes : 0);
        stats->draw_ms = t3 - t2;
        stats->billboards = (fr.bits & HZ_FX_BILLBOARDS) ? (uint32_t)r->n_trees : 0;
        stats->particles = (fr.bits & HZ_FX_WEATHER) ? (uint32_t)r->n_particles : 0;
        stats->reflections = r->n_refl;
        stats->far_patches = r->n_inst - r->n_inst_near;
        stats->lit_map = fr.lit;
        /* (The variant is chosen only with the lit map and patches.) */
        stats->lit_per_vertex = r->terrain_patch_cur && (r->terrain_patch_cur->key & FX_VARIANT_VLIT);
        stats->lit_vertex_patches = stats->lit_per_vertex ? r->n_inst : r->fine_patches;
        stats->lit_bake_ms = bake_ms;
        stats->sky_cells = (fr.bits & HZ_FX_SKY) ? 0 : r->sky_cells;
    }
    return hz_gl_check(err, "frame draw");
}

hz_result hz_renderer_draw(hz_renderer *r, const hz_camera *cam, const hz_scene_params *params,
                           const uint32_t *indices, uint32_t count, hz_draw_stats *stats, hz_err *err)
{
    r->late_skipped = 0;
    r->late_wait_ms = 0.0;
    hz_result res = draw_frame(r, cam, params, indices, count, stats, err);
    patch_late_end(r); /* waits for a late cull the frame did not reach */
    if (stats) {
        stats->late_hidden = r->late_skipped;
        stats->late_wait_ms = r->late_wait_ms;
    }
    return res;
}

/* Binds the frame we drew for reading. */
static void bind_read(const hz_renderer *r)
{
    glBindFramebuffer(GL_READ_FRAMEBUFFER, r->to_default ? 0 : r->fbo);
    glReadBuffer(r->to_default ? GL_BACK : GL_COLOR_ATTACHMENT0);
    glBindBuffer(GL_PIXEL_PACK_BUFFER, 0);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glPixelStorei(GL_PACK_ROW_LENGTH, 0);
    glPixelStorei(GL_PACK_SKIP_ROWS, 0);
    glPixelStorei(GL_PACK_SKIP_PIXELS, 0);
}

/* GL rows are bottom-up; ours are top-down. */
static bool flip_rows(uint8_t *p, size_t row_bytes, uint32_t rows)
{
    uint8_t *tmp = malloc(row_bytes);
    if (!tmp)
        return false;
    for (uint32_t y = 0; y < rows / 2; y++) {
        uint8_t *a = p + (size_t)y * row_bytes, *b = p + (size_t)(rows - 1 - y) * row_bytes;
        memcpy(tmp, a, row_bytes);
        memcpy(a, b, row_bytes);
        memcpy(b, tmp, row_bytes);
    }
    free(tmp);
    return true;
}

hz_result hz_renderer_read_rgb(hz_renderer *r, uint8_t *rgb, hz_err *err)
{
    HZ_ASSERT(r && rgb);
    hz_result ctx_res = fx_check_context(r, err, "hz_renderer_read_rgb");
    if (ctx_res != HZ_OK)
        return ctx_res;
    hz_gl_drain();
    bind_read(r);
    glReadPixels(0, 0, (GLsizei)r->width, (GLsizei)r->height, GL_RGB, GL_UNSIGNED_BYTE, rgb);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
    hz_result res = hz_gl_check(err, "glReadPixels(RGB)");
    if (res != HZ_OK)
        return res;
    if (!flip_rows(rgb, (size_t)r->width * 3, r->height))
        return hz_err_set(err, HZ_ERR_MEMORY, "out of memory");
    return HZ_OK;
}

/* The scene's depth, bottom row first (GL order). */
static hz_result read_depth_rows(hz_renderer *r, float *depth, hz_err *err)
{
    hz_gl_drain();
    bind_read(r);
    /* The depth is where the scene was drawn: the chain's scene target or the
     * output framebuffer. */
    glBindFramebuffer(GL_READ_FRAMEBUFFER, r->depth_fbo ? r->depth_fbo : r->fbo);
    glPixelStorei(GL_PACK_ALIGNMENT, 4);
    glReadPixels(0, 0, (GLsizei)r->width, (GLsizei)r->height, GL_DEPTH_COMPONENT, GL_FLOAT, depth);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
    return hz_gl_check(err, "glReadPixels(DEPTH)");
}

hz_result hz_renderer_read_depth(hz_renderer *r, float *depth, hz_err *err)
{
    HZ_ASSERT(r && depth);
    if (r->to_default)
        return hz_err_set(err, HZ_ERR_UNSUPPORTED, "renderer: reading the depth needs the internal framebuffer");
    hz_result res = fx_check_context(r, err, "hz_renderer_read_depth");
    if (res == HZ_OK)
        res = read_depth_rows(r, depth, err);
    if (res == HZ_OK && !flip_rows((uint8_t *)depth, (size_t)r->width * sizeof *depth, r->height))
        res = hz_err_set(err, HZ_ERR_MEMORY, "out of memory");
    return res;
}

hz_result hz_renderer_read_sky_mask(hz_renderer *r, uint8_t *mask, hz_err *err)
{
    HZ_ASSERT(r && mask);
    if (r->to_default)
        return hz_err_set(err, HZ_ERR_UNSUPPORTED, "renderer: sky mask needs the internal framebuffer");
    hz_result ctx_res = fx_check_context(r, err, "hz_renderer_read_sky_mask");
    if (ctx_res != HZ_OK)
        return ctx_res;
    const size_t n = (size_t)r->width * r->height;
    float *depth = malloc(n * sizeof *depth);
    if (!depth)
        return hz_err_set(err, HZ_ERR_MEMORY, "out of memory");
    hz_result res = read_depth_rows(r, depth, err);
    if (res == HZ_OK) {
        /* Depth is cleared to 0 (reverse-Z far); terrain, objects, tree
         * billboards and water planes write it (not the sky, not particles). */
        for (uint32_t y = 0; y < r->height; y++) {
            const float *src = depth + (size_t)(r->height - 1 - y) * r->width;
            uint8_t *dst = mask + (size_t)y * r->width;
            for (uint32_t x = 0; x < r->width; x++)
                dst[x] = src[x] == 0.0f ? 1 : 0;
        }
    }
    free(depth);
    return res;
}

void hz_renderer_set_climate(hz_renderer *r, const hz_climate *c)
{
    r->climate = c ? *c : hz_climate_of_kind(HZ_CLIMATE_TEMPERATE, 45.0);
}
