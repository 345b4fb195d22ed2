/* CPU occlusion buffer (SPEC G4): conservative coarse depth of the big
 * occluders; see occlusion.h. */
#include "horizon/occlusion.h"

#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

bool hz_occlusion_init(hz_occlusion *o, uint32_t w, uint32_t h)
{
    *o = (hz_occlusion){.w = w ? (w > 1024 ? 1024 : w) : 256, .h = h ? h : 144};
    o->depth = malloc((size_t)o->w * o->h * sizeof *o->depth);
    return o->depth != NULL;
}

static void samples_free(hz_occlusion *o)
{
    free(o->col_px);
    free(o->row_px);
    free(o->col_of);
    free(o->row_of);
    free(o->mask);
    free(o->zpart);
    o->col_px = o->row_px = o->col_of = o->row_of = NULL;
    o->mask = NULL;
    o->zpart = NULL;
    o->px_w = o->px_h = 0;
}

void hz_occlusion_free(hz_occlusion *o)
{
    free(o->depth);
    o->depth = NULL;
    samples_free(o);
}

/* The first pixel of each of n cells over px pixels (first[n] = px): the
 * first whose centre is at or right of the cell's left side, i.e. the least
 * p with (2p + 1) n >= 2 i px; and the cell of each pixel's centre. false
 * when a cell would span more than 8. */
static bool first_pixels(uint32_t *first, uint32_t *cell, uint32_t n, uint32_t px)
{
    for (uint64_t i = 0; i <= n; i++) {
        const uint64_t num = 2 * i * px; /* (2p + 1) n >= num */
        first[i] = num <= n ? 0 : (uint32_t)((num - n + 2 * (uint64_t)n - 1) / (2 * (uint64_t)n));
        if (i && first[i] - first[i - 1] > 8)
            return false;
        if (i)
            for (uint32_t p = first[i - 1]; p < first[i]; p++)
                cell[p] = (uint32_t)i - 1;
    }
    return true;
}

bool hz_occlusion_set_viewport(hz_occlusion *o, uint32_t px_w, uint32_t px_h)
{
    if (px_w == o->px_w && px_h == o->px_h)
        return o->mask != NULL;
    samples_free(o);
    if (!px_w || !px_h || !o->depth || px_w > 8 * o->w || px_h > 8 * o->h)
        return false;
    const size_t cells = (size_t)o->w * o->h;
    o->col_px = malloc(((size_t)o->w + 1) * sizeof *o->col_px);
    o->row_px = malloc(((size_t)o->h + 1) * sizeof *o->row_px);
    o->col_of = malloc((size_t)px_w * sizeof *o->col_of);
    o->row_of = malloc((size_t)px_h * sizeof *o->row_of);
    o->mask = calloc(cells, sizeof *o->mask);
    o->zpart = malloc(cells * sizeof *o->zpart);
    if (!o->col_px || !o->row_px || !o->col_of || !o->row_of || !o->mask || !o->zpart ||
        !first_pixels(o->col_px, o->col_of, o->w, px_w) || !first_pixels(o->row_px, o->row_of, o->h, px_h)) {
        samples_free(o);
        return false;
    }
    o->px_w = px_w, o->px_h = px_h;
    return true;
}

void hz_occlusion_begin(hz_occlusion *o, const hz_camera *cam)
{
    hz_camera_view(cam, o->view);
    hz_camera_proj(cam, o->proj);
    glm_mat4_mul(o->proj, o->view, o->viewproj);
    o->cam = *cam;
    o->znear = cam->znear > 0 ? cam->znear : 1.0f;
    for (size_t k = 0; k < (size_t)o->w * o->h; k++)
        o->depth[k] = INFINITY;
    if (o->mask)
        memset(o->mask, 0, (size_t)o->w * o->h * sizeof *o->mask);
    o->triangles = o->cells_written = 0;
    o->raster_ms = 0;
}

/* Screen position in cells (x right, y up) and view depth of the clip
 * position c (the projection's w is the depth along the view axis); false
 * when it is nearer than the near plane. */
static bool to_screen(const hz_occlusion *o, const vec4 c, float s[2], float *d)
{
    *d = c[3];
    if (!(*d >= o->znear))
        return false;
    s[0] = (c[0] / c[3] * 0.5f + 0.5f) * (float)o->w;
    s[1] = (c[1] / c[3] * 0.5f + 0.5f) * (float)o->h;
    return true;
}

