/* Leaf item buffers (R32UI ids, depth peeling) for VMI ranking (SPEC F2) and
 * the whole tree's leaf-id images for precision/recall (F7). The VMI maths and the
 * greedy order live in src/foliage (no GL). */
#include "horizon/forest_render.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gl_util.h"
#include "hz_shaders.h"

typedef struct itembuf {
    GLuint prog, vao;
    GLuint leaf_buf, leaf_tex;   /* RGBA32F, 3 texels per leaf */
    GLuint node_buf, node_tex;   /* RGBA32F, 2 texels per node slot */
    GLuint scale_buf, scale_tex; /* R32F per node */
    GLuint fbo, id_tex, depth_tex[2];
    uint32_t w, h;
    GLint u_leaves, u_nodes, u_scales, u_mode, u_slot_base, u_viewproj, u_right, u_up, u_fwd, u_atlas, u_tile,
        u_prev_depth, u_layer;
} itembuf;

static void ib_destroy(itembuf *ib)
{
    glDeleteProgram(ib->prog);
    glDeleteVertexArrays(1, &ib->vao);
    glDeleteBuffers(1, &ib->leaf_buf);
    glDeleteBuffers(1, &ib->node_buf);
    glDeleteBuffers(1, &ib->scale_buf);
    glDeleteTextures(1, &ib->leaf_tex);
    glDeleteTextures(1, &ib->node_tex);
    glDeleteTextures(1, &ib->scale_tex);
    glDeleteTextures(1, &ib->id_tex);
    glDeleteTextures(2, ib->depth_tex);
    glDeleteFramebuffers(1, &ib->fbo);
    memset(ib, 0, sizeof *ib);
}


/* Leaf texels: (c, node), (u, 0), (v, 0). */
static float *leaf_texels(const hz_tree *t)
{
    float *d = malloc((size_t)t->leaf_count * 12 * sizeof *d + 16);
    if (!d)
        return NULL;
    for (uint32_t n = 0; n < t->node_count; n++)
        for (uint32_t k = t->nodes[n].first; k < t->nodes[n].first + t->nodes[n].count; k++) {
            float *o = d + (size_t)k * 12;
            const hz_tree_leaf *l = &t->leaves[k];
            o[0] = l->c[0], o[1] = l->c[1], o[2] = l->c[2], o[3] = (float)n;
            o[4] = l->u[0], o[5] = l->u[1], o[6] = l->u[2], o[7] = 0;
            o[8] = l->v[0], o[9] = l->v[1], o[10] = l->v[2], o[11] = 0;
        }
    return d;
}

