/* horizon bench --forest: the seed's forest table (SPEC F7). Flies a path
 * over a forest and measures, in the same run, simplified frames with and
 * without hysteresis and unsimplified frames (on a subset: they are slow in
 * software GL), then precision/recall of every species' VMI order against
 * random pruning. */
#include "bench_forest.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "horizon/safety.h"

typedef struct frow {
    double frame_ms, frame_ms_nohyst, frame_ms_full, frame_ms_at_full;
    double forest_ms, select_ms;
    uint32_t in_frustum, detailed, hulls, changed, held, changed_nohyst;
    uint64_t tri_full, tri_drawn, tri_drawn_nohyst;
    bool has_full;
} frow;

static int cmp_d(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Median of a field over rows (only rows with has_full when full_only). */
static double med(const frow *r, size_t n, size_t off, bool is_u64, bool is_u32, bool full_only)
{
    double *v = malloc((n ? n : 1) * sizeof *v);
    size_t m = 0;
    for (size_t i = 0; i < n; i++) {
        if (full_only && !r[i].has_full)
            continue;
        const char *p = (const char *)&r[i] + off;
        v[m++] = is_u64 ? (double)*(const uint64_t *)p : is_u32 ? (double)*(const uint32_t *)p : *(const double *)p;
    }
    double res = 0;
    if (m) {
        qsort(v, m, sizeof *v, cmp_d);
        res = m % 2 ? v[m / 2] : 0.5 * (v[m / 2 - 1] + v[m / 2]);
    }
    free(v);
    return res;
}

#define MD(f) med(rows, frames, offsetof(frow, f), false, false, false)
#define MD64(f) med(rows, frames, offsetof(frow, f), true, false, false)
#define MD32(f) med(rows, frames, offsetof(frow, f), false, true, false)
#define MDF(f) med(rows, frames, offsetof(frow, f), false, false, true)

typedef struct species_row {
    const hz_tree *t;
    hz_pr_result pr[4]; /* vmi, vmi enlarged, random, random enlarged */
} species_row;

/* One frame: terrain LOD + forest selection + draw. */
static bool frame(hz_renderer *ren, const hz_terrain *t, cli_opts *o, cli_forest *cf, const hz_camera *cam,
                  const hz_forest_params *fp, double now, hz_index_list *il, double *ms, hz_err *err)
{
    double t0 = hz_time_ms();
    hz_lod_stats st;
    if (hz_lod_select(t->lod, cam, &o->lod, il, NULL, NULL, &st) != HZ_OK) {
        hz_err_set(err, HZ_ERR_MEMORY, "LOD selection out of memory");
        return false;
    }
    if (hz_forest_update(cf->forest, cam, fp, now, &cf->frame, err) != HZ_OK)
        return false;
    hz_scene_params sp = {0};
    cli_scene_lod(&sp, &st);
    cli_forest_hook(cf, &sp);
    if (hz_renderer_draw(ren, cam, &sp, il->data, (uint32_t)il->count, NULL, err) != HZ_OK)
        return false;
    if (cf->hook.failed) {
        *err = cf->hook.err;
        return false;
    }
    *ms = hz_time_ms() - t0;
    return true;
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
    frow *rows = calloc(bo->frames, sizeof *rows);
    species_row *sr = NULL;
    uint8_t *rgb = malloc((size_t)o->width * o->height * 3);
    const uint32_t frames = bo->frames;
    if (!rows || !rgb) {
        hz_err_set(&err, HZ_ERR_MEMORY, "out of memory");
        goto done;
    }
    gl = hz_gl_create_headless(&err);
    if (!gl)
        goto done;
    ren = hz_renderer_create(&(hz_renderer_desc){.width = o->width, .height = o->height}, &err);
    if (!ren || cli_renderer_setup(ren, t, o, &err) != HZ_OK)
        goto done;
    cf = cli_forest_create(o, t);
    if (!cf) {
        hz_err_set(&err, HZ_ERR_VALUE, "no forest");
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
    if (!o->far)
        cam.zfar = 6000.0f;
    cam.znear = 0.3f;
    hz_forest_params with = o->forest, without = o->forest, full = o->forest;
    with.hysteresis = true;
    without.hysteresis = false;
    full.simplify = false;
    const uint32_t every = bo->full_every ? bo->full_every : (frames >= 6 ? frames / 6 : 1);
    /* Warm-up (shader compilation, buffer growth). */
    hz_path_sample(&path, 0.0f, &cam);
    double ms;
    if (!frame(ren, t, o, cf, &cam, &with, 0.0, &il, &ms, &err))
        goto done;
    /* 2 frames per path second unless --fps was given: the camera moves a
     * few metres between frames (across the forest in a 36-frame run), and
     * the hysteresis still sees consecutive frames. */
    const double dt = 1.0 / (bo->fps > 0 ? bo->fps : 2.0);
    /* Run 0: simplified with hysteresis; 1: without; 2: unsimplified on
     * every `every`-th frame. Separate runs, so that one does not disturb
     * the other's caches. */
    for (int run = 0; run < 3; run++) {
        if (run == 2 && bo->no_full)
            break;
        hz_forest_reset(cf->forest);
        for (uint32_t f = 0; f < frames; f++) {
            frow *r = &rows[f];
            if (run == 2 && f % every != 0)
                continue;
            double now = (double)f * dt;
            hz_path_sample(&path, (float)now, &cam);
            const hz_forest_params *fp = run == 0 ? &with : run == 1 ? &without : &full;
            if (!frame(ren, t, o, cf, &cam, fp, now, &il, &ms, &err))
                goto done;
            const hz_forest_frame *fr = &cf->frame;
            if (run == 0) {
                r->frame_ms = ms;
                r->forest_ms = cf->hook.draw_ms;
                r->select_ms = fr->select_ms;
                r->in_frustum = fr->trees_in_frustum;
                r->detailed = fr->trees_detailed;
                r->hulls = fr->trees_hull;
                r->tri_full = fr->triangles_full;
                r->tri_drawn = fr->triangles_drawn;
                r->changed = fr->nodes_changed;
                r->held = fr->nodes_held;
            } else if (run == 1) {
                r->frame_ms_nohyst = ms;
                r->tri_drawn_nohyst = fr->triangles_drawn;
                r->changed_nohyst = fr->nodes_changed;
            } else {
                r->frame_ms_at_full = r->frame_ms;
                r->frame_ms_full = ms;
                r->has_full = true;
            }
            if (bo->save_dir && run != 1) {
                char name[1024];
                snprintf(name, sizeof name, "%s/forest_%s%04u.png", bo->save_dir, run == 2 ? "full_" : "", f);
                if (hz_renderer_read_rgb(ren, rgb, &err) != HZ_OK ||
                    hz_image_write_png(name, rgb, o->width, o->height, &err) != HZ_OK)
                    goto done;
            }
            if (!o->quiet)
                hz_progress_stderr(NULL, run == 0 ? "forest frames (hysteresis)" : run == 1 ? "forest frames (no hysteresis)"
                                                                                   : "forest frames (unsimplified)",
                                   f + 1, frames);
        }
    }
    /* Image similarity per species: VMI order vs random pruning. */
    sr = calloc(cf->model_count, sizeof *sr);
    if (!sr) {
        hz_err_set(&err, HZ_ERR_MEMORY, "out of memory");
        goto done;
    }
    for (uint32_t m = 0; m < cf->model_count && !bo->no_pr; m++) {
        sr[m].t = cf->models[m];
        hz_tree *rnd = hz_tree_shuffled(cf->models[m], 12345 + m, &err);
        if (!rnd)
            goto done;
        for (int k = 0; k < 4; k++) {
            hz_pr_desc d = {.views = bo->pr_views, .res = bo->pr_res, .rate = 0.5f, .enlarge = k % 2 == 1};
            if (hz_tree_pr(k < 2 ? cf->models[m] : rnd, &d, &sr[m].pr[k], &err) != HZ_OK) {
                hz_tree_destroy(rnd);
                goto done;
            }
        }
        hz_tree_destroy(rnd);
        if (!o->quiet)
            hz_progress_stderr(NULL, "precision/recall per species", m + 1, cf->model_count);
    }
    for (uint32_t m = 0; m < cf->model_count; m++)
        sr[m].t = cf->models[m];

    double full_ms = MDF(frame_ms_full), at_full_ms = MDF(frame_ms_at_full);
    double speedup = at_full_ms > 0 ? full_ms / at_full_ms : 0;
    double tri_full = MD64(tri_full), tri_drawn = MD64(tri_drawn);
    const hz_forest_params *fp = &o->forest;
    hz_rate_params rp = hz_rate_params_defaults(&fp->rate);
    float hull_dist = fp->hull_dist > 0 ? fp->hull_dist : 0.5f * rp.far_m;
    if (!o->quiet || !bo->json_out) {
        printf("horizon bench --forest: %u trees on %s (%ux%u, %.0f m), path %s, %u frames at %ux%u\n",
               hz_forest_tree_count(cf->forest), t->source, t->hm.size, t->hm.size, (double)t->spacing, path.name,
               frames, o->width, o->height);
        printf("F3 near %.0f m, far %.0f m, hulls beyond %.0f m; models prepared in %.1f s\n", (double)rp.near_m,
               (double)rp.far_m, (double)hull_dist, cf->prep_ms / 1000.0);
        printf("%-34s %14s %14s\n", "", "this run", "seed (F7)");
        printf("%-34s %14u %14s\n", "trees", hz_forest_tree_count(cf->forest), "1 660");
        printf("%-34s %14.0f %14s\n", "trees in frustum (median)", MD32(in_frustum), "621");
        printf("%-34s %14.0f %14s\n", "  of them crown hulls", MD32(hulls), "");
        printf("%-34s %14.0f %14s\n", "triangles, full", tri_full, "42.51 M");
        printf("%-34s %14.0f %14s\n", "triangles, drawn", tri_drawn, "2.00 M");
        printf("%-34s %13.1f%% %14s\n", "drawn / full", tri_full > 0 ? 100.0 * tri_drawn / tri_full : 0.0, "4.7%");
        printf("%-34s %14.1f %14s\n", "frame ms, simplified (hysteresis)", MD(frame_ms), "33.1");
        printf("%-34s %14.1f %14s\n", "frame ms, simplified (no hyst.)", MD(frame_ms_nohyst), "");
        printf("%-34s %14.1f %14s\n", "frame ms, unsimplified (sampled)", full_ms, "");
        printf("%-34s %13.2fx %14s\n", "speedup on the sampled frames", speedup, "15.18x");
        printf("%-34s %14.0f %14s\n", "nodes changed/frame (hyst./none)", MD32(changed), "");
        printf("%-34s %14.0f %14s\n", "", MD32(changed_nohyst), "");
        if (!bo->no_pr) {
            printf("precision/recall of leaf coverage at 50%% simplification (%u views, %ux%u):\n",
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
            printf("  seed: VMI 0.95/0.82 and 0.96/0.88, random 0.90/0.71 and 0.92/0.78; "
                   "oak hull 133 327 -> 4 198 triangles\n");
        }
    }
    if (bo->json_out) {
        hz_outfile jof;
        FILE *jf = hz_outfile_open(&jof, bo->json_out, &err);
        if (!jf)
            goto done;
        fprintf(jf,
                "{\"bench\":\"forest\",\"terrain\":\"%s\",\"size\":%u,\"path\":\"%s\",\"frames\":%u,\"width\":%u,"
                "\"height\":%u,\"trees\":%u,\"trees_in_frustum\":%.0f,\"trees_hull\":%.0f,\"trees_detailed\":%.0f,"
                "\"triangles_full\":%.0f,\"triangles_drawn\":%.0f,\"drawn_ratio\":%.5f,"
                "\"triangles_drawn_no_hysteresis\":%.0f,\"frame_ms\":%.3f,\"frame_ms_no_hysteresis\":%.3f,"
                "\"frame_ms_full\":%.3f,\"frame_ms_simplified_same_frames\":%.3f,\"full_frames\":%u,"
                "\"speedup\":%.3f,\"forest_draw_ms\":%.3f,\"select_ms\":%.3f,\"nodes_changed\":%.0f,"
                "\"nodes_changed_no_hysteresis\":%.0f,\"nodes_held\":%.0f,\"near_m\":%g,\"far_m\":%g,"
                "\"hull_dist_m\":%g,\"prep_s\":%.2f,\"peak_rss_mb\":%.1f,\"species\":[",
                t->source, t->hm.size, path.name, frames, o->width, o->height, hz_forest_tree_count(cf->forest),
                MD32(in_frustum), MD32(hulls), MD32(detailed), tri_full, tri_drawn,
                tri_full > 0 ? tri_drawn / tri_full : 0.0, MD64(tri_drawn_nohyst), MD(frame_ms), MD(frame_ms_nohyst),
                full_ms, at_full_ms, (frames + every - 1) / every, speedup, MD(forest_ms), MD(select_ms),
                MD32(changed), MD32(changed_nohyst), MD32(held), (double)rp.near_m, (double)rp.far_m,
                (double)hull_dist, cf->prep_ms / 1000.0, (double)hz_peak_rss_bytes() / 1048576.0);
        for (uint32_t m = 0; m < cf->model_count; m++) {
            const hz_tree *tr = sr[m].t;
            fprintf(jf,
                    "%s{\"name\":\"%s\",\"leaves\":%u,\"leaf_nodes\":%u,\"branch_nodes\":%u,\"triangles\":%llu,"
                    "\"hull_triangles\":%u,\"rank_ms\":%.1f,\"memory_mb\":%.2f",
                    m ? "," : "", tr->species, tr->leaf_count, tr->node_count, tr->branch_count,
                    (unsigned long long)hz_tree_triangles(tr), tr->hull.index_count / 3, tr->rank_ms,
                    (double)hz_tree_memory_bytes(tr) / 1048576.0);
            if (!bo->no_pr) {
                const char *names[4] = {"vmi", "vmi_enlarged", "random", "random_enlarged"};
                for (int k = 0; k < 4; k++)
                    fprintf(jf, ",\"%s_precision\":%.4f,\"%s_recall\":%.4f,\"%s_f\":%.4f", names[k],
                            sr[m].pr[k].precision, names[k], sr[m].pr[k].recall, names[k], sr[m].pr[k].f_measure);
                fprintf(jf, ",\"pr_views\":%u,\"pr_res\":%u", sr[m].pr[0].views, sr[m].pr[0].res);
            }
            fputc('}', jf);
        }
        fputs("]}\n", jf);
        if (hz_outfile_close(&jof, jf, &err) != HZ_OK)
            goto done;
    }
    rc = 0;
done:
    if (rc)
        fprintf(stderr, "horizon bench: %s\n", err.msg[0] ? err.msg : "failed");
    free(sr);
    free(rows);
    free(rgb);
    free(il.data);
    hz_path_free(&path);
    cli_forest_destroy(cf);
    hz_renderer_destroy(ren);
    hz_gl_destroy(gl);
    return rc;
}
