/* .hzt tree files: little-endian binary with a CRC-32 trailer. The layout is
 * documented in README.md ("Tree files"). Derived data (node spheres, leaf
 * densities, layers, bounds) is recomputed on load, not stored. */
#include "horizon/tree.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

static const char MAGIC[8] = {'H', 'Z', 'T', 'R', 'E', 'E', '\r', '\n'};
#define VERSION 1u
#define MAX_FILE (1ull << 31)

uint32_t hz_tree_crc32(const uint8_t *data, size_t size)
{
    uLong c = crc32(0L, Z_NULL, 0);
    while (size > 0) {
        uInt chunk = size > (1u << 30) ? (1u << 30) : (uInt)size;
        c = crc32(c, data, chunk);
        data += chunk;
        size -= chunk;
    }
    return (uint32_t)c;
}

/* ---- writer --------------------------------------------------------------- */

typedef struct wbuf {
    uint8_t *p;
    size_t n, cap;
    bool oom;
} wbuf;

static void put(wbuf *w, const void *src, size_t n)
{
    if (w->oom)
        return;
    if (w->n + n > w->cap) {
        size_t nc = w->cap ? w->cap : 4096;
        while (nc < w->n + n)
            nc *= 2;
        uint8_t *np = realloc(w->p, nc);
        if (!np) {
            w->oom = true;
            return;
        }
        w->p = np;
        w->cap = nc;
    }
    memcpy(w->p + w->n, src, n);
    w->n += n;
}

static void put_u32(wbuf *w, uint32_t v)
{
    uint8_t b[4] = {(uint8_t)v, (uint8_t)(v >> 8), (uint8_t)(v >> 16), (uint8_t)(v >> 24)};
    put(w, b, 4);
}
static void put_u64(wbuf *w, uint64_t v)
{
    put_u32(w, (uint32_t)v);
    put_u32(w, (uint32_t)(v >> 32));
}
static void put_f32(wbuf *w, float f)
{
    uint32_t v;
    memcpy(&v, &f, 4);
    put_u32(w, v);
}
static void put_f64(wbuf *w, double f)
{
    uint64_t v;
    memcpy(&v, &f, 8);
    put_u64(w, v);
}
static void put_f32s(wbuf *w, const float *f, size_t n)
{
    for (size_t k = 0; k < n; k++)
        put_f32(w, f[k]);
}
static void put_u32s(wbuf *w, const uint32_t *v, size_t n)
{
    for (size_t k = 0; k < n; k++)
        put_u32(w, v[k]);
}

hz_result hz_tree_save_mem(const hz_tree *t, uint8_t **data, size_t *size, hz_err *err)
{
    hz_result vr = hz_tree_validate(t, err);
    if (vr != HZ_OK)
        return vr;
    wbuf w = {0};
    put(&w, MAGIC, 8);
    put_u32(&w, VERSION);
    char species[32] = {0};
    snprintf(species, sizeof species, "%s", t->species);
    put(&w, species, 32);
    put_u64(&w, t->seed);
    put_u32(&w, t->levels);
    put_u32(&w, t->branch_count);
    put_u32(&w, t->node_count);
    put_u32(&w, t->leaf_count);
    put_u32(&w, t->bark.vertex_count);
    put_u32(&w, t->bark.index_count);
    put_u32(&w, t->hull.vertex_count);
    put_u32(&w, t->hull.index_count);
    put_f32s(&w, t->leaf_color, 3);
    put_f32s(&w, t->bark_color, 3);
    put_u32(&w, t->ranked ? 1u : 0u);
    put_u32(&w, t->rank_views);
    put_u32(&w, t->rank_res);
    put_u32(&w, t->rank_layers);
    put_f64(&w, t->rank_ms);
    put_u32s(&w, t->bark_level_end, HZ_TREE_MAX_LEVELS);
    for (uint32_t b = 0; b < t->branch_count; b++) {
        const hz_tree_branch *br = &t->branches[b];
        put_u32(&w, br->parent);
        put_u32(&w, br->level);
        put_u32(&w, br->leaf_node);
        put_f32(&w, br->length);
        put_f32(&w, br->radius);
        put_f32s(&w, br->base, 3);
        put_f32s(&w, br->tip, 3);
        put_f32s(&w, br->dir, 3);
    }
    for (uint32_t n = 0; n < t->node_count; n++) {
        put_u32(&w, t->nodes[n].branch);
        put_u32(&w, t->nodes[n].first);
        put_u32(&w, t->nodes[n].count);
    }
    for (uint32_t k = 0; k < t->leaf_count; k++) {
        put_f32s(&w, t->leaves[k].c, 3);
        put_f32s(&w, t->leaves[k].u, 3);
        put_f32s(&w, t->leaves[k].v, 3);
    }
    const hz_tree_mesh *meshes[2] = {&t->bark, &t->hull};
    for (int m = 0; m < 2; m++) {
        put_f32s(&w, meshes[m]->pos, (size_t)meshes[m]->vertex_count * 3);
        put_f32s(&w, meshes[m]->nrm, (size_t)meshes[m]->vertex_count * 3);
        put_u32s(&w, meshes[m]->idx, meshes[m]->index_count);
    }
    if (!w.oom)
        put_u32(&w, hz_tree_crc32(w.p, w.n));
    if (w.oom) {
        free(w.p);
        return hz_err_set(err, HZ_ERR_MEMORY, "out of memory writing the tree");
    }
    *data = w.p;
    *size = w.n;
    return HZ_OK;
}

