/* City models and scene objects on the terrain for render / bench / view:
 * --city FILE.city.json, --pick X,Y, the culling switches. The CLI's own
 * code for issue 13; cli.c only forwards unknown options here. */
#ifndef HZ_CITY_CLI_H
#define HZ_CITY_CLI_H

#include <jansson.h>

#include "horizon/city.h"
#include "horizon/occlusion.h"
#include "horizon/scene_file.h"
#include "horizon/scene_render.h"
#include "horizon/terrain.h"

typedef struct city_opts {
    const char *city;     /* --city FILE */
    const char *scene;    /* --scene FILE (docs/scene.md) */
    const char *footprints; /* --footprints FILE: OGR polygons extruded */
    const char *height_field; /* --height-field NAME (default: height, building:height, measuredHeight) */
    const char *levels_field; /* --levels-field NAME (default: building:levels, num_floors, building_l, levels) */
    bool have_pick;
    float pick[2];        /* --pick X,Y: pixel, x right, y down from the top-left */
    bool no_frustum;      /* --cull none|frustum|occlusion (default occlusion) */
    bool no_occlusion;
    bool gpu_queries;     /* --cull gpu: GPU occlusion queries instead of the CPU buffer */
    bool naive;           /* --draw naive|sorted (default sorted) */
    float tin_cell;       /* --tin-cell M: TINRelief grid when the city is its own terrain (default 5) */
    const char *bench;    /* --city-bench street|overview */
    uint32_t bench_frames; /* --city-bench-frames N (default 12) */
} city_opts;

/* One option of argv at *i (value v, may be NULL). Returns -1 when it is
 * not a city option, 0 when consumed (*i advanced past a value), 2 after
 * printing a usage error. */
int city_cli_option(city_opts *c, const char *a, const char *v, const char *cmd, int *i);
void city_cli_usage(void);

struct cli_opts;

typedef struct city_app {
    hz_city *city;         /* --city, or NULL */
    hz_city *fp;           /* --footprints, or NULL */
    hz_city_placed fp_placed;
    hz_scene_file *file;   /* --scene, or NULL */
    hz_scene_file_info file_info;
    hz_scene_file_stats file_stats;
    hz_scene *scene;
    hz_city_placed placed;
    double place_ms;
    char tin_path[256];    /* the TINRelief grid written for the terrain (removed at the end) */
    /* occluders: the terrain's coarse cells; per mesh its face quads (local),
     * per occluding node its mesh */
    const hz_terrain *ter;  /* the terrain placed on (city_app_place; it outlives the app) */
    float *ter_cmin;        /* (ter_cn + 1)^2 corner heights of the coarse terrain cells */
    uint8_t *ter_cell_ok;   /* ter_cn^2: the cell lies over valid data */
    float *ter_quads;       /* a window's occluder quads, 12 floats each (terrain_occlude) */
    size_t ter_quads_cap;   /* quads it holds */
    uint32_t ter_cn;
    float ter_cell;         /* metres per coarse cell side */
    uint32_t *mesh_first, *mesh_quads;   /* per mesh: first quad, count */
    uint8_t *node_closed;   /* per node: (a part of) a closed, consistently wound object (back
                               faces occlude too) */
    float *quads;
    uint32_t *occ_node;
    uint32_t occ_nodes;
    uint32_t *occ_cand;    /* per frame: the occluders in reach, nearest first (4 per node: + sort scratch) */
    uint32_t occ_cand_cap; /* nodes it holds (the scene's when placed, + 1) */
    hz_occlusion occ;
    hz_occlusion occ_ter;  /* the terrain's occluders, rasterised on a thread of their own */
    double occ_ms;         /* last frame's occlusion buffer build */
    bool occ_built;        /* the last frame had an occlusion buffer */
    uint32_t occ_rest;     /* frames left without one (it hid too little) */
    /* the terrain's cdlod patches behind the occluders are not drawn either */
    hz_lod *lod;           /* the terrain's (city_app_place) */
    hz_patch *patch_keep;  /* this frame's visible patches (sp->patches points here) */
    uint32_t *patch_vis;   /* per patch in view: hidden whole (0x10000) or its hidden blocks */
    size_t patch_keep_cap;
    uint32_t patches_in, patches_drawn; /* last frame: terrain patches in the view, drawn */
    uint32_t blocks_hidden;             /* ... and blocks of the drawn ones left out (hz_patch.hidden) */
    uint32_t ter_window_cells;          /* last buffer: the terrain's cells with data within reach, */
    uint32_t ter_occluders;             /* ... and the occluder quads made of them (one each) */
    /* the objects as shadow casters of the light map (hz_lightmap_desc.casters): per terrain
     * sample the top of the highest object box over it, -inf elsewhere; NULL when none */
    float *casters;
    uint64_t caster_samples; /* samples under an object */
    uint32_t sun_rect[4];    /* the samples around the objects (i0, j0, w, h) whose sun heights shade
                                their faces (hz_lightmap_desc.sun_heights); w 0: none */
    /* GL */
    hz_scene_gpu *gpu;
    hz_scene_hook hook;
} city_app;

