/* Billboards (R3): vegetation (axial, alpha-tested) and weather particles
 * (rain streaks along their fall, camera-facing snow; blended back to front).
 * The lists are built by the CPU module (fx.h): cull, sort, batch per
 * texture; here they are uploaded once per frame and drawn one instanced
 * call per batch. */
#include "render_internal.h"

#include "gl_util.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "hz_shaders.h"

/* Mipmaps that keep an alpha-tested sprite's coverage (hz_sprite_mip_next). */
static hz_result upload_sprite(hz_renderer *r, uint32_t slot, const uint8_t *rgba, uint32_t w, uint32_t h,
                               hz_err *err)
{
    if (!r->bb_tex[slot])
        glGenTextures(1, &r->bb_tex[slot]);
    glBindTexture(GL_TEXTURE_2D, r->bb_tex[slot]);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, (GLsizei)w, (GLsizei)h, 0, GL_RGBA, GL_UNSIGNED_BYTE, rgba);
    uint8_t *a = malloc((size_t)w * h * 4), *b = malloc((size_t)w * h * 4);
    if (!a || !b) {
        free(a);
        free(b);
        glBindTexture(GL_TEXTURE_2D, 0);
        return hz_err_set(err, HZ_ERR_MEMORY, "billboard texture: out of memory for mipmaps");
    }
    memcpy(a, rgba, (size_t)w * h * 4);
    const double cover0 = hz_sprite_coverage(rgba, (size_t)w * h);
    int level = 0;
    for (uint32_t lw = w, lh = h; lw > 1 || lh > 1;) {
        uint32_t nw, nh;
        hz_sprite_mip_next(a, lw, lh, cover0, b, &nw, &nh);
        level++;
        glTexImage2D(GL_TEXTURE_2D, level, GL_RGBA8, (GLsizei)nw, (GLsizei)nh, 0, GL_RGBA, GL_UNSIGNED_BYTE, b);
        uint8_t *t = a;
        a = b;
        b = t;
        lw = nw, lh = nh;
    }
    free(a);
    free(b);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, level);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    glBindTexture(GL_TEXTURE_2D, 0);
    return hz_gl_check(err, "billboard texture upload");
}

hz_result fx_billboards_ensure(hz_renderer *r, const fx_frame *f, hz_err *err)
{
    static const char *const names[] = {"u_viewproj", "u_cam_right", "u_cam_up", "u_px_per_m",
                                        "u_blend",    "u_first",     "u_facing", NULL};
    r->bb_cur = prog_cache_get(&r->bb, f->bits & (HZ_FX_SKY | HZ_FX_SHADOWS | HZ_FX_FOG), hz_shader_fx_billboard_vs,
                               hz_shader_fx_billboard_fs, "fx_billboard", 3, names, err);
    if (!r->bb_cur)
        return HZ_ERR_GL;
    if (r->bb_tbo)
        return HZ_OK;
    glGenBuffers(1, &r->bb_buf_gl);
    glGenTextures(1, &r->bb_tbo);
    /* The procedural sprites in slots 0..3 (unless the user set them). */
    static const struct {
        hz_sprite kind;
        uint32_t w, h;
    } sprites[4] = {{HZ_SPRITE_CONIFER, 64, 128}, {HZ_SPRITE_BROADLEAF, 128, 128}, {HZ_SPRITE_RAIN, 8, 64},
                    {HZ_SPRITE_SNOW, 32, 32}};
    uint8_t *img = malloc(128 * 128 * 4);
    if (!img)
        return hz_err_set(err, HZ_ERR_MEMORY, "renderer: out of memory for sprites");
    hz_result res = HZ_OK;
    for (uint32_t k = 0; k < 4 && res == HZ_OK; k++) {
        if (r->bb_tex[k])
            continue;
        hz_texgen_sprite(sprites[k].kind, sprites[k].w, sprites[k].h, 1, img);
        res = upload_sprite(r, k, img, sprites[k].w, sprites[k].h, err);
    }
    free(img);
    if (res != HZ_OK)
        return res;
    return hz_gl_check(err, "billboard setup");
}