static hz_result ib_create(itembuf *ib, const hz_tree *t, uint32_t w, uint32_t h, hz_err *err)
{
    memset(ib, 0, sizeof *ib);
    if (!hz_gl_has_context())
        return hz_err_set(err, HZ_ERR_GL, "item buffer: no current OpenGL context");
    hz_gl_drain();
    GLint max_rb = 0;
    glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_rb);
    if (w > (uint32_t)max_rb || h > (uint32_t)max_rb)
        return hz_err_set(err, HZ_ERR_UNSUPPORTED, "item buffer %ux%u exceeds GL_MAX_TEXTURE_SIZE %d", w, h, max_rb);
    ib->prog = hz_gl_program(hz_shader_itembuf_vs, hz_shader_itembuf_fs, "itembuf", err);
    if (!ib->prog)
        return HZ_ERR_GL;
    GLuint p = ib->prog;
    ib->u_leaves = glGetUniformLocation(p, "u_leaves");
    ib->u_nodes = glGetUniformLocation(p, "u_nodes");
    ib->u_scales = glGetUniformLocation(p, "u_scales");
    ib->u_mode = glGetUniformLocation(p, "u_mode");
    ib->u_slot_base = glGetUniformLocation(p, "u_slot_base");
    ib->u_viewproj = glGetUniformLocation(p, "u_viewproj");
    ib->u_right = glGetUniformLocation(p, "u_right");
    ib->u_up = glGetUniformLocation(p, "u_up");
    ib->u_fwd = glGetUniformLocation(p, "u_fwd");
    ib->u_atlas = glGetUniformLocation(p, "u_atlas");
    ib->u_tile = glGetUniformLocation(p, "u_tile");
    ib->u_prev_depth = glGetUniformLocation(p, "u_prev_depth");
    ib->u_layer = glGetUniformLocation(p, "u_layer");
    glGenVertexArrays(1, &ib->vao);
    float *lt = leaf_texels(t);
    if (!lt) {
        ib_destroy(ib);
        return hz_err_set(err, HZ_ERR_MEMORY, "out of memory");
    }
    hz_gl_buffer_texture(&ib->leaf_buf, &ib->leaf_tex, GL_RGBA32F, lt, (size_t)t->leaf_count * 48, GL_DYNAMIC_DRAW);
    free(lt);
    ib->w = w;
    ib->h = h;
    glGenTextures(1, &ib->id_tex);
    glBindTexture(GL_TEXTURE_2D, ib->id_tex);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_R32UI, (GLsizei)w, (GLsizei)h, 0, GL_RED_INTEGER, GL_UNSIGNED_INT, NULL);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glGenTextures(2, ib->depth_tex);
    for (int k = 0; k < 2; k++) {
        glBindTexture(GL_TEXTURE_2D, ib->depth_tex[k]);
        glTexImage2D(GL_TEXTURE_2D, 0, GL_DEPTH_COMPONENT32F, (GLsizei)w, (GLsizei)h, 0, GL_DEPTH_COMPONENT, GL_FLOAT,
                     NULL);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_COMPARE_MODE, GL_NONE);
    }
    glBindTexture(GL_TEXTURE_2D, 0);
    glGenFramebuffers(1, &ib->fbo);
    glBindFramebuffer(GL_FRAMEBUFFER, ib->fbo);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, ib->id_tex, 0);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, ib->depth_tex[0], 0);
    GLenum st = glCheckFramebufferStatus(GL_FRAMEBUFFER);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    if (st != GL_FRAMEBUFFER_COMPLETE) {
        ib_destroy(ib);
        return hz_err_set(err, HZ_ERR_GL, "item buffer: framebuffer incomplete (0x%04x)", (unsigned)st);
    }
    hz_result r = hz_gl_check(err, "item buffer setup");
    if (r != HZ_OK)
        ib_destroy(ib);
    return r;
}

/* Common state for an item-buffer draw. */
static void ib_begin(itembuf *ib, int mode)
{
    glBindFramebuffer(GL_FRAMEBUFFER, ib->fbo);
    glViewport(0, 0, (GLsizei)ib->w, (GLsizei)ib->h);
    glDisable(GL_BLEND);
    glDisable(GL_CULL_FACE);
    glDisable(GL_SCISSOR_TEST);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glDepthMask(GL_TRUE);
    glUseProgram(ib->prog);
    glBindVertexArray(ib->vao);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_BUFFER, ib->leaf_tex);
    glUniform1i(ib->u_leaves, 0);
    glActiveTexture(GL_TEXTURE1);
    glBindTexture(GL_TEXTURE_BUFFER, mode == 0 ? ib->node_tex : ib->scale_tex);
    glUniform1i(mode == 0 ? ib->u_nodes : ib->u_scales, 1);
    glUniform1i(mode == 0 ? ib->u_scales : ib->u_nodes, 1);
    glUniform1i(ib->u_prev_depth, 2);
    glUniform1i(ib->u_mode, mode);
}

static void ib_end(void)
{
    glActiveTexture(GL_TEXTURE2);
    glBindTexture(GL_TEXTURE_2D, 0);
    glActiveTexture(GL_TEXTURE1);
    glBindTexture(GL_TEXTURE_BUFFER, 0);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_BUFFER, 0);
    glUseProgram(0);
    glBindVertexArray(0);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

/* Clears and draws one layer into depth_tex[layer & 1], peeling against the other. */
static void ib_layer(itembuf *ib, uint32_t layer, void (*draw)(void *), void *user)
{
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, ib->depth_tex[layer & 1], 0);
    const GLuint zero[4] = {0, 0, 0, 0};
    glClearBufferuiv(GL_COLOR, 0, zero);
    glClearDepth(1.0);
    glClear(GL_DEPTH_BUFFER_BIT);
    glActiveTexture(GL_TEXTURE2);
    glBindTexture(GL_TEXTURE_2D, layer ? ib->depth_tex[(layer + 1) & 1] : 0);
    glUniform1i(ib->u_layer, (GLint)layer);
    draw(user);
}

