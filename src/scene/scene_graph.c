/* Scene graph (SPEC G1, G3, G5): nodes in one array, children as linked
 * lists (first child, next sibling), index 0 a hidden root whose children
 * are the user's roots. Every traversal walks the links without a stack
 * (down to the first child, else to the next sibling, else up), so a deep
 * tree from a file cannot overflow anything. */
#include "horizon/scene.h"

#include "horizon/occlusion.h"

#include "horizon/safety.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct node {
    uint32_t parent, first_child, last_child, next_sibling;
    vec3 t, scale;
    versor q;
    mat4 world;
    hz_box own, sub;       /* world: the mesh's box, the subtree's box */
    uint32_t mesh, material;
    char *name, *attrs;
    uint8_t dirty_xf;      /* own transform changed */
    uint8_t dirty_below;   /* something in the subtree needs an update */
    uint8_t dirty_mesh;    /* own mesh changed */
    uint8_t moved;         /* world recomputed in the running update */
} node;

struct hz_scene {
    node *n;
    uint32_t count, cap;   /* count includes the hidden root */
    uint32_t objects;      /* nodes with a mesh (the cull's stats; no walk over every node a frame) */
    hz_vertex *v;
    uint32_t vcount, vcap;
    uint32_t *idx;
    uint32_t icount, icap;
    hz_mesh_range *mesh;
    uint32_t mcount, mcap;
    hz_material *mat;
    uint32_t matcount, matcap;
};

hz_scene *hz_scene_create(const hz_scene_desc *desc)
{
    hz_scene *s = calloc(1, sizeof *s);
    if (!s)
        return NULL;
    uint32_t cap = desc && desc->node_capacity ? desc->node_capacity + 1 : 65;
    if (!hz_grow((void **)&s->n, &s->cap, cap, sizeof *s->n, 16)) {
        free(s);
        return NULL;
    }
    memset(&s->n[0], 0, sizeof s->n[0]);
    glm_mat4_identity(s->n[0].world);
    hz_box_empty(&s->n[0].own);
    hz_box_empty(&s->n[0].sub);
    s->n[0].mesh = HZ_MESH_NONE;
    s->count = 1;
    return s;
}

void hz_scene_destroy(hz_scene *s)
{
    if (!s)
        return;
    for (uint32_t k = 0; k < s->count; k++) {
        free(s->n[k].name);
        free(s->n[k].attrs);
    }
    free(s->n);
    free(s->v);
    free(s->idx);
    free(s->mesh);
    free(s->mat);
    free(s);
}

uint32_t hz_scene_add_material(hz_scene *s, const hz_material *m)
{
    if (!hz_grow((void **)&s->mat, &s->matcap, s->matcount + 1, sizeof *s->mat, 16))
        return HZ_MESH_NONE;
    s->mat[s->matcount] = *m;
    s->mat[s->matcount].name[sizeof m->name - 1] = 0;
    return s->matcount++;
}

uint32_t hz_scene_material_count(const hz_scene *s)
{
    return s->matcount;
}

const hz_material *hz_scene_material(const hz_scene *s, uint32_t material)
{
    return material < s->matcount ? &s->mat[material] : NULL;
}

