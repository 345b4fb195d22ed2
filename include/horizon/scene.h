/* horizon scene graph (SPEC G1, G3, G5): a tree of nodes, each with a
 * transform relative to its parent (translate, rotate about an axis or by
 * yaw/pitch/roll, scale) and an optional mesh; world transforms are
 * inherited; world bounds are kept per subtree and recomputed only where
 * something changed; hierarchical frustum culling; a render queue sorted by
 * shader -> material -> mesh. No GL: src/render/object_draw.c draws it.
 *
 * World space as everywhere in horizon: metres, y up, x east, z south.
 * Meshes are stored merged: every mesh's vertices and indices go into one
 * pair of arrays (what the renderer uploads as one static buffer). */
#ifndef HORIZON_SCENE_H
#define HORIZON_SCENE_H

#include <cglm/cglm.h>
#include "horizon/camera.h"
#include "horizon/core.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct hz_scene hz_scene; /* opaque CPU object */

#define HZ_NODE_NONE 0u /* node ids start at 1; 0 = none / the implicit root's parent */
#define HZ_MESH_NONE 0xffffffffu

/* Axis-aligned box, world or local metres. Empty when min > max. */
typedef struct hz_box {
    vec3 min, max;
} hz_box;

/* An empty box (min = +inf, max = -inf) and its test. */
void hz_box_empty(hz_box *b);
bool hz_box_is_empty(const hz_box *b);
/* b grown to contain p / another box. */
void hz_box_add_point(hz_box *b, const float p[3]);
void hz_box_add_box(hz_box *b, const hz_box *o);
/* Squared distance from p to b (0 for p inside; +inf for an empty box). */
float hz_box_distance2(const hz_box *b, const float p[3]);
/* Whether cam's eye lies inside b grown by twice the near distance on every
 * side: the near plane may clip b's faces (or the eye is within), so what
 * lies behind them may show through. */
bool hz_box_around_eye(const hz_box *b, const hz_camera *cam);
/* The box of the 8 corners of b transformed by m (an affine matrix). */
void hz_box_transform(const hz_box *b, const mat4 m, hz_box *dest);

/* One vertex of a scene mesh: position and normal, mesh-local metres. */
typedef struct hz_vertex {
    float pos[3];
    float normal[3];
} hz_vertex;

/* A mesh as stored: its range in the merged arrays. */
typedef struct hz_mesh_range {
    uint32_t first_vertex, vertex_count;
    uint32_t first_index, index_count; /* indices are relative to first_vertex */
    hz_box bounds;                     /* mesh-local */
} hz_mesh_range;

/* Materials: a flat colour per material, the shader that draws it. */
typedef struct hz_material {
    float color[3];   /* linear albedo */
    uint32_t shader;  /* 0: lit opaque (the only one today); part of the queue's sort key */
    char name[32];
} hz_material;

typedef struct hz_scene_desc {
    uint32_t node_capacity; /* initial; grows; 0 -> 64 */
    const char *label;      /* optional, for messages */
} hz_scene_desc;

hz_scene *hz_scene_create(const hz_scene_desc *desc);
void hz_scene_destroy(hz_scene *s);

/* Adds a material; returns its index, or HZ_MESH_NONE on out of memory. */
uint32_t hz_scene_add_material(hz_scene *s, const hz_material *m);
uint32_t hz_scene_material_count(const hz_scene *s);
const hz_material *hz_scene_material(const hz_scene *s, uint32_t material);

/* Copies a triangle mesh (idx: 3 per triangle, < vcount) into the merged
 * arrays. Returns the mesh index, or HZ_MESH_NONE with err (out of memory,
 * an index out of range, a non-finite position, more than 2^32 entries). */
uint32_t hz_scene_add_mesh(hz_scene *s, const hz_vertex *v, uint32_t vcount, const uint32_t *idx, uint32_t icount,
                           hz_err *err);
uint32_t hz_scene_mesh_count(const hz_scene *s);
const hz_mesh_range *hz_scene_mesh(const hz_scene *s, uint32_t mesh);
/* The merged arrays (what a renderer uploads once). */
const hz_vertex *hz_scene_vertices(const hz_scene *s, uint32_t *count);
const uint32_t *hz_scene_indices(const hz_scene *s, uint32_t *count);

/* Adds a node under parent (HZ_NODE_NONE: a root). name is copied (may be
 * NULL); the node starts at the identity transform, with no mesh. Returns
 * its id (>= 1), or HZ_NODE_NONE on out of memory or a bad parent. */
uint32_t hz_scene_add_node(hz_scene *s, uint32_t parent, const char *name);
uint32_t hz_scene_node_count(const hz_scene *s);
uint32_t hz_scene_parent(const hz_scene *s, uint32_t node);
const char *hz_scene_name(const hz_scene *s, uint32_t node);
/* The first node of that name (depth-first order), HZ_NODE_NONE if none. */
uint32_t hz_scene_find(const hz_scene *s, const char *name);
/* Free-form attributes of a node (a JSON object text, e.g. {"osm_id":1}),
 * copied; NULL clears. Returned "" when none. */
