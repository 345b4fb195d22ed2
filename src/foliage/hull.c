/* Crown hull for far trees (SPEC F5). The seed reconstructs a Poisson
 * surface from branch tips; we get a closed crown more simply: splat leaf
 * centres and twig tips into a density grid, blur it, take the iso-surface
 * that keeps a chosen fraction of the leaves inside (marching tetrahedra on
 * the Kuhn split of each cube: a level set of a piecewise-linear field, so
 * the surface is closed and 2-manifold by construction), then simplify it
 * with meshoptimizer. No GL. */
#include "horizon/tree.h"

#include <math.h>
#include <meshoptimizer.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "foliage_internal.h"

/* ---- mesh topology check ------------------------------------------------- */

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

static bool has_key(const uint64_t *keys, size_t n, uint64_t k)
{
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = (lo + hi) / 2;
        if (keys[mid] < k)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo < n && keys[lo] == k;
}

typedef struct corner {
    uint32_t v, b, c; /* triangle (v, b, c) seen from v */
} corner;

static int cmp_corner(const void *a, const void *b)
{
    const corner *x = a, *y = b;
    if (x->v != y->v)
        return (x->v > y->v) - (x->v < y->v);
    return (x->b > y->b) - (x->b < y->b);
}

hz_result hz_mesh_check(const uint32_t *idx, uint32_t index_count, uint32_t vertex_count,
                        hz_mesh_topology *out, hz_err *err)
{
    *out = (hz_mesh_topology){0};
    const size_t nt = index_count / 3;
    uint64_t *e = malloc((nt * 3 + 1) * sizeof *e);
    corner *cn = malloc((nt * 3 + 1) * sizeof *cn);
    uint8_t *used = calloc(vertex_count + 1, 1);
    if (!e || !cn || !used) {
        free(e);
        free(cn);
        free(used);
        return hz_err_set(err, HZ_ERR_MEMORY, "out of memory");
    }
    size_t ne = 0, nc = 0;
    for (size_t t = 0; t < nt; t++) {
        uint32_t a = idx[t * 3], b = idx[t * 3 + 1], c = idx[t * 3 + 2];
        if (a >= vertex_count || b >= vertex_count || c >= vertex_count) {
            free(e);
            free(cn);
            free(used);
            return hz_err_set(err, HZ_ERR_VALUE, "mesh: index out of range");
        }
        if (a == b || b == c || a == c) {
            out->degenerate++;
            continue;
        }
        used[a] = used[b] = used[c] = 1;
        e[ne++] = (uint64_t)a << 32 | b;
        e[ne++] = (uint64_t)b << 32 | c;
        e[ne++] = (uint64_t)c << 32 | a;
        cn[nc++] = (corner){a, b, c};
        cn[nc++] = (corner){b, c, a};
        cn[nc++] = (corner){c, a, b};
    }
    qsort(e, ne, sizeof *e, cmp_u64);
    for (size_t k = 0; k < ne; k++) {
        bool dup = (k > 0 && e[k] == e[k - 1]) || (k + 1 < ne && e[k] == e[k + 1]);
        uint64_t rev = (e[k] & 0xffffffffu) << 32 | e[k] >> 32;
        if (dup || !has_key(e, ne, rev))
            out->bad_edges++;
    }
    out->edges = ne / 2;
    /* Each vertex: the edges (b -> c) opposite it must form one cycle. */
    qsort(cn, nc, sizeof *cn, cmp_corner);
    for (size_t s = 0; s < nc;) {
        size_t t = s;
        while (t < nc && cn[t].v == cn[s].v)
            t++;
        size_t deg = t - s;
        bool ok = true;
        for (size_t k = s + 1; k < t && ok; k++)
            ok = cn[k].b != cn[k - 1].b; /* each link vertex starts one edge */
        if (ok) {
            uint32_t start = cn[s].b, cur = start;
            size_t steps = 0;
            do {
                /* find the corner whose b == cur (binary search on b) */
                size_t lo = s, hi = t;
                while (lo < hi) {
                    size_t mid = (lo + hi) / 2;
                    if (cn[mid].b < cur)
                        lo = mid + 1;
                    else
                        hi = mid;
                }
                if (lo >= t || cn[lo].b != cur) {
                    ok = false;
                    break;
                }
                cur = cn[lo].c;
                steps++;
            } while (cur != start && steps <= deg);
            ok = ok && cur == start && steps == deg;
        }
        if (!ok)
            out->bad_vertices++;
        s = t;
    }
    int64_t nv = 0;
    for (uint32_t v = 0; v < vertex_count; v++)
        nv += used[v];
    out->euler = nv - (int64_t)out->edges + (int64_t)(nc / 3);
    free(e);
    free(cn);
    free(used);
    return HZ_OK;
}