/* Loads the city and/or the scene file (before the terrain): when the command has no terrain
 * source (--dem / --generate), the city's TINRelief becomes the terrain (a
 * GeoTIFF grid in $TMPDIR, in o->terrain), else the scene file's terrain;
 * the scene file's sun unless --sun. NULL with *rc = 0 when there is no
 * --city nor --scene; NULL with *rc = 1 after printing an error. */
city_app *city_app_load(struct cli_opts *o, const char *cmd, int *rc);
/* Places the city on the terrain (through its georeference, clamped to
 * hz_terrain_surface_at; a terrain without one gets the city centred) and
 * prepares the occluders. 0, or 1 after printing. */
int city_app_place(city_app *a, const hz_terrain *t, const char *cmd);
/* A camera looking at the city from the south-east (when --camera is not given). */
hz_camera city_app_camera(const city_app *a, const struct cli_opts *o, const hz_terrain *t);
/* Uploads the scene (current GL context). 0 or 1 after printing. */
int city_app_gpu(city_app *a, const char *cmd);
/* Per frame: the occlusion buffer for cam (unless off) and sp's object
 * hook (chained in front of a hook sp already has). With the buffer, the
 * terrain's in-memory cdlod patches it hides are dropped from sp too. */
void city_app_frame(city_app *a, const struct cli_opts *o, const hz_camera *cam, uint32_t fb_w, uint32_t fb_h,
                    hz_scene_params *sp);
/* --pick: what is under the point (x, y) of cam's image (w x h; continuous:
 * pixel (i, j) spans [i, i + 1) x [j, j + 1), so its centre is i + 0.5): the
 * nearest of the scene's triangles and the terrain's surface; printed, with
 * the pixel it lies in, as text or JSON members. */
void city_app_pick(const city_app *a, const hz_terrain *t, const hz_camera *cam, float x, float y, uint32_t w,
                   uint32_t h, json_t *json);
/* The same as one line (a HUD message). */
void city_app_pick_line(const city_app *a, const hz_terrain *t, const hz_camera *cam, float x, float y, uint32_t w,
                        uint32_t h, char *buf, size_t n);
/* The figures: JSON members (",\"city\":{...}") or text lines. */
void city_app_print(const city_app *a, json_t *json);
void city_app_destroy(city_app *a);

struct app_fx;
/* --city-bench: the path's frames drawn with every culling / queue
 * configuration (rotating order), medians and pixel differences printed.
 * 0 or 1 after printing. */
int city_app_bench(city_app *a, struct cli_opts *o, hz_terrain *t, hz_renderer *ren, struct app_fx *afx, bool json);

/* horizon city --blocks N --out FILE: a procedural city as a scene file. */
int cmd_city(int argc, char **argv);

#endif
