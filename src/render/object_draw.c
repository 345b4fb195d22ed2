/* Scene objects (G3-G5): the scene graph's merged meshes in one static
 * vertex + index buffer; per frame the CPU culls (hz_scene_cull, and the
 * caller's occlusion buffer), builds the render queue
 * (hz_scene_queue_build_instanced) and uploads one world matrix and
 * material colour per drawn node into a per-instance buffer in queue order;
 * then one glMultiDrawElementsIndirect per shader (each command one mesh
 * with its run of instances, baseInstance selecting their data). The naive
 * mode draws one object per call, in scene order, for the comparison. */
#include "horizon/scene_render.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gl_util.h"
#include "hz_shaders.h"

typedef struct draw_cmd {
    GLuint count, instance_count, first_index;
    GLint base_vertex;
    GLuint base_instance;
} draw_cmd;

/* Instance data: a world matrix (16 floats), the material's colour (3). */
enum { INST_FLOATS = 19, INST_BYTES = INST_FLOATS * 4 };

/* The object program's variants (object_fs.glsl): the paths a pass needs. */
enum { OBJ_SUN_HEIGHTS = 1, OBJ_HEIGHT_FOG = 2, OBJ_FAR_FADE = 4, OBJ_VARIANTS = 8 };

typedef struct obj_prog {
    GLuint prog;
    GLint u_viewproj, u_clip, u_sun, u_sky, u_eye, u_fog, u_ambient, u_fog_far;
    GLint u_sunh_tex, u_sunh_map, u_sunh, u_sun_h, u_height_fog, u_zenith;
} obj_prog;

struct hz_scene_gpu {
    obj_prog var[OBJ_VARIANTS]; /* compiled on first use */
    GLuint vao, vbo, ibo, inst_buf, cmd_buf;
    GLuint box_prog, box_vao, box_vbo, box_ibo;  /* occlusion query proxies */
    GLint ub_viewproj, ub_min, ub_max;
    GLuint *queries;
    uint32_t query_cap;
    size_t inst_cap, cmd_cap;  /* bytes */
    uint32_t mesh_count;
    /* CPU scratch */
    uint32_t *vis, *order, *sort_tmp; /* sort_tmp: 3 per node */
    hz_draw_item *items;
    float *mats;
    draw_cmd *cmds;
    uint32_t scratch_cap;
};

void hz_scene_gpu_destroy(hz_scene_gpu *g)
{
    if (!g)
        return;
    if (hz_gl_has_context()) {
        for (int k = 0; k < OBJ_VARIANTS; k++)
            glDeleteProgram(g->var[k].prog);
        glDeleteVertexArrays(1, &g->vao);
        GLuint b[6] = {g->vbo, g->ibo, g->inst_buf, g->cmd_buf, g->box_vbo, g->box_ibo};
        glDeleteBuffers(6, b);
        glDeleteProgram(g->box_prog);
        glDeleteVertexArrays(1, &g->box_vao);
        if (g->query_cap)
            glDeleteQueries((GLsizei)g->query_cap, g->queries);
    }
    free(g->vis);
    free(g->order);
    free(g->sort_tmp);
    free(g->items);
    free(g->mats);
    free(g->cmds);
    free(g->queries);
    free(g);
}

/* The program variant with the paths of key (OBJ_*), compiled on first
 * use; NULL + err if it does not compile. */