hz_result hz_tree_save(const hz_tree *t, const char *path, hz_err *err)
{
    uint8_t *data = NULL;
    size_t size = 0;
    hz_result r = hz_tree_save_mem(t, &data, &size, err);
    if (r != HZ_OK)
        return r;
    FILE *f = fopen(path, "wb");
    if (!f) {
        free(data);
        return hz_err_set(err, HZ_ERR_IO, "cannot write '%s': %s", path, strerror(errno));
    }
    size_t wr = fwrite(data, 1, size, f);
    int cl = fclose(f);
    free(data);
    if (wr != size || cl != 0)
        return hz_err_set(err, HZ_ERR_IO, "cannot write '%s': %s", path, strerror(errno));
    return HZ_OK;
}

/* ---- reader --------------------------------------------------------------- */

typedef struct rbuf {
    const uint8_t *p;
    size_t n, at;
    bool short_read;
} rbuf;

static bool has(rbuf *r, uint64_t n)
{
    if (r->short_read || n > r->n - r->at) {
        r->short_read = true;
        return false;
    }
    return true;
}
static uint32_t get_u32(rbuf *r)
{
    if (!has(r, 4))
        return 0;
    const uint8_t *b = r->p + r->at;
    r->at += 4;
    return (uint32_t)b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 | (uint32_t)b[3] << 24;
}
static uint64_t get_u64(rbuf *r)
{
    uint64_t lo = get_u32(r);
    return lo | (uint64_t)get_u32(r) << 32;
}
static float get_f32(rbuf *r)
{
    uint32_t v = get_u32(r);
    float f;
    memcpy(&f, &v, 4);
    return f;
}
static double get_f64(rbuf *r)
{
    uint64_t v = get_u64(r);
    double f;
    memcpy(&f, &v, 8);
    return f;
}
static void get_f32s(rbuf *r, float *f, size_t n)
{
    for (size_t k = 0; k < n; k++)
        f[k] = get_f32(r);
}

/* Allocates count*elem bytes after checking the file still holds
 * count*file_elem bytes (so a lying header cannot make us allocate). */
static void *alloc_checked(rbuf *r, uint64_t count, size_t elem, size_t file_elem, bool *oom)
{
    if (count == 0)
        return NULL;
    if (!has(r, count * file_elem))
        return NULL;
    void *p = calloc((size_t)count, elem);
    if (!p)
        *oom = true;
    return p;
}

static hz_result read_mesh(rbuf *r, hz_tree_mesh *m, const char *what, hz_err *err)
{
    bool oom = false;
    uint64_t vc = m->vertex_count, ic = m->index_count;
    m->vertex_count = m->index_count = 0; /* until filled */
    m->pos = alloc_checked(r, vc * 3, sizeof(float), 4, &oom);
    if (m->pos || vc == 0) {
        get_f32s(r, m->pos, vc * 3);
        m->nrm = alloc_checked(r, vc * 3, sizeof(float), 4, &oom);
        if (m->nrm || vc == 0) {
            get_f32s(r, m->nrm, vc * 3);
            m->idx = alloc_checked(r, ic, sizeof(uint32_t), 4, &oom);
            for (uint64_t k = 0; m->idx && k < ic; k++)
                m->idx[k] = get_u32(r);
        }
    }
    if (oom)
        return hz_err_set(err, HZ_ERR_MEMORY, "out of memory reading the %s mesh", what);
    if (r->short_read)
        return hz_err_set(err, HZ_ERR_FORMAT, "truncated in the %s mesh", what);
    m->vertex_count = (uint32_t)vc;
    m->index_count = (uint32_t)ic;
    return HZ_OK;
}

