/* horizon quadtree LOD (SPEC T2-T7): per-node roughness and min/max
 * precomputation, and the per-frame breadth-first selection that emits one
 * crack-free triangle list into the full-resolution sample grid. No GL.
 *
 * Nodes: a node is its centre sample (x, z) and half-size s (a power of two);
 * it covers samples [x-s, x+s] x [z-s, z+s]. Level 0 is the root (s = (size-1)/2),
 * level levels-1 holds the smallest nodes (s = 1, 3x3 samples). */
#ifndef HORIZON_LOD_H
#define HORIZON_LOD_H

#include "horizon/camera.h"
#include "horizon/heightmap.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct hz_lod hz_lod;

typedef struct hz_lod_desc {
    const hz_heightmap *hm; /* required; retained: must outlive the hz_lod */
    float spacing;          /* metres between samples; 0 -> 1 */
    float zscale;           /* height multiplier; 0 -> 1; must be > 0 */
    float propagate_c;      /* C for Röttger's upward propagation of d2,
                               K = C / (2 (C - 1)); 0 -> 25 (clamped to >= 2) */
    uint32_t patch_cells;   /* cdlod: grid cells per side of the patch every node is drawn
                               with, a power of two >= 2; 0 -> 8 (clamped to the map) */
    bool holes;             /* some samples are not drawn (nodata): a ray may pass under the
                               ground through them, so no horizon culling */
    hz_progress_fn progress; /* optional */
    void *progress_user;
} hz_lod_desc;

/* Precomputes d2 (propagated) and the min/max pyramid. NULL + err on failure. */
hz_lod *hz_lod_create(const hz_lod_desc *desc, hz_err *err);
void hz_lod_destroy(hz_lod *lod);

/* Bytes of all LOD data including the 16-bit heights (heights, d2, min/max,
 * flags), and per sample. */
size_t hz_lod_memory_bytes(const hz_lod *lod);
double hz_lod_bytes_per_sample(const hz_lod *lod);

typedef enum hz_lod_criterion {
    HZ_LOD_CLAMPED = 0, /* Röttger: split when l / (d C max(C2 d2, 1)) < 1 (default) */
    HZ_LOD_UNCLAMPED    /* the seed's form: split when l / (d C C2 d2) < 1 */
} hz_lod_criterion;

/* Level-of-detail methods (SPEC T6, G2 and beyond). All emit one crack-free
 * triangle list into the full-resolution sample grid. */
typedef enum hz_lod_mode {
    HZ_LOD_QUADTREE = 0,   /* seed 000: restricted quadtree, breadth-first, fans skip
                              the edge midpoints toward coarser neighbours (T6a) */
    HZ_LOD_REMEDY,         /* seed 003: recursive, any level difference; fans insert
                              the finer neighbours' edge vertices (T6b) */
    HZ_LOD_BIDIRECTIONAL,  /* seed 001: free selection, then where neighbours differ by
                              >= 2 levels coarsen the fine side beyond distance m, else
                              split the coarse side (T6c) */
    HZ_LOD_ROAM,           /* seed 002: binary triangle tree with split and merge queues,
                              forced splits, frame-to-frame coherence (G2) */
    HZ_LOD_CDLOD,          /* screen-space error bound in pixels, restricted quadtree with
                              forced splits and per-vertex geomorphing (no popping) */
    HZ_LOD_MODE_COUNT
} hz_lod_mode;

/* "quadtree", "remedy", "bidirectional", "roam", "cdlod". */
const char *hz_lod_mode_name(hz_lod_mode mode);
/* False if the name is unknown. */
bool hz_lod_mode_from_name(const char *name, hz_lod_mode *mode);

/* cdlod's morph start (hz_lod_params.morph_start): the range it is clamped
 * to and its default. The lower end is where the morph zones of two
 * consecutive levels would begin to overlap. */
#define HZ_LOD_MORPH_START_MIN 0.8
#define HZ_LOD_MORPH_START_MAX 0.98
#define HZ_LOD_MORPH_START_DEFAULT 0.95