/* ---- density grid ---------------------------------------------------------- */

typedef struct grid {
    uint32_t nx, ny, nz;
    float origin[3], h;
    float *f;
} grid;

static inline size_t gidx(const grid *g, uint32_t x, uint32_t y, uint32_t z)
{
    return ((size_t)z * g->ny + y) * g->nx + x;
}

static void splat(grid *g, const float *p, float w)
{
    float q[3];
    for (int c = 0; c < 3; c++)
        q[c] = (p[c] - g->origin[c]) / g->h;
    int i = (int)floorf(q[0]), j = (int)floorf(q[1]), k = (int)floorf(q[2]);
    float fx = q[0] - (float)i, fy = q[1] - (float)j, fz = q[2] - (float)k;
    if (i < 0 || j < 0 || k < 0 || i + 1 >= (int)g->nx || j + 1 >= (int)g->ny || k + 1 >= (int)g->nz)
        return;
    for (int d = 0; d < 8; d++) {
        float wx = (d & 1) ? fx : 1 - fx, wy = (d & 2) ? fy : 1 - fy, wz = (d & 4) ? fz : 1 - fz;
        g->f[gidx(g, (uint32_t)(i + (d & 1)), (uint32_t)(j + ((d >> 1) & 1)), (uint32_t)(k + ((d >> 2) & 1)))] +=
            w * wx * wy * wz;
    }
}

static float sample(const grid *g, const float *p)
{
    float q[3];
    for (int c = 0; c < 3; c++)
        q[c] = (p[c] - g->origin[c]) / g->h;
    int i = (int)floorf(q[0]), j = (int)floorf(q[1]), k = (int)floorf(q[2]);
    if (i < 0 || j < 0 || k < 0 || i + 1 >= (int)g->nx || j + 1 >= (int)g->ny || k + 1 >= (int)g->nz)
        return 0.0f;
    float fx = q[0] - (float)i, fy = q[1] - (float)j, fz = q[2] - (float)k, s = 0.0f;
    for (int d = 0; d < 8; d++) {
        float wx = (d & 1) ? fx : 1 - fx, wy = (d & 2) ? fy : 1 - fy, wz = (d & 4) ? fz : 1 - fz;
        s += wx * wy * wz *
             g->f[gidx(g, (uint32_t)(i + (d & 1)), (uint32_t)(j + ((d >> 1) & 1)), (uint32_t)(k + ((d >> 2) & 1)))];
    }
    return s;
}

/* Separable Gaussian blur along one axis. */
static bool blur_axis(grid *g, int axis, float sigma)
{
    int r = (int)ceilf(3.0f * sigma);
    float kern[64];
    if (r > 31)
        r = 31;
    float ks = 0.0f;
    for (int k = -r; k <= r; k++)
        ks += kern[k + r] = expf(-0.5f * (float)(k * k) / (sigma * sigma));
    for (int k = 0; k <= 2 * r; k++)
        kern[k] /= ks;
    uint32_t n[3] = {g->nx, g->ny, g->nz};
    uint32_t len = n[axis];
    float *line = malloc(len * sizeof *line);
    if (!line)
        return false;
    uint32_t a1 = (uint32_t)(axis + 1) % 3, a2 = (uint32_t)(axis + 2) % 3;
    for (uint32_t u = 0; u < n[a1]; u++)
        for (uint32_t w = 0; w < n[a2]; w++) {
            uint32_t c[3];
            c[a1] = u;
            c[a2] = w;
            for (uint32_t s = 0; s < len; s++) {
                c[axis] = s;
                line[s] = g->f[gidx(g, c[0], c[1], c[2])];
            }
            for (uint32_t s = 0; s < len; s++) {
                float acc = 0.0f;
                for (int k = -r; k <= r; k++) {
                    int q = (int)s + k;
                    if (q >= 0 && q < (int)len)
                        acc += kern[k + r] * line[q];
                }
                c[axis] = s;
                g->f[gidx(g, c[0], c[1], c[2])] = acc;
            }
        }
    free(line);
    return true;
}

