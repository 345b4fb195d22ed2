/* horizon bench: fly a camera path headless, measure the LOD against a
 * full-resolution reference, print a summary table and write JSON. */
#include "cli.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "horizon/metrics.h"

typedef struct frame_row {
    double t;
    uint32_t triangles, nodes_visited, nodes_culled, restricted;
    double lod_ms, upload_ms, draw_ms, frame_ms;
    double px_p99, px_max;
    uint64_t uncovered;
    double psnr, silhouette, popping;
    double pop_px_max, pop_px_mean; /* geometric popping: drawn surface change since the last frame */
    uint32_t ref_triangles;
} frame_row;

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Percentile q in [0, 1] of n values (nearest rank); INFINITY sorts last. */
static double pct(const frame_row *rows, size_t n, size_t off, double q)
{
    double *v = malloc(n * sizeof *v);
    if (!v || n == 0) {
        free(v);
        return 0;
    }
    for (size_t i = 0; i < n; i++)
        v[i] = *(const double *)((const char *)&rows[i] + off);
    qsort(v, n, sizeof *v, cmp_double);
    size_t k = (size_t)ceil(q * (double)n);
    k = k ? k - 1 : 0;
    double r = q >= 0.5 && q < 0.51 && n % 2 == 0 ? 0.5 * (v[n / 2 - 1] + v[n / 2]) : v[k < n ? k : n - 1];
    free(v);
    return r;
}

static double pct_u32(const frame_row *rows, size_t n, size_t off, double q)
{
    frame_row *tmp = malloc(n * sizeof *tmp);
    if (!tmp)
        return 0;
    for (size_t i = 0; i < n; i++)
        tmp[i].t = (double)*(const uint32_t *)((const char *)&rows[i] + off);
    double r = pct(tmp, n, offsetof(frame_row, t), q);
    free(tmp);
    return r;
}

/* JSON has no infinity: PSNR of identical images is written as null. */
static void json_num(FILE *f, double v)
{
    if (isfinite(v))
        fprintf(f, "%.6g", v);
    else
        fputs("null", f);
}

typedef struct morph_user {
    hz_lod *lod;
    const hz_camera *cam;
    const hz_lod_stats *st;
} morph_user;

static float morph_height(void *user, uint32_t index)
{
    const morph_user *u = user;
    return hz_lod_morph_height(u->lod, u->cam, u->st, index);
}

static void usage(void)
{
    fprintf(stderr, "usage: horizon bench [terrain, LOD and view options as in render] [bench options]\n"
                    "Flies a camera path headless and measures every frame.\n");
    cli_usage_terrain();
    fprintf(stderr,
            "bench:\n"
            "  --path flyover|orbit|ground|FILE.csv  camera path (CSV: t,x,y,z,yaw,pitch; default flyover)\n"
            "  --frames N              frames to measure (default 60)\n"
            "  --fps F                 path time per frame is 1/F s (default 30)\n"
            "  --reference on|off      full-resolution reference frames for PSNR/popping (default on)\n"
            "  --json FILE             write the summary and per-frame figures as JSON\n"
            "  --plot FILE.png         chart of triangles, frame ms and pixel error (needs gnuplot)\n"
            "  --save-frames DIR       write every LOD (and reference) frame as PNG\n");
}

