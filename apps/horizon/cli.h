/* Shared option parsing for the horizon subcommands. */
#ifndef HZ_CLI_H
#define HZ_CLI_H

#include "horizon/fx.h"
#include "horizon/render.h"
#include "horizon/terrain.h"
#include "horizon/forest_render.h"
#include "json_out.h"
#include "city_cli.h"
#include "curv_cli.h"

#define CLI_MAX_DEMS 4096

typedef struct cli_opts {
    hz_terrain_desc terrain;
    const char *dems[CLI_MAX_DEMS]; /* every --dem (terrain.dem_paths points here when > 1) */
    uint32_t dem_count;
    hz_lod_params lod;
    bool have_camera;
    float camera[5]; /* x, y, z, yaw, pitch */
    float fov;       /* 0 -> 60 */
    float far;       /* view distance metres; 0 -> 1.5 x map side */
    float near;      /* near clip plane metres; 0 -> the camera's default (0.25 m) */
    uint32_t width, height;
    const char *out;
    const char *dump_mesh;
    bool json;
    bool wireframe;
    bool no_lit_map;      /* --lit-map off */
    bool lit_per_vertex;  /* --lit-map vertex */
    bool lit_pixel;       /* --lit-map pixel */
    bool quiet;
    uint32_t repeat; /* LOD selections to time; median reported */
    /* forest (SPEC F) */
    uint32_t forest_n;          /* trees; 0 = no forest */
    const char *forest_file;    /* CSV x,z,model,scale,yaw (instead of placing forest_n trees) */
    const char *forest_save;    /* writes the placed trees there, in forest_file's format */
    const char *forest_trees;   /* comma-separated .hzt files; NULL -> the four species */
    const char *tree_cache;     /* where generated trees are kept; NULL -> ~/.cache/horizon/trees */
    uint32_t forest_leaves;     /* leaves per generated tree; 0 -> the species' own */
    float forest_density;       /* trees per hectare; 0 -> 400 */
    bool forest_at_set;
    float forest_at[2];         /* world x, z of the forest centre; default the map centre */
    uint64_t forest_seed;
    hz_forest_params forest;    /* simplification switches and the F3 parameters */
    /* effects */
    uint32_t effects;     /* HZ_FX_* (default HZ_FX_DEFAULT) */
    hz_fx_settings fx;    /* zero fields: defaults */
    bool have_sun;
    float sun[2];         /* azimuth (clockwise from north), elevation; degrees */
    double time;          /* effect time of the (first) frame, seconds */
    int water_mode;       /* 0 auto, 1 off, 2 water_level */
    float water_level;    /* metres */
    float fog;            /* per metre; 0 default (3 / view distance; at most CLI_FOG_CLEAR_DAY
                             when the view distance is the default), < 0 off */
    float trees;          /* trees per hectare inside forests; 0 default, < 0 none */
    const char *colormap; /* PNG over the whole terrain */
    const char *imagery;  /* --imagery: any GDAL raster, draped by its georeference */
    uint32_t imagery_max; /* --imagery-max: texels per side at most (0: 8192) */
    const char *textures; /* directory of PNGs replacing the procedural detail textures / sprites */
    /* ground climate (issue 15) */
    hz_climate_kind climate; /* 0 auto: from the georeference's lon/lat, else temperate */
    bool have_latitude;
    float latitude;          /* --latitude: where a DEM without a georeference lies */
    city_opts city;       /* --city, --pick, --cull, --draw (city_cli.c) */
    curv_opts curv;       /* --curvature (curv_cli.c); resolved by cli_curvature */
} cli_opts;

/* The haze of a clear day, 30 km visibility (2 % contrast): the default fog
 * is never thicker when the view distance follows the map's size, so a small
 * map (a town seen from 3 km) is not lost in fog. */
#define CLI_FOG_CLEAR_DAY (3.912f / 30000.0f)
/* The scene's fog_density for the default fog at view distance zfar: the
 * clear day's where 3 / zfar is thicker, else 0 (the renderer's 3 / zfar). */
static inline float cli_fog_default(float zfar)
{
    return 3.0f / zfar > CLI_FOG_CLEAR_DAY ? CLI_FOG_CLEAR_DAY : 0.0f;
}

/* Effect resources of a terrain for a renderer: light map for the sun,
 * scattered trees, forest cover, water planes, colour map; and per frame the
 * scene parameters and the LOD selection for the mirrored (reflection) camera. */