static void ib_read(itembuf *ib, uint32_t *ids)
{
    glBindFramebuffer(GL_READ_FRAMEBUFFER, ib->fbo);
    glReadBuffer(GL_COLOR_ATTACHMENT0);
    glBindBuffer(GL_PIXEL_PACK_BUFFER, 0);
    glPixelStorei(GL_PACK_ALIGNMENT, 4);
    glPixelStorei(GL_PACK_ROW_LENGTH, 0);
    glReadPixels(0, 0, (GLsizei)ib->w, (GLsizei)ib->h, GL_RED_INTEGER, GL_UNSIGNED_INT, ids);
}

/* ---- ranking ------------------------------------------------------------------ */

typedef struct range_draw {
    GLint first;
    GLsizei count;
} range_draw;

static void draw_range(void *user)
{
    const range_draw *r = user;
    glDrawArrays(GL_TRIANGLES, r->first, r->count);
}

typedef struct node_lists {
    uint32_t *view_start; /* views + 1 */
    uint16_t *ids;
    size_t n, cap;        /* pixels */
} node_lists;

static void view_basis(const float *toward_viewer, float *right, float *up, float *fwd)
{
    for (int c = 0; c < 3; c++)
        fwd[c] = -toward_viewer[c];
    float ref[3] = {0, 1, 0};
    if (fabsf(fwd[1]) > 0.95f)
        ref[0] = 1, ref[1] = 0;
    right[0] = fwd[1] * ref[2] - fwd[2] * ref[1];
    right[1] = fwd[2] * ref[0] - fwd[0] * ref[2];
    right[2] = fwd[0] * ref[1] - fwd[1] * ref[0];
    float l = sqrtf(right[0] * right[0] + right[1] * right[1] + right[2] * right[2]);
    for (int c = 0; c < 3; c++)
        right[c] /= l;
    up[0] = right[1] * fwd[2] - right[2] * fwd[1];
    up[1] = right[2] * fwd[0] - right[0] * fwd[2];
    up[2] = right[0] * fwd[1] - right[1] * fwd[0];
}

/* Draws up to `layers` depth-peeled layers of rd into ids (w x h ids per
 * layer), stopping after the first empty one; the number of layers drawn. */
static uint32_t ib_peel(itembuf *ib, uint32_t layers, range_draw *rd, uint32_t *ids)
{
    const size_t npx = (size_t)ib->w * ib->h;
    uint32_t got = 0;
    for (uint32_t l = 0; l < layers; l++) {
        ib_layer(ib, l, draw_range, rd);
        uint32_t *lay = ids + (size_t)l * npx;
        ib_read(ib, lay);
        glBindFramebuffer(GL_FRAMEBUFFER, ib->fbo);
        got = l + 1;
        bool any = false;
        for (size_t p = 0; p < npx && !any; p++)
            any = lay[p] != 0;
        if (!any)
            break;
    }
    return got;
}

/* Appends one pixel (layers ids) to a node's list. */
static bool list_push(node_lists *nl, const uint16_t *px, uint32_t layers)
{
    if (nl->n == nl->cap) {
        size_t nc = nl->cap ? nl->cap * 2 : 1024;
        uint16_t *np = realloc(nl->ids, nc * layers * sizeof *np);
        if (!np)
            return false;
        nl->ids = np;
        nl->cap = nc;
    }
    memcpy(nl->ids + nl->n * layers, px, layers * sizeof *px);
    nl->n++;
    return true;
}

/* VMI in the tree: the pixel lists come from the whole tree rendered from
 * each view (orthographic, framing the bounding sphere, tres x tres,
 * depth-peeled), so a leaf's visible area is what the rest of the crown
 * leaves of it: each pixel belongs to the node of its front-most leaf, with
 * that node's leaves front to back until another node's leaf hides the
 * rest. Then hz_vmi_rank per node, as for nodes rendered alone. */