/* ---- marching tetrahedra ---------------------------------------------------- */

typedef struct vmap {
    uint64_t *keys; /* edge key + 1, 0 = empty */
    uint32_t *vals;
    size_t cap;
} vmap;

typedef struct mt_out {
    float *pos;
    uint32_t nv, cap_v;
    uint32_t *idx;
    size_t ni, cap_i;
    bool oom;
} mt_out;

static uint32_t edge_vertex(vmap *m, mt_out *o, const grid *g, size_t ia, size_t ib, float fa, float fb, float iso)
{
    if (ia > ib) {
        size_t t = ia;
        ia = ib;
        ib = t;
        float tf = fa;
        fa = fb;
        fb = tf;
    }
    uint64_t key = ((uint64_t)ia * 0x9E3779B97F4A7C15ULL) ^ ((uint64_t)ib + 0x632BE59BD9B4E019ULL);
    uint64_t tag = ((uint64_t)ia << 32 | (uint64_t)ib) + 1; /* grids < 2^32 samples */
    size_t h = (size_t)(key ^ (key >> 29)) & (m->cap - 1);
    while (m->keys[h]) {
        if (m->keys[h] == tag)
            return m->vals[h];
        h = (h + 1) & (m->cap - 1);
    }
    if (o->nv == o->cap_v) {
        uint32_t nc = o->cap_v ? o->cap_v * 2 : 4096;
        float *np = realloc(o->pos, (size_t)nc * 3 * sizeof *np);
        if (!np) {
            o->oom = true;
            return 0;
        }
        o->pos = np;
        o->cap_v = nc;
    }
    float t = (iso - fa) / (fb - fa);
    t = fminf(fmaxf(t, 0.02f), 0.98f); /* no zero-area triangles */
    size_t plane = (size_t)g->nx * g->ny;
    float pa[3] = {(float)(ia % g->nx), (float)((ia / g->nx) % g->ny), (float)(ia / plane)};
    float pb[3] = {(float)(ib % g->nx), (float)((ib / g->nx) % g->ny), (float)(ib / plane)};
    for (int c = 0; c < 3; c++)
        o->pos[(size_t)o->nv * 3 + c] = g->origin[c] + g->h * (pa[c] + (pb[c] - pa[c]) * t);
    m->keys[h] = tag;
    m->vals[h] = o->nv;
    return o->nv++;
}

static void emit(mt_out *o, uint32_t a, uint32_t b, uint32_t c, const float *outward)
{
    if (o->ni + 3 > o->cap_i) {
        size_t nc = o->cap_i ? o->cap_i * 2 : 12288;
        uint32_t *np = realloc(o->idx, nc * sizeof *np);
        if (!np) {
            o->oom = true;
            return;
        }
        o->idx = np;
        o->cap_i = nc;
    }
    float e1[3], e2[3], n[3];
    v3_sub(e1, &o->pos[b * 3], &o->pos[a * 3]);
    v3_sub(e2, &o->pos[c * 3], &o->pos[a * 3]);
    v3_cross(n, e1, e2);
    if (v3_dot(n, outward) < 0.0f) {
        uint32_t t = b;
        b = c;
        c = t;
    }
    o->idx[o->ni++] = a;
    o->idx[o->ni++] = b;
    o->idx[o->ni++] = c;
}