typedef struct app_fx {
    uint32_t effects;
    hz_fx_settings fx;
    vec3 sun;             /* toward the sun */
    float fog;            /* --fog: 0 default, < 0 off */
    bool fog_capped;      /* default fog with the default view distance: at most CLI_FOG_CLEAR_DAY */
    bool no_lit_map;      /* --lit-map off: the plain terrain shaded per pixel */
    bool lit_per_vertex;  /* --lit-map vertex: the lit map read per vertex */
    bool lit_pixel;       /* --lit-map pixel: ... per pixel on every patch */
    bool water;
    float water_level;
    uint8_t *lightmap;
    const float *casters; /* objects casting shadows into the light map (city_app's), or NULL */
    uint32_t sun_rect[4]; /* samples around the objects whose sun heights shade them (city_app's; w 0: none) */
    float *sun_heights;   /* the light map's sun heights over sun_rect */
    vec3 lightmap_sun;
    double lightmap_ms;   /* last build */
    uint32_t lightmap_threads;
    size_t trees;
    double setup_ms;      /* everything in app_fx_setup */
    hz_index_list refl;   /* this frame's reflection selection */
    hz_climate climate;   /* what the ground, trees and water follow */
    bool climate_known;   /* from the georeference (else a default or --climate/--latitude) */
    /* --imagery as draped: texels per side, tiles per side, the image's own
     * metres per pixel, the fraction of the map it covers, load ms */
    uint32_t imagery_side, imagery_tiles;
    double imagery_native_m, imagery_coverage, imagery_ms;
} app_fx;
/* Loads o->imagery onto the georeference g of a square grid of `samples`
 * at `spacing` metres and hands it to r; records its figures in a. 0, or 1
 * after printing the error. */
int app_load_imagery(app_fx *a, const cli_opts *o, const hz_georef *g, uint32_t samples, double spacing,
                     hz_renderer *r, const char *cmd);

/* The city's objects (or none) as the effects see them: shadow casters of
 * the light map and the samples whose sun heights shade their faces. Call
 * before app_fx_setup. */
void app_fx_objects(app_fx *a, const city_app *ca);

/* Builds and uploads what o's effects need. 0, or 1 after printing the error. */
int app_fx_setup(app_fx *a, const cli_opts *o, const hz_terrain *t, hz_renderer *r, const char *cmd);
/* Fills the scene parameters for a frame seen by cam (selects the reflection
 * terrain with the mirrored camera when water is on). time in seconds. */
void app_fx_params(app_fx *a, const hz_terrain *t, const hz_camera *cam, const hz_lod_params *lod, double time,
                   hz_scene_params *sp);
/* Moves the sun and recomputes the light map (when shadows are on). 0 or 1. */
int app_fx_set_sun(app_fx *a, const hz_terrain *t, hz_renderer *r, float azimuth, float elevation);
void app_fx_free(app_fx *a);
/* The sun's azimuth/elevation in degrees. */
void app_fx_sun_angles(const app_fx *a, float *azimuth, float *elevation);

/* A finite number / a decimal integer in [lo, hi], the whole string; false
 * otherwise (out untouched). */
bool cli_parse_float(const char *s, double lo, double hi, float *out);
/* --water-level: "auto" (*mode 0), "off" (1) or metres in [-1e5, 1e5] (2,
 * *level). False, with nothing set, otherwise. */
bool cli_parse_water_level(const char *s, int *mode, float *level);
bool cli_parse_u32(const char *s, uint32_t lo, uint32_t hi, uint32_t *out);
/* Splits s (modified in place) at commas into at most cap items. Returns the
 * count, or -1 when an item is empty ("a,,b", "a,") or there are more than
 * cap. */
int cli_split(char *s, char **items, int cap);

/* Parses argv[first..argc). Returns 0 on success, 2 on bad usage (message
 * printed). Unknown options are errors. */
int cli_parse(int argc, char **argv, int first, cli_opts *o, const char *cmd);
void cli_usage_terrain(void);
/* A file a command reads or writes and the option that names it. */
typedef enum cli_file_kind {
    CLI_FILE = 0,  /* path is one file */
    CLI_LIST,      /* path is a comma-separated list of files (--forest-trees) */
    CLI_TEXTURES   /* path is the --textures folder: its grass.png ... snowflake.png */
} cli_file_kind;
typedef struct cli_file {
    const char *path; /* NULL entries are skipped */
    const char *opt;  /* "--dem" */
    cli_file_kind kind;
} cli_file;

/* Appends o's inputs (--dem, --colormap, --forest-file, --forest-trees,
 * --textures) to ins[n..cap); returns the new count. */
size_t cli_opts_inputs(const cli_opts *o, cli_file *ins, size_t n, size_t cap);
/* Refuses, with a message naming both options, an output that is the same
 * file as an input or as another output (same device and inode, or the same
 * resolved path; horizon/safety.h). Returns 0, or 2 after the message. */
