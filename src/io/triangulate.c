#define _GNU_SOURCE
/* Polygon triangulation for city faces: ear clipping on the polygon's plane,
 * holes bridged into the outer ring first. Written here because Debian has
 * no C library for it (earcut is C++ only there and GLU's tessellator drags
 * libGL into CPU code). O(n^2) per polygon: building faces have a few to a
 * few hundred vertices. */
#include "horizon/city.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct pnode {
    double x, y;
    uint32_t idx;            /* into the caller's points */
    uint32_t prev, next;
} pnode;

static double cross3(const pnode *a, const pnode *b, const pnode *c)
{
    return (b->x - a->x) * (c->y - a->y) - (b->y - a->y) * (c->x - a->x);
}

static bool same_pos(const pnode *a, const pnode *b)
{
    return a->x == b->x && a->y == b->y;
}

/* p inside or on triangle abc (counter-clockwise). */
static bool in_tri(const pnode *a, const pnode *b, const pnode *c, const pnode *p)
{
    return cross3(a, b, p) >= 0 && cross3(b, c, p) >= 0 && cross3(c, a, p) >= 0;
}

static int sgn(double v)
{
    return (v > 0) - (v < 0);
}

/* Segments ab and cd cross (touching at a shared endpoint does not count). */
static bool seg_cross(const pnode *a, const pnode *b, const pnode *c, const pnode *d)
{
    if (same_pos(a, c) || same_pos(a, d) || same_pos(b, c) || same_pos(b, d))
        return false;
    int o1 = sgn(cross3(a, b, c)), o2 = sgn(cross3(a, b, d));
    int o3 = sgn(cross3(c, d, a)), o4 = sgn(cross3(c, d, b));
    if (o1 != o2 && o3 != o4)
        return true;
    /* Collinear overlaps count as crossing (a bridge along an edge is bad). */
    if (!o1 && !o2 && !o3 && !o4) {
        double lo1 = fmin(a->x, b->x), hi1 = fmax(a->x, b->x), lo2 = fmin(c->x, d->x), hi2 = fmax(c->x, d->x);
        double lo3 = fmin(a->y, b->y), hi3 = fmax(a->y, b->y), lo4 = fmin(c->y, d->y), hi4 = fmax(c->y, d->y);
        return lo1 <= hi2 && lo2 <= hi1 && lo3 <= hi4 && lo4 <= hi3;
    }
    return false;
}

static double ring_area(const pnode *n, uint32_t first, uint32_t count)
{
    double a = 0;
    for (uint32_t k = 0; k < count; k++) {
        const pnode *p = &n[first + k], *q = &n[first + (k + 1) % count];
        a += p->x * q->y - q->x * p->y;
    }
    return 0.5 * a;
}

/* Reverses a ring's links in place (first..first+count-1 as a cycle). */
static void link_ring(pnode *n, uint32_t first, uint32_t count, bool reverse)
{
    for (uint32_t k = 0; k < count; k++) {
        uint32_t i = first + k;
        uint32_t nx = first + (k + 1) % count, pv = first + (k + count - 1) % count;
        n[i].next = reverse ? pv : nx;
        n[i].prev = reverse ? nx : pv;
    }
}

typedef struct hole {
    uint32_t first, count, right; /* right: the vertex with the largest x */
} hole;

static int cmp_hole(const void *pa, const void *pb, void *pn)
{
    const hole *a = pa, *b = pb;
    const pnode *n = pn;
    double xa = n[a->right].x, xb = n[b->right].x;
    return (xa < xb) - (xa > xb); /* largest x first */
}

/* Whether segment m-p crosses an edge of the ring through start or of a hole
 * not yet bridged. */
static bool bridge_blocked(const pnode *n, uint32_t start, const hole *holes, uint32_t h0, uint32_t nh,
                           const pnode *m, const pnode *p)
{
    uint32_t i = start;
    do {
        if (seg_cross(m, p, &n[i], &n[n[i].next]))
            return true;
        i = n[i].next;
    } while (i != start);
    for (uint32_t k = h0; k < nh; k++) {
        uint32_t j = holes[k].first;
        do {
            if (seg_cross(m, p, &n[j], &n[n[j].next]))
                return true;
            j = n[j].next;
        } while (j != holes[k].first);
    }
    return false;
}