typedef struct hz_lod_params {
    hz_lod_mode mode;     /* 0 -> quadtree */
    float c;              /* distance factor C; 0 -> 25 */
    float c2;             /* roughness factor C2; 0 -> 2.5 */
    hz_lod_criterion criterion;
    bool no_cull;         /* keep every node regardless of the frustum (tests, references) */
    float pixel_error;    /* screen-space error bound tau in pixels. > 0: quadtree, remedy
                             and bidirectional split when the projected d2 error
                             d2 * d * K / l > tau (K = viewport_height / (2 tan(fov/2)))
                             instead of using C and C2. roam and cdlod always use it;
                             0 -> 1 px for them */
    uint32_t viewport_height; /* pixels, for pixel_error; 0 -> 720 */
    float bidir_distance; /* bidirectional: m in metres; 0 -> 0.25 x the camera's far distance */
    uint32_t roam_budget; /* roam: at most this many triangles; 0 -> no budget */
    float morph_start;    /* cdlod: fraction of a vertex's range where morphing starts, clamped to
                             [HZ_LOD_MORPH_START_MIN, _MAX]; 0 -> HZ_LOD_MORPH_START_DEFAULT */
    bool horizon_cull;    /* cdlod patches: drop those that nearer ground hides (horizon
                             culling; off by default: it costs about 1 ms of CPU a frame on
                             the peers' flight, which pays on llvmpipe, not on a GPU; run it
                             beside the drawing with hz_lod_horizon_hide; no_cull turns it
                             off) */
    /* cdlod: a looser bound near the eye. Within near_distance metres the
     * bound is near_pixel_error (> pixel_error; otherwise off); beyond, it
     * tightens as 1 / sqrt(distance) and is pixel_error from
     * near_distance * (near_pixel_error / pixel_error)^2 on. The far ground
     * (the skyline) keeps pixel_error while the near ground, whose shape
     * the full-resolution shading hides, gets fewer triangles. The bound
     * depends on the distance alone, so every vertex keeps one morph range
     * (hz_lod_morph_range) and nothing pops. A vertex whose bound is looser
     * morphs over a wider zone (its error, larger, would otherwise drift
     * across the zone faster): from the range times
     * max(HZ_LOD_MORPH_START_MIN, 1 - (1 - morph_start) (tau(R) / tau)^2). */
    float near_pixel_error;
    float near_distance;  /* metres; 0 -> HZ_LOD_NEAR_DISTANCE_DEFAULT */
} hz_lod_params;

#define HZ_LOD_NEAR_DISTANCE_DEFAULT 500.0f

/* A growable array the caller owns; free with free(list->data). */
typedef struct hz_index_list {
    uint32_t *data; /* triangles, 3 indices each, index = z * size + x */
    size_t count, cap;
} hz_index_list;

typedef struct hz_lod_node {
    uint32_t x, z, half;
    uint32_t level;
} hz_lod_node;

typedef struct hz_node_list {
    hz_lod_node *data;
    size_t count, cap;
} hz_node_list;

typedef struct hz_lod_stats {
    uint32_t nodes_visited; /* nodes whose criterion or box was evaluated */
    uint32_t nodes_culled;  /* nodes dropped by the frustum */
    uint32_t leaves;        /* nodes drawn as fans */
    uint32_t restricted;    /* splits refused because a neighbour was coarser */
    uint32_t triangles;
    uint32_t max_level;
    uint32_t forced;        /* cdlod / roam: splits forced to keep the mesh crack-free;
                               bidirectional: coarse nodes split */
    uint32_t merged;        /* bidirectional: fine subtrees coarsened; roam: merges */
    uint32_t still;         /* cdlod patches: those none of whose vertices morphs (hz_patch.still) */
    uint32_t simple;        /* ... those none of whose even vertices morphs (hz_patch.simple) */
    uint32_t hidden;        /* cdlod patches dropped because nearer ground hides them */
    float morph_scale;      /* cdlod: metres of morph range per h16 step of a vertex's
                               morph error at pixel_error (0: no morphing this frame);
                               hz_lod_morph_range applies the near bound */
    float morph_start;      /* cdlod: morph starts at this fraction of the range */
    float morph_near;       /* cdlod: pixel_error / near_pixel_error (1: no near bound) */
    float morph_near_distance; /* cdlod: the near bound's distance, metres */
    double ms;              /* CPU time of the selection */
} hz_lod_stats;

