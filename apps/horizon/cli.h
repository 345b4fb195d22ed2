/* Shared option parsing for the horizon subcommands. */
#ifndef HZ_CLI_H
#define HZ_CLI_H

#include "horizon/render.h"
#include "horizon/terrain.h"

typedef struct cli_opts {
    hz_terrain_desc terrain;
    hz_lod_params lod;
    bool have_camera;
    float camera[5]; /* x, y, z, yaw, pitch */
    float fov;       /* 0 -> 60 */
    float far;       /* view distance metres; 0 -> 1.5 x map side */
    uint32_t width, height;
    const char *out;
    const char *dump_mesh;
    bool json;
    bool wireframe;
    bool quiet;
    uint32_t repeat; /* LOD selections to time; median reported */
} cli_opts;

/* Parses argv[first..argc). Returns 0 on success, 2 on bad usage (message
 * printed). Unknown options are errors. */
int cli_parse(int argc, char **argv, int first, cli_opts *o, const char *cmd);
void cli_usage_terrain(void);
/* Loads the terrain with a progress bar; NULL after printing the error. */
hz_terrain *cli_load_terrain(const cli_opts *o);
/* Uploads the heights (and, for cdlod, the morph data) to a renderer. */
hz_result cli_renderer_setup(hz_renderer *r, hz_terrain *t, const cli_opts *o, hz_err *err);
/* Copies a frame's LOD figures the renderer needs (cdlod morphing) into sp. */
void cli_scene_lod(hz_scene_params *sp, const hz_lod_stats *st);
/* The camera: --camera or the terrain's default, with --fov/--far applied. */
hz_camera cli_camera(const cli_opts *o, const hz_terrain *t);

int cmd_render(int argc, char **argv);
int cmd_bench(int argc, char **argv);
int cmd_view(int argc, char **argv);

#endif