static bool march(const grid *g, float iso, mt_out *o)
{
    /* Kuhn split: 6 tetrahedra along the cube diagonal 0 -> 7 (bit 0 = x,
     * bit 1 = y, bit 2 = z). Every cube is split the same way, so shared
     * faces are split by the same diagonal and the surface has no cracks. */
    static const uint8_t tets[6][4] = {{0, 1, 3, 7}, {0, 1, 5, 7}, {0, 2, 3, 7},
                                       {0, 2, 6, 7}, {0, 4, 5, 7}, {0, 4, 6, 7}};
    vmap m = {0};
    m.cap = 1u << 16;
    size_t cells = (size_t)g->nx * g->ny * g->nz;
    while (m.cap < cells / 2)
        m.cap <<= 1;
    m.keys = calloc(m.cap, sizeof *m.keys);
    m.vals = malloc(m.cap * sizeof *m.vals);
    if (!m.keys || !m.vals) {
        free(m.keys);
        free(m.vals);
        return false;
    }
    size_t used = 0;
    for (uint32_t z = 0; z + 1 < g->nz && !o->oom; z++)
        for (uint32_t y = 0; y + 1 < g->ny; y++)
            for (uint32_t x = 0; x + 1 < g->nx; x++) {
                size_t ci[8];
                float cf[8];
                int inside = 0;
                for (int d = 0; d < 8; d++) {
                    ci[d] = gidx(g, x + (d & 1), y + ((d >> 1) & 1), z + ((d >> 2) & 1));
                    cf[d] = g->f[ci[d]];
                    inside += cf[d] > iso;
                }
                if (inside == 0 || inside == 8)
                    continue;
                /* Keep the hash table below half full. */
                if (used + 24 > m.cap / 2) {
                    size_t nc = m.cap * 2;
                    uint64_t *nk = calloc(nc, sizeof *nk);
                    uint32_t *nvv = malloc(nc * sizeof *nvv);
                    if (!nk || !nvv) {
                        free(nk);
                        free(nvv);
                        free(m.keys);
                        free(m.vals);
                        return false;
                    }
                    for (size_t k = 0; k < m.cap; k++)
                        if (m.keys[k]) {
                            uint64_t tag = m.keys[k] - 1, ia = tag >> 32, ib = tag & 0xffffffffu;
                            uint64_t key = (ia * 0x9E3779B97F4A7C15ULL) ^ (ib + 0x632BE59BD9B4E019ULL);
                            size_t h = (size_t)(key ^ (key >> 29)) & (nc - 1);
                            while (nk[h])
                                h = (h + 1) & (nc - 1);
                            nk[h] = m.keys[k];
                            nvv[h] = m.vals[k];
                        }
                    free(m.keys);
                    free(m.vals);
                    m.keys = nk;
                    m.vals = nvv;
                    m.cap = nc;
                }
                for (int t = 0; t < 6; t++) {
                    int in[4], out[4], ni = 0, no = 0;
                    for (int k = 0; k < 4; k++) {
                        int c = tets[t][k];
                        if (cf[c] > iso)
                            in[ni++] = c;
                        else
                            out[no++] = c;
                    }
                    if (ni == 0 || ni == 4)
                        continue;
                    /* Outward = from the inside corners toward the outside ones. */
                    float ctr_in[3] = {0, 0, 0}, ctr_out[3] = {0, 0, 0}, outward[3];
                    for (int k = 0; k < ni; k++) {
                        ctr_in[0] += (float)(in[k] & 1) / (float)ni;
                        ctr_in[1] += (float)((in[k] >> 1) & 1) / (float)ni;
                        ctr_in[2] += (float)((in[k] >> 2) & 1) / (float)ni;
                    }
                    for (int k = 0; k < no; k++) {
                        ctr_out[0] += (float)(out[k] & 1) / (float)no;
                        ctr_out[1] += (float)((out[k] >> 1) & 1) / (float)no;
                        ctr_out[2] += (float)((out[k] >> 2) & 1) / (float)no;
                    }
                    v3_sub(outward, ctr_out, ctr_in);
#define EV(i_, o_) edge_vertex(&m, o, g, ci[i_], ci[o_], cf[i_], cf[o_], iso)
                    if (ni == 1) {
                        uint32_t a = EV(in[0], out[0]), b = EV(in[0], out[1]), c = EV(in[0], out[2]);
                        emit(o, a, b, c, outward);
                        used += 3;
                    } else if (ni == 3) {
                        uint32_t a = EV(in[0], out[0]), b = EV(in[1], out[0]), c = EV(in[2], out[0]);
                        emit(o, a, b, c, outward);
                        used += 3;
                    } else {
                        uint32_t e00 = EV(in[0], out[0]), e01 = EV(in[0], out[1]);
                        uint32_t e11 = EV(in[1], out[1]), e10 = EV(in[1], out[0]);
                        emit(o, e00, e01, e11, outward);
                        emit(o, e00, e11, e10, outward);
                        used += 4;
                    }
#undef EV
                    if (o->oom)
                        break;
                }
            }
    free(m.keys);
    free(m.vals);
    return !o->oom;
}

/* Drops connected pieces smaller than frac of the triangles (specks of a few
 * stray leaves), which simplification would only crush. */