hz_result hz_scene_set_attributes(hz_scene *s, uint32_t node, const char *json, hz_err *err);
const char *hz_scene_attributes(const hz_scene *s, uint32_t node);

/* Local transform, relative to the parent: world = parent_world * T * R * S.
 * Each setter marks the node's subtree for hz_scene_update. */
void hz_scene_set_translation(hz_scene *s, uint32_t node, const float t[3]);
void hz_scene_translate(hz_scene *s, uint32_t node, const float d[3]); /* adds d */
/* Rotation about a unit axis by deg degrees (right-handed). Replaces the rotation. */
void hz_scene_set_axis_angle(hz_scene *s, uint32_t node, const float axis[3], float deg);
/* Rotation by yaw, pitch and roll in degrees, in the camera's convention
 * (camera.h): a node's forward axis -z turns toward +x (east) with yaw 90,
 * up with pitch > 0, and roll > 0 banks it right; R = Ry(-yaw) Rx(pitch)
 * Rz(-roll). Replaces the rotation. */
void hz_scene_set_ypr(hz_scene *s, uint32_t node, float yaw, float pitch, float roll);
/* Multiplies the rotation by an axis-angle turn applied after the current one. */
void hz_scene_rotate(hz_scene *s, uint32_t node, const float axis[3], float deg);
void hz_scene_set_scale(hz_scene *s, uint32_t node, const float scale[3]);
void hz_scene_local_matrix(const hz_scene *s, uint32_t node, mat4 dest);
void hz_scene_query_translation(const hz_scene *s, uint32_t node, float dest[3]);

/* Draws mesh with material at this node (HZ_MESH_NONE: nothing). */
void hz_scene_set_mesh(hz_scene *s, uint32_t node, uint32_t mesh, uint32_t material);
uint32_t hz_scene_node_mesh(const hz_scene *s, uint32_t node);
uint32_t hz_scene_node_material(const hz_scene *s, uint32_t node);

/* Recomputes world transforms of the nodes whose transform or an
 * ancestor's changed, and world bounds of the subtrees that contain such a
 * node or a changed mesh; nothing else is visited below an unchanged
 * subtree. Returns the number of world transforms recomputed (0 when
 * nothing changed). */
uint32_t hz_scene_update(hz_scene *s);
/* After hz_scene_update: the node's world matrix, and the world box of its
 * mesh (empty without) and of its whole subtree. */
void hz_scene_world_matrix(const hz_scene *s, uint32_t node, mat4 dest);
void hz_scene_node_bounds(const hz_scene *s, uint32_t node, hz_box *dest);
void hz_scene_subtree_bounds(const hz_scene *s, uint32_t node, hz_box *dest);
/* The box of everything (empty for an empty scene). */
void hz_scene_bounds(const hz_scene *s, hz_box *dest);

/* Depth-first traversal from every root, parents before children, children
 * in the order they were added. fn returns false to skip the node's
 * children. */
typedef bool (*hz_scene_visit_fn)(void *user, const hz_scene *s, uint32_t node, uint32_t depth);
void hz_scene_visit(const hz_scene *s, hz_scene_visit_fn fn, void *user);

/* ---- culling (G3) ---------------------------------------------------------- */

typedef struct hz_cull_stats {
    uint32_t objects;        /* nodes with a mesh in the scene */
    uint32_t visible;        /* written to out */
    uint32_t nodes_tested;   /* boxes tested against the planes */
    uint32_t subtrees_culled;/* subtrees dropped whole */
    uint32_t subtrees_inside;/* subtrees accepted whole (fully inside, children not tested) */
    uint32_t in_frustum;     /* nodes with a mesh in the frustum (before occlusion) */
    uint32_t occlusion_tests;/* boxes tested against the occlusion buffer */
    uint32_t subtrees_hidden;/* subtrees (of more than one node) it hid whole */
} hz_cull_stats;

/* Box against planes (hz_camera_frustum layout: inside when dot(n, p) + d
 * >= 0): -1 outside, 0 intersecting, 1 inside. */
int hz_box_vs_planes(const hz_box *b, const vec4 *planes, uint32_t plane_count);

/* Hierarchical frustum culling: a subtree whose box is outside a plane is
 * dropped, one fully inside is taken without further tests. Writes the ids
 * of visible nodes that have a mesh to out (depth-first order) and returns
 * how many there are (may exceed cap: then only cap were written). After
 * hz_scene_update. stats may be NULL. */
uint32_t hz_scene_cull(const hz_scene *s, const vec4 planes[6], uint32_t *out, uint32_t cap, hz_cull_stats *stats);
/* hz_scene_cull for the objects as cam draws them: with cam->earth_radius,
 * every box is first lowered by the Earth curvature (hz_camera_curve_box);
 * planes are cam's frustum (or any planes the caller wants). */