int hz_polygon_triangulate(const double *pts, const uint32_t *ring_start, uint32_t ring_count, uint32_t *tris)
{
    if (!ring_count)
        return 0;
    const uint32_t total = ring_start[ring_count] - ring_start[0];
    const uint32_t outer_n = ring_start[1] - ring_start[0];
    if (outer_n < 3)
        return 0;
    /* Newell normal of the outer ring picks the projection plane. */
    double nx = 0, ny = 0, nz = 0;
    for (uint32_t k = 0; k < outer_n; k++) {
        const double *a = pts + 3 * (ring_start[0] + k), *b = pts + 3 * (ring_start[0] + (k + 1) % outer_n);
        nx += (a[1] - b[1]) * (a[2] + b[2]);
        ny += (a[2] - b[2]) * (a[0] + b[0]);
        nz += (a[0] - b[0]) * (a[1] + b[1]);
    }
    int ax = fabs(nx) > fabs(ny) ? (fabs(nx) > fabs(nz) ? 0 : 2) : (fabs(ny) > fabs(nz) ? 1 : 2);
    int u = (ax + 1) % 3, v = (ax + 2) % 3;
    /* Two extra nodes per hole for the bridge's copies. */
    const uint32_t cap = total + 2 * (ring_count - 1);
    pnode *n = malloc((size_t)cap * sizeof *n);
    hole *holes = ring_count > 1 ? malloc((size_t)(ring_count - 1) * sizeof *holes) : NULL;
    if (!n || (ring_count > 1 && !holes)) {
        free(n);
        free(holes);
        return -1;
    }
    /* Project, centred on the first vertex (keeps doubles exact-ish for UTM). */
    const double *o = pts + 3 * ring_start[0];
    for (uint32_t k = 0; k < total; k++) {
        const double *p = pts + 3 * (ring_start[0] + k);
        n[k] = (pnode){p[u] - o[u], p[v] - o[v], ring_start[0] + k, 0, 0};
    }
    double a_out = ring_area(n, 0, outer_n);
    if (a_out < 0) {
        for (uint32_t k = 0; k < total; k++)
            n[k].x = -n[k].x;
        a_out = -a_out;
    }
    if (!(a_out > 0)) {
        free(n);
        free(holes);
        return 0;
    }
    link_ring(n, 0, outer_n, false);
    uint32_t nh = 0, used = total;
    for (uint32_t r = 1; r < ring_count; r++) {
        uint32_t f = ring_start[r] - ring_start[0], c = ring_start[r + 1] - ring_start[r];
        if (c < 3)
            continue;
        double a = ring_area(n, f, c);
        if (a == 0)
            continue;
        link_ring(n, f, c, a > 0); /* holes run clockwise */
        uint32_t right = f;
        for (uint32_t k = f; k < f + c; k++)
            if (n[k].x > n[right].x)
                right = k;
        holes[nh++] = (hole){f, c, right};
    }
    if (nh > 1)
        qsort_r(holes, nh, sizeof *holes, cmp_hole, n);
    uint32_t start = 0;
    for (uint32_t h = 0; h < nh; h++) {
        const uint32_t m = holes[h].right;
        /* The nearest outer vertex the bridge reaches without crossing anything. */
        uint32_t best = UINT32_MAX;
        double best_d = INFINITY;
        uint32_t i = start;
        do {
            double dx = n[i].x - n[m].x, dy = n[i].y - n[m].y, d = dx * dx + dy * dy;
            if (d < best_d && !bridge_blocked(n, start, holes, h + 1, nh, &n[m], &n[i])) {
                /* The bridge must leave p into the polygon's inside (between its edges). */
                best_d = d;
                best = i;
            }
            i = n[i].next;
        } while (i != start);
        if (best == UINT32_MAX)
            continue; /* a hole we cannot reach: left out (it stays filled) */
        /* p -> m -> (hole) -> m' -> p' -> p.next */
        uint32_t p = best, pn = n[p].next, mp = n[m].prev;
        uint32_t m2 = used++, p2 = used++;
        n[m2] = n[m];
        n[p2] = n[p];
        n[p].next = m;
        n[m].prev = p;
        n[mp].next = m2;
        n[m2].prev = mp;
        n[m2].next = p2;
        n[p2].prev = m2;
        n[p2].next = pn;
        n[pn].prev = p2;
    }
    /* Ear clipping. */
    uint32_t left = 0;
    {
        uint32_t i = start;
        do {
            left++;
            i = n[i].next;
        } while (i != start);
    }
    int tri = 0;
    uint32_t cur = start, stall = 0;
    while (left > 3) {
        uint32_t pv = n[cur].prev, nx2 = n[cur].next;
        const pnode *a = &n[pv], *b = &n[cur], *c = &n[nx2];
        double cr = cross3(a, b, c);
        bool ear = false, drop = false;
        if (cr == 0 && stall < left) {
            drop = false; /* collinear: try elsewhere first */
        } else if (cr > 0) {
            ear = true;
            for (uint32_t j = n[nx2].next; j != pv; j = n[j].next)
                if (!same_pos(&n[j], a) && !same_pos(&n[j], b) && !same_pos(&n[j], c) && in_tri(a, b, c, &n[j])) {
                    ear = false;
                    break;
                }
        }
        if (stall >= left) {
            /* A full round without an ear (self-touching or degenerate
             * input): cut the current vertex anyway so the loop ends. */
            ear = cr > 0;
            drop = !ear;
        }
        if (ear || drop) {
            if (ear) {
                tris[3 * tri] = a->idx;
                tris[3 * tri + 1] = b->idx;
                tris[3 * tri + 2] = c->idx;
                tri++;
            }
            n[pv].next = nx2;
            n[nx2].prev = pv;
            left--;
            stall = 0;
            cur = pv;
        } else {
            cur = nx2;
            stall++;
        }
    }
    if (left == 3) {
        uint32_t pv = n[cur].prev, nx2 = n[cur].next;
        if (cross3(&n[pv], &n[cur], &n[nx2]) > 0) {
            tris[3 * tri] = n[pv].idx;
            tris[3 * tri + 1] = n[cur].idx;
            tris[3 * tri + 2] = n[nx2].idx;
            tri++;
        }
    }
    /* Triangles keep the ring's own winding: when x was negated to make the
     * outer ring counter-clockwise, it was clockwise in the plane, and so are
     * the triangles once the mirror is undone. */
    free(n);
    free(holes);
    return tri;
}
