/* horizon bench --forest: the forest table (SPEC F7, issue 16). Flies a path
 * over a forest and measures, on the same frames: simplified with and
 * without hysteresis, the bare terrain (no trees), and on a subset the
 * unsimplified forest (slow in software GL), with the image PSNR and the
 * tree-silhouette error of the simplified frames against the unsimplified
 * ones; then precision/recall of every species' VMI order against random
 * pruning. */
#include "bench_forest.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "horizon/metrics.h"

/* RUN_PARTS: the hysteresis frames again, each forest draw split by
 * glFinish into leaves, bark + hulls and impostors, timed (kept apart so
 * that the splits do not slow the runs compared). */
enum { RUN_HYST, RUN_NOHYST, RUN_FULL, RUN_TERRAIN, RUN_PARTS, RUNS };
static const char *const RUN_NAME[RUNS] = {"forest frames (hysteresis)", "forest frames (no hysteresis)",
                                           "forest frames (unsimplified)", "bare terrain frames",
                                           "forest frames (parts timed)"};

#include "horizon/safety.h"

typedef struct frow {
    bool done;
    double frame_ms, cpu_ms, draw_ms, select_ms;
    double part_ms[3]; /* RUN_PARTS: leaves, bark + hulls, impostors */
    uint64_t tri_full, tri_drawn, upload;
    uint32_t in_frustum, leaves, hulls, impostors, fading, changed, held;
} frow;

/* CPU time of the whole process (all of llvmpipe's threads), ms: less
 * sensitive than wall time to other load on a shared machine. */
static double cpu_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

