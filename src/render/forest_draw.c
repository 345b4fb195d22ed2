/* Forest drawing: the models once on the GPU, per frame one index list of
 * every detailed tree's kept leaf prefixes (node by node) and one draw per
 * tree; bark by level; far trees as crown hulls. Drawn through the
 * renderer's object hook so fog and reflections apply. */
#include "horizon/forest_render.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "gl_util.h"
#include "hz_shaders.h"

typedef struct mesh_gpu {
    GLuint vao, vbo, ibo;
    uint32_t count;
} mesh_gpu;

typedef struct model_gpu {
    GLuint leaf_buf, leaf_tex;
    mesh_gpu bark, hull;
    uint32_t bark_level_end[HZ_TREE_MAX_LEVELS];
} model_gpu;

typedef struct prog_u {
    GLint leaves, scales, scale_base, model, viewproj, clip, crown, color, sun, sky, eye, fog, ambient, hull;
} prog_u;

struct hz_forest_gpu {
    model_gpu *m;
    uint32_t nm;
    GLuint leaf_prog, bark_prog;
    prog_u lu, bu;
    GLuint empty_vao;
    GLuint idx_buf;
    size_t idx_gpu_cap;
    GLuint scale_buf, scale_tex;
    size_t scale_gpu_cap;
    uint32_t *idx;          /* per-frame index list */
    size_t idx_cap;
    size_t *draw_off, *draw_cnt;
    uint32_t draw_cap;
    uint64_t built_serial;  /* frame serial the lists were built for */
    bool built;
};

static void get_u(GLuint p, prog_u *u)
{
    u->leaves = glGetUniformLocation(p, "u_leaves");
    u->scales = glGetUniformLocation(p, "u_scales");
    u->scale_base = glGetUniformLocation(p, "u_scale_base");
    u->model = glGetUniformLocation(p, "u_model");
    u->viewproj = glGetUniformLocation(p, "u_viewproj");
    u->clip = glGetUniformLocation(p, "u_clip_plane");
    u->crown = glGetUniformLocation(p, "u_crown");
    u->color = glGetUniformLocation(p, "u_color");
    u->sun = glGetUniformLocation(p, "u_sun_dir");
    u->sky = glGetUniformLocation(p, "u_sky_horizon");
    u->eye = glGetUniformLocation(p, "u_eye");
    u->fog = glGetUniformLocation(p, "u_fog_density");
    u->ambient = glGetUniformLocation(p, "u_ambient");
    u->hull = glGetUniformLocation(p, "u_hull");
}

static void mesh_upload(mesh_gpu *g, const hz_tree_mesh *m, uint32_t count)
{
    glGenVertexArrays(1, &g->vao);
    glGenBuffers(1, &g->vbo);
    glGenBuffers(1, &g->ibo);
    glBindVertexArray(g->vao);
    size_t nv = m->vertex_count;
    float *inter = malloc(nv * 6 * sizeof *inter + 16);
    if (inter) {
        for (size_t v = 0; v < nv; v++) {
            memcpy(inter + v * 6, m->pos + v * 3, 3 * sizeof(float));
            memcpy(inter + v * 6 + 3, m->nrm + v * 3, 3 * sizeof(float));
        }
    }
    glBindBuffer(GL_ARRAY_BUFFER, g->vbo);
    /* Empty meshes still get a (tiny, undefined) store so the VAO is valid. */
    glBufferData(GL_ARRAY_BUFFER, (GLsizeiptr)(nv ? nv * 24 : 16), nv ? inter : NULL, GL_STATIC_DRAW);
    free(inter);
    glEnableVertexAttribArray(0);
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 24, (const void *)0);
    glEnableVertexAttribArray(1);
    glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 24, (const void *)12);
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, g->ibo);
    glBufferData(GL_ELEMENT_ARRAY_BUFFER, (GLsizeiptr)(m->index_count ? (size_t)m->index_count * 4 : 16),
                 m->index_count ? m->idx : NULL, GL_STATIC_DRAW);
    glBindVertexArray(0);
    glBindBuffer(GL_ARRAY_BUFFER, 0);
    g->count = count;
}

