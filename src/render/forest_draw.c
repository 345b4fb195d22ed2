/* Forest drawing, one LOD chain per tree: VMI leaf prefixes near, the crown
 * hull shaded from the tree's own impostor in the middle, image impostors
 * far, cross-faded by dithering. Models live on the GPU once: leaves
 * interleaved by rank within node groups, with a static quad index buffer
 * (a tree draws, per group, the range holding its kept leaves; the vertex
 * shader drops leaves beyond their node's kept count, read from a
 * persistent per-(tree, node) buffer of which only changed ranges are
 * uploaded) or as points where leaves are a few pixels long, bark and hull
 * meshes, and an impostor atlas baked from the full tree (albedo + normals,
 * several views). Far trees are one draw over a static buffer of all trees.
 * Drawn through the renderer's object hook so fog and reflections apply. */
#include "horizon/forest_render.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <xxhash.h>

#include "gl_util.h"
#include "hz_shaders.h"

/* Leaves at most this many pixels long (the tree's nearest leaves, mean
 * size, before enlargement) are drawn as points: one vertex each instead of
 * four, one point instead of two triangles. Larger leaves keep quads, whose
 * depth varies across the leaf. At 24 (16 before) the forest bench's leaves
 * take 14-17.5 ms instead of 19.4-21.9; up to this size the points cover
 * the quads' pixels to within 0.34 % (test_point_leaves_match_quads). */
#define POINT_LEAF_PX 24.0f

/* Impostor atlas: IMP_AZ azimuths x IMP_EL elevation rows (0, 25, 50, 75
 * degrees) of IMP_TILE pixels, one texture-array layer per model. */
#define IMP_AZ 12
#define IMP_EL 4
#define IMP_EL_STEP 0.436332313f /* 25 degrees */
#define IMP_TILE 128

typedef struct mesh_gpu {
    GLuint vao, vbo, ibo;
    uint32_t count;
} mesh_gpu;

typedef struct model_gpu {
    GLuint leaf_buf, leaf_tex;
    GLuint quad_ibo;        /* 6 indices per leaf position: 4p + 0,1,2, 0,2,3 */
    GLuint point_vao;       /* leaf_buf as vertex attributes (points) */
    mesh_gpu bark, hull;
    uint32_t bark_level_end[HZ_TREE_MAX_LEVELS];
    float leaf_size;        /* mean leaf length (model units): points or quads */
} model_gpu;

typedef struct prog_u {
    GLint leaves, kept, scales, kept_base, model, viewproj, mvp, clip, color, sun, sky, eye, fog, ambient,
        dither, albedo, normals, layer, tile, right, up, bound, trees, models, order, band, max_dist, views,
        el_step, rects, px_scale, tile_px, max_lod, lod, size, viewport, tree_eye, sun_model;
} prog_u;

struct hz_forest_gpu {
    model_gpu *m;
    uint32_t nm;
    GLuint leaf_prog, point_prog, bark_prog, hull_prog, imp_prog;
    prog_u lu, pu, bu, hu, iu;
    GLuint empty_vao;
    GLuint kept_buf, kept_tex;  /* R32UI per (tree, node) */
    GLuint scale_buf, scale_tex;/* R32F per (tree, node) */
    GLuint tree_buf, tree_tex;  /* impostor data per tree */
    GLuint model_buf, model_tex;
    GLuint order_buf, order_tex;  /* R32UI: the frame's impostor trees */
    GLuint rect_buf, rect_tex;    /* RGBA32F per (model, view): the image's extent in its tile */
    GLuint atlas[2];            /* albedo, normals: RGBA8 arrays */
    bool *baked;                /* per model: baked here (not given by hz_forest_gpu_desc) */
    uint32_t tree_count;
    size_t node_total;
    uint64_t last_serial;       /* frame whose counts were uploaded last */
    uint64_t upload_bytes;      /* of the last frame */
    float point_px;             /* hz_forest_gpu_point_leaves */
    uint32_t point_trees;       /* of the last main pass */
    bool time_parts;
    double part_ms[3];
};

static void get_u(GLuint p, prog_u *u)
{
    u->leaves = glGetUniformLocation(p, "u_leaves");
    u->kept = glGetUniformLocation(p, "u_kept");
    u->kept_base = glGetUniformLocation(p, "u_kept_base");
    u->scales = glGetUniformLocation(p, "u_scales");
    u->model = glGetUniformLocation(p, "u_model");
    u->viewproj = glGetUniformLocation(p, "u_viewproj");
    u->clip = glGetUniformLocation(p, "u_clip_plane");
    u->mvp = glGetUniformLocation(p, "u_mvp");
    u->color = glGetUniformLocation(p, "u_color");
    u->sun = glGetUniformLocation(p, "u_sun_dir");
    u->sky = glGetUniformLocation(p, "u_sky_horizon");
    u->eye = glGetUniformLocation(p, "u_eye");
    u->fog = glGetUniformLocation(p, "u_fog_density");
    u->ambient = glGetUniformLocation(p, "u_ambient");
    u->dither = glGetUniformLocation(p, "u_dither");
    u->albedo = glGetUniformLocation(p, "u_albedo");
    u->normals = glGetUniformLocation(p, "u_normals");
    u->layer = glGetUniformLocation(p, "u_layer");
    u->tile = glGetUniformLocation(p, "u_tile");
    u->right = glGetUniformLocation(p, "u_right");
    u->up = glGetUniformLocation(p, "u_up");
    u->bound = glGetUniformLocation(p, "u_bound");
    u->trees = glGetUniformLocation(p, "u_trees");
    u->models = glGetUniformLocation(p, "u_models");
    u->order = glGetUniformLocation(p, "u_order");
    u->rects = glGetUniformLocation(p, "u_rects");
    u->px_scale = glGetUniformLocation(p, "u_px_scale");
    u->tile_px = glGetUniformLocation(p, "u_tile_px");
    u->max_lod = glGetUniformLocation(p, "u_max_lod");
    u->lod = glGetUniformLocation(p, "u_lod");
    u->size = glGetUniformLocation(p, "u_size");
    u->band = glGetUniformLocation(p, "u_band");
    u->max_dist = glGetUniformLocation(p, "u_max_dist");
    u->views = glGetUniformLocation(p, "u_views");
    u->el_step = glGetUniformLocation(p, "u_el_step");
    u->viewport = glGetUniformLocation(p, "u_viewport");
    u->tree_eye = glGetUniformLocation(p, "u_tree_eye");
    u->sun_model = glGetUniformLocation(p, "u_sun_model");
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
            glDeleteBuffers(1, &g->m[k].quad_ibo);
            glDeleteVertexArrays(1, &g->m[k].point_vao);
            mesh_free(&g->m[k].bark);
            mesh_free(&g->m[k].hull);
        }
        glDeleteProgram(g->leaf_prog);
        glDeleteProgram(g->point_prog);
        glDeleteProgram(g->bark_prog);
        glDeleteProgram(g->hull_prog);
        glDeleteProgram(g->imp_prog);
        glDeleteVertexArrays(1, &g->empty_vao);
        glDeleteBuffers(1, &g->kept_buf);
        glDeleteTextures(1, &g->kept_tex);
        glDeleteBuffers(1, &g->scale_buf);
        glDeleteTextures(1, &g->scale_tex);
        glDeleteBuffers(1, &g->tree_buf);
        glDeleteTextures(1, &g->tree_tex);
        glDeleteBuffers(1, &g->model_buf);
        glDeleteTextures(1, &g->model_tex);
        glDeleteBuffers(1, &g->order_buf);
        glDeleteTextures(1, &g->order_tex);
        glDeleteBuffers(1, &g->rect_buf);
        glDeleteTextures(1, &g->rect_tex);
        glDeleteTextures(2, g->atlas);
    }
    free(g->m);
    free(g->baked);
    free(g);
}

