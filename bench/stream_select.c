/* stream_select: CPU time of the streamed cdlod selection against the
 * in-memory one over the same terrain and cameras (issue figure: "LOD ms
 * streamed within 20 % of in memory").
 *
 *   stream_select --pyramid F.hzp --dem F.png --path P.csv [--spacing 10]
 *                 [--zscale 0.03] [--pixel-error 1] [--height 720] [--runs 7]
 *
 * The pyramid must be the DEM imported with the same spacing and zscale.
 * Every tile the flight needs is loaded first (synchronously), so the times
 * are the selection alone. Each run times both selections frame by frame,
 * alternating, with the thread's CPU clock; the best run of each is printed
 * as one JSON object. */
#include "horizon/lod.h"
#include "horizon/path.h"
#include "horizon/stream.h"
#include "horizon/terrain.h"

#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

enum { FRAMES = 120 };

static double cpu_ms(void)
{
    struct timespec t;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return (double)t.tv_sec * 1e3 + (double)t.tv_nsec * 1e-6;
}

static int usage(void)
{
    fprintf(stderr, "usage: stream_select --pyramid F.hzp --dem F --path P.csv [--spacing S] [--zscale Z] "
                    "[--pixel-error T] [--height H] [--runs N]\n");
    return 2;
}

int main(int argc, char **argv)
{
    const char *pyr = NULL, *dem = NULL, *path_csv = NULL;
    float spacing = 10.0f, zscale = 0.03f, tau = 1.0f;
    int height = 720, runs = 7;
    static const struct option opts[] = {
        {"pyramid", required_argument, 0, 'p'}, {"dem", required_argument, 0, 'd'},
        {"path", required_argument, 0, 'c'},    {"spacing", required_argument, 0, 's'},
        {"zscale", required_argument, 0, 'z'},  {"pixel-error", required_argument, 0, 't'},
        {"height", required_argument, 0, 'h'},  {"runs", required_argument, 0, 'r'},
        {0, 0, 0, 0}};
    for (int o; (o = getopt_long(argc, argv, "", opts, NULL)) != -1;) {
        switch (o) {
        case 'p': pyr = optarg; break;
        case 'd': dem = optarg; break;
        case 'c': path_csv = optarg; break;
        case 's': spacing = strtof(optarg, NULL); break;
        case 'z': zscale = strtof(optarg, NULL); break;
        case 't': tau = strtof(optarg, NULL); break;
        case 'h': height = atoi(optarg); break;
        case 'r': runs = atoi(optarg); break;
        default: return usage();
        }
    }
    if (!pyr || !dem || !path_csv || !(spacing > 0) || !(zscale > 0) || !(tau > 0) || height < 16 || runs < 1 ||
        runs > 100)
        return usage();

    hz_err err = {0};
    hz_path path;
    if (hz_path_load_csv(path_csv, &path, &err) != HZ_OK) {
        fprintf(stderr, "stream_select: %s\n", err.msg);
        return 1;
    }
    const float dur = hz_path_duration(&path);
    hz_camera cams[FRAMES];
    for (int f = 0; f < FRAMES; f++) {
        cams[f] = (hz_camera){.fov_y = 60, .aspect = 16.0f / 9, .znear = 1, .zfar = 90000};
        hz_path_sample(&path, dur * (float)f / (FRAMES - 1), &cams[f]);
        cams[f].aspect = 16.0f / 9;
    }
    hz_lod_params lp = {.mode = HZ_LOD_CDLOD, .pixel_error = tau, .viewport_height = (uint32_t)height};

    hz_stream *s = hz_stream_create(
        &(hz_stream_desc){.path = pyr, .cache_bytes = 2048ull << 20, .synchronous = true},
        &err);
    if (!s) {
        fprintf(stderr, "stream_select: %s\n", err.msg);
        return 1;
    }
    hz_patch_list ps = {0}, pm = {0};
    hz_lod_stats st;
    hz_stream_set_clock(s, 0.0);
    /* load what every frame needs (tiles arrive level after level) */
    for (int f = 0; f < FRAMES; f++)
        for (int k = 0; k < 40; k++) {
            hz_stream_select(s, &cams[f], &lp, &ps, &st);
            uint32_t slot;
            const uint16_t *tex;
            int n = 0;
            while (hz_stream_next_upload(s, &slot, &tex)) {
                hz_stream_uploaded(s, slot);
                n++;
            }
            hz_stream_stats ss = hz_stream_take_stats(s);
            if (!n && !ss.pending && !ss.requested)
                break;
        }
    hz_stream_set_clock(s, 1e3); /* every tile has slid in */
    hz_terrain *t =
        hz_terrain_create(&(hz_terrain_desc){.dem_path = dem, .spacing = spacing, .zscale = zscale}, &err);
    if (!t) {
        fprintf(stderr, "stream_select: %s\n", err.msg);
        hz_stream_destroy(s);
        return 1;
    }
    hz_lod_prepare(t->lod, HZ_LOD_CDLOD);

    double best_s = 1e30, best_m = 1e30;
    double tri_s = 0, tri_m = 0, nodes_s = 0, nodes_m = 0;
    for (int run = 0; run < runs; run++) {
        double ts = 0, tm = 0;
        tri_s = tri_m = nodes_s = nodes_m = 0;
        for (int f = 0; f < FRAMES; f++) {
            double a = cpu_ms();
            hz_stream_select(s, &cams[f], &lp, &ps, &st);
            ts += cpu_ms() - a;
            tri_s += st.triangles, nodes_s += (double)ps.count;
            a = cpu_ms();
            hz_lod_select_patches(t->lod, &cams[f], &lp, &pm, &st);
            tm += cpu_ms() - a;
            tri_m += st.triangles, nodes_m += (double)pm.count;
        }
        best_s = ts < best_s ? ts : best_s;
        best_m = tm < best_m ? tm : best_m;
    }
    printf("{\"frames\": %d, \"runs\": %d, \"pixel_error\": %g, \"height\": %d,\n"
           " \"stream_ms\": %.4f, \"memory_ms\": %.4f, \"ratio\": %.3f,\n"
           " \"stream_triangles\": %.0f, \"memory_triangles\": %.0f, \"stream_nodes\": %.0f, \"memory_nodes\": %.0f}\n",
           FRAMES, runs, tau, height, best_s / FRAMES, best_m / FRAMES, best_s / best_m, tri_s / FRAMES,
           tri_m / FRAMES, nodes_s / FRAMES, nodes_m / FRAMES);
    free(ps.data);
    free(pm.data);
    hz_terrain_destroy(t);
    hz_stream_destroy(s);
    return 0;
}
