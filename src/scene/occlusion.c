/* CPU occlusion buffer (SPEC G4): conservative coarse depth of the big
 * occluders; see occlusion.h. */
#include "horizon/occlusion.h"

#include <math.h>
#include <stdlib.h>

bool hz_occlusion_init(hz_occlusion *o, uint32_t w, uint32_t h)
{
    *o = (hz_occlusion){.w = w ? (w > 1024 ? 1024 : w) : 256, .h = h ? h : 144};
    o->depth = malloc((size_t)o->w * o->h * sizeof *o->depth);
    return o->depth != NULL;
}

void hz_occlusion_free(hz_occlusion *o)
{
    free(o->depth);
    o->depth = NULL;
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
