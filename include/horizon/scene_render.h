/* horizon scene drawing (GL side of SPEC G3-G5): a scene graph's meshes in
 * one static vertex and index buffer, drawn through the renderer's object
 * hook after frustum culling (and optionally occlusion culling), from a
 * render queue sorted shader -> mesh (hz_scene_queue_build_instanced: the
 * materials' colours come with the instances): one multi-draw per shader,
 * identical meshes as instances, nearest first whatever their material.
 * Needs a current OpenGL 4.5 context. */
#ifndef HORIZON_SCENE_RENDER_H
#define HORIZON_SCENE_RENDER_H

#include "horizon/render.h"
#include "horizon/occlusion.h"
#include "horizon/scene.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct hz_scene_gpu hz_scene_gpu;

/* Uploads the scene's merged meshes (call again after adding meshes:
 * hz_scene_gpu_destroy + create). NULL + err on GL failure. The scene is
 * not retained. */
hz_scene_gpu *hz_scene_gpu_create(const hz_scene *s, hz_err *err);
void hz_scene_gpu_destroy(hz_scene_gpu *g);

typedef struct hz_scene_draw_opts {
    bool no_frustum;   /* draw every object (no frustum culling) */
    bool naive;        /* no sorting, no instancing, no multi-draw: one draw per object in
                          scene order, the material set whenever it differs (the baseline) */
    /* Occlusion culling (G4), main pass only: objects the buffer proves
     * hidden (hz_occlusion_box_hidden) are skipped. NULL: none. Built by the
     * caller for this pass's camera (hz_occlusion_begin / _rasterize). */
    const struct hz_occlusion *occlusion;
    /* Occlusion culling on the GPU instead (main pass; for comparison):
     * the objects nearer than gpu_near metres are drawn first as occluders,
     * then every other object's world box is drawn against the depth
     * buffer (terrain and those occluders) inside a
     * GL_ANY_SAMPLES_PASSED_CONSERVATIVE query, and only the objects whose
     * box passed are drawn. Conservative. */
    bool gpu_queries;
    float gpu_near;  /* 0 -> 300 m */
} hz_scene_draw_opts;

typedef struct hz_scene_draw_stats {
    uint32_t objects;          /* nodes with a mesh */
    uint32_t after_frustum;    /* visible after frustum culling */
    uint32_t after_occlusion;  /* drawn */
    uint32_t draw_calls;       /* GL draw calls */
    uint32_t state_changes;    /* program + VAO binds + material changes */
    uint32_t items;            /* queue items (distinct shader/material/mesh runs) */
    uint64_t triangles;        /* drawn */
    double cull_ms;            /* frustum + occlusion + queue (CPU) */
    double draw_ms;            /* main pass: the objects' GL time, between two glFinish when the
                                  hook's time_draw is set; else the submission's CPU time */
    uint32_t nodes_tested;     /* frustum: boxes tested */
    uint32_t occlusion_tests;  /* boxes tested against the occlusion buffer (subtrees first) */
    uint32_t queries;          /* GPU occlusion queries issued */
    double query_ms;           /* issuing them and reading the results back */
} hz_scene_draw_stats;

/* Draws the scene for one pass (as the object hook does). stats may be NULL. */
hz_result hz_scene_gpu_draw(hz_scene_gpu *g, const hz_scene *s, const hz_pass_info *pass,
                            const hz_scene_draw_opts *opts, hz_scene_draw_stats *stats, hz_err *err);

/* For hz_scene_params.draw_objects: user = a hz_scene_hook. The main pass's
 * figures land in stats; a GL failure sets failed and err. next (optional)
 * is called after (another hook, e.g. the forest). */
typedef struct hz_scene_hook {
    hz_scene_gpu *gpu;
    const hz_scene *scene;
    hz_scene_draw_opts opts;
    /* Time the objects' own GL work (stats.draw_ms): the main pass waits
     * for the GPU before and after them. That stall costs the frame the
     * overlap of the objects' rasterisation with the vertex work of the
     * draws after them (on llvmpipe 3-5 ms of a 20-30 ms street frame), so
     * leave it off for speed. */
    bool time_draw;
    hz_scene_draw_stats stats;
    bool failed;
    hz_err err;
    hz_draw_hook_fn next;
    void *next_user;
} hz_scene_hook;
void hz_scene_draw_hook(void *user, const hz_pass_info *pass);

#ifdef __cplusplus
}
#endif
#endif