static hz_result rank_in_tree(hz_tree *t, const float *dirs, uint32_t views, uint32_t layers, uint32_t tres,
                              const hz_rank_desc *d, uint32_t *orders, hz_rank_stats *st, hz_err *err)
{
    const uint32_t nn = t->node_count, nl_ = t->leaf_count;
    const size_t npx = (size_t)tres * tres;
    itembuf ib;
    hz_result res = ib_create(&ib, t, tres, tres, err);
    if (res != HZ_OK)
        return res;
    float *ones = malloc((nn ? nn : 1) * sizeof *ones);
    uint32_t *node_of = malloc((nl_ ? nl_ : 1) * sizeof *node_of);
    uint32_t *ids = malloc(npx * layers * sizeof *ids);
    node_lists *lists = calloc(nn ? nn : 1, sizeof *lists);
    uint16_t px[16];
    if (!ones || !node_of || !ids || !lists) {
        res = hz_err_set(err, HZ_ERR_MEMORY, "rank: out of memory");
        goto done;
    }
    for (uint32_t n = 0; n < nn; n++) {
        ones[n] = 1.0f;
        lists[n].view_start = malloc((views + 1) * sizeof *lists[n].view_start);
        if (!lists[n].view_start) {
            res = hz_err_set(err, HZ_ERR_MEMORY, "rank: out of memory");
            goto done;
        }
    }
    for (uint32_t l = 0; l < nl_; l++)
        node_of[l] = UINT32_MAX;
    for (uint32_t n = 0; n < nn; n++)
        for (uint32_t l = t->nodes[n].first; l < t->nodes[n].first + t->nodes[n].count; l++)
            node_of[l] = n;
    hz_gl_buffer_texture(&ib.scale_buf, &ib.scale_tex, GL_R32F, ones, (nn ? nn : 1) * sizeof(float), GL_DYNAMIC_DRAW);
    const float *c = t->bound_center, R = t->bound_radius > 0 ? t->bound_radius : 1.0f;
    range_draw rd = {0, (GLsizei)(nl_ * 6)};
    for (uint32_t v = 0; v < views; v++) {
        double r0 = hz_time_ms();
        float right[3], up[3], fwd[3];
        view_basis(dirs + v * 3, right, up, fwd);
        /* column-major: x = right.(p - c) / R, y = up.(p - c) / R, z = fwd.(p - c) / R */
        float m[16] = {0};
        for (int k = 0; k < 3; k++) {
            m[k * 4 + 0] = right[k] / R;
            m[k * 4 + 1] = up[k] / R;
            m[k * 4 + 2] = 0.999f * fwd[k] / R;
        }
        m[12] = -(right[0] * c[0] + right[1] * c[1] + right[2] * c[2]) / R;
        m[13] = -(up[0] * c[0] + up[1] * c[1] + up[2] * c[2]) / R;
        m[14] = -0.999f * (fwd[0] * c[0] + fwd[1] * c[1] + fwd[2] * c[2]) / R;
        m[15] = 1.0f;
        ib_begin(&ib, 2);
        glUniformMatrix4fv(ib.u_viewproj, 1, GL_FALSE, m);
        const uint32_t got = ib_peel(&ib, layers, &rd, ids);
        ib_end();
        if ((res = hz_gl_check(err, "tree item buffer rendering")) != HZ_OK)
            goto done;
        st->render_ms += hz_time_ms() - r0;
        for (uint32_t n = 0; n < nn; n++)
            lists[n].view_start[v] = (uint32_t)lists[n].n;
        for (size_t p = 0; p < npx; p++) {
            uint32_t id0 = ids[p];
            if (!id0 || id0 > nl_ || node_of[id0 - 1] == UINT32_MAX)
                continue;
            const uint32_t n = node_of[id0 - 1], first = t->nodes[n].first;
            bool blocked = false;
            for (uint32_t l = 0; l < layers; l++) {
                uint32_t id = l < got ? ids[(size_t)l * npx + p] : 0;
                if (!id || id > nl_ || node_of[id - 1] != n)
                    blocked = true; /* another node's leaf, or nothing, from here on */
                px[l] = blocked ? HZ_VMI_EMPTY : (uint16_t)(id - 1 - first);
            }
            if (px[layers - 1] != HZ_VMI_EMPTY)
                st->deep_pixels++;
            if (!list_push(&lists[n], px, layers)) {
                res = hz_err_set(err, HZ_ERR_MEMORY, "rank: out of memory");
                goto done;
            }
        }
    }
    double r1 = hz_time_ms();
    for (uint32_t n = 0; n < nn; n++) {
        node_lists *nl = &lists[n];
        nl->view_start[views] = (uint32_t)nl->n;
        st->pixels += nl->n;
        hz_vmi_input in = {.leaf_count = t->nodes[n].count, .view_count = views, .layers = layers,
                           .view_start = nl->view_start, .ids = nl->ids};
        hz_vmi_stats vs;
        if ((res = hz_vmi_rank(&in, orders + t->nodes[n].first, &vs, err)) != HZ_OK)
            goto done;
        st->candidates += vs.candidates;
        free(nl->ids);
        nl->ids = NULL;
        if (d->progress && (n + 1) % 64 == 0)
            d->progress(d->progress_user, "rank leaves (VMI)", n + 1, nn);
    }
    st->vmi_ms += hz_time_ms() - r1;
    st->batches = views;
done:
    if (lists)
        for (uint32_t n = 0; n < nn; n++) {
            free(lists[n].view_start);
            free(lists[n].ids);
        }
    free(lists);
    free(ids);
    free(node_of);
    free(ones);
    ib_destroy(&ib);
    return res;
}

