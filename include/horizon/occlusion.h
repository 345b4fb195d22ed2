/* horizon occlusion culling (SPEC G4) on the CPU: the big near occluders
 * (terrain below its surface, building walls) are rasterised into a coarse
 * depth buffer; an object whose screen rectangle lies entirely behind it is
 * hidden. Conservative: a cell holds the farthest depth at which an
 * occluder certainly covers the whole cell, and an object is hidden only
 * when its nearest point is farther than that in every cell it touches.
 * No GL.
 *
 * Depths are view distances along the camera axis, metres. */
#ifndef HORIZON_OCCLUSION_H
#define HORIZON_OCCLUSION_H

#include "horizon/camera.h"
#include "horizon/scene.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct hz_occlusion {
    uint32_t w, h;        /* cells; row 0 = the bottom of the image */
    float *depth;         /* w * h; +inf where no occluder covers the cell */
    mat4 view, proj;      /* the camera's (OpenGL convention) */
    mat4 viewproj;        /* proj * view: clip w is the view depth */
    float znear;
    uint64_t triangles;   /* rasterised (after near-plane rejection) */
    uint64_t cells_written;
    double raster_ms;
    hz_camera cam;        /* of hz_occlusion_begin: its Earth curvature lowers occluders and
                             boxes as the shaders draw them */
    /* Skip the triangles and quads that face away from the camera
     * (clockwise on screen, the back faces of GL_CULL_FACE with GL_CCW
     * fronts). Right for occluders drawn with back faces culled: a back
     * face then hides nothing, and a closed mesh's front faces cover all
     * it covers. false after hz_occlusion_init: both faces occlude. */
    bool cull_back;
} hz_occlusion;

/* Allocates a w x h buffer (0 -> 256 x 144; w at most 1024); false on out of memory. */
bool hz_occlusion_init(hz_occlusion *o, uint32_t w, uint32_t h);
void hz_occlusion_free(hz_occlusion *o);
/* Clears the buffer for a camera. */
void hz_occlusion_begin(hz_occlusion *o, const hz_camera *cam);
/* Rasterises occluder triangles (world positions, 3 vertices each, xyz
 * floats, optionally transformed by model; NULL = identity; counter-clockwise
 * seen from the front). A cell takes a
 * triangle only when all four of its corners are inside it, at the
 * triangle's farthest vertex depth. Triangles crossing the near plane are
 * skipped (conservative). */
void hz_occlusion_rasterize(hz_occlusion *o, const float *tri_xyz, size_t tri_count, const mat4 model);
/* The same for quads: 4 vertices each, in order around, standing for the
 * two triangles (v0, v1, v3) and (v1, v2, v3) that share the diagonal
 * v1-v3. A quad whose screen projection is convex is rasterised as one
 * polygon, so the cells along the diagonal count as covered (each triangle
 * alone would leave them out); otherwise as its two triangles. */
void hz_occlusion_rasterize_quads(hz_occlusion *o, const float *quad_xyz, size_t quad_count, const mat4 model);
/* Takes src's occluders into o: per cell the nearer of the two depths, and
 * src's counts. For buffers of the same size begun for the same camera and
 * filled apart (on two threads, say). false, o unchanged, when the sizes
 * differ. */
bool hz_occlusion_merge(hz_occlusion *o, const hz_occlusion *src);
/* True when the world box is certainly hidden behind the occluders. */
bool hz_occlusion_box_hidden(const hz_occlusion *o, const hz_box *b);
/* True when occluders certainly cover every point of the screen rectangle
 * [x0, x1] x [y0, y1] (NDC, -1..1, y up), whatever their depth: what lies
 * behind everything there (the sky) is hidden. False for a rectangle
 * reaching off the screen. */
bool hz_occlusion_rect_covered(const hz_occlusion *o, float x0, float y0, float x1, float y1);

#ifdef __cplusplus
}
#endif
#endif
