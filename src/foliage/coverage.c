/* Coverage of leaf prefixes (F4 done by coverage): how much of a leaf
 * node's projected area the first k of its leaves cover, averaged over
 * views around the node. Leaf enlargement compensates the coverage a prefix
 * lost, not the leaves it dropped: VMI drops hidden leaves first, so its
 * prefixes lose less than k/n and need less enlargement than a random
 * order. Software rasterization of the leaf outlines, no GL. */
#include "horizon/tree.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "foliage_internal.h"

#define COV_VIEWS 12
#define COV_GRID 32

/* The leaf outline drawn by the leaf shaders: |b| <= 0.9 (1 - a^2) in the
 * quad's (a, b) coordinates. */
static void raster_leaf(const float *c2, const float *u2, const float *v2, uint16_t rank, uint16_t *first,
                        uint32_t *hist)
{
    float det = u2[0] * v2[1] - u2[1] * v2[0];
    if (fabsf(det) < 1e-9f)
        return; /* edge-on */
    float ex = fabsf(u2[0]) + fabsf(v2[0]), ey = fabsf(u2[1]) + fabsf(v2[1]);
    int x0 = (int)floorf(c2[0] - ex), x1 = (int)ceilf(c2[0] + ex);
    int y0 = (int)floorf(c2[1] - ey), y1 = (int)ceilf(c2[1] + ey);
    x0 = x0 < 0 ? 0 : x0, y0 = y0 < 0 ? 0 : y0;
    x1 = x1 > COV_GRID - 1 ? COV_GRID - 1 : x1, y1 = y1 > COV_GRID - 1 ? COV_GRID - 1 : y1;
    float inv = 1.0f / det;
    for (int y = y0; y <= y1; y++)
        for (int x = x0; x <= x1; x++) {
            float dx = (float)x + 0.5f - c2[0], dy = (float)y + 0.5f - c2[1];
            float a = (dx * v2[1] - dy * v2[0]) * inv, b = (u2[0] * dy - u2[1] * dx) * inv;
            if (fabsf(a) > 1.0f || fabsf(b) > 0.9f * (1.0f - a * a))
                continue;
            uint16_t *f = &first[y * COV_GRID + x];
            if (*f == 0xffff) {
                *f = rank;
                hist[rank]++;
            }
        }
}

hz_result hz_tree_prefix_coverage(const hz_tree *t, float *cov, hz_err *err)
{
    float dirs[COV_VIEWS * 3];
    hz_sphere_views(COV_VIEWS, dirs);
    uint32_t maxn = 1;
    for (uint32_t n = 0; n < t->node_count; n++)
        maxn = t->nodes[n].count > maxn ? t->nodes[n].count : maxn;
    if (maxn >= 0xffff)
        return hz_err_set(err, HZ_ERR_VALUE, "coverage: a leaf node of %u leaves (at most 65534)", maxn);
    uint32_t *hist = malloc(maxn * sizeof *hist);
    uint16_t *first = malloc(COV_GRID * COV_GRID * sizeof *first);
    if (!hist || !first) {
        free(hist);
        free(first);
        return hz_err_set(err, HZ_ERR_MEMORY, "coverage: out of memory");
    }
    for (uint32_t l = 0; l < t->leaf_count; l++)
        cov[l] = 1.0f;
    for (uint32_t n = 0; n < t->node_count; n++) {
        const hz_tree_node *nd = &t->nodes[n];
        if (!nd->count)
            continue;
        memset(hist, 0, nd->count * sizeof *hist);
        float r = nd->radius > 0 ? nd->radius : 1.0f, sc = 0.5f * COV_GRID / r;
        for (int v = 0; v < COV_VIEWS; v++) {
            const float *d = &dirs[v * 3];
            float ref[3] = {0, 1, 0}, right[3], up[3];
            if (fabsf(d[1]) > 0.95f)
                v3_set(ref, 1, 0, 0);
            v3_cross(right, ref, d);
            v3_norm(right);
            v3_cross(up, d, right);
            memset(first, 0xff, COV_GRID * COV_GRID * sizeof *first);
            for (uint32_t i = 0; i < nd->count; i++) {
                const hz_tree_leaf *lf = &t->leaves[nd->first + i];
                float rel[3];
                v3_sub(rel, lf->c, nd->center);
                float c2[2] = {v3_dot(rel, right) * sc + 0.5f * COV_GRID, v3_dot(rel, up) * sc + 0.5f * COV_GRID};
                float u2[2] = {v3_dot(lf->u, right) * sc, v3_dot(lf->u, up) * sc};
                float v2[2] = {v3_dot(lf->v, right) * sc, v3_dot(lf->v, up) * sc};
                raster_leaf(c2, u2, v2, (uint16_t)i, first, hist);
            }
        }
        uint64_t total = 0;
        for (uint32_t i = 0; i < nd->count; i++)
            total += hist[i];
        uint64_t sum = 0;
        for (uint32_t i = 0; i < nd->count; i++) {
            sum += hist[i];
            /* A node too small for the grid falls back to the leaf count. */
            cov[nd->first + i] = total ? (float)((double)sum / (double)total) : (float)(i + 1) / (float)nd->count;
        }
    }
    free(hist);
    free(first);
    return HZ_OK;
}

float hz_enlarge_coverage(float max_enlarge, float cov)
{
    if (!(cov > 0.0f) || cov >= 1.0f)
        return 1.0f;
    return fminf(sqrtf(1.0f / cov), max_enlarge > 0 ? max_enlarge : 3.0f);
}