int cli_check_outputs(const char *cmd, const cli_file *outs, size_t nout, const cli_file *ins, size_t nin);
/* An output folder (--save-frames, --shot-dir): refuses, with a message,
 * one that does not exist, is not a folder or cannot be written into, before
 * any work. Returns 0, or 1 after the message. */
int cli_check_dir(const char *cmd, const char *opt, const char *dir);

/* GL_MAX_TEXTURE_BUFFER_SIZE of a short-lived headless context: the most
 * heightmap samples the renderer takes; 0 when unknown. */
uint64_t cli_gpu_max_samples(void);
/* Loads the terrain with a progress bar; NULL after printing the error.
 * Refuses a terrain over the GPU's heightmap limit (cli_gpu_max_samples) or
 * the memory budget before the work. */
hz_terrain *cli_load_terrain(const cli_opts *o);
/* Uploads cdlod's morph data to a renderer when mode needs it (nothing for
 * the other modes). */
hz_result cli_renderer_morph(hz_renderer *r, hz_terrain *t, hz_lod_mode mode, hz_err *err);
/* Uploads the heights (and, for cdlod, the morph data) to a renderer. */
hz_result cli_renderer_setup(hz_renderer *r, hz_terrain *t, const cli_opts *o, hz_err *err);
/* The terrain's georeference and the camera in its CRS and as lon/lat:
 * JSON members set in obj ("crs": null when the terrain has none) or text
 * lines. */
void cli_georef_json(json_t *obj, const hz_terrain *t, const hz_camera *cam);
void cli_print_georef_text(const hz_terrain *t, const hz_camera *cam);
/* Copies a frame's LOD figures the renderer needs (cdlod morphing) into sp. */
void cli_scene_lod(hz_scene_params *sp, const hz_lod_stats *st);

/* One frame's terrain: cdlod selects nodes (patches, drawn as such), the
 * other modes an index list. */
typedef struct cli_lod_frame {
    hz_index_list il;   /* indices (cdlod: only after cli_lod_indices) */
    hz_patch_list pl;   /* cdlod patches */
    hz_lod_stats st;
    bool patches;
    size_t masked;      /* triangles dropped because they touch nodata or padding (index lists) */
    /* Set by a caller that draws each selection once: cdlod's horizon cull
     * (hz_lod_params.horizon_cull) then runs on a thread of its own while
     * the renderer draws the nearest patches (hz_lod_horizon_hide), and
     * cli_lod_finish completes the frame after the draw. */
    bool late_ok;
    bool late;                 /* this frame's cull is on job */
    hz_job job;
    hz_lod *lod;               /* the job's input: the selection's lod, camera, */
    hz_camera cam;             /* parameters and stats, and the first patch */
    hz_lod_params params;      /* it may hide */
    hz_lod_stats sel;
    size_t from;
    uint8_t *hidden;           /* its output: a flag per patch */
    uint16_t *blocks;          /* and the hidden blocks of the others */
    size_t hidden_cap;
    hz_horizon_stats hs;       /* and what it hid */
    hz_result late_res;
    double cull_ms;            /* the last late cull's CPU time (0: none) */
} cli_lod_frame;

/* Selects the frame for cam with p (p->mode). */
hz_result cli_lod_select(hz_terrain *t, const hz_camera *cam, const hz_lod_params *p, cli_lod_frame *f);
/* The frame in sp (patches and morphing, a late cull) and the index list to
 * pass to hz_renderer_draw (none for patches). */
void cli_lod_scene(cli_lod_frame *f, hz_scene_params *sp, const uint32_t **idx, uint32_t *count);
/* After the draw: waits for the frame's late cull, drops the patches it
 * hid from f->pl and counts them in f->st (as the cull in the selection
 * would have; f->cull_ms its time). Nothing to do without one. */
hz_result cli_lod_finish(cli_lod_frame *f);
/* The frame's triangles as indices in f->il (cdlod: expands the patches). */
hz_result cli_lod_indices(hz_terrain *t, cli_lod_frame *f);
void cli_lod_frame_free(cli_lod_frame *f);
/* The pixel error bound p selects with: p->pixel_error, or 1 for cdlod and
 * roam when it is 0 (their default); 0 for the quadtree modes on C and C2. */
float cli_pixel_error(const hz_lod_params *p);
/* near_pixel_error and near_error_distance into j (null when cdlod has no near bound). */
void cli_near_json(json_t *j, const hz_lod_params *p);
/* The camera: --camera or the terrain's default, with --fov/--far applied. */
hz_camera cli_camera(const cli_opts *o, const hz_terrain *t);
/* Resolves --curvature for the loaded terrain (o->curv.radius, which
 * cli_camera and cli_forest_camera give their cameras). Call after loading. */