/* The same for a world point through mvp (projection * view [* model]). */
static bool project(const hz_occlusion *o, const mat4 mvp, const float p[3], float s[2], float *d)
{
    vec4 c;
    glm_mat4_mulv((vec4 *)mvp, (vec4){p[0], p[1], p[2], 1}, c);
    return to_screen(o, c, s, d);
}

/* fminf and fmaxf as inline compares (at -O2 they are calls into libm, and
 * the box test makes tens of them per box): like them, a NaN argument
 * yields the other one. */
static inline float min_f(float a, float b)
{
    return a < b || b != b ? a : b;
}

static inline float max_f(float a, float b)
{
    return a > b || b != b ? a : b;
}

static float edge(const float *a, const float *b, float x, float y)
{
    return (b[0] - a[0]) * (y - a[1]) - (b[1] - a[1]) * (x - a[0]);
}

/* Whether corner point i of a row lies inside every edge (e0 + dx i >= 0). */
static bool inside(const float *e0, const float *dx, int n, long i)
{
    for (int k = 0; k < n; k++)
        if (!(e0[k] + dx[k] * (float)i >= 0))
            return false;
    return true;
}

/* The bits of a cell's pixel centres: nc columns, nr rows. */
static inline uint64_t full_mask(uint32_t nc, uint32_t nr)
{
    const uint64_t rows = nr >= 8 ? ~(uint64_t)0 : ((uint64_t)1 << (8 * nr)) - 1;
    return (((uint64_t)1 << nc) - 1) * (0x0101010101010101ull & rows);
}

/* Cell k takes occluders at depth d covering the pixel centres m of its
 * full set. The partial layer keeps the farthest depth of the occluders
 * whose samples it holds; when they are all covered the cell is. An
 * occluder far behind the layer is left out of it, one far in front
 * replaces it (either is conservative). */
static inline void take_samples(hz_occlusion *o, size_t k, uint64_t m, uint64_t full, float d)
{
    if (!(d < o->depth[k]) || !m)
        return;
    uint64_t om = o->mask[k];
    const float oz = o->zpart[k];
    if (om && !(oz < o->depth[k]))
        om = 0; /* behind the whole-cell depth: worthless */
    if ((m | om) == full) {
        o->depth[k] = m == full ? d : max_f(d, oz);
        o->mask[k] = 0;
        o->cells_written++;
    } else if (!om || oz > 2.0f * d) {
        o->mask[k] = m, o->zpart[k] = d;
    } else if (!(d > 2.0f * oz)) {
        o->mask[k] = om | m, o->zpart[k] = max_f(oz, d);
    }
}

/* min and max for numbers that are not NaN. */
static inline float lesser(float a, float b)
{
    return a < b ? a : b;
}

static inline float greater(float a, float b)
{
    return a > b ? a : b;
}

static inline long floor_l(float x)
{
    const long i = (long)x;
    return i - (x < (float)i);
}

static inline long ceil_l(float x)
{
    const long i = (long)x;
    return i + (x > (float)i);
}

/* A convex polygon's edges: edge k's inside is c + ex x + ey y >= 0, a
 * left bound (ex > 0) or a right one (ex < 0) at x = a + xb y. */
typedef struct edge_lines {
    float ex[4], ey[4], xb[4];
} edge_lines;

/* Narrows [lo, hi] to the polygon's x interval at height y, with the edges'
 * constants c and a (with or without a margin); false when a horizontal
 * edge leaves y outside. */
static inline bool span_at(const float *c, const float *a, const edge_lines *l, int n, float y, float *lo, float *hi)
{
    for (int k = 0; k < n; k++) {
        const float x = a[k] + l->xb[k] * y;
        if (l->ex[k] > 0)
            *lo = greater(*lo, x);
        else if (l->ex[k] < 0)
            *hi = lesser(*hi, x);
        else if (c[k] + l->ey[k] * y < 0)
            return false;
    }
    return *lo <= *hi;
}

/* The pixel centres a convex polygon covers (s in cells, sg its winding's
 * sign), taken into the cells it does not already cover at depth dmax. A
 * centre is covered at least 1/16 pixel inside every edge. Per row of
 * pixels, the centres inside form an interval: each edge bounds it from one
 * side at x = a + b y. Within 16 384 pixels of the image's corner float
 * moves the edges by under 1/200 pixel (normal to them), well inside the
 * margin; false, nothing done, for a polygon reaching farther. */