uint32_t hz_scene_add_mesh(hz_scene *s, const hz_vertex *v, uint32_t vcount, const uint32_t *idx, uint32_t icount,
                           hz_err *err)
{
    if (icount % 3) {
        hz_err_set(err, HZ_ERR_VALUE, "mesh: %u indices is not a whole number of triangles", icount);
        return HZ_MESH_NONE;
    }
    hz_mesh_range r = {.first_vertex = s->vcount, .vertex_count = vcount, .first_index = s->icount,
                       .index_count = icount};
    hz_box_empty(&r.bounds);
    for (uint32_t k = 0; k < vcount; k++) {
        if (!isfinite(v[k].pos[0]) || !isfinite(v[k].pos[1]) || !isfinite(v[k].pos[2])) {
            hz_err_set(err, HZ_ERR_VALUE, "mesh: vertex %u is not finite", k);
            return HZ_MESH_NONE;
        }
        hz_box_add_point(&r.bounds, v[k].pos);
    }
    for (uint32_t k = 0; k < icount; k++)
        if (idx[k] >= vcount) {
            hz_err_set(err, HZ_ERR_VALUE, "mesh: index %u = %u is out of range (%u vertices)", k, idx[k], vcount);
            return HZ_MESH_NONE;
        }
    if ((uint64_t)s->vcount + vcount > UINT32_MAX || (uint64_t)s->icount + icount > UINT32_MAX ||
        !hz_grow((void **)&s->v, &s->vcap, s->vcount + vcount, sizeof *s->v, 16) ||
        !hz_grow((void **)&s->idx, &s->icap, s->icount + icount, sizeof *s->idx, 16) ||
        !hz_grow((void **)&s->mesh, &s->mcap, s->mcount + 1, sizeof *s->mesh, 16)) {
        hz_err_set(err, HZ_ERR_MEMORY, "mesh: out of memory (%u vertices, %u indices so far)", s->vcount, s->icount);
        return HZ_MESH_NONE;
    }
    if (vcount)
        memcpy(s->v + s->vcount, v, (size_t)vcount * sizeof *v);
    if (icount)
        memcpy(s->idx + s->icount, idx, (size_t)icount * sizeof *idx);
    s->vcount += vcount;
    s->icount += icount;
    s->mesh[s->mcount] = r;
    return s->mcount++;
}

uint32_t hz_scene_mesh_count(const hz_scene *s)
{
    return s->mcount;
}

const hz_mesh_range *hz_scene_mesh(const hz_scene *s, uint32_t mesh)
{
    return mesh < s->mcount ? &s->mesh[mesh] : NULL;
}

const hz_vertex *hz_scene_vertices(const hz_scene *s, uint32_t *count)
{
    *count = s->vcount;
    return s->v;
}

const uint32_t *hz_scene_indices(const hz_scene *s, uint32_t *count)
{
    *count = s->icount;
    return s->idx;
}

/* Marks the node's ancestors: their subtrees need an update. */
static void mark_up(hz_scene *s, uint32_t id)
{
    for (uint32_t p = s->n[id].parent;; p = s->n[p].parent) {
        if (s->n[p].dirty_below)
            break;
        s->n[p].dirty_below = 1;
        if (p == 0)
            break;
    }
}

uint32_t hz_scene_add_node(hz_scene *s, uint32_t parent, const char *name)
{
    if (parent >= s->count || s->count == UINT32_MAX)
        return HZ_NODE_NONE;
    char *nm = NULL;
    if (name && !(nm = strdup(name)))
        return HZ_NODE_NONE;
    if (!hz_grow((void **)&s->n, &s->cap, s->count + 1, sizeof *s->n, 16)) {
        free(nm);
        return HZ_NODE_NONE;
    }
    uint32_t id = s->count++;
    node *n = &s->n[id];
    memset(n, 0, sizeof *n);
    n->parent = parent;
    glm_vec3_one(n->scale);
    glm_quat_identity(n->q);
    glm_mat4_identity(n->world);
    hz_box_empty(&n->own);
    hz_box_empty(&n->sub);
    n->mesh = HZ_MESH_NONE;
    n->name = nm;
    n->dirty_xf = 1;
    node *p = &s->n[parent];
    if (p->last_child)
        s->n[p->last_child].next_sibling = id;
    else
        p->first_child = id;
    p->last_child = id;
    mark_up(s, id);
    return id;
}

uint32_t hz_scene_node_count(const hz_scene *s)
{
    return s->count - 1;
}

uint32_t hz_scene_parent(const hz_scene *s, uint32_t id)
{
    HZ_ASSERT(id && id < s->count);
    return s->n[id].parent;
}

const char *hz_scene_name(const hz_scene *s, uint32_t id)
{
    HZ_ASSERT(id && id < s->count);
    return s->n[id].name ? s->n[id].name : "";
}