hz_result hz_tree_rank(hz_tree *t, const hz_rank_desc *desc, hz_rank_stats *stats, hz_err *err)
{
    double t0 = hz_time_ms();
    hz_rank_desc d = desc ? *desc : (hz_rank_desc){0};
    if (!d.views)
        d.views = 162;
    if (!d.res)
        d.res = 32;
    if (!d.layers)
        d.layers = 4;
    hz_rank_stats st = {0};
    if (d.res < 4 || d.res > 256 || d.layers > 16 || (d.views != 12 && d.views != 42 && d.views != 162) ||
        (d.tree_res && (d.tree_res < 512 || d.tree_res > 4096)) || d.min_elevation < -90 || d.min_elevation > 90)
        return hz_err_set(err, HZ_ERR_VALUE,
                          "rank: bad parameters (views %u: 12, 42 or 162; resolution %u: 4..256; layers %u: 1..16; "
                          "tree resolution %u: 512..4096; minimum elevation %d: -90..90 degrees)",
                          d.views, d.res, d.layers, d.tree_res, (int)d.min_elevation);
    float dirs[162 * 3];
    hz_sphere_views(d.views, dirs);
    /* The views a simplified tree is seen from: directions toward the viewer
     * at or above min_elevation (a tree is seen from beneath only from close by,
     * where it is simplified least). */
    const uint32_t sphere_views = d.views;
    const float ymin = sinf((float)d.min_elevation * 0.0174532925f) - 1e-4f;
    d.views = 0;
    for (uint32_t v = 0; v < sphere_views; v++)
        if (dirs[v * 3 + 1] >= ymin) {
            memmove(dirs + d.views * 3, dirs + v * 3, 3 * sizeof *dirs);
            d.views++;
        }
    if (d.views < 2)
        return hz_err_set(err, HZ_ERR_VALUE, "rank: %u of the %u views lie at or above %d degrees elevation (2 needed)",
                          d.views, sphere_views, (int)d.min_elevation);
    const uint32_t per_row = d.res <= 64 ? 1024 / d.res : 4;
    const uint32_t per_batch = per_row * per_row;
    const uint32_t W = per_row * d.res, H = W;
    itembuf ib;
    hz_result res = ib_create(&ib, t, W, H, err);
    if (res != HZ_OK)
        return res;
    uint32_t *ids = malloc((size_t)W * H * d.layers * sizeof *ids);
    float *nodes = malloc((size_t)per_batch * 8 * sizeof *nodes);
    node_lists *lists = calloc(per_batch, sizeof *lists);
    uint32_t *orders = malloc((size_t)(t->leaf_count ? t->leaf_count : 1) * sizeof *orders);
    if (!ids || !nodes || !lists || !orders) {
        res = hz_err_set(err, HZ_ERR_MEMORY, "rank: out of memory");
        goto done;
    }
    for (uint32_t s = 0; s < per_batch; s++) {
        lists[s].view_start = malloc((d.views + 1) * sizeof *lists[s].view_start);
        if (!lists[s].view_start) {
            res = hz_err_set(err, HZ_ERR_MEMORY, "rank: out of memory");
            goto done;
        }
    }
    if (d.tree_res) {
        if ((res = rank_in_tree(t, dirs, d.views, d.layers, d.tree_res, &d, orders, &st, err)) != HZ_OK)
            goto done;
    }
    for (uint32_t b0 = 0; b0 < t->node_count && !d.tree_res; b0 += per_batch) {
        uint32_t b1 = b0 + per_batch < t->node_count ? b0 + per_batch : t->node_count;
        double r0 = hz_time_ms();
        for (uint32_t n = b0; n < b1; n++) {
            uint32_t s = n - b0;
            float *o = nodes + (size_t)s * 8;
            const hz_tree_node *nd = &t->nodes[n];
            o[0] = nd->center[0], o[1] = nd->center[1], o[2] = nd->center[2], o[3] = nd->radius;
            o[4] = (float)((s % per_row) * d.res), o[5] = (float)((s / per_row) * d.res);
            o[6] = (float)nd->first, o[7] = 0;
            lists[s].n = 0;
        }
        hz_gl_buffer_texture(&ib.node_buf, &ib.node_tex, GL_RGBA32F, nodes, (size_t)(b1 - b0) * 32, GL_DYNAMIC_DRAW);
        range_draw rd = {(GLint)(t->nodes[b0].first * 6),
                         (GLsizei)((t->nodes[b1 - 1].first + t->nodes[b1 - 1].count - t->nodes[b0].first) * 6)};
        ib_begin(&ib, 0);
        glUniform1i(ib.u_slot_base, (GLint)b0);
        glUniform2f(ib.u_atlas, (float)W, (float)H);
        glUniform1f(ib.u_tile, (float)d.res);
        for (uint32_t v = 0; v < d.views; v++) {
            float right[3], up[3], fwd[3];
            view_basis(dirs + v * 3, right, up, fwd);
            glUniform3fv(ib.u_right, 1, right);
            glUniform3fv(ib.u_up, 1, up);
            glUniform3fv(ib.u_fwd, 1, fwd);
            const uint32_t layers = ib_peel(&ib, d.layers, &rd, ids);
            /* Per node: its tile's covered pixels, ids front to back. */
            for (uint32_t n = b0; n < b1; n++) {
                uint32_t s = n - b0;
                node_lists *nl = &lists[s];
                nl->view_start[v] = (uint32_t)nl->n;
                uint32_t tx = (s % per_row) * d.res, ty = (s / per_row) * d.res;
                for (uint32_t y = ty; y < ty + d.res; y++)
                    for (uint32_t x = tx; x < tx + d.res; x++) {
                        size_t p = (size_t)y * W + x;
                        if (!ids[p])
                            continue;
                        uint16_t px[16];
                        for (uint32_t l = 0; l < d.layers; l++) {
                            uint32_t id = l < layers ? ids[(size_t)l * W * H + p] : 0;
                            px[l] = id ? (uint16_t)(id - 1) : HZ_VMI_EMPTY;
                        }
                        if (px[d.layers - 1] != HZ_VMI_EMPTY)
                            st.deep_pixels++;
                        if (!list_push(nl, px, d.layers)) {
                            ib_end();
                            res = hz_err_set(err, HZ_ERR_MEMORY, "rank: out of memory");
                            goto done;
                        }
                    }
            }
        }
        ib_end();
        res = hz_gl_check(err, "item buffer rendering");
        if (res != HZ_OK)
            goto done;
        double r1 = hz_time_ms();
        st.render_ms += r1 - r0;
        for (uint32_t n = b0; n < b1; n++) {
            node_lists *nl = &lists[n - b0];
            nl->view_start[d.views] = (uint32_t)nl->n;
            st.pixels += nl->n;
            hz_vmi_input in = {.leaf_count = t->nodes[n].count, .view_count = d.views, .layers = d.layers,
                               .view_start = nl->view_start, .ids = nl->ids};
            hz_vmi_stats vs;
            res = hz_vmi_rank(&in, orders + t->nodes[n].first, &vs, err);
            if (res != HZ_OK)
                goto done;
            st.candidates += vs.candidates;
        }
        st.vmi_ms += hz_time_ms() - r1;
        st.batches++;
        if (d.progress)
            d.progress(d.progress_user, "rank leaves (VMI)", b1, t->node_count);
    }
    res = hz_tree_apply_order(t, orders, err);
    if (res == HZ_OK) {
        t->ranked = true;
        t->rank_views = d.views;
        t->rank_res = d.tree_res ? d.tree_res : d.res;
        t->rank_layers = d.layers;
        st.nodes = t->node_count;
        st.ms = hz_time_ms() - t0;
        t->rank_ms = st.ms;
    }
done:
    if (lists)
        for (uint32_t s = 0; s < per_batch; s++) {
            free(lists[s].view_start);
            free(lists[s].ids);
        }
    free(lists);
    free(ids);
    free(nodes);
    free(orders);
    ib_destroy(&ib);
    if (stats)
        *stats = st;
    return res;
}

