/* The plain terrain's lit map: per heightmap sample, the colour that
 * terrain_fs.glsl computes without effects (colour by height and slope, sun
 * Lambert, ambient; fog aside), baked on the GPU by the same GLSL
 * (shaders/ground_color.glsl). The plain terrain then reads it with one
 * trilinear fetch per pixel instead of the normal map, the colour and the
 * lighting: on llvmpipe that shading is a large share of the frame.
 *
 * Like Ogre's composite map it must follow the lighting. It is baked again
 * when the sun, the ambient term or the climate change, once they have held
 * still for a frame: while they change from frame to frame (an animated
 * sun) the terrain is shaded per pixel, so a frame never waits for a bake. */
#include "render_internal.h"

#include "hz_shaders.h"

#include <stdlib.h>
#include <string.h>

/* At most this much for the map with its mip levels (RGBA8, 4/3 n^2 texels):
 * up to 4097^2 samples (90 MB). Larger maps are shaded per pixel. */
#define LIT_MAX_BYTES (96ull << 20)

enum { LL_SIZE, LL_HSCALE, LL_HOFFSET, LL_CLIMATE, LL_SUN, LL_AMBIENT, LL_COUNT };
_Static_assert(LL_COUNT == sizeof ((hz_renderer *)0)->lit_loc / sizeof(GLint), "lit_loc holds LL_COUNT locations");

/* What the lit map depends on besides the heightmap. */
static void lighting_key(const hz_renderer *r, const fx_frame *f, float key[LIT_KEY_LEN])
{
    key[0] = f->sp.sun_dir[0];
    key[1] = f->sp.sun_dir[1];
    key[2] = f->sp.sun_dir[2];
    key[3] = f->sp.ambient;
    key[4] = r->climate.snow_line;
    key[5] = r->climate.tree_line;
    key[6] = r->climate.aridity;
    key[7] = r->zscale;
}

/* Whether the heightmap can have a lit map (in memory, with a normal map,
 * small enough). */
static bool litmap_fits(const hz_renderer *r)
{
    const uint64_t n = r->size;
    return r->has_heights && !r->streamed && r->normal_tex && n > 0 && n <= (uint64_t)r->max_tex &&
           n * n * 16 / 3 <= LIT_MAX_BYTES;
}

static hz_result lit_setup(hz_renderer *r, hz_err *err)
{
    if (!r->lit_prog) {
        r->lit_prog = link_program(hz_shader_post_vs, hz_shader_terrain_lit_fs, "terrain_lit", 0, 0, err);
        if (!r->lit_prog)
            return HZ_ERR_GL;
        fx_program_setup(r->lit_prog);
        static const char *const names[LL_COUNT] = {"u_size", "u_hscale", "u_hoffset",
                                                    "u_climate", "u_sun_dir", "u_ambient"};
        for (int k = 0; k < LL_COUNT; k++)
            r->lit_loc[k] = glGetUniformLocation(r->lit_prog, names[k]);
    }
    if (r->lit_tex)
        return HZ_OK;
    hz_result res = fx_make_target(&r->lit_fbo, &r->lit_tex, 0, r->size, r->size, GL_RGBA8, err);
    if (res == HZ_OK) {
        /* Mipmapped and filtered as the normal map it replaces
         * (make_normal_texture); each bake generates the levels. */
        glBindTexture(GL_TEXTURE_2D, r->lit_tex);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
        glBindTexture(GL_TEXTURE_2D, 0);
        res = hz_gl_check(err, "lit map allocation (RGBA8)");
    }
    if (res != HZ_OK)
        litmap_release(r);
    return res;
}

/* Interpolated over a cell's two triangles instead of bilinearly, a colour
 * is off by at most a quarter of the cell's twist |a - b - c + d| (at its
 * centre, whichever the diagonal). Blocks whose twist stays within 4 *
 * LIT_SMOOTH_TOL in every cell and channel are smooth. */
#define LIT_SMOOTH_TOL 2

/* The smooth blocks of P x P cells (hz_renderer.lit_smooth) of the baked
 * map, read back from its framebuffer a row of blocks at a time (OpenGL
 * 3.3). Not fatal when out of memory or on a GL error: no block is smooth
 * then (every patch reads per pixel). */
static void litmap_smooth(hz_renderer *r, uint32_t P)
{
    free(r->lit_smooth);
    r->lit_smooth = NULL;
    r->lit_smooth_cells = P; /* tried for this size, done or not: not again each frame */
    r->lit_smooth_n = 0;
    const uint32_t n = r->size;
    if (!P || n < 2 || (n - 1) % P)
        return;
    const uint32_t nb = (n - 1) / P;
    uint8_t *mask = calloc((size_t)nb * nb, 1);
    uint8_t *rows = malloc((size_t)(P + 1) * n * 4);
    if (!mask || !rows) {
        free(mask);
        free(rows);
        return;
    }
    GLint read_fbo = 0;
    glGetIntegerv(GL_READ_FRAMEBUFFER_BINDING, &read_fbo);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, r->lit_fbo);
    glBindBuffer(GL_PIXEL_PACK_BUFFER, 0);
    for (uint32_t bj = 0; bj < nb; bj++) {
        glReadPixels(0, (GLint)(bj * P), (GLsizei)n, (GLsizei)(P + 1), GL_RGBA, GL_UNSIGNED_BYTE, rows);
        for (uint32_t bi = 0; bi < nb; bi++) {
            bool smooth = true;
            for (uint32_t j = 0; j < P && smooth; j++) {
                const uint8_t *r0 = rows + ((size_t)j * n + (size_t)bi * P) * 4, *r1 = r0 + (size_t)n * 4;
                for (uint32_t i = 0; i < P * 4 && smooth; i++) {
                    if ((i & 3) == 3)
                        continue; /* alpha */
                    const int t = (int)r0[i] - r0[i + 4] - r1[i] + r1[i + 4];
                    smooth = abs(t) <= 4 * LIT_SMOOTH_TOL;
                }
            }
            mask[(size_t)bj * nb + bi] = smooth;
        }
    }
    free(rows);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, (GLuint)read_fbo);
    if (glGetError() != GL_NO_ERROR) {
        free(mask);
        hz_gl_drain();
        return;
    }
    r->lit_smooth = mask;
    r->lit_smooth_n = nb;
}

