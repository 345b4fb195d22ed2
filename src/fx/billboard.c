/* Billboard lists (SPEC R3), CPU side: culling, back-to-front sorting,
 * batching per texture, and a cell-bucketed static field. */
#include "horizon/fx.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

_Static_assert(sizeof(hz_billboard) == 40, "hz_billboard is mirrored by the renderer's instance layout");

typedef struct key_idx {
    uint32_t key, idx;
} key_idx;

static void bb_sphere(const hz_billboard *b, vec3 c, float *r)
{
    if (b->flags & HZ_BB_FACING) {
        glm_vec3_copy((float *)b->pos, c);
        *r = 0.5f * sqrtf(b->width * b->width + b->height * b->height);
    } else {
        float l2 = b->axis[0] * b->axis[0] + b->axis[1] * b->axis[1] + b->axis[2] * b->axis[2];
        for (int k = 0; k < 3; k++)
            c[k] = b->pos[k] + 0.5f * b->axis[k];
        *r = 0.5f * sqrtf(l2 + b->width * b->width);
    }
}

static bool sphere_visible(const vec4 planes[6], const vec3 eye, float max_dist, const vec3 c, float r)
{
    for (int p = 0; p < 6; p++)
        if (planes[p][0] * c[0] + planes[p][1] * c[1] + planes[p][2] * c[2] + planes[p][3] < -r)
            return false;
    float dx = c[0] - eye[0], dy = c[1] - eye[1], dz = c[2] - eye[2];
    float lim = max_dist + r;
    return dx * dx + dy * dy + dz * dz <= lim * lim;
}

size_t hz_billboards_cull(const hz_billboard *in, size_t n, const hz_camera *cam, float max_dist,
                          hz_billboard *out, size_t cap)
{
    vec4 planes[6];
    hz_camera_frustum(cam, planes);
    size_t k = 0;
    for (size_t i = 0; i < n; i++) {
        vec3 c;
        float r;
        bb_sphere(&in[i], c, &r);
        hz_camera_curve_sphere(cam, c, &r); /* drawn lower with Earth curvature */
        if (!sphere_visible((const vec4 *)planes, cam->pos, max_dist, c, r))
            continue;
        if (k < cap)
            out[k] = in[i];
        k++;
    }
    return k;
}

size_t hz_billboards_scratch_bytes(size_t n)
{
    return n * (2 * sizeof(key_idx) + sizeof(hz_billboard));
}

/* Stable LSD radix sort of (key, idx) pairs on the low `bits` bits of key,
 * 8 bits per pass; the result ends in a. */
static void radix(key_idx *a, key_idx *tmp, size_t n, unsigned bits)
{
    for (unsigned shift = 0; shift < bits; shift += 8) {
        size_t count[257] = {0};
        for (size_t i = 0; i < n; i++)
            count[((a[i].key >> shift) & 255u) + 1]++;
        for (int b = 0; b < 256; b++)
            count[b + 1] += count[b];
        for (size_t i = 0; i < n; i++)
            tmp[count[(a[i].key >> shift) & 255u]++] = a[i];
        memcpy(a, tmp, n * sizeof *a);
    }
}

static void permute(hz_billboard *b, size_t n, const key_idx *order, hz_billboard *copy)
{
    memcpy(copy, b, n * sizeof *b);
    for (size_t i = 0; i < n; i++)
        b[i] = copy[order[i].idx];
}

bool hz_billboards_sort(hz_billboard *b, size_t n, const vec3 eye, void *scratch)
{
    if (n < 2)
        return true;
    void *mem = scratch ? scratch : malloc(hz_billboards_scratch_bytes(n));
    if (!mem)
        return false;
    key_idx *a = mem, *t = a + n;
    hz_billboard *copy = (hz_billboard *)(t + n);
    for (size_t i = 0; i < n; i++) {
        float dx = b[i].pos[0] - eye[0], dy = b[i].pos[1] - eye[1], dz = b[i].pos[2] - eye[2];
        float d2 = dx * dx + dy * dy + dz * dz;
        uint32_t bitsv;
        memcpy(&bitsv, &d2, 4);          /* non-negative floats order like their bits */
        a[i] = (key_idx){~bitsv, (uint32_t)i}; /* far first */
    }
    radix(a, t, n, 32);
    permute(b, n, a, copy);
    if (!scratch)
        free(mem);
    return true;
}

