/* horizon bench: fly a camera path headless, measure the LOD against a
 * full-resolution reference, print a summary table and write JSON.
 *
 * With several modes (--lod quadtree,cdlod,...) every mode flies the same
 * path and is compared with the same reference frames, rendered once; with
 * --tune-p99 PX each mode first searches the largest pixel error bound whose
 * 99th-percentile screen-space error stays within PX. */
#include "cli.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "horizon/safety.h"

#include "bench_forest.h"
#include "horizon/lightmap.h"
#include "horizon/metrics.h"

typedef struct frame_row {
    double t;
    uint32_t triangles, nodes_visited, nodes_culled, nodes_hidden, restricted, nodes_drawn, nodes_still, nodes_simple;
    double lod_ms, upload_ms, draw_ms, frame_ms, upload_kb;
    double cull_ms, cull_wait_ms; /* a late horizon cull: its CPU time on its thread, the draw's wait for it */
    double px_p99, px_max;
    uint64_t uncovered;
    double psnr, silhouette, popping;
    double pop_px_max, pop_px_mean; /* geometric popping: drawn surface change since the last frame */
    uint32_t ref_triangles;
    uint64_t ref_hash;  /* FNV-1a of the reference image this frame was compared with */
    double sky_frac;    /* fraction of the LOD frame's pixels that are sky */
    bool lit_map;       /* the terrain read its lit map (hz_draw_stats) */
    bool lit_vertex;    /* ... per vertex */
    uint32_t lit_vertex_patches; /* patches that read it per vertex */
    double lit_bake_ms; /* the frame baked it first (in upload_ms) */
} frame_row;

