/* Render helpers below both the frame driver (renderer.c) and the effect
 * modules (fx_*.c, terrain_patch.c): context checks, shader compilation with
 * the effects' common block, the per-variant program cache. Nothing here
 * calls up into them. */
#include "render_internal.h"

#include <stdio.h>
#include <string.h>

#include "gl_util.h"
#include "hz_shaders.h" /* generated from shaders/<name>.glsl */

/* The renderer's GL names only mean something in the context that made them. */
hz_result fx_check_context(const hz_renderer *r, hz_err *err, const char *what)
{
    void *cur = hz_gl_current_context();
    if (!cur)
        return hz_err_set(err, HZ_ERR_GL, "renderer: %s without a current OpenGL context", what);
    if (cur != r->ctx)
        return hz_err_set(err, HZ_ERR_GL, "renderer: %s with a different OpenGL context current than the one "
                          "the renderer was created in", what);
    return HZ_OK;
}


/* ---- shaders ------------------------------------------------------------- */

/* Compiles src; with `common`, shaders/fx_common.glsl is inserted after the
 * #version line (the GLSL has no #include); a variant is passed as
 * FX_VARIANT. */
static GLuint compile_shader(GLenum type, const char *src, const char *name, bool common, uint32_t variant,
                             hz_err *err)
{
    if (!common && !variant)
        return hz_gl_compile(type, 1, &src, NULL, name, err);
    const char *nl = strchr(src, '\n');
    if (common) {
        if (!nl || strncmp(src, "#version", 8) != 0) {
            hz_err_set(err, HZ_ERR_GL, "GL: shader %s does not start with a #version line", name);
            return 0;
        }
        char consts[480];
        snprintf(consts, sizeof consts,
                 "const int FX_ENABLED = %u;\nconst bool FX_HAS_COLORMAP = %s;\nconst bool FX_HAS_COVER = %s;\n"
                 "const bool FX_CLIP_PASS = %s;\nconst bool FX_HAS_IMAGERY = %s;\n"
                 "const bool FX_DETAIL_FAR = %s;\nconst bool FX_LIT = %s;\n%s",
                 variant & HZ_FX_ALL, (variant & FX_VARIANT_COLORMAP) ? "true" : "false",
                 (variant & FX_VARIANT_COVER) ? "true" : "false", (variant & FX_VARIANT_CLIP) ? "true" : "false",
                 (variant & FX_VARIANT_IMAGERY) ? "true" : "false",
                 (variant & FX_VARIANT_DETAIL_FAR) ? "true" : "false", (variant & FX_VARIANT_LIT) ? "true" : "false",
                 (variant & FX_VARIANT_VLIT) ? "#define FX_VLIT 1\n" : "");
        const char *parts[6] = {src, consts, "#line 1 1\n", hz_shader_fx_common, "\n#line 2 0\n", nl + 1};
        const GLint lens[6] = {(GLint)(nl + 1 - src), -1, -1, -1, -1, -1};
        return hz_gl_compile(type, 6, parts, lens, name, err);
    }
    char def[64];
    snprintf(def, sizeof def, "#define FX_VARIANT %u\n", variant);
    return hz_gl_compile_defs(type, src, def, name, err);
}

GLuint link_program(const char *vs_src, const char *fs_src, const char *name, int common, uint32_t variant,
                    hz_err *err)
{
    char vs_name[64], fs_name[64];
    snprintf(vs_name, sizeof vs_name, "%s_vs.glsl", name);
    snprintf(fs_name, sizeof fs_name, "%s_fs.glsl", name);
    GLuint vs = compile_shader(GL_VERTEX_SHADER, vs_src, vs_name, (common & 1) != 0, variant, err);
    GLuint fs = vs ? compile_shader(GL_FRAGMENT_SHADER, fs_src, fs_name, (common & 2) != 0, variant, err) : 0;
    GLuint p = hz_gl_link(vs, fs, name, err);
    if (p && common)
        fx_program_setup(p);
    return p;
}