/* ---- precision / recall --------------------------------------------------------- */

typedef struct multi_draw {
    const GLint *first;
    const GLsizei *count;
    GLsizei n;
} multi_draw;

static void draw_multi(void *user)
{
    const multi_draw *m = user;
    glMultiDrawArrays(GL_TRIANGLES, m->first, m->count, m->n);
}

/* Precision, recall and F-measure from the counts (1 where nothing was there to find). */
static void pr_ratios(uint64_t tp, uint64_t fp, uint64_t fn, double *precision, double *recall, double *f)
{
    *precision = tp + fp ? (double)tp / (double)(tp + fp) : 1.0;
    *recall = tp + fn ? (double)tp / (double)(tp + fn) : 1.0;
    *f = *precision + *recall > 0 ? 2.0 * *precision * *recall / (*precision + *recall) : 0.0;
}

hz_result hz_tree_pr(const hz_tree *t, const hz_pr_desc *desc, hz_pr_result *out, hz_err *err)
{
    hz_pr_desc d = desc ? *desc : (hz_pr_desc){0};
    if (!d.views)
        d.views = 16;
    if (!d.res)
        d.res = 512;
    *out = (hz_pr_result){.views = d.views, .res = d.res};
    if (d.res < 16 || d.res > 4096 || !(d.rate >= 0.0f && d.rate < 1.0f) || d.views > 1024)
        return hz_err_set(err, HZ_ERR_VALUE, "pr: bad parameters (resolution %u, rate %g, views %u)", d.res,
                          (double)d.rate, d.views);
    itembuf ib;
    hz_result res = ib_create(&ib, t, d.res, d.res, err);
    if (res != HZ_OK)
        return res;
    const uint32_t nn = t->node_count;
    GLint *first = malloc((nn ? nn : 1) * sizeof *first);
    GLsizei *full = malloc((nn ? nn : 1) * sizeof *full), *kept = malloc((nn ? nn : 1) * sizeof *kept);
    float *ones = malloc((nn ? nn : 1) * sizeof *ones), *scales = malloc((nn ? nn : 1) * sizeof *scales);
    uint32_t *a = malloc((size_t)d.res * d.res * sizeof *a), *b = malloc((size_t)d.res * d.res * sizeof *b);
    float *cov = d.enlarge ? malloc((t->leaf_count ? t->leaf_count : 1) * sizeof *cov) : NULL;
    if (!first || !full || !kept || !ones || !scales || !a || !b || (d.enlarge && !cov)) {
        res = hz_err_set(err, HZ_ERR_MEMORY, "pr: out of memory");
        goto done;
    }
    if (d.enlarge && (res = hz_tree_prefix_coverage(t, cov, err)) != HZ_OK)
        goto done;
    hz_rate_params rp = hz_rate_params_defaults(NULL);
    rp.max_enlarge = 100.0f;
    for (uint32_t n = 0; n < nn; n++) {
        const hz_tree_node *nd = &t->nodes[n];
        uint32_t k = (uint32_t)ceilf((1.0f - d.rate) * (float)nd->count - 1e-4f);
        if (k < 1)
            k = 1;
        first[n] = (GLint)(nd->first * 6);
        full[n] = (GLsizei)(nd->count * 6);
        kept[n] = (GLsizei)(k * 6);
        ones[n] = 1.0f;
        /* F4 by coverage: the kept prefix grows to cover its node's area */
        scales[n] = d.enlarge ? hz_enlarge_coverage(rp.max_enlarge, cov[nd->first + k - 1]) : 1.0f;
    }
    /* Views around the crown: 8 azimuths at 0 and 35 degrees elevation
     * (then more rings if more views are asked), framing the leaves. */
    const float fov = 40.0f * 0.0174532925f;
    const float dist = t->crown_radius / sinf(0.5f * fov);
    for (uint32_t v = 0; v < d.views; v++) {
        float az = 6.2831853f * ((float)(v % 8) + 0.5f * (float)((v / 8) % 2)) / 8.0f;
        float el = (float)((v / 8) % 3) * 35.0f * 0.0174532925f;
        hz_camera cam = {.pos = {t->crown_center[0] + dist * cosf(el) * sinf(az),
                                 t->crown_center[1] + dist * sinf(el),
                                 t->crown_center[2] + dist * cosf(el) * cosf(az)},
                         .yaw = -az * 57.29578f, .pitch = -el * 57.29578f, .fov_y = 40.0f, .aspect = 1.0f,
                         .znear = 0.1f * dist, .zfar = 4.0f * dist};
        mat4 vp;
        hz_camera_viewproj(&cam, vp);
        for (int pass = 0; pass < 2; pass++) {
            hz_gl_buffer_texture(&ib.scale_buf, &ib.scale_tex, GL_R32F, pass ? scales : ones, nn * sizeof(float), GL_DYNAMIC_DRAW);
            ib_begin(&ib, 2); /* leaf ids: coverage is id != 0 */
            glUniformMatrix4fv(ib.u_viewproj, 1, GL_FALSE, (const float *)vp);
            multi_draw md = {first, pass ? kept : full, (GLsizei)nn};
            ib_layer(&ib, 0, draw_multi, &md);
            ib_read(&ib, pass ? b : a);
            ib_end();
        }
        res = hz_gl_check(err, "coverage rendering");
        if (res != HZ_OK)
            goto done;
        for (size_t p = 0; p < (size_t)d.res * d.res; p++) {
            bool x = a[p] != 0, y = b[p] != 0, same = a[p] == b[p];
            out->tp += x && y;
            out->fp += !x && y;
            out->fn += x && !y;
            out->leaf_tp += x && same;
            out->leaf_fp += y && !same;
            out->leaf_fn += x && !same;
        }
    }
    pr_ratios(out->tp, out->fp, out->fn, &out->precision, &out->recall, &out->f_measure);
    pr_ratios(out->leaf_tp, out->leaf_fp, out->leaf_fn, &out->leaf_precision, &out->leaf_recall,
              &out->leaf_f_measure);
done:
    free(first);
    free(full);
    free(kept);
    free(ones);
    free(scales);
    free(cov);
    free(a);
    free(b);
    ib_destroy(&ib);
    return res;
}

