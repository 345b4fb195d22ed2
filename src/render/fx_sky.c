/* Sky dome with clouds (R1), the sun and its lens flare (R2).
 *
 * Clouds: a tileable fractal Perlin noise texture is computed once on the GPU
 * (the seed found CPU noise too slow for large sky textures); the sky shader
 * projects two layers of it onto a plane above the terrain, drifting with the
 * wind as a function of the frame time, so the same time gives the same sky.
 *
 * Flare: the sun's screen position is projected on the CPU; an occlusion
 * query counts how much of a small disc around it lies on sky (the depth
 * buffer still at its cleared far value) and not behind clouds; the flare's
 * rings along the sun -> screen centre line are scaled by that fraction and
 * added last, so a sun behind a mountain has no flare. */
#include "render_internal.h"

#include <math.h>
#include <string.h>

#include "hz_shaders.h"

#define NOISE_SIZE 512

hz_result fx_sky_ensure(hz_renderer *r, const fx_frame *f, hz_err *err)
{
    static const char *const names[] = {"u_inv_viewproj_rot", "u_sky_z", NULL};
    (void)f;
    /* One variant: the sky only exists with HZ_FX_SKY. */
    r->fx_sky_cur = prog_cache_get(&r->fx_sky, HZ_FX_SKY, hz_shader_sky_vs, hz_shader_fx_sky_fs, "fx_sky", 2, names,
                                   err);
    if (!r->fx_sky_cur)
        return HZ_ERR_GL;
    if (r->noise_tex)
        return HZ_OK;
    /* The cloud noise, rendered once. */
    GLuint prog = link_program(hz_shader_post_vs, hz_shader_fx_noise_fs, "fx_noise", 0, 0, err);
    if (!prog)
        return HZ_ERR_GL;
    GLuint fbo = 0;
    glGenTextures(1, &r->noise_tex);
    glBindTexture(GL_TEXTURE_2D, r->noise_tex);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RG8, NOISE_SIZE, NOISE_SIZE, 0, GL_RG, GL_UNSIGNED_BYTE, NULL);
    /* Nearest mip level: half the texels of trilinear (two fetches per sky
     * pixel); the smooth noise shows no seam between levels. */
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_REPEAT);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_REPEAT);
    glGenFramebuffers(1, &fbo);
    glBindFramebuffer(GL_FRAMEBUFFER, fbo);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, r->noise_tex, 0);
    GLenum status = glCheckFramebufferStatus(GL_FRAMEBUFFER);
    if (status == GL_FRAMEBUFFER_COMPLETE) {
        glViewport(0, 0, NOISE_SIZE, NOISE_SIZE);
        glDisable(GL_DEPTH_TEST);
        glDisable(GL_BLEND);
        glDisable(GL_CULL_FACE);
        glUseProgram(prog);
        glUniform1ui(glGetUniformLocation(prog, "u_seed"), 7u);
        glBindVertexArray(r->vao);
        glDrawArrays(GL_TRIANGLES, 0, 3);
        glBindVertexArray(0);
        glUseProgram(0);
    }
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glDeleteFramebuffers(1, &fbo);
    glDeleteProgram(prog);
    glGenerateMipmap(GL_TEXTURE_2D);
    glBindTexture(GL_TEXTURE_2D, 0);
    if (status != GL_FRAMEBUFFER_COMPLETE) {
        glDeleteTextures(1, &r->noise_tex);
        r->noise_tex = 0;
        return hz_err_set(err, HZ_ERR_GL, "GL: cloud noise framebuffer incomplete (0x%04x)", (unsigned)status);
    }
    return hz_gl_check(err, "cloud noise");
}