uint32_t hz_scene_cull_curved(const hz_scene *s, const hz_camera *cam, const vec4 planes[6], uint32_t *out,
                              uint32_t cap, hz_cull_stats *stats);
/* The same with hierarchical occlusion culling (G4): a subtree whose box
 * occ (a buffer begun for cam; NULL: none) hides is dropped whole, and so
 * is a node whose own box it hides. Its nodes in the frustum still count in
 * stats->in_frustum. */
struct hz_occlusion;
uint32_t hz_scene_cull_occluded(const hz_scene *s, const hz_camera *cam, const vec4 planes[6],
                                const struct hz_occlusion *occ, uint32_t *out, uint32_t cap, hz_cull_stats *stats);

/* ---- render queue (G5) ------------------------------------------------------ */

/* Orders nodes[0..n) nearest first by the distance from eye to each node's
 * world box (0 for an eye inside it); stable: equal distances keep their
 * order. tmp: scratch of 3 * n entries. After hz_scene_update. Fed to
 * hz_scene_queue_build, the instances of each item come nearest first. */
void hz_scene_sort_near_first(const hz_scene *s, const float eye[3], uint32_t *nodes, uint32_t n, uint32_t *tmp);

/* A draw: consecutive instances of one mesh with one material. */
typedef struct hz_draw_item {
    uint32_t shader, material, mesh;
    uint32_t first;      /* into the queue's node array: the instances' nodes */
    uint32_t count;      /* instances */
} hz_draw_item;

typedef struct hz_queue_stats {
    uint32_t objects;        /* nodes queued */
    uint32_t items;          /* draw items (one per distinct shader/material/mesh run) */
    uint32_t shader_changes; /* program binds in queue order (the first counts) */
    uint32_t material_changes; /* material uniform changes (the first counts) */
} hz_queue_stats;

/* Builds the render queue of nodes (e.g. hz_scene_cull's output):
 * sorted = true orders by (shader, material, mesh, then node order: stable)
 * and merges equal (shader, material, mesh) into one item with several
 * instances; false keeps the given order, one item per node (the naive
 * baseline). nodes_out receives the nodes in queue order (count entries),
 * items at most count entries. Returns the item count, or 0 with *stats
 * zero on out of memory (count > 0). stats may be NULL. */
uint32_t hz_scene_queue_build(const hz_scene *s, const uint32_t *nodes, uint32_t count, bool sorted,
                              uint32_t *nodes_out, hz_draw_item *items, hz_queue_stats *stats);

/* An item's material when materials are instance data. */
#define HZ_MATERIAL_PER_INSTANCE UINT32_MAX
/* hz_scene_queue_build for materials given to the shader per instance
 * (hz_scene_gpu_draw passes their colour with each instance's matrix, so
 * they are no state to change between draws): sorted orders by (shader,
 * mesh) and merges equal ones into one item whose instances keep the node
 * order whatever their material (nearest first after
 * hz_scene_sort_near_first: near walls hide far ones of any colour before
 * they are shaded). Items' material is HZ_MATERIAL_PER_INSTANCE and
 * stats->material_changes 0. */
uint32_t hz_scene_queue_build_instanced(const hz_scene *s, const uint32_t *nodes, uint32_t count, bool sorted,
                                        uint32_t *nodes_out, hz_draw_item *items, hz_queue_stats *stats);

/* ---- what stands on the ground ------------------------------------------------ */

/* Raises tops (size x size samples, row-major, sample (i, j) at world
 * x = i * spacing, z = j * spacing) to the highest point of the scene's mesh
 * triangles over each sample: a triangle whose ground projection covers
 * sample points raises them to its own height there; one that covers none
 * (smaller than a sample cell, or edge-on, as a wall) raises the sample
 * nearest its centre to its highest vertex. Samples under nothing keep
 * their value (-INFINITY for "nothing stands here"). After hz_scene_update.
 * Returns how many samples were -INFINITY and were raised. */
uint64_t hz_scene_heights(const hz_scene *s, uint32_t size, float spacing, float *tops);

/* ---- picking ---------------------------------------------------------------- */

typedef struct hz_scene_hit {
    uint32_t node;     /* HZ_NODE_NONE: no mesh hit */
    float t;           /* ray parameter: hit = origin + t * dir */
    float pos[3];      /* world */
    uint32_t triangle; /* within the node's mesh */
} hz_scene_hit;

/* Nearest intersection of a ray (world, dir need not be unit) with the
 * scene's mesh triangles (both faces) with t in (0, t_max). Tests the
 * subtree boxes first. True if something was hit. After hz_scene_update. */
bool hz_scene_raycast(const hz_scene *s, const float origin[3], const float dir[3], float t_max, hz_scene_hit *hit);

#ifdef __cplusplus
}
#endif
#endif