hz_tree *hz_tree_shuffled(const hz_tree *t, uint64_t seed, hz_err *err)
{
    uint8_t *data = NULL;
    size_t size = 0;
    if (hz_tree_save_mem(t, &data, &size, err) != HZ_OK)
        return NULL;
    hz_tree *c = hz_tree_load_mem(data, size, err);
    free(data);
    if (!c)
        return NULL;
    uint32_t *ord = malloc((c->leaf_count ? c->leaf_count : 1) * sizeof *ord);
    if (!ord) {
        hz_tree_destroy(c);
        hz_err_set(err, HZ_ERR_MEMORY, "out of memory");
        return NULL;
    }
    uint64_t s = seed * 0x9E3779B97F4A7C15ULL + 1;
    for (uint32_t n = 0; n < c->node_count; n++) {
        uint32_t *o = ord + c->nodes[n].first, cnt = c->nodes[n].count;
        for (uint32_t k = 0; k < cnt; k++)
            o[k] = k;
        for (uint32_t k = cnt; k > 1; k--) {
            s ^= s << 13, s ^= s >> 7, s ^= s << 17;
            uint32_t j = (uint32_t)(s % k);
            uint32_t tmp = o[k - 1];
            o[k - 1] = o[j];
            o[j] = tmp;
        }
    }
    hz_result r = hz_tree_apply_order(c, ord, err);
    free(ord);
    if (r != HZ_OK) {
        hz_tree_destroy(c);
        return NULL;
    }
    c->ranked = false;
    return c;
}