/* A leaf's colour factor: a tint in [0.75, 1.25] per leaf (a hash of its
 * index, so simplification keeps it) times the crown occlusion, darker
 * toward the crown's centre (0.45 there). */
static float leaf_shade(const hz_tree *t, uint32_t leaf)
{
    uint32_t h = leaf * 0x9E3779B1u;
    h ^= h >> 15;
    h *= 0x85EBCA77u;
    h ^= h >> 13;
    float tint = (float)(h >> 8) / 16777216.0f;
    const float *c = t->leaves[leaf].c, *cc = t->crown_center;
    float d = sqrtf((c[0] - cc[0]) * (c[0] - cc[0]) + (c[1] - cc[1]) * (c[1] - cc[1]) + (c[2] - cc[2]) * (c[2] - cc[2]));
    float r = t->crown_radius > 0 ? fminf(d / t->crown_radius, 1.0f) : 1.0f;
    return (0.75f + 0.5f * tint) * (0.45f + 0.55f * r);
}

/* Mip levels of the atlas: down to 1 texel per tile. */
static int imp_levels(void)
{
    int levels = 1;
    for (int s = IMP_TILE; s > 1; s >>= 1)
        levels++;
    return levels;
}

/* The image axes of view (ia, ie) in model space, as the impostor shader
 * derives them: fwd from the viewer toward the tree. */
static void view_axes(int ia, int ie, float right[3], float up[3], float fwd[3])
{
    float az = (float)ia * 6.2831853f / IMP_AZ, el = (float)ie * IMP_EL_STEP;
    float toward[3] = {sinf(az) * cosf(el), sinf(el), cosf(az) * cosf(el)};
    for (int c = 0; c < 3; c++)
        fwd[c] = -toward[c];
    /* right = normalize(cross(fwd, +y)), up = cross(right, fwd) */
    right[0] = -fwd[2], right[1] = 0, right[2] = fwd[0];
    float l = sqrtf(right[0] * right[0] + right[2] * right[2]);
    right[0] /= l, right[2] /= l;
    up[0] = right[1] * fwd[2] - right[2] * fwd[1];
    up[1] = right[2] * fwd[0] - right[0] * fwd[2];
    up[2] = right[0] * fwd[1] - right[1] * fwd[0];
}

/* The view nearest to where a tree is seen from (model-space unit vector
 * from the tree toward the eye), as impostor_vs.glsl picks it. */
static void nearest_view(const float dm[3], int *ia, int *ie)
{
    float az = atan2f(dm[0], dm[2]), el = asinf(fmaxf(-1.0f, fminf(1.0f, dm[1])));
    int a = (int)floorf(az / 6.2831853f * IMP_AZ + 0.5f);
    *ia = ((a % IMP_AZ) + IMP_AZ) % IMP_AZ;
    int e = (int)floorf(el / IMP_EL_STEP + 0.5f);
    *ie = e < 0 ? 0 : e >= IMP_EL ? IMP_EL - 1 : e;
}

static void common_uniforms(GLuint prog, const prog_u *u, const hz_pass_info *pass)
{
    hz_gl_set_curvature(prog, pass->cam);
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

/* Whether a tree's leaves are drawn as points: when its nearest leaves are
 * at most g->point_px across on screen. */
static bool leaf_points(const hz_forest_gpu *g, const hz_forest *f, const hz_forest_draw *dr, const hz_tree *t,
                        float focal_px)
{
    const hz_forest_tree *tr = &hz_forest_trees(f)[dr->tree];
    float near = fmaxf(dr->dist - tr->scale * t->bound_radius, 0.25f);
    return g->m[dr->model].leaf_size * tr->scale * focal_px <= g->point_px * near;
}

/* A detailed tree's leaves: per node group, the range holding its kept
 * leaves (hz_forest_draw), as points or quads. */
static void draw_leaves(const hz_forest_gpu *g, const hz_tree *t, const hz_forest_draw *dr, bool points)
{
    glBindVertexArray(points ? g->m[dr->model].point_vao : g->empty_vao);
    if (!points)
        glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, g->m[dr->model].quad_ibo);
    /* A group drawn whole runs on into the next one: one draw for both (an
     * unsimplified tree is one draw). */
    uint32_t run_first = 0, run_n = 0;
    for (uint32_t k = 0; k <= HZ_FOREST_GROUPS; k++) {
        uint32_t first = 0, n = 0;
        if (k < HZ_FOREST_GROUPS) {
            first = dr->group_first[k];
            uint32_t end = dr->group_first[k + 1] < t->leaf_count ? dr->group_first[k + 1] : t->leaf_count;
            n = first < end ? (dr->group_count[k] < end - first ? dr->group_count[k] : end - first) : 0;
            if (n && run_n && run_first + run_n == first) {
                run_n += n;
                continue;
            }
        }
        if (run_n) {
            if (points)
                glDrawArrays(GL_POINTS, (GLint)run_first, (GLsizei)run_n);
            else
                glDrawElements(GL_TRIANGLES, (GLsizei)((size_t)run_n * 6), GL_UNSIGNED_INT,
                               (const void *)((size_t)run_first * 6 * sizeof(uint32_t)));
        }
        run_first = first, run_n = n;
    }
}