static hz_tree *parse(const uint8_t *data, size_t size, hz_err *err)
{
    if (size < 8 + 4 + 4 || memcmp(data, MAGIC, 8) != 0) {
        hz_err_set(err, HZ_ERR_FORMAT, "not a horizon tree file (.hzt): bad magic");
        return NULL;
    }
    rbuf r = {.p = data, .n = size - 4, .at = 8};
    uint32_t version = get_u32(&r);
    if (version != VERSION) {
        hz_err_set(err, HZ_ERR_FORMAT, "tree file version %u is not supported (this build reads %u)", version,
                   VERSION);
        return NULL;
    }
    uint32_t stored = (uint32_t)data[size - 4] | (uint32_t)data[size - 3] << 8 | (uint32_t)data[size - 2] << 16 |
                      (uint32_t)data[size - 1] << 24;
    if (stored != hz_tree_crc32(data, size - 4)) {
        hz_err_set(err, HZ_ERR_FORMAT, "tree file is corrupt or truncated (CRC-32 mismatch)");
        return NULL;
    }
    hz_tree *t = calloc(1, sizeof *t);
    if (!t) {
        hz_err_set(err, HZ_ERR_MEMORY, "out of memory");
        return NULL;
    }
    if (has(&r, 32)) {
        memcpy(t->species, r.p + r.at, 31);
        r.at += 32;
    }
    for (char *c = t->species; *c; c++)
        if ((unsigned char)*c < 32 || (unsigned char)*c > 126)
            *c = '?';
    t->seed = get_u64(&r);
    t->levels = get_u32(&r);
    uint32_t nb = get_u32(&r), nn = get_u32(&r), nl = get_u32(&r);
    t->bark.vertex_count = get_u32(&r);
    t->bark.index_count = get_u32(&r);
    t->hull.vertex_count = get_u32(&r);
    t->hull.index_count = get_u32(&r);
    get_f32s(&r, t->leaf_color, 3);
    get_f32s(&r, t->bark_color, 3);
    uint32_t ranked = get_u32(&r);
    t->ranked = ranked != 0;
    t->rank_views = get_u32(&r);
    t->rank_res = get_u32(&r);
    t->rank_layers = get_u32(&r);
    t->rank_ms = get_f64(&r);
    for (uint32_t l = 0; l < HZ_TREE_MAX_LEVELS; l++)
        t->bark_level_end[l] = get_u32(&r);
    bool oom = false;
    if (r.short_read)
        goto truncated;
    if (ranked > 1 || t->levels < 1 || t->levels > HZ_TREE_MAX_LEVELS || !isfinite(t->rank_ms)) {
        hz_err_set(err, HZ_ERR_FORMAT, "tree file header is inconsistent (levels %u, ranked %u)", t->levels, ranked);
        goto fail;
    }
    for (int c = 0; c < 3; c++)
        if (!isfinite(t->leaf_color[c]) || !isfinite(t->bark_color[c])) {
            hz_err_set(err, HZ_ERR_FORMAT, "tree file colours are not finite");
            goto fail;
        }
    t->branches = alloc_checked(&r, nb, sizeof *t->branches, 56, &oom);
    if (!t->branches && !oom)
        goto truncated;
    if (oom)
        goto nomem;
    t->branch_count = nb;
    for (uint32_t b = 0; b < nb; b++) {
        hz_tree_branch *br = &t->branches[b];
        br->parent = get_u32(&r);
        br->level = get_u32(&r);
        br->leaf_node = get_u32(&r);
        br->length = get_f32(&r);
        br->radius = get_f32(&r);
        get_f32s(&r, br->base, 3);
        get_f32s(&r, br->tip, 3);
        get_f32s(&r, br->dir, 3);
    }
    if (nn) {
        t->nodes = alloc_checked(&r, nn, sizeof *t->nodes, 12, &oom);
        if (!t->nodes && !oom)
            goto truncated;
        if (oom)
            goto nomem;
    }
    for (uint32_t n = 0; n < nn; n++) {
        t->nodes[n].branch = get_u32(&r);
        t->nodes[n].first = get_u32(&r);
        t->nodes[n].count = get_u32(&r);
        t->nodes[n].bsl = 1;
    }
    t->node_count = nn;
    if (nl) {
        t->leaves = alloc_checked(&r, nl, sizeof *t->leaves, 36, &oom);
        if (!t->leaves && !oom)
            goto truncated;
        if (oom)
            goto nomem;
    }
    for (uint32_t k = 0; k < nl; k++) {
        get_f32s(&r, t->leaves[k].c, 3);
        get_f32s(&r, t->leaves[k].u, 3);
        get_f32s(&r, t->leaves[k].v, 3);
    }
    t->leaf_count = nl;
    if (r.short_read)
        goto truncated;
    if (read_mesh(&r, &t->bark, "bark", err) != HZ_OK || read_mesh(&r, &t->hull, "hull", err) != HZ_OK)
        goto fail;
    if (r.at != r.n) {
        hz_err_set(err, HZ_ERR_FORMAT, "tree file has %zu unexpected bytes before its CRC", r.n - r.at);
        goto fail;
    }
    /* Node ranges must be sane before the derived data is computed from them. */
    uint32_t next = 0;
    for (uint32_t n = 0; n < nn; n++) {
        const hz_tree_node *nd = &t->nodes[n];
        if (nd->first != next || nd->count == 0 || nd->count > nl - next || nd->branch >= nb) {
            hz_err_set(err, HZ_ERR_FORMAT, "tree file: leaf node %u range [%u, +%u) or branch %u is invalid", n,
                       nd->first, nd->count, nd->branch);
            goto fail;
        }
        next += nd->count;
    }
    /* Leaves before hz_tree_finish: validate would otherwise name the node
     * spheres derived from a bad leaf, not the leaf. The bark and hull
     * vertices are bounded by hz_tree_validate below. */
    for (uint32_t k = 0; k < nl; k++)
        for (int c = 0; c < 3; c++)
            if (!isfinite(t->leaves[k].c[c]) || !isfinite(t->leaves[k].u[c]) || !isfinite(t->leaves[k].v[c]) ||
                fabsf(t->leaves[k].c[c]) > HZ_TREE_MAX_COORD || fabsf(t->leaves[k].u[c]) > HZ_TREE_MAX_COORD ||
                fabsf(t->leaves[k].v[c]) > HZ_TREE_MAX_COORD) {
                hz_err_set(err, HZ_ERR_FORMAT, "tree file: leaf %u is not finite or absurdly large", k);
                goto fail;
            }
    hz_tree_finish(t);
    if (hz_tree_validate(t, err) != HZ_OK)
        goto fail;
    return t;
truncated:
    hz_err_set(err, HZ_ERR_FORMAT, "tree file is truncated or its counts do not match its size");
    goto fail;
nomem:
    hz_err_set(err, HZ_ERR_MEMORY, "out of memory reading the tree");
fail:
    hz_tree_destroy(t);
    return NULL;
}