int cmd_bench(int argc, char **argv)
{
    /* Split off bench-only options, pass the rest to the common parser. */
    const char *path_name = "flyover", *json_out = NULL, *plot_out = NULL, *save_dir = NULL;
    uint32_t frames = 60;
    float fps = 30.0f;
    bool reference = true;
    char **rest = calloc((size_t)argc + 1, sizeof *rest);
    int nrest = 0;
    if (!rest)
        return 1;
    rest[nrest++] = argv[0];
    rest[nrest++] = argv[1];
    for (int i = 2; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            usage();
            free(rest);
            return 0;
        }
        bool takes = !strcmp(a, "--path") || !strcmp(a, "--frames") || !strcmp(a, "--fps") ||
                     !strcmp(a, "--reference") || !strcmp(a, "--plot") || !strcmp(a, "--save-frames") ||
                     (!strcmp(a, "--json") && v && v[0] != '-');
        if (!takes) {
            rest[nrest++] = argv[i];
            continue;
        }
        if (!v) {
            fprintf(stderr, "horizon bench: option %s needs a value\n", a);
            free(rest);
            return 2;
        }
        i++;
        char *end;
        if (!strcmp(a, "--path"))
            path_name = v;
        else if (!strcmp(a, "--json"))
            json_out = v;
        else if (!strcmp(a, "--plot"))
            plot_out = v;
        else if (!strcmp(a, "--save-frames"))
            save_dir = v;
        else if (!strcmp(a, "--reference")) {
            if (strcmp(v, "on") && strcmp(v, "off")) {
                fprintf(stderr, "horizon bench: --reference takes on or off\n");
                free(rest);
                return 2;
            }
            reference = !strcmp(v, "on");
        } else if (!strcmp(a, "--frames")) {
            unsigned long f = strtoul(v, &end, 10);
            if (*end || end == v || f < 1 || f > 100000 || v[0] == '-') {
                fprintf(stderr, "horizon bench: invalid value '%s' for --frames: expected 1..100000\n", v);
                free(rest);
                return 2;
            }
            frames = (uint32_t)f;
        } else if (!strcmp(a, "--fps")) {
            double f = strtod(v, &end);
            if (*end || end == v || !(f >= 0.1 && f <= 10000)) {
                fprintf(stderr, "horizon bench: invalid value '%s' for --fps: expected 0.1..10000\n", v);
                free(rest);
                return 2;
            }
            fps = (float)f;
        }
    }
    cli_opts o;
    int rc = cli_parse(nrest, rest, 2, &o, "bench");
    free(rest);
    if (rc)
        return rc;
    if (o.out || o.dump_mesh) {
        fprintf(stderr, "horizon bench: --out/--dump-mesh belong to render; use --save-frames DIR\n");
        return 2;
    }

    hz_terrain *t = cli_load_terrain(&o);
    if (!t)
        return 1;
    hz_err err = {0};
    hz_path path = {0};
    size_t plen = strlen(path_name);
    hz_result pr = plen > 4 && !strcmp(path_name + plen - 4, ".csv") ? hz_path_load_csv(path_name, &path, &err)
                                                                     : hz_terrain_path(t, path_name, &path, &err);
    if (pr != HZ_OK) {
        fprintf(stderr, "horizon bench: %s\n", err.msg);
        hz_terrain_destroy(t);
        return pr == HZ_ERR_VALUE && strstr(err.msg, "unknown path") ? 2 : 1;
    }

    rc = 1;
    const size_t npx = (size_t)o.width * o.height;
    frame_row *rows = calloc(frames, sizeof *rows);
    uint8_t *img[2] = {malloc(npx * 3), malloc(npx * 3)}, *ref[2] = {malloc(npx * 3), malloc(npx * 3)};
    uint8_t *sky_l = malloc(npx), *sky_r = malloc(npx);
    hz_index_list il = {0}, rl = {0};
    hz_float_buf scratch = {0};
    float *surf[2] = {NULL, NULL};
    hz_renderer *ren = NULL;
    hz_gl *gl = NULL;
    if (!rows || !img[0] || !img[1] || !ref[0] || !ref[1] || !sky_l || !sky_r) {
        hz_err_set(&err, HZ_ERR_MEMORY, "out of memory");
        goto done;
    }
    if (reference) {
        const size_t ns = (size_t)t->hm.size * t->hm.size;
        surf[0] = malloc(ns * sizeof(float));
        surf[1] = malloc(ns * sizeof(float));
        if (!surf[0] || !surf[1]) {
            hz_err_set(&err, HZ_ERR_MEMORY, "out of memory for the surface buffers (use --reference off)");
            goto done;
        }
    }
    gl = hz_gl_create_headless(&err);
    if (!gl)
        goto done;
    ren = hz_renderer_create(&(hz_renderer_desc){.width = o.width, .height = o.height}, &err);
    if (!ren || cli_renderer_setup(ren, t, &o, &err) != HZ_OK)
        goto done;

    hz_camera cam = cli_camera(&o, t);
    /* Full resolution inside the frustum: every node splits down to 3x3. */
    hz_lod_params refp = {.c = 1e30f, .c2 = 1e30f, .criterion = HZ_LOD_CLAMPED};
    /* One untimed warm-up frame: buffer allocation and shader compilation in
     * llvmpipe happen on the first draw, not in steady state. */
    hz_path_sample(&path, 0.0f, &cam);
    hz_lod_stats st0;
    hz_scene_params sp0 = {0};
    if (hz_lod_select(t->lod, &cam, &o.lod, &il, NULL, NULL, &st0) != HZ_OK)
        goto done;
    cli_scene_lod(&sp0, &st0);
    if (hz_renderer_draw(ren, &cam, &sp0, il.data, (uint32_t)il.count, NULL, &err) != HZ_OK)
        goto done;
    double t_start = hz_time_ms(), last_progress = t_start;
    for (uint32_t f = 0; f < frames; f++) {
        frame_row *row = &rows[f];
        row->t = (double)f / fps;
        hz_path_sample(&path, (float)row->t, &cam);
        double f0 = hz_time_ms();
        hz_lod_stats st;
        if (hz_lod_select(t->lod, &cam, &o.lod, &il, NULL, NULL, &st) != HZ_OK) {
            hz_err_set(&err, HZ_ERR_MEMORY, "LOD selection out of memory");
            goto done;
        }
        hz_draw_stats ds;
        hz_scene_params sp = {0};
        cli_scene_lod(&sp, &st);
        if (hz_renderer_draw(ren, &cam, &sp, il.data, (uint32_t)il.count, &ds, &err) != HZ_OK)
            goto done;
        row->frame_ms = hz_time_ms() - f0;
        row->triangles = st.triangles;
        row->nodes_visited = st.nodes_visited;
        row->nodes_culled = st.nodes_culled;
        row->restricted = st.restricted;
        row->lod_ms = st.ms;
        row->upload_ms = ds.upload_ms;
        row->draw_ms = ds.draw_ms;
        uint8_t *cur = img[f & 1], *prev = img[(f + 1) & 1];
        if (hz_renderer_read_rgb(ren, cur, &err) != HZ_OK || hz_renderer_read_sky_mask(ren, sky_l, &err) != HZ_OK)
            goto done;
        hz_px_error pe;
        morph_user mu = {t->lod, &cam, &st};
        if (hz_metrics_px_error_ex(&t->hm, t->spacing, t->zscale, il.data, il.count,
                                   st.morph_scale > 0 ? morph_height : NULL, &mu, &cam, o.height, &scratch,
                                   &pe) != HZ_OK) {
            hz_err_set(&err, HZ_ERR_MEMORY, "pixel error out of memory");
            goto done;
        }
        row->px_p99 = pe.p99_px;
        row->px_max = pe.max_px;
        row->uncovered = pe.uncovered;
        char name[1024];
        if (save_dir) {
            snprintf(name, sizeof name, "%s/lod_%04u.png", save_dir, f);
            if (hz_image_write_png(name, cur, o.width, o.height, &err) != HZ_OK)
                goto done;
        }
        if (reference) {
            uint8_t *rcur = ref[f & 1], *rprev = ref[(f + 1) & 1];
            hz_lod_stats rs;
            if (hz_lod_select(t->lod, &cam, &refp, &rl, NULL, NULL, &rs) != HZ_OK) {
                hz_err_set(&err, HZ_ERR_MEMORY, "reference selection out of memory");
                goto done;
            }
            row->ref_triangles = rs.triangles;
            if (hz_renderer_draw(ren, &cam, NULL, rl.data, (uint32_t)rl.count, NULL, &err) != HZ_OK ||
                hz_renderer_read_rgb(ren, rcur, &err) != HZ_OK ||
                hz_renderer_read_sky_mask(ren, sky_r, &err) != HZ_OK)
                goto done;
            float *scur = surf[f & 1], *sprev = surf[(f + 1) & 1];
            hz_metrics_surface(&t->hm, t->zscale, il.data, il.count, st.morph_scale > 0 ? morph_height : NULL, &mu,
                               scur);
            if (f) {
                hz_pop_stats ps;
                hz_metrics_surface_change(&t->hm, t->spacing, t->zscale, sprev, scur, &cam, o.height, &ps);
                row->pop_px_max = ps.max_px;
                row->pop_px_mean = ps.mean_px;
            }
            row->psnr = hz_metrics_psnr(cur, rcur, npx);
            row->silhouette = hz_metrics_silhouette(sky_l, sky_r, npx);
            row->popping = f ? hz_metrics_popping(prev, cur, rprev, rcur, npx) : 0.0;
            if (save_dir) {
                snprintf(name, sizeof name, "%s/ref_%04u.png", save_dir, f);
                if (hz_image_write_png(name, rcur, o.width, o.height, &err) != HZ_OK)
                    goto done;
            }
        }
        double now = hz_time_ms();
        if (!o.quiet && (now - last_progress > 200 || f + 1 == frames) && now - t_start > 1000) {
            hz_progress_stderr(NULL, "bench frames", f + 1, frames);
            last_progress = now;
        }
    }

    /* Summary. */
    const size_t n = frames;
    /* Popping is defined from the second frame on. */
    const frame_row *pop_rows = n > 1 ? rows + 1 : rows;
    const size_t pop_n = n > 1 ? n - 1 : n;
    double bps = hz_lod_bytes_per_sample(t->lod), rss = (double)hz_peak_rss_bytes() / 1048576.0;