static bool raster_samples(hz_occlusion *o, float s[][2], int n, float sg, float dmax)
{
    const float sx = (float)o->px_w / (float)o->w, sy = (float)o->px_h / (float)o->h;
    float p[4][2], x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
    for (int k = 0; k < n; k++) {
        p[k][0] = s[k][0] * sx, p[k][1] = s[k][1] * sy;
        if (!(fabsf(p[k][0]) < 16384.0f && fabsf(p[k][1]) < 16384.0f))
            return false; /* far off screen, or not a number */
        x0 = lesser(x0, p[k][0]);
        x1 = greater(x1, p[k][0]);
        y0 = lesser(y0, p[k][1]);
        y1 = greater(y1, p[k][1]);
    }
    /* Pixel rows and columns whose centres lie in the polygon's box. */
    const long py0 = ceil_l(greater(y0 - 0.5f, 0)), py1 = floor_l(lesser(y1 - 0.5f, (float)o->px_h - 1));
    if (py0 > py1 || ceil_l(greater(x0 - 0.5f, 0)) > floor_l(lesser(x1 - 0.5f, (float)o->px_w - 1)))
        return true;
    /* Edge k inside: ec + ex x + ey y >= 0, the margin taken off ec:
     * (|ex| + |ey|) / 16 is at least 1/16 pixel, as the edge's length is
     * at most |ex| + |ey|. A left (ex > 0) or right (ex < 0) bound at
     * x = xa + xb y. */
    float er[4], ec[4], xa[4], xr[4]; /* er, xr: ec, xa of the edge itself, no margin */
    edge_lines lines;
    float *ex = lines.ex, *ey = lines.ey, *xb = lines.xb;
    for (int k = 0; k < n; k++) {
        const float *a = p[k], *b = p[(k + 1) % n];
        ex[k] = -sg * (b[1] - a[1]);
        ey[k] = sg * (b[0] - a[0]);
        er[k] = -ex[k] * a[0] - ey[k] * a[1];
        const float inv = ex[k] != 0 ? -1.0f / ex[k] : 0;
        ec[k] = er[k] - (fabsf(ex[k]) + fabsf(ey[k])) * (1.0f / 16.0f);
        xa[k] = ec[k] * inv;
        xr[k] = er[k] * inv;
        xb[k] = ey[k] * inv;
    }
    for (long r = o->row_of[py0]; r < (long)o->h && o->row_px[r] <= (uint32_t)py1; r++) {
        const uint32_t first = o->row_px[r], nr = o->row_px[r + 1] - first;
        {
            /* The polygon's x extent over the row's centres [ya, yb]: its
             * left side's least x is at an end or at a vertex between (the
             * left side is the greatest of the left edges' lines, a convex
             * function of y), its right side's greatest x likewise. No pixel
             * of it left or right of that; nothing to do in the row when
             * the cells between are all covered as near. */
            const float ya = greater((float)first + 0.5f, y0), yb = lesser((float)(first + nr) - 0.5f, y1);
            if (!(ya <= yb))
                continue;
            float xl = INFINITY, xh = -INFINITY;
            for (int k = 0; k < n; k++) {
                if (p[k][1] >= ya && p[k][1] <= yb) {
                    xl = lesser(xl, p[k][0]);
                    xh = greater(xh, p[k][0]);
                }
            }
            for (int e = 0; e < 2; e++) {
                float lo = -INFINITY, hi = INFINITY;
                if (span_at(er, xr, &lines, n, e ? yb : ya, &lo, &hi)) {
                    xl = lesser(xl, lo);
                    xh = greater(xh, hi);
                }
            }
            const long qa = ceil_l(greater(xl - 0.5f, 0)), qb = floor_l(lesser(xh - 0.5f, (float)o->px_w - 1));
            if (qa > qb)
                continue;
            const float *row = &o->depth[(size_t)r * o->w];
            const long ca = o->col_of[qa], cb = o->col_of[qb];
            long c = ca;
            while (c <= cb && !(dmax < row[c]))
                c++;
            if (c > cb)
                continue;
        }
        long lo_px[8], hi_px[8], lo_all = LONG_MAX, hi_all = -1;
        for (uint32_t t = 0; t < nr; t++) {
            lo_px[t] = 0, hi_px[t] = -1;
            const long py = (long)(first + t);
            if (py < py0 || py > py1)
                continue;
            const float y = (float)py + 0.5f;
            float lo = 0.5f, hi = (float)o->px_w - 0.5f;
            if (!span_at(ec, xa, &lines, n, y, &lo, &hi))
                continue;
            const long c0 = ceil_l(lo - 0.5f), c1 = floor_l(hi - 0.5f);
            if (c0 > c1)
                continue;
            lo_px[t] = c0, hi_px[t] = c1;
            lo_all = c0 < lo_all ? c0 : lo_all;
            hi_all = c1 > hi_all ? c1 : hi_all;
        }
        if (hi_all < 0)
            continue;
        /* The cells whose pixels every row covers (from the first column
         * at or right of all rows' starts to the last at or left of all
         * rows' ends) are whole; the others in [lo_all, hi_all] take masks. */
        long lo_max = lo_px[0], hi_min = hi_px[0];
        for (uint32_t t = 1; t < nr; t++) {
            lo_max = lo_px[t] > lo_max ? lo_px[t] : lo_max;
            hi_min = hi_px[t] < hi_min ? hi_px[t] : hi_min;
        }
        float *row = &o->depth[(size_t)r * o->w];
        const long ce = o->col_of[hi_all];
        for (long c = o->col_of[lo_all]; c <= ce; c++) {
            const long cf = o->col_px[c], cl = o->col_px[c + 1] - 1;
            if (!(dmax < row[c]))
                continue; /* covered at least as near */
            if (cf >= lo_max && cl <= hi_min && lo_max <= hi_min) {
                row[c] = dmax;
                o->cells_written++;
                continue;
            }
            /* Whole too when its four corners are inside (a centre may lie
             * on the cell's side when the cells are not whole pixels). */
            const float cx0 = (float)c * sx, cx1 = (float)(c + 1) * sx;
            const float cy0 = (float)r * sy, cy1 = (float)(r + 1) * sy;
            if (cx0 >= x0 && cx1 <= x1 && cy0 >= y0 && cy1 <= y1) {
                bool in = true;
                for (int k = 0; k < n && in; k++)
                    in = er[k] + ex[k] * cx0 + ey[k] * cy0 >= 0 && er[k] + ex[k] * cx1 + ey[k] * cy0 >= 0 &&
                         er[k] + ex[k] * cx0 + ey[k] * cy1 >= 0 && er[k] + ex[k] * cx1 + ey[k] * cy1 >= 0;
                if (in) {
                    row[c] = dmax;
                    o->cells_written++;
                    continue;
                }
            }
            uint64_t m = 0;
            for (uint32_t t = 0; t < nr; t++) {
                const long a = lo_px[t] > cf ? lo_px[t] : cf, b = hi_px[t] < cl ? hi_px[t] : cl;
                if (a <= b)
                    m |= ((((uint64_t)1 << (b - a + 1)) - 1) << (a - cf)) << (8 * t);
            }
            take_samples(o, (size_t)r * o->w + (size_t)c, m, full_mask((uint32_t)(cl - cf + 1), nr), dmax);
        }
    }
    return true;
}