hz_tree *hz_tree_load_mem(const uint8_t *data, size_t size, hz_err *err)
{
    return parse(data, size, err);
}

hz_tree *hz_tree_load(const char *path, hz_err *err)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        hz_err_set(err, HZ_ERR_IO, "cannot open tree file '%s': %s", path, strerror(errno));
        return NULL;
    }
    uint8_t *data = NULL;
    size_t n = 0, cap = 0;
    for (;;) {
        if (n == cap) {
            size_t nc = cap ? cap * 2 : (1u << 20);
            if (nc > MAX_FILE) {
                fclose(f);
                free(data);
                hz_err_set(err, HZ_ERR_FORMAT, "tree file '%s' is larger than 2 GB", path);
                return NULL;
            }
            uint8_t *np = realloc(data, nc);
            if (!np) {
                fclose(f);
                free(data);
                hz_err_set(err, HZ_ERR_MEMORY, "out of memory reading '%s'", path);
                return NULL;
            }
            data = np;
            cap = nc;
        }
        size_t got = fread(data + n, 1, cap - n, f);
        n += got;
        if (got == 0)
            break;
    }
    bool bad = ferror(f);
    fclose(f);
    if (bad) {
        free(data);
        hz_err_set(err, HZ_ERR_IO, "cannot read tree file '%s'", path);
        return NULL;
    }
    hz_err e = {0};
    hz_tree *t = parse(data, n, &e);
    free(data);
    if (!t)
        hz_err_set(err, e.code, "%s: %s", path, e.msg);
    return t;
}