static const obj_prog *obj_program(hz_scene_gpu *g, unsigned key, hz_err *err)
{
    obj_prog *v = &g->var[key];
    if (v->prog)
        return v;
    char defs[128];
    snprintf(defs, sizeof defs, "#define OBJ_SUN_HEIGHTS %d\n#define OBJ_HEIGHT_FOG %d\n#define OBJ_FAR_FADE %d\n",
             (key & OBJ_SUN_HEIGHTS) != 0, (key & OBJ_HEIGHT_FOG) != 0, (key & OBJ_FAR_FADE) != 0);
    const GLuint p = hz_gl_program_defs(hz_shader_object_vs, hz_shader_object_fs, defs, "object", err);
    if (!p)
        return NULL;
    v->prog = p;
    v->u_viewproj = glGetUniformLocation(p, "u_viewproj");
    v->u_clip = glGetUniformLocation(p, "u_clip_plane");
    v->u_sun = glGetUniformLocation(p, "u_sun_dir");
    v->u_sky = glGetUniformLocation(p, "u_sky_horizon");
    v->u_eye = glGetUniformLocation(p, "u_eye");
    v->u_fog = glGetUniformLocation(p, "u_fog_density");
    v->u_ambient = glGetUniformLocation(p, "u_ambient");
    v->u_fog_far = glGetUniformLocation(p, "u_fog_far");
    v->u_sunh_tex = glGetUniformLocation(p, "u_sun_heights");
    v->u_sunh_map = glGetUniformLocation(p, "u_sunh_map");
    v->u_sunh = glGetUniformLocation(p, "u_sunh");
    v->u_sun_h = glGetUniformLocation(p, "u_sun_h");
    v->u_height_fog = glGetUniformLocation(p, "u_height_fog");
    v->u_zenith = glGetUniformLocation(p, "u_zenith");
    return v;
}

/* The variant a pass needs: the sun heights when it has them, the height
 * fog when it is on, the fade to the sky over the last stretch of the view
 * when that stretch is set. */
static unsigned obj_key(const hz_pass_info *pass)
{
    unsigned key = 0;
    if (pass->sun_heights_tex)
        key |= OBJ_SUN_HEIGHTS;
    if (pass->height_fog[2] > 0 && pass->height_fog[0] > 0)
        key |= OBJ_HEIGHT_FOG;
    if (pass->fog_far[1] > pass->fog_far[0])
        key |= OBJ_FAR_FADE;
    return key;
}

hz_scene_gpu *hz_scene_gpu_create(const hz_scene *s, hz_err *err)
{
    if (!hz_gl_has_context()) {
        hz_err_set(err, HZ_ERR_GL, "scene: no current GL context");
        return NULL;
    }
    hz_scene_gpu *g = calloc(1, sizeof *g);
    if (!g) {
        hz_err_set(err, HZ_ERR_MEMORY, "scene: out of memory");
        return NULL;
    }
    /* The plain variant now: a broken shader shows at creation. */
    if (!obj_program(g, 0, err)) {
        hz_scene_gpu_destroy(g);
        return NULL;
    }
    uint32_t vc, ic;
    const hz_vertex *v = hz_scene_vertices(s, &vc);
    const uint32_t *ix = hz_scene_indices(s, &ic);
    g->mesh_count = hz_scene_mesh_count(s);
    glGenVertexArrays(1, &g->vao);
    GLuint b[4];
    glGenBuffers(4, b);
    g->vbo = b[0];
    g->ibo = b[1];
    g->inst_buf = b[2];
    g->cmd_buf = b[3];
    glBindVertexArray(g->vao);
    glBindBuffer(GL_ARRAY_BUFFER, g->vbo);
    glBufferData(GL_ARRAY_BUFFER, (GLsizeiptr)((size_t)(vc ? vc : 1) * sizeof *v), v, GL_STATIC_DRAW);
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, sizeof(hz_vertex), (const void *)offsetof(hz_vertex, pos));
    glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, sizeof(hz_vertex), (const void *)offsetof(hz_vertex, normal));
    glEnableVertexAttribArray(0);
    glEnableVertexAttribArray(1);
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, g->ibo);
    glBufferData(GL_ELEMENT_ARRAY_BUFFER, (GLsizeiptr)((size_t)(ic ? ic : 1) * sizeof *ix), ix, GL_STATIC_DRAW);
    glBindBuffer(GL_ARRAY_BUFFER, g->inst_buf);
    glBufferData(GL_ARRAY_BUFFER, INST_BYTES, NULL, GL_STREAM_DRAW);
    g->inst_cap = INST_BYTES;
    /* Per instance: the world matrix (4 columns), then the material's colour. */
    for (GLuint c = 0; c < 5; c++) {
        glVertexAttribPointer(2 + c, c < 4 ? 4 : 3, GL_FLOAT, GL_FALSE, INST_BYTES, (const void *)(uintptr_t)(16 * c));
        glVertexAttribDivisor(2 + c, 1);
        glEnableVertexAttribArray(2 + c);
    }
    glBindVertexArray(0);
    /* The unit cube for occlusion queries. */
    g->box_prog = hz_gl_program(hz_shader_object_box_vs, hz_shader_object_box_fs, "object_box", err);
    if (!g->box_prog) {
        hz_scene_gpu_destroy(g);
        return NULL;
    }
    g->ub_viewproj = glGetUniformLocation(g->box_prog, "u_viewproj");
    g->ub_min = glGetUniformLocation(g->box_prog, "u_min");
    g->ub_max = glGetUniformLocation(g->box_prog, "u_max");
    static const float cube[24] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0, 0, 0, 1, 1, 0, 1, 0, 1, 1, 1, 1, 1};
    static const uint32_t cix[36] = {0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4,
                                     2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5};
    glGenVertexArrays(1, &g->box_vao);
    glGenBuffers(1, &g->box_vbo);
    glGenBuffers(1, &g->box_ibo);
    glBindVertexArray(g->box_vao);
    glBindBuffer(GL_ARRAY_BUFFER, g->box_vbo);
    glBufferData(GL_ARRAY_BUFFER, sizeof cube, cube, GL_STATIC_DRAW);
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 12, (const void *)0);
    glEnableVertexAttribArray(0);
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, g->box_ibo);
    glBufferData(GL_ELEMENT_ARRAY_BUFFER, sizeof cix, cix, GL_STATIC_DRAW);
    glBindVertexArray(0);
    glBindBuffer(GL_ARRAY_BUFFER, 0);
    if (hz_gl_check(err, "scene buffers") != HZ_OK) {
        hz_scene_gpu_destroy(g);
        return NULL;
    }
    return g;
}