static uint64_t fnv1a(const uint8_t *p, size_t n)
{
    uint64_t h = 0xcbf29ce484222325ULL;
    for (size_t i = 0; i < n; i++)
        h = (h ^ p[i]) * 0x100000001b3ULL;
    return h;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Percentile q in [0, 1] of n values (nearest rank; the median of an even
 * count is the mean of the middle two); INFINITY sorts last. */
static double pct_values(double *v, size_t n, double q)
{
    if (n == 0)
        return 0;
    qsort(v, n, sizeof *v, cmp_double);
    size_t k = (size_t)ceil(q * (double)n);
    k = k ? k - 1 : 0;
    return q >= 0.5 && q < 0.51 && n % 2 == 0 ? 0.5 * (v[n / 2 - 1] + v[n / 2]) : v[k < n ? k : n - 1];
}

static double pct(const frame_row *rows, size_t n, size_t off, bool u32, double q)
{
    double *v = malloc((n ? n : 1) * sizeof *v);
    if (!v)
        return 0;
    for (size_t i = 0; i < n; i++) {
        const char *p = (const char *)&rows[i] + off;
        v[i] = u32 ? (double)*(const uint32_t *)p : *(const double *)p;
    }
    double r = pct_values(v, n, q);
    free(v);
    return r;
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
    cli_usage_forest();
    city_cli_usage();
    fprintf(stderr,
            "bench:\n"
            "  --path flyover|orbit|ground|FILE.csv  camera path (CSV: t,x,y,z,yaw,pitch; default flyover)\n"
            "  --frames N              frames to measure (default 60)\n"
            "  --fps F                 path time per frame is 1/F s (default 30)\n"
            "  --lod M1,M2,...         compare several LOD modes on the same path and reference frames\n"
            "  --tune-p99 PX           per mode, use the largest --pixel-error whose 99th-percentile\n"
            "                          screen-space error (p95 over frames) stays <= PX\n"
            "  --tune-silhouette F     per mode, use the largest --pixel-error whose median silhouette\n"
            "                          error against the reference (fraction of pixels) stays <= F\n"
            "  --tune-psnr DB          ... whose median PSNR against the reference stays >= DB (with\n"
            "                          --tune-silhouette: both)\n"
            "  --reference on|off      full-resolution reference frames for PSNR/popping (default on):\n"
            "                          every cell of the grid as two triangles, no LOD, no culling\n"
            "  --metrics on|off        the exact per-frame screen-space error (default on; off for\n"
            "                          speed runs: it costs ~0.2 s per frame outside frame_ms)\n"
            "  --json FILE             write the summary and per-frame figures as JSON\n"
            "  --plot FILE.png         chart of triangles, frame ms and pixel error (needs gnuplot)\n"
            "  --save-frames DIR       write every LOD (and reference) frame as PNG\n"
            "forest bench (with --forest N; path default: forest, just above the crowns; --fps default 2):\n"
            "  --full-every N          also draw every N-th frame unsimplified (default frames/6)\n"
            "  --no-full               no unsimplified frames\n"
            "  --no-pr                 skip the per-species precision/recall\n"
            "  --pr-views N --pr-res N views (default 16) and image size (default 512) for it\n"
            "  --pr-shuffles N         random orders pooled into the random-pruning figures (default 4)\n"
            "effects:\n"
            "  --effect-costs FILE     instead of the above: the frame-time cost of each effect along\n"
            "                          the path (none, each alone, all, all but each) and the light\n"
            "                          map build time, as JSON\n"
            "The reference frames get the same effects as the LOD frames (their own motion blur\n"
            "history, the same effect time and the same reflection terrain).\n");
}

static int cmp_d(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median_of(double *v, size_t n)
{
    if (n == 0)
        return 0;
    qsort(v, n, sizeof *v, cmp_d);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* --effect-costs: every frame of the path is drawn once per configuration
 * (interleaved, so slow drift of the machine hits all alike); a cost is the
 * median over frames of the per-frame difference. */
static int effect_costs(const cli_opts *o, hz_terrain *t, hz_renderer *ren, app_fx *afx, const hz_path *path,
                        uint32_t frames, float fps, const char *json_out, const char *gl_desc)
{
    enum { NCFG = 2 + 2 * HZ_FX_COUNT };
    uint32_t cfg[NCFG];
    cfg[0] = 0;
    cfg[1] = HZ_FX_ALL;
    for (uint32_t k = 0; k < HZ_FX_COUNT; k++) {
        cfg[2 + k] = 1u << k;
        cfg[2 + HZ_FX_COUNT + k] = HZ_FX_ALL & ~(1u << k);
    }
    double *ms = calloc((size_t)NCFG * frames, sizeof *ms), *tmp = calloc(frames, sizeof *tmp);
    hz_index_list il = {0};
    hz_err err = {0};
    int rc = 1;
    if (!ms || !tmp)
        goto out;
    hz_camera cam = cli_camera(o, t);
    for (uint32_t f = 0; f < frames; f++) {
        double time = (double)f / fps + o->time;
        hz_path_sample(path, (float)((double)f / fps), &cam);
        hz_lod_stats st;
        if (hz_lod_select(t->lod, &cam, &o->lod, &il, NULL, NULL, &st) != HZ_OK)
            goto out;
        hz_scene_params sp = {0};
        afx->effects = HZ_FX_ALL;
        app_fx_params(afx, t, &cam, &o->lod, time, &sp);
        cli_scene_lod(&sp, &st);
        /* One untimed draw with the frame's new indices, then every
         * configuration, starting at a different one each frame so no
         * configuration always follows the index upload or another. */
        sp.effects = 0;
        hz_draw_stats ds;
        if (hz_renderer_draw(ren, &cam, &sp, il.data, (uint32_t)il.count, &ds, &err) != HZ_OK)
            goto out;
        for (uint32_t i = 0; i < NCFG; i++) {
            const uint32_t c = (i + f * 7) % NCFG;
            sp.effects = cfg[c];
            sp.history = c % HZ_MAX_HISTORY;
            /* First frame: one untimed draw per configuration (shader variants compile). */
            if (f == 0 && hz_renderer_draw(ren, &cam, &sp, il.data, (uint32_t)il.count, &ds, &err) != HZ_OK)
                goto out;
            if (hz_renderer_draw(ren, &cam, &sp, il.data, (uint32_t)il.count, &ds, &err) != HZ_OK)
                goto out;
            ms[(size_t)c * frames + f] = ds.draw_ms;
        }
        if (!o->quiet)
            hz_progress_stderr(NULL, "effect costs", f + 1, frames);
    }
    /* The light map of this terrain: 1 and 2 threads, median of 3 each. */
    double lm[2] = {0, 0};
    uint8_t *buf = malloc(hz_lightmap_bound(&t->hm));
    if (!buf)
        goto out;
    for (uint32_t th = 1; th <= 2; th++) {
        double v[3];
        for (int k = 0; k < 3; k++) {
            hz_lightmap_desc d = {.hm = &t->hm, .spacing = t->spacing, .zscale = t->zscale, .threads = th};
            glm_vec3_copy(afx->sun, d.sun_dir);
            hz_lightmap_stats st;
            if (hz_lightmap_build(&d, buf, &st, &err) != HZ_OK) {
                free(buf);
                goto out;
            }
            v[k] = st.ms;
        }
        lm[th - 1] = median_of(v, 3);
    }
    free(buf);

    double med[NCFG];
    for (uint32_t c = 0; c < NCFG; c++) {
        memcpy(tmp, ms + (size_t)c * frames, frames * sizeof *tmp);
        med[c] = median_of(tmp, frames);
    }
    hz_outfile jof;
    FILE *jf = json_out ? hz_outfile_open(&jof, json_out, &err) : NULL;
    if (json_out && !jf)
        goto out;
    if (!o->quiet || !jf)
        printf("horizon bench --effect-costs: %s (%ux%u), path %s, %u frames at %ux%u on %s\n"
               "%-12s %10s %10s\n%-12s %10.2f\n%-12s %10.2f\n", t->source, t->hm.size, t->hm.size, path->name,
               frames, o->width, o->height, gl_desc, "effect", "alone ms", "in all ms", "none (base)", med[0],
               "all", med[1]);
    json_t *jroot = json_object(), *jfx = json_object();
    jx_set(jroot, "terrain", jx_str(t->source));
    jx_set(jroot, "size", jx_int(t->hm.size));
    jx_set(jroot, "path", jx_str(path->name));
    jx_set(jroot, "frames", jx_int(frames));
    curv_cli_json(jroot, &o->curv);
    jx_set(jroot, "width", jx_int(o->width));
    jx_set(jroot, "height", jx_int(o->height));
    jx_set(jroot, "gl", jx_str(gl_desc));
    jx_set(jroot, "base_ms", jx_fix(med[0], 3));
    jx_set(jroot, "all_ms", jx_fix(med[1], 3));
    jx_set(jroot, "lightmap_size", jx_int(t->hm.size));
    jx_set(jroot, "lightmap_ms_1thread", jx_fix(lm[0], 1));
    jx_set(jroot, "lightmap_ms_2threads", jx_fix(lm[1], 1));
    jx_set(jroot, "trees", jx_int((long long)afx->trees));
    jx_set(jroot, "effects", jfx);
    for (uint32_t k = 0; k < HZ_FX_COUNT; k++) {
        /* Per frame: alone = t(e) - t(none), in all = t(all) - t(all but e). */
        for (uint32_t f = 0; f < frames; f++)
            tmp[f] = ms[(size_t)(2 + k) * frames + f] - ms[f];
        double alone = median_of(tmp, frames);
        for (uint32_t f = 0; f < frames; f++)
            tmp[f] = ms[(size_t)1 * frames + f] - ms[(size_t)(2 + HZ_FX_COUNT + k) * frames + f];
        double in_all = median_of(tmp, frames);
        if (!o->quiet || !jf)
            printf("%-12s %10.2f %10.2f\n", hz_fx_name(k), alone, in_all);
        jx_set(jfx, hz_fx_name(k),
               json_pack("{s:o,s:o,s:o}", "alone_ms", jx_fix(alone, 3), "in_all_ms", jx_fix(in_all, 3),
                         "alone_frame_ms", jx_fix(med[2 + k], 3)));
    }
    if (!o->quiet || !jf)
        printf("light map %ux%u: %.1f ms (1 thread), %.1f ms (2 threads)\n", t->hm.size, t->hm.size, lm[0], lm[1]);
    if (jf) {
        const bool wrote = jx_print(jroot, jf) == 0;
        jroot = NULL;
        if (hz_outfile_close(&jof, jf, &err) != HZ_OK)
            goto out;
        if (!wrote) {
            hz_err_set(&err, HZ_ERR_IO, "cannot write '%s'", json_out);
            goto out;
        }
    } else {
        json_decref(jroot);
    }
    rc = 0;
out:
    if (rc && err.msg[0])
        fprintf(stderr, "horizon bench: %s\n", err.msg);
    free(ms);
    free(tmp);
    free(il.data);
    return rc;
}

typedef struct bench {
    cli_opts o;
    hz_terrain *t;
    hz_path path;
    uint32_t frames;
    float fps;
    bool reference, quiet, metrics;
    const char *save_dir;
    cli_lod_frame lf;      /* this frame's selection */
    cli_lod_frame lf_all;  /* with --horizon-cull, the frame without it, for the pixel error */
    double load_ms, setup_ms;
    double warm_bake_ms;   /* the running mode's warm-up frame baked the lit map: its time */
    double tune_sil;       /* --tune-silhouette target, 0 = none */
    double tune_psnr;      /* --tune-psnr target (dB), 0 = none */
    hz_renderer *ren;
    size_t npx;
    /* Reference frames, rendered once when several modes share them. */
    bool cache_ref;
    uint8_t **ref_rgb, **ref_sky;
    uint32_t *ref_tris;
    /* Scratch. */
    uint8_t *img[2], *ref[2], *sky_l, *sky_r;
    hz_index_list il, rl;
    hz_float_buf scratch;
    float *surf[2];
    hz_err err;
    /* Effects: the LOD frames and their references get the same ones. */
    app_fx afx;
    city_app *ca;          /* --city / --scene / --footprints: drawn in every frame */
} bench;

/* The scene parameters of frame f seen by cam: the effects at the frame's
 * time (the reflection terrain comes from the mirrored camera, so it is the
 * same for a LOD frame and its reference) and a motion blur history slot. */
static void frame_params(bench *b, const hz_camera *cam, uint32_t f, uint32_t history, hz_scene_params *sp)
{
    *sp = (hz_scene_params){0};
    app_fx_params(&b->afx, b->t, cam, &b->o.lod, (double)f / b->fps + b->o.time, sp);
    if (b->ca)
        city_app_frame(b->ca, &b->o, cam, b->o.width, b->o.height, sp);
    sp->history = history;
    sp->reset_history = f == 0;
}

static hz_result reference_frame(bench *b, const hz_camera *cam, uint32_t f, uint8_t *rgb, uint8_t *sky,
                                 uint32_t *tris)
{
    /* Full resolution, independent of the code it measures: every cell of
     * the grid as two triangles, no LOD selection and no culling (the GPU
     * clips what is off screen). Built once. */
    if (b->rl.count == 0 && hz_lod_full_mesh(&b->t->hm, &b->rl) != HZ_OK)
        return hz_err_set(&b->err, HZ_ERR_MEMORY, "out of memory for the full-resolution reference mesh");
    *tris = (uint32_t)(b->rl.count / 3);
    hz_scene_params sp;
    frame_params(b, cam, f, 1, &sp);
    hz_result r = hz_renderer_draw(b->ren, cam, &sp, b->rl.data, (uint32_t)b->rl.count, NULL, &b->err);
    if (r == HZ_OK)
        r = hz_renderer_read_rgb(b->ren, rgb, &b->err);
    if (r == HZ_OK)
        r = hz_renderer_read_sky_mask(b->ren, sky, &b->err);
    return r;
}

static void progress(bench *b, const char *label, uint32_t done, uint32_t total, double t_start, double *last)
{
    double now = hz_time_ms();
    if (!b->quiet && (now - *last > 200 || done == total) && now - t_start > 1000) {
        hz_progress_stderr(NULL, label, done, total);
        *last = now;
    }
}

static hz_result cache_references(bench *b)
{
    b->ref_rgb = calloc(b->frames, sizeof *b->ref_rgb);
    b->ref_sky = calloc(b->frames, sizeof *b->ref_sky);
    b->ref_tris = calloc(b->frames, sizeof *b->ref_tris);
    if (!b->ref_rgb || !b->ref_sky || !b->ref_tris)
        return hz_err_set(&b->err, HZ_ERR_MEMORY, "out of memory for the reference frames");
    double t0 = hz_time_ms(), last = t0;
    for (uint32_t f = 0; f < b->frames; f++) {
        b->ref_rgb[f] = malloc(b->npx * 3);
        b->ref_sky[f] = malloc(b->npx);
        if (!b->ref_rgb[f] || !b->ref_sky[f])
            return hz_err_set(&b->err, HZ_ERR_MEMORY, "out of memory for %u reference frames (fewer --frames?)",
                              b->frames);
        hz_camera cam = cli_camera(&b->o, b->t);
        hz_path_sample(&b->path, (float)f / b->fps, &cam);
        hz_result r = reference_frame(b, &cam, f, b->ref_rgb[f], b->ref_sky[f], &b->ref_tris[f]);
        if (r != HZ_OK)
            return r;
        if (b->save_dir) {
            char name[1024];
            snprintf(name, sizeof name, "%s/ref_%04u.png", b->save_dir, f);
            if (hz_image_write_png(name, b->ref_rgb[f], b->o.width, b->o.height, &b->err) != HZ_OK)
                return HZ_ERR_IO;
        }
        progress(b, "reference frames", f + 1, b->frames, t0, &last);
    }
    return HZ_OK;
}

/* Screen-space error of one frame (per-frame p99), for the tuning. */
static hz_result frame_p99(bench *b, const hz_lod_params *lod, const hz_camera *cam, double *p99)
{
    hz_lod_stats st;
    hz_lod_params all = *lod;
    all.horizon_cull = false; /* the error of the whole surface in view, hidden or not */
    if (hz_lod_select(b->t->lod, cam, &all, &b->il, NULL, NULL, &st) != HZ_OK)
        return hz_err_set(&b->err, HZ_ERR_MEMORY, "LOD selection out of memory");
    morph_user mu = {b->t->lod, cam, &st};
    hz_px_error pe;
    if (hz_metrics_px_error_ex(&b->t->hm, b->t->spacing, b->t->zscale, b->il.data, b->il.count,
                               st.morph_scale > 0 ? morph_height : NULL, &mu, cam, b->o.height, &b->scratch,
                               &pe) != HZ_OK)
        return hz_err_set(&b->err, HZ_ERR_MEMORY, "pixel error out of memory");
    *p99 = pe.p99_px;
    return HZ_OK;
}

/* The largest pixel error bound (bisection in log space, 8 steps over
 * 0.02..64 px: 3 % resolution) whose px_error_p99 (p95 over up to 8 frames
 * spread along the run of the per-frame p99) stays <= target. */
static hz_result tune(bench *b, hz_lod_params *lod, double target, double *found)
{
    const uint32_t K = b->frames < 8 ? b->frames : 8;
    double lo = log(0.02), hi = log(64.0), best = 0.02, vals[8];
    double t0 = hz_time_ms(), last = t0;
    const int iters = 8;
    for (int it = 0; it < iters; it++) {
        const double mid = 0.5 * (lo + hi);
        lod->pixel_error = (float)exp(mid);
        for (uint32_t k = 0; k < K; k++) {
            const uint32_t f = K > 1 ? (uint32_t)((uint64_t)k * (b->frames - 1) / (K - 1)) : 0;
            hz_camera cam = cli_camera(&b->o, b->t);
            hz_path_sample(&b->path, (float)f / b->fps, &cam);
            hz_result r = frame_p99(b, lod, &cam, &vals[k]);
            if (r != HZ_OK)
                return r;
        }
        const double m = pct_values(vals, K, 0.95);
        if (m <= target) {
            lo = mid;
            best = exp(mid);
        } else {
            hi = mid;
        }
        progress(b, "tuning the pixel error", (uint32_t)it + 1, iters, t0, &last);
    }
    lod->pixel_error = (float)best;
    *found = best;
    return HZ_OK;
}

/* Frames along the path the image tuning measures (their reference sky
 * masks are kept, and their images when PSNR is tuned: 4 bytes a pixel).
 * On the peers' 4097^2 flight, tuned to Ogre tau 1's 41.0 dB the median
 * PSNR of all 120 frames was 40.80 dB with 8 frames, 40.92 with 16 and
 * 41.00 with 60 (tau 1.24, 1.20, 1.18). */
#define TUNE_IMAGE_FRAMES 60

/* The largest pixel error bound (bisection in log space, 10 steps over
 * 0.05..64 px) whose median silhouette error against the full-resolution
 * reference, over up to TUNE_IMAGE_FRAMES frames spread along the path,
 * stays <= sil (a fraction of the pixels; 0: any) and whose median PSNR
 * against it is >= psnr dB (0: any): the setting that matches an image
 * error. Both errors grow with the bound. */
static hz_result tune_image(bench *b, hz_lod_params *lod, double sil, double psnr, double *found)
{
    const uint32_t K = b->frames < TUNE_IMAGE_FRAMES ? b->frames : TUNE_IMAGE_FRAMES;
    uint8_t *sky[TUNE_IMAGE_FRAMES] = {0}, *ref[TUNE_IMAGE_FRAMES] = {0}, *mine = malloc(b->npx),
            *rgb = malloc(b->npx * 3);
    hz_camera cams[TUNE_IMAGE_FRAMES];
    hz_result r = mine && rgb ? HZ_OK : hz_err_set(&b->err, HZ_ERR_MEMORY, "out of memory for the tuning");
    for (uint32_t k = 0; r == HZ_OK && k < K; k++) {
        const uint32_t f = K > 1 ? (uint32_t)((uint64_t)k * (b->frames - 1) / (K - 1)) : 0;
        cams[k] = cli_camera(&b->o, b->t);
        hz_path_sample(&b->path, (float)f / b->fps, &cams[k]);
        sky[k] = malloc(b->npx);
        ref[k] = psnr > 0 ? malloc(b->npx * 3) : NULL; /* the image is kept only to tune PSNR */
        uint32_t tris;
        r = sky[k] && (ref[k] || psnr <= 0)
                ? reference_frame(b, &cams[k], f, ref[k] ? ref[k] : rgb, sky[k], &tris)
                : hz_err_set(&b->err, HZ_ERR_MEMORY, "out of memory for the tuning");
    }
    double lo = log(0.05), hi = log(64.0), best = 0.05, vals[TUNE_IMAGE_FRAMES], dbs[TUNE_IMAGE_FRAMES];
    double t0 = hz_time_ms(), last = t0;
    const int iters = 10;
    for (int it = 0; r == HZ_OK && it < iters; it++) {
        const double mid = 0.5 * (lo + hi);
        lod->pixel_error = (float)exp(mid);
        for (uint32_t k = 0; r == HZ_OK && k < K; k++) {
            const uint32_t *idx;
            uint32_t nidx;
            hz_scene_params sp;
            r = cli_lod_select(b->t, &cams[k], lod, &b->lf);
            if (r != HZ_OK)
                break;
            frame_params(b, &cams[k], 0, 2, &sp);
            cli_lod_scene(&b->lf, &sp, &idx, &nidx);
            r = hz_renderer_draw(b->ren, &cams[k], &sp, idx, nidx, NULL, &b->err);
            if (r == HZ_OK)
                r = hz_renderer_read_sky_mask(b->ren, mine, &b->err);
            if (r == HZ_OK && psnr > 0)
                r = hz_renderer_read_rgb(b->ren, rgb, &b->err);
            if (r == HZ_OK) {
                vals[k] = hz_metrics_silhouette(mine, sky[k], b->npx);
                /* identical frames: infinite PSNR */
                dbs[k] = psnr > 0 ? hz_metrics_psnr(rgb, ref[k], b->npx) : 0.0;
            }
        }
        if (r != HZ_OK)
            break;
        if ((sil <= 0 || pct_values(vals, K, 0.5) <= sil) && (psnr <= 0 || pct_values(dbs, K, 0.5) >= psnr)) {
            lo = mid;
            best = exp(mid);
        } else {
            hi = mid;
        }
        progress(b, "tuning the image error", (uint32_t)it + 1, iters, t0, &last);
    }
    lod->pixel_error = (float)best;
    *found = best;
    for (uint32_t k = 0; k < K; k++) {
        free(sky[k]);
        free(ref[k]);
    }
    free(mine);
    free(rgb);
    return r;
}

/* Flies the path with one LOD setting; fills rows[frames]. */
static hz_result run(bench *b, const hz_lod_params *lod, frame_row *rows)
{
    const cli_opts *o = &b->o;
    hz_camera cam = cli_camera(o, b->t);
    /* Each selection is drawn once: a horizon cull can run while the
     * nearest patches are drawn (cli_lod_frame.late_ok). */
    b->lf.late_ok = true;
    /* One untimed warm-up frame: buffer allocation and shader compilation in
     * llvmpipe happen on the first draw, not in steady state. */
    hz_path_sample(&b->path, 0.0f, &cam);
    const uint32_t *idx;
    uint32_t nidx;
    if (cli_lod_select(b->t, &cam, lod, &b->lf) != HZ_OK)
        return hz_err_set(&b->err, HZ_ERR_MEMORY, "LOD selection out of memory");
    hz_scene_params sp0;
    frame_params(b, &cam, 0, 0, &sp0);
    cli_lod_scene(&b->lf, &sp0, &idx, &nidx);
    hz_draw_stats ds0;
    if (hz_renderer_draw(b->ren, &cam, &sp0, idx, nidx, &ds0, &b->err) != HZ_OK)
        return HZ_ERR_GL;
    if (cli_lod_finish(&b->lf) != HZ_OK)
        return hz_err_set(&b->err, HZ_ERR_MEMORY, "horizon culling out of memory");
    b->warm_bake_ms = ds0.lit_bake_ms;
    double t_start = hz_time_ms(), last = t_start;
    char name[1024];
    for (uint32_t f = 0; f < b->frames; f++) {
        frame_row *row = &rows[f];
        memset(row, 0, sizeof *row);
        row->t = (double)f / b->fps;
        hz_path_sample(&b->path, (float)row->t, &cam);
        double f0 = hz_time_ms();
        if (cli_lod_select(b->t, &cam, lod, &b->lf) != HZ_OK)
            return hz_err_set(&b->err, HZ_ERR_MEMORY, "LOD selection out of memory");
        hz_draw_stats ds;
        hz_scene_params sp;
        frame_params(b, &cam, f, 0, &sp); /* (resets this mode's motion blur at its first frame) */
        cli_lod_scene(&b->lf, &sp, &idx, &nidx);
        if (hz_renderer_draw(b->ren, &cam, &sp, idx, nidx, &ds, &b->err) != HZ_OK)
            return HZ_ERR_GL;
        if (cli_lod_finish(&b->lf) != HZ_OK)
            return hz_err_set(&b->err, HZ_ERR_MEMORY, "horizon culling out of memory");
        row->frame_ms = hz_time_ms() - f0;
        const hz_lod_stats st = b->lf.st;
        row->cull_ms = b->lf.cull_ms;
        row->cull_wait_ms = ds.late_wait_ms;
        row->nodes_drawn = st.leaves;
        row->nodes_still = st.still;
        row->nodes_simple = st.simple;
        row->upload_kb = (double)ds.upload_bytes / 1024.0;
        row->triangles = st.triangles;
        row->nodes_visited = st.nodes_visited;
        row->nodes_culled = st.nodes_culled;
        row->nodes_hidden = st.hidden;
        row->restricted = st.restricted;
        row->lod_ms = st.ms;
        row->upload_ms = ds.upload_ms;
        row->draw_ms = ds.draw_ms;
        row->lit_map = ds.lit_map;
        row->lit_vertex = ds.lit_per_vertex;
        row->lit_vertex_patches = ds.lit_vertex_patches;
        row->lit_bake_ms = ds.lit_bake_ms;
        uint8_t *cur = b->img[f & 1], *prev = b->img[(f + 1) & 1];
        if (hz_renderer_read_rgb(b->ren, cur, &b->err) != HZ_OK ||
            hz_renderer_read_sky_mask(b->ren, b->sky_l, &b->err) != HZ_OK)
            return HZ_ERR_GL;
        size_t sky = 0;
        for (size_t k = 0; k < b->npx; k++)
            sky += b->sky_l[k] != 0;
        row->sky_frac = (double)sky / (double)b->npx;
        /* The exact screen-space error of the drawn surface (outside the
         * frame's time; --metrics off skips it for speed runs). */
        if (b->metrics) {
            /* Over the whole surface in view, the patches nearer ground
             * hides included: the LOD's error, whatever shows (and every
             * sample in the frustum is covered). */
            cli_lod_frame *lf = &b->lf;
            if (lod->horizon_cull) { /* select again, without it */
                hz_lod_params all = *lod;
                all.horizon_cull = false;
                lf = &b->lf_all;
                if (cli_lod_select(b->t, &cam, &all, lf) != HZ_OK)
                    return hz_err_set(&b->err, HZ_ERR_MEMORY, "LOD selection out of memory");
            }
            if (cli_lod_indices(b->t, lf) != HZ_OK)
                return hz_err_set(&b->err, HZ_ERR_MEMORY, "out of memory expanding the patches");
            morph_user mu = {b->t->lod, &cam, &st};
            hz_px_error pe;
            if (hz_metrics_px_error_ex(&b->t->hm, b->t->spacing, b->t->zscale, lf->il.data, lf->il.count,
                                       st.morph_scale > 0 ? morph_height : NULL, &mu, &cam, o->height, &b->scratch,
                                       &pe) != HZ_OK)
                return hz_err_set(&b->err, HZ_ERR_MEMORY, "pixel error out of memory");
            row->px_p99 = pe.p99_px;
            row->px_max = pe.max_px;
            row->uncovered = pe.uncovered;
        } else {
            row->px_p99 = row->px_max = NAN;
        }
        if (b->save_dir) {
            snprintf(name, sizeof name, "%s/%s_%04u.png", b->save_dir, hz_lod_mode_name(lod->mode), f);
            if (hz_image_write_png(name, cur, o->width, o->height, &b->err) != HZ_OK)
                return HZ_ERR_IO;
        }
        if (b->reference) {
            uint8_t *rcur, *rprev, *rsky;
            if (b->cache_ref) {
                rcur = b->ref_rgb[f];
                rprev = b->ref_rgb[f ? f - 1 : 0];
                rsky = b->ref_sky[f];
                row->ref_triangles = b->ref_tris[f];
            } else {
                rcur = b->ref[f & 1];
                rprev = b->ref[(f + 1) & 1];
                rsky = b->sky_r;
                hz_result r = reference_frame(b, &cam, f, rcur, rsky, &row->ref_triangles);
                if (r != HZ_OK)
                    return r;
            }
            /* The drawn surface that the pixel error just rasterised. */
            float *scur = b->surf[f & 1], *sprev = b->surf[(f + 1) & 1];
            if (b->metrics)
                memcpy(scur, b->scratch.surface, (size_t)b->t->hm.size * b->t->hm.size * sizeof *scur);
            row->pop_px_max = row->pop_px_mean = NAN;
            if (f && b->metrics) {
                hz_pop_stats ps;
                hz_metrics_surface_change(&b->t->hm, b->t->spacing, b->t->zscale, sprev, scur, &cam, o->height,
                                          &ps);
                row->pop_px_max = ps.max_px;
                row->pop_px_mean = ps.mean_px;
            }
            row->ref_hash = fnv1a(rcur, b->npx * 3);
            row->psnr = hz_metrics_psnr(cur, rcur, b->npx);
            row->silhouette = hz_metrics_silhouette(b->sky_l, rsky, b->npx);
            row->popping = f ? hz_metrics_popping(prev, cur, rprev, rcur, b->npx) : 0.0;
            if (b->save_dir && !b->cache_ref) {
                snprintf(name, sizeof name, "%s/ref_%04u.png", b->save_dir, f);
                if (hz_image_write_png(name, rcur, o->width, o->height, &b->err) != HZ_OK)
                    return HZ_ERR_IO;
            }
        }
        progress(b, "bench frames", f + 1, b->frames, t_start, &last);
    }
    return HZ_OK;
}

#define OFF(f) offsetof(frame_row, f)
typedef struct col {
    const char *name;
    size_t off;
    bool u32;
    bool pop; /* from the second frame on */
} col;
/* Columns by name; those from COL_PSNR on need the reference. */
enum {
    COL_TRIANGLES, COL_VISITED, COL_CULLED, COL_HIDDEN, COL_DRAWN, COL_STILL, COL_SIMPLE, COL_UPLOAD_KB, COL_LOD, COL_CULL, COL_CULL_WAIT,
    COL_UPLOAD_MS, COL_DRAW,
    COL_FRAME, COL_P99, COL_PXMAX, COL_PSNR, COL_SIL, COL_POP, COL_POP_MAX, COL_POP_MEAN, NCOLS,
    NCOLS_NOREF = COL_PSNR
};
static const col COLS[NCOLS] = {
    [COL_TRIANGLES] = {"triangles", OFF(triangles), true, false},
    [COL_VISITED] = {"nodes_visited", OFF(nodes_visited), true, false},
    [COL_CULLED] = {"nodes_culled", OFF(nodes_culled), true, false},
    [COL_HIDDEN] = {"nodes_hidden", OFF(nodes_hidden), true, false},
    [COL_DRAWN] = {"nodes_drawn", OFF(nodes_drawn), true, false},
    [COL_STILL] = {"nodes_still", OFF(nodes_still), true, false},
    [COL_SIMPLE] = {"nodes_simple", OFF(nodes_simple), true, false},
    [COL_UPLOAD_KB] = {"upload_kb", OFF(upload_kb), false, false},
    [COL_LOD] = {"lod_ms", OFF(lod_ms), false, false},
    [COL_CULL] = {"cull_ms", OFF(cull_ms), false, false},
    [COL_CULL_WAIT] = {"cull_wait_ms", OFF(cull_wait_ms), false, false},
    [COL_UPLOAD_MS] = {"upload_ms", OFF(upload_ms), false, false},
    [COL_DRAW] = {"draw_ms", OFF(draw_ms), false, false},
    [COL_FRAME] = {"frame_ms", OFF(frame_ms), false, false},
    [COL_P99] = {"px_error_p99", OFF(px_p99), false, false},
    [COL_PXMAX] = {"px_error_max", OFF(px_max), false, false},
    [COL_PSNR] = {"psnr_db", OFF(psnr), false, false},
    [COL_SIL] = {"silhouette_frac", OFF(silhouette), false, false},
    [COL_POP] = {"popping", OFF(popping), false, true},
    [COL_POP_MAX] = {"pop_px_max", OFF(pop_px_max), false, true},
    [COL_POP_MEAN] = {"pop_px_mean", OFF(pop_px_mean), false, true},
};

typedef struct summary {
    double v[NCOLS][3]; /* median, p95, max */
    double mean_sil, mean_pop;
} summary;

static void summarize(const bench *b, const frame_row *rows, summary *s)
{
    const size_t n = b->frames;
    /* Popping is defined from the second frame on. */
    const frame_row *pop_rows = n > 1 ? rows + 1 : rows;
    const size_t pop_n = n > 1 ? n - 1 : n;
    const size_t ncols = b->reference ? NCOLS : NCOLS_NOREF;
    for (size_t c = 0; c < ncols; c++) {
        const frame_row *r = COLS[c].pop ? pop_rows : rows;
        const size_t m = COLS[c].pop ? pop_n : n;
        s->v[c][0] = pct(r, m, COLS[c].off, COLS[c].u32, 0.5);
        s->v[c][1] = pct(r, m, COLS[c].off, COLS[c].u32, 0.95);
        s->v[c][2] = pct(r, m, COLS[c].off, COLS[c].u32, 1.0);
    }
    double sil = 0, pop = 0;
    for (size_t i = 0; i < n; i++)
        sil += rows[i].silhouette;
    for (size_t i = 0; i < pop_n; i++)
        pop += pop_rows[i].popping;
    s->mean_sil = n ? sil / (double)n : 0;
    s->mean_pop = pop_n ? pop / (double)pop_n : 0;
}

static void lod_text(const hz_lod_params *lod, char *buf, size_t len)
{
    if (lod->pixel_error > 0 || lod->mode == HZ_LOD_ROAM || lod->mode == HZ_LOD_CDLOD)
        snprintf(buf, len, "%s, pixel error %.3g", hz_lod_mode_name(lod->mode),
                 (double)(lod->pixel_error > 0 ? lod->pixel_error : 1.0f));
    else
        snprintf(buf, len, "%s, C=%g C2=%g", hz_lod_mode_name(lod->mode), (double)(lod->c > 0 ? lod->c : 25),
                 (double)(lod->c2 > 0 ? lod->c2 : 2.5f));
}

static void print_table(const bench *b, const hz_lod_params *lod, const summary *s, double tuned_for)
{
    char lt[128];
    lod_text(lod, lt, sizeof lt);
    char fxs[200];
    hz_fx_format(b->o.effects, fxs, sizeof fxs);
    printf("horizon bench: %s (%ux%u, %.1f m), path %s, %u frames at %ux%u, %s%s, effects %s", b->t->source,
           b->t->hm.size, b->t->hm.size, (double)b->t->spacing, b->path.name, b->frames, b->o.width, b->o.height, lt,
           b->reference ? "" : ", no reference", fxs);
    if (tuned_for > 0)
        printf(" (tuned for p99 <= %g px)", tuned_for);
    if (b->tune_sil > 0)
        printf(" (tuned for median silhouette <= %g)", b->tune_sil);
    if (b->tune_psnr > 0)
        printf(" (tuned for median PSNR >= %g dB)", b->tune_psnr);
    printf("\n");
    curv_cli_print(&b->o.curv);
    printf("%-18s %12s %12s %12s\n", "", "median", "p95", "max");
    const size_t ncols = b->reference ? NCOLS : NCOLS_NOREF;
    for (size_t c = 0; c < ncols; c++)
        printf("%-18s %12.4g %12.4g %12.4g\n", COLS[c].name, s->v[c][0], s->v[c][1], s->v[c][2]);
    printf("%-18s %12.3f\n%-18s %12.1f\n", "bytes_per_sample", hz_lod_bytes_per_sample(b->t->lod), "peak_rss_mb",
           (double)hz_peak_rss_bytes() / 1048576.0);
}

static json_t *bench_json(const bench *b, const hz_lod_params *lod, const frame_row *rows, const summary *s,
                          double tuned_for)
{
    const hz_camera cam = cli_camera(&b->o, b->t);
    char fxs[200];
    hz_fx_format(b->o.effects, fxs, sizeof fxs);
    json_t *j = json_object();
    jx_set(j, "frames", jx_int(b->frames));
    curv_cli_json(j, &b->o.curv);
    jx_set(j, "terrain", jx_str(b->t->source));
    jx_set(j, "size", jx_int(b->t->hm.size));
    jx_set(j, "spacing", jx_num(b->t->spacing));
    jx_set(j, "lod_mode", jx_str(hz_lod_mode_name(lod->mode)));
    jx_set(j, "pixel_error", jx_num(cli_pixel_error(lod)));
    cli_near_json(j, lod);
    jx_set(j, "tuned_for_p99", jx_num(tuned_for));
    jx_set(j, "criterion", jx_str(lod->criterion == HZ_LOD_UNCLAMPED ? "unclamped" : "clamped"));
    jx_set(j, "lod_c", jx_num(lod->c > 0 ? lod->c : 25));
    jx_set(j, "lod_c2", jx_num(lod->c2 > 0 ? lod->c2 : 2.5f));
    jx_set(j, "path", jx_str(b->path.name));
    jx_set(j, "fps", jx_num(b->fps));
    jx_set(j, "width", jx_int(b->o.width));
    jx_set(j, "height", jx_int(b->o.height));
    jx_set(j, "fov", jx_num(cam.fov_y));
    jx_set(j, "far", jx_fix(cam.zfar, 1));
    jx_set(j, "reference", jx_bool(b->reference));
    jx_set(j, "effects", jx_str(fxs));
    jx_set(j, "fx_setup_ms", jx_fix(b->afx.setup_ms, 1));
    jx_set(j, "lightmap_ms", jx_fix(b->afx.lightmap_ms, 1));
    jx_set(j, "trees", jx_int((long long)b->afx.trees));
    const size_t ncols = b->reference ? NCOLS : NCOLS_NOREF;
    char key[64];
    for (size_t c = 0; c < ncols; c++) {
        const char *nm = COLS[c].name;
        if (!strcmp(nm, "silhouette_frac") || !strcmp(nm, "popping")) {
            /* the keys: mean over frames */
            jx_set(j, nm, jx_num(!strcmp(nm, "popping") ? s->mean_pop : s->mean_sil));
            snprintf(key, sizeof key, "%s_max", nm);
            jx_set(j, key, jx_num(s->v[c][2]));
            continue;
        }
        static const char *const sfx[3] = {"median", "p95", "max"};
        for (int q = 0; q < 3; q++) {
            snprintf(key, sizeof key, "%s_%s", nm, sfx[q]);
            jx_set(j, key, jx_num(s->v[c][q]));
        }
    }
    if (!b->reference) {
        jx_set(j, "psnr_db_median", json_null());
        jx_set(j, "silhouette_frac", json_null());
        jx_set(j, "popping", json_null());
        jx_set(j, "pop_px_max_median", json_null());
    }
    /* px_error_p99 / px_error_max as top-level keys (p95 over frames of the
     * per-frame p99, and the max over all frames). */
    jx_set(j, "px_error_p99", jx_num(s->v[COL_P99][1]));
    jx_set(j, "px_error_max", jx_num(s->v[COL_PXMAX][2]));
    jx_set(j, "tuned_for_silhouette", jx_num(b->tune_sil));
    jx_set(j, "tuned_for_psnr_db", jx_num(b->tune_psnr));
    jx_set(j, "metrics", jx_bool(b->metrics));
    uint32_t lit_frames = 0, lit_vertex = 0;
    uint64_t lit_vertex_patches = 0;
    double lit_bake = b->warm_bake_ms;
    for (size_t i = 0; i < b->frames; i++) {
        lit_frames += rows[i].lit_map;
        lit_vertex += rows[i].lit_vertex;
        lit_vertex_patches += rows[i].lit_vertex_patches;
        lit_bake += rows[i].lit_bake_ms;
    }
    jx_set(j, "lit_map_frames", jx_int(lit_frames));
    jx_set(j, "lit_per_vertex_frames", jx_int(lit_vertex));
    jx_set(j, "lit_vertex_patches", jx_int((long long)lit_vertex_patches));
    jx_set(j, "lit_bake_ms", jx_fix(lit_bake, 1));
    jx_set(j, "load_ms", jx_fix(b->load_ms, 1));
    jx_set(j, "setup_ms", jx_fix(b->setup_ms, 1));
    jx_set(j, "near", jx_num(cam.znear));
    jx_set(j, "patch_cells", jx_int(lod->mode == HZ_LOD_CDLOD ? hz_lod_patch_cells(b->t->lod) : 0u));
    jx_set(j, "bytes_per_sample", jx_fix(hz_lod_bytes_per_sample(b->t->lod), 4));
    jx_set(j, "peak_rss_mb", jx_fix((double)hz_peak_rss_bytes() / 1048576.0, 1));
    json_t *pf = json_array();
    for (size_t i = 0; i < b->frames; i++) {
        const frame_row *r = &rows[i];
        json_t *o = json_object();
        jx_set(o, "t", jx_fix(r->t, 4));
        jx_set(o, "triangles", jx_int(r->triangles));
        jx_set(o, "nodes_visited", jx_int(r->nodes_visited));
        jx_set(o, "nodes_culled", jx_int(r->nodes_culled));
        jx_set(o, "nodes_hidden", jx_int(r->nodes_hidden));
        jx_set(o, "restricted", jx_int(r->restricted));
        jx_set(o, "lod_ms", jx_fix(r->lod_ms, 4));
        jx_set(o, "cull_ms", jx_fix(r->cull_ms, 4));
        jx_set(o, "cull_wait_ms", jx_fix(r->cull_wait_ms, 4));
        jx_set(o, "upload_ms", jx_fix(r->upload_ms, 4));
        jx_set(o, "draw_ms", jx_fix(r->draw_ms, 3));
        jx_set(o, "frame_ms", jx_fix(r->frame_ms, 3));
        jx_set(o, "nodes_drawn", jx_int(r->nodes_drawn));
        jx_set(o, "nodes_still", jx_int(r->nodes_still));
        jx_set(o, "nodes_simple", jx_int(r->nodes_simple));
        jx_set(o, "upload_kb", jx_fix(r->upload_kb, 3));
        jx_set(o, "lit_map", jx_bool(r->lit_map));
        jx_set(o, "lit_vertex_patches", jx_int(r->lit_vertex_patches));
        if (r->lit_bake_ms > 0)
            jx_set(o, "lit_bake_ms", jx_fix(r->lit_bake_ms, 1));
        jx_set(o, "px_error_p99", jx_num(r->px_p99));
        jx_set(o, "px_error_max", jx_num(r->px_max));
        jx_set(o, "uncovered", jx_int((long long)r->uncovered));
        jx_set(o, "sky_frac", jx_fix(r->sky_frac, 5));
        if (b->reference) {
            char hash[20];
            snprintf(hash, sizeof hash, "%016llx", (unsigned long long)r->ref_hash);
            jx_set(o, "ref_triangles", jx_int(r->ref_triangles));
            jx_set(o, "ref_hash", jx_str(hash));
            jx_set(o, "psnr_db", jx_num(r->psnr));
            jx_set(o, "silhouette_frac", jx_num(r->silhouette));
            jx_set(o, "popping", jx_num(r->popping));
            jx_set(o, "pop_px_max", jx_num(r->pop_px_max));
            jx_set(o, "pop_px_mean", jx_num(r->pop_px_mean));
        }
        json_array_append_new(pf, o);
    }
    jx_set(j, "per_frame", pf);
    return j;
}

static hz_result plot(const bench *b, const char *plot_out, const frame_row *rows, hz_err *err)
{
    /* The data goes to a temporary file next to the chart (never committed),
     * the chart to another one renamed into place once gnuplot succeeded. */
    char dname[1100];
    snprintf(dname, sizeof dname, "%s.dat", plot_out);
    hz_outfile datf, pngf;
    FILE *df = hz_outfile_open(&datf, dname, err);
    if (!df)
        return HZ_ERR_IO;
    const char *dat = datf.tmp;
    for (size_t i = 0; i < b->frames; i++)
        fprintf(df, "%u %u %.3f %.4f\n", (unsigned)i, rows[i].triangles, rows[i].frame_ms, rows[i].px_p99);
    if (fclose(df) != 0 || hz_outfile_begin(&pngf, plot_out, err) != HZ_OK) {
        hz_outfile_discard(&datf);
        return hz_err_set(err, HZ_ERR_IO, "cannot write '%s'", plot_out);
    }
    char cmd[24576];
    snprintf(cmd, sizeof cmd,
             "gnuplot -e \"set terminal pngcairo size 1000,700 noenhanced; set output '%s'; set multiplot layout 3,1 "
             "title '%s %s'; set xlabel 'frame'; set ylabel 'triangles'; plot '%s' using 1:2 with lines notitle; "
             "set ylabel 'frame ms'; plot '%s' using 1:3 with lines notitle; "
             "set ylabel 'px error p99'; plot '%s' using 1:4 with lines notitle; unset multiplot\"",
             pngf.tmp, b->t->source, b->path.name, dat, dat, dat);
    if (system(cmd) != 0) {
        hz_outfile_discard(&pngf);
        return hz_err_set(err, HZ_ERR_IO, "gnuplot failed or is not installed (apt-get install gnuplot-nox); data in %s",
                          dat);
    }
    hz_outfile_discard(&datf);
    return hz_outfile_commit(&pngf, err);
}

/* --save-frames DIR writes DIR/<mode>_NNNN.png and DIR/ref_NNNN.png: before
 * any work, refuses (after a message) a folder it cannot write into (1) and
 * an input that is one of those files (2). */
static int check_frame_outputs(const char *dir, const cli_file *ins, size_t nin)
{
    if (cli_check_dir("bench", "--save-frames", dir))
        return 1;
    for (size_t k = 0; k < nin; k++) {
        if (!ins[k].path || ins[k].kind != CLI_FILE)
            continue;
        const char *slash = strrchr(ins[k].path, '/');
        const char *base = slash ? slash + 1 : ins[k].path;
        char mode[32], tail[8];
        unsigned num;
        if (sscanf(base, "%31[a-z]_%4u.%7s", mode, &num, tail) != 3 || strcmp(tail, "png"))
            continue;
        hz_lod_mode m;
        if (strcmp(mode, "ref") && !hz_lod_mode_from_name(mode, &m))
            continue;
        char in_dir[4096];
        if (slash)
            snprintf(in_dir, sizeof in_dir, "%.*s", (int)(slash - ins[k].path), ins[k].path);
        else
            snprintf(in_dir, sizeof in_dir, ".");
        if (hz_same_file(in_dir[0] ? in_dir : "/", dir)) {
            fprintf(stderr, "horizon bench: --save-frames %s would overwrite the %s input '%s'; choose another "
                            "folder\n", dir, ins[k].opt, ins[k].path);
            return 2;
        }
    }
    return 0;
}

/* Splits "--lod a,b,c" off argv: modes[] receives them. Returns the count
 * (0 if no --lod), -1 on a bad name (message printed). */
static int parse_modes(const char *v, hz_lod_mode *modes, int cap)
{
    char buf[256], *it[HZ_LOD_MODE_COUNT * 2];
    const int nit = (int)(sizeof it / sizeof *it) < cap ? (int)(sizeof it / sizeof *it) : cap;
    /* An empty item ("quadtree,,cdlod") is an error, not skipped. */
    int count = snprintf(buf, sizeof buf, "%s", v) < (int)sizeof buf ? cli_split(buf, it, nit) : -1;
    int n = 0;
    for (int k = 0; k < (count < 0 ? 1 : count); k++) {
        if (count < 0 || !hz_lod_mode_from_name(it[k], &modes[n])) {
            fprintf(stderr, "horizon bench: invalid value '%s' for --lod: expected quadtree, remedy, bidirectional, "
                            "roam or cdlod, or a comma-separated list of them\n",
                    v);
            return -1;
        }
        n++;
    }
    if (n == 0) {
        fprintf(stderr, "horizon bench: --lod needs a mode\n");
        return -1;
    }
    return n;
}

int cmd_bench(int argc, char **argv)
{
    if (cli_wants_stream(argc, argv, 2))
        return stream_bench(argc, argv);
    /* Split off bench-only options, pass the rest to the common parser. */
    const char *path_name = NULL, *json_out = NULL, *plot_out = NULL, *save_dir = NULL, *costs_out = NULL;
    bench_forest_opts bfo = {0};
    uint32_t frames = 60;
    float fps = 30.0f, tune_p99 = 0.0f, tune_sil = 0.0f, tune_psnr = 0.0f;
    bool fps_set = false;
    bool reference = true, metrics = true;
    hz_lod_mode modes[HZ_LOD_MODE_COUNT * 2];
    int nmodes = 0;
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
        if (!strcmp(a, "--no-full") || !strcmp(a, "--no-pr")) {
            if (!strcmp(a, "--no-full"))
                bfo.no_full = true;
            else
                bfo.no_pr = true;
            continue;
        }
        bool takes = !strcmp(a, "--path") || !strcmp(a, "--frames") || !strcmp(a, "--fps") ||
                     !strcmp(a, "--full-every") || !strcmp(a, "--pr-views") || !strcmp(a, "--pr-res") ||
                     !strcmp(a, "--pr-shuffles") || !strcmp(a, "--reference") || !strcmp(a, "--plot") ||
                     !strcmp(a, "--save-frames") ||
                     !strcmp(a, "--tune-p99") || (!strcmp(a, "--lod") && v && strchr(v, ',')) ||
                     !strcmp(a, "--tune-silhouette") || !strcmp(a, "--tune-psnr") || !strcmp(a, "--metrics") ||
                     !strcmp(a, "--effect-costs") ||
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
        if (!strcmp(a, "--path"))
            path_name = v;
        else if (!strcmp(a, "--json"))
            json_out = v;
        else if (!strcmp(a, "--plot"))
            plot_out = v;
        else if (!strcmp(a, "--save-frames"))
            save_dir = v;
        else if (!strcmp(a, "--effect-costs"))
            costs_out = v;
        else if (!strcmp(a, "--lod")) {
            nmodes = parse_modes(v, modes, (int)(sizeof modes / sizeof *modes));
            if (nmodes < 0) {
                free(rest);
                return 2;
            }
        } else if (!strcmp(a, "--full-every") || !strcmp(a, "--pr-views") || !strcmp(a, "--pr-res") ||
                   !strcmp(a, "--pr-shuffles")) {
            const uint32_t hi = !strcmp(a, "--pr-res") ? 4096 : !strcmp(a, "--pr-shuffles") ? HZ_PR_ORDERS_MAX : 100000,
                           lo = !strcmp(a, "--pr-res") ? 16 : 1;
            uint32_t x;
            if (!cli_parse_u32(v, lo, hi, &x)) {
                fprintf(stderr, "horizon bench: invalid value '%s' for %s: expected a count in [%u, %u]\n", v, a, lo, hi);
                free(rest);
                return 2;
            }
            if (!strcmp(a, "--full-every"))
                bfo.full_every = x;
            else if (!strcmp(a, "--pr-views"))
                bfo.pr_views = x;
            else if (!strcmp(a, "--pr-shuffles"))
                bfo.pr_shuffles = x;
            else
                bfo.pr_res = x;
        } else if (!strcmp(a, "--metrics")) {
            if (strcmp(v, "on") && strcmp(v, "off")) {
                fprintf(stderr, "horizon bench: --metrics takes on or off\n");
                free(rest);
                return 2;
            }
            metrics = !strcmp(v, "on");
        } else if (!strcmp(a, "--tune-silhouette")) {
            if (!cli_parse_float(v, 1e-7, 1.0, &tune_sil)) {
                fprintf(stderr, "horizon bench: invalid value '%s' for --tune-silhouette: expected a fraction of "
                                "the pixels in (0, 1], e.g. 0.0002\n", v);
                free(rest);
                return 2;
            }
        } else if (!strcmp(a, "--tune-psnr")) {
            if (!cli_parse_float(v, 1.0, 200.0, &tune_psnr)) {
                fprintf(stderr, "horizon bench: invalid value '%s' for --tune-psnr: expected dB in [1, 200], e.g. 41\n",
                        v);
                free(rest);
                return 2;
            }
        } else if (!strcmp(a, "--reference")) {
            if (strcmp(v, "on") && strcmp(v, "off")) {
                fprintf(stderr, "horizon bench: --reference takes on or off\n");
                free(rest);
                return 2;
            }
            reference = !strcmp(v, "on");
        } else if (!strcmp(a, "--frames")) {
            if (!cli_parse_u32(v, 1, 100000, &frames)) {
                fprintf(stderr, "horizon bench: invalid value '%s' for --frames: expected a count in [1, 100000]\n", v);
                free(rest);
                return 2;
            }
        } else if (!strcmp(a, "--fps") || !strcmp(a, "--tune-p99")) {
            const bool is_fps = !strcmp(a, "--fps");
            float f;
            if (!cli_parse_float(v, is_fps ? 0.1 : 0.01, is_fps ? 10000.0 : 1000.0, &f)) {
                fprintf(stderr, "horizon bench: invalid value '%s' for %s: expected %s\n", v, a,
                        is_fps ? "frames per second in [0.1, 10000]" : "pixels in [0.01, 1000]");
                free(rest);
                return 2;
            }
            if (is_fps) {
                fps = f;
                fps_set = true;
            } else {
                tune_p99 = f;
            }
        }
    }
    bench b = {.frames = frames, .fps = fps, .reference = reference, .metrics = metrics, .save_dir = save_dir};
    b.tune_sil = tune_sil;
    b.tune_psnr = tune_psnr;
    if ((tune_sil > 0 || tune_psnr > 0) && tune_p99 > 0) {
        fprintf(stderr, "horizon bench: --tune-p99 and --tune-silhouette / --tune-psnr are alternatives\n");
        return 2;
    }
    if ((tune_sil > 0 || tune_psnr > 0) && !reference) {
        fprintf(stderr, "horizon bench: --tune-silhouette and --tune-psnr need the reference frames (not --reference off)\n");
        return 2;
    }
    int rc = cli_parse(nrest, rest, 2, &b.o, "bench");
    free(rest);
    if (rc)
        return rc;
    if (b.o.out || b.o.dump_mesh) {
        fprintf(stderr, "horizon bench: --out/--dump-mesh belong to render; use --save-frames DIR\n");
        return 2;
    }
    {
        cli_file ins[8];
        size_t nin = cli_opts_inputs(&b.o, ins, 0, 7);
        const size_t pl = path_name ? strlen(path_name) : 0;
        if (pl > 4 && !strcmp(path_name + pl - 4, ".csv")) /* else a built-in path's name */
            ins[nin++] = (cli_file){path_name, "--path", CLI_FILE};
        const cli_file outs[] = {{json_out, "--json", CLI_FILE}, {plot_out, "--plot", CLI_FILE},
                                 {costs_out, "--effect-costs", CLI_FILE}, {b.o.forest_save, "--forest-save", CLI_FILE}};
        if ((rc = cli_check_outputs("bench", outs, 4, ins, nin)))
            return rc;
        if (save_dir && (rc = check_frame_outputs(save_dir, ins, nin)))
            return rc;
    }
    /* --plot needs gnuplot: said before the run, not after it. */
    if (plot_out && system("command -v gnuplot >/dev/null 2>&1") != 0) {
        fprintf(stderr, "horizon bench: --plot needs gnuplot, which is not installed (apt-get install gnuplot-nox, "
                        "or make bench installs it)\n");
        return 2;
    }
    if (nmodes == 0)
        modes[nmodes++] = b.o.lod.mode;
    b.quiet = b.o.quiet;

    int crc = 0;
    b.ca = city_app_load(&b.o, "bench", &crc);
    if (crc)
        return crc;
    b.t = cli_load_terrain(&b.o);
    if (!b.t || (b.ca && city_app_place(b.ca, b.t, "bench"))) {
        city_app_destroy(b.ca);
        hz_terrain_destroy(b.t);
        return 1;
    }
    cli_curvature(&b.o, b.t);
    for (int m = 0; m < nmodes; m++)
        if (hz_lod_prepare(b.t->lod, modes[m]) != HZ_OK) {
            fprintf(stderr, "horizon bench: out of memory preparing the %s LOD data\n", hz_lod_mode_name(modes[m]));
            city_app_destroy(b.ca);
            hz_terrain_destroy(b.t);
            return 1;
        }
    if (b.o.forest_n) {
        if (nmodes > 1) {
            fprintf(stderr, "horizon bench: --forest measures one --lod mode at a time\n");
            city_app_destroy(b.ca);
            hz_terrain_destroy(b.t);
            return 2;
        }
        b.o.lod.mode = modes[0];
        bfo.path = path_name ? path_name : "forest";
        bfo.frames = frames;
        bfo.fps = fps_set ? fps : 0.0f;
        bfo.json_out = json_out;
        bfo.save_dir = save_dir;
        rc = bench_forest(&b.o, b.t, &bfo);
        hz_terrain_destroy(b.t);
        return rc;
    }
    if (!path_name)
        path_name = "flyover";
    size_t plen = strlen(path_name);
    hz_result pr = plen > 4 && !strcmp(path_name + plen - 4, ".csv") ? hz_path_load_csv(path_name, &b.path, &b.err)
                                                                     : hz_terrain_path(b.t, path_name, &b.path, &b.err);
    if (pr != HZ_OK) {
        fprintf(stderr, "horizon bench: %s\n", b.err.msg);
        hz_terrain_destroy(b.t);
        return pr == HZ_ERR_VALUE && strstr(b.err.msg, "unknown path") ? 2 : 1;
    }

    rc = 1;
    hz_gl *gl = NULL;
    FILE *jf = NULL;
    hz_outfile jof;
    json_t *jroot = NULL, *jcmp = NULL, *jone = NULL;
    frame_row *rows = NULL;
    b.npx = (size_t)b.o.width * b.o.height;
    b.cache_ref = reference && nmodes > 1;
    rows = calloc(frames, sizeof *rows);
    for (int k = 0; k < 2; k++) {
        b.img[k] = malloc(b.npx * 3);
        b.ref[k] = malloc(b.npx * 3);
    }
    b.sky_l = malloc(b.npx);
    b.sky_r = malloc(b.npx);
    if (!rows || !b.img[0] || !b.img[1] || !b.ref[0] || !b.ref[1] || !b.sky_l || !b.sky_r) {
        hz_err_set(&b.err, HZ_ERR_MEMORY, "out of memory");
        goto done;
    }
    b.load_ms = b.t->load_ms + b.t->prep_ms;
    if (reference) {
        const size_t ns = (size_t)b.t->hm.size * b.t->hm.size;
        b.surf[0] = malloc(ns * sizeof(float));
        b.surf[1] = malloc(ns * sizeof(float));
        if (!b.surf[0] || !b.surf[1]) {
            hz_err_set(&b.err, HZ_ERR_MEMORY, "out of memory for the surface buffers (use --reference off)");
            goto done;
        }
    }
    double setup0 = hz_time_ms();
    gl = hz_gl_create_headless(&b.err);
    if (!gl)
        goto done;
    b.ren = hz_renderer_create(&(hz_renderer_desc){.width = b.o.width, .height = b.o.height}, &b.err);
    if (!b.ren || hz_renderer_set_heightmap(b.ren, &b.t->hm, b.t->spacing, b.t->zscale, &b.err) != HZ_OK ||
        hz_renderer_set_valid(b.ren, b.t->valid, &b.err) != HZ_OK)
        goto done;
    for (int m = 0; m < nmodes; m++)
        if (cli_renderer_morph(b.ren, b.t, modes[m], &b.err) != HZ_OK)
            goto done;
    if (b.ca && city_app_gpu(b.ca, "bench"))
        goto done;
    /* --effect-costs builds every effect's resources ("view" does). */
    app_fx_objects(&b.afx, b.ca);
    if (app_fx_setup(&b.afx, &b.o, b.t, b.ren, costs_out ? "view" : "bench")) {
        snprintf(b.err.msg, sizeof b.err.msg, "effects setup failed");
        goto done;
    }
    b.setup_ms = hz_time_ms() - setup0;
    if (costs_out) {
        rc = effect_costs(&b.o, b.t, b.ren, &b.afx, &b.path, frames, fps, costs_out, hz_gl_describe(gl));
        goto done;
    }
    if (b.cache_ref && cache_references(&b) != HZ_OK)
        goto done;
    if (json_out) {
        jf = hz_outfile_open(&jof, json_out, &b.err);
        if (!jf)
            goto done;
    }
    if (nmodes > 1) {
        jroot = json_object();
        jcmp = json_array();
    }
    if (jroot)
        jx_set(jroot, "compare", json_incref(jcmp));
    for (int m = 0; m < nmodes; m++) {
        hz_lod_params lod = b.o.lod;
        lod.mode = modes[m];
        double tuned = 0;
        if (tune_p99 > 0 && tune(&b, &lod, tune_p99, &tuned) != HZ_OK)
            goto done;
        if ((tune_sil > 0 || tune_psnr > 0) && tune_image(&b, &lod, tune_sil, tune_psnr, &tuned) != HZ_OK)
            goto done;
        if (run(&b, &lod, rows) != HZ_OK)
            goto done;
        summary s;
        summarize(&b, rows, &s);
        if (!b.quiet || !json_out)
            print_table(&b, &lod, &s, tune_p99);
        if (jf) {
            json_t *jm = bench_json(&b, &lod, rows, &s, tune_p99);
            if (jcmp)
                json_array_append_new(jcmp, jm);
            else
                jone = jm;
        }
        if (plot_out && nmodes == 1 && plot(&b, plot_out, rows, &b.err) != HZ_OK)
            goto done;
    }
    if (jf) {
        json_t *jout = jroot ? jroot : jone;
        jroot = jone = NULL;
        if (jx_print(jout, jf))
            hz_err_set(&b.err, HZ_ERR_IO, "cannot write '%s'", json_out);
        hz_result closed = hz_outfile_close(&jof, jf, &b.err);
        jf = NULL;
        if (closed != HZ_OK)
            goto done;
    }
    if (plot_out && nmodes > 1)
        fprintf(stderr, "horizon bench: --plot charts a single mode; skipped for %d modes\n", nmodes);
    rc = 0;
done:
    json_decref(jroot);
    json_decref(jcmp);
    json_decref(jone);
    if (rc)
        fprintf(stderr, "horizon bench: %s\n", b.err.msg[0] ? b.err.msg : "failed");
    if (jf) {
        fclose(jf);
        hz_outfile_discard(&jof); /* a failed run leaves the old file as it was */
    }
    app_fx_free(&b.afx);
    city_app_destroy(b.ca);
    hz_renderer_destroy(b.ren);
    hz_gl_destroy(gl);
    if (b.ref_rgb)
        for (uint32_t f = 0; f < frames; f++) {
            free(b.ref_rgb[f]);
            free(b.ref_sky[f]);
        }
    free(b.ref_rgb);
    free(b.ref_sky);
    free(b.ref_tris);
    free(rows);
    for (int k = 0; k < 2; k++) {
        free(b.img[k]);
        free(b.ref[k]);
        free(b.surf[k]);
    }
    free(b.sky_l);
    free(b.sky_r);
    free(b.il.data);
    free(b.rl.data);
    cli_lod_frame_free(&b.lf);
    cli_lod_frame_free(&b.lf_all);
    hz_float_buf_free(&b.scratch);
    hz_path_free(&b.path);
    hz_terrain_destroy(b.t);
    return rc;
}
