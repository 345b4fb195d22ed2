/* Water planes (R9): planar reflections, transparency by depth, animated
 * normals, drawn grouped by material.
 *
 * Reflection: for each distinct visible water height the scene (sky, terrain,
 * tree billboards, the object hook) is rendered at half resolution with the
 * view matrix V * M, M the mirror at y = h, front faces flipped, and
 * everything below the plane discarded (fx_clip in the shaders,
 * GL_CLIP_DISTANCE0 for hook objects). A water fragment then samples that
 * texture at its own screen position, displaced by its wave normal. The
 * pass is scissored to where its water can show: the screen rectangle of
 * the map blocks whose lowest ground is below the plane (and of the open sea
 * beyond the map), widened by that displacement; with none in view there is
 * no pass.
 *
 * Terrain for the mirrored camera comes from the caller
 * (hz_scene_params.reflection_indices, an LOD selection for
 * hz_camera_mirror_y) or, without one, the main selection. */
#include "render_internal.h"

#include "gl_util.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "hz_shaders.h"

/* Cells per side of a water plane drawn with Earth curvature (fx_water_vs.glsl):
 * quadratic spacing keeps each flat cell within ~1e-4 rad of the sphere. */
enum { WATER_GRID = 64 };

hz_result fx_water_ensure(hz_renderer *r, const fx_frame *f, hz_err *err)
{
    static const char *const names[] = {"u_rect",    "u_level",   "u_viewproj", "u_has_reflection", "u_viewport",
                                        "u_size",    "u_spacing", "u_hscale",   "u_hoffset",        "u_deep",
                                        "u_clarity", "u_waves",   "u_reflectivity", "u_grid", "u_has_valid", "u_sea",
                                        "u_coast_rect", "u_coast_spacing", NULL};
    r->water_cur = prog_cache_get(&r->water, f->bits & (HZ_FX_SKY | HZ_FX_FOG), hz_shader_fx_water_vs,
                                  hz_shader_fx_water_fs, "fx_water", 3, names, err);
    return r->water_cur ? HZ_OK : HZ_ERR_GL;
}

hz_result hz_renderer_set_water(hz_renderer *r, const hz_water_plane *planes, uint32_t count,
                                const hz_water_material *materials, uint32_t material_count, hz_err *err)
{
    HZ_ASSERT(r);
    if (count && !planes)
        return hz_err_set(err, HZ_ERR_VALUE, "renderer: %u water planes but no array", count);
    if (material_count && !materials)
        return hz_err_set(err, HZ_ERR_VALUE, "renderer: %u water materials but no array", material_count);
    for (uint32_t k = 0; k < count; k++) {
        const hz_water_plane *p = &planes[k];
        bool whole = p->rect[0] == 0 && p->rect[1] == 0 && p->rect[2] == 0 && p->rect[3] == 0;
        bool finite = isfinite(p->height) && isfinite(p->rect[0]) && isfinite(p->rect[1]) && isfinite(p->rect[2]) &&
                      isfinite(p->rect[3]);
        if (!finite || (!whole && (p->rect[2] <= p->rect[0] || p->rect[3] <= p->rect[1])))
            return hz_err_set(err, HZ_ERR_VALUE, "renderer: water plane %u: height %g, rect (%g, %g)-(%g, %g) is not "
                              "a finite, non-empty rectangle", k, (double)p->height, (double)p->rect[0],
                              (double)p->rect[1], (double)p->rect[2], (double)p->rect[3]);
        if (p->material >= (material_count ? material_count : 1))
            return hz_err_set(err, HZ_ERR_VALUE, "renderer: water plane %u uses material %u of %u", k, p->material,
                              material_count);
    }
    for (uint32_t k = 0; k < material_count; k++) {
        const hz_water_material *m = &materials[k];
        if (!isfinite(m->clarity) || m->clarity < 0 || !isfinite(m->waves) || m->waves < 0 ||
            !isfinite(m->reflectivity) || m->reflectivity < 0 || !isfinite(m->deep[0]) || !isfinite(m->deep[1]) ||
            !isfinite(m->deep[2]))
            return hz_err_set(err, HZ_ERR_VALUE, "renderer: water material %u has a negative or non-finite value", k);
    }
    hz_water_plane *np = NULL;
    hz_water_material *nm = NULL;
    if (count && !(np = malloc(count * sizeof *np)))
        return hz_err_set(err, HZ_ERR_MEMORY, "renderer: out of memory");
    uint32_t nmats = material_count ? material_count : 1;
    if (!(nm = calloc(nmats, sizeof *nm))) {
        free(np);
        return hz_err_set(err, HZ_ERR_MEMORY, "renderer: out of memory");
    }
    if (count)
        memcpy(np, planes, count * sizeof *np);
    if (material_count)
        memcpy(nm, materials, material_count * sizeof *nm);
    for (uint32_t k = 0; k < nmats; k++) {
        hz_water_material *m = &nm[k];
        if (m->deep[0] == 0 && m->deep[1] == 0 && m->deep[2] == 0) {
            m->deep[0] = 0.04f;
            m->deep[1] = 0.12f;
            m->deep[2] = 0.16f;
        }
        if (m->clarity == 0)
            m->clarity = 2.5f;
        if (m->waves == 0)
            m->waves = 1.0f;
        if (m->reflectivity == 0)
            m->reflectivity = 1.0f;
    }
    free(r->planes);
    free(r->mats);
    r->planes = np;
    r->mats = nm;
    r->n_planes = count;
    r->n_mats = nmats;
    return HZ_OK;
}