static void drop_small_components(mt_out *o, double frac)
{
    uint32_t *par = malloc((o->nv ? o->nv : 1) * sizeof *par);
    uint32_t *cnt = calloc(o->nv ? o->nv : 1, sizeof *cnt);
    if (!par || !cnt) {
        free(par);
        free(cnt);
        return;
    }
    for (uint32_t v = 0; v < o->nv; v++)
        par[v] = v;
    for (size_t k = 0; k < o->ni; k += 3)
        for (int e = 1; e < 3; e++) {
            uint32_t a = o->idx[k], b = o->idx[k + e];
            while (par[a] != a)
                a = par[a] = par[par[a]];
            while (par[b] != b)
                b = par[b] = par[par[b]];
            if (a != b)
                par[b] = a;
        }
    for (size_t k = 0; k < o->ni; k += 3) {
        uint32_t a = o->idx[k];
        while (par[a] != a)
            a = par[a];
        cnt[a]++;
    }
    size_t w = 0, min_tris = (size_t)(frac * (double)(o->ni / 3));
    for (size_t k = 0; k < o->ni; k += 3) {
        uint32_t a = o->idx[k];
        while (par[a] != a)
            a = par[a];
        if (cnt[a] >= min_tris) {
            memmove(&o->idx[w], &o->idx[k], 3 * sizeof *o->idx);
            w += 3;
        }
    }
    if (w > 0)
        o->ni = w;
    free(par);
    free(cnt);
}

typedef struct tcorner {
    uint32_t v, b, c, tri, slot;
} tcorner;

static int cmp_tcorner(const void *a, const void *b)
{
    const tcorner *x = a, *y = b;
    return (x->v > y->v) - (x->v < y->v);
}

/* A vertex where two fans of triangles touch (a pinch) gets one copy per
 * fan, which makes it manifold without moving anything. Vertices are
 * appended to *pos (capacity grown as needed). false on out of memory. */
static bool split_pinched_vertices(uint32_t *idx, size_t ni, float **pos, uint32_t *nv, uint32_t *cap)
{
    size_t nc = ni;
    tcorner *cn = malloc((nc ? nc : 1) * sizeof *cn);
    if (!cn)
        return false;
    for (size_t t = 0; t < ni / 3; t++)
        for (uint32_t k = 0; k < 3; k++)
            cn[t * 3 + k] = (tcorner){idx[t * 3 + k], idx[t * 3 + (k + 1) % 3], idx[t * 3 + (k + 2) % 3],
                                      (uint32_t)t, k};
    qsort(cn, nc, sizeof *cn, cmp_tcorner);
    bool ok = true;
    uint32_t fan[256];
    for (size_t s0 = 0; s0 < nc && ok;) {
        size_t s1 = s0;
        while (s1 < nc && cn[s1].v == cn[s0].v)
            s1++;
        size_t deg = s1 - s0;
        if (deg <= 256) {
            for (size_t i = 0; i < deg; i++)
                fan[i] = (uint32_t)i;
            /* union corners that share a link edge endpoint in chain order */
            bool changed = true;
            while (changed) {
                changed = false;
                for (size_t i = 0; i < deg; i++)
                    for (size_t j = 0; j < deg; j++)
                        if (cn[s0 + i].c == cn[s0 + j].b && fan[i] != fan[j]) {
                            uint32_t m = fan[i] < fan[j] ? fan[i] : fan[j];
                            fan[i] = fan[j] = m;
                            changed = true;
                        }
            }
            for (size_t i = 0; i < deg; i++) {
                if (fan[i] == fan[0])
                    continue;
                /* first corner of a later fan: new vertex for the whole fan */
                uint32_t f = fan[i];
                if (*nv == *cap) {
                    uint32_t ncap = *cap * 2 + 16;
                    float *np = realloc(*pos, (size_t)ncap * 3 * sizeof *np);
                    if (!np) {
                        ok = false;
                        break;
                    }
                    *pos = np;
                    *cap = ncap;
                }
                uint32_t nvid = (*nv)++;
                memcpy(*pos + (size_t)nvid * 3, *pos + (size_t)cn[s0].v * 3, 3 * sizeof(float));
                for (size_t j = i; j < deg; j++)
                    if (fan[j] == f) {
                        idx[cn[s0 + j].tri * 3 + cn[s0 + j].slot] = nvid;
                        fan[j] = fan[0]; /* handled */
                    }
            }
        }
        s0 = s1;
    }
    free(cn);
    return ok;
}