/* What hz_lod_horizon_hide hid. */
typedef struct hz_horizon_stats {
    uint32_t patches;   /* patches hidden */
    uint32_t triangles; /* their triangles and the quadrants' (as hz_lod_stats.triangles counts them) */
    uint32_t still;     /* those of them still (hz_patch.still) */
    uint32_t simple;    /* those of them morphing simply or still (hz_patch.simple) */
    uint32_t quadrants; /* quadrants hidden of patches not hidden whole */
    double ms;          /* CPU time of the cull */
} hz_horizon_stats;

/* Replaces the progress callback given in the desc (e.g. when its user data
 * goes out of scope); NULL for none. */
void hz_lod_set_progress(hz_lod *lod, hz_progress_fn progress, void *user);

/* Builds a mode's own precomputed data now (cdlod: nested error bounds and
 * per-sample morph errors, 2 bytes/sample more; roam: diamond error bounds
 * and its mesh), with progress; otherwise the first hz_lod_select in that mode
 * does it. HZ_ERR_MEMORY on failure. */
hz_result hz_lod_prepare(hz_lod *lod, hz_lod_mode mode);

/* Selects the level of detail for a camera with params->mode and writes the
 * triangle list into out (cleared first, grown as needed). leaves / culled
 * (may be NULL) receive the drawn leaf nodes / the culled nodes of the quadtree
 * modes (roam leaves them empty: its leaves are triangles). stats may be NULL.
 * roam keeps its mesh in the hz_lod from frame to frame (coherence); the other
 * modes start from the root every frame. Not thread-safe on the same hz_lod.
 * Returns HZ_ERR_MEMORY if a list cannot grow, HZ_ERR_VALUE on a bad mode. */
hz_result hz_lod_select(hz_lod *lod, const hz_camera *cam, const hz_lod_params *params,
                        hz_index_list *out, hz_node_list *leaves, hz_node_list *culled,
                        hz_lod_stats *stats);

/* ---- cdlod: nodes, not triangles ------------------------------------------
 * cdlod selects quadtree nodes; every node is drawn with the same static
 * grid patch of P x P cells (P = hz_lod_patch_cells) whose vertices are
 * 2^shift samples apart, so a frame is a list of a few hundred patches. Its
 * cells are split as the full-resolution mesh's (hz_lod_full_mesh, union
 * jack: nested from level to level). Where the neighbour
 * across a node's edge is one level coarser, the odd vertices of that edge
 * are moved onto the even vertex before them (lower index along the edge):
 * the triangles that collapse are dropped and the edge matches the coarser
 * node's exactly (no T-junction). Heights are then geomorphed per vertex
 * (hz_lod_morph_height), a function of the sample and the eye alone. */
typedef struct hz_patch {
    uint32_t x0, z0;   /* sample coordinates of the node's north-west corner */
    uint8_t shift;     /* vertices are 1 << shift samples apart */
    uint8_t coarse;    /* bit (1 << dir), dir W=0 E=1 N=2 S=3: the neighbour across that
                          edge is coarser (the edge is stitched) */
    uint16_t level;    /* quadtree level (0 = root) */
    float dist;        /* eye to the node's box, metres; patches come nearest first (ordered by
                          distance to within 1/32 of a doubling, at most 3 %) */
    uint32_t layer1;   /* streamed terrains: 1 + the tile slot holding the node; 0 otherwise */
    uint16_t ox, oz;   /* streamed terrains: the node's corner inside its tile (tile texels) */
    /* Streamed terrains, a tile that just arrived slides in: the least morph
     * (0..255 = 0..1) of the vertices this level adds (odd ones), inside the
     * patch and along each edge (dir as coarse; two patches of one level
     * sharing an edge agree on it). 0 = the distance alone decides. */
    uint8_t slide;
    uint8_t slide_edge[4];
    /* In-memory terrains: no vertex of the patch morphs for this eye (its
     * farthest point is nearer than its vertices' morph starts), so the
     * renderer draws it without the morph code. 0 = may morph. */
    uint8_t still;
    /* In-memory terrains: none of the patch's even vertices (those of the
     * next coarser grid) morphs for this eye, so every odd vertex morphs
     * toward the midpoint of two unmoved neighbours (hz_lod_morph_target2):
     * the renderer draws it with the simpler morph code. Set when still. */
    uint8_t simple;
    /* Occlusion culling (set by the caller after selection): bit B * bz + bx
     * set leaves block (bx, bz) of the patch's B x B blocks undrawn, B =
     * hz_lod_patch_blocks (each block P / B cells square, bx along x). The
     * selection sets 0: every block drawn. */
    uint16_t hidden;
} hz_patch;