hz_result hz_scene_set_attributes(hz_scene *s, uint32_t id, const char *json, hz_err *err)
{
    HZ_ASSERT(id && id < s->count);
    char *a = NULL;
    if (json && !(a = strdup(json)))
        return hz_err_set(err, HZ_ERR_MEMORY, "scene: out of memory for attributes");
    free(s->n[id].attrs);
    s->n[id].attrs = a;
    return HZ_OK;
}

const char *hz_scene_attributes(const hz_scene *s, uint32_t id)
{
    HZ_ASSERT(id && id < s->count);
    return s->n[id].attrs ? s->n[id].attrs : "";
}

/* The next node of a pre-order walk after n; descend = false skips n's
 * children. 0 at the end. leave (may be NULL) is called for every node as
 * the walk leaves it for good (post-order). */
static uint32_t walk_next(const hz_scene *s, uint32_t n, bool descend, void (*leave)(hz_scene *, uint32_t),
                          hz_scene *ms)
{
    if (descend && s->n[n].first_child)
        return s->n[n].first_child;
    while (n) {
        if (leave)
            leave(ms, n);
        if (s->n[n].next_sibling)
            return s->n[n].next_sibling;
        n = s->n[n].parent;
    }
    return 0;
}

uint32_t hz_scene_find(const hz_scene *s, const char *name)
{
    for (uint32_t n = s->n[0].first_child; n; n = walk_next(s, n, true, NULL, NULL))
        if (s->n[n].name && !strcmp(s->n[n].name, name))
            return n;
    return HZ_NODE_NONE;
}

static void touch_xf(hz_scene *s, uint32_t id)
{
    s->n[id].dirty_xf = 1;
    mark_up(s, id);
}

void hz_scene_set_translation(hz_scene *s, uint32_t id, const float t[3])
{
    HZ_ASSERT(id && id < s->count);
    glm_vec3_copy((float *)t, s->n[id].t);
    touch_xf(s, id);
}

void hz_scene_translate(hz_scene *s, uint32_t id, const float d[3])
{
    HZ_ASSERT(id && id < s->count);
    glm_vec3_add(s->n[id].t, (float *)d, s->n[id].t);
    touch_xf(s, id);
}

void hz_scene_set_axis_angle(hz_scene *s, uint32_t id, const float axis[3], float deg)
{
    HZ_ASSERT(id && id < s->count);
    vec3 a;
    glm_vec3_normalize_to((float *)axis, a);
    glm_quatv(s->n[id].q, glm_rad(deg), a);
    touch_xf(s, id);
}

void hz_scene_set_ypr(hz_scene *s, uint32_t id, float yaw, float pitch, float roll)
{
    HZ_ASSERT(id && id < s->count);
    versor qy, qp, qr, t;
    glm_quatv(qy, glm_rad(-yaw), (vec3){0, 1, 0});
    glm_quatv(qp, glm_rad(pitch), (vec3){1, 0, 0});
    glm_quatv(qr, glm_rad(-roll), (vec3){0, 0, 1});
    glm_quat_mul(qy, qp, t);
    glm_quat_mul(t, qr, s->n[id].q);
    touch_xf(s, id);
}

void hz_scene_rotate(hz_scene *s, uint32_t id, const float axis[3], float deg)
{
    HZ_ASSERT(id && id < s->count);
    vec3 a;
    versor r, q;
    glm_vec3_normalize_to((float *)axis, a);
    glm_quatv(r, glm_rad(deg), a);
    glm_quat_mul(r, s->n[id].q, q);
    glm_quat_copy(q, s->n[id].q);
    touch_xf(s, id);
}

void hz_scene_set_scale(hz_scene *s, uint32_t id, const float scale[3])
{
    HZ_ASSERT(id && id < s->count);
    glm_vec3_copy((float *)scale, s->n[id].scale);
    touch_xf(s, id);
}