void cli_curvature(cli_opts *o, const hz_terrain *t);

/* A forest on the terrain, ready to draw through the renderer's hook. */
typedef struct cli_forest {
    hz_tree **models;
    uint32_t model_count;
    hz_forest *forest;
    hz_forest_gpu *gpu;
    hz_forest_frame frame;
    hz_forest_hook hook;
    float center[2], side;   /* where the trees stand */
    double prep_ms;          /* growing/ranking/loading the models */
    uint32_t cleared;        /* placed trees left out because a building stands there */
} cli_forest;

/* Loads or grows (and caches) the models, places o->forest_n trees and
 * uploads them. Needs a current GL context (ranking, upload). NULL after
 * printing the error. */
/* object_tops: the city's objects as light-map casters (or NULL); no tree is
 * planted where an object stands within its crown. */
cli_forest *cli_forest_create(const cli_opts *o, const hz_terrain *t, const float *object_tops);
void cli_forest_destroy(cli_forest *cf);
/* Selects the frame's trees/nodes for cam at time now_s; false after printing. */
bool cli_forest_update(cli_forest *cf, const cli_opts *o, const hz_camera *cam, double now_s);
/* The effects' tree billboards (R3) show the forest's own trees: their
 * sprites become the side views baked from the forest's conifer and
 * broadleaf models (unless --textures gave sprites). Non-zero after printing. */
int cli_forest_billboards(const cli_forest *cf, const cli_opts *o, hz_renderer *ren);
/* Sets sp's object hook to draw the forest. */
void cli_forest_hook(cli_forest *cf, hz_scene_params *sp);
/* Where the forest stands (no GL needed): --forest-at, else the most plantable
 * square (object_tops as for cli_forest_create, or NULL). */
void cli_forest_area(const cli_opts *o, const hz_terrain *t, const float *object_tops, float center[2], float *side);
/* A camera at the forest's edge looking across it (no GL needed). */
hz_camera cli_forest_camera(const cli_opts *o, const hz_terrain *t);
/* The "forest" path: 60 s low over the forest, across and back. */
hz_result cli_forest_path(const cli_forest *cf, const hz_terrain *t, hz_path *out, hz_err *err);
void cli_usage_forest(void);
/* hz_progress_fn for growing/ranking trees: a bar on a terminal, else a line
 * every 10 % or 10 s. user: NULL or a line_progress (forest_cli.c). */
void cli_tree_progress(void *user, const char *label, uint64_t done, uint64_t total);
/* Sets obj's prefix_precision, _recall, _f and prefix_leaf_precision,
 * _leaf_recall, _leaf_f (the same-leaf measure) from r, 4 decimals. */
void cli_pr_json(json_t *obj, const char *prefix, const hz_pr_result *r);
/* Reads a --forest-file: x,z,model,scale,yaw lines ('#' comments, blank
 * lines skipped), y from t. *out (allocated) receives *n trees. False after
 * filling err. */
bool cli_read_forest_file(const char *file, const hz_terrain *t, uint32_t models, hz_forest_tree **out, uint32_t *n,
                          hz_err *err);

/* The command line read by getopt_long against cmd's options ("render",
 * "bench", "view", "tree", "info"): --name=value splits, unambiguous
 * prefixes expand, -h is --help; *out_argv (free() it; its strings are
 * argv's or static) holds "horizon" cmd then "--name" [value] and the
 * operands in order. An unknown option (with the nearest name suggested)
 * or a missing value: message, returns 2. */
int cli_args_normalize(const char *cmd, int argc, char **argv, int *out_argc, char ***out_argv);
/* Refuses argv[i], which no option of cmd took: an operand (after "--" or
 * not) or an unknown option, with a message; returns 2. */
int cli_unknown(const char *cmd, char **argv, int argc, int i);
/* The option of cmd nearest to arg ("--lod-cc" -> "--lod-c"), or NULL when
 * none is close. Static storage. */
const char *cli_args_nearest(const char *cmd, const char *arg);

int cmd_render(int argc, char **argv);
int cmd_bench(int argc, char **argv);
int cmd_view(int argc, char **argv);
int cmd_tree(int argc, char **argv);
int cmd_info(int argc, char **argv);

 /* streamed pyramids (cmd_stream.c) */
int cmd_import(int argc, char **argv);
/* arr: append the pyramid's JSON object to it; NULL: print text */
int pyramid_info(const char *path, bool verify, json_t *arr);
int stream_render(int argc, char **argv);
int stream_bench(int argc, char **argv);
int stream_view(int argc, char **argv);  /* view --terrain (view_stream.c) */
/* True when argv (from first) holds --terrain: the command streams a pyramid. */
bool cli_wants_stream(int argc, char **argv, int first);

#endif
