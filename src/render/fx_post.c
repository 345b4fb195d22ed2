/* The effect chain over a render-to-texture of the scene (R7, R8): the scene
 * is drawn into an RGBA8 texture (see the NOTE below), then a list of full-screen passes runs
 * over it, each reading the previous one's output:
 *   motion blur  P = (1 - f) P_now + f P_prev, P_prev its own previous output,
 *                kept per history slot (ping-pong textures);
 *   bloom        bright pass at half resolution, separable Gaussian at a
 *                quarter;
 *   final        bloom added, then exposure and gamma, into the output.
 * One scene render per frame, as the seed wanted for motion blur. */
#include "render_internal.h"

#include <string.h>

#include "hz_shaders.h"

/* NOTE: the chain runs in RGBA8: llvmpipe's fast paths are 8-bit unorm, and a
 * half-float scene cost about twice as much per pass. Bright parts saturate
 * at white before bloom, which is enough for the sun and its reflections. */
#define FX_CHAIN_FORMAT GL_RGBA8


/* Variants of the last pass (post_final_fs.glsl): it copies the scene depth
 * (windows), adds bloom, applies a gamma other than 1. */
enum { FINAL_DEPTH = 1, FINAL_BLOOM = 2, FINAL_GAMMA = 4, FINAL_ALL = 7 };

/* The last pass's variant for key (FX_VARIANT), linked on first use; 0 +
 * err if it does not link. */
static GLuint final_program(hz_renderer *r, unsigned key, hz_err *err)
{
    if (!r->final_prog[key])
        r->final_prog[key] = link_program(hz_shader_post_vs, hz_shader_post_final_fs, "post_final", 0, key, err);
    return r->final_prog[key];
}

hz_result fx_post_ensure(hz_renderer *r, hz_err *err)
{
    if (r->final_prog[FINAL_ALL])
        return HZ_OK;
    r->blur_prog = link_program(hz_shader_post_vs, hz_shader_post_blur_fs, "post_blur", 0, 0, err);
    r->bright_prog = r->blur_prog ? link_program(hz_shader_post_vs, hz_shader_post_bright_fs, "post_bright", 0, 0, err) : 0;
    r->gauss_prog = r->bright_prog ? link_program(hz_shader_post_vs, hz_shader_post_gauss_fs, "post_gauss", 0, 0, err) : 0;
    /* The variant that does everything, kept as the fallback of the others. */
    if (!r->gauss_prog || !final_program(r, FINAL_ALL, err))
        return HZ_ERR_GL;
    return hz_gl_check(err, "post chain setup");
}

hz_result fx_scene_target(hz_renderer *r, hz_err *err)
{
    if (r->scene_fbo && r->scene_w == r->width && r->scene_h == r->height)
        return HZ_OK;
    /* Depth as a texture: the last pass copies it to the output (the window's
     * overlay depth-tests against it). */
    if (!r->scene_depth)
        glGenTextures(1, &r->scene_depth);
    glBindTexture(GL_TEXTURE_2D, r->scene_depth);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_DEPTH_COMPONENT32F, (GLsizei)r->width, (GLsizei)r->height, 0,
                 GL_DEPTH_COMPONENT, GL_FLOAT, NULL);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    glBindTexture(GL_TEXTURE_2D, 0);
    hz_result res = fx_make_target(&r->scene_fbo, &r->scene_color, 0, r->width, r->height, FX_CHAIN_FORMAT, err);
    if (res != HZ_OK)
        return res;
    glBindFramebuffer(GL_FRAMEBUFFER, r->scene_fbo);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, r->scene_depth, 0);
    GLenum status = glCheckFramebufferStatus(GL_FRAMEBUFFER);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    if (status != GL_FRAMEBUFFER_COMPLETE)
        return hz_err_set(err, HZ_ERR_GL, "GL: scene target %ux%u incomplete (0x%04x)", r->width, r->height,
                          (unsigned)status);
    r->scene_w = r->width;
    r->scene_h = r->height;
    return hz_gl_check(err, "scene target");
}