typedef struct hz_patch_list {
    hz_patch *data;
    size_t count, cap;
} hz_patch_list;

/* The heightmap the LOD was made for. */
const hz_heightmap *hz_lod_query_heightmap(const hz_lod *lod);

/* cdlod's nested, dilated error bound of the node a patch draws (h16 steps;
 * metres = value * heightmap scale * zscale). Its split range in metres is
 * hz_lod_morph_range(stats, value): an unsplit node lies at least that far. */
float hz_lod_patch_error(hz_lod *lod, const hz_patch *p);

/* cdlod: the range in metres of an error of q h16 steps (a vertex's morph
 * error, a node's error bound) in the frame of stats: the distance where the
 * error projects to the bound (pixel_error, or near_pixel_error falling
 * with the distance). Increasing in q. The vertex shader computes the same. */
float hz_lod_morph_range(const hz_lod_stats *stats, float q);

/* Grid cells per side of a cdlod patch. */
uint32_t hz_lod_patch_cells(const hz_lod *lod);

/* cdlod selection as nodes (params->mode is ignored): the leaves to draw as
 * patches, nearest first, into out (cleared first, grown as needed).
 * stats.triangles counts the non-degenerate triangles they draw. Work and
 * output are proportional to the nodes, not to the triangles. */
hz_result hz_lod_select_patches(hz_lod *lod, const hz_camera *cam, const hz_lod_params *params,
                                hz_patch_list *out, hz_lod_stats *stats);

/* Horizon culling apart from the selection, to run on a thread of its own
 * while the renderer draws the nearest patches (hz_scene_params.
 * patch_late_job): for patches[0, count), the list hz_lod_select_patches
 * just gave for cam and params (selected: its stats; run it without
 * horizon_cull), hidden[k] = 1 for each patch from index from on that
 * nearer ground hides (what horizon_cull would drop), 0 for the others and
 * for every one before from (those are drawn before the cull is done; all
 * patches still serve as occluders). blocks (may be NULL): for each patch
 * from `from` on not hidden whole, the blocks (hz_patch.hidden's bits) of
 * its quadrants that nearer ground hides, 0 for the others (patches of 2
 * cells have no quadrants: all 0). stats (may be NULL) counts what it hid.
 * Hides nothing with no_cull, over holes or when the eye is not above the
 * ground nearby. Reads the patches and writes only hidden, stats and lod's
 * culling scratch: the caller may read the patches meanwhile, but must not
 * use lod until it returns. HZ_ERR_MEMORY (nothing hidden) when out of
 * memory. */
hz_result hz_lod_horizon_hide(hz_lod *lod, const hz_camera *cam, const hz_lod_params *params,
                              const hz_lod_stats *selected, const hz_patch *patches, size_t count, size_t from,
                              uint8_t *hidden, uint16_t *blocks, hz_horizon_stats *stats);
/* Takes what hz_lod_horizon_hide hid off the selection's stats st: its
 * triangles, still and simple patches and leaves; adds its patches to
 * st->hidden. */
void hz_lod_stats_hide(hz_lod_stats *st, const hz_horizon_stats *hs);

/* The triangles n patches draw, as indices into the full-resolution grid
 * (stitched edges applied, collapsed triangles dropped), appended to out.
 * For tests, mesh dumps and exact metrics; the renderer draws patches. */
hz_result hz_lod_patches_to_indices(const hz_lod *lod, const hz_patch *p, size_t n, hz_index_list *out);
/* The same for any n x n map drawn with P x P-cell patches (streamed terrains). */
hz_result hz_patches_to_indices(uint32_t n, uint32_t P, const hz_patch *patches, size_t count, hz_index_list *out);