static bool scratch(hz_scene_gpu *g, uint32_t n)
{
    if (n <= g->scratch_cap)
        return true;
    uint32_t c = n + n / 2 + 16;
    uint32_t *vis = realloc(g->vis, (size_t)c * sizeof *vis);
    if (vis)
        g->vis = vis;
    uint32_t *order = realloc(g->order, (size_t)c * sizeof *order);
    if (order)
        g->order = order;
    hz_draw_item *items = realloc(g->items, (size_t)c * sizeof *items);
    if (items)
        g->items = items;
    float *mats = realloc(g->mats, (size_t)c * INST_FLOATS * sizeof *mats);
    if (mats)
        g->mats = mats;
    draw_cmd *cmds = realloc(g->cmds, (size_t)c * sizeof *cmds);
    if (cmds)
        g->cmds = cmds;
    uint32_t *sort_tmp = realloc(g->sort_tmp, (size_t)c * 3 * sizeof *sort_tmp);
    if (sort_tmp)
        g->sort_tmp = sort_tmp;
    if (!vis || !order || !items || !mats || !cmds || !sort_tmp)
        return false;
    g->scratch_cap = c;
    return true;
}

/* Uploads bytes into a growing stream buffer bound to target. */
static void stream(GLenum target, GLuint buf, size_t *cap, const void *data, size_t bytes)
{
    glBindBuffer(target, buf);
    if (bytes > *cap || bytes < *cap / 4) {
        *cap = bytes + bytes / 4 + 64;
        glBufferData(target, (GLsizeiptr)*cap, NULL, GL_STREAM_DRAW);
    }
    glBufferSubData(target, 0, (GLsizeiptr)bytes, data);
}

/* The texture unit of the sun heights: above the renderer's fixed units. */
#define SUNH_UNIT 15

/* The light map's sun heights of the pass (or none): shade from the terrain
 * and the other objects. */
static void set_sun_heights(const obj_prog *v, const hz_pass_info *pass)
{
    if (!pass->sun_heights_tex)
        return;
    const float *s = pass->sun_dir, hl = sqrtf(s[0] * s[0] + s[2] * s[2]);
    const float sp = pass->sun_heights_spacing;
    glActiveTexture(GL_TEXTURE0 + SUNH_UNIT);
    glBindTexture(GL_TEXTURE_2D, pass->sun_heights_tex);
    glActiveTexture(GL_TEXTURE0);
    glUniform1i(v->u_sunh_tex, SUNH_UNIT);
    glUniform4fv(v->u_sunh_map, 1, pass->sun_heights_map);
    /* Soft over a tenth of a sample (0.5 .. 3 m): the heights are bilinear between samples. */
    const float soft = fminf(fmaxf(0.1f * sp, 0.5f), 3.0f);
    glUniform4f(v->u_sunh, 1.0f, sp, hl > 1e-6f ? s[1] / hl : 0.0f, soft);
    glUniform2f(v->u_sun_h, hl > 1e-6f ? s[0] / hl : 0.0f, hl > 1e-6f ? s[2] / hl : 0.0f);
}