hz_result hz_renderer_set_billboard_texture(hz_renderer *r, uint32_t slot, const uint8_t *rgba, uint32_t w,
                                            uint32_t h, hz_err *err)
{
    HZ_ASSERT(r);
    if (slot >= HZ_MAX_BB_TEXTURES || !rgba || w == 0 || h == 0 || w > 4096 || h > 4096)
        return hz_err_set(err, HZ_ERR_VALUE, "renderer: billboard texture slot %u (< %u), size %ux%u", slot,
                          HZ_MAX_BB_TEXTURES, w, h);
    hz_result ctx = fx_check_context(r, err, "hz_renderer_set_billboard_texture");
    if (ctx != HZ_OK)
        return ctx;
    hz_gl_drain();
    return upload_sprite(r, slot, rgba, w, h, err);
}

hz_result hz_renderer_set_billboards(hz_renderer *r, const hz_billboard *b, size_t n, hz_err *err)
{
    HZ_ASSERT(r);
    if (n && !b)
        return hz_err_set(err, HZ_ERR_VALUE, "renderer: %zu billboards but no array", n);
    for (size_t i = 0; i < n; i++)
        if (!isfinite(b[i].pos[0]) || !isfinite(b[i].pos[1]) || !isfinite(b[i].pos[2]) || !isfinite(b[i].width) ||
            !isfinite(b[i].axis[1]) || b[i].texture >= HZ_MAX_BB_TEXTURES)
            return hz_err_set(err, HZ_ERR_VALUE, "renderer: billboard %zu is not finite or has texture slot %u", i,
                              b[i].texture);
    hz_bb_field_destroy(r->field);
    r->field = NULL;
    if (n == 0)
        return HZ_OK;
    r->field = hz_bb_field_create(b, n, 256.0f);
    if (!r->field)
        return hz_err_set(err, HZ_ERR_MEMORY, "renderer: out of memory for %zu billboards", n);
    return HZ_OK;
}

static bool reserve(hz_renderer *r, size_t n)
{
    if (n > r->bb_cap) {
        size_t cap = n + n / 2 + 256;
        hz_billboard *p = realloc(r->bb_buf, cap * sizeof *p);
        if (!p)
            return false;
        r->bb_buf = p;
        r->bb_cap = cap;
    }
    size_t sb = hz_billboards_scratch_bytes(n);
    if (sb > r->bb_scratch_cap) {
        void *p = realloc(r->bb_scratch, sb + sb / 2);
        if (!p)
            return false;
        r->bb_scratch = p;
        r->bb_scratch_cap = sb + sb / 2;
    }
    return true;
}

/* Culls the field for a camera into bb_buf at `at`; returns the count. */
static bool cull_into(hz_renderer *r, size_t at, const hz_camera *cam, float dist, size_t *n)
{
    size_t room = r->bb_cap - at;
    size_t got = hz_bb_field_cull(r->field, cam, dist, r->bb_buf + at, room);
    if (got > room) {
        if (!reserve(r, at + got))
            return false;
        got = hz_bb_field_cull(r->field, cam, dist, r->bb_buf + at, got);
    }
    *n = got;
    return true;
}