static void mesh_free(mesh_gpu *g)
{
    glDeleteVertexArrays(1, &g->vao);
    glDeleteBuffers(1, &g->vbo);
    glDeleteBuffers(1, &g->ibo);
}

void hz_forest_gpu_destroy(hz_forest_gpu *g)
{
    if (!g)
        return;
    if (hz_gl_has_context()) {
        for (uint32_t k = 0; k < g->nm && g->m; k++) {
            glDeleteBuffers(1, &g->m[k].leaf_buf);
            glDeleteTextures(1, &g->m[k].leaf_tex);
            mesh_free(&g->m[k].bark);
            mesh_free(&g->m[k].hull);
        }
        glDeleteProgram(g->leaf_prog);
        glDeleteProgram(g->bark_prog);
        glDeleteVertexArrays(1, &g->empty_vao);
        glDeleteBuffers(1, &g->idx_buf);
        glDeleteBuffers(1, &g->scale_buf);
        glDeleteTextures(1, &g->scale_tex);
    }
    free(g->m);
    free(g->idx);
    free(g->draw_off);
    free(g->draw_cnt);
    free(g);
}

hz_forest_gpu *hz_forest_gpu_create(const hz_forest *f, hz_err *err)
{
    if (!hz_gl_has_context()) {
        hz_err_set(err, HZ_ERR_GL, "forest: no current OpenGL context");
        return NULL;
    }
    hz_forest_gpu *g = calloc(1, sizeof *g);
    if (!g) {
        hz_err_set(err, HZ_ERR_MEMORY, "out of memory");
        return NULL;
    }
    hz_gl_drain();
    g->nm = hz_forest_model_count(f);
    g->m = calloc(g->nm, sizeof *g->m);
    if (!g->m) {
        hz_err_set(err, HZ_ERR_MEMORY, "out of memory");
        goto fail;
    }
    g->leaf_prog = hz_gl_program(hz_shader_leaf_vs, hz_shader_leaf_fs, "leaf", err);
    if (!g->leaf_prog)
        goto fail;
    g->bark_prog = hz_gl_program(hz_shader_bark_vs, hz_shader_bark_fs, "bark", err);
    if (!g->bark_prog)
        goto fail;
    get_u(g->leaf_prog, &g->lu);
    get_u(g->bark_prog, &g->bu);
    glGenVertexArrays(1, &g->empty_vao);
    glGenBuffers(1, &g->idx_buf);
    glGenBuffers(1, &g->scale_buf);
    glGenTextures(1, &g->scale_tex);
    for (uint32_t k = 0; k < g->nm; k++) {
        const hz_tree *t = hz_forest_model(f, k);
        model_gpu *m = &g->m[k];
        float *d = malloc((size_t)t->leaf_count * 48 + 16);
        if (!d) {
            hz_err_set(err, HZ_ERR_MEMORY, "out of memory");
            goto fail;
        }
        for (uint32_t n = 0; n < t->node_count; n++)
            for (uint32_t l = t->nodes[n].first; l < t->nodes[n].first + t->nodes[n].count; l++) {
                float *o = d + (size_t)l * 12;
                const hz_tree_leaf *lf = &t->leaves[l];
                o[0] = lf->c[0], o[1] = lf->c[1], o[2] = lf->c[2], o[3] = (float)n;
                o[4] = lf->u[0], o[5] = lf->u[1], o[6] = lf->u[2], o[7] = 0;
                o[8] = lf->v[0], o[9] = lf->v[1], o[10] = lf->v[2], o[11] = 0;
            }
        glGenBuffers(1, &m->leaf_buf);
        glGenTextures(1, &m->leaf_tex);
        glBindBuffer(GL_TEXTURE_BUFFER, m->leaf_buf);
        glBufferData(GL_TEXTURE_BUFFER, (GLsizeiptr)((size_t)t->leaf_count * 48 + 16), d, GL_STATIC_DRAW);
        free(d);
        glBindTexture(GL_TEXTURE_BUFFER, m->leaf_tex);
        glTexBuffer(GL_TEXTURE_BUFFER, GL_RGBA32F, m->leaf_buf);
        glBindTexture(GL_TEXTURE_BUFFER, 0);
        glBindBuffer(GL_TEXTURE_BUFFER, 0);
        mesh_upload(&m->bark, &t->bark, t->bark.index_count);
        mesh_upload(&m->hull, &t->hull, t->hull.index_count);
        memcpy(m->bark_level_end, t->bark_level_end, sizeof m->bark_level_end);
    }
    if (hz_gl_check(err, "forest upload") != HZ_OK)
        goto fail;
    return g;
fail:
    hz_forest_gpu_destroy(g);
    return NULL;
}

