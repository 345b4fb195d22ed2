/* horizon tree: grow, import, rank (VMI), hull, inspect and preview trees. */
#include "cli.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "horizon/safety.h"
#include <sys/stat.h>

#include "horizon/forest_render.h"

static void usage(void)
{
    fprintf(stderr,
            "usage: horizon tree [source] [processing] [output]\n"
            "Grows (or imports, or loads) a tree, ranks its leaves by VMI, builds its crown hull,\n"
            "and writes a .hzt tree file.\n"
            "source (one of):\n"
            "  --species NAME          grow oak, maple, birch or conifer (default oak)\n"
            "  --seed S                growth seed (default 1)\n"
            "  --leaves N              target leaf count (default: the species', 50 000..100 000)\n"
            "  --max-memory SIZE       refuse an import needing more (default half the RAM)\n"
            "  --import FILE           OBJ/glTF/... through assimp; leaves are meshes named\n"
            "                          leaf/leaves/foliage/needle (mesh, node or material name)\n"
            "  --leaf-match TEXT       other name part that marks leaf meshes\n"
            "  --up y|z                imported up axis (default: the longest extent)\n"
            "  --scale F               imported units to metres (default 1)\n"
            "  --node-leaves N         imported leaves per leaf node, at most (default 48)\n"
            "  --in FILE.hzt           load a tree file\n"
            "processing:\n"
            "  --no-rank               skip the VMI ranking (done by default when not yet ranked)\n"
            "  --rank                  rank again even if the tree is ranked\n"
            "  --views 12|42|162       VMI viewpoints on the icosahedron (default 162)\n"
            "  --min-elevation DEG     only viewpoints at or above this elevation over the crown\n"
            "                          (default 0: from the side and above, as distant trees are seen;\n"
            "                          -90: the whole sphere)\n"
            "  --rank-tree PX          rank in the whole tree rendered PX pixels across, so that a leaf's\n"
            "                          visible area is what the rest of the crown leaves of it (default\n"
            "                          2048; 0: each leaf node rendered alone)\n"
            "  --rank-res PX           with --rank-tree 0: item-buffer pixels across a leaf node (default 32)\n"
            "  --layers L              depth-peeled layers per pixel (default 4)\n"
            "  --no-hull               skip the crown hull (built by default when missing)\n"
            "  --hull-grid N           density grid voxels along the crown (default 40)\n"
            "  --hull-triangles N      hull simplification target (default 3000)\n"
            "output:\n"
            "  --out FILE.hzt          write the tree\n"
            "  --json                  figures as one JSON object on stdout\n"
            "  --preview FILE.png      render the tree alone (leaves, bark) headless\n"
            "  --rate R                simplification rate of every leaf node in the preview (default 0)\n"
            "  --hull-preview          draw the crown hull instead of the leaves in the preview\n"
            "  --size N                preview size in pixels (default 512)\n"
            "  --pr                    precision/recall at 50%% simplification, of foliage coverage and\n"
            "                          of the same leaf per pixel, VMI order vs random order, with and\n"
            "                          without enlargement\n"
            "  --pr-views N --pr-res N views (default 16) and image size (default 512) for --pr\n"
            "  --pr-shuffles N         random orders pooled into the random rows (default 4, 1..64);\n"
            "                          the JSON gives their spread (_min, _max)\n"
            "  --quiet                 no progress bars\n");
}

static int bad(const char *opt, const char *val, const char *want)
{
    fprintf(stderr, "horizon tree: invalid value '%s' for %s: expected %s\n", val ? val : "", opt, want);
    return 2;
}

typedef struct pr_row {
    const char *order;
    bool enlarge;
    hz_pr_result r;
    double leaf_p[2], leaf_r[2]; /* random rows: the least and greatest over the orders */
} pr_row;