size_t hz_billboards_batch(hz_billboard *b, size_t n, hz_bb_batch *batches, size_t cap, void *scratch)
{
    if (n == 0)
        return 0;
    void *mem = scratch ? scratch : malloc(hz_billboards_scratch_bytes(n));
    if (!mem)
        return 0;
    key_idx *a = mem, *t = a + n;
    hz_billboard *copy = (hz_billboard *)(t + n);
    for (size_t i = 0; i < n; i++)
        a[i] = (key_idx){((b[i].flags & HZ_BB_BLEND) ? 1u << 16 : 0u) | b[i].texture, (uint32_t)i};
    radix(a, t, n, 24);
    permute(b, n, a, copy);
    size_t nb = 0;
    for (size_t i = 0; i < n;) {
        size_t j = i;
        while (j < n && a[j].key == a[i].key)
            j++;
        if (nb < cap)
            batches[nb] = (hz_bb_batch){.texture = b[i].texture, .flags = b[i].flags & HZ_BB_BLEND,
                                        .first = (uint32_t)i, .count = (uint32_t)(j - i)};
        nb++;
        i = j;
    }
    if (!scratch)
        free(mem);
    return nb;
}

/* ---- field ------------------------------------------------------------------ */

typedef struct cell {
    uint32_t first, count;
    float lo[3], hi[3]; /* box around every billboard's bounding sphere */
} cell;

struct hz_bb_field {
    hz_billboard *b;
    size_t n;
    cell *cells;
    uint32_t nx, nz;
    float x0, z0, size;
};

hz_bb_field *hz_bb_field_create(const hz_billboard *b, size_t n, float cell_size)
{
    hz_bb_field *f = calloc(1, sizeof *f);
    if (!f)
        return NULL;
    f->size = cell_size > 0.0f ? cell_size : 256.0f;
    float x0 = INFINITY, z0 = INFINITY, x1 = -INFINITY, z1 = -INFINITY;
    for (size_t i = 0; i < n; i++) {
        x0 = fminf(x0, b[i].pos[0]), x1 = fmaxf(x1, b[i].pos[0]);
        z0 = fminf(z0, b[i].pos[2]), z1 = fmaxf(z1, b[i].pos[2]);
    }
    if (n == 0)
        x0 = z0 = x1 = z1 = 0.0f;
    f->x0 = x0, f->z0 = z0;
    double nx = floor((double)(x1 - x0) / f->size) + 1, nz = floor((double)(z1 - z0) / f->size) + 1;
    while (nx * nz > 4e6) { /* absurd spreads: coarser cells rather than a huge table */
        f->size *= 2.0f;
        nx = floor((double)(x1 - x0) / f->size) + 1, nz = floor((double)(z1 - z0) / f->size) + 1;
    }
    f->nx = (uint32_t)nx, f->nz = (uint32_t)nz;
    f->n = n;
    f->b = malloc((n ? n : 1) * sizeof *f->b);
    f->cells = calloc((size_t)f->nx * f->nz, sizeof *f->cells);
    uint32_t *cid = malloc((n ? n : 1) * sizeof *cid);
    if (!f->b || !f->cells || !cid) {
        free(cid);
        hz_bb_field_destroy(f);
        return NULL;
    }
    for (size_t i = 0; i < n; i++) {
        uint32_t cx = (uint32_t)((b[i].pos[0] - x0) / f->size), cz = (uint32_t)((b[i].pos[2] - z0) / f->size);
        cx = cx < f->nx ? cx : f->nx - 1, cz = cz < f->nz ? cz : f->nz - 1;
        cid[i] = cz * f->nx + cx;
        f->cells[cid[i]].count++;
    }
    uint32_t acc = 0;
    for (size_t c = 0; c < (size_t)f->nx * f->nz; c++) {
        f->cells[c].first = acc;
        acc += f->cells[c].count;
        f->cells[c].count = 0;
        for (int k = 0; k < 3; k++)
            f->cells[c].lo[k] = INFINITY, f->cells[c].hi[k] = -INFINITY;
    }
    for (size_t i = 0; i < n; i++) {
        cell *c = &f->cells[cid[i]];
        f->b[c->first + c->count++] = b[i];
        vec3 ctr;
        float r;
        bb_sphere(&b[i], ctr, &r);
        for (int k = 0; k < 3; k++) {
            c->lo[k] = fminf(c->lo[k], ctr[k] - r);
            c->hi[k] = fmaxf(c->hi[k], ctr[k] + r);
        }
    }
    free(cid);
    return f;
}