static int cmp_d(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Percentile q (0.5 = median) of a field over the frames a run measured;
 * only_full: only the frames the unsimplified run also measured. */
static double pct(const frow *r, const frow *full, uint32_t n, size_t off, char kind, double q)
{
    double *v = malloc((n ? n : 1) * sizeof *v);
    uint32_t m = 0;
    if (!v)
        return NAN;
    for (uint32_t i = 0; i < n; i++) {
        if (!r[i].done || (full && !full[i].done))
            continue;
        const char *p = (const char *)&r[i] + off;
        v[m++] = kind == 'q' ? (double)*(const uint64_t *)p : kind == 'u' ? (double)*(const uint32_t *)p
                                                                          : *(const double *)p;
    }
    double res = NAN;
    if (m) {
        qsort(v, m, sizeof *v, cmp_d);
        double x = q * (double)(m - 1);
        size_t lo = (size_t)floor(x), hi = lo + 1 < m ? lo + 1 : lo;
        res = v[lo] + (v[hi] - v[lo]) * (x - (double)lo);
    }
    free(v);
    return res;
}

#define MED(run, f) pct(rows[run], NULL, frames, offsetof(frow, f), 'd', 0.5)
#define P95(run, f) pct(rows[run], NULL, frames, offsetof(frow, f), 'd', 0.95)
#define MEDQ(run, f) pct(rows[run], NULL, frames, offsetof(frow, f), 'q', 0.5)
#define MEDU(run, f) pct(rows[run], NULL, frames, offsetof(frow, f), 'u', 0.5)
#define MEDF(run, f) pct(rows[run], rows[RUN_FULL], frames, offsetof(frow, f), 'd', 0.5)

typedef struct species_row {
    const hz_tree *t;
    hz_pr_result pr[4]; /* vmi, vmi enlarged, random, random enlarged */
} species_row;

/* One frame: terrain LOD + forest selection + draw (no forest: terrain only). */
static bool frame(hz_renderer *ren, const hz_terrain *t, cli_opts *o, cli_forest *cf, const hz_camera *cam,
                  const hz_forest_params *fp, double now, hz_index_list *il, frow *r, hz_err *err)
{
    double t0 = hz_time_ms(), c0 = cpu_ms();
    hz_lod_stats st;
    if (hz_lod_select(t->lod, cam, &o->lod, il, NULL, NULL, &st) != HZ_OK) {
        hz_err_set(err, HZ_ERR_MEMORY, "LOD selection out of memory");
        return false;
    }
    hz_scene_params sp = {0};
    cli_scene_lod(&sp, &st);
    if (fp) {
        if (hz_forest_update(cf->forest, cam, fp, now, &cf->frame, err) != HZ_OK)
            return false;
        cli_forest_hook(cf, &sp);
    }
    if (hz_renderer_draw(ren, cam, &sp, il->data, (uint32_t)il->count, NULL, err) != HZ_OK)
        return false;
    if (fp && cf->hook.failed) {
        *err = cf->hook.err;
        return false;
    }
    r->frame_ms = hz_time_ms() - t0;
    r->cpu_ms = cpu_ms() - c0;
    r->done = true;
    if (fp) {
        const hz_forest_frame *fr = &cf->frame;
        r->draw_ms = cf->hook.draw_ms;
        r->select_ms = fr->select_ms;
        r->in_frustum = fr->trees_in_frustum;
        r->leaves = fr->trees_detailed;
        r->hulls = fr->trees_hull;
        r->impostors = fr->trees_impostor;
        r->fading = fr->trees_fading;
        r->tri_full = fr->triangles_full;
        r->tri_drawn = fr->triangles_drawn;
        r->changed = fr->nodes_changed;
        r->held = fr->nodes_held;
        r->upload = hz_forest_gpu_upload_bytes(cf->gpu);
        const double *parts = hz_forest_gpu_part_ms(cf->gpu);
        for (int k = 0; k < 3; k++)
            r->part_ms[k] = parts ? parts[k] : NAN;
    }
    return true;
}

/* Pixels where the trees are: differing from the bare terrain frame. */
static void tree_mask(const uint8_t *img, const uint8_t *bare, size_t npx, uint8_t *mask)
{
    for (size_t p = 0; p < npx; p++)
        mask[p] = abs(img[p * 3] - bare[p * 3]) + abs(img[p * 3 + 1] - bare[p * 3 + 1]) +
                      abs(img[p * 3 + 2] - bare[p * 3 + 2]) >
                  24;
}

/* key = v rounded to `digits` decimals (null when not finite). */
static void json_num(json_t *j, const char *key, double v, int digits)
{
    jx_set(j, key, jx_fix(v, digits));
}

int bench_forest(cli_opts *o, hz_terrain *t, const bench_forest_opts *bo)
{
    int rc = 1;
    hz_err err = {0};
    hz_gl *gl = NULL;
    hz_renderer *ren = NULL;
    cli_forest *cf = NULL;
    hz_path path = {0};
    hz_index_list il = {0};
    const uint32_t frames = bo->frames;
    const size_t npx = (size_t)o->width * o->height;
    frow *rows[RUNS] = {0};
    species_row *sr = NULL;
    uint8_t *rgb = malloc(npx * 3), *mask_a = malloc(npx), *mask_b = malloc(npx);
    uint8_t **img[3] = {0}; /* sampled frames: simplified (hysteresis), unsimplified, bare terrain */
    double *psnr = calloc(frames ? frames : 1, sizeof *psnr), *sil = calloc(frames ? frames : 1, sizeof *sil);
    bool oom = !rgb || !mask_a || !mask_b || !psnr || !sil;
    for (int r = 0; r < RUNS; r++)
        oom |= !(rows[r] = calloc(frames ? frames : 1, sizeof *rows[r]));
    for (int k = 0; k < 3; k++)
        oom |= !(img[k] = calloc(frames ? frames : 1, sizeof *img[k]));
    if (oom) {
        hz_err_set(&err, HZ_ERR_MEMORY, "out of memory");
        goto done;
    }
    gl = hz_gl_create_headless(&err);
    if (!gl)
        goto done;
    ren = hz_renderer_create(&(hz_renderer_desc){.width = o->width, .height = o->height}, &err);
    if (!ren || cli_renderer_setup(ren, t, o, &err) != HZ_OK)
        goto done;
    cf = cli_forest_create(o, t, NULL);
    if (!cf) {
        hz_err_set(&err, HZ_ERR_VALUE, "no forest");
        goto done;
    }
    if (cli_forest_billboards(cf, o, ren)) {
        hz_err_set(&err, HZ_ERR_VALUE, "forest billboards");
        goto done;
    }
    hz_result pr;
    size_t plen = strlen(bo->path);
    if (plen > 4 && !strcmp(bo->path + plen - 4, ".csv"))
        pr = hz_path_load_csv(bo->path, &path, &err);
    else if (!strcmp(bo->path, "forest"))
        pr = cli_forest_path(cf, t, &path, &err);
    else
        pr = hz_terrain_path(t, bo->path, &path, &err);
    if (pr != HZ_OK)
        goto done;
    hz_camera cam = cli_camera(o, t);
    if (o->far <= 0.0f)
        cam.zfar = 6000.0f;
    cam.znear = 0.3f;
    hz_forest_params with = o->forest, without = o->forest, full = o->forest;
    with.hysteresis = true;
    without.hysteresis = false;
    full.simplify = false;
    const uint32_t every = bo->full_every ? bo->full_every : (frames >= 6 ? frames / 6 : 1);
    /* Warm-up (shader compilation, buffer growth). */
    hz_path_sample(&path, 0.0f, &cam);
    frow warm = {0};
    if (!frame(ren, t, o, cf, &cam, &with, 0.0, &il, &warm, &err) ||
        !frame(ren, t, o, cf, &cam, NULL, 0.0, &il, &warm, &err))
        goto done;
    /* 2 frames per path second unless --fps was given: the camera moves a
     * few metres between frames, and the hysteresis still sees consecutive
     * frames. Each run is a separate pass over the same frames, so that one
     * does not disturb the other's caches. */
    const double dt = 1.0 / (bo->fps > 0 ? bo->fps : 2.0);
    for (int run = 0; run < RUNS; run++) {
        if (run == RUN_FULL && bo->no_full)
            continue;
        hz_forest_reset(cf->forest);
        hz_forest_gpu_time_parts(cf->gpu, run == RUN_PARTS);
        /* The forest's own GL time only where the frame is not what is
         * measured (the pass timed apart) or is too slow to care (the
         * unsimplified frames): waiting for the GPU around the trees stalls
         * the frame (hz_forest_hook.time_draw). Elsewhere draw_ms is the
         * submission's CPU time. */
        cf->hook.time_draw = run == RUN_PARTS || run == RUN_FULL;
        for (uint32_t f = 0; f < frames; f++) {
            bool sampled = f % every == 0;
            if (run == RUN_FULL && !sampled)
                continue;
            double now = (double)f * dt;
            hz_path_sample(&path, (float)now, &cam);
            const hz_forest_params *fp = run == RUN_HYST || run == RUN_PARTS ? &with
                                         : run == RUN_NOHYST                ? &without
                                                               : run == RUN_FULL   ? &full
                                                                                   : NULL;
            if (!frame(ren, t, o, cf, &cam, fp, now, &il, &rows[run][f], &err))
                goto done;
            int slot = run == RUN_HYST ? 0 : run == RUN_FULL ? 1 : run == RUN_TERRAIN ? 2 : -1;
            bool keep = slot >= 0 && sampled && !bo->no_full;
            const bool save = bo->save_dir && run != RUN_NOHYST && run != RUN_PARTS;
            if (keep || save) {
                if (hz_renderer_read_rgb(ren, rgb, &err) != HZ_OK)
                    goto done;
            }
            if (keep) {
                img[slot][f] = malloc(npx * 3);
                if (!img[slot][f]) {
                    hz_err_set(&err, HZ_ERR_MEMORY, "out of memory");
                    goto done;
                }
                memcpy(img[slot][f], rgb, npx * 3);
            }
            if (save) {
                char name[1024];
                static const char *const pre[RUNS] = {"", "", "full_", "terrain_", ""};
                snprintf(name, sizeof name, "%s/forest_%s%04u.png", bo->save_dir, pre[run], f);
                if (hz_image_write_png(name, rgb, o->width, o->height, &err) != HZ_OK)
                    goto done;
            }
            if (!o->quiet)
                cli_tree_progress(NULL, RUN_NAME[run], f + 1, frames);
        }
    }
    /* Simplified against unsimplified on the sampled frames. */
    uint32_t ncmp = 0;
    for (uint32_t f = 0; f < frames; f++)
        if (img[0][f] && img[1][f] && img[2][f]) {
            psnr[ncmp] = hz_metrics_psnr(img[0][f], img[1][f], npx);
            tree_mask(img[0][f], img[2][f], npx, mask_a);
            tree_mask(img[1][f], img[2][f], npx, mask_b);
            uint64_t diff = 0;
            for (size_t p = 0; p < npx; p++)
                diff += mask_a[p] != mask_b[p];
            sil[ncmp] = (double)diff / (double)npx;
            ncmp++;
        }
    qsort(psnr, ncmp, sizeof *psnr, cmp_d);
    qsort(sil, ncmp, sizeof *sil, cmp_d);
    double psnr_med = ncmp ? psnr[ncmp / 2] : NAN, sil_med = ncmp ? sil[ncmp / 2] : NAN;
    double sil_max = ncmp ? sil[ncmp - 1] : NAN;
    /* Image similarity per species: VMI order vs random pruning. */
    sr = calloc(cf->model_count, sizeof *sr);
    if (!sr) {
        hz_err_set(&err, HZ_ERR_MEMORY, "out of memory");
        goto done;
    }
    const uint32_t orders = bo->pr_shuffles ? bo->pr_shuffles : HZ_PR_ORDERS_DEFAULT;
    for (uint32_t m = 0; m < cf->model_count && !bo->no_pr; m++) {
        sr[m].t = cf->models[m];
        for (int k = 0; k < 4; k++) {
            hz_pr_desc d = {.views = bo->pr_views, .res = bo->pr_res, .rate = 0.5f, .enlarge = k % 2 == 1};
            if ((k < 2 ? hz_tree_pr(cf->models[m], &d, &sr[m].pr[k], &err)
                       : hz_tree_pr_random(cf->models[m], &d, orders, 12345 + 1000 * m, &sr[m].pr[k], NULL,
                                           &err)) != HZ_OK)
                goto done;
        }
        if (!o->quiet)
            cli_tree_progress(NULL, "precision/recall per species", m + 1, cf->model_count);
    }
    for (uint32_t m = 0; m < cf->model_count; m++)
        sr[m].t = cf->models[m];

    double full_ms = MEDF(RUN_FULL, frame_ms), at_full_ms = MEDF(RUN_HYST, frame_ms);
    double speedup = at_full_ms > 0 && isfinite(full_ms) ? full_ms / at_full_ms : NAN;
    double tri_full = MEDQ(RUN_HYST, tri_full), tri_drawn = MEDQ(RUN_HYST, tri_drawn);
    double terrain_ms = MED(RUN_TERRAIN, frame_ms);
    const hz_forest_params *fp = &o->forest;
    hz_rate_params rp = hz_rate_params_defaults(&fp->rate);
    const hz_forest_frame *lf = &cf->frame;
    if (!o->quiet || !bo->json_out) {
        printf("horizon bench --forest: %u trees on %s (%ux%u, %.0f m), path %s, %u frames at %ux%u\n",
               hz_forest_tree_count(cf->forest), t->source, t->hm.size, t->hm.size, (double)t->spacing, path.name,
               frames, o->width, o->height);
        printf("F3 near %.0f m, far %.0f m; leaves to %.0f m, crown hulls to %.0f m, impostors beyond "
               "(dithered over the last %.0f%%); models prepared in %.1f s\n",
               (double)rp.near_m, (double)rp.far_m, (double)lf->hull_band[1], (double)lf->impostor_band[1],
               100.0 * (1.0 - (double)(lf->hull_band[0] / lf->hull_band[1])), cf->prep_ms / 1000.0);
        printf("%-30s %12s %12s %12s %12s\n", "median (p95) over frames", "hysteresis", "no hyst.", "unsimplified",
               "terrain");
        printf("%-30s %12.1f %12.1f %12.1f %12.1f\n", "frame ms", MED(RUN_HYST, frame_ms), MED(RUN_NOHYST, frame_ms),
               full_ms, terrain_ms);
        printf("%-30s %12.1f %12.1f %12.1f %12.1f\n", "frame ms p95", P95(RUN_HYST, frame_ms),
               P95(RUN_NOHYST, frame_ms), pct(rows[RUN_FULL], NULL, frames, offsetof(frow, frame_ms), 'd', 0.95),
               P95(RUN_TERRAIN, frame_ms));
        printf("%-30s %12.1f %12.1f %12.1f %12.1f\n", "CPU ms (all threads)", MED(RUN_HYST, cpu_ms),
               MED(RUN_NOHYST, cpu_ms), MEDF(RUN_FULL, cpu_ms), MED(RUN_TERRAIN, cpu_ms));
        printf("%-30s %12.1f %12s %12.1f\n", "forest draw ms (timed apart)", MED(RUN_PARTS, draw_ms), "-",
               MEDF(RUN_FULL, draw_ms));
        printf("%-30s %12.1f\n", "  leaves", MED(RUN_PARTS, part_ms[0]));
        printf("%-30s %12.1f\n", "  bark + crown hulls", MED(RUN_PARTS, part_ms[1]));
        printf("%-30s %12.1f\n", "  impostors", MED(RUN_PARTS, part_ms[2]));
        printf("%-30s %12.2f %12.2f\n", "forest submission CPU ms", MED(RUN_HYST, draw_ms), MED(RUN_NOHYST, draw_ms));
        printf("%-30s %12.0f %12.0f %12.0f\n", "triangles drawn", tri_drawn, MEDQ(RUN_NOHYST, tri_drawn),
               MEDQ(RUN_FULL, tri_drawn));
        printf("%-30s %12.0f %12.0f %12.0f\n", "trees in frustum", MEDU(RUN_HYST, in_frustum),
               MEDU(RUN_NOHYST, in_frustum), MEDU(RUN_FULL, in_frustum));
        printf("%-30s %12.0f %12.0f %12.0f\n", "  as leaves", MEDU(RUN_HYST, leaves), MEDU(RUN_NOHYST, leaves),
               MEDU(RUN_FULL, leaves));
        printf("%-30s %12.0f %12.0f\n", "  as crown hulls", MEDU(RUN_HYST, hulls), MEDU(RUN_NOHYST, hulls));
        printf("%-30s %12.0f %12.0f\n", "  as impostors", MEDU(RUN_HYST, impostors), MEDU(RUN_NOHYST, impostors));
        printf("%-30s %12.0f %12.0f\n", "  cross-fading", MEDU(RUN_HYST, fading), MEDU(RUN_NOHYST, fading));
        printf("%-30s %12.2f %12.2f %12.2f\n", "selection CPU ms", MED(RUN_HYST, select_ms),
               MED(RUN_NOHYST, select_ms), MEDF(RUN_FULL, select_ms));
        printf("%-30s %12.0f %12.0f\n", "upload bytes/frame", MEDQ(RUN_HYST, upload), MEDQ(RUN_NOHYST, upload));
        printf("%-30s %12.0f %12.0f\n", "nodes changed/frame", MEDU(RUN_HYST, changed), MEDU(RUN_NOHYST, changed));
        printf("speedup over unsimplified on the %u sampled frames: %.1fx; simplified / bare terrain: %.2fx\n",
               ncmp, speedup, MED(RUN_HYST, frame_ms) / terrain_ms);
        printf("against unsimplified on the same frames: PSNR %.1f dB, tree silhouette error %.2f%% of pixels "
               "(max %.2f%%)\n",
               psnr_med, 100.0 * sil_med, 100.0 * sil_max);
        printf("seed (F7): 621 trees in frustum, 42.51 M -> 2.00 M triangles, 33.1 ms, 15.18x\n");
        if (!bo->no_pr) {
            printf("precision/recall of foliage coverage at 50%% simplification (%u views, %ux%u):\n",
                   sr[0].pr[0].views, sr[0].pr[0].res, sr[0].pr[0].res);
            printf("  %-12s %8s %8s | %-21s | %-21s | %9s %9s %7s\n", "species", "leaves", "tris", "VMI P/R (enlarged)",
                   "random P/R (enlarged)", "rank s", "hull tri", "MB");
            for (uint32_t m = 0; m < cf->model_count; m++) {
                const hz_tree *tr = sr[m].t;
                printf("  %-12s %8u %8llu | %.3f/%.3f (%.3f/%.3f) | %.3f/%.3f (%.3f/%.3f) | %9.1f %9u %7.1f\n",
                       tr->species, tr->leaf_count, (unsigned long long)hz_tree_triangles(tr), sr[m].pr[0].precision,
                       sr[m].pr[0].recall, sr[m].pr[1].precision, sr[m].pr[1].recall, sr[m].pr[2].precision,
                       sr[m].pr[2].recall, sr[m].pr[3].precision, sr[m].pr[3].recall, tr->rank_ms / 1000.0,
                       tr->hull.index_count / 3, (double)hz_tree_memory_bytes(tr) / 1048576.0);
            }
            printf("  the same leaf in each pixel:\n");
            for (uint32_t m = 0; m < cf->model_count; m++)
                printf("  %-12s %17s | %.3f/%.3f (%.3f/%.3f) | %.3f/%.3f (%.3f/%.3f) |\n", sr[m].t->species, "",
                       sr[m].pr[0].leaf_precision, sr[m].pr[0].leaf_recall, sr[m].pr[1].leaf_precision,
                       sr[m].pr[1].leaf_recall, sr[m].pr[2].leaf_precision, sr[m].pr[2].leaf_recall,
                       sr[m].pr[3].leaf_precision, sr[m].pr[3].leaf_recall);
            printf("  seed: VMI 0.95/0.82 and 0.96/0.88, random 0.90/0.71 and 0.92/0.78; "
                   "oak hull 133 327 -> 4 198 triangles\n");
        }
    }
    if (bo->json_out) {
        hz_outfile jof;
        FILE *jf = hz_outfile_open(&jof, bo->json_out, &err);
        if (!jf)
            goto done;
        json_t *jo = json_object();
        jx_set(jo, "bench", jx_str("forest"));
        jx_set(jo, "terrain", jx_str(t->source));
        jx_set(jo, "size", jx_int(t->hm.size));
        jx_set(jo, "path", jx_str(path.name));
        jx_set(jo, "frames", jx_int(frames));
        jx_set(jo, "width", jx_int(o->width));
        jx_set(jo, "height", jx_int(o->height));
        jx_set(jo, "trees", jx_int(hz_forest_tree_count(cf->forest)));
        jx_set(jo, "full_frames", jx_int(ncmp));
        jx_set(jo, "near_m", jx_num(rp.near_m));
        jx_set(jo, "far_m", jx_num(rp.far_m));
        jx_set(jo, "hull_dist_m", jx_num(lf->hull_band[1]));
        jx_set(jo, "impostor_dist_m", jx_num(lf->impostor_band[1]));
        jx_set(jo, "prep_s", jx_fix(cf->prep_ms / 1000.0, 2));
        jx_set(jo, "peak_rss_mb", jx_fix((double)hz_peak_rss_bytes() / 1048576.0, 1));
        static const char *const sfx[RUNS] = {"", "_no_hysteresis", "_full", "_terrain", "_parts"};
        for (int run = 0; run < RUNS; run++) {
            if (run == RUN_PARTS)
                continue;
            char key[96];
            const frow *rr = rows[run];
#define JK(name) (snprintf(key, sizeof key, "%s%s", name, sfx[run]), key)
            json_num(jo, JK("frame_ms"), pct(rr, NULL, frames, offsetof(frow, frame_ms), 'd', 0.5), 3);
            json_num(jo, JK("frame_ms_p95"), pct(rr, NULL, frames, offsetof(frow, frame_ms), 'd', 0.95), 3);
            json_num(jo, JK("cpu_ms"), pct(rr, NULL, frames, offsetof(frow, cpu_ms), 'd', 0.5), 3);
            if (run == RUN_TERRAIN)
                continue;
            /* The forest's GL time (the pass timed apart for the simplified
             * frames), and the submission's CPU time in the frames measured. */
            if (run == RUN_HYST)
                json_num(jo, "forest_draw_ms", MED(RUN_PARTS, draw_ms), 3);
            else if (run == RUN_FULL)
                json_num(jo, JK("forest_draw_ms"), pct(rr, NULL, frames, offsetof(frow, draw_ms), 'd', 0.5), 3);
            if (run != RUN_FULL)
                json_num(jo, JK("forest_submit_ms"), pct(rr, NULL, frames, offsetof(frow, draw_ms), 'd', 0.5), 3);
            json_num(jo, JK("select_ms"), pct(rr, NULL, frames, offsetof(frow, select_ms), 'd', 0.5), 3);
            json_num(jo, JK("triangles_drawn"), pct(rr, NULL, frames, offsetof(frow, tri_drawn), 'q', 0.5), 0);
            json_num(jo, JK("trees_in_frustum"), pct(rr, NULL, frames, offsetof(frow, in_frustum), 'u', 0.5), 0);
            json_num(jo, JK("trees_leaves"), pct(rr, NULL, frames, offsetof(frow, leaves), 'u', 0.5), 0);
            json_num(jo, JK("trees_hull"), pct(rr, NULL, frames, offsetof(frow, hulls), 'u', 0.5), 0);
            json_num(jo, JK("trees_impostor"), pct(rr, NULL, frames, offsetof(frow, impostors), 'u', 0.5), 0);
            json_num(jo, JK("trees_fading"), pct(rr, NULL, frames, offsetof(frow, fading), 'u', 0.5), 0);
            json_num(jo, JK("upload_bytes"), pct(rr, NULL, frames, offsetof(frow, upload), 'q', 0.5), 0);
            json_num(jo, JK("nodes_changed"), pct(rr, NULL, frames, offsetof(frow, changed), 'u', 0.5), 0);
#undef JK
        }
        static const char *const part_key[3] = {"forest_leaves_ms", "forest_hulls_ms", "forest_impostors_ms"};
        for (int k = 0; k < 3; k++)
            json_num(jo, part_key[k], MED(RUN_PARTS, part_ms[k]), 3);
        json_num(jo, "trees_detailed", MEDU(RUN_HYST, leaves), 0);
        json_num(jo, "nodes_held", MEDU(RUN_HYST, held), 0);
        json_num(jo, "triangles_full", tri_full, 0);
        json_num(jo, "drawn_ratio", tri_full > 0 ? tri_drawn / tri_full : NAN, 5);
        json_num(jo, "frame_ms_simplified_same_frames", at_full_ms, 3);
        json_num(jo, "speedup", speedup, 3);
        json_num(jo, "terrain_ratio", MED(RUN_HYST, frame_ms) / terrain_ms, 3);
        json_num(jo, "psnr_db", psnr_med, 2);
        json_num(jo, "silhouette_frac", sil_med, 5);
        json_num(jo, "silhouette_frac_max", sil_max, 5);
        json_t *spa = json_array();
        for (uint32_t m = 0; m < cf->model_count; m++) {
            const hz_tree *tr = sr[m].t;
            json_t *sp = json_object();
            jx_set(sp, "name", jx_str(tr->species));
            jx_set(sp, "leaves", jx_int(tr->leaf_count));
            jx_set(sp, "leaf_nodes", jx_int(tr->node_count));
            jx_set(sp, "branch_nodes", jx_int(tr->branch_count));
            jx_set(sp, "triangles", jx_int((long long)hz_tree_triangles(tr)));
            jx_set(sp, "hull_triangles", jx_int(tr->hull.index_count / 3));
            jx_set(sp, "rank_ms", jx_fix(tr->rank_ms, 1));
            jx_set(sp, "memory_mb", jx_fix((double)hz_tree_memory_bytes(tr) / 1048576.0, 2));
            if (!bo->no_pr) {
                const char *names[4] = {"vmi", "vmi_enlarged", "random", "random_enlarged"};
                for (int k = 0; k < 4; k++)
                    cli_pr_json(sp, names[k], &sr[m].pr[k]);
                jx_set(sp, "pr_views", jx_int(sr[m].pr[0].views));
                jx_set(sp, "pr_res", jx_int(sr[m].pr[0].res));
                jx_set(sp, "random_shuffles", jx_int(orders));
            }
            json_array_append_new(spa, sp);
        }
        jx_set(jo, "species", spa);
        const bool wrote = jx_print(jo, jf) == 0;
        if (hz_outfile_close(&jof, jf, &err) != HZ_OK)
            goto done;
        if (!wrote) {
            hz_err_set(&err, HZ_ERR_IO, "cannot write '%s'", bo->json_out);
            goto done;
        }
    }
    rc = 0;
done:
    if (rc)
        fprintf(stderr, "horizon bench: %s\n", err.msg[0] ? err.msg : "failed");
    free(sr);
    for (int r = 0; r < RUNS; r++)
        free(rows[r]);
    for (int k = 0; k < 3; k++) {
        for (uint32_t f = 0; img[k] && f < frames; f++)
            free(img[k][f]);
        free(img[k]);
    }
    free(rgb);
    free(mask_a);
    free(mask_b);
    free(psnr);
    free(sil);
    free(il.data);
    hz_path_free(&path);
    cli_forest_destroy(cf);
    hz_renderer_destroy(ren);
    hz_gl_destroy(gl);
    return rc;
}