hz_result hz_tree_pr_random(const hz_tree *t, const hz_pr_desc *desc, uint32_t shuffles, uint64_t seed,
                            hz_pr_result *out, hz_pr_result *each, hz_err *err)
{
    hz_err local = {0};
    if (!err)
        err = &local;
    *out = (hz_pr_result){0};
    if (shuffles < 1 || shuffles > HZ_PR_ORDERS_MAX)
        return hz_err_set(err, HZ_ERR_VALUE, "pr: %u random orders (1..%u)", shuffles, HZ_PR_ORDERS_MAX);
    for (uint32_t k = 0; k < shuffles; k++) {
        hz_tree *rnd = hz_tree_shuffled(t, seed + k, err);
        if (!rnd)
            return err->code != HZ_OK ? err->code : HZ_ERR_MEMORY;
        hz_pr_result r;
        hz_result res = hz_tree_pr(rnd, desc, &r, err);
        hz_tree_destroy(rnd);
        if (res != HZ_OK)
            return res;
        if (each)
            each[k] = r;
        out->views = r.views;
        out->res = r.res;
        out->tp += r.tp;
        out->fp += r.fp;
        out->fn += r.fn;
        out->leaf_tp += r.leaf_tp;
        out->leaf_fp += r.leaf_fp;
        out->leaf_fn += r.leaf_fn;
    }
    pr_ratios(out->tp, out->fp, out->fn, &out->precision, &out->recall, &out->f_measure);
    pr_ratios(out->leaf_tp, out->leaf_fp, out->leaf_fn, &out->leaf_precision, &out->leaf_recall,
              &out->leaf_f_measure);
    return HZ_OK;
}