void hz_scene_local_matrix(const hz_scene *s, uint32_t id, mat4 dest)
{
    const node *n = &s->n[id];
    mat4 r;
    glm_quat_mat4((float *)n->q, r);
    glm_mat4_identity(dest);
    glm_translate(dest, (float *)n->t);
    glm_mat4_mul(dest, r, dest);
    glm_scale(dest, (float *)n->scale);
}

void hz_scene_query_translation(const hz_scene *s, uint32_t id, float dest[3])
{
    HZ_ASSERT(id && id < s->count);
    glm_vec3_copy((float *)s->n[id].t, dest);
}

void hz_scene_set_mesh(hz_scene *s, uint32_t id, uint32_t mesh, uint32_t material)
{
    HZ_ASSERT(id && id < s->count);
    HZ_ASSERT(mesh == HZ_MESH_NONE || mesh < s->mcount);
    s->objects += (mesh != HZ_MESH_NONE) - (s->n[id].mesh != HZ_MESH_NONE);
    s->n[id].mesh = mesh;
    s->n[id].material = material;
    s->n[id].dirty_mesh = 1;
    mark_up(s, id);
}

uint32_t hz_scene_node_mesh(const hz_scene *s, uint32_t id)
{
    return s->n[id].mesh;
}

uint32_t hz_scene_node_material(const hz_scene *s, uint32_t id)
{
    return s->n[id].material;
}

/* Post-order step of the update: the subtree box from the node's own box
 * and its children's, then the flags are cleared. */
static void update_leave(hz_scene *s, uint32_t id)
{
    node *n = &s->n[id];
    if (!n->moved && !n->dirty_below && !n->dirty_mesh)
        return;
    n->sub = n->own;
    for (uint32_t c = n->first_child; c; c = s->n[c].next_sibling)
        hz_box_add_box(&n->sub, &s->n[c].sub);
    n->moved = n->dirty_below = n->dirty_mesh = 0;
}

uint32_t hz_scene_update(hz_scene *s)
{
    uint32_t recomputed = 0;
    if (!s->n[0].dirty_below)
        return 0;
    for (uint32_t id = s->n[0].first_child; id;) {
        node *n = &s->n[id];
        const node *p = &s->n[n->parent];
        bool moved = n->dirty_xf || (n->parent && p->moved);
        if (moved) {
            mat4 local;
            hz_scene_local_matrix(s, id, local);
            glm_mat4_mul((vec4 *)p->world, local, n->world);
            n->dirty_xf = 0;
            n->moved = 1;
            recomputed++;
        }
        if (moved || n->dirty_mesh) {
            if (n->mesh != HZ_MESH_NONE)
                hz_box_transform(&s->mesh[n->mesh].bounds, n->world, &n->own);
            else
                hz_box_empty(&n->own);
        }
        /* An unchanged subtree (no move from above, nothing marked inside)
         * is left alone: neither its transforms nor its boxes are touched. */
        bool descend = moved || n->dirty_below;
        id = walk_next(s, id, descend, update_leave, s);
    }
    s->n[0].sub = s->n[0].own;
    hz_box_empty(&s->n[0].sub);
    for (uint32_t c = s->n[0].first_child; c; c = s->n[c].next_sibling)
        hz_box_add_box(&s->n[0].sub, &s->n[c].sub);
    s->n[0].dirty_below = 0;
    return recomputed;
}

void hz_scene_world_matrix(const hz_scene *s, uint32_t id, mat4 dest)
{
    HZ_ASSERT(id < s->count);
    glm_mat4_copy((vec4 *)s->n[id].world, dest);
}

void hz_scene_node_bounds(const hz_scene *s, uint32_t id, hz_box *dest)
{
    *dest = s->n[id].own;
}

void hz_scene_subtree_bounds(const hz_scene *s, uint32_t id, hz_box *dest)
{
    *dest = s->n[id].sub;
}

void hz_scene_bounds(const hz_scene *s, hz_box *dest)
{
    *dest = s->n[0].sub;
}

