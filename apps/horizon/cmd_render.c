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
    if (cli_wants_stream(argc, argv, 2))
        return stream_render(argc, argv);
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
    if (o.city.have_pick && (o.city.pick[0] >= (float)o.width || o.city.pick[1] >= (float)o.height)) {
        fprintf(stderr, "horizon render: --pick %g,%g lies outside the %ux%u image (pixels from 0,0 at the top-left)\n",
                (double)o.city.pick[0], (double)o.city.pick[1], o.width, o.height);
        return 2;
    }
    const char *out = o.out ? o.out : "render.png";
    cli_file ins[8];
    const size_t nin = cli_opts_inputs(&o, ins, 0, 8);
    const cli_file outs[] = {{out, "--out", CLI_FILE}, {o.dump_mesh, "--dump-mesh", CLI_FILE},
                             {o.forest_save, "--forest-save", CLI_FILE}};
    if ((rc = cli_check_outputs("render", outs, 3, ins, nin)))
        return rc;
    if ((o.lod.c > 0 || o.lod.c2 > 0 || o.lod.criterion) && !o.quiet &&
        (o.lod.mode == HZ_LOD_CDLOD || o.lod.mode == HZ_LOD_ROAM))
        fprintf(stderr, "horizon render: note: --lod-c, --lod-c2 and --criterion apply to the quadtree modes; "
                        "%s takes --pixel-error (add --lod quadtree for C and C2)\n",
                hz_lod_mode_name(o.lod.mode));
    city_app *ca = city_app_load(&o, "render", &rc);
    if (rc)
        return rc;
    hz_terrain *t = cli_load_terrain(&o);
    if (!t || (ca && city_app_place(ca, t, "render"))) {
        city_app_destroy(ca);
        hz_terrain_destroy(t);
        return 1;
    }
    cli_curvature(&o, t);
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
    app_fx_objects(&afx, ca);
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
        cf = cli_forest_create(&o, t, ca ? ca->casters : NULL);
        if (!cf) {
            hz_err_set(&err, HZ_ERR_VALUE, "no forest");
            goto done;
        }
        if (cli_forest_billboards(cf, &o, ren))
            goto done;
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
        city_app_frame(ca, &o, &cam, o.width, o.height, &sp);
    }
    double draw[3];
    hz_draw_stats ds = {0};
    /* Three frames timed; with objects or trees a fourth (not counted) that
     * waits for the GPU around them, for their own ms in the figures printed. */
    for (int k = 0; k < (ca || cf ? 4 : 3); k++) {
        if (ca)
            ca->hook.time_draw = k == 3;
        if (cf)
            cf->hook.time_draw = k == 3;
        hz_draw_stats dk = {0};
        if (hz_renderer_draw(ren, &cam, &sp, draw_idx, draw_count, k < 3 ? &ds : &dk, &err) != HZ_OK)
            goto done;
        if (cf && cf->hook.failed) {
            err = cf->hook.err;
            goto done;
        }
        if (ca && ca->hook.failed) {
            err = ca->hook.err;
            goto done;
        }
        if (k < 3)
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
        json_t *j = json_object();
        jx_set(j, "terrain", jx_str(t->source));
        jx_set(j, "heightmap_size", jx_int(t->hm.size));
        jx_set(j, "spacing", jx_num(t->spacing));
        jx_set(j, "zscale", jx_num(t->zscale));
        jx_set(j, "layout", jx_str(hz_layout_name(t->hm.layout)));
        jx_set(j, "lod_mode", jx_str(hz_lod_mode_name(o.lod.mode)));
        jx_set(j, "pixel_error", jx_num(cli_pixel_error(&o.lod)));
        cli_near_json(j, &o.lod);
        jx_set(j, "lod_c", jx_num(o.lod.c > 0 ? o.lod.c : 25));
        jx_set(j, "lod_c2", jx_num(o.lod.c2 > 0 ? o.lod.c2 : 2.5f));
        jx_set(j, "criterion", jx_str(o.lod.criterion == HZ_LOD_UNCLAMPED ? "unclamped" : "clamped"));
        jx_set(j, "forced", jx_int(st.forced));
        jx_set(j, "merged", jx_int(st.merged));
        jx_set(j, "lod_ms_first", jx_fix(lod_first, 4));
        jx_set(j, "camera", json_pack("[ooooo]", jx_fix(cam.pos[0], 3), jx_fix(cam.pos[1], 3), jx_fix(cam.pos[2], 3),
                                      jx_fix(cam.yaw, 4), jx_fix(cam.pitch, 4)));
        jx_set(j, "fov", jx_num(cam.fov_y));
        jx_set(j, "far", jx_fix(cam.zfar, 1));
        curv_cli_json(j, &o.curv);
        jx_set(j, "width", jx_int(o.width));
        jx_set(j, "height", jx_int(o.height));
        jx_set(j, "triangles", jx_int(st.triangles));
        jx_set(j, "vertices", jx_int((long long)count_vertices(&il, t->hm.size)));
        jx_set(j, "nodes_visited", jx_int(st.nodes_visited));
        jx_set(j, "nodes_culled", jx_int(st.nodes_culled));
        jx_set(j, "nodes_hidden", jx_int(st.hidden));
        jx_set(j, "leaves", jx_int(st.leaves));
        jx_set(j, "leaves_still", jx_int(st.still));
        jx_set(j, "restricted", jx_int(st.restricted));
        jx_set(j, "lod_ms", jx_fix(lod_med, 4));
        jx_set(j, "lod_runs", jx_int(o.repeat));
        jx_set(j, "upload_ms", jx_fix(ds.upload_ms, 3));
        jx_set(j, "draw_ms", jx_fix(draw_med, 3));
        jx_set(j, "draw_ms_first", jx_fix(draw_first, 3));
        jx_set(j, "bytes_per_sample", jx_fix(hz_lod_bytes_per_sample(t->lod), 3));
        jx_set(j, "lod_bytes", jx_int((long long)hz_lod_memory_bytes(t->lod)));
        jx_set(j, "load_ms", jx_fix(t->load_ms, 1));
        jx_set(j, "prep_ms", jx_fix(t->prep_ms, 1));
        jx_set(j, "peak_rss_mb", jx_fix((double)hz_peak_rss_bytes() / (1024.0 * 1024.0), 1));
        jx_set(j, "out", jx_str(out));
        jx_set(j, "effects", jx_str(fxs));
        jx_set(j, "fx_setup_ms", jx_fix(afx.setup_ms, 1));
        if (o.imagery) {
            json_t *im = json_object();
            jx_set(im, "file", jx_str(o.imagery));
            jx_set(im, "texels_per_side", jx_int(afx.imagery_side));
            jx_set(im, "tiles_per_side", jx_int(afx.imagery_tiles));
            jx_set(im, "metres_per_texel", jx_fix((double)hz_terrain_extent(t) / (afx.imagery_side ? (double)afx.imagery_side : 1.0), 3));
            jx_set(im, "image_metres_per_pixel", jx_fix(afx.imagery_native_m, 3));
            jx_set(im, "coverage", jx_fix(afx.imagery_coverage, 4));
            jx_set(im, "load_ms", jx_fix(afx.imagery_ms, 1));
            jx_set(j, "imagery", im);
        }
        jx_set(j, "lightmap_ms", jx_fix(afx.lightmap_ms, 1));
        jx_set(j, "trees", jx_int((long long)afx.trees));
        jx_set(j, "billboards", jx_int(ds.billboards));
        jx_set(j, "particles", jx_int(ds.particles));
        jx_set(j, "reflections", jx_int(ds.reflections));
        jx_set(j, "sun_visible", jx_fix(ds.sun_visible, 4));
        jx_set(j, "water_level", afx.water ? jx_fix(afx.water_level, 2) : json_null());
        jx_set(j, "terrain_in_view", jx_bool(in_view));
        jx_set(j, "climate", jx_str(hz_climate_name(afx.climate.kind)));
        jx_set(j, "climate_from_place", jx_bool(afx.climate_known));
        jx_set(j, "snow_line", jx_fix(afx.climate.snow_line, 0));
        jx_set(j, "tree_line", jx_fix(afx.climate.tree_line, 0));
        jx_set(j, "aridity", jx_fix(afx.climate.aridity, 2));
        jx_set(j, "triangles_masked", jx_int((long long)masked_tris));
        jx_set(j, "data_size", json_pack("[II]", (json_int_t)t->data_w, (json_int_t)t->data_h));
        jx_set(j, "samples_valid", jx_int((long long)t->valid_count));
        jx_set(j, "file_samples", jx_int((long long)t->file_samples));
        cli_georef_json(j, t, &cam);
        if (cf) {
            const hz_forest_frame *fr = &cf->frame;
            jx_set(j, "forest_trees", jx_int(fr->trees));
            jx_set(j, "trees_in_frustum", jx_int(fr->trees_in_frustum));
            jx_set(j, "trees_detailed", jx_int(fr->trees_detailed));
            jx_set(j, "trees_hull", jx_int(fr->trees_hull));
            jx_set(j, "triangles_full", jx_int((long long)fr->triangles_full));
            jx_set(j, "triangles_drawn", jx_int((long long)fr->triangles_drawn));
            jx_set(j, "leaves_drawn", jx_int((long long)fr->leaves_drawn));
            /* The forest's own culled nodes (the terrain's are nodes_culled). */
            jx_set(j, "forest_nodes_culled", jx_int(fr->nodes_culled));
            jx_set(j, "forest_draw_ms", jx_fix(cf->hook.draw_ms, 3));
            jx_set(j, "forest_select_ms", jx_fix(fr->select_ms, 3));
            jx_set(j, "forest_prep_ms", jx_fix(cf->prep_ms, 1));
        }
        if (ca)
            city_app_print(ca, j);
        if (o.city.have_pick)
            city_app_pick(ca, t, &cam, o.city.pick[0] + 0.5f, o.city.pick[1] + 0.5f, o.width, o.height, j);
        if (jx_print(j, stdout)) {
            snprintf(err.msg, sizeof err.msg, "cannot write the JSON to stdout");
            goto done;
        }
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
        curv_cli_print(&o.curv);
        printf("nodes         %u visited, %u culled, %u drawn", st.nodes_visited, st.nodes_culled, st.leaves);
        if (o.lod.mode == HZ_LOD_CDLOD)
            printf(" (%u still: no vertex morphs), %u hidden by nearer ground", st.still, st.hidden);
        printf("\n");
        printf("LOD           %.3f ms (median of %u; first %.3f ms)\n", lod_med, o.repeat, lod_first);
        printf("draw          %.1f ms (median of 3; first %.1f ms) on %s\n", draw_med, draw_first,
               hz_gl_describe(gl));
        printf("LOD memory    %.2f bytes/sample (%.1f MB)\n", hz_lod_bytes_per_sample(t->lod),
               (double)hz_lod_memory_bytes(t->lod) / 1048576.0);
        printf("climate       %s%s: snow above %.0f m, trees below %.0f m, aridity %.2f\n",
               hz_climate_name(afx.climate.kind), afx.climate_known ? " (from the place)" : " (default)",
               (double)afx.climate.snow_line, (double)afx.climate.tree_line, (double)afx.climate.aridity);
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
            city_app_print(ca, NULL);
        if (o.city.have_pick)
            city_app_pick(ca, t, &cam, o.city.pick[0] + 0.5f, o.city.pick[1] + 0.5f, o.width, o.height, NULL);
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
