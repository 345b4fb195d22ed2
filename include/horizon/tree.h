/* horizon trees (SPEC F1, F2, F5): procedural growth, the branch / leaf-node
 * hierarchy, the .hzt file, VMI leaf ranking maths and the crown hull.
 * No GL: the item buffers that feed the ranking are rendered by the render
 * module (horizon/render.h: hz_tree_rank).
 *
 * Model space: metres, +y up, the trunk base at the origin. */
#ifndef HORIZON_TREE_H
#define HORIZON_TREE_H

#include "horizon/core.h"

#ifdef __cplusplus
extern "C" {
#endif

#define HZ_TREE_NONE 0xffffffffu
#define HZ_TREE_MAX_LEVELS 6u
/* Metres: a tree coordinate (branch ends, leaf centres and axes, bark and
 * hull vertices) beyond this is refused as absurd by hz_tree_validate, the
 * .hzt reader and the importer. */
#define HZ_TREE_MAX_COORD 1e6f

/* A branch node (F1): one stem. The trunk has level 1, its children 2, ... */
typedef struct hz_tree_branch {
    uint32_t parent;     /* branch index, HZ_TREE_NONE for the trunk; parent < own index */
    uint32_t level;      /* 1 = trunk; parent's level + 1 */
    uint32_t leaf_node;  /* index of its leaf node, HZ_TREE_NONE if it carries no leaves */
    float length;        /* metres along the stem */
    float radius;        /* metres, at the base */
    float base[3];       /* model space */
    float tip[3];
    float dir[3];        /* unit growth direction (base -> tip) */
} hz_tree_branch;

/* A leaf: a quad of two triangles, corners c +- u +- v. */
typedef struct hz_tree_leaf {
    float c[3];  /* centre */
    float u[3];  /* half axis along the leaf (from the petiole to the tip) */
    float v[3];  /* half axis across; the leaf normal is u x v */
} hz_tree_leaf;

/* A leaf node (F1): the leaves of one last-level branch, stored contiguously
 * in hz_tree.leaves[first .. first + count). Once ranked (F2) they are in
 * order of importance, so drawing a LOD is drawing a prefix. */
typedef struct hz_tree_node {
    uint32_t branch;     /* the branch that carries it */
    uint32_t first, count;
    float center[3];     /* bounding sphere of its leaves' corners */
    float radius;
    float ld;            /* initial leaf density: leaves per metre of branch (F3 f3) */
    uint32_t bsl;        /* bounding-sphere layer in the crown, 1 (outer) .. 3 (inner) (F3 f1) */
} hz_tree_node;

/* A triangle mesh: positions and normals (3 floats each per vertex), indices. */
typedef struct hz_tree_mesh {
    float *pos, *nrm;
    uint32_t vertex_count;
    uint32_t *idx;
    uint32_t index_count;
} hz_tree_mesh;

typedef struct hz_tree {
    char species[32];
    uint64_t seed;
    uint32_t levels;                 /* branch levels, trunk = 1 */
    hz_tree_branch *branches;
    uint32_t branch_count;
    hz_tree_node *nodes;
    uint32_t node_count;
    hz_tree_leaf *leaves;
    uint32_t leaf_count;
    /* Bark: triangles sorted by branch level, so the first level_end[k-1]
     * indices draw levels 1..k (level_end[levels-1] == index_count). */
    hz_tree_mesh bark;
    uint32_t bark_level_end[HZ_TREE_MAX_LEVELS];
    hz_tree_mesh hull;               /* crown hull (F5); empty until built */
    float leaf_color[3], bark_color[3]; /* linear RGB */
    float crown_center[3], crown_radius; /* bounding sphere of the leaves */
    float bound_center[3], bound_radius; /* of the whole tree */
    float height;                    /* metres */
    /* Ranking (F2): set by hz_tree_rank. */
    bool ranked;
    uint32_t rank_views, rank_res, rank_layers;
    double rank_ms;
} hz_tree;

/* ---- growth (Weber & Penn 1995 style) ------------------------------------ */

typedef struct hz_tree_desc {
    const char *species;   /* "oak", "maple", "birch", "conifer"; NULL -> "oak" */
    uint64_t seed;
    uint32_t leaves;       /* target leaf count (within ~10% from 1 000 leaves up); 0 -> the species' own
                              (50 000 .. 300 000) */
} hz_tree_desc;

/* Names of the built-in species, NULL-terminated. */
const char *const *hz_tree_species_names(void);

/* Grows a tree: recursive stems with per-level length, curve, down angle,
 * rotation and branching; leaves on the last-level stems, one leaf node per
 * such stem. Deterministic for (species, seed, leaves). NULL + err on an
 * unknown species or absurd leaf count (> 2 000 000). Destroy with
 * hz_tree_destroy. */
hz_tree *hz_tree_grow(const hz_tree_desc *desc, hz_err *err);
void hz_tree_destroy(hz_tree *t);

/* Recomputes derived data from branches and leaves: node spheres, leaf
 * densities, bounding-sphere layers, crown and tree bounds, height. */
void hz_tree_finish(hz_tree *t);

/* Checks the hierarchy and the meshes: parents before children, levels =
 * parent + 1, trunk first, every leaf in exactly one node, node ranges in
 * bounds, node branches carry the node, indices < vertex counts, finite
 * numbers, coordinates within HZ_TREE_MAX_COORD. HZ_OK or HZ_ERR_FORMAT with
 * the first problem in err. */
hz_result hz_tree_validate(const hz_tree *t, hz_err *err);

/* Triangles of the full tree: 2 per leaf plus the bark. */
uint64_t hz_tree_triangles(const hz_tree *t);
/* Bytes of heap memory the tree holds. */
size_t hz_tree_memory_bytes(const hz_tree *t);

/* ---- .hzt files ----------------------------------------------------------- */

/* Binary, little-endian, CRC-32 checked (README: "Tree files"). */
hz_result hz_tree_save(const hz_tree *t, const char *path, hz_err *err);
/* NULL + err (naming the file and the problem) on a missing, truncated,
 * corrupt or inconsistent file. */
hz_tree *hz_tree_load(const char *path, hz_err *err);
/* In-memory forms (the file's bytes). save_mem: *data is malloc'ed. */
hz_result hz_tree_save_mem(const hz_tree *t, uint8_t **data, size_t *size, hz_err *err);
hz_tree *hz_tree_load_mem(const uint8_t *data, size_t size, hz_err *err);
/* The CRC the file format uses (zlib crc32), for tools and tests. */
uint32_t hz_tree_crc32(const uint8_t *data, size_t size);

/* ---- import (assimp) ------------------------------------------------------ */

typedef struct hz_tree_import_desc {
    const char *path;        /* OBJ, glTF, FBX... anything assimp reads */
    const char *leaf_match;  /* meshes whose mesh, node or material name contains this
                                (case-insensitive) are leaves; NULL -> "leaf", "leaves",
                                "foliage", "needle" */
    char up;                 /* 'y' or 'z'; 0 -> the axis of the largest extent */
    float scale;             /* 0 -> 1 (file units are metres) */
    uint32_t node_leaves;    /* max leaves per leaf node; 0 -> 48 */
    uint64_t max_memory;     /* bytes the import may take (checked on the file size before
                                assimp reads it, and on the meshes before copying them);
                                0 -> hz_mem_budget_default() */
} hz_tree_import_desc;

/* Imports a tree: leaf meshes are split into connected pieces, each refit as
 * a quad (centroid, principal axes); bark pieces become branches (the one
 * reaching lowest is the trunk, level 1, the rest level 2); each leaf joins
 * the nearest bark piece, whose leaves form leaf nodes of at most
 * node_leaves (split along their longest axis). NULL + err when the file
 * cannot be read or has no leaves or no bark. */
hz_tree *hz_tree_import(const hz_tree_import_desc *desc, hz_err *err);

/* ---- VMI (F2) -------------------------------------------------------------- */

#define HZ_VMI_EMPTY 0xffffu

/* Item-buffer results for one leaf node: for each view, the covered pixels,
 * each with up to `layers` local leaf ids (0 .. leaf_count-1) front to back,
 * padded with HZ_VMI_EMPTY. */
typedef struct hz_vmi_input {
    uint32_t leaf_count;    /* n <= 65535 */
    uint32_t view_count;    /* Nv */
    uint32_t layers;        /* ids per pixel */
    const uint32_t *view_start; /* view_count + 1 pixel offsets */
    const uint16_t *ids;    /* view_start[view_count] * layers */
} hz_vmi_input;

/* Conventions: p(v) = 1/Nv (uniform), log base 2 (bits). a_o = pixels where
 * leaf o is the front-most remaining leaf; p(o|v) = a_o/a_t,
 * p(o) = (1/Nv) sum_v p(o|v), I(v,O) = sum_o p(o|v) log2(p(o|v)/p(o)).
 *
 * Computes I(v, O) for every view from a counts matrix counts[o * Nv + v].
 * Views with no visible pixel get 0. vmi: Nv values. */
void hz_vmi_compute(const uint32_t *counts, uint32_t n, uint32_t nv, double *vmi);

typedef struct hz_vmi_stats {
    uint32_t steps;             /* removals evaluated (n) */
    uint64_t candidates;        /* e_VMI evaluations */
    uint64_t transfers_updated; /* candidates whose pixel transfers were recomputed */
} hz_vmi_stats;

/* Greedy VMI ranking of one leaf node. Backward elimination: repeatedly
 * remove the leaf whose removal changes the VMI least,
 * e_VMI = sum_v |I(v,O) - I(v,O\{o})|, where removing o hands each of its
 * pixels to the next remaining leaf behind it (or the background). After
 * each removal the counts are updated incrementally from the pixel lists
 * (no re-rendering), and only the leaves whose pixels changed recompute
 * their transfers. The reverse of the removal order is the ranking: order[0]
 * is the most important leaf. order: leaf_count local ids. stats may be NULL.
 * HZ_ERR_MEMORY or HZ_ERR_VALUE (ids out of range). */
hz_result hz_vmi_rank(const hz_vmi_input *in, uint32_t *order, hz_vmi_stats *stats, hz_err *err);

/* Reorders each node's leaves: node_orders holds, node after node, each
 * node's local order (a permutation of 0..count-1). */
hz_result hz_tree_apply_order(hz_tree *t, const uint32_t *node_orders, hz_err *err);

/* Coverage of leaf prefixes (F4 by coverage): cov[l] (one float per leaf,
 * tree order) = the share of its node's projected leaf area, summed over 12
 * views around the node, that the node's leaves up to and including l
 * cover. 1 at each node's last leaf; VMI orders reach high values early.
 * HZ_ERR_VALUE for a node of 65535 leaves or more. */
hz_result hz_tree_prefix_coverage(const hz_tree *t, float *cov, hz_err *err);
/* F4 by coverage: the enlargement that gives a prefix covering `cov` of its
 * node's area the whole area back, sqrt(1 / cov), capped at max_enlarge
 * (0 -> 3); 1 for cov >= 1. */
float hz_enlarge_coverage(float max_enlarge, float cov);

/* Viewpoints on the unit sphere: vertices of a subdivided icosahedron.
 * count must be 12, 42 or 162 (0, 1, 2 subdivisions); dirs: count * 3
 * floats, unit vectors. false for another count. */
bool hz_sphere_views(uint32_t count, float *dirs);

/* ---- crown hull (F5) ------------------------------------------------------ */

typedef struct hz_hull_desc {
    uint32_t grid;          /* voxels along the longest crown axis; 0 -> 40 */
    float blur;             /* Gaussian sigma in voxels; 0 -> 2.5 */
    float coverage;         /* fraction of leaf centres inside the hull; 0 -> 0.9 */
    uint32_t triangles;     /* simplification target; 0 -> 3000 */
} hz_hull_desc;

typedef struct hz_hull_stats {
    uint32_t grid[3];
    uint32_t raw_triangles;  /* iso-surface before simplification */
    uint32_t triangles;      /* after */
    double ms;
} hz_hull_stats;

/* Crown hull: leaf centres and last-level branch tips splatted into a
 * density grid, blurred, iso-surfaced by marching tetrahedra (closed,
 * manifold), simplified with meshoptimizer. Replaces t->hull. stats may be
 * NULL. */
hz_result hz_hull_build(hz_tree *t, const hz_hull_desc *desc, hz_hull_stats *stats, hz_err *err);

/* A coarser copy of a mesh (meshoptimizer, sloppy when the topology-keeping
 * simplification stops short) of about `triangles` triangles, normals
 * recomputed; a mesh already that small is copied. out is allocated (free
 * its arrays). For far LODs, where holes do not matter. */
hz_result hz_mesh_simplify(const hz_tree_mesh *in, uint32_t triangles, hz_tree_mesh *out, hz_err *err);

/* Topology of an indexed triangle mesh: counts edges used by other than
 * exactly two triangles with opposite orientation (open or non-manifold
 * edges), vertices whose triangle fan is not one cycle, and degenerate
 * triangles (repeated index). A closed manifold has all three zero. */
typedef struct hz_mesh_topology {
    uint64_t bad_edges, bad_vertices, degenerate;
    uint64_t edges;
    int64_t euler;   /* V - E + F over used vertices */
} hz_mesh_topology;
hz_result hz_mesh_check(const uint32_t *idx, uint32_t index_count, uint32_t vertex_count,
                        hz_mesh_topology *out, hz_err *err);

#ifdef __cplusplus
}
#endif
#endif