/* The per-frame index list: 6 consecutive "vertex ids" per kept leaf. */
static hz_result build_lists(hz_forest_gpu *g, const hz_forest *f, const hz_forest_frame *fr, hz_err *err)
{
    if (g->draw_cap < fr->draw_count) {
        free(g->draw_off);
        free(g->draw_cnt);
        g->draw_off = malloc(fr->draw_count * sizeof *g->draw_off);
        g->draw_cnt = malloc(fr->draw_count * sizeof *g->draw_cnt);
        if (!g->draw_off || !g->draw_cnt) {
            g->draw_cap = 0;
            return hz_err_set(err, HZ_ERR_MEMORY, "forest: out of memory");
        }
        g->draw_cap = fr->draw_count;
    }
    /* Trees drawn in full need no list: one glDrawArrays over all leaves. */
    size_t need = 0;
    for (uint32_t d = 0; d < fr->draw_count; d++) {
        const hz_forest_draw *dr = &fr->draws[d];
        if (dr->hull)
            continue;
        const hz_tree *t = hz_forest_model(f, dr->model);
        size_t kept = 0;
        for (uint32_t n = 0; n < t->node_count; n++)
            kept += fr->counts[dr->node_base + n];
        if (kept < t->leaf_count)
            need += kept * 6;
    }
    if (need > g->idx_cap) {
        free(g->idx);
        g->idx_cap = need + need / 4 + 1024;
        g->idx = malloc(g->idx_cap * sizeof *g->idx);
        if (!g->idx) {
            g->idx_cap = 0;
            return hz_err_set(err, HZ_ERR_MEMORY, "forest: out of memory (%zu indices)", need);
        }
    }
    size_t at = 0;
    for (uint32_t d = 0; d < fr->draw_count; d++) {
        const hz_forest_draw *dr = &fr->draws[d];
        g->draw_off[d] = at;
        g->draw_cnt[d] = 0;
        if (dr->hull)
            continue;
        const hz_tree *t = hz_forest_model(f, dr->model);
        size_t kept = 0;
        for (uint32_t n = 0; n < t->node_count; n++)
            kept += fr->counts[dr->node_base + n];
        if (kept >= t->leaf_count) {
            g->draw_off[d] = SIZE_MAX; /* all leaves, no list */
            g->draw_cnt[d] = (size_t)t->leaf_count * 6;
            continue;
        }
        for (uint32_t n = 0; n < t->node_count; n++) {
            uint32_t c = fr->counts[dr->node_base + n];
            uint32_t v = t->nodes[n].first * 6;
            uint32_t *o = g->idx + at;
            for (uint32_t k = 0; k < c * 6; k++)
                o[k] = v + k;
            at += (size_t)c * 6;
        }
        g->draw_cnt[d] = at - g->draw_off[d];
    }
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, g->idx_buf);
    size_t bytes = at * 4;
    if (bytes > g->idx_gpu_cap)
        g->idx_gpu_cap = bytes + bytes / 4 + 4096;
    glBufferData(GL_ELEMENT_ARRAY_BUFFER, (GLsizeiptr)g->idx_gpu_cap, NULL, GL_STREAM_DRAW);
    if (bytes)
        glBufferSubData(GL_ELEMENT_ARRAY_BUFFER, 0, (GLsizeiptr)bytes, g->idx);
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, 0);
    glBindBuffer(GL_TEXTURE_BUFFER, g->scale_buf);
    size_t sb = (size_t)fr->node_total * 4 + 16;
    if (sb > g->scale_gpu_cap)
        g->scale_gpu_cap = sb + sb / 4;
    glBufferData(GL_TEXTURE_BUFFER, (GLsizeiptr)g->scale_gpu_cap, NULL, GL_STREAM_DRAW);
    if (fr->node_total)
        glBufferSubData(GL_TEXTURE_BUFFER, 0, (GLsizeiptr)((size_t)fr->node_total * 4), fr->scales);
    glBindTexture(GL_TEXTURE_BUFFER, g->scale_tex);
    glTexBuffer(GL_TEXTURE_BUFFER, GL_R32F, g->scale_buf);
    glBindTexture(GL_TEXTURE_BUFFER, 0);
    glBindBuffer(GL_TEXTURE_BUFFER, 0);
    g->built = true;
    g->built_serial = fr->serial;
    return hz_gl_check(err, "forest per-frame upload");
}

