/* The streamed terrain's command line (--terrain NAME.hzp), shared by
 * render and bench (cmd_stream.c) and view (view_stream.c): options, the
 * stream + renderer pair, and the upload of decoded tiles. */
#ifndef HZ_STREAM_CLI_H
#define HZ_STREAM_CLI_H

#include "cli.h"

#include "horizon/stream.h"

typedef struct sopts {
    const char *terrain, *out, *path, *json_out;
    double cache_mb, tau;
    double near_tau, near_distance; /* --near-pixel-error, --near-error-distance (0: off, default) */
    bool have_camera, json, quiet;
    float camera[5];
    uint32_t width, height, frames;
    hz_pyr_remote remote; /* --terrain http(s)://: --disk-cache, --http-* */
    const char *imagery;  /* --imagery: draped by its georeference */
    uint32_t imagery_max; /* --imagery-max (0: 8192) */
    curv_opts curv;       /* --curvature (curv_cli.c); resolved by stream_curvature */
    /* bench: --realtime paces the flight at --fps (a viewer's flight);
     * --deterministic waits for the tiles of every frame and hashes it */
    bool realtime, deterministic, frames_given;
    double fps;
    /* view only */
    const char *script, *screenshot;
    double speed, dt;     /* m/s (0: map side / 200); fixed seconds per frame (0: real time) */
    bool no_vsync, no_hud;
    int water_mode;       /* --water-level: 0 auto (a real place's sea), 1 off, 2 water_level */
    float water_level;
} sopts;

typedef struct sctx {
    hz_stream *s;
    hz_gl *gl;            /* the headless context (NULL for view: its window's is current) */
    hz_renderer *r;
    hz_patch_list pl;
    hz_lod_params lp;
    uint32_t first_view_loads, first_view_rounds; /* tiles loaded to find the first view */
    bool water;           /* a sea is drawn (stream_water) */
    float water_level;
} sctx;

/* A coarse level of the pyramid (at most 8 x 8 tiles) read whole: heights
 * and validity (stream_ground.c). */
typedef struct coarse {
    float *h;
    uint8_t *v;       /* 1 = data */
    uint32_t n, step; /* samples per side, level-0 samples between them */
    double spacing;
} coarse;
/* 0, or 1 after a message naming cmd. */
int coarse_load(const sopts *o, coarse *g, const char *cmd);
void coarse_free(coarse *g);
/* The highest ground within r of (x, z). */
float coarse_max(const coarse *g, float x, float z, float r, bool wrap);

/* Parses argv[2..] for cmd ("render", "bench", "view"). 0, or 2 after a message. */
int parse_stream(int argc, char **argv, sopts *o, const char *cmd);
/* Opens the stream and its renderer (and a headless GL context unless cmd
 * is "view"). ground: the pyramid's coarse level when the caller has read it
 * already (the sea's coast comes from it), or NULL. 0, or 1 after a message. */
int sctx_open(sctx *c, const sopts *o, const coarse *ground, const char *cmd);
void sctx_free(sctx *c);
/* Uploads the decoded tiles waiting; *n gets their count. 0, or 1 after a message. */
int upload_ready(sctx *c, uint32_t *n);
/* Resolves --curvature for the pyramid: its side, and the WGS84 radius at
 * its centre when it is georeferenced. */
void stream_curvature(sopts *o, const hz_pyr_info *in);
/* A first view over the pyramid's data. */
hz_camera default_camera(const hz_pyr_info *in, uint32_t w, uint32_t h);
/* The camera of render and view: --camera (far plane after its height) or
 * the first view of the highest ground (loads the coarse tiles to find it),
 * with --curvature resolved into its earth radius. */
hz_camera stream_camera(sopts *o, sctx *c, uint32_t w, uint32_t h);

/* The sea of a pyramid (stream_ground.c): with --water-level auto, a real
 * place's (georeferenced) sea at 0 m when its data has one; with a level,
 * water at it. Drawn deep (the streamed heights are not resident to see
 * through), going on beyond the data where its coast does (hz_coast, on a
 * coarse level: ground, or read here when NULL). Sets c->water. 0, or 1
 * after a message. */
int stream_water(sctx *c, const sopts *o, const coarse *ground, const char *cmd);
/* The effects of a streamed frame: water when stream_water found some. */
static inline uint32_t stream_effects(const sctx *c)
{
    return c->water ? HZ_FX_WATER : 0u;
}

int stream_view(int argc, char **argv);

#endif
