/* Node geometry shared by the LOD modes, below all of them: the fan of a
 * quadtree leaf, the state of a node's same-level neighbour, the two
 * triangles of a grid cell. The boxes, frustum tests and distances are
 * inline in lod_internal.h. No GL. */
#include "lod_internal.h"

/* Appends a fan around (x, z) with half-size s; an edge midpoint is skipped when
 * the neighbour across it is coarser. Triangles are counter-clockwise seen from
 * above (+y). */
uint32_t hz__emit_fan(uint32_t *dst, uint32_t n, uint32_t x, uint32_t z, uint32_t s,
                         const uint8_t nb[4])
{
    const uint32_t c = z * n + x;
    uint32_t ring[9];
    uint32_t k = 0;
    /* Ring order W, SW, S, SE, E, NE, N, NW (counter-clockwise from above). */
    if (nb[DIR_W] != NB_ABSENT)
        ring[k++] = z * n + (x - s);
    ring[k++] = (z + s) * n + (x - s);
    if (nb[DIR_S] != NB_ABSENT)
        ring[k++] = (z + s) * n + x;
    ring[k++] = (z + s) * n + (x + s);
    if (nb[DIR_E] != NB_ABSENT)
        ring[k++] = z * n + (x + s);
    ring[k++] = (z - s) * n + (x + s);
    if (nb[DIR_N] != NB_ABSENT)
        ring[k++] = (z - s) * n + x;
    ring[k++] = (z - s) * n + (x - s);
    ring[k] = ring[0];
    for (uint32_t t = 0; t < k; t++) {
        dst[3 * t + 0] = c;
        dst[3 * t + 1] = ring[t];
        dst[3 * t + 2] = ring[t + 1];
    }
    return k;
}

void hz_lod_cell_triangles(bool main_diagonal, uint32_t a, uint32_t b, uint32_t c, uint32_t d, uint32_t out[6])
{
    if (main_diagonal) {
        out[0] = a, out[1] = b, out[2] = d;
        out[3] = a, out[4] = d, out[5] = c;
    } else {
        out[0] = a, out[1] = b, out[2] = c;
        out[3] = c, out[4] = b, out[5] = d;
    }
}


static inline uint32_t low_bit(uint32_t v)
{
    return v ? v & (~v + 1u) : 0x80000000u;
}

bool hz__morph_neighbours(uint32_t n, uint32_t i, uint32_t j, uint32_t ni[2], uint32_t nj[2])
{
    const uint32_t bi = low_bit(i), bj = low_bit(j);
    if (bi == bj) {
        const uint32_t s = bi;
        if (i < s || j < s || i + s >= n || j + s >= n)
            return false;
        const bool main = (((i - s) / (2 * s) + (j - s) / (2 * s)) & 1u) == 0;
        ni[0] = i - s, nj[0] = main ? j - s : j + s;
        ni[1] = i + s, nj[1] = main ? j + s : j - s;
    } else if (bi < bj) {
        if (i < bi || i + bi >= n)
            return false;
        ni[0] = i - bi, nj[0] = j;
        ni[1] = i + bi, nj[1] = j;
    } else {
        if (j < bj || j + bj >= n)
            return false;
        ni[0] = i, nj[0] = j - bj;
        ni[1] = i, nj[1] = j + bj;
    }
    return true;
}

uint32_t hz__patch_triangles(uint32_t P, uint8_t coarse)
{
    uint32_t t = 2 * P * P;
    for (int dir = 0; dir < 4; dir++)
        if (coarse & (1u << dir))
            t -= P / 2;
    return t;
}

enum { SORT_BUCKETS = 1024 };

static inline uint32_t dist_bucket(float d)
{
    /* log2(d + 1) in 1/32 steps from the float's exponent and top mantissa bits */
    union {
        float f;
        uint32_t u;
    } v = {.f = d + 1.0f};
    const uint32_t k = (v.u >> 18) - (127u << 5);
    return k < SORT_BUCKETS ? k : SORT_BUCKETS - 1;
}

hz_result hz__sort_patches(hz_patch_list *out, hz_patch **tmp, size_t *tmp_cap)
{
    const size_t n = out->count;
    if (n < 2)
        return HZ_OK;
    if (list_reserve((void **)tmp, tmp_cap, n, sizeof(hz_patch)))
        return HZ_ERR_MEMORY;
    uint32_t start[SORT_BUCKETS + 1];
    memset(start, 0, sizeof start);
    for (size_t k = 0; k < n; k++)
        start[dist_bucket(out->data[k].dist) + 1]++;
    for (uint32_t b = 0; b < SORT_BUCKETS; b++)
        start[b + 1] += start[b];
    hz_patch *t = *tmp;
    for (size_t k = 0; k < n; k++)
        t[start[dist_bucket(out->data[k].dist)]++] = out->data[k];
    memcpy(out->data, t, n * sizeof *t);
    return HZ_OK;
}