void hz_bb_field_destroy(hz_bb_field *f)
{
    if (!f)
        return;
    free(f->b);
    free(f->cells);
    free(f);
}

size_t hz_bb_field_count(const hz_bb_field *f)
{
    return f ? f->n : 0;
}

size_t hz_bb_field_cull(const hz_bb_field *f, const hz_camera *cam, float max_dist, hz_billboard *out, size_t cap)
{
    if (!f || f->n == 0)
        return 0;
    vec4 planes[6];
    hz_camera_frustum(cam, planes);
    const float *e = cam->pos;
    size_t k = 0;
    /* Only the cells within max_dist of the eye (in x/z). */
    float ax = (e[0] - max_dist - f->x0) / f->size, bx = (e[0] + max_dist - f->x0) / f->size;
    float az = (e[2] - max_dist - f->z0) / f->size, bz = (e[2] + max_dist - f->z0) / f->size;
    /* Clamped to the grid before the int conversion: an eye far outside it
     * (or non-finite) would overflow int (undefined behaviour). */
    const float gx = (float)f->nx + 1.0f, gz = (float)f->nz + 1.0f;
    ax = fmaxf(fminf(ax, gx), -1.0f), bx = fmaxf(fminf(bx, gx), -1.0f);
    az = fmaxf(fminf(az, gz), -1.0f), bz = fmaxf(fminf(bz, gz), -1.0f);
    /* One cell of margin: a billboard's sphere may reach out of its cell. */
    int cx0 = (int)floorf(ax) - 1, cx1 = (int)floorf(bx) + 1, cz0 = (int)floorf(az) - 1, cz1 = (int)floorf(bz) + 1;
    cx0 = cx0 < 0 ? 0 : cx0, cz0 = cz0 < 0 ? 0 : cz0;
    cx1 = cx1 >= (int)f->nx ? (int)f->nx - 1 : cx1, cz1 = cz1 >= (int)f->nz ? (int)f->nz - 1 : cz1;
    for (int cz = cz0; cz <= cz1; cz++)
        for (int cx = cx0; cx <= cx1; cx++) {
            const cell *c = &f->cells[(size_t)cz * f->nx + (size_t)cx];
            if (!c->count)
                continue;
            /* Box (as drawn: lowered by the Earth curvature) against the
             * frustum (the corner farthest along each normal). */
            float cb[2][3] = {{c->lo[0], c->lo[1], c->lo[2]}, {c->hi[0], c->hi[1], c->hi[2]}};
            hz_camera_curve_box(cam, cb);
            bool out_box = false, inside = true;
            for (int p = 0; p < 6 && !out_box; p++) {
                float pv = planes[p][3], nv = planes[p][3];
                for (int a = 0; a < 3; a++) {
                    float nrm = planes[p][a];
                    pv += nrm * (nrm >= 0 ? cb[1][a] : cb[0][a]);
                    nv += nrm * (nrm >= 0 ? cb[0][a] : cb[1][a]);
                }
                out_box = pv < 0;
                inside &= nv >= 0;
            }
            if (out_box)
                continue;
            /* Distance from the eye to the box (nearest and farthest point). */
            float dn = 0, dfar = 0;
            for (int a = 0; a < 3; a++) {
                float d = e[a] < c->lo[a] ? c->lo[a] - e[a] : e[a] > c->hi[a] ? e[a] - c->hi[a] : 0;
                float g = fmaxf(fabsf(e[a] - c->lo[a]), fabsf(e[a] - c->hi[a]));
                dn += d * d, dfar += g * g;
            }
            if (dn > max_dist * max_dist)
                continue;
            if (inside && dfar <= max_dist * max_dist) {
                for (uint32_t i = 0; i < c->count; i++, k++)
                    if (k < cap)
                        out[k] = f->b[c->first + i];
                continue;
            }
            size_t got = hz_billboards_cull(f->b + c->first, c->count, cam, max_dist, k < cap ? out + k : NULL,
                                            k < cap ? cap - k : 0);
            k += got;
        }
    return k;
}