/* The plane's rectangle, the open sea (all zero) being the map plus the view
 * distance around it. */
static void plane_rect(const hz_renderer *r, const hz_water_plane *p, float zfar, float out[4])
{
    if (p->rect[0] == 0 && p->rect[1] == 0 && p->rect[2] == 0 && p->rect[3] == 0) {
        float ext = r->has_heights || r->streamed ? (float)(r->size - 1) * r->spacing : 0.0f;
        out[0] = -zfar, out[1] = -zfar, out[2] = ext + zfar, out[3] = ext + zfar;
    } else {
        memcpy(out, p->rect, 4 * sizeof(float));
    }
}

/* The rectangle at height y as cam draws it (lowered by the Earth curvature). */
static bool rect_visible(const vec4 planes[6], const hz_camera *cam, const float rc[4], float y)
{
    float box[2][3] = {{rc[0], y, rc[1]}, {rc[2], y, rc[3]}};
    hz_camera_curve_box(cam, box);
    for (int p = 0; p < 6; p++) {
        float best = planes[p][3] + planes[p][1] * box[planes[p][1] >= 0][1];
        best += planes[p][0] * (planes[p][0] >= 0 ? rc[2] : rc[0]);
        best += planes[p][2] * (planes[p][2] >= 0 ? rc[3] : rc[1]);
        if (best < 0)
            return false;
    }
    return true;
}

/* Widens acc (NDC x0, y0, x1, y1) by the part of the rectangle rc at height
 * y that v sees: the box's corners in front of the eye and, on each edge
 * crossing the near side (w = 1e-3), the crossing point. */
static void rect_ndc(const vec4 planes[6], const fx_view *v, const float rc[4], float y, float acc[4])
{
    if (rc[0] >= rc[2] || rc[1] >= rc[3] || !rect_visible(planes, &v->cam, rc, y))
        return;
    float box[2][3] = {{rc[0], y, rc[1]}, {rc[2], y, rc[3]}};
    hz_camera_curve_box(&v->cam, box);
    vec4 q[8];
    for (int c = 0; c < 8; c++) {
        vec4 p = {box[c & 1][0], box[(c >> 1) & 1][1], box[c >> 2][2], 1.0f};
        glm_mat4_mulv((vec4 *)v->viewproj, p, q[c]);
    }
    const float eps = 1e-3f;
    vec4 pts[8 + 12];
    int n = 0;
    for (int c = 0; c < 8; c++)
        if (q[c][3] > eps)
            glm_vec4_copy(q[c], pts[n++]);
    for (int c = 0; c < 8; c++)
        for (int bit = 1; bit < 8; bit <<= 1) {
            const int d = c | bit; /* each of the 12 edges once: c has the bit clear */
            if (d == c || (q[c][3] > eps) == (q[d][3] > eps))
                continue;
            const float t = (eps - q[c][3]) / (q[d][3] - q[c][3]);
            glm_vec4_lerp(q[c], q[d], t, pts[n]);
            pts[n++][3] = eps;
        }
    for (int k = 0; k < n; k++) {
        const float x = pts[k][0] / pts[k][3], yy = pts[k][1] / pts[k][3];
        acc[0] = fminf(acc[0], x), acc[1] = fminf(acc[1], yy);
        acc[2] = fmaxf(acc[2], x), acc[3] = fmaxf(acc[3], yy);
    }
}