void hz_scene_visit(const hz_scene *s, hz_scene_visit_fn fn, void *user)
{
    uint32_t depth = 0;
    for (uint32_t id = s->n[0].first_child; id;) {
        bool descend = fn(user, s, id, depth);
        /* Depth: down one on a first child, else up by the levels climbed. */
        uint32_t next = walk_next(s, id, descend, NULL, NULL);
        if (next && descend && next == s->n[id].first_child) {
            depth++;
        } else if (next) {
            for (uint32_t a = s->n[id].parent; a != s->n[next].parent; a = s->n[a].parent)
                depth--;
        }
        id = next;
    }
}

/* A box against the planes as cam draws it (cam NULL or flat: as it is). */
static int drawn_box_vs_planes(const hz_box *b, const hz_camera *cam, const vec4 *planes)
{
    if (!cam || cam->earth_radius == 0.0f || hz_box_is_empty(b))
        return hz_box_vs_planes(b, planes, 6);
    hz_box c = *b;
    float box[2][3] = {{c.min[0], c.min[1], c.min[2]}, {c.max[0], c.max[1], c.max[2]}};
    hz_camera_curve_box(cam, box);
    c.min[1] = box[0][1];
    c.max[1] = box[1][1];
    return hz_box_vs_planes(&c, planes, 6);
}

uint32_t hz_scene_cull(const hz_scene *s, const vec4 planes[6], uint32_t *out, uint32_t cap, hz_cull_stats *stats)
{
    return hz_scene_cull_curved(s, NULL, planes, out, cap, stats);
}

uint32_t hz_scene_cull_curved(const hz_scene *s, const hz_camera *cam, const vec4 planes[6], uint32_t *out,
                              uint32_t cap, hz_cull_stats *stats)
{
    return hz_scene_cull_occluded(s, cam, planes, NULL, out, cap, stats);
}

uint32_t hz_scene_cull_occluded(const hz_scene *s, const hz_camera *cam, const vec4 planes[6],
                                const struct hz_occlusion *occ, uint32_t *out, uint32_t cap, hz_cull_stats *stats)
{
    hz_cull_stats st = {0};
    uint32_t n_out = 0;
    uint32_t inside_root = 0; /* while > 0: inside a subtree accepted whole */
    uint32_t hidden_root = 0; /* while > 0: inside a subtree the buffer hides (only counted) */
    st.objects = s->objects;
    for (uint32_t id = s->n[0].first_child; id;) {
        const node *n = &s->n[id];
        bool descend = true;
        bool take = n->mesh != HZ_MESH_NONE;
        if (!inside_root) {
            st.nodes_tested++;
            int r = drawn_box_vs_planes(&n->sub, cam, planes);
            if (r < 0) {
                st.subtrees_culled++;
                descend = take = false;
            } else if (r > 0) {
                st.subtrees_inside++;
                if (n->first_child)
                    inside_root = id;
            } else if (take && n->first_child) {
                st.nodes_tested++;
                take = drawn_box_vs_planes(&n->own, cam, planes) >= 0;
            }
        }
        st.in_frustum += take;
        if (occ && descend && !hidden_root) {
            /* the subtree's box, then the node's own (a leaf's are one) */
            if (n->first_child) {
                st.occlusion_tests++;
                if (hz_occlusion_box_hidden(occ, &n->sub)) {
                    st.subtrees_hidden++;
                    hidden_root = id;
                }
            }
            if (take && !hidden_root) {
                st.occlusion_tests++;
                take = !hz_occlusion_box_hidden(occ, &n->own);
            }
        }
        if (take && !hidden_root) {
            if (n_out < cap)
                out[n_out] = id;
            n_out++;
        }
        /* Leaving an accepted or hidden subtree ends its pass. */
        uint32_t next;
        if (descend && n->first_child) {
            next = n->first_child;
        } else {
            next = 0;
            for (uint32_t m = id; m; m = s->n[m].parent) {
                if (m == inside_root)
                    inside_root = 0;
                if (m == hidden_root)
                    hidden_root = 0;
                if (s->n[m].next_sibling) {
                    next = s->n[m].next_sibling;
                    break;
                }
            }
        }
        id = next;
    }
    st.visible = n_out;
    if (stats)
        *stats = st;
    return n_out;
}