const prog_variant *prog_cache_get(prog_cache *c, uint32_t key, const char *vs, const char *fs, const char *name,
                                   int common_mask, const char *const *names, hz_err *err)
{
    c->tick++;
    for (uint32_t k = 0; k < c->n; k++)
        if (c->v[k].key == key && c->v[k].prog) {
            c->v[k].last_use = c->tick;
            return &c->v[k];
        }
    GLuint p = link_program(vs, fs, name, common_mask, key, err);
    if (!p)
        return NULL;
    uint32_t slot = c->n;
    if (slot == FX_MAX_VARIANTS) { /* full: replace the least recently used */
        slot = 0;
        for (uint32_t k = 1; k < c->n; k++)
            if (c->v[k].last_use < c->v[slot].last_use)
                slot = k;
        glDeleteProgram(c->v[slot].prog);
    } else {
        c->n++;
    }
    prog_variant *v = &c->v[slot];
    memset(v, 0, sizeof *v);
    v->key = key;
    v->prog = p;
    v->last_use = c->tick;
    for (int k = 0; k < FX_MAX_LOCS; k++)
        v->loc[k] = -1;
    for (int k = 0; names && names[k] && k < FX_MAX_LOCS; k++)
        v->loc[k] = glGetUniformLocation(p, names[k]);
    return v;
}

void prog_cache_clear(prog_cache *c)
{
    for (uint32_t k = 0; k < c->n; k++)
        glDeleteProgram(c->v[k].prog);
    memset(c, 0, sizeof *c);
}

void fx_program_setup(GLuint p)
{
    GLuint block = glGetUniformBlockIndex(p, "FxCommon");
    if (block != GL_INVALID_INDEX)
        glUniformBlockBinding(p, block, FX_UBO_BINDING);
    static const struct {
        const char *name;
        GLint unit;
    } units[] = {{"u_heights", FX_UNIT_HEIGHTS},     {"u_lightmap", FX_UNIT_LIGHTMAP}, {"u_detail", FX_UNIT_DETAIL},
                 {"u_colormap", FX_UNIT_COLORMAP},   {"u_cover", FX_UNIT_COVER},       {"u_tex", FX_UNIT_SPRITE},
                 {"u_reflection", FX_UNIT_REFLECTION}, {"u_cloud_noise", FX_UNIT_CLOUDS}, {"u_bb", FX_UNIT_BB},
                 {"u_normals", FX_UNIT_NORMALS}, {"u_lit", FX_UNIT_LIT}, {"u_tiles", FX_UNIT_TILES},
                 {"u_img_ov", FX_UNIT_IMG_OV}, {"u_img_tiles", FX_UNIT_IMG_TILES}, {"u_valid", FX_UNIT_VALID},
                 {"u_coast", FX_UNIT_COAST}};
    glUseProgram(p);
    for (size_t k = 0; k < sizeof units / sizeof units[0]; k++) {
        GLint loc = glGetUniformLocation(p, units[k].name);
        if (loc >= 0)
            glUniform1i(loc, units[k].unit);
    }
    glUseProgram(0);
}



hz_result fx_make_target(GLuint *fbo, GLuint *tex, GLuint depth, uint32_t w, uint32_t h, GLenum format, hz_err *err)
{
    if (!*tex)
        glGenTextures(1, tex);
    glBindTexture(GL_TEXTURE_2D, *tex);
    glTexImage2D(GL_TEXTURE_2D, 0, (GLint)format, (GLsizei)w, (GLsizei)h, 0, GL_RGBA,
                 format == GL_RGBA8 ? GL_UNSIGNED_BYTE : GL_HALF_FLOAT, NULL);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    glBindTexture(GL_TEXTURE_2D, 0);
    if (!*fbo)
        glGenFramebuffers(1, fbo);
    glBindFramebuffer(GL_FRAMEBUFFER, *fbo);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, *tex, 0);
    if (depth)
        glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth);
    GLenum status = glCheckFramebufferStatus(GL_FRAMEBUFFER);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    if (status != GL_FRAMEBUFFER_COMPLETE)
        return hz_err_set(err, HZ_ERR_GL, "GL: effect target %ux%u incomplete (0x%04x)", w, h, (unsigned)status);
    return hz_gl_check(err, "effect target");
}