/* Where plane p's water can show on v's screen (NDC x0, y0, x1, y1): the
 * parts of its rectangle over blocks of the map whose lowest sample is
 * below it, and beyond the map's edge (the open sea), widened by the
 * reflection's wave displacement. False when none is in view. Without the
 * block grid (a streamed pyramid) the whole screen. */
static bool plane_screen_rect(const hz_renderer *r, const vec4 planes[6], const fx_view *v, const float rc[4],
                              float h, float out[4])
{
    if (!r->wet_min || r->streamed) {
        out[0] = out[1] = -1.0f, out[2] = out[3] = 1.0f;
        return true;
    }
    float acc[4] = {INFINITY, INFINITY, -INFINITY, -INFINITY};
    const float ext = (float)(r->size - 1) * r->spacing, bm = (float)r->wet_block * r->spacing;
    for (uint32_t bj = 0; bj < r->wet_n; bj++)
        for (uint32_t bi = 0; bi < r->wet_n; bi++) {
            if (!(r->wet_min[(size_t)bj * r->wet_n + bi] < h))
                continue;
            const float b[4] = {fmaxf(rc[0], (float)bi * bm), fmaxf(rc[1], (float)bj * bm),
                                fminf(rc[2], fminf(ext, (float)(bi + 1) * bm)),
                                fminf(rc[3], fminf(ext, (float)(bj + 1) * bm))};
            rect_ndc(planes, v, b, h, acc);
        }
    /* Beyond the map: west and east strips, then north and south between them. */
    const float strips[4][4] = {{rc[0], rc[1], fminf(rc[2], 0.0f), rc[3]},
                                {fmaxf(rc[0], ext), rc[1], rc[2], rc[3]},
                                {fmaxf(rc[0], 0.0f), rc[1], fminf(rc[2], ext), fminf(rc[3], 0.0f)},
                                {fmaxf(rc[0], 0.0f), fmaxf(rc[1], ext), fminf(rc[2], ext), rc[3]}};
    for (int k = 0; k < 4; k++)
        rect_ndc(planes, v, strips[k], h, acc);
    /* A water fragment samples its reflection up to 0.05 of the viewport
     * away (fx_water_fs.glsl: n.xz * 0.05): 0.1 in NDC. */
    const float m = 0.1f + 4.0f / (float)(v->w ? v->w : 1);
    out[0] = fmaxf(-1.0f, acc[0] - m), out[1] = fmaxf(-1.0f, acc[1] - m);
    out[2] = fminf(1.0f, acc[2] + m), out[3] = fminf(1.0f, acc[3] + m);
    return out[0] < out[2] && out[1] < out[3];
}

/* Whether v (its frustum: planes) sees a plane's rectangle rc at height h. */
static bool plane_visible(const vec4 planes[6], const fx_view *v, const float rc[4], float h)
{
    if (v->eye[1] <= h + 0.01f)
        return false; /* from below the surface we do not draw it */
    return rect_visible(planes, &v->cam, rc, h);
}

