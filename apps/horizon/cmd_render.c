/* horizon render: one frame of a terrain, headless, to PNG (+ OBJ, JSON). */
#include "cli.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "horizon/safety.h"

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median(double *v, size_t n)
{
    qsort(v, n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

static size_t count_vertices(const hz_index_list *il, uint32_t n)
{
    uint8_t *seen = calloc((size_t)n * n, 1);
    if (!seen)
        return 0;
    size_t c = 0;
    for (size_t k = 0; k < il->count; k++)
        if (!seen[il->data[k]]) {
            seen[il->data[k]] = 1;
            c++;
        }
    free(seen);
    return c;
}

/* The mesh as drawn: cdlod vertices at their morphed heights. */
static int write_obj(const char *path, const hz_terrain *t, const hz_index_list *il, const hz_camera *cam,
                     const hz_lod_stats *st)
{
    const uint32_t n = t->hm.size;
    hz_outfile of;
    hz_err err = {0};
    FILE *f = hz_outfile_open(&of, path, &err);
    if (!f) {
        fprintf(stderr, "horizon render: %s\n", err.msg);
        return 1;
    }
    uint32_t *remap = calloc((size_t)n * n, sizeof *remap);
    if (!remap) {
        fclose(f);
        hz_outfile_discard(&of);
        fprintf(stderr, "horizon render: out of memory writing %s\n", path);
        return 1;
    }
    fprintf(f, "# horizon LOD mesh: %s, %zu triangles, world metres, y up%s\n", t->source, il->count / 3,
            st->morph_scale > 0 ? ", cdlod morph applied" : "");
    uint32_t next = 1;
    for (size_t k = 0; k < il->count; k++) {
        uint32_t v = il->data[k];
        if (!remap[v]) {
            remap[v] = next++;
            uint32_t i = v % n, j = v / n;
            float y = st->morph_scale > 0 ? hz_lod_morph_height(t->lod, cam, st, v)
                                          : hz_heightmap_get(&t->hm, i, j) * t->zscale;
            fprintf(f, "v %.3f %.3f %.3f\n", (double)((float)i * t->spacing), (double)y,
                    (double)((float)j * t->spacing));
        }
    }
    for (size_t k = 0; k < il->count; k += 3)
        fprintf(f, "f %u %u %u\n", remap[il->data[k]], remap[il->data[k + 1]], remap[il->data[k + 2]]);
    free(remap);
    if (hz_outfile_close(&of, f, &err) != HZ_OK) {
        fprintf(stderr, "horizon render: %s\n", err.msg);
        return 1;
    }
    return 0;
}

int cmd_render(int argc, char **argv)
{
    cli_opts o;
    for (int i = 2; i < argc; i++)
        if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) {
            fprintf(stderr, "usage: horizon render [options]\n"
                            "Renders one frame headless (EGL, no window) and prints its figures.\n");
            cli_usage_terrain();
            cli_usage_forest();
            city_cli_usage();
            fprintf(stderr, "output:\n"
                            "  --out FILE.png          image (default render.png)\n"
                            "  --dump-mesh FILE.obj    the frame's LOD mesh, world coordinates\n"
                            "  --json                  figures as one JSON object on stdout\n"
                            "  --wireframe             draw the mesh edges over the shading\n"
                            "  --repeat N              LOD selections timed, median reported (default 20)\n"
                            "  --quiet                 no progress bars or notes\n");
            return 0;
        }
    int rc = cli_parse(argc, argv, 2, &o, "render");
    if (rc)
        return rc;
    const char *out = o.out ? o.out : "render.png";
    cli_file ins[8];
    const size_t nin = cli_opts_inputs(&o, ins, 0, 8);
    const cli_file outs[] = {{out, "--out", CLI_FILE}, {o.dump_mesh, "--dump-mesh", CLI_FILE}};
    if ((rc = cli_check_outputs("render", outs, 2, ins, nin)))
        return rc;
    city_app *ca = city_app_load(&o, "render", &rc);
    if (rc)
        return rc;
    hz_terrain *t = cli_load_terrain(&o);
    if (!t || (ca && city_app_place(ca, t, "render"))) {
        city_app_destroy(ca);
        hz_terrain_destroy(t);
        return 1;
    }
    hz_camera cam = o.forest_n && !o.have_camera ? cli_forest_camera(&o, t) : cli_camera(&o, t);
    if (ca)
        cam = city_app_camera(ca, &o, t);
    cli_forest *cf = NULL;

    cli_lod_frame lf = {0};
    double *lod_ms = malloc(o.repeat * sizeof *lod_ms);
    if (!lod_ms)
        return 1;
    for (uint32_t r = 0; r < o.repeat; r++) {
        if (cli_lod_select(t, &cam, &o.lod, &lf) != HZ_OK) {
            fprintf(stderr, "horizon render: out of memory in LOD selection\n");
            return 1;
        }
        lod_ms[r] = lf.st.ms;
    }
    /* cdlod draws nodes; the index list is for the mesh dump and the figures. */
    if (cli_lod_indices(t, &lf) != HZ_OK) {
        fprintf(stderr, "horizon render: out of memory expanding the patches\n");
        return 1;
    }
    const hz_index_list il = lf.il;
    const hz_lod_stats st = lf.st;
    /* Triangles touching nodata or padding are not drawn (cli_lod_select
     * drops them from index lists; the patch shader for cdlod). */
    const size_t masked_tris = lf.masked;
    /* roam refines from its previous mesh: the first selection builds it,
     * later ones from the same camera change nothing. */
    double lod_first = lod_ms[0];
    double lod_med = median(lod_ms, o.repeat);
    free(lod_ms);

    rc = 1;
    hz_err err = {0};
    hz_renderer *ren = NULL;
    app_fx afx = {0};
    hz_gl *gl = hz_gl_create_headless(&err);
    if (!gl)
        goto done;
    ren = hz_renderer_create(&(hz_renderer_desc){.width = o.width, .height = o.height}, &err);
    if (!ren || cli_renderer_setup(ren, t, &o, &err) != HZ_OK)
        goto done;
    if (app_fx_setup(&afx, &o, t, ren, "render")) {
        snprintf(err.msg, sizeof err.msg, "effects setup failed");
        goto done;
    }
    hz_scene_params sp = {.wireframe = o.wireframe};
    app_fx_params(&afx, t, &cam, &o.lod, o.time, &sp);
    const uint32_t *draw_idx;
    uint32_t draw_count;
    cli_lod_scene(&lf, &sp, &draw_idx, &draw_count);
    if (o.forest_n) {
        cf = cli_forest_create(&o, t);
        if (!cf) {
            hz_err_set(&err, HZ_ERR_VALUE, "no forest");
            goto done;
        }
        if (!cli_forest_update(cf, &o, &cam, 0.0))
            goto done;
        cli_forest_hook(cf, &sp);
    }
    if (ca) {
        if (city_app_gpu(ca, "render"))
            goto done;
        if (o.city.bench) {
            rc = city_app_bench(ca, &o, t, ren, &afx, o.json);
            err.msg[0] = 0;
            goto done_bench;
        }
        city_app_frame(ca, &o, &cam, &sp);
    }
    double draw[3];
    hz_draw_stats ds = {0};
    for (int k = 0; k < 3; k++) {
        if (hz_renderer_draw(ren, &cam, &sp, draw_idx, draw_count, &ds, &err) != HZ_OK)
            goto done;
        if (cf && cf->hook.failed) {
            err = cf->hook.err;
            goto done;
        }
        if (ca && ca->hook.failed) {
            err = ca->hook.err;
            goto done;
        }
        draw[k] = ds.draw_ms;
    }
    double draw_first = draw[0];
    char fxs[200];
    hz_fx_format(o.effects, fxs, sizeof fxs);
    double draw_med = median(draw, 3);
    uint8_t *rgb = malloc((size_t)o.width * o.height * 3);
    hz_outfile png;
    if (!rgb || hz_renderer_read_rgb(ren, rgb, &err) != HZ_OK || hz_outfile_begin(&png, out, &err) != HZ_OK) {
        free(rgb);
        goto done;
    }
    if (hz_image_write_png(png.tmp, rgb, o.width, o.height, &err) != HZ_OK || hz_outfile_commit(&png, &err) != HZ_OK) {
        hz_outfile_discard(&png);
        free(rgb);
        goto done;
    }
    free(rgb);
    if (o.dump_mesh && write_obj(o.dump_mesh, t, &il, &cam, &st))
        goto done;

    /* Never a blank image without a word: no terrain triangle in the frustum. */
    const bool in_view = il.count > 0;
    if (!in_view)
        fprintf(stderr, "horizon render: the terrain is not in view from camera %.0f,%.0f,%.0f yaw %.1f pitch %.1f "
                        "(far %.0f m): the image shows only sky\n",
                (double)cam.pos[0], (double)cam.pos[1], (double)cam.pos[2], (double)cam.yaw, (double)cam.pitch,
                (double)cam.zfar);
    char water[32] = "null";
    if (afx.water)
        snprintf(water, sizeof water, "%.2f", (double)afx.water_level);
    if (o.json) {
        printf("{\"terrain\":\"%s\",\"heightmap_size\":%u,\"spacing\":%g,\"zscale\":%g,"
               "\"layout\":\"%s\",\"lod_mode\":\"%s\",\"pixel_error\":%g,\"lod_c\":%g,\"lod_c2\":%g,"
               "\"criterion\":\"%s\",\"forced\":%u,\"merged\":%u,\"lod_ms_first\":%.4f,"
               "\"camera\":[%g,%g,%g,%g,%g],\"fov\":%g,\"far\":%g,\"width\":%u,\"height\":%u,"
               "\"triangles\":%u,\"vertices\":%zu,\"nodes_visited\":%u,\"nodes_culled\":%u,"
               "\"leaves\":%u,\"restricted\":%u,\"lod_ms\":%.4f,\"lod_runs\":%u,\"upload_ms\":%.3f,"
               "\"draw_ms\":%.3f,\"draw_ms_first\":%.3f,\"bytes_per_sample\":%.3f,"
               "\"lod_bytes\":%zu,\"load_ms\":%.1f,\"prep_ms\":%.1f,\"peak_rss_mb\":%.1f,\"out\":\"%s\","
               "\"effects\":\"%s\",\"fx_setup_ms\":%.1f,\"lightmap_ms\":%.1f,\"trees\":%zu,\"billboards\":%u,"
               "\"particles\":%u,\"reflections\":%u,\"sun_visible\":%.4f,\"water_level\":%s",
               t->source, t->hm.size, (double)t->spacing, (double)t->zscale, hz_layout_name(t->hm.layout),
               hz_lod_mode_name(o.lod.mode), (double)o.lod.pixel_error,
               (double)(o.lod.c > 0 ? o.lod.c : 25), (double)(o.lod.c2 > 0 ? o.lod.c2 : 2.5f),
               o.lod.criterion == HZ_LOD_UNCLAMPED ? "unclamped" : "clamped", st.forced, st.merged, lod_first,
               (double)cam.pos[0],
               (double)cam.pos[1], (double)cam.pos[2], (double)cam.yaw, (double)cam.pitch,
               (double)cam.fov_y, (double)cam.zfar, o.width, o.height, st.triangles,
               count_vertices(&il, t->hm.size), st.nodes_visited, st.nodes_culled, st.leaves,
               st.restricted, lod_med, o.repeat, ds.upload_ms, draw_med, draw_first,
               hz_lod_bytes_per_sample(t->lod), hz_lod_memory_bytes(t->lod), t->load_ms, t->prep_ms,
               (double)hz_peak_rss_bytes() / (1024.0 * 1024.0), out, fxs, afx.setup_ms, afx.lightmap_ms, afx.trees,
               ds.billboards, ds.particles, ds.reflections, (double)ds.sun_visible, water);
        printf(",\"terrain_in_view\":%s", in_view ? "true" : "false");
        printf(",\"triangles_masked\":%zu,\"data_size\":[%u,%u],\"samples_valid\":%llu,\"file_samples\":%llu",
               masked_tris, t->data_w, t->data_h, (unsigned long long)t->valid_count,
               (unsigned long long)t->file_samples);
        cli_print_georef_json(t, &cam);
        if (cf) {
            const hz_forest_frame *fr = &cf->frame;
            printf(",\"forest_trees\":%u,\"trees_in_frustum\":%u,\"trees_detailed\":%u,\"trees_hull\":%u,"
                   "\"triangles_full\":%llu,\"triangles_drawn\":%llu,\"leaves_drawn\":%llu,\"nodes_culled\":%u,"
                   "\"forest_draw_ms\":%.3f,\"forest_select_ms\":%.3f,\"forest_prep_ms\":%.1f",
                   fr->trees, fr->trees_in_frustum, fr->trees_detailed, fr->trees_hull,
                   (unsigned long long)fr->triangles_full, (unsigned long long)fr->triangles_drawn,
                   (unsigned long long)fr->leaves_drawn, fr->nodes_culled, cf->hook.draw_ms, fr->select_ms,
                   cf->prep_ms);
        }
        if (ca)
            city_app_print(ca, true);
        if (o.city.have_pick)
            city_app_pick(ca, t, &cam, o.city.pick[0], o.city.pick[1], o.width, o.height, true);
        printf("}\n");
    } else {
        printf("terrain       %s (%ux%u, %.1f m spacing%s%s)\n", t->source, t->hm.size, t->hm.size,
               (double)t->spacing, t->note[0] ? "; " : "", t->note);
        printf("camera        %.0f,%.0f,%.0f yaw %.1f pitch %.1f fov %.0f far %.0f m\n", (double)cam.pos[0],
               (double)cam.pos[1], (double)cam.pos[2], (double)cam.yaw, (double)cam.pitch,
               (double)cam.fov_y, (double)cam.zfar);
        cli_print_georef_text(t, &cam);
        if (o.lod.pixel_error > 0 || o.lod.mode == HZ_LOD_ROAM || o.lod.mode == HZ_LOD_CDLOD)
            printf("LOD mode      %s, pixel error %g px\n", hz_lod_mode_name(o.lod.mode),
                   (double)(o.lod.pixel_error > 0 ? o.lod.pixel_error : 1.0f));
        else
            printf("LOD mode      %s, C %g, C2 %g (%s)\n", hz_lod_mode_name(o.lod.mode),
                   (double)(o.lod.c > 0 ? o.lod.c : 25), (double)(o.lod.c2 > 0 ? o.lod.c2 : 2.5f),
                   o.lod.criterion == HZ_LOD_UNCLAMPED ? "unclamped" : "clamped");
        printf("triangles     %u\n", st.triangles);
        printf("nodes         %u visited, %u culled, %u drawn\n", st.nodes_visited, st.nodes_culled, st.leaves);
        printf("LOD           %.3f ms (median of %u; first %.3f ms)\n", lod_med, o.repeat, lod_first);
        printf("draw          %.1f ms (median of 3; first %.1f ms) on %s\n", draw_med, draw_first,
               hz_gl_describe(gl));
        printf("LOD memory    %.2f bytes/sample (%.1f MB)\n", hz_lod_bytes_per_sample(t->lod),
               (double)hz_lod_memory_bytes(t->lod) / 1048576.0);
        printf("effects       %s", fxs);
        if (o.effects)
            printf(" (setup %.0f ms: light map %.0f ms, %zu trees; %u billboards, %u particles drawn%s)",
                   afx.setup_ms, afx.lightmap_ms, afx.trees, ds.billboards, ds.particles,
                   ds.reflections ? ", water reflected" : "");
        printf("\n");
        if (cf) {
            const hz_forest_frame *fr = &cf->frame;
            printf("forest        %u trees, %u in the frustum (%u detailed, %u crown hulls)\n", fr->trees,
                   fr->trees_in_frustum, fr->trees_detailed, fr->trees_hull);
            printf("forest tris   %llu drawn of %llu full (%.1f%%), %.1f ms draw, %.2f ms selection%s\n",
                   (unsigned long long)fr->triangles_drawn, (unsigned long long)fr->triangles_full,
                   fr->triangles_full ? 100.0 * (double)fr->triangles_drawn / (double)fr->triangles_full : 0.0,
                   cf->hook.draw_ms, fr->select_ms, o.forest.simplify ? "" : " (unsimplified)");
        }
        if (ca)
            city_app_print(ca, false);
        if (o.city.have_pick)
            city_app_pick(ca, t, &cam, o.city.pick[0], o.city.pick[1], o.width, o.height, false);
        printf("image         %s (%ux%u)\n", out, o.width, o.height);
    }
    rc = 0;
done:
    if (rc)
        fprintf(stderr, "horizon render: %s\n", err.msg[0] ? err.msg : "failed");
done_bench:
    cli_forest_destroy(cf);
    city_app_destroy(ca);
    app_fx_free(&afx);
    hz_renderer_destroy(ren);
    hz_gl_destroy(gl);
    cli_lod_frame_free(&lf);
    hz_terrain_destroy(t);
    return rc;
}