/* Per-sample morph errors for cdlod (row-major, size*size values, h16 steps;
 * 65535 = never morphs), built on first use (may take a moment: progress goes
 * to the desc's callback). NULL on out of memory. A vertex's morph range in
 * metres is hz_lod_morph_range(stats, value). */
const uint16_t *hz_lod_morph_errors(hz_lod *lod);

/* The height a sample collapses to on the coarser level (h16 steps, times
 * two so it stays an integer): the sum of the heights of its two
 * neighbours at the spacing where it first appears (along x, along z, or on
 * the diagonal of the coarser cell, union jack). A sample of the root patch's grid
 * returns twice its own height. */
uint32_t hz_lod_morph_target2(const hz_lod *lod, uint32_t i, uint32_t j);

/* The height (metres, zscale applied) the viewer sees at sample index
 * (j * size + i) in a cdlod frame: the true height moved toward its coarser
 * neighbours by the vertex's morph factor. stats from that frame's selection
 * (morph_scale 0: the true height). The renderer's vertex shader computes the
 * same. */
float hz_lod_morph_height(hz_lod *lod, const hz_camera *cam, const hz_lod_stats *stats, uint32_t index);

/* Morph factor in [0, 1] of sample index (0 = true height, 1 = fully on the
 * coarser level's surface). */
float hz_lod_morph_factor(hz_lod *lod, const hz_camera *cam, const hz_lod_stats *stats, uint32_t index);

/* The two triangles of a grid cell with corners a = (i, j), b = (i, j+1),
 * c = (i+1, j), d = (i+1, j+1), counter-clockwise seen from above: split
 * along a-d (main diagonal) or c-b. Every grid horizon draws is a "union
 * jack": cell (i, j) in units of its spacing uses the main diagonal when
 * i + j is even. */
void hz_lod_cell_triangles(bool main_diagonal, uint32_t a, uint32_t b, uint32_t c, uint32_t d, uint32_t out[6]);

/* Every cell of the grid as two triangles (the full-resolution reference mesh,
 * union jack), counter-clockwise seen from above. */
hz_result hz_lod_full_mesh(const hz_heightmap *hm, hz_index_list *out);

/* Read-only per-node data (x, z, half as above): propagated d2 and the node's
 * min/max height in metres (before zscale). False if (x, z, half) is not a node. */
bool hz_lod_query_node(const hz_lod *lod, uint32_t x, uint32_t z, uint32_t half, float *d2,
                       float *min_h, float *max_h);

/* World-space box of a node: metres, y from the node's min/max times zscale. */
bool hz_lod_node_box(const hz_lod *lod, uint32_t x, uint32_t z, uint32_t half, vec3 box[2]);
/* A box holding in-memory cdlod patch p as drawn for cam in the frame of
 * stats (hz_lod_select_patches' camera and figures, which set p->still),
 * morphing included (flat world; occlusion and culling lower it for the
 * Earth's curvature): its footprint, and the height range of its node's
 * samples, widened by what its corners take while they morph (a corner
 * collapses toward samples beyond the patch). False for a patch of no node
 * of lod. */
bool hz_lod_patch_box(hz_lod *lod, const hz_patch *p, const hz_camera *cam, const hz_lod_stats *stats, vec3 box[2]);

/* Blocks per side of a cdlod patch of patch_cells cells (hz_lod_patch_cells)
 * for hz_patch.hidden: 4 (8 cells or more), 2 (4 cells), 1 (2 cells: a
 * patch is drawn whole). */
uint32_t hz_lod_patch_blocks(uint32_t patch_cells);

/* The same box for block (bx, bz) of patch p cut into per_side x per_side
 * blocks (1, 2, 4 ... up to hz_lod_patch_blocks; bx along x): its footprint
 * and its samples' heights, widened while a corner of the block morphs. A
 * block's box lies within the box of every larger block holding it. False
 * for a patch of no node of lod or a block outside it. */
bool hz_lod_patch_block_box(hz_lod *lod, const hz_patch *p, uint32_t per_side, uint32_t bx, uint32_t bz,
                            const hz_camera *cam, const hz_lod_stats *stats, vec3 box[2]);

#ifdef __cplusplus
}
#endif
#endif