uint32_t fx_water_visible(const hz_renderer *r, const fx_frame *f, const fx_view *v, float *levels,
                          float (*rects)[4])
{
    uint32_t n = 0;
    vec4 planes[6];
    hz_camera_frustum(&v->cam, planes);
    for (uint32_t k = 0; k < r->n_planes; k++) {
        const hz_water_plane *p = &r->planes[k];
        float rc[4], sr[4];
        plane_rect(r, p, f->zfar, rc);
        if (!plane_visible((const vec4 *)planes, v, rc, p->height) ||
            !plane_screen_rect(r, (const vec4 *)planes, v, rc, p->height, sr))
            continue;
        int at = -1;
        for (uint32_t i = 0; i < n; i++)
            if (fabsf(levels[i] - p->height) < 0.01f)
                at = (int)i;
        if (at < 0 && n < FX_MAX_REFLECTIONS) {
            at = (int)n++;
            levels[at] = p->height;
            rects[at][0] = rects[at][1] = INFINITY, rects[at][2] = rects[at][3] = -INFINITY;
        } else if (at < 0) {
            /* Keep the nearest heights to the eye. */
            uint32_t far_i = 0;
            for (uint32_t i = 1; i < n; i++)
                if (fabsf(v->eye[1] - levels[i]) > fabsf(v->eye[1] - levels[far_i]))
                    far_i = i;
            if (!(fabsf(v->eye[1] - p->height) < fabsf(v->eye[1] - levels[far_i])))
                continue;
            at = (int)far_i;
            levels[at] = p->height;
            rects[at][0] = rects[at][1] = INFINITY, rects[at][2] = rects[at][3] = -INFINITY;
        }
        rects[at][0] = fminf(rects[at][0], sr[0]), rects[at][1] = fminf(rects[at][1], sr[1]);
        rects[at][2] = fmaxf(rects[at][2], sr[2]), rects[at][3] = fmaxf(rects[at][3], sr[3]);
    }
    /* Nearest first. */
    for (uint32_t i = 1; i < n; i++)
        for (uint32_t j = i; j > 0 && fabsf(v->eye[1] - levels[j]) < fabsf(v->eye[1] - levels[j - 1]); j--) {
            float t = levels[j];
            levels[j] = levels[j - 1];
            levels[j - 1] = t;
            float tr[4];
            memcpy(tr, rects[j], sizeof tr);
            memcpy(rects[j], rects[j - 1], sizeof tr);
            memcpy(rects[j - 1], tr, sizeof tr);
        }
    return n;
}

void fx_water_mirror_view(const fx_view *main, float level, fx_view *out)
{
    *out = *main;
    out->pass = HZ_PASS_REFLECTION;
    out->water_level = level;
    mat4 m;
    glm_mat4_identity(m);
    m[1][1] = -1.0f;
    m[3][1] = 2.0f * level;
    glm_mat4_mul((vec4 *)main->view, m, out->view);
    mat4 view_rot, vp_rot;
    glm_mat4_mul(out->proj, out->view, out->viewproj);
    glm_mat4_copy(out->view, view_rot);
    view_rot[3][0] = view_rot[3][1] = view_rot[3][2] = 0.0f;
    glm_mat4_mul(out->proj, view_rot, vp_rot);
    glm_mat4_inv(vp_rot, out->inv_vp_rot);
    out->eye[1] = 2.0f * level - main->eye[1];
    hz_camera_mirror_y(&main->cam, level, &out->cam);
    out->clip[0] = 0.0f, out->clip[1] = 1.0f, out->clip[2] = 0.0f, out->clip[3] = -level;
}

static hz_result ensure_targets(hz_renderer *r, uint32_t n, hz_err *err)
{
    uint32_t w = r->width / 2 ? r->width / 2 : 1, h = r->height / 2 ? r->height / 2 : 1;
    if (r->refl_w != w || r->refl_h != h) {
        glDeleteFramebuffers(FX_MAX_REFLECTIONS, r->refl_fbo);
        glDeleteTextures(FX_MAX_REFLECTIONS, r->refl_tex);
        glDeleteRenderbuffers(FX_MAX_REFLECTIONS, r->refl_depth);
        memset(r->refl_fbo, 0, sizeof r->refl_fbo);
        memset(r->refl_tex, 0, sizeof r->refl_tex);
        memset(r->refl_depth, 0, sizeof r->refl_depth);
        r->refl_w = w, r->refl_h = h;
    }
    for (uint32_t k = 0; k < n; k++) {
        if (r->refl_fbo[k])
            continue;
        glGenRenderbuffers(1, &r->refl_depth[k]);
        glBindRenderbuffer(GL_RENDERBUFFER, r->refl_depth[k]);
        glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT32F, (GLsizei)w, (GLsizei)h);
        glBindRenderbuffer(GL_RENDERBUFFER, 0);
        hz_result res = fx_make_target(&r->refl_fbo[k], &r->refl_tex[k], r->refl_depth[k], w, h, GL_RGBA8, err);
        if (res != HZ_OK)
            return res;
    }
    return HZ_OK;
}