static int cmp_float(const void *a, const void *b)
{
    float x = *(const float *)a, y = *(const float *)b;
    return (x > y) - (x < y);
}

hz_result hz_hull_build(hz_tree *t, const hz_hull_desc *desc, hz_hull_stats *stats, hz_err *err)
{
    double t0 = hz_time_ms();
    hz_hull_desc d = desc ? *desc : (hz_hull_desc){0};
    if (!d.grid)
        d.grid = 40;
    if (d.blur <= 0.0f)
        d.blur = 2.5f;
    if (d.coverage <= 0.0f)
        d.coverage = 0.9f;
    if (!d.triangles)
        d.triangles = 3000;
    if (d.grid < 8 || d.grid > 256 || d.blur > 8.0f || d.coverage > 1.0f || d.triangles < 16)
        return hz_err_set(err, HZ_ERR_VALUE,
                          "hull: bad parameters (grid %u in 8..256, blur %g in (0, 8], coverage %g in (0, 1], "
                          "triangles %u >= 16)",
                          d.grid, (double)d.blur, (double)d.coverage, d.triangles);
    if (t->leaf_count == 0)
        return hz_err_set(err, HZ_ERR_VALUE, "hull: the tree has no leaves");
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (uint32_t k = 0; k < t->leaf_count; k++)
        for (int c = 0; c < 3; c++) {
            lo[c] = fminf(lo[c], t->leaves[k].c[c]);
            hi[c] = fmaxf(hi[c], t->leaves[k].c[c]);
        }
    float ext = fmaxf(fmaxf(hi[0] - lo[0], hi[1] - lo[1]), fmaxf(hi[2] - lo[2], 1e-3f));
    grid g = {.h = ext / (float)d.grid};
    uint32_t pad = (uint32_t)ceilf(3.0f * d.blur) + 2;
    uint32_t dims[3];
    for (int c = 0; c < 3; c++) {
        dims[c] = (uint32_t)ceilf((hi[c] - lo[c]) / g.h) + 1 + 2 * pad;
        g.origin[c] = lo[c] - (float)pad * g.h;
    }
    g.nx = dims[0], g.ny = dims[1], g.nz = dims[2];
    g.f = calloc((size_t)g.nx * g.ny * g.nz, sizeof *g.f);
    float *dens = malloc(t->leaf_count * sizeof *dens);
    mt_out o = {0};
    unsigned int *simp = NULL, *remap = NULL;
    hz_result res = HZ_OK;
    if (!g.f || !dens) {
        res = hz_err_set(err, HZ_ERR_MEMORY, "hull: out of memory");
        goto done;
    }
    for (uint32_t k = 0; k < t->leaf_count; k++)
        splat(&g, t->leaves[k].c, 1.0f);
    for (uint32_t b = 0; b < t->branch_count; b++)
        if (t->branches[b].leaf_node != HZ_TREE_NONE)
            splat(&g, t->branches[b].tip, 1.0f);
    for (int axis = 0; axis < 3; axis++)
        if (!blur_axis(&g, axis, d.blur)) {
            res = hz_err_set(err, HZ_ERR_MEMORY, "hull: out of memory");
            goto done;
        }
    /* Iso level: `coverage` of the leaf centres lie at density >= iso. */
    for (uint32_t k = 0; k < t->leaf_count; k++)
        dens[k] = sample(&g, t->leaves[k].c);
    qsort(dens, t->leaf_count, sizeof *dens, cmp_float);
    size_t q = (size_t)((1.0f - d.coverage) * (float)(t->leaf_count - 1));
    float iso = dens[q];
    if (!(iso > 0.0f))
        iso = dens[t->leaf_count - 1] * 0.5f;
    /* A few leaves (a sapling, a small import) can make that level the
     * field's very peak, where the surface shrinks to points: lower it until
     * the surface encloses them (more leaves inside, never fewer). */
    for (int tries = 0;; tries++) {
        if (!march(&g, iso, &o)) {
            res = hz_err_set(err, HZ_ERR_MEMORY, "hull: out of memory");
            goto done;
        }
        if (o.ni > 0 || tries == 8)
            break;
        free(o.pos);
        free(o.idx);
        o = (mt_out){0};
        iso *= 0.5f;
    }
    if (o.ni == 0) {
        res = hz_err_set(err, HZ_ERR_VALUE, "hull: the iso-surface is empty (%u leaves)", t->leaf_count);
        goto done;
    }
    /* Simplify. target_error is relative to the mesh extent; a crown seen
     * from afar tolerates a few percent. */
    simp = malloc(o.ni * sizeof *simp);
    remap = malloc((size_t)o.nv * sizeof *remap);
    size_t remap_cap = o.nv;
    if (!simp || !remap) {
        res = hz_err_set(err, HZ_ERR_MEMORY, "hull: out of memory");
        goto done;
    }
    drop_small_components(&o, 0.02);
    size_t target = (size_t)d.triangles * 3;
    size_t ni = o.ni;
    bool simplified = false;
    /* meshoptimizer's collapses can pinch a thin part of the crown into a
     * non-manifold vertex (split it: one copy per fan) or edge (retry with
     * targets around the asked one); should all fail, keep the raw surface,
     * so that far trees never show holes. */
    static const float factors[10] = {1.0f, 0.9f, 1.1f, 0.8f, 1.25f, 0.7f, 1.4f, 0.6f, 1.6f, 2.0f};
    const size_t base_target = target;
    for (int attempt = 0; attempt < 10 && o.ni > base_target && !simplified; attempt++) {
        target = (size_t)((float)base_target * factors[attempt]) / 3 * 3;
        float rerr = 0.0f;
        ni = meshopt_simplify(simp, o.idx, o.ni, o.pos, o.nv, 3 * sizeof(float), target, 0.08f, 0, &rerr);
        hz_mesh_topology topo;
        if (hz_mesh_check(simp, (uint32_t)ni, o.nv, &topo, err) != HZ_OK) {
            res = HZ_ERR_MEMORY;
            goto done;
        }
        if (topo.bad_vertices && !topo.bad_edges && !topo.degenerate) {
            /* Pinched vertices only: split them (appends vertices). */
            if (!split_pinched_vertices(simp, ni, &o.pos, &o.nv, &o.cap_v)) {
                res = hz_err_set(err, HZ_ERR_MEMORY, "hull: out of memory");
                goto done;
            }
            if (o.nv > remap_cap) {
                unsigned int *nr = realloc(remap, (size_t)o.nv * sizeof *nr);
                if (!nr) {
                    res = hz_err_set(err, HZ_ERR_MEMORY, "hull: out of memory");
                    goto done;
                }
                remap = nr;
                remap_cap = o.nv;
            }
            if (hz_mesh_check(simp, (uint32_t)ni, o.nv, &topo, err) != HZ_OK) {
                res = HZ_ERR_MEMORY;
                goto done;
            }
        }
        simplified = ni > 0 && !topo.bad_edges && !topo.bad_vertices && !topo.degenerate;
        if (getenv("HZ_HULL_DEBUG"))
            fprintf(stderr, "hull: simplified %zu -> %zu tris err %g bad e %lu v %lu deg %lu\n", o.ni / 3, ni / 3,
                    (double)rerr, (unsigned long)topo.bad_edges, (unsigned long)topo.bad_vertices,
                    (unsigned long)topo.degenerate);
    }
    if (!simplified) {
        memcpy(simp, o.idx, o.ni * sizeof *simp);
        ni = o.ni;
    }
    size_t nv = meshopt_optimizeVertexFetchRemap(remap, simp, ni, o.nv);
    free(t->hull.pos);
    free(t->hull.nrm);
    free(t->hull.idx);
    t->hull = (hz_tree_mesh){0};
    t->hull.pos = malloc(nv * 3 * sizeof(float));
    t->hull.nrm = calloc(nv * 3, sizeof(float));
    t->hull.idx = malloc(ni * sizeof(uint32_t));
    if (!t->hull.pos || !t->hull.nrm || !t->hull.idx) {
        free(t->hull.pos);
        free(t->hull.nrm);
        free(t->hull.idx);
        t->hull = (hz_tree_mesh){0};
        res = hz_err_set(err, HZ_ERR_MEMORY, "hull: out of memory");
        goto done;
    }
    meshopt_remapIndexBuffer(t->hull.idx, simp, ni, remap);
    meshopt_remapVertexBuffer(t->hull.pos, o.pos, o.nv, 3 * sizeof(float), remap);
    t->hull.vertex_count = (uint32_t)nv;
    t->hull.index_count = (uint32_t)ni;
    for (size_t k = 0; k < ni; k += 3) {
        const uint32_t *ix = &t->hull.idx[k];
        float e1[3], e2[3], n[3];
        v3_sub(e1, &t->hull.pos[ix[1] * 3], &t->hull.pos[ix[0] * 3]);
        v3_sub(e2, &t->hull.pos[ix[2] * 3], &t->hull.pos[ix[0] * 3]);
        v3_cross(n, e1, e2);
        for (int c = 0; c < 3; c++)
            v3_add(&t->hull.nrm[ix[c] * 3], &t->hull.nrm[ix[c] * 3], n);
    }
    for (size_t v = 0; v < nv; v++) {
        v3_norm(&t->hull.nrm[v * 3]);
        if (!isfinite(t->hull.nrm[v * 3]))
            v3_set(&t->hull.nrm[v * 3], 0, 1, 0);
    }
    if (stats) {
        stats->grid[0] = g.nx, stats->grid[1] = g.ny, stats->grid[2] = g.nz;
        stats->raw_triangles = (uint32_t)(o.ni / 3);
        stats->triangles = (uint32_t)(ni / 3);
    }
done:
    if (stats)
        stats->ms = hz_time_ms() - t0;
    free(g.f);
    free(dens);
    free(o.pos);
    free(o.idx);
    free(simp);
    free(remap);
    return res;
}