/* Queues, uploads the world matrices of and draws nodes[0..n) (n <= the
 * scratch capacity; nodes may alias g->vis). Adds to st. */
static hz_result submit(hz_scene_gpu *g, const hz_scene *s, const hz_pass_info *pass, const hz_scene_draw_opts *opts,
                        const uint32_t *nodes, uint32_t n, hz_scene_draw_stats *st, hz_err *err)
{
    if (!n)
        return HZ_OK;
    double t0 = hz_time_ms();
    /* Materials are colours, passed with each instance: one item per
     * (shader, mesh), its instances nearest first whatever their colour. */
    uint32_t ni = hz_scene_queue_build_instanced(s, nodes, n, !opts->naive, g->order, g->items, NULL);
    if (!ni)
        return hz_err_set(err, HZ_ERR_MEMORY, "scene: out of memory for the render queue");
    st->items += ni;
    for (uint32_t k = 0; k < n; k++) {
        mat4 m;
        hz_scene_world_matrix(s, g->order[k], m);
        float *o = g->mats + INST_FLOATS * (size_t)k;
        memcpy(o, m, sizeof m);
        const hz_material *mt = hz_scene_material(s, hz_scene_node_material(s, g->order[k]));
        static const float grey[3] = {0.7f, 0.7f, 0.7f};
        memcpy(o + 16, mt ? mt->color : grey, 3 * sizeof *o);
    }
    st->cull_ms += hz_time_ms() - t0;
    const obj_prog *v = obj_program(g, obj_key(pass), err);
    if (!v)
        return HZ_ERR_GL;
    glUseProgram(v->prog);
    glBindVertexArray(g->vao);
    st->state_changes += 2;
    stream(GL_ARRAY_BUFFER, g->inst_buf, &g->inst_cap, g->mats, (size_t)n * INST_BYTES);
    glUniformMatrix4fv(v->u_viewproj, 1, GL_FALSE, (const float *)pass->viewproj);
    hz_gl_set_curvature(v->prog, pass->cam);
    glUniform4fv(v->u_clip, 1, pass->clip_plane);
    glUniform3fv(v->u_sun, 1, pass->sun_dir);
    glUniform3fv(v->u_sky, 1, pass->sky_color);
    glUniform3fv(v->u_eye, 1, pass->cam->pos);
    glUniform1f(v->u_fog, pass->fog_density);
    glUniform1f(v->u_ambient, pass->ambient > 0 ? pass->ambient : 0.3f);
    glUniform2fv(v->u_fog_far, 1, pass->fog_far);
    glUniform3f(v->u_height_fog, pass->height_fog[0], pass->height_fog[1], pass->height_fog[2]);
    glUniform3fv(v->u_zenith, 1, pass->zenith_color);
    set_sun_heights(v, pass);
    /* Closed outward meshes: back faces culled (mirrored passes flip the
     * front face, set by the renderer). */
    glEnable(GL_CULL_FACE);
    if (opts->naive) {
        for (uint32_t k = 0; k < ni; k++) {
            const hz_draw_item *it = &g->items[k];
            const hz_mesh_range *m = hz_scene_mesh(s, it->mesh);
            glDrawElementsInstancedBaseVertexBaseInstance(
                GL_TRIANGLES, (GLsizei)m->index_count, GL_UNSIGNED_INT,
                (const void *)(uintptr_t)((size_t)m->first_index * 4), (GLsizei)it->count, (GLint)m->first_vertex,
                it->first);
            st->draw_calls++;
            st->triangles += (uint64_t)m->index_count / 3 * it->count;
        }
    } else {
        /* Commands for all items, then one multi-draw per shader run. */
        for (uint32_t k = 0; k < ni; k++) {
            const hz_draw_item *it = &g->items[k];
            const hz_mesh_range *m = hz_scene_mesh(s, it->mesh);
            g->cmds[k] = (draw_cmd){m->index_count, it->count, m->first_index, (GLint)m->first_vertex, it->first};
            st->triangles += (uint64_t)m->index_count / 3 * it->count;
        }
        size_t cmd_cap = g->cmd_cap;
        stream(GL_DRAW_INDIRECT_BUFFER, g->cmd_buf, &cmd_cap, g->cmds, (size_t)ni * sizeof(draw_cmd));
        g->cmd_cap = cmd_cap;
        for (uint32_t k = 0; k < ni;) {
            uint32_t e = k + 1;
            while (e < ni && g->items[e].shader == g->items[k].shader)
                e++;
            glMultiDrawElementsIndirect(GL_TRIANGLES, GL_UNSIGNED_INT,
                                        (const void *)(uintptr_t)((size_t)k * sizeof(draw_cmd)), (GLsizei)(e - k), 0);
            st->draw_calls++;
            k = e;
        }
        glBindBuffer(GL_DRAW_INDIRECT_BUFFER, 0);
    }
    glDisable(GL_CULL_FACE);
    glBindVertexArray(0);
    glUseProgram(0);
    glBindBuffer(GL_ARRAY_BUFFER, 0);
    if (pass->sun_heights_tex) {
        glActiveTexture(GL_TEXTURE0 + SUNH_UNIT);
        glBindTexture(GL_TEXTURE_2D, 0);
        glActiveTexture(GL_TEXTURE0);
    }
    return hz_gl_check(err, "scene draw");
}