hz_result hz_forest_gpu_sprite(const hz_forest_gpu *g, const hz_forest *f, uint32_t model, float width_frac,
                               uint32_t w, uint32_t h, uint8_t *rgba, hz_err *err)
{
    if (model >= g->nm || !rgba || w == 0 || h == 0 || w > 4096 || h > 4096 || !(width_frac > 0.05f) ||
        !(width_frac <= 4.0f))
        return hz_err_set(err, HZ_ERR_VALUE, "forest sprite: bad arguments (model %u of %u, %ux%u, width %g)", model,
                          g->nm, w, h, (double)width_frac);
    if (!hz_gl_has_context())
        return hz_err_set(err, HZ_ERR_GL, "forest sprite: no current OpenGL context");
    /* The side view (azimuth 0, elevation 0: image x = model x, y = model y),
     * level 0, premultiplied albedo. */
    uint8_t *tile = malloc((size_t)IMP_TILE * IMP_TILE * 4);
    if (!tile)
        return hz_err_set(err, HZ_ERR_MEMORY, "out of memory");
    hz_gl_drain();
    GLint old_read = 0;
    glGetIntegerv(GL_READ_FRAMEBUFFER_BINDING, &old_read);
    GLuint fbo;
    glGenFramebuffers(1, &fbo);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo);
    glFramebufferTextureLayer(GL_READ_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, g->atlas[0], 0, (GLint)model);
    glReadBuffer(GL_COLOR_ATTACHMENT0);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glReadPixels(0, 0, IMP_TILE, IMP_TILE, GL_RGBA, GL_UNSIGNED_BYTE, tile);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, (GLuint)old_read);
    glDeleteFramebuffers(1, &fbo);
    hz_result r = hz_gl_check(err, "forest sprite");
    if (r != HZ_OK) {
        free(tile);
        return r;
    }
    /* Model-space extent the image shows: the tile frames the bounding
     * sphere; the sprite stands on the foot (y = 0) and reaches the tree's
     * top, or higher when the crown is wider than width_frac of that. */
    const hz_tree *t = hz_forest_model(f, model);
    const float *bc = t->bound_center, R = t->bound_radius;
    int top_row = -1;
    float half_w = 0.0f;
    for (int y = 0; y < IMP_TILE; y++)
        for (int x = 0; x < IMP_TILE; x++)
            if (tile[((size_t)y * IMP_TILE + (size_t)x) * 4 + 3] >= 128) {
                top_row = y > top_row ? y : top_row;
                float mx = fabsf(bc[0] + R * (2.0f * ((float)x + 0.5f) / IMP_TILE - 1.0f));
                half_w = fmaxf(half_w, mx);
            }
    float top = top_row >= 0 ? bc[1] + R * (2.0f * ((float)top_row + 1.0f) / IMP_TILE - 1.0f) : bc[1] + R;
    float height = fmaxf(fmaxf(top, 2.0f * half_w / width_frac), 1e-3f);
    for (uint32_t row = 0; row < h; row++) {
        float my = height * (1.0f - ((float)row + 0.5f) / (float)h); /* top row first */
        for (uint32_t col = 0; col < w; col++) {
            float mx = width_frac * height * (((float)col + 0.5f) / (float)w - 0.5f);
            /* bilinear in the tile, premultiplied */
            float tx = ((mx - bc[0]) / R * 0.5f + 0.5f) * IMP_TILE - 0.5f;
            float ty = ((my - bc[1]) / R * 0.5f + 0.5f) * IMP_TILE - 0.5f;
            float acc[4] = {0, 0, 0, 0};
            int x0 = (int)floorf(tx), y0 = (int)floorf(ty);
            float fx = tx - (float)x0, fy = ty - (float)y0;
            for (int dy = 0; dy < 2; dy++)
                for (int dx = 0; dx < 2; dx++) {
                    int xx = x0 + dx, yy = y0 + dy;
                    if (xx < 0 || yy < 0 || xx >= IMP_TILE || yy >= IMP_TILE)
                        continue;
                    float wt = (dx ? fx : 1.0f - fx) * (dy ? fy : 1.0f - fy);
                    const uint8_t *p = tile + ((size_t)yy * IMP_TILE + (size_t)xx) * 4;
                    for (int c = 0; c < 4; c++)
                        acc[c] += wt * (float)p[c];
                }
            uint8_t *o = rgba + ((size_t)row * w + col) * 4;
            for (int c = 0; c < 3; c++)
                o[c] = (uint8_t)fminf(255.0f, acc[3] > 0.5f ? acc[c] / acc[3] * 255.0f + 0.5f : 0.0f);
            o[3] = (uint8_t)fminf(255.0f, acc[3] + 0.5f);
        }
    }
    free(tile);
    return HZ_OK;
}

/* Bakes every model's impostor atlas: the full tree (leaves and bark)
 * orthographically from each view, framing its bounding sphere; albedo
 * unlit, normals in model space; mipmapped. */
/* Views rendered between two glFinish calls while baking. llvmpipe bins a
 * whole scene before it rasterises; 48 views of a 100 000-leaf tree queued at
 * once took up to 1 GB more peak memory than 4 at a time (which costs about
 * 10 % more bake time than none). */
#define BAKE_FINISH_EVERY 4
_Static_assert((IMP_AZ * IMP_EL) % BAKE_FINISH_EVERY == 0, "progress counts whole groups of views");

/* Bakes the atlas layer of every model that was not given (given[model]:
 * its level 0, albedo then normals, as hz_forest_gpu_impostor_read gives it),
 * uploads the given ones, then builds the mipmaps and each view's extent. */