typedef struct qkey {
    uint32_t shader, material, mesh, order, node;
} qkey;

static int cmp_qkey(const void *pa, const void *pb)
{
    const qkey *a = pa, *b = pb;
    if (a->shader != b->shader)
        return a->shader < b->shader ? -1 : 1;
    if (a->material != b->material)
        return a->material < b->material ? -1 : 1;
    if (a->mesh != b->mesh)
        return a->mesh < b->mesh ? -1 : 1;
    return (a->order > b->order) - (a->order < b->order);
}

/* An LSD radix sort on the squared distances' float bits (non-negative
 * floats order as their bits), a byte per pass; stable. */
void hz_scene_sort_near_first(const hz_scene *s, const float eye[3], uint32_t *nodes, uint32_t n, uint32_t *tmp)
{
    if (n < 2)
        return;
    uint32_t *key = tmp, *key_tmp = tmp + n, *node_tmp = tmp + 2 * (size_t)n;
    for (uint32_t k = 0; k < n; k++) {
        hz_box b;
        hz_scene_node_bounds(s, nodes[k], &b);
        float d2 = hz_box_distance2(&b, eye);
        if (!(d2 >= 0)) /* NaN: last */
            d2 = INFINITY;
        memcpy(&key[k], &d2, sizeof d2);
    }
    for (int shift = 0; shift < 32; shift += 8) {
        uint32_t count[257] = {0};
        for (uint32_t k = 0; k < n; k++)
            count[((key[k] >> shift) & 255u) + 1]++;
        if (count[((key[0] >> shift) & 255u) + 1] == n)
            continue; /* every key has this byte: the pass would change nothing */
        for (int b = 0; b < 256; b++)
            count[b + 1] += count[b];
        for (uint32_t k = 0; k < n; k++) {
            const uint32_t at = count[(key[k] >> shift) & 255u]++;
            key_tmp[at] = key[k];
            node_tmp[at] = nodes[k];
        }
        memcpy(key, key_tmp, (size_t)n * sizeof *key);
        memcpy(nodes, node_tmp, (size_t)n * sizeof *nodes);
    }
}

/* The queue; per_instance: materials are instance data, not part of the key. */
static uint32_t queue_build(const hz_scene *s, const uint32_t *nodes, uint32_t count, bool sorted, bool per_instance,
                            uint32_t *nodes_out, hz_draw_item *items, hz_queue_stats *stats)
{
    hz_queue_stats st = {0};
    if (stats)
        *stats = st;
    if (!count)
        return 0;
    qkey *k = malloc((size_t)count * sizeof *k);
    if (!k)
        return 0;
    for (uint32_t i = 0; i < count; i++) {
        const node *n = &s->n[nodes[i]];
        const hz_material *m = hz_scene_material(s, n->material);
        k[i] = (qkey){m ? m->shader : 0, per_instance ? HZ_MATERIAL_PER_INSTANCE : n->material, n->mesh, i, nodes[i]};
    }
    if (sorted)
        qsort(k, count, sizeof *k, cmp_qkey);
    uint32_t ni = 0;
    for (uint32_t i = 0; i < count; i++) {
        nodes_out[i] = k[i].node;
        const bool same = ni && sorted && items[ni - 1].shader == k[i].shader &&
                          items[ni - 1].material == k[i].material && items[ni - 1].mesh == k[i].mesh;
        if (same) {
            items[ni - 1].count++;
            continue;
        }
        if (!ni || items[ni - 1].shader != k[i].shader)
            st.shader_changes++;
        if (!per_instance && (!ni || items[ni - 1].material != k[i].material))
            st.material_changes++;
        items[ni++] = (hz_draw_item){k[i].shader, k[i].material, k[i].mesh, i, 1};
    }
    free(k);
    st.objects = count;
    st.items = ni;
    if (stats)
        *stats = st;
    return ni;
}