/* GPU occlusion queries on vis[first..n): keeps the objects whose box shows
 * past the depth buffer; returns the new n. */
static uint32_t gpu_query(hz_scene_gpu *g, const hz_scene *s, const hz_pass_info *pass, uint32_t first, uint32_t n,
                          hz_scene_draw_stats *st)
{
    const uint32_t q = n - first;
    if (!q)
        return n;
    double t0 = hz_time_ms();
    if (q > g->query_cap) {
        GLuint *nq = realloc(g->queries, (size_t)q * sizeof *nq);
        if (!nq)
            return n; /* no queries: everything stays (conservative) */
        g->queries = nq;
        glGenQueries((GLsizei)(q - g->query_cap), g->queries + g->query_cap);
        g->query_cap = q;
    }
    glUseProgram(g->box_prog);
    glBindVertexArray(g->box_vao);
    glUniformMatrix4fv(g->ub_viewproj, 1, GL_FALSE, (const float *)pass->viewproj);
    hz_gl_set_curvature(g->box_prog, pass->cam);
    glColorMask(GL_FALSE, GL_FALSE, GL_FALSE, GL_FALSE);
    glDepthMask(GL_FALSE);
    glDepthFunc(GL_GEQUAL);
    glDisable(GL_CULL_FACE);
    bool *always = calloc(q, sizeof *always);
    for (uint32_t k = 0; k < q; k++) {
        hz_box b;
        hz_scene_node_bounds(s, g->vis[first + k], &b);
        /* A box around the eye (or across the near plane) would be clipped
         * away: such objects are kept without asking. */
        if (!always || hz_box_around_eye(&b, pass->cam)) {
            if (always)
                always[k] = true;
            continue;
        }
        glUniform3fv(g->ub_min, 1, b.min);
        glUniform3fv(g->ub_max, 1, b.max);
        glBeginQuery(GL_ANY_SAMPLES_PASSED_CONSERVATIVE, g->queries[k]);
        glDrawElements(GL_TRIANGLES, 36, GL_UNSIGNED_INT, (const void *)0);
        glEndQuery(GL_ANY_SAMPLES_PASSED_CONSERVATIVE);
        st->queries++;
    }
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    glDepthMask(GL_TRUE);
    glDepthFunc(GL_GREATER);
    glBindVertexArray(0);
    glUseProgram(0);
    uint32_t kept = first;
    for (uint32_t k = 0; k < q; k++) {
        GLuint any = 1;
        if (!always || !always[k])
            glGetQueryObjectuiv(g->queries[k], GL_QUERY_RESULT, &any);
        if (any)
            g->vis[kept++] = g->vis[first + k];
    }
    free(always);
    st->query_ms += hz_time_ms() - t0;
    return kept;
}

