/* Mesh validity checks shared by the LOD tests (no GL). */
#ifndef HZ_TEST_MESH_CHECK_H
#define HZ_TEST_MESH_CHECK_H

#include "horizon/lod.h"

typedef struct mesh_report {
    size_t triangles;
    size_t edges;
    size_t edges_over_two;     /* edges used by 3+ triangles */
    size_t open_interior;      /* edges used once, not on the map border, not outside the frustum */
    size_t t_junctions;        /* a used vertex strictly inside some edge */
    size_t degenerate;         /* zero area in xz */
    size_t flipped;            /* clockwise seen from above */
    size_t level_jumps;        /* adjacent leaf cells whose levels differ by > 1 */
    double area;               /* sum of xz areas in cells (samples^2) */
} mesh_report;

/* planes may be NULL (then every open edge off the border counts as a hole).
 * leaves may be NULL (level check skipped). hm/spacing/zscale give world
 * positions for the frustum test. */
mesh_report mesh_check(const hz_heightmap *hm, float spacing, float zscale, const uint32_t *idx,
                       size_t count, const vec4 *planes, const hz_node_list *leaves);

/* cmocka assertions that a report shows a valid mesh: no edge shared by
 * three triangles, no hole, no T-junction, no degenerate or flipped
 * triangle and (levels) no neighbouring leaves two levels apart. Prints
 * the report under label when it does not. */
void mesh_assert_valid(const mesh_report *r, bool levels, const char *label);

/* Deterministic test randomness (splitmix64) over the caller's state. */
uint64_t test_rnd(uint64_t *state);
float test_frand(uint64_t *state, float lo, float hi);
/* A random camera in and around the map (metres): up to 20 % of the side
 * outside it, from the lowest quantised height to twice the relief above the
 * highest, aimed at a random sample of the terrain give or take 20 degrees
 * of yaw and pitch, fov 30..90, far 0.3..2 map sides. */
hz_camera test_random_camera(uint64_t *state, const hz_heightmap *hm, float spacing);

#endif