/* A convex screen polygon of n <= 4 vertices (either winding) at depth dmax. */
static void raster_convex(hz_occlusion *o, float s[][2], int n, float dmax)
{
    float area = 0;
    for (int k = 0; k < n; k++)
        area += s[k][0] * s[(k + 1) % n][1] - s[(k + 1) % n][0] * s[k][1];
    if (fabsf(area) < 1e-6f || (o->cull_back && area < 0))
        return; /* edge-on, or a back face (screen y is up: front faces turn counter-clockwise) */
    o->triangles++;
    const float sg = area > 0 ? 1.0f : -1.0f;
    float x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
    for (int k = 0; k < n; k++) {
        x0 = min_f(x0, s[k][0]);
        x1 = max_f(x1, s[k][0]);
        y0 = min_f(y0, s[k][1]);
        y1 = max_f(y1, s[k][1]);
    }
    /* Cells whose four corners (integer points) are all inside. Along a row
     * of corner points the inside is an interval (the polygon is convex):
     * each edge bounds it from one side, and its ends are checked with the
     * edge functions, so no point is taken that the test of every point
     * would refuse. A cell is covered where its row's and the next row's
     * intervals both hold its two corners: one span per row of cells, and
     * no work per cell outside the polygon. */
    if (o->mask && raster_samples(o, s, n, sg, dmax))
        return; /* it takes every whole cell the corners would, and more */
    const long i0 = (long)ceilf(max_f(x0, 0)), i1 = (long)floorf(min_f(x1, (float)o->w));
    const long j0 = (long)ceilf(max_f(y0, 0)), j1 = (long)floorf(min_f(y1, (float)o->h));
    if (i0 >= i1 || j0 >= j1)
        return;
    float e0[4], dx[4];
    long plo = 0, phi = -1; /* the previous row's interval of inside points */
    for (long j = j0; j <= j1; j++) {
        float lo = (float)i0, hi = (float)i1;
        for (int k = 0; k < n; k++) {
            const float *a = s[k], *b = s[(k + 1) % n];
            e0[k] = sg * edge(a, b, 0.0f, (float)j);
            dx[k] = -sg * (b[1] - a[1]); /* d(edge)/dx */
            if (dx[k] > 0)
                lo = max_f(lo, -e0[k] / dx[k]);
            else if (dx[k] < 0)
                hi = min_f(hi, -e0[k] / dx[k]);
            else if (e0[k] < 0)
                lo = hi + 1; /* parallel to the row, outside */
        }
        long clo = (long)ceilf(lo), chi = (long)floorf(hi);
        /* The division rounds: the ends are settled with the edge functions
         * (an end point outside moves inward). */
        while (clo <= chi && !inside(e0, dx, n, clo))
            clo++;
        while (chi >= clo && !inside(e0, dx, n, chi))
            chi--;
        if (j > j0) {
            const long c0 = clo > plo ? clo : plo, c1 = (chi < phi ? chi : phi) - 1;
            float *row = &o->depth[(size_t)(j - 1) * o->w];
            for (long i = c0; i <= c1; i++)
                if (dmax < row[i]) {
                    row[i] = dmax;
                    o->cells_written++;
                }
        }
        plo = clo, phi = chi;
    }
}

