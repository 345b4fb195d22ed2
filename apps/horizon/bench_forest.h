/* horizon bench --forest (SPEC F7). */
#ifndef HZ_BENCH_FOREST_H
#define HZ_BENCH_FOREST_H

#include "cli.h"

typedef struct bench_forest_opts {
    const char *path;      /* "forest" (default), a built-in terrain path or a CSV */
    uint32_t frames;
    float fps;
    const char *json_out;  /* may be NULL */
    const char *save_dir;  /* may be NULL */
    uint32_t full_every;   /* unsimplified frame every N frames; 0 -> frames / 6 */
    bool no_full, no_pr;
    uint32_t pr_views, pr_res; /* 0 -> 16, 512 */
    uint32_t pr_shuffles;      /* random orders pooled; 0 -> HZ_PR_ORDERS_DEFAULT */
} bench_forest_opts;

/* Runs the forest benchmark; prints the table, writes JSON. 0 or 1. */
int bench_forest(cli_opts *o, hz_terrain *t, const bench_forest_opts *bo);

#endif
