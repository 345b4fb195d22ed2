/* horizon forest rendering (GL side of SPEC F2, F4, F7): the item buffers
 * that rank leaves by VMI, foliage coverage for precision/recall, and the
 * instanced forest drawn through the renderer's object hook.
 * All functions need a current OpenGL 4.5 (3.3 for the item buffer) context. */
#ifndef HORIZON_FOREST_RENDER_H
#define HORIZON_FOREST_RENDER_H

#include "horizon/forest.h"
#include "horizon/render.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- VMI ranking (F2) ------------------------------------------------------- */

typedef struct hz_rank_desc {
    uint32_t views;    /* viewpoints: 12, 42 or 162 (icosahedron, 0/1/2 subdivisions); 0 -> 162 */
    int32_t min_elevation; /* degrees (-90..90): viewpoints below this elevation seen from the
                              crown are left out. 0 (default) keeps the upper hemisphere and
                              the horizon's ring, the views a much simplified (distant) tree is
                              seen from; -90 keeps the whole sphere. t->rank_views counts those used */
    uint32_t res;      /* item-buffer pixels across one leaf node's bounding sphere; 0 -> 32 */
    uint32_t layers;   /* depth-peeled layers kept per pixel; 0 -> 4 */
    uint32_t tree_res; /* 0: each node rendered alone, res pixels across it, as F2 reads literally;
                          else the whole tree rendered tree_res pixels across (512..4096), so that a
                          leaf's visible area is what the rest of the crown leaves of it;
                          t->rank_res records it (> 256 says: ranked in the tree) */
    hz_progress_fn progress; /* optional */
    void *progress_user;
} hz_rank_desc;

/* The tree_res horizon's commands rank at (tree, and the forests' models):
 * the leaves of the grown species are about a pixel across there, and the
 * VMI order keeps more of the full tree's own leaves at 50 % than ranked
 * node by node, and than at 1024 (README, "VMI ranking"). */
#define HZ_RANK_TREE_RES 2048u

typedef struct hz_rank_stats {
    double ms, render_ms, vmi_ms;
    uint64_t pixels;          /* covered item-buffer pixels (all views, all nodes) */
    uint64_t deep_pixels;     /* pixels whose last kept layer was still a leaf */
    uint64_t candidates;      /* e_VMI evaluations */
    uint32_t nodes, batches;
} hz_rank_stats;

/* Ranks every leaf node's leaves by VMI and reorders them most important
 * first (t->ranked, rank_views/res/layers/ms are set). Each leaf node is an
 * object of its own (F2): its leaves are rendered alone, orthographically
 * from the `views` directions at or above min_elevation, framing its
 * bounding sphere, into tiles of an
 * atlas (R32UI leaf ids, depth-peeled into `layers` layers), and ranked by
 * hz_vmi_rank. stats may be NULL. */
hz_result hz_tree_rank(hz_tree *t, const hz_rank_desc *desc, hz_rank_stats *stats, hz_err *err);

/* ---- precision / recall of foliage coverage (F7) ------------------------------ */

typedef struct hz_pr_desc {
    uint32_t views;    /* 0 -> 16: 8 azimuths x elevations 0 and 35 degrees */
    uint32_t res;      /* image side in pixels; 0 -> 512 */
    float rate;        /* simplification rate of every leaf node; 0 -> none (the full tree) */
    bool enlarge;      /* F4 on the simplified tree */
} hz_pr_desc;

typedef struct hz_pr_result {
    double precision, recall, f_measure; /* of foliage coverage */
    uint64_t tp, fp, fn;
    /* Of what each pixel shows: TP where both images show the same leaf, FP
     * where the simplified one shows a leaf the full one does not show there,
     * FN where the full one shows a leaf the simplified one does not. */
    double leaf_precision, leaf_recall, leaf_f_measure;
    uint64_t leaf_tp, leaf_fp, leaf_fn;
    uint32_t views, res;
} hz_pr_result;

/* Renders the tree's leaves (no bark) as leaf-id images from each view, full
 * and simplified (the first ceil((1-rate) n) leaves of every node, enlarged
 * by F4 if asked). Coverage: sums TP (foliage in both), FP (simplified
 * only), FN (full only). Same leaf: the leaf_ counts above, so a leaf
 * exposed by pruning, or an enlarged leaf over its removed neighbour, counts
 * against it although the pixel is still foliage. The order is the tree's
 * current leaf order. */
hz_result hz_tree_pr(const hz_tree *t, const hz_pr_desc *desc, hz_pr_result *out, hz_err *err);

/* Copy of t whose leaves are in a random order within each node (the
 * random-pruning baseline). NULL on out of memory. */
hz_tree *hz_tree_shuffled(const hz_tree *t, uint64_t seed, hz_err *err);

/* The random-pruning baseline as an expectation, not one draw: hz_tree_pr
 * of `shuffles` random orders of t's leaves (hz_tree_shuffled with seeds
 * seed, seed + 1, ...), their counts pooled into out (the ratios are those
 * of the sums). each, if not NULL, receives every shuffle's own result
 * (`shuffles` of them), for the spread. shuffles in 1..HZ_PR_ORDERS_MAX. */
#define HZ_PR_ORDERS_MAX 64u
#define HZ_PR_ORDERS_DEFAULT 4u /* what horizon tree and bench pool unless told */
hz_result hz_tree_pr_random(const hz_tree *t, const hz_pr_desc *desc, uint32_t shuffles, uint64_t seed,
                            hz_pr_result *out, hz_pr_result *each, hz_err *err);

/* ---- forest drawing ------------------------------------------------------------ */