static bool convex4(float s[4][2])
{
    float sg = 0;
    for (int k = 0; k < 4; k++) {
        float e = edge(s[k], s[(k + 1) % 4], s[(k + 2) % 4][0], s[(k + 2) % 4][1]);
        if (e == 0 || (sg != 0 && (e > 0) != (sg > 0)))
            return false;
        sg = e;
    }
    return true;
}

/* n = 3 (triangles) or 4 (quads: as one convex polygon when its screen
 * projection is convex, so the diagonal leaves no uncovered cells). */
static void rasterize_n(hz_occlusion *o, const float *v, size_t count, const mat4 model, int n)
{
    double t0 = hz_time_ms();
    mat4 mvp;
    const bool curved = o->cam.earth_radius != 0.0f;
    if (model && !curved)
        glm_mat4_mul(o->viewproj, (vec4 *)model, mvp);
    else
        glm_mat4_copy(o->viewproj, mvp);
    for (size_t t = 0; t < count; t++) {
        float s[4][2], d[4];
        bool ok = true;
        for (int k = 0; k < n && ok; k++) {
            const float *p = v + (size_t)(3 * n) * t + 3 * k;
            float w[3] = {p[0], p[1], p[2]};
            if (curved) {
                /* World, then lowered by the Earth curvature, as the vertex shaders do. */
                if (model) {
                    vec4 q;
                    glm_mat4_mulv((vec4 *)model, (vec4){p[0], p[1], p[2], 1}, q);
                    w[0] = q[0], w[1] = q[1], w[2] = q[2];
                }
                w[1] -= hz_camera_drop(&o->cam, w[0], w[2]);
            }
            ok = project(o, mvp, w, s[k], &d[k]);
        }
        if (!ok)
            continue;
        float dmax = d[0];
        for (int k = 1; k < n; k++)
            dmax = max_f(dmax, d[k]);
        if (n == 3 || convex4(s)) {
            raster_convex(o, s, n, dmax);
        } else {
            /* The quad's own two triangles, split along v1-v3. */
            float a[3][2] = {{s[0][0], s[0][1]}, {s[1][0], s[1][1]}, {s[3][0], s[3][1]}};
            float b[3][2] = {{s[1][0], s[1][1]}, {s[2][0], s[2][1]}, {s[3][0], s[3][1]}};
            raster_convex(o, a, 3, max_f(d[0], max_f(d[1], d[3])));
            raster_convex(o, b, 3, max_f(d[1], max_f(d[2], d[3])));
        }
    }
    o->raster_ms += hz_time_ms() - t0;
}

