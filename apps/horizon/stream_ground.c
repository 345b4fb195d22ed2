/* A streamed pyramid's ground as a whole, from one coarse level read at
 * once: the highest ground along a flight (bench), and its sea (render,
 * bench, view). */
#include "stream_cli.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "horizon/fx.h"
#include "horizon/render.h"

int coarse_load(const sopts *o, coarse *g, const char *cmd)
{
    hz_pyramid *p;
    hz_err err = {0};
    memset(g, 0, sizeof *g);
    if (hz_pyramid_open_with(o->terrain, &o->remote, &p, &err) != HZ_OK) {
        fprintf(stderr, "horizon %s: %s\n", cmd, err.msg);
        return 1;
    }
    const hz_pyr_info *in = hz_pyramid_info(p);
    uint32_t l = 0;
    while (l + 1 < in->levels && hz_pyr_level_tiles(in, l) > 8)
        l++;
    const uint32_t m = hz_pyr_level_tiles(in, l), c = hz_pyr_level_cells(in, l);
    g->n = m * c + 1;
    g->step = 1u << l;
    g->spacing = in->spacing;
    g->h = malloc((size_t)g->n * g->n * sizeof *g->h);
    g->v = malloc((size_t)g->n * g->n);
    int rc = g->h && g->v ? 0 : 1;
    if (rc)
        fprintf(stderr, "horizon %s: out of memory for the coarse ground\n", cmd);
    for (uint32_t tz = 0; !rc && tz < m; tz++)
        for (uint32_t tx = 0; !rc && tx < m; tx++) {
            hz_pyr_tile t;
            if (hz_pyramid_read_tile(p, l, tx, tz, &t, &err) != HZ_OK) {
                fprintf(stderr, "horizon %s: %s\n", cmd, err.msg);
                rc = 1;
                break;
            }
            for (uint32_t b = 0; b <= c; b++)
                for (uint32_t a = 0; a <= c; a++) {
                    const size_t k = (size_t)(tz * c + b) * g->n + tx * c + a, s = (size_t)b * (c + 1) + a;
                    g->h[k] = (float)(in->h_offset + in->h_scale * t.h[s]);
                    g->v[k] = !t.valid || t.valid[s];
                }
            hz_pyr_tile_free(&t);
        }
    hz_pyramid_close(p);
    if (rc)
        coarse_free(g);
    return rc;
}

void coarse_free(coarse *g)
{
    free(g->h);
    free(g->v);
    memset(g, 0, sizeof *g);
}

float coarse_max(const coarse *g, float x, float z, float r, bool wrap)
{
    float m = -INFINITY;
    const double d = g->spacing * g->step, per = (double)(g->n - 1);
    for (int dz = -4; dz <= 4; dz++)
        for (int dx = -4; dx <= 4; dx++) {
            double fx = (x + r * (float)dx / 4.0f) / d, fz = (z + r * (float)dz / 4.0f) / d;
            if (wrap)
                fx -= floor(fx / per) * per, fz -= floor(fz / per) * per;
            if (fx < 0 || fz < 0 || fx > g->n - 1 || fz > g->n - 1)
                continue;
            m = fmaxf(m, g->h[(size_t)(fz + 0.5) * g->n + (size_t)(fx + 0.5)]);
        }
    return m;
}

/* A real place's sea is flat at 0 m: the most common height within 0.5 m
 * of 0 (in steps of 1 cm) holds at least 0.5 % of the samples with data (the
 * flat sea of SRTM and its kin). The level is 0.1 m over it, as for an
 * in-memory DEM (hz_water_level_auto). */
static bool sea_level(const coarse *g, float *level)
{
    uint64_t valid = 0, count[101] = {0};
    for (size_t k = 0; k < (size_t)g->n * g->n; k++) {
        if (!g->v[k])
            continue;
        valid++;
        if (fabsf(g->h[k]) <= 0.5f)
            count[(int)lrintf(g->h[k] * 100.0f) + 50]++;
    }
    int best = 0;
    for (int b = 1; b <= 100; b++)
        best = count[b] > count[best] ? b : best;
    if (!valid || (double)count[best] < 0.005 * (double)valid)
        return false;
    *level = (float)(best - 50) / 100.0f + 0.1f;
    return true;
}

int stream_water(sctx *c, const sopts *o, const coarse *ground, const char *cmd)
{
    const hz_pyr_info *in = hz_stream_info(c->s);
    c->water = false;
    if (o->water_mode == 1 || (o->water_mode == 0 && !in->wkt[0]))
        return 0;
    coarse own = {0};
    if (!ground && coarse_load(o, &own, cmd))
        return 1;
    const coarse g = ground ? *ground : own;
    float level = o->water_level;
    if (o->water_mode == 0 && !sea_level(&g, &level)) {
        coarse_free(&own);
        return 0;
    }
    hz_err err = {0};
    hz_grid grid = {.width = g.n, .height = g.n, .z = g.h};
    hz_heightmap hm = {0};
    hz_coast coast = {0};
    /* the data's rectangle in coarse samples (the data starts at the origin) */
    const uint32_t x1 = (in->data_w - 1 + g.step - 1) / g.step, z1 = (in->data_h - 1 + g.step - 1) / g.step;
    const uint32_t rect[4] = {0, 0, x1 < g.n ? x1 : g.n - 1, z1 < g.n ? z1 : g.n - 1};
    hz_water_plane plane = {.height = level, .sea = true};
    hz_result res = hz_heightmap_create(&hm, &grid, HZ_LAYOUT_LINEAR, &err);
    if (res == HZ_OK)
        res = hz_coast_make(&hm, g.v, (float)(g.spacing * g.step), 1.0f, level, rect, &coast, &err);
    if (res == HZ_OK)
        res = hz_renderer_set_coast(c->r, &coast, &err);
    if (res == HZ_OK)
        res = hz_renderer_set_water(c->r, &plane, 1, NULL, 0, &err);
    hz_coast_free(&coast);
    hz_heightmap_destroy(&hm);
    coarse_free(&own);
    if (res != HZ_OK) {
        fprintf(stderr, "horizon %s: water: %s\n", cmd, err.msg);
        return 1;
    }
    c->water = true;
    c->water_level = level;
    return 0;
}