static void fullscreen(GLuint fbo, uint32_t w, uint32_t h)
{
    glBindFramebuffer(GL_FRAMEBUFFER, fbo);
    glViewport(0, 0, (GLsizei)w, (GLsizei)h);
    glDrawArrays(GL_TRIANGLES, 0, 3);
}

static void bind_tex(GLuint unit, GLuint tex)
{
    glActiveTexture(GL_TEXTURE0 + unit);
    glBindTexture(GL_TEXTURE_2D, tex);
}

/* Motion blur: returns the texture holding this frame's blended result. */
static GLuint motion_blur(hz_renderer *r, const fx_frame *f, GLuint src)
{
    hist_slot *h = &r->hist[f->sp.history];
    if (h->w != r->width || h->h != r->height || !h->fbo[0]) {
        for (int k = 0; k < 2; k++)
            if (fx_make_target(&h->fbo[k], &h->tex[k], 0, r->width, r->height, FX_CHAIN_FORMAT, NULL) != HZ_OK)
                return src; /* no history target: no blur this frame (the frame is still right) */
        h->w = r->width, h->h = r->height;
        h->valid = false;
    }
    if (f->sp.reset_history)
        h->valid = false;
    const int dst = 1 - h->cur;
    glUseProgram(r->blur_prog);
    glUniform1i(glGetUniformLocation(r->blur_prog, "u_now"), 0);
    glUniform1i(glGetUniformLocation(r->blur_prog, "u_prev"), 1);
    /* The first frame of a slot has no past: P = P_now. */
    glUniform1f(glGetUniformLocation(r->blur_prog, "u_f"), h->valid ? f->fx.blur : 0.0f);
    bind_tex(0, src);
    bind_tex(1, h->tex[h->cur]);
    fullscreen(h->fbo[dst], r->width, r->height);
    h->cur = dst;
    h->valid = true;
    return h->tex[dst];
}

static GLuint bloom(hz_renderer *r, const fx_frame *f, GLuint src)
{
    uint32_t hw = r->width / 2 ? r->width / 2 : 1, hh = r->height / 2 ? r->height / 2 : 1;
    uint32_t qw = r->width / 4 ? r->width / 4 : 1, qh = r->height / 4 ? r->height / 4 : 1;
    if (r->bloom_w != r->width || r->bloom_h != r->height || !r->bloom_fbo[0]) {
        if (fx_make_target(&r->bloom_fbo[0], &r->bloom_tex[0], 0, hw, hh, FX_CHAIN_FORMAT, NULL) != HZ_OK ||
            fx_make_target(&r->bloom_fbo[1], &r->bloom_tex[1], 0, qw, qh, FX_CHAIN_FORMAT, NULL) != HZ_OK ||
            fx_make_target(&r->bloom_fbo[2], &r->bloom_tex[2], 0, qw, qh, FX_CHAIN_FORMAT, NULL) != HZ_OK)
            return 0;
        r->bloom_w = r->width, r->bloom_h = r->height;
    }
    glUseProgram(r->bright_prog);
    glUniform1i(glGetUniformLocation(r->bright_prog, "u_src"), 0);
    glUniform2f(glGetUniformLocation(r->bright_prog, "u_texel"), 1.0f / (float)r->width, 1.0f / (float)r->height);
    glUniform1f(glGetUniformLocation(r->bright_prog, "u_threshold"), f->fx.bloom_threshold);
    bind_tex(0, src);
    fullscreen(r->bloom_fbo[0], hw, hh);
    glUseProgram(r->gauss_prog);
    glUniform1i(glGetUniformLocation(r->gauss_prog, "u_src"), 0);
    GLint step = glGetUniformLocation(r->gauss_prog, "u_step");
    /* Horizontal, reading the half-resolution image (bilinear: a 2x2 average). */
    glUniform2f(step, 2.0f / (float)hw, 0.0f);
    bind_tex(0, r->bloom_tex[0]);
    fullscreen(r->bloom_fbo[1], qw, qh);
    glUniform2f(step, 0.0f, 1.0f / (float)qh);
    bind_tex(0, r->bloom_tex[1]);
    fullscreen(r->bloom_fbo[2], qw, qh);
    return r->bloom_tex[2];
}