static hz_result bake_impostors(hz_forest_gpu *g, const hz_forest *f, GLuint leaf_bake, GLuint bark_bake,
                                const hz_forest_gpu_desc *desc, hz_err *err)
{
    const uint8_t *const *given = desc ? desc->impostors : NULL;
    const hz_progress_fn progress = desc ? desc->progress : NULL;
    uint64_t views_done = 0, views_total = 0;
    for (uint32_t mi = 0; mi < g->nm; mi++)
        views_total += (given && given[mi]) ? 0 : (uint64_t)IMP_AZ * IMP_EL;
    if (progress && views_total)
        progress(desc->progress_user, "bake impostors", 0, views_total);
    const GLsizei W = IMP_AZ * IMP_TILE, H = IMP_EL * IMP_TILE;
    GLint old_fbo = 0, old_vp[4];
    glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &old_fbo);
    glGetIntegerv(GL_VIEWPORT, old_vp);
    glGenTextures(2, g->atlas);
    for (int k = 0; k < 2; k++) {
        glBindTexture(GL_TEXTURE_2D_ARRAY, g->atlas[k]);
        glTexStorage3D(GL_TEXTURE_2D_ARRAY, imp_levels(), GL_RGBA8, W, H, (GLsizei)g->nm);
        glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_NEAREST);
        glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
        glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
        glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    }
    GLuint fbo = 0, depth = 0;
    glGenFramebuffers(1, &fbo);
    glGenRenderbuffers(1, &depth);
    glBindRenderbuffer(GL_RENDERBUFFER, depth);
    glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT24, W, H);
    glBindFramebuffer(GL_FRAMEBUFFER, fbo);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth);
    const GLenum bufs[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
    glDrawBuffers(2, bufs);
    glDisable(GL_BLEND);
    glDisable(GL_SCISSOR_TEST);
    glDisable(GL_CULL_FACE);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glDepthMask(GL_TRUE);
    prog_u lu, bu;
    get_u(leaf_bake, &lu);
    get_u(bark_bake, &bu);
    hz_result r = HZ_OK;
    for (uint32_t mi = 0; mi < g->nm && r == HZ_OK; mi++) {
        const hz_tree *t = hz_forest_model(f, mi);
        g->baked[mi] = !(given && given[mi]);
        if (!g->baked[mi]) {
            glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
            glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
            for (int k = 0; k < 2; k++) {
                glBindTexture(GL_TEXTURE_2D_ARRAY, g->atlas[k]);
                glTexSubImage3D(GL_TEXTURE_2D_ARRAY, 0, 0, 0, (GLint)mi, W, H, 1, GL_RGBA, GL_UNSIGNED_BYTE,
                                given[mi] + (size_t)k * W * H * 4);
            }
            glBindTexture(GL_TEXTURE_2D_ARRAY, 0);
            continue;
        }
        for (int k = 0; k < 2; k++)
            glFramebufferTextureLayer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0 + k, g->atlas[k], 0, (GLint)mi);
        if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
            r = hz_err_set(err, HZ_ERR_GL, "forest: impostor framebuffer incomplete");
            break;
        }
        glViewport(0, 0, W, H);
        const float zero[4] = {0, 0, 0, 0};
        glClearBufferfv(GL_COLOR, 0, zero);
        glClearBufferfv(GL_COLOR, 1, zero);
        glClearDepth(1.0);
        glClear(GL_DEPTH_BUFFER_BIT);
        const float *c = t->bound_center, R = t->bound_radius;
        const float ident[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
        for (int ie = 0; ie < IMP_EL; ie++)
            for (int ia = 0; ia < IMP_AZ; ia++) {
                float right[3], up[3], fwd[3];
                view_axes(ia, ie, right, up, fwd);
                /* clip = ((p-c).right / R, (p-c).up / R, ((p-c).fwd + R) / 2R, 1): z in [0, 1]
                 * whatever the clip-control depth range. */
                float vp[16] = {0};
                for (int a = 0; a < 3; a++) {
                    vp[a * 4 + 0] = right[a] / R;
                    vp[a * 4 + 1] = up[a] / R;
                    vp[a * 4 + 2] = fwd[a] / (2 * R);
                }
                vp[12] = -(c[0] * right[0] + c[1] * right[1] + c[2] * right[2]) / R;
                vp[13] = -(c[0] * up[0] + c[1] * up[1] + c[2] * up[2]) / R;
                vp[14] = (R - (c[0] * fwd[0] + c[1] * fwd[1] + c[2] * fwd[2])) / (2 * R);
                vp[15] = 1;
                float eye[3];
                for (int a = 0; a < 3; a++)
                    eye[a] = c[a] - fwd[a] * 100.0f * R;
                glViewport(ia * IMP_TILE, ie * IMP_TILE, IMP_TILE, IMP_TILE);
                /* leaves, all of them */
                glUseProgram(leaf_bake);
                glUniformMatrix4fv(lu.viewproj, 1, GL_FALSE, vp);
                glUniformMatrix4fv(lu.model, 1, GL_FALSE, ident);
                glUniform4f(lu.clip, 0, 0, 0, 1);
                glUniform3fv(lu.eye, 1, eye);
                glUniform3fv(lu.color, 1, t->leaf_color);
                glUniform1i(lu.kept_base, -1);
                glUniform1i(lu.leaves, 0);
                glUniform1i(lu.kept, 1);
                glUniform1i(lu.scales, 6);
                glActiveTexture(GL_TEXTURE0);
                glBindTexture(GL_TEXTURE_BUFFER, g->m[mi].leaf_tex);
                glActiveTexture(GL_TEXTURE1);
                glBindTexture(GL_TEXTURE_BUFFER, g->kept_tex);
                glActiveTexture(GL_TEXTURE0);
                glBindVertexArray(g->empty_vao);
                glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, g->m[mi].quad_ibo);
                glDrawElements(GL_TRIANGLES, (GLsizei)((size_t)t->leaf_count * 6), GL_UNSIGNED_INT, (const void *)0);
                /* bark, all levels */
                glUseProgram(bark_bake);
                glUniformMatrix4fv(bu.viewproj, 1, GL_FALSE, vp);
                glUniformMatrix4fv(bu.model, 1, GL_FALSE, ident);
                glUniform4f(bu.clip, 0, 0, 0, 1);
                glUniform3fv(bu.color, 1, t->bark_color);
                if (g->m[mi].bark.count) {
                    glBindVertexArray(g->m[mi].bark.vao);
                    glDrawElements(GL_TRIANGLES, (GLsizei)g->m[mi].bark.count, GL_UNSIGNED_INT, (const void *)0);
                }
                if ((ie * IMP_AZ + ia + 1) % BAKE_FINISH_EVERY == 0) {
                    glFinish();
                    views_done += BAKE_FINISH_EVERY;
                    if (progress)
                        progress(desc->progress_user, "bake impostors", views_done, views_total);
                }
            }
    }
    glBindVertexArray(0);
    glUseProgram(0);
    glActiveTexture(GL_TEXTURE1);
    glBindTexture(GL_TEXTURE_BUFFER, 0);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_BUFFER, 0);
    glBindFramebuffer(GL_FRAMEBUFFER, (GLuint)old_fbo);
    glViewport(old_vp[0], old_vp[1], old_vp[2], old_vp[3]);
    glDeleteFramebuffers(1, &fbo);
    glDeleteRenderbuffers(1, &depth);
    for (int k = 0; k < 2; k++) {
        glBindTexture(GL_TEXTURE_2D_ARRAY, g->atlas[k]);
        glGenerateMipmap(GL_TEXTURE_2D_ARRAY);
    }
    if (r != HZ_OK) {
        glBindTexture(GL_TEXTURE_2D_ARRAY, 0);
        return r;
    }
    /* Each view's extent in its tile (texels with any coverage, one texel
     * of margin), so impostor quads cover little more than the tree. */
    const size_t nt = (size_t)IMP_AZ * IMP_EL;
    uint8_t *px = malloc((size_t)W * H * 4 * g->nm);
    float *rects = malloc(nt * g->nm * 16);
    if (!px || !rects) {
        free(px);
        free(rects);
        glBindTexture(GL_TEXTURE_2D_ARRAY, 0);
        return hz_err_set(err, HZ_ERR_MEMORY, "out of memory");
    }
    glBindTexture(GL_TEXTURE_2D_ARRAY, g->atlas[0]);
    glPixelStorei(GL_PACK_ALIGNMENT, 4);
    glPixelStorei(GL_PACK_ROW_LENGTH, 0);
    glGetTexImage(GL_TEXTURE_2D_ARRAY, 0, GL_RGBA, GL_UNSIGNED_BYTE, px);
    glBindTexture(GL_TEXTURE_2D_ARRAY, 0);
    for (uint32_t mi = 0; mi < g->nm; mi++)
        for (size_t tl = 0; tl < nt; tl++) {
            int tx = (int)(tl % IMP_AZ) * IMP_TILE, ty = (int)(tl / IMP_AZ) * IMP_TILE;
            int x0 = IMP_TILE, y0 = IMP_TILE, x1 = -1, y1 = -1;
            for (int y = 0; y < IMP_TILE; y++)
                for (int x = 0; x < IMP_TILE; x++)
                    if (px[(((size_t)mi * H + (size_t)(ty + y)) * W + (size_t)(tx + x)) * 4 + 3]) {
                        x0 = x < x0 ? x : x0, x1 = x > x1 ? x : x1;
                        y0 = y < y0 ? y : y0, y1 = y > y1 ? y : y1;
                    }
            float *o = rects + (mi * nt + tl) * 4;
            if (x1 < 0) {
                o[0] = o[1] = o[2] = o[3] = 0.0f; /* empty view: a zero-area quad */
                continue;
            }
            o[0] = fmaxf(-1.0f, 2.0f * (float)(x0 - 1) / IMP_TILE - 1.0f);
            o[1] = fmaxf(-1.0f, 2.0f * (float)(y0 - 1) / IMP_TILE - 1.0f);
            o[2] = fminf(1.0f, 2.0f * (float)(x1 + 2) / IMP_TILE - 1.0f);
            o[3] = fminf(1.0f, 2.0f * (float)(y1 + 2) / IMP_TILE - 1.0f);
        }
    hz_gl_buffer_texture(&g->rect_buf, &g->rect_tex, GL_RGBA32F, rects, nt * g->nm * 16, GL_STATIC_DRAW);
    free(px);
    free(rects);
    return hz_gl_check(err, "forest impostor bake");
}

