#include "horizon/metrics.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* The k-th smallest of v[0..n) (v is reordered): Hoare's selection with a
 * median-of-three pivot, O(n) on average. Per-frame sample counts reach
 * millions, where a full sort dominated the bench. */
static float select_kth(float *v, size_t n, size_t k)
{
    size_t lo = 0, hi = n - 1;
    while (lo < hi) {
        const size_t mid = lo + (hi - lo) / 2;
        float a = v[lo], b = v[mid], c = v[hi];
        float pivot = a < b ? (b < c ? b : (a < c ? c : a)) : (a < c ? a : (b < c ? c : b));
        size_t i = lo, j = hi;
        while (i <= j) {
            while (v[i] < pivot)
                i++;
            while (v[j] > pivot)
                j--;
            if (i <= j) {
                float t = v[i];
                v[i] = v[j];
                v[j] = t;
                i++;
                if (j == 0)
                    break;
                j--;
            }
        }
        if (k <= j)
            hi = j;
        else if (k >= i)
            lo = i;
        else
            return v[k];
    }
    return v[k];
}

hz_result hz_metrics_px_error(const hz_heightmap *hm, float spacing, float zscale,
                              const uint32_t *indices, size_t count, const hz_camera *cam,
                              uint32_t image_height, hz_float_buf *scratch, hz_px_error *out)
{
    return hz_metrics_px_error_ex(hm, spacing, zscale, indices, count, NULL, NULL, cam, image_height, scratch, out);
}

void hz_float_buf_free(hz_float_buf *buf)
{
    free(buf->data);
    free(buf->surface);
    *buf = (hz_float_buf){0};
}

static bool in_frustum(const vec4 planes[6], double x, double y, double z)
{
    for (int p = 0; p < 6; p++)
        if (planes[p][0] * x + planes[p][1] * y + planes[p][2] * z + planes[p][3] < 0)
            return false;
    return true;
}

hz_result hz_metrics_px_error_ex(const hz_heightmap *hm, float spacing, float zscale, const uint32_t *indices,
                                 size_t count, hz_vertex_height_fn vertex_height, void *user, const hz_camera *cam,
                                 uint32_t image_height, hz_float_buf *scratch, hz_px_error *out)
{
    memset(out, 0, sizeof *out);
    const uint32_t n = hm->size;
    const size_t ns = (size_t)n * n;
    vec4 planes[6];
    hz_camera_frustum(cam, planes);
    const double k = (double)image_height / (2.0 * tan(glm_rad(cam->fov_y > 0 ? cam->fov_y : 60.0f) * 0.5));
    if (scratch->surface_cap < ns) {
        float *p = realloc(scratch->surface, ns * sizeof *p);
        if (!p)
            return HZ_ERR_MEMORY;
        scratch->surface = p;
        scratch->surface_cap = ns;
    }
    /* The drawn surface at every sample (a sample on a shared edge gets the
     * same height from both triangles), then every sample in the frustum. */
    hz_metrics_surface(hm, zscale, indices, count, vertex_height, user, scratch->surface);
    scratch->count = 0;
    for (uint32_t z = 0; z < n; z++)
        for (uint32_t x = 0; x < n; x++) {
            const double true_h = hz_heightmap_get(hm, x, z);
            const double wx = (double)x * spacing, wz = (double)z * spacing, wy = true_h * zscale;
            /* Where the sample is drawn: lowered by the Earth curvature (the
             * LOD surface and the true one drop alike, so dh is unchanged). */
            const double wy_drawn = wy - hz_camera_drop(cam, (float)wx, (float)wz);
            if (!in_frustum((const vec4 *)planes, wx, wy_drawn, wz))
                continue;
            const float lod_h = scratch->surface[(size_t)z * n + x];
            if (isnan(lod_h)) {
                out->uncovered++; /* a hole, or a culled node whose samples are in the frustum */
                continue;
            }
            const double dx = wx - cam->pos[0], dy = wy_drawn - cam->pos[1], dz = wz - cam->pos[2];
            const double dist = sqrt(dx * dx + dy * dy + dz * dz);
            const double dh = fabs((double)lod_h - wy);
            const double px = dist > 1e-6 ? dh * k / dist : (dh > 0 ? INFINITY : 0);
            if (scratch->count == scratch->cap) {
                size_t nc = scratch->cap ? scratch->cap * 2 : 1 << 16;
                float *p2 = realloc(scratch->data, nc * sizeof *p2);
                if (!p2)
                    return HZ_ERR_MEMORY;
                scratch->data = p2;
                scratch->cap = nc;
            }
            scratch->data[scratch->count++] = (float)px;
            out->max_px = px > out->max_px ? px : out->max_px;
            out->max_m = dh > out->max_m ? dh : out->max_m;
        }
    out->samples = scratch->count;
    if (scratch->count) {
        size_t kth = (size_t)floor(0.99 * (double)(scratch->count - 1));
        out->p99_px = select_kth(scratch->data, scratch->count, kth);
    }
    return HZ_OK;
}