hz_result hz_scene_gpu_draw(hz_scene_gpu *g, const hz_scene *s, const hz_pass_info *pass,
                            const hz_scene_draw_opts *opts, hz_scene_draw_stats *stats, hz_err *err)
{
    static const hz_scene_draw_opts none = {0};
    if (!opts)
        opts = &none;
    hz_scene_draw_stats st = {0};
    double t0 = hz_time_ms();
    const uint32_t total = hz_scene_node_count(s);
    if (!scratch(g, total + 1))
        return hz_err_set(err, HZ_ERR_MEMORY, "scene: out of memory for %u nodes", total);
    if (hz_scene_mesh_count(s) != g->mesh_count)
        return hz_err_set(err, HZ_ERR_VALUE, "scene: meshes were added after the upload (%u now, %u uploaded)",
                          hz_scene_mesh_count(s), g->mesh_count);
    /* Frustum culling (hierarchical), or every object in scene order. */
    vec4 planes[6];
    hz_cull_stats cs;
    if (opts->no_frustum) {
        /* All planes accept everything: a plane with zero normal and d = 1. */
        for (int k = 0; k < 6; k++)
            glm_vec4_copy((vec4){0, 0, 0, 1}, planes[k]);
    } else {
        hz_camera_frustum(pass->cam, planes);
    }
    /* With occlusion (main pass), hierarchical: a block of buildings behind
     * the buffer is one test. */
    const hz_occlusion *occ = pass->pass == HZ_PASS_MAIN ? opts->occlusion : NULL;
    uint32_t n = hz_scene_cull_occluded(s, pass->cam, planes, occ, g->vis, g->scratch_cap, &cs);
    st.objects = cs.objects;
    st.after_frustum = cs.in_frustum;
    st.nodes_tested = cs.nodes_tested;
    st.occlusion_tests = cs.occlusion_tests;
    /* Nearest first (the queue keeps this order within each item): near
     * objects fill the depth buffer first, and the hidden fragments of
     * those behind fail the depth test before shading. */
    if (!opts->naive)
        hz_scene_sort_near_first(s, pass->cam->pos, g->vis, n, g->sort_tmp);
    st.cull_ms = hz_time_ms() - t0;
    hz_result r = HZ_OK;
    if (opts->gpu_queries && pass->pass == HZ_PASS_MAIN) {
        /* Near objects first (drawn, they occlude), then queries for the rest. */
        const float near = opts->gpu_near > 0 ? opts->gpu_near : 300.0f;
        uint32_t nn = 0;
        for (uint32_t k = 0; k < n; k++) {
            hz_box b;
            hz_scene_node_bounds(s, g->vis[k], &b);
            if (hz_box_distance2(&b, pass->cam->pos) < near * near) {
                uint32_t t = g->vis[nn];
                g->vis[nn++] = g->vis[k];
                g->vis[k] = t;
            }
        }
        r = submit(g, s, pass, opts, g->vis, nn, &st, err);
        uint32_t kept = r == HZ_OK ? gpu_query(g, s, pass, nn, n, &st) : n;
        /* submit() reorders nothing in vis; the far survivors follow the near ones. */
        if (r == HZ_OK)
            r = submit(g, s, pass, opts, g->vis + nn, kept - nn, &st, err);
        n = kept;
    } else {
        r = submit(g, s, pass, opts, g->vis, n, &st, err);
    }
    st.after_occlusion = n;
    if (stats)
        *stats = st;
    return r;
}

void hz_scene_draw_hook(void *user, const hz_pass_info *pass)
{
    hz_scene_hook *h = user;
    if (h && h->gpu && h->scene && !h->failed) {
        const bool is_main = pass->pass == HZ_PASS_MAIN;
        if (is_main && h->time_draw)
            glFinish();
        const double t0 = hz_time_ms();
        hz_scene_draw_stats st;
        if (hz_scene_gpu_draw(h->gpu, h->scene, pass, &h->opts, &st, &h->err) != HZ_OK)
            h->failed = true;
        if (is_main) {
            if (h->time_draw)
                glFinish();
            st.draw_ms = hz_time_ms() - t0;
            h->stats = st;
        }
    }
    if (h && h->next) {
        glUseProgram(0);
        glBindVertexArray(0);
        h->next(h->next_user, pass);
    }
}