hz_forest_gpu *hz_forest_gpu_create(const hz_forest *f, hz_err *err)
{
    return hz_forest_gpu_create_with(f, NULL, err);
}

hz_forest_gpu *hz_forest_gpu_create_with(const hz_forest *f, const hz_forest_gpu_desc *desc, hz_err *err)
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
    GLuint leaf_bake = 0, bark_bake = 0;
    hz_gl_drain();
    g->nm = hz_forest_model_count(f);
    g->m = calloc(g->nm, sizeof *g->m);
    g->baked = calloc(g->nm ? g->nm : 1, sizeof *g->baked);
    if (!g->m || !g->baked) {
        hz_err_set(err, HZ_ERR_MEMORY, "out of memory");
        goto fail;
    }
    g->leaf_prog = hz_gl_program(hz_shader_leaf_vs, hz_shader_leaf_fs, "leaf", err);
    if (!g->leaf_prog)
        goto fail;
    g->point_prog = hz_gl_program(hz_shader_leaf_point_vs, hz_shader_leaf_point_fs, "leaf_point", err);
    if (!g->point_prog)
        goto fail;
    g->bark_prog = hz_gl_program(hz_shader_bark_vs, hz_shader_bark_fs, "bark", err);
    if (!g->bark_prog)
        goto fail;
    g->hull_prog = hz_gl_program_defs(hz_shader_bark_vs, hz_shader_bark_fs, "#define BARK_HULL 1\n", "bark", err);
    if (!g->hull_prog)
        goto fail;
    g->imp_prog = hz_gl_program(hz_shader_impostor_vs, hz_shader_impostor_fs, "impostor", err);
    if (!g->imp_prog)
        goto fail;
    leaf_bake = hz_gl_program(hz_shader_leaf_vs, hz_shader_leaf_bake_fs, "leaf_bake", err);
    bark_bake = leaf_bake ? hz_gl_program(hz_shader_bark_vs, hz_shader_bark_bake_fs, "bark_bake", err) : 0;
    if (!bark_bake)
        goto fail;
    get_u(g->leaf_prog, &g->lu);
    get_u(g->point_prog, &g->pu);
    get_u(g->bark_prog, &g->bu);
    get_u(g->hull_prog, &g->hu);
    get_u(g->imp_prog, &g->iu);
    glGenVertexArrays(1, &g->empty_vao);
    g->point_px = POINT_LEAF_PX;
    /* Per (tree, node) kept counts, filled as trees become detailed. */
    const hz_forest_tree *trees = hz_forest_trees(f);
    g->tree_count = hz_forest_tree_count(f);
    for (uint32_t k = 0; k < g->tree_count; k++)
        g->node_total += hz_forest_model(f, trees[k].model)->node_count;
    hz_gl_buffer_texture(&g->kept_buf, &g->kept_tex, GL_R32UI, NULL, g->node_total * 4, GL_DYNAMIC_DRAW);
    hz_gl_buffer_texture(&g->scale_buf, &g->scale_tex, GL_R32F, NULL, g->node_total * 4, GL_DYNAMIC_DRAW);
    float *td = malloc((size_t)(g->tree_count ? g->tree_count : 1) * 32);
    float *md = malloc((size_t)g->nm * 16);
    if (!td || !md) {
        free(td);
        free(md);
        hz_err_set(err, HZ_ERR_MEMORY, "out of memory");
        goto fail;
    }
    for (uint32_t k = 0; k < g->tree_count; k++) {
        const hz_forest_tree *tr = &trees[k];
        float *o = td + (size_t)k * 8;
        o[0] = tr->pos[0], o[1] = tr->pos[1], o[2] = tr->pos[2], o[3] = tr->yaw;
        o[4] = tr->scale, o[5] = (float)tr->model, o[6] = 0, o[7] = 0;
    }
    for (uint32_t k = 0; k < g->nm; k++) {
        const hz_tree *t = hz_forest_model(f, k);
        md[k * 4 + 0] = t->bound_center[0], md[k * 4 + 1] = t->bound_center[1];
        md[k * 4 + 2] = t->bound_center[2], md[k * 4 + 3] = t->bound_radius;
    }
    hz_gl_buffer_texture(&g->tree_buf, &g->tree_tex, GL_RGBA32F, td, (size_t)g->tree_count * 32, GL_STATIC_DRAW);
    hz_gl_buffer_texture(&g->model_buf, &g->model_tex, GL_RGBA32F, md, (size_t)g->nm * 16, GL_STATIC_DRAW);
    hz_gl_buffer_texture(&g->order_buf, &g->order_tex, GL_R32UI, NULL, (size_t)(g->tree_count ? g->tree_count : 1) * 4,
                   GL_STREAM_DRAW);
    free(td);
    free(md);
    for (uint32_t k = 0; k < g->nm; k++) {
        const hz_tree *t = hz_forest_model(f, k);
        const uint32_t *order = hz_forest_model_order(f, k);
        model_gpu *m = &g->m[k];
        /* leaf texels in interleaved rank order: (c, node), (u, rank), (v, node size) */
        float *d = malloc((size_t)t->leaf_count * 48 + 16);
        uint32_t *q = malloc((size_t)t->leaf_count * 24 + 16);
        uint32_t *node_of = malloc((size_t)t->leaf_count * 4 + 16);
        if (!d || !q || !node_of) {
            free(d);
            free(q);
            free(node_of);
            hz_err_set(err, HZ_ERR_MEMORY, "out of memory");
            goto fail;
        }
        for (uint32_t l = 0; l < t->leaf_count; l++)
            node_of[l] = UINT32_MAX;
        for (uint32_t n = 0; n < t->node_count; n++)
            for (uint32_t l = t->nodes[n].first; l < t->nodes[n].first + t->nodes[n].count; l++)
                node_of[l] = n;
        double size_sum = 0;
        for (uint32_t p = 0; p < t->leaf_count; p++) {
            uint32_t l = order[p], n = node_of[l];
            const hz_tree_leaf *lf = &t->leaves[l];
            float *o = d + (size_t)p * 12;
            bool in_node = n != UINT32_MAX;
            o[0] = lf->c[0], o[1] = lf->c[1], o[2] = lf->c[2], o[3] = in_node ? (float)n : 0.0f;
            o[4] = lf->u[0], o[5] = lf->u[1], o[6] = lf->u[2], o[7] = in_node ? (float)(l - t->nodes[n].first) : 0.0f;
            o[8] = lf->v[0], o[9] = lf->v[1], o[10] = lf->v[2], o[11] = leaf_shade(t, l);
            static const uint32_t qi[6] = {0, 1, 2, 0, 2, 3};
            for (int j = 0; j < 6; j++)
                q[(size_t)p * 6 + j] = 4 * p + qi[j];
            float lu = sqrtf(lf->u[0] * lf->u[0] + lf->u[1] * lf->u[1] + lf->u[2] * lf->u[2]);
            float lv = sqrtf(lf->v[0] * lf->v[0] + lf->v[1] * lf->v[1] + lf->v[2] * lf->v[2]);
            size_sum += 2.0 * fmax(lu, lv);
        }
        free(node_of);
        m->leaf_size = t->leaf_count ? (float)(size_sum / t->leaf_count) : 0.0f;
        hz_gl_buffer_texture(&m->leaf_buf, &m->leaf_tex, GL_RGBA32F, d, (size_t)t->leaf_count * 48, GL_STATIC_DRAW);
        glGenVertexArrays(1, &m->point_vao);
        glBindVertexArray(m->point_vao);
        glBindBuffer(GL_ARRAY_BUFFER, m->leaf_buf);
        for (GLuint a = 0; a < 3; a++) {
            glEnableVertexAttribArray(a);
            glVertexAttribPointer(a, 4, GL_FLOAT, GL_FALSE, 48, (const void *)(uintptr_t)(a * 16));
        }
        glBindVertexArray(0);
        glBindBuffer(GL_ARRAY_BUFFER, 0);
        free(d);
        glGenBuffers(1, &m->quad_ibo);
        glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, m->quad_ibo);
        glBufferData(GL_ELEMENT_ARRAY_BUFFER, (GLsizeiptr)((size_t)t->leaf_count * 24 + 16), q, GL_STATIC_DRAW);
        glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, 0);
        free(q);
        mesh_upload(&m->bark, &t->bark, t->bark.index_count);
        const hz_tree_mesh *hull = hz_forest_model_hull(f, k);
        mesh_upload(&m->hull, hull, hull->index_count);
        memcpy(m->bark_level_end, t->bark_level_end, sizeof m->bark_level_end);
    }
    if (hz_gl_check(err, "forest upload") != HZ_OK)
        goto fail;
    if (bake_impostors(g, f, leaf_bake, bark_bake, desc, err) != HZ_OK)
        goto fail;
    glDeleteProgram(leaf_bake);
    glDeleteProgram(bark_bake);
    return g;
