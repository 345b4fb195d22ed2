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
    /* Pixel samples (hz_occlusion_set_viewport; all 0/NULL without): the
     * screen's pixels, px_w x px_h; per cell a partial layer, the bits of
     * the pixel centres (8 per row of pixels, bottom row first) that
     * occluders nearer than zpart cover, merged across occluders, so that a
     * cell covered by several (walls side by side) becomes covered. */
    uint32_t px_w, px_h;
    uint32_t *col_px, *row_px; /* w + 1, h + 1: a cell's first pixel column / row */
    uint32_t *col_of, *row_of; /* px_w, px_h: the cell column / row of a pixel's centre */
    uint64_t *mask;            /* w * h */
    float *zpart;              /* w * h */
} hz_occlusion;

/* Allocates a w x h buffer (0 -> 256 x 144; w at most 1024); false on out of memory. */
bool hz_occlusion_init(hz_occlusion *o, uint32_t w, uint32_t h);
void hz_occlusion_free(hz_occlusion *o);
/* Tells the buffer the size in pixels of the image its camera draws, so
 * that it also takes a cell as covered when its occluders together (none
 * of them whole) cover the centre of every pixel in it. The buffer is then
 * conservative for an image drawn at that size without multisampling: the
 * occluders must be drawn (or lie behind what is drawn) where they are
 * rasterised. A sample counts as covered only when it lies at least 1/16
 * pixel inside a polygon (the GPU snaps vertices to a subpixel grid). True
 * when samples are on; false when the cells would be more than 8 x 8
 * pixels, or on out of memory: then only whole cells count, as without
 * (0 x 0 switches samples off). */
bool hz_occlusion_set_viewport(hz_occlusion *o, uint32_t px_w, uint32_t px_h);
/* Clears the buffer for a camera. */
void hz_occlusion_begin(hz_occlusion *o, const hz_camera *cam);
/* Rasterises occluder triangles (world positions, 3 vertices each, xyz
 * floats, optionally transformed by model; NULL = identity; counter-clockwise
 * seen from the front). A cell takes a
 * triangle only when all four of its corners are inside it, at the
 * triangle's farthest vertex depth (or, with pixel samples, when its
 * pixels' centres are all covered, by this and earlier occluders; the cell
 * then takes the farthest depth of them). Triangles crossing the near plane are
 * skipped (conservative). */
void hz_occlusion_rasterize(hz_occlusion *o, const float *tri_xyz, size_t tri_count, const mat4 model);
/* The same for quads: 4 vertices each, in order around, standing for the
 * two triangles (v0, v1, v3) and (v1, v2, v3) that share the diagonal
 * v1-v3. A quad whose screen projection is convex is rasterised as one
 * polygon, so the cells along the diagonal count as covered (each triangle
 * alone would leave them out); otherwise as its two triangles. */
void hz_occlusion_rasterize_quads(hz_occlusion *o, const float *quad_xyz, size_t quad_count, const mat4 model);
/* Takes src's occluders into o: per cell the nearer of the two depths,
 * src's partial layers (when both have the same pixel samples), and
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