void fx_sky_draw(hz_renderer *r, const fx_frame *f, const fx_view *v)
{
    (void)f;
    glUseProgram(r->fx_sky_cur->prog);
    glUniformMatrix4fv(r->fx_sky_cur->loc[SL_INV_VP], 1, GL_FALSE, (const float *)v->inv_vp_rot);
    /* Drawn after the terrain at the far plane (depth 0 in reverse-Z: NDC 0
     * with glClipControl, -1 with GL's default range), depth test GEQUAL. */
    glUniform1f(r->fx_sky_cur->loc[SL_SKY_Z], r->clip_control ? 0.0f : -1.0f);
    glActiveTexture(GL_TEXTURE0 + FX_UNIT_CLOUDS);
    glBindTexture(GL_TEXTURE_2D, r->noise_tex);
    glActiveTexture(GL_TEXTURE0);
    glDrawArrays(GL_TRIANGLES, 0, 3);
}

hz_result fx_flare_ensure(hz_renderer *r, const fx_frame *f, hz_err *err)
{
    static const char *const names[] = {"u_center", "u_half", "u_z", "u_clouds", NULL};
    r->query_cur = prog_cache_get(&r->query, f->bits & HZ_FX_SKY, hz_shader_fx_sunquery_vs, hz_shader_fx_sunquery_fs,
                                  "fx_sunquery", 3, names, err);
    if (!r->query_cur)
        return HZ_ERR_GL;
    if (r->flare_prog)
        return HZ_OK;
    r->flare_prog = link_program(hz_shader_fx_flare_vs, hz_shader_fx_flare_fs, "fx_flare", 0, 0, err);
    if (!r->flare_prog)
        return HZ_ERR_GL;
    r->f_sun = glGetUniformLocation(r->flare_prog, "u_sun");
    r->f_aspect = glGetUniformLocation(r->flare_prog, "u_aspect");
    r->f_t = glGetUniformLocation(r->flare_prog, "u_t");
    r->f_size = glGetUniformLocation(r->flare_prog, "u_size");
    r->f_color = glGetUniformLocation(r->flare_prog, "u_color");
    r->f_intensity = glGetUniformLocation(r->flare_prog, "u_intensity");
    glGenQueries(2, r->queries);
    return hz_gl_check(err, "flare setup");
}

/* The flare's elements: position along sun -> centre, radius (fraction of
 * the screen height), colour, kind (0 glow, 1 ring, 2 disc). */
static const struct {
    float t, size, rgb[3], kind;
} elements[8] = {
    {0.00f, 0.16f, {1.00f, 0.90f, 0.72f}, 0}, {0.42f, 0.035f, {0.95f, 0.55f, 0.25f}, 2},
    {0.62f, 0.090f, {0.35f, 0.65f, 1.00f}, 1}, {0.86f, 0.022f, {0.55f, 1.00f, 0.55f}, 2},
    {1.15f, 0.055f, {0.70f, 0.45f, 1.00f}, 2}, {1.40f, 0.150f, {1.00f, 0.60f, 0.30f}, 1},
    {1.75f, 0.030f, {0.40f, 0.80f, 1.00f}, 2}, {2.10f, 0.085f, {1.00f, 0.90f, 0.60f}, 2},
};
static const float element_gain[8] = {0.30f, 0.16f, 0.10f, 0.18f, 0.10f, 0.06f, 0.14f, 0.07f};