hz_result hz_mesh_simplify(const hz_tree_mesh *in, uint32_t triangles, hz_tree_mesh *out, hz_err *err)
{
    *out = (hz_tree_mesh){0};
    size_t target = (size_t)triangles * 3;
    uint32_t *idx = malloc((in->index_count ? in->index_count : 1) * sizeof *idx);
    unsigned int *remap = malloc((in->vertex_count ? in->vertex_count : 1) * sizeof *remap);
    if (!idx || !remap) {
        free(idx);
        free(remap);
        return hz_err_set(err, HZ_ERR_MEMORY, "hull: out of memory");
    }
    size_t ni = in->index_count;
    if (ni > target) {
        ni = meshopt_simplify(idx, in->idx, in->index_count, in->pos, in->vertex_count, 3 * sizeof(float), target,
                              0.5f, 0, NULL);
        if (ni > target + target / 2 || ni < 12)
            ni = meshopt_simplifySloppy(idx, in->idx, in->index_count, in->pos, in->vertex_count, 3 * sizeof(float),
                                        target, 0.5f, NULL);
    }
    if (ni < 12 || ni >= in->index_count) {
        memcpy(idx, in->idx, in->index_count * sizeof *idx);
        ni = in->index_count;
    }
    size_t nv = meshopt_optimizeVertexFetchRemap(remap, idx, ni, in->vertex_count);
    out->pos = malloc((nv ? nv : 1) * 3 * sizeof(float));
    out->nrm = calloc((nv ? nv : 1) * 3, sizeof(float));
    out->idx = malloc((ni ? ni : 1) * sizeof(uint32_t));
    if (!out->pos || !out->nrm || !out->idx) {
        free(out->pos);
        free(out->nrm);
        free(out->idx);
        *out = (hz_tree_mesh){0};
        free(idx);
        free(remap);
        return hz_err_set(err, HZ_ERR_MEMORY, "hull: out of memory");
    }
    meshopt_remapIndexBuffer(out->idx, idx, ni, remap);
    meshopt_remapVertexBuffer(out->pos, in->pos, in->vertex_count, 3 * sizeof(float), remap);
    out->vertex_count = (uint32_t)nv;
    out->index_count = (uint32_t)ni;
    for (size_t k = 0; k < ni; k += 3) {
        const uint32_t *ix = &out->idx[k];
        float e1[3], e2[3], n[3];
        v3_sub(e1, &out->pos[ix[1] * 3], &out->pos[ix[0] * 3]);
        v3_sub(e2, &out->pos[ix[2] * 3], &out->pos[ix[0] * 3]);
        v3_cross(n, e1, e2);
        for (int c = 0; c < 3; c++)
            v3_add(&out->nrm[ix[c] * 3], &out->nrm[ix[c] * 3], n);
    }
    for (size_t v = 0; v < nv; v++) {
        v3_norm(&out->nrm[v * 3]);
        if (!isfinite(out->nrm[v * 3]))
            v3_set(&out->nrm[v * 3], 0, 1, 0);
    }
    free(idx);
    free(remap);
    return HZ_OK;
}