uint32_t hz_scene_queue_build(const hz_scene *s, const uint32_t *nodes, uint32_t count, bool sorted,
                              uint32_t *nodes_out, hz_draw_item *items, hz_queue_stats *stats)
{
    return queue_build(s, nodes, count, sorted, false, nodes_out, items, stats);
}

uint32_t hz_scene_queue_build_instanced(const hz_scene *s, const uint32_t *nodes, uint32_t count, bool sorted,
                                        uint32_t *nodes_out, hz_draw_item *items, hz_queue_stats *stats)
{
    return queue_build(s, nodes, count, sorted, true, nodes_out, items, stats);
}

/* Slab test: the ray's entry parameter into b, or false. */
static bool ray_box(const hz_box *b, const float o[3], const float d[3], float t_max, float *t_enter)
{
    float t0 = 0, t1 = t_max;
    for (int k = 0; k < 3; k++) {
        if (fabsf(d[k]) < 1e-30f) {
            if (o[k] < b->min[k] || o[k] > b->max[k])
                return false;
            continue;
        }
        float inv = 1.0f / d[k];
        float a = (b->min[k] - o[k]) * inv, e = (b->max[k] - o[k]) * inv;
        if (a > e) {
            float x = a;
            a = e;
            e = x;
        }
        t0 = fmaxf(t0, a);
        t1 = fminf(t1, e);
        if (t0 > t1)
            return false;
    }
    *t_enter = t0;
    return true;
}

/* Möller–Trumbore, both faces; t in (0, t_best). */
static bool ray_tri(const float o[3], const float d[3], const vec3 a, const vec3 b, const vec3 c, float *t)
{
    vec3 e1, e2, p, q, s;
    glm_vec3_sub((float *)b, (float *)a, e1);
    glm_vec3_sub((float *)c, (float *)a, e2);
    glm_vec3_cross((float *)d, e2, p);
    float det = glm_vec3_dot(e1, p);
    if (fabsf(det) < 1e-12f)
        return false;
    float inv = 1.0f / det;
    glm_vec3_sub((float *)o, (float *)a, s);
    float u = glm_vec3_dot(s, p) * inv;
    if (u < 0 || u > 1)
        return false;
    glm_vec3_cross(s, e1, q);
    float v = glm_vec3_dot((float *)d, q) * inv;
    if (v < 0 || u + v > 1)
        return false;
    float tt = glm_vec3_dot(e2, q) * inv;
    if (tt <= 0 || tt >= *t)
        return false;
    *t = tt;
    return true;
}

bool hz_scene_raycast(const hz_scene *s, const float origin[3], const float dir[3], float t_max, hz_scene_hit *hit)
{
    hz_scene_hit best = {.node = HZ_NODE_NONE, .t = t_max};
    for (uint32_t id = s->n[0].first_child; id;) {
        const node *n = &s->n[id];
        float te;
        bool descend = ray_box(&n->sub, origin, dir, best.t, &te);
        if (descend && n->mesh != HZ_MESH_NONE && ray_box(&n->own, origin, dir, best.t, &te)) {
            const hz_mesh_range *m = &s->mesh[n->mesh];
            const uint32_t *ix = s->idx + m->first_index;
            const hz_vertex *vv = s->v + m->first_vertex;
            for (uint32_t k = 0; k + 2 < m->index_count; k += 3) {
                vec3 w[3];
                for (int c = 0; c < 3; c++)
                    glm_mat4_mulv3((vec4 *)n->world, (float *)vv[ix[k + (uint32_t)c]].pos, 1.0f, w[c]);
                if (ray_tri(origin, dir, w[0], w[1], w[2], &best.t)) {
                    best.node = id;
                    best.triangle = k / 3;
                }
            }
        }
        id = walk_next(s, id, descend, NULL, NULL);
    }
    if (best.node == HZ_NODE_NONE)
        return false;
    for (int k = 0; k < 3; k++)
        best.pos[k] = origin[k] + best.t * dir[k];
    *hit = best;
    return true;
}