/* Renders the tree alone: a one-tree forest on no terrain, through the hook. */
static int preview(const hz_tree *t, const char *file, uint32_t size, float rate, bool hull, hz_err *err)
{
    hz_forest_tree ft = {.pos = {0, 0, 0}, .yaw = 0, .scale = 1, .model = 0};
    const hz_tree *models[1] = {t};
    hz_forest *f = hz_forest_create(models, 1, &ft, 1, err);
    if (!f)
        return 1;
    int rc = 1;
    hz_renderer *ren = hz_renderer_create(&(hz_renderer_desc){.width = size, .height = size}, err);
    hz_forest_gpu *gpu = ren ? hz_forest_gpu_create(f, err) : NULL;
    uint8_t *rgb = malloc((size_t)size * size * 3);
    if (!ren || !gpu || !rgb)
        goto done;
    float r = t->bound_radius;
    hz_camera cam = {.pos = {t->bound_center[0] + 0.35f * r, t->bound_center[1] + 0.2f * r, t->bound_center[2] + 2.6f * r},
                     .yaw = -7.7f, .pitch = -4.0f, .fov_y = 45.0f, .aspect = 1.0f, .znear = 0.05f, .zfar = 10.0f * r};
    hz_forest_params fp = {.simplify = true, .enlarge = true, .fixed_rate = true, .fixed = rate,
                           .hull_dist = hull ? 1e-3f : 1e9f, .impostor_dist = 1e9f};
    hz_forest_frame fr;
    if (hz_forest_update(f, &cam, &fp, 0.0, &fr, err) != HZ_OK)
        goto done;
    hz_forest_hook hook = {.gpu = gpu, .forest = f, .frame = &fr};
    hz_scene_params sp = {.draw_objects = hz_forest_draw_hook, .draw_objects_user = &hook, .fog_density = -1};
    if (hz_renderer_draw(ren, &cam, &sp, NULL, 0, NULL, err) != HZ_OK)
        goto done;
    if (hook.failed) {
        *err = hook.err;
        goto done;
    }
    hz_outfile of = {0};
    if (hz_renderer_read_rgb(ren, rgb, err) != HZ_OK || hz_outfile_begin(&of, file, err) != HZ_OK ||
        hz_image_write_png(of.tmp, rgb, size, size, err) != HZ_OK || hz_outfile_commit(&of, err) != HZ_OK) {
        hz_outfile_discard(&of);
        goto done;
    }
    rc = 0;
done:
    free(rgb);
    hz_forest_gpu_destroy(gpu);
    hz_renderer_destroy(ren);
    hz_forest_destroy(f);
    return rc;
}