hz_result fx_water_reflections(hz_renderer *r, const fx_frame *f, const fx_view *main, fx_scene_fn draw_scene,
                               hz_err *err)
{
    hz_result res = ensure_targets(r, r->n_refl, err);
    if (res != HZ_OK)
        return res;
    for (uint32_t k = 0; k < r->n_refl; k++) {
        fx_view mv;
        fx_water_mirror_view(main, r->refl_level[k], &mv);
        mv.w = r->refl_w;
        mv.h = r->refl_h;
        glBindFramebuffer(GL_FRAMEBUFFER, r->refl_fbo[k]);
        glViewport(0, 0, (GLsizei)mv.w, (GLsizei)mv.h);
        glDepthMask(GL_TRUE);
        glClearColor(f->sp.sky_color[0], f->sp.sky_color[1], f->sp.sky_color[2], 1.0f);
        glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
        /* Only where this level's water can show (and sample): the rest of
         * the mirror image stays sky-coloured, never read. */
        const float *sr = r->refl_rect[k];
        const GLint x0 = (GLint)floorf((sr[0] * 0.5f + 0.5f) * (float)mv.w);
        const GLint y0 = (GLint)floorf((sr[1] * 0.5f + 0.5f) * (float)mv.h);
        const GLint x1 = (GLint)ceilf((sr[2] * 0.5f + 0.5f) * (float)mv.w);
        const GLint y1 = (GLint)ceilf((sr[3] * 0.5f + 0.5f) * (float)mv.h);
        glEnable(GL_SCISSOR_TEST);
        glScissor(x0, y0, x1 - x0, y1 - y0);
        draw_scene(r, f, &mv, f->refl_ibo, f->refl_count);
        if (k == 0 && (f->bits & HZ_FX_BILLBOARDS))
            fx_trees_draw(r, f, &mv); /* culled for the nearest plane's mirror */
        glDisable(GL_SCISSOR_TEST);
    }
    return hz_gl_check(err, "water reflection pass");
}

