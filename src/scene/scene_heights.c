/* The objects' highest points over a ground grid (see scene.h): what stands
 * on each sample, for the light map's shadows and for keeping trees out of
 * buildings. Built from the drawn triangles, so a turned building shades its
 * own footprint and a tree its crown's, not their world boxes. */
#include "horizon/scene.h"

#include <math.h>

typedef struct grid {
    float *tops;
    uint32_t size;
    float spacing;
    uint64_t raised; /* samples that were -inf before */
} grid;

static void raise(grid *g, uint32_t i, uint32_t j, float h)
{
    float *c = &g->tops[(size_t)j * g->size + i];
    if (h > *c) {
        g->raised += *c == -INFINITY;
        *c = h;
    }
}

/* One world-space triangle: the sample points inside its ground projection
 * at its height there; none inside (smaller than a cell, or edge-on, as a
 * wall) -> the sample nearest its centre at its highest vertex. */
static void triangle(grid *g, const float a[3], const float b[3], const float c[3])
{
    const float sp = g->spacing, last = (float)(g->size - 1);
    const float top = fmaxf(a[1], fmaxf(b[1], c[1]));
    if (!isfinite(top) || !isfinite(a[0] + a[2] + b[0] + b[2] + c[0] + c[2]))
        return;
    const float x0 = fminf(a[0], fminf(b[0], c[0])), x1 = fmaxf(a[0], fmaxf(b[0], c[0]));
    const float z0 = fminf(a[2], fminf(b[2], c[2])), z1 = fmaxf(a[2], fmaxf(b[2], c[2]));
    const float fi0 = fmaxf(ceilf(x0 / sp), 0.0f), fi1 = fminf(floorf(x1 / sp), last);
    const float fj0 = fmaxf(ceilf(z0 / sp), 0.0f), fj1 = fminf(floorf(z1 / sp), last);
    /* twice the signed area of the ground projection */
    const float ex1 = b[0] - a[0], ez1 = b[2] - a[2], ex2 = c[0] - a[0], ez2 = c[2] - a[2];
    const float area = ex1 * ez2 - ez1 * ex2;
    bool hit = false;
    if (fi0 <= fi1 && fj0 <= fj1 && fabsf(area) > 1e-6f * (x1 - x0 + z1 - z0 + 1e-3f) * (x1 - x0 + z1 - z0 + 1e-3f)) {
        const float inv = 1.0f / area;
        for (uint32_t j = (uint32_t)fj0; j <= (uint32_t)fj1; j++)
            for (uint32_t i = (uint32_t)fi0; i <= (uint32_t)fi1; i++) {
                const float px = (float)i * sp - a[0], pz = (float)j * sp - a[2];
                /* barycentric weights of b and c (of a: 1 - u - v) */
                const float u = (px * ez2 - pz * ex2) * inv, v = (ex1 * pz - ez1 * px) * inv;
                const float tol = -1e-5f;
                if (u < tol || v < tol || u + v > 1.0f - tol)
                    continue;
                hit = true;
                raise(g, i, j, a[1] + u * (b[1] - a[1]) + v * (c[1] - a[1]));
            }
    }
    if (hit)
        return;
    const float ci = roundf((a[0] + b[0] + c[0]) / (3.0f * sp)), cj = roundf((a[2] + b[2] + c[2]) / (3.0f * sp));
    if (ci >= 0 && cj >= 0 && ci <= last && cj <= last)
        raise(g, (uint32_t)ci, (uint32_t)cj, top);
}

uint64_t hz_scene_heights(const hz_scene *s, uint32_t size, float spacing, float *tops)
{
    if (!s || !tops || size < 2 || !(spacing > 0.0f) || !isfinite(spacing))
        return 0;
    grid g = {tops, size, spacing, 0};
    const hz_vertex *vert = hz_scene_vertices(s, &(uint32_t){0});
    const uint32_t *idx = hz_scene_indices(s, &(uint32_t){0});
    const float ext = (float)(size - 1) * spacing;
    const uint32_t nodes = hz_scene_node_count(s);
    for (uint32_t id = 1; id <= nodes; id++) {
        const uint32_t m = hz_scene_node_mesh(s, id);
        if (m == HZ_MESH_NONE)
            continue;
        hz_box b;
        hz_scene_node_bounds(s, id, &b);
        if (hz_box_is_empty(&b) || b.max[0] < 0 || b.max[2] < 0 || b.min[0] > ext || b.min[2] > ext)
            continue;
        const hz_mesh_range *r = hz_scene_mesh(s, m);
        mat4 w;
        hz_scene_world_matrix(s, id, w);
        for (uint32_t k = 0; k + 2 < r->index_count; k += 3) {
            float p[3][3];
            for (int e = 0; e < 3; e++) {
                const float *v = vert[r->first_vertex + idx[r->first_index + k + (uint32_t)e]].pos;
                glm_mat4_mulv3(w, (float *)v, 1.0f, p[e]);
            }
            triangle(&g, p[0], p[1], p[2]);
        }
    }
    return g.raised;
}