int cmd_tree(int argc, char **argv)
{
    hz_tree_desc gd = {.species = NULL, .seed = 1};
    hz_tree_import_desc id = {0};
    const char *in = NULL, *out = NULL, *preview_file = NULL;
    bool json = false, quiet = false, no_rank = false, force_rank = false, no_hull = false, pr = false,
         hull_preview = false, have_species = false;
    hz_rank_desc rd = {.tree_res = HZ_RANK_TREE_RES};
    bool rank_res_given = false;
    hz_hull_desc hd = {0};
    hz_pr_desc prd = {.rate = 0.5f};
    uint32_t shuffles = HZ_PR_ORDERS_DEFAULT;
    uint32_t size = 512;
    float rate = 0.0f;
    for (int i = 2; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            usage();
            return 0;
        }
        bool flag = !strcmp(a, "--json") || !strcmp(a, "--quiet") || !strcmp(a, "-q") || !strcmp(a, "--no-rank") ||
                    !strcmp(a, "--rank") || !strcmp(a, "--no-hull") || !strcmp(a, "--pr") ||
                    !strcmp(a, "--hull-preview");
        static const char *const valued[] = {"--species", "--seed", "--leaves", "--import", "--leaf-match", "--up",
                                             "--scale", "--node-leaves", "--in", "--out", "--preview", "--views", "--min-elevation",
                                             "--rank-res", "--rank-tree", "--layers", "--hull-grid", "--hull-triangles", "--rate",
                                             "--size", "--pr-views", "--pr-res", "--pr-shuffles", "--max-memory"};
        bool is_known = flag;
        for (size_t k = 0; k < sizeof valued / sizeof valued[0] && !is_known; k++)
            is_known = !strcmp(a, valued[k]);
        if (!is_known)
            return cli_unknown("tree", argv, argc, i);
        if (!flag && !v) {
            fprintf(stderr, "horizon tree: option %s needs a value (see horizon tree --help)\n", a);
            return 2;
        }
        if (!strcmp(a, "--json")) json = true;
        else if (!strcmp(a, "--quiet") || !strcmp(a, "-q")) quiet = true;
        else if (!strcmp(a, "--no-rank")) no_rank = true;
        else if (!strcmp(a, "--rank")) force_rank = true;
        else if (!strcmp(a, "--no-hull")) no_hull = true;
        else if (!strcmp(a, "--pr")) pr = true;
        else if (!strcmp(a, "--hull-preview")) hull_preview = true;
        else {
            i++;
            if (!strcmp(a, "--species")) {
                gd.species = v;
                have_species = true;
                bool known = false;
                for (const char *const *n = hz_tree_species_names(); *n; n++)
                    known |= !strcmp(*n, v);
                if (!known)
                    return bad(a, v, "oak, maple, birch or conifer");
            } else if (!strcmp(a, "--seed")) {
                char *end;
                errno = 0;
                gd.seed = strtoull(v, &end, 10);
                if (errno || *end || end == v || v[0] == '-')
                    return bad(a, v, "a non-negative integer");
            } else if (!strcmp(a, "--leaves")) {
                if (!cli_parse_u32(v, 1, 2000000, &gd.leaves))
                    return bad(a, v, "a count in [1, 2000000]");
            } else if (!strcmp(a, "--import")) id.path = v;
            else if (!strcmp(a, "--max-memory")) {
                if (!hz_size_parse(v, (uint64_t)1 << 20, (uint64_t)1 << 50, &id.max_memory))
                    return bad(a, v, "a size such as 512M or 8G");
            }
            else if (!strcmp(a, "--leaf-match")) id.leaf_match = v;
            else if (!strcmp(a, "--up")) {
                if (strcmp(v, "y") && strcmp(v, "z"))
                    return bad(a, v, "y or z");
                id.up = v[0];
            } else if (!strcmp(a, "--scale")) {
                if (!cli_parse_float(v, 1e-6, 1e6, &id.scale))
                    return bad(a, v, "a factor in [1e-6, 1e6]");
            } else if (!strcmp(a, "--node-leaves")) {
                if (!cli_parse_u32(v, 1, 4096, &id.node_leaves))
                    return bad(a, v, "a count in [1, 4096]");
            } else if (!strcmp(a, "--in")) in = v;
            else if (!strcmp(a, "--out")) out = v;
            else if (!strcmp(a, "--preview")) preview_file = v;
            else if (!strcmp(a, "--views")) {
                if (!cli_parse_u32(v, 12, 162, &rd.views) || (rd.views != 12 && rd.views != 42 && rd.views != 162))
                    return bad(a, v, "12, 42 or 162");
            } else if (!strcmp(a, "--min-elevation")) {
                float e;
                if (!cli_parse_float(v, -90.0, 90.0, &e) || e != (float)(int)e)
                    return bad(a, v, "whole degrees in [-90, 90]");
                rd.min_elevation = (int32_t)e;
            } else if (!strcmp(a, "--rank-res")) {
                if (!cli_parse_u32(v, 4, 256, &rd.res))
                    return bad(a, v, "pixels in [4, 256]");
                rank_res_given = true;
            } else if (!strcmp(a, "--rank-tree")) {
                if (!cli_parse_u32(v, 0, 4096, &rd.tree_res) || (rd.tree_res && rd.tree_res < 512))
                    return bad(a, v, "0 or pixels in [512, 4096]");
            } else if (!strcmp(a, "--layers")) {
                if (!cli_parse_u32(v, 1, 16, &rd.layers))
                    return bad(a, v, "a count in [1, 16]");
            } else if (!strcmp(a, "--hull-grid")) {
                if (!cli_parse_u32(v, 8, 256, &hd.grid))
                    return bad(a, v, "voxels in [8, 256]");
            } else if (!strcmp(a, "--hull-triangles")) {
                if (!cli_parse_u32(v, 16, 1000000, &hd.triangles))
                    return bad(a, v, "a count in [16, 1000000]");
            } else if (!strcmp(a, "--rate")) {
                if (!cli_parse_float(v, 0.0, 0.99, &rate))
                    return bad(a, v, "a rate in [0, 0.99]");
            } else if (!strcmp(a, "--size")) {
                if (!cli_parse_u32(v, 16, 4096, &size))
                    return bad(a, v, "pixels in [16, 4096]");
            } else if (!strcmp(a, "--pr-views")) {
                if (!cli_parse_u32(v, 1, 1024, &prd.views))
                    return bad(a, v, "a count in [1, 1024]");
            } else if (!strcmp(a, "--pr-res")) {
                if (!cli_parse_u32(v, 16, 4096, &prd.res))
                    return bad(a, v, "pixels in [16, 4096]");
            } else if (!strcmp(a, "--pr-shuffles")) {
                if (!cli_parse_u32(v, 1, HZ_PR_ORDERS_MAX, &shuffles)) {
                    char want[32];
                    snprintf(want, sizeof want, "a count in [1, %u]", HZ_PR_ORDERS_MAX);
                    return bad(a, v, want);
                }
            } else {
                fprintf(stderr, "horizon tree: unknown option '%s' (see horizon tree --help)\n", a);
                return 2;
            }
        }
    }
    if (!in && !id.path && !have_species && !gd.leaves) {
        /* Bare "horizon tree" would grow an oak for a minute and save nothing. */
        usage();
        fprintf(stderr, "horizon tree: give a source: --species NAME (or --leaves N), --import FILE or --in FILE\n");
        return 2;
    }
    if ((in != NULL) + (id.path != NULL) + (have_species || gd.leaves) > 1) {
        fprintf(stderr, "horizon tree: give one source: --species/--leaves, --import or --in\n");
        return 2;
    }
    if (no_rank && force_rank) {
        fprintf(stderr, "horizon tree: --rank and --no-rank contradict each other\n");
        return 2;
    }
    if (rank_res_given && rd.tree_res) {
        fprintf(stderr, "horizon tree: --rank-res sizes a leaf node rendered alone: give it with --rank-tree 0\n");
        return 2;
    }
    const cli_file ins[] = {{in, "--in", CLI_FILE}, {id.path, "--import", CLI_FILE}};
    const cli_file outs[] = {{out, "--out", CLI_FILE}, {preview_file, "--preview", CLI_FILE}};
    if (cli_check_outputs("tree", outs, 2, ins, 2))
        return 2;
    hz_err err = {0};
    double t0 = hz_time_ms();
    hz_tree *t = in ? hz_tree_load(in, &err) : id.path ? hz_tree_import(&id, &err) : hz_tree_grow(&gd, &err);
    if (!t) {
        fprintf(stderr, "horizon tree: %s\n", err.msg);
        return 1;
    }
    double source_ms = hz_time_ms() - t0;
    int rc = 1;
    hz_gl *gl = NULL;
    hz_rank_stats rs = {0};
    hz_hull_stats hs = {0};
    pr_row rows[4] = {{.order = "vmi"}, {.order = "vmi", .enlarge = true}, {.order = "random"},
                      {.order = "random", .enlarge = true}};
    bool need_gl = (!no_rank && (!t->ranked || force_rank)) || preview_file || pr;
    if (need_gl) {
        gl = hz_gl_create_headless(&err);
        if (!gl)
            goto done;
    }
    if (!no_rank && (!t->ranked || force_rank)) {
        rd.progress = quiet ? NULL : cli_tree_progress;
        if (hz_tree_rank(t, &rd, &rs, &err) != HZ_OK)
            goto done;
    }
    if (!no_hull && t->hull.index_count == 0) {
        if (hz_hull_build(t, &hd, &hs, &err) != HZ_OK)
            goto done;
    }
    if (out) {
        hz_outfile of;
        if (hz_outfile_begin(&of, out, &err) != HZ_OK)
            goto done;
        if (hz_tree_save(t, of.tmp, &err) != HZ_OK || hz_outfile_commit(&of, &err) != HZ_OK) {
            hz_outfile_discard(&of);
            goto done;
        }
    }
    if (preview_file && preview(t, preview_file, size, rate, hull_preview, &err))
        goto done;
    if (pr) {
        hz_pr_result each[HZ_PR_ORDERS_MAX];
        for (int k = 0; k < 4; k++) {
            hz_pr_desc d = prd;
            d.enlarge = rows[k].enlarge;
            if (k < 2) {
                if (hz_tree_pr(t, &d, &rows[k].r, &err) != HZ_OK)
                    goto done;
                continue;
            }
            if (hz_tree_pr_random(t, &d, shuffles, 12345, &rows[k].r, each, &err) != HZ_OK)
                goto done;
            rows[k].leaf_p[0] = rows[k].leaf_r[0] = 1;
            for (uint32_t s = 0; s < shuffles; s++) {
                rows[k].leaf_p[0] = fmin(rows[k].leaf_p[0], each[s].leaf_precision);
                rows[k].leaf_p[1] = fmax(rows[k].leaf_p[1], each[s].leaf_precision);
                rows[k].leaf_r[0] = fmin(rows[k].leaf_r[0], each[s].leaf_recall);
                rows[k].leaf_r[1] = fmax(rows[k].leaf_r[1], each[s].leaf_recall);
            }
        }
    }
    long long file_bytes = -1;
    struct stat sb;
    if (out && stat(out, &sb) == 0)
        file_bytes = (long long)sb.st_size;
    hz_mesh_topology topo = {0};
    if (t->hull.index_count)
        hz_mesh_check(t->hull.idx, t->hull.index_count, t->hull.vertex_count, &topo, &err);
    uint32_t maxn = 0;
    for (uint32_t n = 0; n < t->node_count; n++)
        if (t->nodes[n].count > maxn)
            maxn = t->nodes[n].count;
    if (json) {
        json_t *j = json_object();
        jx_set(j, "species", jx_str(t->species));
        jx_set(j, "seed", jx_int((long long)t->seed));
        jx_set(j, "leaves", jx_int(t->leaf_count));
        jx_set(j, "leaf_nodes", jx_int(t->node_count));
        jx_set(j, "branch_nodes", jx_int(t->branch_count));
        jx_set(j, "levels", jx_int(t->levels));
        jx_set(j, "max_node_leaves", jx_int(maxn));
        jx_set(j, "triangles", jx_int((long long)hz_tree_triangles(t)));
        jx_set(j, "bark_triangles", jx_int(t->bark.index_count / 3));
        jx_set(j, "hull_triangles", jx_int(t->hull.index_count / 3));
        jx_set(j, "hull_raw_triangles", jx_int(hs.raw_triangles));
        jx_set(j, "hull_closed_manifold", jx_bool(t->hull.index_count && !topo.bad_edges && !topo.bad_vertices));
        jx_set(j, "height_m", jx_fix(t->height, 2));
        jx_set(j, "source_ms", jx_fix(source_ms, 1));
        jx_set(j, "ranked", jx_bool(t->ranked));
        jx_set(j, "rank_ms", jx_fix(rs.nodes ? rs.ms : t->rank_ms, 1));
        jx_set(j, "rank_render_ms", jx_fix(rs.render_ms, 1));
        jx_set(j, "rank_vmi_ms", jx_fix(rs.vmi_ms, 1));
        jx_set(j, "rank_views", jx_int(t->rank_views));
        jx_set(j, "rank_res", jx_int(t->rank_res));
        jx_set(j, "rank_layers", jx_int(t->rank_layers));
        jx_set(j, "rank_pixels", jx_int((long long)rs.pixels));
        jx_set(j, "rank_deep_pixel_frac", jx_fix(rs.pixels ? (double)rs.deep_pixels / (double)rs.pixels : 0.0, 4));
        jx_set(j, "hull_ms", jx_fix(hs.ms, 1));
        jx_set(j, "memory_bytes", jx_int((long long)hz_tree_memory_bytes(t)));
        jx_set(j, "file_bytes", jx_int(file_bytes));
        jx_set(j, "peak_rss_mb", jx_fix((double)hz_peak_rss_bytes() / 1048576.0, 1));
        if (pr) {
            jx_set(j, "pr_rate", jx_num(prd.rate));
            jx_set(j, "pr_views", jx_int(rows[0].r.views));
            jx_set(j, "pr_res", jx_int(rows[0].r.res));
            for (int k = 0; k < 4; k++) {
                char prefix[32];
                snprintf(prefix, sizeof prefix, "%s%s", rows[k].order, rows[k].enlarge ? "_enlarged" : "");
                cli_pr_json(j, prefix, &rows[k].r);
                if (k >= 2) {
                    const char *sfx[4] = {"_leaf_precision_min", "_leaf_precision_max", "_leaf_recall_min",
                                          "_leaf_recall_max"};
                    const double val[4] = {rows[k].leaf_p[0], rows[k].leaf_p[1], rows[k].leaf_r[0], rows[k].leaf_r[1]};
                    for (int q = 0; q < 4; q++) {
                        char key[64];
                        snprintf(key, sizeof key, "%s%s", prefix, sfx[q]);
                        jx_set(j, key, jx_fix(val[q], 4));
                    }
                }
            }
            jx_set(j, "random_shuffles", jx_int(shuffles));
        }
        jx_print(j, stdout);
    } else {
        printf("tree          %s (seed %llu)\n", t->species, (unsigned long long)t->seed);
        printf("hierarchy     %u branch nodes in %u levels, %u leaf nodes (<= %u leaves each)\n", t->branch_count,
               t->levels, t->node_count, maxn);
        printf("leaves        %u (%llu triangles with %u bark triangles), %.1f m tall\n", t->leaf_count,
               (unsigned long long)hz_tree_triangles(t), t->bark.index_count / 3, (double)t->height);
        if (t->ranked)
            printf("VMI ranking   %u views, %u px, %u layers: %.0f ms%s\n", t->rank_views, t->rank_res,
                   t->rank_layers, rs.nodes ? rs.ms : t->rank_ms, rs.nodes ? "" : " (stored)");
        else
            printf("VMI ranking   none\n");
        if (t->hull.index_count)
            printf("crown hull    %u triangles%s, %s\n", t->hull.index_count / 3,
                   hs.raw_triangles ? "" : " (stored)",
                   !topo.bad_edges && !topo.bad_vertices ? "closed and manifold" : "NOT closed/manifold");
        printf("memory        %.1f MB\n", (double)hz_tree_memory_bytes(t) / 1048576.0);
        if (pr) {
            printf("precision/recall at %.0f%% simplification, %u views at %ux%u (foliage coverage | same leaf;\n"
                   "random: %u orders pooled):\n",
                   (double)prd.rate * 100, rows[0].r.views, rows[0].r.res, rows[0].r.res, shuffles);
            for (int k = 0; k < 4; k++)
                printf("  %-7s %-13s P %.3f  R %.3f  F %.3f  |  P %.3f  R %.3f  F %.3f\n", rows[k].order,
                       rows[k].enlarge ? "enlarged" : "not enlarged", rows[k].r.precision, rows[k].r.recall,
                       rows[k].r.f_measure, rows[k].r.leaf_precision, rows[k].r.leaf_recall,
                       rows[k].r.leaf_f_measure);
        }
        if (out)
            printf("file          %s (%.1f MB)\n", out, (double)file_bytes / 1048576.0);
    }
    rc = 0;
done:
    if (rc)
        fprintf(stderr, "horizon tree: %s\n", err.msg[0] ? err.msg : "failed");
    hz_tree_destroy(t);
    hz_gl_destroy(gl);
    return rc;
}