typedef struct hz_forest_gpu hz_forest_gpu;

/* Uploads the forest's models (leaves interleaved by rank as texture
 * buffers with a static quad index buffer, bark and hull meshes) and bakes
 * each model's impostor atlas (12 azimuths x 4 elevations, albedo and
 * normals, from the full tree). NULL + err on GL failure. */
hz_forest_gpu *hz_forest_gpu_create(const hz_forest *f, hz_err *err);
void hz_forest_gpu_destroy(hz_forest_gpu *g);

/* Baked impostors can be kept (e.g. on disk, include/horizon/blob.h) and
 * given back instead of baking them again (about one second per model). */
typedef struct hz_forest_gpu_desc {
    /* Per model (hz_forest_model_count entries), NULL or a model's impostor
     * as hz_forest_gpu_impostor_read wrote it (hz_forest_gpu_impostor_bytes
     * bytes), for a tree of the same hz_forest_gpu_impostor_key: used as it
     * is. NULL entries, or a NULL array, are baked. */
    const uint8_t *const *impostors;
    /* Optional: called as the impostors are baked ("bake impostors", views
     * done, views to bake; not called when none is baked). */
    hz_progress_fn progress;
    void *progress_user;
} hz_forest_gpu_desc;
hz_forest_gpu *hz_forest_gpu_create_with(const hz_forest *f, const hz_forest_gpu_desc *d, hz_err *err);
/* Bytes of one model's impostor: the albedo then the normal atlas, RGBA8,
 * full resolution (the mipmaps are rebuilt). */
size_t hz_forest_gpu_impostor_bytes(void);
/* A hash of everything a model's impostor depends on (its leaves, nodes,
 * bark, colours, and the bake's shaders and layout): the key to keep it
 * under. */
uint64_t hz_forest_gpu_impostor_key(const hz_tree *t);
/* Copies model's impostor (hz_forest_gpu_impostor_bytes) to out. */
hz_result hz_forest_gpu_impostor_read(const hz_forest_gpu *g, uint32_t model, uint8_t *out, hz_err *err);
/* Whether model's impostor was baked by this hz_forest_gpu (not given). */
bool hz_forest_gpu_impostor_baked(const hz_forest_gpu *g, uint32_t model);

/* Draws a frame's selection with a pass's matrices, lighting and fog:
 * detailed trees as leaf prefixes per node (per node group, the range of
 * the static leaf order holding the kept leaves; only changed node counts
 * are uploaded), as quads or, where leaves are a few pixels long, points
 * (hz_forest_gpu_point_leaves), F4 enlargement in the vertex shader, bark by
 * level, middle trees as crown hulls shaded from their impostor, far trees
 * as impostors (one draw), dithered across the fade bands. */
hz_result hz_forest_gpu_draw(hz_forest_gpu *g, const hz_forest *f, const hz_forest_frame *fr,
                             const hz_pass_info *pass, hz_err *err);

/* Bytes of node counts the last drawn frame uploaded (only changed nodes). */
uint64_t hz_forest_gpu_upload_bytes(const hz_forest_gpu *g);

/* Leaves drawn as points: a detailed tree whose nearest leaves are at most
 * max_px pixels long on screen (mean leaf, before enlargement) draws each
 * leaf as one point that the fragment shader cuts to the leaf's projected
 * outline (one vertex instead of four); nearer trees, and every tree of an
 * unsimplified frame (the reference), draw quads. Default 16; 0 draws every
 * leaf as a quad. Returns the previous value. */
float hz_forest_gpu_point_leaves(hz_forest_gpu *g, float max_px);
/* A billboard sprite of a model, from its impostor's side view (baked from
 * the full tree): RGBA8 w x h, top row first, the trunk's foot at the bottom
 * centre, the tree's top at the top row; the image is width_frac times as
 * wide as high in metres (a crown wider than that lowers the tree in the
 * frame). Unlit albedo with coverage as alpha, for the effects' billboards
 * (hz_renderer_set_billboard_texture) so that they show the forest's trees. */
hz_result hz_forest_gpu_sprite(const hz_forest_gpu *g, const hz_forest *f, uint32_t model, float width_frac,
                               uint32_t w, uint32_t h, uint8_t *rgba, hz_err *err);
/* Detailed trees the last main pass drew as points. */
uint32_t hz_forest_gpu_point_trees(const hz_forest_gpu *g);
/* With on, each main pass is split by glFinish into its three parts, timed
 * (ms): [0] leaves (with the count upload), [1] bark and crown hulls, [2]
 * impostors; read them with hz_forest_gpu_part_ms (NULL when off). */
void hz_forest_gpu_time_parts(hz_forest_gpu *g, bool on);
const double *hz_forest_gpu_part_ms(const hz_forest_gpu *g);

/* Ready-made hz_draw_hook_fn: set draw_objects = hz_forest_draw_hook and
 * draw_objects_user = a hz_forest_hook. Errors land in hook->err/failed. */
typedef struct hz_forest_hook {
    hz_forest_gpu *gpu;
    const hz_forest *forest;
    const hz_forest_frame *frame;
    /* Time the forest's own GL work (draw_ms): the main pass waits for the
     * GPU before and after it. On a GPU those waits drain the pipeline
     * every frame (on llvmpipe the frame shows no measurable cost), so
     * leave it off for speed. */
    bool time_draw;
    bool failed;
    hz_err err;
    double draw_ms;  /* the last main pass: its GL time with time_draw, else its submission's CPU time */
} hz_forest_hook;
void hz_forest_draw_hook(void *user, const hz_pass_info *pass);

#ifdef __cplusplus
}
#endif
#endif