hz_result fx_billboards_prepare(hz_renderer *r, const fx_frame *f, const fx_view *main, const fx_view *mirror,
                                hz_err *err)
{
    r->n_trees = r->n_refl_trees = r->n_particles = 0;
    r->n_tree_batches = r->n_refl_batches = 0;
    if (!reserve(r, 1024))
        return hz_err_set(err, HZ_ERR_MEMORY, "renderer: out of memory for billboards");
    if ((f->bits & HZ_FX_BILLBOARDS) && r->field) {
        const float dist = f->fx.billboard_distance;
        if (!cull_into(r, 0, &main->cam, dist, &r->n_trees))
            return hz_err_set(err, HZ_ERR_MEMORY, "renderer: out of memory for billboards");
        if (mirror && !cull_into(r, r->n_trees, &mirror->cam, 0.5f * dist, &r->n_refl_trees))
            return hz_err_set(err, HZ_ERR_MEMORY, "renderer: out of memory for billboards");
        if (!reserve(r, r->n_trees + r->n_refl_trees))
            return hz_err_set(err, HZ_ERR_MEMORY, "renderer: out of memory for billboards");
        /* Alpha-tested: no order needed, one batch per texture. */
        r->n_tree_batches = hz_billboards_batch(r->bb_buf, r->n_trees, r->tree_batches,
                                                sizeof r->tree_batches / sizeof r->tree_batches[0], r->bb_scratch);
        r->n_refl_batches = hz_billboards_batch(r->bb_buf + r->n_trees, r->n_refl_trees, r->refl_batches,
                                                sizeof r->refl_batches / sizeof r->refl_batches[0], r->bb_scratch);
        for (size_t k = 0; k < r->n_refl_batches; k++)
            r->refl_batches[k].first += (uint32_t)r->n_trees;
    }
    if (f->bits & HZ_FX_WEATHER) {
        const bool snow = f->fx.weather == HZ_WEATHER_SNOW;
        hz_weather_desc wd = {.kind = f->fx.weather, .intensity = f->fx.weather_intensity,
                              .wind = {f->fx.wind[0], f->fx.wind[1]}, .seed = 1,
                              .texture = snow ? HZ_SPRITE_SNOW : HZ_SPRITE_RAIN};
        size_t at = r->n_trees + r->n_refl_trees, want = hz_weather_bound(&wd);
        if (!reserve(r, at + want))
            return hz_err_set(err, HZ_ERR_MEMORY, "renderer: out of memory for particles");
        r->n_particles = hz_weather_build(&wd, main->eye, f->time, r->bb_buf + at, want);
        /* Blended: back to front. */
        if (!hz_billboards_sort(r->bb_buf + at, r->n_particles, main->eye, r->bb_scratch))
            return hz_err_set(err, HZ_ERR_MEMORY, "renderer: out of memory sorting particles");
    }
    size_t total = r->n_trees + r->n_refl_trees + r->n_particles;
    if (total == 0)
        return HZ_OK;
    /* The GPU layout: three RGBA32F texels per billboard. */
    if (total * 12 > r->bb_gpu_cap) {
        size_t cap = total * 12 + total * 6;
        float *p = realloc(r->bb_gpu, cap * sizeof *p);
        if (!p)
            return hz_err_set(err, HZ_ERR_MEMORY, "renderer: out of memory for billboards");
        r->bb_gpu = p;
        r->bb_gpu_cap = cap;
    }
    for (size_t i = 0; i < total; i++) {
        const hz_billboard *b = &r->bb_buf[i];
        float *g = r->bb_gpu + 12 * i;
        g[0] = b->pos[0], g[1] = b->pos[1], g[2] = b->pos[2], g[3] = b->width;
        g[4] = b->axis[0], g[5] = b->axis[1], g[6] = b->axis[2], g[7] = b->height;
        for (int c = 0; c < 4; c++)
            g[8 + c] = (float)((b->rgba >> (8 * c)) & 255u) * (1.0f / 255.0f);
    }
    size_t bytes = total * 12 * sizeof(float);
    if ((size_t)r->max_tbo < total * 3)
        return hz_err_set(err, HZ_ERR_UNSUPPORTED, "renderer: %zu billboards exceed the texture buffer limit", total);
    glBindBuffer(GL_TEXTURE_BUFFER, r->bb_buf_gl);
    if (bytes > r->bb_gl_cap) {
        r->bb_gl_cap = bytes + bytes / 2;
        glBufferData(GL_TEXTURE_BUFFER, (GLsizeiptr)r->bb_gl_cap, NULL, GL_STREAM_DRAW);
        glBindTexture(GL_TEXTURE_BUFFER, r->bb_tbo);
        glTexBuffer(GL_TEXTURE_BUFFER, GL_RGBA32F, r->bb_buf_gl);
        glBindTexture(GL_TEXTURE_BUFFER, 0);
    }
    glBufferSubData(GL_TEXTURE_BUFFER, 0, (GLsizeiptr)bytes, r->bb_gpu);
    glBindBuffer(GL_TEXTURE_BUFFER, 0);
    return hz_gl_check(err, "billboard upload");
}