bool litmap_smooth_at(const hz_renderer *r, uint32_t x0, uint32_t z0)
{
    const uint32_t P = r->lit_smooth_cells;
    if (!r->lit_smooth || !r->lit_valid || P != r->patch_cells || x0 % P || z0 % P)
        return false;
    const uint32_t bi = x0 / P, bj = z0 / P;
    return bi < r->lit_smooth_n && bj < r->lit_smooth_n && r->lit_smooth[(size_t)bj * r->lit_smooth_n + bi];
}

static hz_result bake(hz_renderer *r, const float key[LIT_KEY_LEN], hz_err *err)
{
    hz_result res = lit_setup(r, err);
    if (res != HZ_OK)
        return res;
    glBindFramebuffer(GL_FRAMEBUFFER, r->lit_fbo);
    glViewport(0, 0, (GLsizei)r->size, (GLsizei)r->size);
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_BLEND);
    glDisable(GL_CULL_FACE);
    glDisable(GL_SCISSOR_TEST);
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    glPolygonMode(GL_FRONT_AND_BACK, GL_FILL);
    glUseProgram(r->lit_prog);
    glUniform1i(r->lit_loc[LL_SIZE], (GLint)r->size);
    glUniform1f(r->lit_loc[LL_HSCALE], r->hscale);
    glUniform1f(r->lit_loc[LL_HOFFSET], r->hoffset);
    /* As terrain_program sets them: lines in world units (metres times zscale). */
    glUniform4f(r->lit_loc[LL_CLIMATE], key[4] * key[7], key[5] * key[7], key[6], key[7]);
    glUniform3f(r->lit_loc[LL_SUN], key[0], key[1], key[2]);
    glUniform1f(r->lit_loc[LL_AMBIENT], key[3]);
    glActiveTexture(GL_TEXTURE0 + FX_UNIT_HEIGHTS);
    glBindTexture(GL_TEXTURE_BUFFER, r->height_tex);
    glActiveTexture(GL_TEXTURE0 + FX_UNIT_NORMALS);
    glBindTexture(GL_TEXTURE_2D, r->normal_tex);
    glActiveTexture(GL_TEXTURE0);
    glBindVertexArray(r->vao);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glBindTexture(GL_TEXTURE_2D, r->lit_tex);
    glGenerateMipmap(GL_TEXTURE_2D);
    glBindTexture(GL_TEXTURE_2D, 0);
    glUseProgram(0);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glEnable(GL_DEPTH_TEST);
    glFinish(); /* the frame times the bake */
    res = hz_gl_check(err, "lit map bake");
    if (res != HZ_OK) {
        litmap_release(r);
        return res;
    }
    memcpy(r->lit_key, key, sizeof r->lit_key);
    r->lit_valid = true;
    litmap_smooth(r, r->patch_cells);
    return HZ_OK;
}

double litmap_prepare(hz_renderer *r, const fx_frame *f, bool plain, bool *use)
{
    *use = false;
    if (!plain || f->sp.no_lit_map || !litmap_fits(r))
        return 0.0;
    float key[LIT_KEY_LEN];
    lighting_key(r, f, key);
    const bool held = r->lit_prev_set && memcmp(key, r->lit_prev, sizeof key) == 0;
    memcpy(r->lit_prev, key, sizeof key);
    r->lit_prev_set = true;
    if (r->lit_valid && memcmp(key, r->lit_key, sizeof key) == 0) {
        *use = true;
        if (r->patch_cells == r->lit_smooth_cells)
            return 0.0;
        /* the patches' size changed since the bake: their blocks again */
        const double t0 = hz_time_ms();
        litmap_smooth(r, r->patch_cells);
        return hz_time_ms() - t0;
    }
    /* The lighting changed since the last bake: bake once it holds still
     * (the first bake of a map at once). */
    if ((r->lit_valid && !held) || r->lit_failed)
        return 0.0;
    const double t0 = hz_time_ms();
    hz_err bake_err = {0};
    if (bake(r, key, &bake_err) != HZ_OK) {
        /* Not fatal: the terrain is shaded per pixel, as before the map. */
        hz_gl_drain();
        r->lit_failed = true;
        return 0.0;
    }
    *use = true;
    return hz_time_ms() - t0;
}

void litmap_invalidate(hz_renderer *r)
{
    litmap_release(r);
    r->lit_prev_set = r->lit_failed = false;
}

void litmap_release(hz_renderer *r)
{
    glDeleteFramebuffers(1, &r->lit_fbo);
    glDeleteTextures(1, &r->lit_tex);
    r->lit_fbo = r->lit_tex = 0;
    r->lit_valid = false;
    free(r->lit_smooth);
    r->lit_smooth = NULL;
    r->lit_smooth_cells = r->lit_smooth_n = 0;
}

void litmap_destroy(hz_renderer *r)
{
    litmap_release(r);
    glDeleteProgram(r->lit_prog);
    r->lit_prog = 0;
}