fail:
    if (hz_gl_has_context()) {
        glDeleteProgram(leaf_bake);
        glDeleteProgram(bark_bake);
    }
    hz_forest_gpu_destroy(g);
    return NULL;
}

size_t hz_forest_gpu_impostor_bytes(void)
{
    return (size_t)2 * IMP_AZ * IMP_TILE * IMP_EL * IMP_TILE * 4;
}

/* What a model's baked impostor depends on, hashed: its leaves (in order:
 * the tint is a hash of the leaf), nodes, bark, colours and spheres, the
 * bake's shaders and layout. Bump BAKE_VERSION when the bake's C code
 * changes what it draws. */
#define BAKE_VERSION 1u

uint64_t hz_forest_gpu_impostor_key(const hz_tree *t)
{
    XXH3_state_t *st = XXH3_createState();
    if (!st)
        return 0;
    XXH3_64bits_reset(st);
    const uint32_t head[6] = {BAKE_VERSION, IMP_AZ, IMP_EL, IMP_TILE, t->leaf_count, t->node_count};
    XXH3_64bits_update(st, head, sizeof head);
    XXH3_64bits_update(st, t->leaves, (size_t)t->leaf_count * sizeof *t->leaves);
    for (uint32_t n = 0; n < t->node_count; n++) {
        const uint32_t nd[3] = {t->nodes[n].branch, t->nodes[n].first, t->nodes[n].count};
        XXH3_64bits_update(st, nd, sizeof nd);
    }
    const uint32_t bark[2] = {t->bark.vertex_count, t->bark.index_count};
    XXH3_64bits_update(st, bark, sizeof bark);
    if (t->bark.vertex_count) {
        XXH3_64bits_update(st, t->bark.pos, (size_t)t->bark.vertex_count * 12);
        XXH3_64bits_update(st, t->bark.nrm, (size_t)t->bark.vertex_count * 12);
    }
    if (t->bark.index_count)
        XXH3_64bits_update(st, t->bark.idx, (size_t)t->bark.index_count * 4);
    const float f[14] = {t->leaf_color[0],   t->leaf_color[1],   t->leaf_color[2],   t->bark_color[0],
                         t->bark_color[1],   t->bark_color[2],   t->crown_center[0], t->crown_center[1],
                         t->crown_center[2], t->crown_radius,    t->bound_center[0], t->bound_center[1],
                         t->bound_center[2], t->bound_radius};
    XXH3_64bits_update(st, f, sizeof f);
    const char *const src[4] = {hz_shader_leaf_vs, hz_shader_leaf_bake_fs, hz_shader_bark_vs, hz_shader_bark_bake_fs};
    for (int k = 0; k < 4; k++)
        XXH3_64bits_update(st, src[k], strlen(src[k]));
    uint64_t h = XXH3_64bits_digest(st);
    XXH3_freeState(st);
    return h;
}

bool hz_forest_gpu_impostor_baked(const hz_forest_gpu *g, uint32_t model)
{
    return model < g->nm && g->baked[model];
}