#define OFF(f) offsetof(frame_row, f)
    struct {
        const char *name;
        size_t off;
        bool u32;
        const frame_row *r;
        size_t n;
    } cols[] = {
        {"triangles", OFF(triangles), true, rows, n},
        {"nodes_visited", OFF(nodes_visited), true, rows, n},
        {"nodes_culled", OFF(nodes_culled), true, rows, n},
        {"lod_ms", OFF(lod_ms), false, rows, n},
        {"upload_ms", OFF(upload_ms), false, rows, n},
        {"draw_ms", OFF(draw_ms), false, rows, n},
        {"frame_ms", OFF(frame_ms), false, rows, n},
        {"px_error_p99", OFF(px_p99), false, rows, n},
        {"px_error_max", OFF(px_max), false, rows, n},
        {"psnr_db", OFF(psnr), false, rows, n},
        {"silhouette_frac", OFF(silhouette), false, rows, n},
        {"popping", OFF(popping), false, pop_rows, pop_n},
        {"pop_px_max", OFF(pop_px_max), false, pop_rows, pop_n},
        {"pop_px_mean", OFF(pop_px_mean), false, pop_rows, pop_n},
    };
    const size_t ncols = reference ? sizeof cols / sizeof *cols : 9;
    double summ[sizeof cols / sizeof *cols][3];
    for (size_t c = 0; c < ncols; c++) {
        double (*fn)(const frame_row *, size_t, size_t, double) = cols[c].u32 ? pct_u32 : pct;
        summ[c][0] = fn(cols[c].r, cols[c].n, cols[c].off, 0.5);
        summ[c][1] = fn(cols[c].r, cols[c].n, cols[c].off, 0.95);
        summ[c][2] = fn(cols[c].r, cols[c].n, cols[c].off, 1.0);
    }
    if (!o.quiet || !json_out) {
        char lodtxt[128];
        if (o.lod.pixel_error > 0 || o.lod.mode == HZ_LOD_ROAM || o.lod.mode == HZ_LOD_CDLOD)
            snprintf(lodtxt, sizeof lodtxt, "%s, pixel error %g", hz_lod_mode_name(o.lod.mode),
                     (double)(o.lod.pixel_error > 0 ? o.lod.pixel_error : 1.0f));
        else
            snprintf(lodtxt, sizeof lodtxt, "%s, C=%g C2=%g", hz_lod_mode_name(o.lod.mode),
                     (double)(o.lod.c > 0 ? o.lod.c : 25), (double)(o.lod.c2 > 0 ? o.lod.c2 : 2.5f));
        printf("horizon bench: %s (%ux%u, %.1f m), path %s, %u frames at %ux%u, %s%s\n", t->source, t->hm.size,
               t->hm.size, (double)t->spacing, path.name, frames, o.width, o.height, lodtxt,
               reference ? "" : ", no reference");
        printf("%-18s %12s %12s %12s\n", "", "median", "p95", "max");
        for (size_t c = 0; c < ncols; c++)
            printf("%-18s %12.4g %12.4g %12.4g\n", cols[c].name, summ[c][0], summ[c][1], summ[c][2]);
        printf("%-18s %12.3f\n%-18s %12.1f\n", "bytes_per_sample", bps, "peak_rss_mb", rss);
    }
    if (json_out) {
        FILE *jf = fopen(json_out, "w");
        if (!jf) {
            hz_err_set(&err, HZ_ERR_IO, "cannot write '%s'", json_out);
            goto done;
        }
        fprintf(jf, "{\"frames\":%u,\"terrain\":\"%s\",\"size\":%u,\"spacing\":%g,\"lod_mode\":\"%s\","
                    "\"pixel_error\":%g,\"criterion\":\"%s\",\"lod_c\":%g,\"lod_c2\":%g,\"path\":\"%s\",\"fps\":%g,"
                    "\"width\":%u,\"height\":%u,\"fov\":%g,\"far\":%g,\"reference\":%s,",
                frames, t->source, t->hm.size, (double)t->spacing, hz_lod_mode_name(o.lod.mode),
                (double)o.lod.pixel_error,
                o.lod.criterion == HZ_LOD_UNCLAMPED ? "unclamped" : "clamped",
                (double)(o.lod.c > 0 ? o.lod.c : 25), (double)(o.lod.c2 > 0 ? o.lod.c2 : 2.5f), path.name,
                (double)fps, o.width, o.height, (double)cam.fov_y, (double)cam.zfar, reference ? "true" : "false");
        for (size_t c = 0; c < ncols; c++) {
            const char *nm = cols[c].name;
            if (!strcmp(nm, "silhouette_frac") || !strcmp(nm, "popping")) {
                /* the keys: mean over frames */
                double s = 0;
                for (size_t i = 0; i < cols[c].n; i++)
                    s += *(const double *)((const char *)&cols[c].r[i] + cols[c].off);
                fprintf(jf, "\"%s\":", nm);
                json_num(jf, cols[c].n ? s / (double)cols[c].n : 0);
                fprintf(jf, ",\"%s_max\":", nm);
                json_num(jf, summ[c][2]);
                fputc(',', jf);
                continue;
            }
            fprintf(jf, "\"%s_median\":", nm);
            json_num(jf, summ[c][0]);
            fprintf(jf, ",\"%s_p95\":", nm);
            json_num(jf, summ[c][1]);
            fprintf(jf, ",\"%s_max\":", nm);
            json_num(jf, summ[c][2]);
            fputc(',', jf);
        }
        if (!reference)
            fputs("\"psnr_db_median\":null,\"silhouette_frac\":null,\"popping\":null,\"pop_px_max_median\":null,", jf);
        /* px_error_p99 / px_error_max as top-level keys (p95 over frames of the
         * per-frame p99, and the max over all frames). */
        fprintf(jf, "\"px_error_p99\":");
        json_num(jf, summ[7][1]);
        fprintf(jf, ",\"px_error_max\":");
        json_num(jf, summ[8][2]);
        fprintf(jf, ",\"bytes_per_sample\":%.4f,\"peak_rss_mb\":%.1f,\"per_frame\":[", bps, rss);
        for (size_t i = 0; i < n; i++) {
            const frame_row *r = &rows[i];
            fprintf(jf, "%s{\"t\":%.4f,\"triangles\":%u,\"nodes_visited\":%u,\"nodes_culled\":%u,"
                        "\"restricted\":%u,\"lod_ms\":%.4f,\"upload_ms\":%.4f,\"draw_ms\":%.3f,\"frame_ms\":%.3f,"
                        "\"px_error_p99\":%.5g,\"px_error_max\":%.5g,\"uncovered\":%llu",
                    i ? "," : "", r->t, r->triangles, r->nodes_visited, r->nodes_culled, r->restricted, r->lod_ms,
                    r->upload_ms, r->draw_ms, r->frame_ms, r->px_p99, r->px_max, (unsigned long long)r->uncovered);
            if (reference) {
                fprintf(jf, ",\"ref_triangles\":%u,\"psnr_db\":", r->ref_triangles);
                json_num(jf, r->psnr);
                fprintf(jf, ",\"silhouette_frac\":%.6g,\"popping\":%.6g,\"pop_px_max\":%.6g,\"pop_px_mean\":%.6g",
                        r->silhouette, r->popping, r->pop_px_max, r->pop_px_mean);
            }
            fputc('}', jf);
        }
        fputs("]}\n", jf);
        if (fclose(jf) != 0) {
            hz_err_set(&err, HZ_ERR_IO, "cannot write '%s'", json_out);
            goto done;
        }
    }
    if (plot_out) {
        char dat[1100];
        snprintf(dat, sizeof dat, "%s.dat", plot_out);
        FILE *df = fopen(dat, "w");
        if (!df) {
            hz_err_set(&err, HZ_ERR_IO, "cannot write '%s'", dat);
            goto done;
        }
        for (size_t i = 0; i < n; i++)
            fprintf(df, "%u %u %.3f %.4f\n", (unsigned)i, rows[i].triangles, rows[i].frame_ms, rows[i].px_p99);
        fclose(df);
        char cmd[4096];
        snprintf(cmd, sizeof cmd,
                 "gnuplot -e \"set terminal pngcairo size 1000,700 noenhanced; set output '%s'; set multiplot layout 3,1 title '%s %s'; "
                 "set xlabel 'frame'; set ylabel 'triangles'; plot '%s' using 1:2 with lines notitle; "
                 "set ylabel 'frame ms'; plot '%s' using 1:3 with lines notitle; "
                 "set ylabel 'px error p99'; plot '%s' using 1:4 with lines notitle; unset multiplot\"",
                 plot_out, t->source, path.name, dat, dat, dat);
        if (system(cmd) != 0) {
            hz_err_set(&err, HZ_ERR_IO, "gnuplot failed or is not installed (apt-get install gnuplot-nox); data in %s",
                       dat);
            goto done;
        }
        remove(dat);
    }
    rc = 0;
done:
    if (rc)
        fprintf(stderr, "horizon bench: %s\n", err.msg[0] ? err.msg : "failed");
    hz_renderer_destroy(ren);
    hz_gl_destroy(gl);
    free(rows);
    free(img[0]);
    free(img[1]);
    free(ref[0]);
    free(ref[1]);
    free(sky_l);
    free(sky_r);
    free(il.data);
    free(rl.data);
    free(scratch.data);
    free(surf[0]);
    free(surf[1]);
    hz_path_free(&path);
    hz_terrain_destroy(t);
    return rc;
}