void fx_post_run(hz_renderer *r, const fx_frame *f, GLuint out_fbo)
{
    glDisable(GL_DEPTH_TEST);
    glDepthMask(GL_FALSE);
    glDisable(GL_BLEND);
    glDisable(GL_CULL_FACE);
    glBindVertexArray(r->vao);
    GLuint src = r->scene_color, bloom_tex = 0;
    if (f->bits & HZ_FX_MOTIONBLUR)
        src = motion_blur(r, f, src);
    if (f->bits & HZ_FX_BLOOM)
        bloom_tex = bloom(r, f, src);
    /* A window draws its overlay against the depth buffer: the scene's depth
     * goes along into it (GL_ALWAYS: it was never cleared). Headless, the
     * sky mask reads the scene target's depth directly. */
    const unsigned key = (out_fbo == 0 ? FINAL_DEPTH : 0u) | (bloom_tex ? FINAL_BLOOM : 0u) |
                         (f->fx.gamma != 1.0f ? FINAL_GAMMA : 0u);
    hz_err ignored = {0};
    GLuint fp = final_program(r, key, &ignored);
    if (!fp) {
        fp = r->final_prog[FINAL_ALL]; /* depth copy aside, the same picture */
        hz_gl_drain();
    }
    glUseProgram(fp);
    glUniform1i(glGetUniformLocation(fp, "u_scene"), 0);
    glUniform1i(glGetUniformLocation(fp, "u_bloom"), 1);
    glUniform1i(glGetUniformLocation(fp, "u_depth"), 2);
    bind_tex(2, r->scene_depth);
    if (out_fbo == 0) {
        glEnable(GL_DEPTH_TEST);
        glDepthFunc(GL_ALWAYS);
        glDepthMask(GL_TRUE);
    }
    glUniform1f(glGetUniformLocation(fp, "u_bloom_strength"), f->fx.bloom_strength);
    glUniform1f(glGetUniformLocation(fp, "u_exposure"), f->fx.exposure);
    glUniform1f(glGetUniformLocation(fp, "u_gamma"), f->fx.gamma);
    bind_tex(0, src);
    bind_tex(1, bloom_tex);
    fullscreen(out_fbo, r->width, r->height);
    bind_tex(2, 0);
    bind_tex(1, 0);
    bind_tex(0, 0);
    glDepthFunc(GL_GREATER);
    glDepthMask(GL_TRUE);
}

void fx_post_destroy(hz_renderer *r)
{
    glDeleteProgram(r->blur_prog);
    glDeleteProgram(r->bright_prog);
    glDeleteProgram(r->gauss_prog);
    for (size_t k = 0; k < sizeof r->final_prog / sizeof r->final_prog[0]; k++) {
        glDeleteProgram(r->final_prog[k]);
        r->final_prog[k] = 0;
    }
    r->blur_prog = r->bright_prog = r->gauss_prog = 0;
    glDeleteFramebuffers(1, &r->scene_fbo);
    glDeleteTextures(1, &r->scene_color);
    glDeleteTextures(1, &r->scene_depth);
    r->scene_fbo = r->scene_color = r->scene_depth = 0;
    for (uint32_t k = 0; k < HZ_MAX_HISTORY; k++) {
        glDeleteFramebuffers(2, r->hist[k].fbo);
        glDeleteTextures(2, r->hist[k].tex);
    }
    memset(r->hist, 0, sizeof r->hist);
    glDeleteFramebuffers(3, r->bloom_fbo);
    glDeleteTextures(3, r->bloom_tex);
    memset(r->bloom_fbo, 0, sizeof r->bloom_fbo);
    memset(r->bloom_tex, 0, sizeof r->bloom_tex);
    r->bloom_w = r->bloom_h = 0;
}
