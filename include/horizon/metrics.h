/* horizon metrics: exact screen-space error of a LOD mesh against the
 * full-resolution heightmap, and image comparisons. No GL. */
#ifndef HORIZON_METRICS_H
#define HORIZON_METRICS_H

#include "horizon/camera.h"
#include "horizon/heightmap.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct hz_px_error {
    double max_px;        /* largest projected error of any sample in the frustum */
    double p99_px;        /* 99th percentile over samples in the frustum */
    double max_m;         /* largest vertical error in metres (after zscale) */
    uint64_t samples;     /* samples inside the frustum that the mesh covers */
    uint64_t uncovered;   /* samples inside the frustum with no triangle over them */
} hz_px_error;

/* For every heightmap sample inside the camera frustum: the LOD surface height
 * at its (x, z) (barycentric interpolation in the mesh triangle that covers it)
 * minus the true height, projected to pixels at the sample's distance:
 * h_px = |dh| * image_height / (2 * dist * tan(fov_y / 2)).
 * indices: triangles into the row-major sample grid (index = j * size + i).
 * scratch is grown as needed (free it with hz_float_buf_free); may not be NULL. */
typedef struct hz_float_buf {
    float *data;       /* per-sample errors */
    size_t count, cap;
    float *surface;    /* the drawn surface, size*size */
    size_t surface_cap;
} hz_float_buf;
void hz_float_buf_free(hz_float_buf *buf);

hz_result hz_metrics_px_error(const hz_heightmap *hm, float spacing, float zscale,
                              const uint32_t *indices, size_t count, const hz_camera *cam,
                              uint32_t image_height, hz_float_buf *scratch, hz_px_error *out);

/* The same, for a mesh whose vertices are not at the true heights (cdlod's
 * geomorphing): vertex_height(user, index) gives the height in metres, zscale
 * applied, of sample index j * size + i as drawn. NULL = the true heights. */
typedef float (*hz_vertex_height_fn)(void *user, uint32_t index);
hz_result hz_metrics_px_error_ex(const hz_heightmap *hm, float spacing, float zscale, const uint32_t *indices,
                                 size_t count, hz_vertex_height_fn vertex_height, void *user, const hz_camera *cam,
                                 uint32_t image_height, hz_float_buf *scratch, hz_px_error *out);

/* The drawn surface's height (metres, zscale applied) at every sample, NAN
 * where no triangle covers it; out holds size*size floats. vertex_height as
 * above (NULL = true heights). */
hz_result hz_metrics_surface(const hz_heightmap *hm, float zscale, const uint32_t *indices, size_t count,
                             hz_vertex_height_fn vertex_height, void *user, float *out);

/* Geometric popping: how much the drawn surface moved between two frames
 * (hz_metrics_surface of each), at the samples inside cam's frustum that both
 * cover, projected to pixels at cam: |cur - prev| * H / (2 dist tan(fov/2)).
 * The full-resolution reference never moves, so all of it is LOD change. */
typedef struct hz_pop_stats {
    double max_px, mean_px;
    uint64_t samples;
} hz_pop_stats;
void hz_metrics_surface_change(const hz_heightmap *hm, float spacing, float zscale, const float *prev,
                               const float *cur, const hz_camera *cam, uint32_t image_height, hz_pop_stats *out);

/* PSNR in dB of two RGB8 images of n pixels (INFINITY when identical). */
double hz_metrics_psnr(const uint8_t *a, const uint8_t *b, size_t n);

/* Mean over pixels and channels of |(a1 - a0) - (b1 - b0)| in 0..255 units:
 * the frame-to-frame change of a that b does not have (popping). */
double hz_metrics_popping(const uint8_t *a0, const uint8_t *a1, const uint8_t *b0,
                          const uint8_t *b1, size_t n);

/* Fraction of pixels that are sky in one image and not in the other; sky is
 * given as a per-pixel mask (1 = sky). */
double hz_metrics_silhouette(const uint8_t *sky_a, const uint8_t *sky_b, size_t n);

#ifdef __cplusplus
}
#endif
#endif