double hz_metrics_psnr(const uint8_t *a, const uint8_t *b, size_t n)
{
    double se = 0;
    for (size_t i = 0; i < 3 * n; i++) {
        double d = (double)a[i] - (double)b[i];
        se += d * d;
    }
    if (se == 0)
        return INFINITY;
    double mse = se / (3.0 * (double)n);
    return 10.0 * log10(255.0 * 255.0 / mse);
}

double hz_metrics_popping(const uint8_t *a0, const uint8_t *a1, const uint8_t *b0,
                          const uint8_t *b1, size_t n)
{
    double s = 0;
    for (size_t i = 0; i < 3 * n; i++) {
        int da = (int)a1[i] - (int)a0[i], db = (int)b1[i] - (int)b0[i];
        s += abs(da - db);
    }
    return n ? s / (3.0 * (double)n) : 0;
}

double hz_metrics_silhouette(const uint8_t *sky_a, const uint8_t *sky_b, size_t n)
{
    size_t d = 0;
    for (size_t i = 0; i < n; i++)
        d += (sky_a[i] != 0) != (sky_b[i] != 0);
    return n ? (double)d / (double)n : 0;
}

hz_result hz_metrics_surface(const hz_heightmap *hm, float zscale, const uint32_t *indices, size_t count,
                             hz_vertex_height_fn vertex_height, void *user, float *out)
{
    const uint32_t n = hm->size;
    for (size_t i = 0; i < (size_t)n * n; i++)
        out[i] = NAN;
    for (size_t t = 0; t + 2 < count; t += 3) {
        int64_t xs[3], zs[3];
        double hs[3];
        for (int c = 0; c < 3; c++) {
            const uint32_t v = indices[t + c];
            xs[c] = v % n;
            zs[c] = v / n;
            hs[c] = vertex_height ? (double)vertex_height(user, v)
                                  : (double)hz_heightmap_get(hm, (uint32_t)xs[c], (uint32_t)zs[c]) * zscale;
        }
        const int64_t area2 = (zs[1] - zs[0]) * (xs[2] - xs[0]) - (xs[1] - xs[0]) * (zs[2] - zs[0]);
        if (area2 == 0)
            continue;
        int64_t x0 = xs[0], x1 = xs[0], z0 = zs[0], z1 = zs[0];
        for (int c = 1; c < 3; c++) {
            x0 = xs[c] < x0 ? xs[c] : x0;
            x1 = xs[c] > x1 ? xs[c] : x1;
            z0 = zs[c] < z0 ? zs[c] : z0;
            z1 = zs[c] > z1 ? zs[c] : z1;
        }
        const double a = (double)llabs(area2);
        for (int64_t z = z0; z <= z1; z++)
            for (int64_t x = x0; x <= x1; x++) {
                int64_t w0 = (zs[2] - zs[1]) * (x - xs[1]) - (xs[2] - xs[1]) * (z - zs[1]);
                int64_t w1 = (zs[0] - zs[2]) * (x - xs[2]) - (xs[0] - xs[2]) * (z - zs[2]);
                int64_t w2 = (zs[1] - zs[0]) * (x - xs[0]) - (xs[1] - xs[0]) * (z - zs[0]);
                if (area2 < 0) {
                    w0 = -w0;
                    w1 = -w1;
                    w2 = -w2;
                }
                if (w0 < 0 || w1 < 0 || w2 < 0)
                    continue;
                out[(size_t)z * n + (size_t)x] =
                    (float)(((double)w0 * hs[0] + (double)w1 * hs[1] + (double)w2 * hs[2]) / a);
            }
    }
    return HZ_OK;
}

void hz_metrics_surface_change(const hz_heightmap *hm, float spacing, float zscale, const float *prev,
                               const float *cur, const hz_camera *cam, uint32_t image_height, hz_pop_stats *out)
{
    memset(out, 0, sizeof *out);
    const uint32_t n = hm->size;
    vec4 planes[6];
    hz_camera_frustum(cam, planes);
    const double k = (double)image_height / (2.0 * tan(glm_rad(cam->fov_y > 0 ? cam->fov_y : 60.0f) * 0.5));
    double sum = 0;
    for (uint32_t z = 0; z < n; z++)
        for (uint32_t x = 0; x < n; x++) {
            const size_t i = (size_t)z * n + x;
            if (isnan(prev[i]) || isnan(cur[i]))
                continue;
            const double wx = (double)x * spacing, wz = (double)z * spacing,
                         wy = (double)hz_heightmap_get(hm, x, z) * zscale -
                              hz_camera_drop(cam, (float)wx, (float)wz); /* as drawn */
            if (!in_frustum((const vec4 *)planes, wx, wy, wz))
                continue;
            const double dx = wx - cam->pos[0], dy = wy - cam->pos[1], dz = wz - cam->pos[2];
            const double dist = sqrt(dx * dx + dy * dy + dz * dz);
            const double dh = fabs((double)cur[i] - (double)prev[i]);
            const double px = dist > 1e-6 ? dh * k / dist : 0.0;
            sum += px;
            out->max_px = px > out->max_px ? px : out->max_px;
            out->samples++;
        }
    out->mean_px = out->samples ? sum / (double)out->samples : 0.0;
}