hz_result hz_forest_gpu_impostor_read(const hz_forest_gpu *g, uint32_t model, uint8_t *out, hz_err *err)
{
    if (model >= g->nm)
        return hz_err_set(err, HZ_ERR_VALUE, "forest: no model %u (%u models)", model, g->nm);
    const GLsizei W = IMP_AZ * IMP_TILE, H = IMP_EL * IMP_TILE;
    GLuint fbo = 0;
    GLint old_read = 0;
    glGetIntegerv(GL_READ_FRAMEBUFFER_BINDING, &old_read);
    glGenFramebuffers(1, &fbo);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo);
    glPixelStorei(GL_PACK_ALIGNMENT, 4);
    glPixelStorei(GL_PACK_ROW_LENGTH, 0);
    glBindBuffer(GL_PIXEL_PACK_BUFFER, 0);
    hz_result r = HZ_OK;
    for (int k = 0; k < 2 && r == HZ_OK; k++) {
        glFramebufferTextureLayer(GL_READ_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, g->atlas[k], 0, (GLint)model);
        glReadBuffer(GL_COLOR_ATTACHMENT0);
        if (glCheckFramebufferStatus(GL_READ_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
            r = hz_err_set(err, HZ_ERR_GL, "forest: impostor read framebuffer incomplete");
        else
            glReadPixels(0, 0, W, H, GL_RGBA, GL_UNSIGNED_BYTE, out + (size_t)k * W * H * 4);
    }
    glBindFramebuffer(GL_READ_FRAMEBUFFER, (GLuint)old_read);
    glDeleteFramebuffers(1, &fbo);
    return r == HZ_OK ? hz_gl_check(err, "forest impostor read") : r;
}

/* Uploads the kept counts of the nodes that changed (all of a tree's when
 * frames were missed). */
static hz_result upload_counts(hz_forest_gpu *g, const hz_forest *f, const hz_forest_frame *fr, hz_err *err)
{
    bool all = fr->serial != g->last_serial + 1;
    uint64_t bytes = 0;
    glBindBuffer(GL_TEXTURE_BUFFER, g->kept_buf);
    for (uint32_t d = 0; d < fr->draw_count; d++) {
        const hz_forest_draw *dr = &fr->draws[d];
        if (dr->hull)
            continue;
        uint32_t lo = dr->dirty_lo, hi = dr->dirty_hi;
        if (all) {
            lo = 0;
            hi = hz_forest_model(f, dr->model)->node_count;
        }
        if (lo >= hi || (size_t)dr->node_base + hi > g->node_total)
            continue;
        glBindBuffer(GL_TEXTURE_BUFFER, g->kept_buf);
        glBufferSubData(GL_TEXTURE_BUFFER, (GLintptr)(((size_t)dr->node_base + lo) * 4), (GLsizeiptr)((hi - lo) * 4),
                        fr->counts + dr->node_base + lo);
        glBindBuffer(GL_TEXTURE_BUFFER, g->scale_buf);
        glBufferSubData(GL_TEXTURE_BUFFER, (GLintptr)(((size_t)dr->node_base + lo) * 4), (GLsizeiptr)((hi - lo) * 4),
                        fr->scales + dr->node_base + lo);
        bytes += (uint64_t)(hi - lo) * 8;
    }
    if (fr->impostors && fr->impostor_count && fr->impostor_count <= g->tree_count) {
        glBindBuffer(GL_TEXTURE_BUFFER, g->order_buf);
        glBufferSubData(GL_TEXTURE_BUFFER, 0, (GLsizeiptr)((size_t)fr->impostor_count * 4), fr->impostor_trees);
        bytes += (uint64_t)fr->impostor_count * 4;
    }
    glBindBuffer(GL_TEXTURE_BUFFER, 0);
    g->last_serial = fr->serial;
    g->upload_bytes = bytes;
    return hz_gl_check(err, "forest count upload");
}

float hz_forest_gpu_point_leaves(hz_forest_gpu *g, float max_px)
{
    float old = g->point_px;
    g->point_px = isfinite(max_px) && max_px > 0 ? max_px : 0.0f;
    return old;
}

void hz_forest_gpu_time_parts(hz_forest_gpu *g, bool on)
{
    g->time_parts = on;
}

const double *hz_forest_gpu_part_ms(const hz_forest_gpu *g)
{
    return g->time_parts ? g->part_ms : NULL;
}

/* With time_parts, the main pass's part that ended now (glFinish). */
static void part_done(hz_forest_gpu *g, const hz_pass_info *pass, int part, double *t0)
{
    if (!g->time_parts || pass->pass != HZ_PASS_MAIN)
        return;
    glFinish();
    double t = hz_time_ms();
    g->part_ms[part] = t - *t0;
    *t0 = t;
}

uint32_t hz_forest_gpu_point_trees(const hz_forest_gpu *g)
{
    return g->point_trees;
}

uint64_t hz_forest_gpu_upload_bytes(const hz_forest_gpu *g)
{
    return g ? g->upload_bytes : 0;
}

static void bind_atlas(const prog_u *u)
{
    glUniform1i(u->albedo, 2);
    glUniform1i(u->normals, 3);
}

hz_result hz_forest_gpu_draw(hz_forest_gpu *g, const hz_forest *f, const hz_forest_frame *fr,
                             const hz_pass_info *pass, hz_err *err)
{
    if (!hz_gl_has_context())
        return hz_err_set(err, HZ_ERR_GL, "forest: draw without a current OpenGL context");
    hz_gl_drain();
    double t_part = 0;
    if (g->time_parts && pass->pass == HZ_PASS_MAIN) {
        glFinish();
        t_part = hz_time_ms();
        memset(g->part_ms, 0, sizeof g->part_ms);
    }
    if (fr->serial != g->last_serial) {
        hz_result r = upload_counts(g, f, fr, err);
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
    glActiveTexture(GL_TEXTURE2);
    glBindTexture(GL_TEXTURE_2D_ARRAY, g->atlas[0]);
    glActiveTexture(GL_TEXTURE3);
    glBindTexture(GL_TEXTURE_2D_ARRAY, g->atlas[1]);

    /* Leaves: two-sided, per tree the node groups' ranges (draw_leaves); as
     * quads, or as points where leaves are a few pixels across. */
    glDisable(GL_CULL_FACE);
    const float focal_px = pass->proj[1][1] * 0.5f * (float)pass->height;
    uint32_t point_trees = 0;
    for (int points = 0; points < 2; points++) {
        GLuint prog = points ? g->point_prog : g->leaf_prog;
        const prog_u *u = points ? &g->pu : &g->lu;
        bool any = false;
        uint32_t bound_model = UINT32_MAX;
        for (uint32_t d = 0; d < fr->draw_count; d++) {
            const hz_forest_draw *dr = &fr->draws[d];
            if (dr->hull || dr->prefix == 0)
                continue;
            const hz_tree *t = hz_forest_model(f, dr->model);
            /* The unsimplified reference (no impostors) keeps every leaf a quad. */
            if ((fr->impostors && leaf_points(g, f, dr, t, focal_px)) != (points != 0))
                continue;
            if (!any) {
                any = true;
                glUseProgram(prog);
                common_uniforms(prog, u, pass);
                glUniform2f(u->viewport, (float)pass->width, (float)pass->height);
                glActiveTexture(GL_TEXTURE1);
                glBindTexture(GL_TEXTURE_BUFFER, g->kept_tex);
                glUniform1i(u->kept, 1);
                glActiveTexture(GL_TEXTURE6);
                glBindTexture(GL_TEXTURE_BUFFER, g->scale_tex);
                glUniform1i(u->scales, 6);
                glUniform1i(u->leaves, 0);
                glActiveTexture(GL_TEXTURE0);
                if (points)
                    glEnable(GL_PROGRAM_POINT_SIZE);
            }
            if (bound_model != dr->model) {
                glBindTexture(GL_TEXTURE_BUFFER, g->m[dr->model].leaf_tex);
                glUniform3fv(u->color, 1, t->leaf_color);
                bound_model = dr->model;
            }
            hz_forest_tree_matrix(f, dr->tree, model);
            glUniformMatrix4fv(u->model, 1, GL_FALSE, model);
            if (points) {
                mat4 vp, mm, mvp;
                memcpy(vp, pass->viewproj, sizeof vp);
                memcpy(mm, model, sizeof mm);
                glm_mat4_mul(vp, mm, mvp);
                glUniformMatrix4fv(u->mvp, 1, GL_FALSE, (const float *)mvp);
            }
            glUniform1i(u->kept_base, (GLint)dr->node_base);
            glUniform2f(u->dither, dr->fade, 1.0f);
            if (points)
                point_trees++;
            draw_leaves(g, t, dr, points);
        }
        if (any && points)
            glDisable(GL_PROGRAM_POINT_SIZE);
    }
    if (pass->pass == HZ_PASS_MAIN)
        g->point_trees = point_trees;
    part_done(g, pass, 0, &t_part);
    glBindTexture(GL_TEXTURE_BUFFER, 0);
    glActiveTexture(GL_TEXTURE6);
    glBindTexture(GL_TEXTURE_BUFFER, 0);
    glActiveTexture(GL_TEXTURE1);
    glBindTexture(GL_TEXTURE_BUFFER, 0);
    glActiveTexture(GL_TEXTURE0);

    /* Bark and hulls: closed outward-facing meshes (bark tubes are open at
     * the ends, which only shows at the tips of twigs). A hull is drawn for
     * hull trees (fading out toward the impostor) and, dithered in, for
     * leaf trees in their fade band. */
    glEnable(GL_CULL_FACE);
    glCullFace(GL_BACK);
    glFrontFace(pass->pass == HZ_PASS_REFLECTION ? GL_CW : GL_CCW);
    for (int hull = 0; hull < 2; hull++) {
        const GLuint prog = hull ? g->hull_prog : g->bark_prog;
        const prog_u *u = hull ? &g->hu : &g->bu;
        glUseProgram(prog);
        common_uniforms(prog, u, pass);
        bind_atlas(u);
        for (uint32_t d = 0; d < fr->draw_count; d++) {
            const hz_forest_draw *dr = &fr->draws[d];
            if (hull && !dr->hull && !(dr->fade > 0))
                continue;
            const hz_tree *t = hz_forest_model(f, dr->model);
            const model_gpu *m = &g->m[dr->model];
            const mesh_gpu *mesh = hull ? &m->hull : &m->bark;
            uint32_t count = hull ? mesh->count : m->bark_level_end[(dr->bark_levels ? dr->bark_levels : 1) - 1];
            if (!count)
                continue;
            hz_forest_tree_matrix(f, dr->tree, model);
            glUniformMatrix4fv(u->model, 1, GL_FALSE, model);
            if (hull && !dr->hull)
                glUniform2f(u->dither, 0.0f, dr->fade); /* fading in from the leaves */
            else if (dr->hull)
                glUniform2f(u->dither, dr->fade, 1.0f); /* fading out to the impostor */
            else
                glUniform2f(u->dither, 0.0f, 1.0f);
            if (hull) {
                const hz_forest_tree *tr = &hz_forest_trees(f)[dr->tree];
                /* the view the impostor would show */
                float wc[3], dm[3];
                float c = cosf(tr->yaw), s = sinf(tr->yaw);
                const float *bc = t->bound_center;
                wc[0] = tr->pos[0] + tr->scale * (c * bc[0] + s * bc[2]);
                wc[1] = tr->pos[1] + tr->scale * bc[1];
                wc[2] = tr->pos[2] + tr->scale * (-s * bc[0] + c * bc[2]);
                float e[3] = {pass->cam->pos[0] - wc[0], pass->cam->pos[1] - wc[1], pass->cam->pos[2] - wc[2]};
                float l = sqrtf(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
                if (l <= 0)
                    l = 1;
                dm[0] = (c * e[0] - s * e[2]) / l, dm[1] = e[1] / l, dm[2] = (s * e[0] + c * e[2]) / l;
                glUniform3fv(u->tree_eye, 1, dm);
                const float *sun = pass->sun_dir;
                glUniform3f(u->sun_model, c * sun[0] - s * sun[2], sun[1], s * sun[0] + c * sun[2]);
                int ia, ie;
                nearest_view(dm, &ia, &ie);
                float right[3], up[3], fwd[3];
                view_axes(ia, ie, right, up, fwd);
                glUniform3fv(u->right, 1, right);
                glUniform3fv(u->up, 1, up);
                glUniform4f(u->tile, (float)ia / IMP_AZ, (float)ie / IMP_EL, 1.0f / IMP_AZ, 1.0f / IMP_EL);
                glUniform4f(u->bound, bc[0], bc[1], bc[2], t->bound_radius);
                glUniform1f(u->layer, (float)dr->model);
                /* the level with about one texel per pixel */
                float px = 2.0f * tr->scale * t->bound_radius / l * pass->proj[1][1] * 0.5f * (float)pass->height;
                int lod = (int)floorf(log2f(fmaxf((float)IMP_TILE / fmaxf(px, 1e-3f), 1.0f)) + 0.5f);
                lod = lod < 0 ? 0 : lod >= imp_levels() ? imp_levels() - 1 : lod;
                glUniform1i(u->lod, lod);
                glUniform2f(u->size, (float)((IMP_AZ * IMP_TILE) >> lod), (float)((IMP_EL * IMP_TILE) >> lod));
            } else {
                glUniform3fv(u->color, 1, t->bark_color);
            }
            glBindVertexArray(mesh->vao);
            glDrawElements(GL_TRIANGLES, (GLsizei)count, GL_UNSIGNED_INT, (const void *)0);
        }
    }

    part_done(g, pass, 1, &t_part);
    /* Impostors: every tree in one draw; the shader keeps those in the band. */
    if (fr->impostors && fr->impostor_count && fr->impostor_count <= g->tree_count) {
        glDisable(GL_CULL_FACE);
        glUseProgram(g->imp_prog);
        common_uniforms(g->imp_prog, &g->iu, pass);
        bind_atlas(&g->iu);
        glActiveTexture(GL_TEXTURE0);
        glBindTexture(GL_TEXTURE_BUFFER, g->tree_tex);
        glActiveTexture(GL_TEXTURE1);
        glBindTexture(GL_TEXTURE_BUFFER, g->model_tex);
        glActiveTexture(GL_TEXTURE5);
        glBindTexture(GL_TEXTURE_BUFFER, g->rect_tex);
        glUniform1i(g->iu.rects, 5);
        glUniform1f(g->iu.px_scale, pass->proj[1][1] * 0.5f * (float)pass->height);
        glUniform1i(g->iu.tile_px, IMP_TILE);
        glUniform1i(g->iu.max_lod, imp_levels() - 1);
        glActiveTexture(GL_TEXTURE4);
        glBindTexture(GL_TEXTURE_BUFFER, g->order_tex);
        glUniform1i(g->iu.trees, 0);
        glUniform1i(g->iu.models, 1);
        glUniform1i(g->iu.order, 4);
        glUniform2f(g->iu.band, fr->impostor_band[0], fr->impostor_band[1]);
        glUniform1f(g->iu.max_dist, isfinite(fr->max_dist) ? fr->max_dist : 3.0e38f);
        glUniform2i(g->iu.views, IMP_AZ, IMP_EL);
        glUniform1f(g->iu.el_step, IMP_EL_STEP);
        glBindVertexArray(g->empty_vao);
        glDrawArrays(GL_TRIANGLES, 0, (GLsizei)fr->impostor_count * 6);
        glActiveTexture(GL_TEXTURE5);
        glBindTexture(GL_TEXTURE_BUFFER, 0);
        glActiveTexture(GL_TEXTURE4);
        glBindTexture(GL_TEXTURE_BUFFER, 0);
        glActiveTexture(GL_TEXTURE1);
        glBindTexture(GL_TEXTURE_BUFFER, 0);
        glActiveTexture(GL_TEXTURE1);
        glBindTexture(GL_TEXTURE_BUFFER, 0);
        glActiveTexture(GL_TEXTURE0);
        glBindTexture(GL_TEXTURE_BUFFER, 0);
    }
    part_done(g, pass, 2, &t_part);
    glActiveTexture(GL_TEXTURE3);
    glBindTexture(GL_TEXTURE_2D_ARRAY, 0);
    glActiveTexture(GL_TEXTURE2);
    glBindTexture(GL_TEXTURE_2D_ARRAY, 0);
    glActiveTexture(GL_TEXTURE0);
    glBindVertexArray(0);
    glUseProgram(0);
    glDisable(GL_CULL_FACE);
    if (pass->pass == HZ_PASS_REFLECTION)
        glFrontFace(GL_CW);
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
        if (h->time_draw)
            glFinish();
        t0 = hz_time_ms();
    }
    if (hz_forest_gpu_draw(h->gpu, h->forest, h->frame, pass, &h->err) != HZ_OK)
        h->failed = true;
    if (pass->pass == HZ_PASS_MAIN) {
        if (h->time_draw)
            glFinish();
        h->draw_ms = hz_time_ms() - t0;
    }
}