void hz_occlusion_rasterize(hz_occlusion *o, const float *tri, size_t count, const mat4 model)
{
    rasterize_n(o, tri, count, model, 3);
}

void hz_occlusion_rasterize_quads(hz_occlusion *o, const float *quad, size_t count, const mat4 model)
{
    rasterize_n(o, quad, count, model, 4);
}

bool hz_occlusion_merge(hz_occlusion *o, const hz_occlusion *src)
{
    if (o->w != src->w || o->h != src->h)
        return false;
    for (size_t k = 0; k < (size_t)o->w * o->h; k++)
        o->depth[k] = min_f(o->depth[k], src->depth[k]);
    if (o->mask && src->mask && o->px_w == src->px_w && o->px_h == src->px_h)
        for (uint32_t r = 0; r < o->h; r++)
            for (uint32_t c = 0; c < o->w; c++) {
                const size_t k = (size_t)r * o->w + c;
                if (src->mask[k] && src->zpart[k] < src->depth[k])
                    take_samples(o, k, src->mask[k],
                                 full_mask(o->col_px[c + 1] - o->col_px[c], o->row_px[r + 1] - o->row_px[r]),
                                 src->zpart[k]);
            }
    o->triangles += src->triangles;
    o->cells_written += src->cells_written;
    o->raster_ms += src->raster_ms;
    return true;
}

/* True when every cell the screen rectangle [x0, x1] x [y0, y1] (cell units,
 * clamped to the buffer) touches holds an occluder nearer than d; false when
 * none of it is on screen. */
static bool cells_nearer(const hz_occlusion *o, float x0, float y0, float x1, float y1, float d)
{
    const long i0 = (long)floorf(max_f(x0, 0)), i1 = (long)floorf(min_f(x1, (float)o->w - 0.5f));
    const long j0 = (long)floorf(max_f(y0, 0)), j1 = (long)floorf(min_f(y1, (float)o->h - 0.5f));
    if (i0 > i1 || j0 > j1)
        return false;
    for (long j = j0; j <= j1; j++)
        for (long i = i0; i <= i1; i++)
            if (!(o->depth[(size_t)j * o->w + (size_t)i] < d))
                return false;
    return true;
}

bool hz_occlusion_box_hidden(const hz_occlusion *o, const hz_box *b)
{
    if (hz_box_is_empty(b))
        return false;
    float cb[2][3] = {{b->min[0], b->min[1], b->min[2]}, {b->max[0], b->max[1], b->max[2]}};
    hz_camera_curve_box(&o->cam, cb); /* holds the object as drawn */
    /* The corners' clip positions: the min corner's plus the box's edges
     * along x, y and z in clip space. */
    vec4 c0, e[3];
    glm_mat4_mulv((vec4 *)o->viewproj, (vec4){cb[0][0], cb[0][1], cb[0][2], 1}, c0);
    for (int a = 0; a < 3; a++)
        glm_vec4_scale((float *)o->viewproj[a], cb[1][a] - cb[0][a], e[a]);
    float x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY, near = INFINITY;
    for (int k = 0; k < 8; k++) {
        vec4 c;
        glm_vec4_copy(c0, c);
        for (int a = 0; a < 3; a++)
            if (k & (1 << a))
                glm_vec4_add(c, e[a], c);
        float s[2], d;
        if (!to_screen(o, c, s, &d))
            return false; /* reaches the eye's side of the near plane */
        x0 = min_f(x0, s[0]);
        x1 = max_f(x1, s[0]);
        y0 = min_f(y0, s[1]);
        y1 = max_f(y1, s[1]);
        near = min_f(near, d);
    }
    return cells_nearer(o, x0, y0, x1, y1, near); /* false off screen: the frustum's business */
}

bool hz_occlusion_rect_covered(const hz_occlusion *o, float x0, float y0, float x1, float y1)
{
    if (!(x0 >= -1.0f && x1 <= 1.0f && y0 >= -1.0f && y1 <= 1.0f && x0 <= x1 && y0 <= y1))
        return false;
    const float w = (float)o->w, h = (float)o->h;
    return cells_nearer(o, (x0 * 0.5f + 0.5f) * w, (y0 * 0.5f + 0.5f) * h, (x1 * 0.5f + 0.5f) * w,
                        (y1 * 0.5f + 0.5f) * h, INFINITY);
}