static void begin(hz_renderer *r, const fx_view *v, bool blend)
{
    const GLint *bl = r->bb_cur->loc;
    glUseProgram(r->bb_cur->prog);
    glUniformMatrix4fv(bl[BL_VIEWPROJ], 1, GL_FALSE, (const float *)v->viewproj);
    hz_gl_set_curvature(r->bb_cur->prog, &v->cam);
    /* The camera's axes in world space: the rows of the view rotation. */
    glUniform3f(bl[BL_CAM_RIGHT], v->view[0][0], v->view[1][0], v->view[2][0]);
    glUniform3f(bl[BL_CAM_UP], v->view[0][1], v->view[1][1], v->view[2][1]);
    glUniform1f(bl[BL_PX_PER_M], v->proj[1][1] * 0.5f * (float)v->h);
    glUniform1i(bl[BL_BLEND], blend ? 1 : 0);
    glBindVertexArray(r->vao);
    glActiveTexture(GL_TEXTURE0 + FX_UNIT_BB);
    glBindTexture(GL_TEXTURE_BUFFER, r->bb_tbo);
    glActiveTexture(GL_TEXTURE0 + FX_UNIT_LIGHTMAP);
    glBindTexture(GL_TEXTURE_2D, r->lightmap_tex);
    glActiveTexture(GL_TEXTURE0 + FX_UNIT_SPRITE);
    glDisable(GL_CULL_FACE);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_GREATER);
}

static void end(hz_renderer *r)
{
    glBindTexture(GL_TEXTURE_2D, 0);
    glActiveTexture(GL_TEXTURE0 + FX_UNIT_BB);
    glBindTexture(GL_TEXTURE_BUFFER, 0);
    glActiveTexture(GL_TEXTURE0);
    glBindVertexArray(r->vao);
}

/* One batch: count billboards from `first`, two triangles each. */
static void draw_range(hz_renderer *r, size_t first, size_t count, bool facing)
{
    glUniform1i(r->bb_cur->loc[BL_FIRST], (GLint)first);
    glUniform1i(r->bb_cur->loc[BL_FACING], facing ? 1 : 0);
    glDrawArrays(GL_TRIANGLES, 0, (GLsizei)(6 * count));
}

void fx_trees_draw(hz_renderer *r, const fx_frame *f, const fx_view *v)
{
    (void)f;
    const bool refl = v->pass == HZ_PASS_REFLECTION;
    const hz_bb_batch *bt = refl ? r->refl_batches : r->tree_batches;
    size_t nb = refl ? r->n_refl_batches : r->n_tree_batches;
    if (!nb)
        return;
    begin(r, v, false);
    glDisable(GL_BLEND);
    glDepthMask(GL_TRUE);
    for (size_t k = 0; k < nb && k < HZ_MAX_BB_TEXTURES * 2; k++) {
        if (!r->bb_tex[bt[k].texture])
            continue;
        glBindTexture(GL_TEXTURE_2D, r->bb_tex[bt[k].texture]);
        draw_range(r, bt[k].first, bt[k].count, false);
    }
    end(r);
}

void fx_weather_draw(hz_renderer *r, const fx_frame *f, const fx_view *v)
{
    if (!r->n_particles)
        return;
    const uint16_t tex = f->fx.weather == HZ_WEATHER_SNOW ? HZ_SPRITE_SNOW : HZ_SPRITE_RAIN;
    if (!r->bb_tex[tex])
        return;
    begin(r, v, true);
    glEnable(GL_BLEND);
    glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
    glDepthMask(GL_FALSE);
    glBindTexture(GL_TEXTURE_2D, r->bb_tex[tex]);
    /* One texture: a single batch, already sorted back to front. */
    draw_range(r, r->n_trees + r->n_refl_trees, r->n_particles, f->fx.weather == HZ_WEATHER_SNOW);
    glDisable(GL_BLEND);
    glDepthMask(GL_TRUE);
    end(r);
}

void fx_billboards_destroy(hz_renderer *r)
{
    prog_cache_clear(&r->bb);
    r->bb_cur = NULL;
    glDeleteTextures(1, &r->bb_tbo);
    glDeleteBuffers(1, &r->bb_buf_gl);
    free(r->bb_gpu);
    r->bb_gpu = NULL;
    r->bb_gpu_cap = r->bb_gl_cap = 0;
    glDeleteTextures(HZ_MAX_BB_TEXTURES, r->bb_tex);
    memset(r->bb_tex, 0, sizeof r->bb_tex);
    r->bb_tbo = r->bb_buf_gl = 0;
    hz_bb_field_destroy(r->field);
    r->field = NULL;
    free(r->bb_buf);
    free(r->bb_scratch);
    r->bb_buf = NULL;
    r->bb_scratch = NULL;
    r->bb_cap = r->bb_scratch_cap = 0;
}