void fx_water_draw(hz_renderer *r, const fx_frame *f, const fx_view *v)
{
    const GLint *u = r->water_cur->loc;
    glUseProgram(r->water_cur->prog);
    glUniformMatrix4fv(u[WL_VIEWPROJ], 1, GL_FALSE, (const float *)v->viewproj);
    hz_gl_set_curvature(r->water_cur->prog, &v->cam);
    glUniform2f(u[WL_VIEWPORT], (float)v->w, (float)v->h);
    /* Without the heights (a streamed pyramid) every ground is deep: 0 samples. */
    glUniform1i(u[WL_SIZE], r->has_heights ? (GLint)r->size : 0);
    glUniform1f(u[WL_SPACING], r->spacing);
    glUniform1f(u[WL_HSCALE], r->hscale);
    glUniform1f(u[WL_HOFFSET], r->hoffset);
    glActiveTexture(GL_TEXTURE0 + FX_UNIT_HEIGHTS);
    glBindTexture(GL_TEXTURE_BUFFER, r->height_tex);
    glActiveTexture(GL_TEXTURE0 + FX_UNIT_VALID);
    glBindTexture(GL_TEXTURE_BUFFER, r->has_valid ? r->valid_tex : 0);
    glUniform1i(u[WL_HAS_VALID], r->has_valid);
    glActiveTexture(GL_TEXTURE0 + FX_UNIT_COAST);
    glBindTexture(GL_TEXTURE_BUFFER, r->coast_rect[2] >= r->coast_rect[0] ? r->coast_tex : 0);
    glUniform4i(u[WL_COAST_RECT], r->coast_rect[0], r->coast_rect[1], r->coast_rect[2], r->coast_rect[3]);
    glUniform1f(u[WL_COAST_SPACING], r->coast_spacing);
    glActiveTexture(GL_TEXTURE0 + FX_UNIT_REFLECTION);
    glEnable(GL_BLEND);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_GREATER);
    const bool mask = f->water_mask > -1e29f;
    if (mask)
        /* A sea (deep: alpha 0): where the ground stands above it (alpha 1)
         * the ground, elsewhere the sea. The depth test only saves the
         * shading of what ground in front of the plane hides: the plane is
         * lifted over the curved surface (fx_water_vs.glsl), so it never
         * rejects the sea itself; nor does it write depth. */
        glBlendFuncSeparate(GL_ONE_MINUS_DST_ALPHA, GL_DST_ALPHA, GL_ZERO, GL_ONE);
    else
        glBlendFunc(GL_ONE, GL_SRC_ALPHA); /* src + alpha x (terrain below) */
    glDepthMask(mask ? GL_FALSE : GL_TRUE);
    glDisable(GL_CULL_FACE);
    vec4 planes[6];
    hz_camera_frustum(&v->cam, planes);
    /* Grouped by material: its uniforms once, then its planes. */
    for (uint32_t m = 0; m < r->n_mats; m++) {
        const hz_water_material *mat = &r->mats[m];
        bool any = false;
        for (uint32_t k = 0; k < r->n_planes; k++) {
            const hz_water_plane *p = &r->planes[k];
            float rc[4];
            plane_rect(r, p, f->zfar, rc);
            if (p->material != m || !plane_visible((const vec4 *)planes, v, rc, p->height))
                continue;
            if (!any) {
                glUniform3fv(u[WL_DEEP], 1, mat->deep);
                glUniform1f(u[WL_CLARITY], mat->clarity);
                glUniform1f(u[WL_WAVES], mat->waves);
                glUniform1f(u[WL_REFLECTIVITY], mat->reflectivity);
                any = true;
            }
            /* The reflection rendered for the nearest height. */
            int best = -1;
            for (uint32_t i = 0; i < r->n_refl; i++)
                if (best < 0 || fabsf(r->refl_level[i] - p->height) < fabsf(r->refl_level[best] - p->height))
                    best = (int)i;
            glBindTexture(GL_TEXTURE_2D, best >= 0 ? r->refl_tex[best] : 0);
            glUniform1i(u[WL_HAS_REFLECTION], best >= 0);
            glUniform4fv(u[WL_RECT], 1, rc);
            glUniform1f(u[WL_LEVEL], p->height);
            glUniform1i(u[WL_SEA], p->sea);
            if (v->cam.earth_radius != 0.0f) {
                /* Earth curvature: the plane as a grid that can bend (a quad's
                 * four corners dropped 100 km would sink its middle too). */
                glUniform1i(u[WL_GRID], WATER_GRID);
                glDrawArrays(GL_TRIANGLES, 0, 6 * WATER_GRID * WATER_GRID);
            } else {
                glUniform1i(u[WL_GRID], 0);
                glDrawArrays(GL_TRIANGLE_STRIP, 0, 4);
            }
        }
    }
    glBindTexture(GL_TEXTURE_2D, 0);
    glActiveTexture(GL_TEXTURE0 + FX_UNIT_HEIGHTS);
    glBindTexture(GL_TEXTURE_BUFFER, 0);
    glActiveTexture(GL_TEXTURE0);
    glDisable(GL_BLEND);
    glEnable(GL_DEPTH_TEST);
    glDepthMask(GL_TRUE);
}

void fx_water_destroy(hz_renderer *r)
{
    prog_cache_clear(&r->water);
    r->water_cur = NULL;
    glDeleteFramebuffers(FX_MAX_REFLECTIONS, r->refl_fbo);
    glDeleteTextures(FX_MAX_REFLECTIONS, r->refl_tex);
    glDeleteRenderbuffers(FX_MAX_REFLECTIONS, r->refl_depth);
    memset(r->refl_fbo, 0, sizeof r->refl_fbo);
    memset(r->refl_tex, 0, sizeof r->refl_tex);
    memset(r->refl_depth, 0, sizeof r->refl_depth);
    r->refl_w = r->refl_h = 0;
    free(r->planes);
    free(r->mats);
    r->planes = NULL;
    r->mats = NULL;
    r->n_planes = r->n_mats = 0;
}