static void common_uniforms(const prog_u *u, const hz_pass_info *pass)
{
    glUniformMatrix4fv(u->viewproj, 1, GL_FALSE, (const float *)pass->viewproj);
    bool clip = pass->clip_plane[0] != 0 || pass->clip_plane[1] != 0 || pass->clip_plane[2] != 0 ||
                pass->clip_plane[3] != 0;
    const float none[4] = {0, 0, 0, 1};
    glUniform4fv(u->clip, 1, clip ? pass->clip_plane : none);
    glUniform3fv(u->sun, 1, pass->sun_dir);
    glUniform3fv(u->sky, 1, pass->sky_color);
    glUniform3fv(u->eye, 1, pass->cam->pos);
    glUniform1f(u->fog, pass->fog_density);
    glUniform1f(u->ambient, pass->ambient);
}

hz_result hz_forest_gpu_draw(hz_forest_gpu *g, const hz_forest *f, const hz_forest_frame *fr,
                             const hz_pass_info *pass, hz_err *err)
{
    if (!hz_gl_has_context())
        return hz_err_set(err, HZ_ERR_GL, "forest: draw without a current OpenGL context");
    hz_gl_drain();
    if (!g->built || g->built_serial != fr->serial) {
        hz_result r = build_lists(g, f, fr, err);
        if (r != HZ_OK)
            return r;
    }
    bool clip = pass->clip_plane[0] != 0 || pass->clip_plane[1] != 0 || pass->clip_plane[2] != 0 ||
                pass->clip_plane[3] != 0;
    if (clip)
        glEnable(GL_CLIP_DISTANCE0);
    glEnable(GL_DEPTH_TEST);
    glDepthMask(GL_TRUE);
    glDisable(GL_BLEND);
    float model[16];

    /* Leaves: two-sided. */
    glDisable(GL_CULL_FACE);
    glUseProgram(g->leaf_prog);
    common_uniforms(&g->lu, pass);
    glBindVertexArray(g->empty_vao);
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, g->idx_buf);
    glActiveTexture(GL_TEXTURE1);
    glBindTexture(GL_TEXTURE_BUFFER, g->scale_tex);
    glUniform1i(g->lu.scales, 1);
    glUniform1i(g->lu.leaves, 0);
    glActiveTexture(GL_TEXTURE0);
    uint32_t bound_model = UINT32_MAX;
    for (uint32_t d = 0; d < fr->draw_count; d++) {
        const hz_forest_draw *dr = &fr->draws[d];
        if (dr->hull || g->draw_cnt[d] == 0)
            continue;
        const hz_tree *t = hz_forest_model(f, dr->model);
        if (bound_model != dr->model) {
            glBindTexture(GL_TEXTURE_BUFFER, g->m[dr->model].leaf_tex);
            glUniform3fv(g->lu.color, 1, t->leaf_color);
            glUniform4f(g->lu.crown, t->crown_center[0], t->crown_center[1], t->crown_center[2], t->crown_radius);
            bound_model = dr->model;
        }
        hz_forest_tree_matrix(f, dr->tree, model);
        glUniformMatrix4fv(g->lu.model, 1, GL_FALSE, model);
        glUniform1i(g->lu.scale_base, (GLint)dr->node_base);
        if (g->draw_off[d] == SIZE_MAX)
            glDrawArrays(GL_TRIANGLES, 0, (GLsizei)g->draw_cnt[d]);
        else
            glDrawElements(GL_TRIANGLES, (GLsizei)g->draw_cnt[d], GL_UNSIGNED_INT,
                           (const void *)(g->draw_off[d] * sizeof(uint32_t)));
    }
    glBindTexture(GL_TEXTURE_BUFFER, 0);
    glActiveTexture(GL_TEXTURE1);
    glBindTexture(GL_TEXTURE_BUFFER, 0);
    glActiveTexture(GL_TEXTURE0);

    /* Bark and hulls: closed outward-facing meshes (bark tubes are open at
     * the ends, which only shows at the tips of twigs). */
    glEnable(GL_CULL_FACE);
    glCullFace(GL_BACK);
    glFrontFace(GL_CCW);
    glUseProgram(g->bark_prog);
    common_uniforms(&g->bu, pass);
    for (int hull = 0; hull < 2; hull++) {
        glUniform1i(g->bu.hull, hull);
        for (uint32_t d = 0; d < fr->draw_count; d++) {
            const hz_forest_draw *dr = &fr->draws[d];
            if (hull && !dr->hull)
                continue;
            const hz_tree *t = hz_forest_model(f, dr->model);
            const model_gpu *m = &g->m[dr->model];
            const mesh_gpu *mesh = hull ? &m->hull : &m->bark;
            uint32_t count = hull ? mesh->count : m->bark_level_end[(dr->bark_levels ? dr->bark_levels : 1) - 1];
            if (!count)
                continue;
            hz_forest_tree_matrix(f, dr->tree, model);
            glUniformMatrix4fv(g->bu.model, 1, GL_FALSE, model);
            glUniform3fv(g->bu.color, 1, hull ? t->leaf_color : t->bark_color);
            glBindVertexArray(mesh->vao);
            glDrawElements(GL_TRIANGLES, (GLsizei)count, GL_UNSIGNED_INT, (const void *)0);
        }
    }
    glBindVertexArray(0);
    glUseProgram(0);
    glDisable(GL_CULL_FACE);
    if (clip)
        glDisable(GL_CLIP_DISTANCE0);
    return hz_gl_check(err, "forest draw");
}

void hz_forest_draw_hook(void *user, const hz_pass_info *pass)
{
    hz_forest_hook *h = user;
    if (!h || !h->gpu || !h->forest || !h->frame || h->failed)
        return;
    double t0 = 0;
    if (pass->pass == HZ_PASS_MAIN) {
        glFinish();
        t0 = hz_time_ms();
    }
    if (hz_forest_gpu_draw(h->gpu, h->forest, h->frame, pass, &h->err) != HZ_OK)
        h->failed = true;
    if (pass->pass == HZ_PASS_MAIN) {
        glFinish();
        h->draw_ms = hz_time_ms() - t0;
    }
}