void fx_flare_draw(hz_renderer *r, const fx_frame *f, const fx_view *v, hz_draw_stats *st)
{
    const float *s = f->sp.sun_dir;
    vec4 dir = {s[0], s[1], s[2], 0.0f}, clip;
    glm_mat4_mulv((vec4 *)v->viewproj, dir, clip);
    if (clip[3] <= 1e-6f || s[1] <= -0.02f)
        return; /* behind the camera or below the horizon */
    const float nx = clip[0] / clip[3], ny = clip[1] / clip[3];
    if (fabsf(nx) > 1.25f || fabsf(ny) > 1.25f)
        return;

    /* Occlusion query over a disc a little larger than the sun. */
    const float fov = glm_rad(v->cam.fov_y > 0 ? v->cam.fov_y : 60.0f);
    const float px_per_rad = (float)v->h / (2.0f * tanf(0.5f * fov));
    float radius_px = fmaxf(6.0f, 1.5f * glm_rad(0.35f) * px_per_rad);
    const GLint *ql = r->query_cur->loc;
    glUseProgram(r->query_cur->prog);
    glUniform2f(ql[QL_CENTER], nx, ny);
    glUniform2f(ql[QL_HALF], radius_px * 2.0f / (float)v->w, radius_px * 2.0f / (float)v->h);
    /* The far plane: depth 0 in reverse-Z (NDC z 0 with glClipControl's [0, 1]
     * range, -1 with GL's default [-1, 1]). */
    glUniform1f(ql[QL_Z], r->clip_control ? 0.0f : -1.0f);
    glActiveTexture(GL_TEXTURE0 + FX_UNIT_CLOUDS);
    glBindTexture(GL_TEXTURE_2D, r->noise_tex);
    glActiveTexture(GL_TEXTURE0);
    glColorMask(GL_FALSE, GL_FALSE, GL_FALSE, GL_FALSE);
    glDepthMask(GL_FALSE);
    glDisable(GL_CULL_FACE);
    glDisable(GL_BLEND);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_GEQUAL); /* passes only where nothing nearer than the far plane was drawn */
    glUniform1i(ql[QL_CLOUDS], (f->bits & HZ_FX_SKY) ? 1 : 0);
    glBeginQuery(GL_SAMPLES_PASSED, r->queries[0]);
    glDrawArrays(GL_TRIANGLE_STRIP, 0, 4);
    glEndQuery(GL_SAMPLES_PASSED);
    glDisable(GL_DEPTH_TEST);
    glUniform1i(ql[QL_CLOUDS], 0);
    glBeginQuery(GL_SAMPLES_PASSED, r->queries[1]);
    glDrawArrays(GL_TRIANGLE_STRIP, 0, 4);
    glEndQuery(GL_SAMPLES_PASSED);
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    /* NOTE: waiting for the result stalls a real GPU for a moment; it keeps
     * the frame deterministic (tests, bench), which matters more here. */
    GLuint passed = 0, total = 0;
    glGetQueryObjectuiv(r->queries[0], GL_QUERY_RESULT, &passed);
    glGetQueryObjectuiv(r->queries[1], GL_QUERY_RESULT, &total);
    float vis = total ? (float)passed / (float)total : 0.0f;
    if (st)
        st->sun_visible = vis;
    if (vis <= 0.0f)
        return;

    /* Weaker toward the screen edges and with the sun at the horizon. */
    float edge = 1.0f - glm_clamp(fmaxf(fabsf(nx), fabsf(ny)) - 0.7f, 0.0f, 0.55f) / 0.55f;
    float low = glm_clamp(s[1] / 0.05f, 0.0f, 1.0f);
    float intensity = vis * f->fx.flare * edge * low;
    if (intensity <= 0.0f)
        return;
    float t[8], size[8], color[32];
    for (int k = 0; k < 8; k++) {
        t[k] = elements[k].t;
        size[k] = elements[k].size;
        for (int c = 0; c < 3; c++)
            color[4 * k + c] = elements[k].rgb[c] * element_gain[k] * f->sun_color[c];
        color[4 * k + 3] = elements[k].kind;
    }
    glUseProgram(r->flare_prog);
    glUniform2f(r->f_sun, nx, ny);
    glUniform1f(r->f_aspect, (float)v->w / (float)v->h);
    glUniform1fv(r->f_t, 8, t);
    glUniform1fv(r->f_size, 8, size);
    glUniform4fv(r->f_color, 8, color);
    glUniform1f(r->f_intensity, intensity);
    glEnable(GL_BLEND);
    glBlendFunc(GL_ONE, GL_ONE); /* the seed's additive (rs + rd, gs + gd, bs + bd) */
    glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, 8);
    glDisable(GL_BLEND);
    glDepthMask(GL_TRUE);
}

void fx_sky_destroy(hz_renderer *r)
{
    prog_cache_clear(&r->fx_sky);
    prog_cache_clear(&r->query);
    glDeleteProgram(r->flare_prog);
    glDeleteTextures(1, &r->noise_tex);
    glDeleteQueries(2, r->queries);
    r->fx_sky_cur = r->query_cur = NULL;
    r->flare_prog = r->noise_tex = 0;
}
