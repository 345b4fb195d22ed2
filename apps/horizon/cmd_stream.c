/* horizon import (DEM or Perlin -> .hzp pyramid), and render / bench /
 * info over a streamed pyramid (--terrain NAME.hzp). */
#include "stream_cli.h"

#include <errno.h>
#include <getopt.h>
#include <jansson.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "horizon/gl_limits.h"
#include "horizon/path.h"
#include "horizon/pyramid.h"
#include "horizon/safety.h"
#include "horizon/stream.h"
#include "horizon/imagery.h"

static bool num(const char *opt, const char *s, double lo, double hi, double *out)
{
    char *end;
    double v = strtod(s, &end);
    if (end == s || *end || !(v >= lo && v <= hi)) {
        fprintf(stderr, "horizon: %s '%s': expected a number in [%g, %g]\n", opt, s, lo, hi);
        return false;
    }
    *out = v;
    return true;
}

static void print_json(json_t *o)
{
    jx_print(o, stdout);
}

bool cli_wants_stream(int argc, char **argv, int first)
{
    for (int i = first; i < argc; i++)
        if (!strcmp(argv[i], "--terrain") || !strncmp(argv[i], "--terrain=", 10))
            return true;
    return false;
}

/* ---- import ---- */

int cmd_import(int argc, char **argv)
{
    static const struct option opts[] = {
        {"out", required_argument, 0, 'o'},     {"generate", required_argument, 0, 'g'},
        {"size", required_argument, 0, 's'},    {"seed", required_argument, 0, 'S'},
        {"amplitude", required_argument, 0, 'a'}, {"spacing", required_argument, 0, 'p'},
        {"crs", required_argument, 0, 'c'},     {"max-error", required_argument, 0, 'e'},
        {"tile", required_argument, 0, 't'},    {"threads", required_argument, 0, 'j'},
        {"json", no_argument, 0, 'J'},          {"quiet", no_argument, 0, 'q'},
        {"tiles", required_argument, 0, 'T'},   {"finish", no_argument, 0, 'F'},
        {"zscale", required_argument, 0, 'z'},  {"wrap", no_argument, 0, 'W'},
        {"jobs", no_argument, 0, 'N'},          {"help", no_argument, 0, 'h'},
        {0, 0, 0, 0}};
    hz_pyr_import d = {0};
    bool json = false, quiet = false, jobs = false;
    double v;
    optind = 2;
    opterr = 1;
    int ch;
    while ((ch = getopt_long(argc, argv, "o:h", opts, NULL)) != -1) {
        switch (ch) {
        case 'o': d.out = optarg; break;
        case 'g':
            if (strcmp(optarg, "perlin")) {
                fprintf(stderr, "horizon import: --generate %s: only perlin can be generated tile by tile\n", optarg);
                return 2;
            }
            d.generate = true;
            d.gen.kind = HZ_GEN_PERLIN;
            break;
        case 's': if (!num("--size", optarg, 3, 1048577, &v)) return 2; d.gen.size = (uint32_t)v; break;
        case 'S': if (!num("--seed", optarg, 0, 1e18, &v)) return 2; d.gen.seed = (uint64_t)v; break;
        case 'a': if (!num("--amplitude", optarg, 0.001, 100000, &v)) return 2; d.gen.amplitude = (float)v; break;
        case 'p': if (!num("--spacing", optarg, 0.001, 100000, &v)) return 2; d.spacing = v; break;
        case 'c': d.crs = optarg; break;
        case 'e': if (!num("--max-error", optarg, 0, 1000, &v)) return 2; d.max_error = v; break;
        case 't': if (!num("--tile", optarg, 16, 4096, &v)) return 2; d.tile_cells = (uint32_t)v; break;
        case 'j': if (!num("--threads", optarg, 1, 64, &v)) return 2; d.threads = (uint32_t)v; break;
        case 'J': json = true; break;
        case 'q': quiet = true; break;
        case 'T': d.tiles = optarg; break;
        case 'W': d.wrap = true; break;
        case 'z': if (!num("--zscale", optarg, 1e-6, 1000, &v)) return 2; d.zscale = v; break;
        case 'F': d.finish = true; break;
        case 'N': jobs = true; break;
        case 'h':
            fprintf(stderr,
                    "usage: horizon import IN... --out NAME.hzp [options]\n"
                    "       horizon import --generate perlin --size N --out NAME.hzp [options]\n"
                    "Writes a terrain pyramid (docs/pyramid.md) window by window: any GDAL rasters or folders\n"
                    "(mosaicked, nodata masked, geographic input reprojected to UTM), or a Perlin terrain of\n"
                    "any size. Then: horizon render|bench --terrain NAME.hzp, horizon info NAME.hzp --verify.\n"
                    "  --out FILE.hzp          the pyramid (required; never one of the inputs)\n"
                    "  --generate perlin       a generated terrain instead of inputs; --size 2^n+1 samples,\n"
                    "                          --seed N, --amplitude M (default 1800)\n"
                    "  --spacing M             metres per sample (reprojection; generated default 10)\n"
                    "  --crs EPSG:N            target CRS of geographic input (default the UTM zone)\n"
                    "  --wrap                  a terrain that repeats in x and z (endless flight): Perlin is\n"
                    "                          made periodic; a DEM must be square 2^n+1 (its last row and\n"
                    "                          column become its first)\n"
                    "  --zscale F              metres per source unit (0.3048 for feet; default 1)\n"
                    "  --max-error M           allowed height error in metres (default lossless for 16-bit\n"
                    "                          integer input, else range / 131070)\n"
                    "  --tile N                cells per tile side, power of two (default 256)\n"
                    "  --threads N             default every core\n"
                    "  --jobs                  print how many independent jobs the import splits into\n"
                    "  --tiles A-B             run jobs A..B only (0-based), writing NAME.hzp.part-A-B; run\n"
                    "                          the ranges anywhere (GNU parallel, Slurm, Kubernetes), then\n"
                    "  --finish                join every part into NAME.hzp (same inputs and options):\n"
                    "                          the same bytes as a single run\n"
                    "  --json                  figures as JSON on stdout\n"
                    "  --quiet                 no progress\n");
            return 0;
        default: return 2;
        }
    }
    const char **ins = (const char **)(argv + optind);
    d.inputs = ins;
    d.input_count = (uint32_t)(argc - optind);
    if (!d.out) {
        fprintf(stderr, "horizon import: --out NAME.hzp is required\n");
        return 2;
    }
    if (d.generate && d.input_count) {
        fprintf(stderr, "horizon import: give inputs or --generate, not both\n");
        return 2;
    }
    if (d.generate && !d.gen.size) {
        fprintf(stderr, "horizon import: --generate perlin needs --size (2^n+1)\n");
        return 2;
    }
    for (uint32_t k = 0; k < d.input_count; k++)
        if (hz_same_file(ins[k], d.out)) {
            fprintf(stderr, "horizon import: --out '%s' is the input '%s'; refusing to overwrite it\n", d.out, ins[k]);
            return 2;
        }
    d.progress = quiet ? NULL : hz_progress_stderr; /* a bar in a terminal, else periodic lines */
    hz_pyr_import_stats st = {0};
    hz_err err = {0};
    if (jobs) {
        const uint32_t n = hz_pyramid_jobs(&d, &err);
        if (!n) {
            fprintf(stderr, "horizon import: %s\n", err.msg);
            return 1;
        }
        printf("%u\n", n);
        return 0;
    }
    if (hz_pyramid_import(&d, &st, &err) != HZ_OK) {
        fprintf(stderr, "horizon import: %s\n", err.msg);
        return 1;
    }
    const double bps = st.samples ? (double)st.bytes / (double)st.samples : 0;
    if (d.tiles) {
        if (!quiet)
            printf("%s: jobs %s written as a part (%.1f s); join with --finish\n", d.out, d.tiles, st.ms / 1000.0);
        return 0;
    }
    if (json) {
        json_t *o = json_object();
        json_object_set_new(o, "out", jx_str(d.out));
        json_object_set_new(o, "samples", json_integer((json_int_t)st.samples));
        json_object_set_new(o, "tiles", json_integer((json_int_t)st.tiles));
        json_object_set_new(o, "bytes", json_integer((json_int_t)st.bytes));
        json_object_set_new(o, "bytes_per_sample", jx_dbl(bps));
        json_object_set_new(o, "max_error_m", jx_dbl(st.max_error));
        json_object_set_new(o, "finish_mb", jx_dbl((double)st.finish_bytes / 1e6));
        json_object_set_new(o, "ms", jx_dbl(st.ms));
        json_object_set_new(o, "peak_rss_mb", jx_dbl((double)hz_peak_rss_bytes() / 1048576.0));
        print_json(o);
    } else if (!quiet) {
        printf("%s: %llu samples, %llu tiles, %.1f MB (%.3f bytes/sample), max error %.3g m, %.1f s, peak RSS %.0f MB\n",
               d.out, (unsigned long long)st.samples, (unsigned long long)st.tiles, (double)st.bytes / 1e6, bps,
               st.max_error, st.ms / 1000.0, (double)hz_peak_rss_bytes() / 1048576.0);
    }
    return 0;
}

/* ---- info ---- */

int pyramid_info(const char *path, bool verify, json_t *arr)
{
    const bool json = arr != NULL;
    hz_pyramid *p = NULL;
    hz_err err = {0};
    if (hz_pyramid_open(path, &p, &err) != HZ_OK) {
        fprintf(stderr, "horizon info: %s\n", err.msg);
        return 1;
    }
    const hz_pyr_info *in = hz_pyramid_info(p);
    uint64_t bad = 0;
    hz_result vr = HZ_OK;
    if (verify)
        vr = hz_pyramid_verify(p, &bad, hz_progress_stderr, NULL, &err); /* long over http: progress */
    hz_georef *g = NULL;
    double corners[4][2] = {{0}};
    bool has_geo = false;
    if (in->wkt && in->wkt[0]) {
        g = hz_georef_create(in->wkt, in->geotransform, in->data_w, in->data_h, NULL);
        has_geo = g && hz_georef_corners_lonlat(g, corners, NULL) == HZ_OK;
    }
    const double hmin = in->h_offset + in->h_scale * in->h_min, hmax = in->h_offset + in->h_scale * in->h_max;
    const double nd = (double)in->nodata / ((double)in->data_w * in->data_h);
    if (json) {
        json_t *o = json_object();
        json_object_set_new(o, "file", jx_str(path));
        json_object_set_new(o, "format", jx_str("hzp"));
        json_object_set_new(o, "version", json_integer(in->version));
        json_object_set_new(o, "width", json_integer(in->data_w));
        json_object_set_new(o, "height", json_integer(in->data_h));
        json_object_set_new(o, "size", json_integer(in->size));
        json_object_set_new(o, "levels", json_integer(in->levels));
        json_object_set_new(o, "tiles", json_integer((json_int_t)in->tiles));
        json_object_set_new(o, "tile_cells", json_integer(in->tile_cells));
        json_object_set_new(o, "spacing", jx_dbl(in->spacing));
        json_object_set_new(o, "height_min", jx_dbl(hmin));
        json_object_set_new(o, "height_max", jx_dbl(hmax));
        json_object_set_new(o, "height_step", jx_dbl(in->h_scale));
        json_object_set_new(o, "max_error", jx_dbl(in->max_error));
        json_object_set_new(o, "nodata", json_integer((json_int_t)in->nodata));
        json_object_set_new(o, "nodata_fraction", jx_dbl(nd));
        json_object_set_new(o, "bytes", json_integer((json_int_t)in->file_bytes));
        json_object_set_new(o, "bytes_per_sample",
                            jx_dbl((double)in->file_bytes / ((double)in->data_w * in->data_h)));
        json_object_set_new(o, "crs", g ? jx_str(hz_georef_label(g)) : json_null());
        if (has_geo) /* as horizon info prints DEMs */
            json_object_set_new(o, "corners_lonlat",
                                json_pack("{s:[f,f],s:[f,f],s:[f,f],s:[f,f]}", "nw", corners[0][0], corners[0][1], "ne",
                                          corners[1][0], corners[1][1], "se", corners[2][0], corners[2][1], "sw",
                                          corners[3][0], corners[3][1]));
        if (verify) {
            json_object_set_new(o, "verified", json_boolean(vr == HZ_OK));
            json_object_set_new(o, "bad_tiles", json_integer((json_int_t)bad));
        }
        json_array_append_new(arr, o);
    } else {
        printf("%s: terrain pyramid v%u, %ux%u samples (square %u), %u levels, %llu tiles of %u cells\n", path,
               in->version, in->data_w, in->data_h, in->size, in->levels, (unsigned long long)in->tiles,
               in->tile_cells);
        printf("  spacing %.4g m, heights %.2f .. %.2f m (step %.4g m, max error %.3g m), nodata %.2f %%\n",
               in->spacing, hmin, hmax, in->h_scale, in->max_error, 100.0 * nd);
        printf("  %.1f MB, %.3f bytes per sample\n", (double)in->file_bytes / 1e6,
               (double)in->file_bytes / ((double)in->data_w * in->data_h));
        if (g)
            printf("  CRS %s\n", hz_georef_label(g));
        if (has_geo)
            printf("  corners lon/lat: NW %.7f %.7f  NE %.7f %.7f  SE %.7f %.7f  SW %.7f %.7f\n", corners[0][0],
                   corners[0][1], corners[1][0], corners[1][1], corners[2][0], corners[2][1], corners[3][0],
                   corners[3][1]);
        if (verify)
            printf("  verify: %s (%llu bad tiles)\n", vr == HZ_OK ? "every tile checks" : err.msg,
                   (unsigned long long)bad);
    }
    hz_georef_destroy(g);
    hz_pyramid_close(p);
    return verify && vr != HZ_OK ? 1 : 0;
}

/* ---- streamed render and bench ---- */


int parse_stream(int argc, char **argv, sopts *o, const char *cmd)
{
    static const struct option opts[] = {
        {"terrain", required_argument, 0, 'T'}, {"cache-mb", required_argument, 0, 'm'},
        {"out", required_argument, 0, 'o'},     {"camera", required_argument, 0, 'c'},
        {"pixel-error", required_argument, 0, 'e'}, {"width", required_argument, 0, 'w'},
        {"near-pixel-error", required_argument, 0, 1012}, {"near-error-distance", required_argument, 0, 1013},
        {"height", required_argument, 0, 'H'},  {"path", required_argument, 0, 'p'},
        {"frames", required_argument, 0, 'f'},  {"json", no_argument, 0, 'J'},
        {"quiet", no_argument, 0, 'q'},         {"lod", required_argument, 0, 'l'},
        /* a pyramid over http(s) */
        {"disk-cache", required_argument, 0, 1001}, {"disk-cache-mb", required_argument, 0, 1002},
        {"http-timeout", required_argument, 0, 1003}, {"http-retries", required_argument, 0, 1004},
        {"http-connections", required_argument, 0, 1005},
        {"imagery", required_argument, 0, 1101}, {"imagery-max", required_argument, 0, 1102},
        /* view */
        {"script", required_argument, 0, 1201}, {"screenshot", required_argument, 0, 1202},
        {"speed", required_argument, 0, 1203},  {"dt", required_argument, 0, 1204},
        {"no-vsync", no_argument, 0, 1205},     {"no-hud", no_argument, 0, 1206},
        {"curvature", required_argument, 0, 1010},
        /* bench pacing */
        {"realtime", no_argument, 0, 1006}, {"fps", required_argument, 0, 1007},
        {"deterministic", no_argument, 0, 1008},
        {"water-level", required_argument, 0, 1011},
        {0, 0, 0, 0}};
    *o = (sopts){.cache_mb = 256, .tau = 1.0, .width = 1280, .height = 720, .frames = strcmp(cmd, "view") ? 120 : 0,
                 .fps = 30};
    optind = 2;
    int ch;
    double v;
    bool fps_given = false;
    while ((ch = getopt_long(argc, argv, "", opts, NULL)) != -1) {
        switch (ch) {
        case 'T': o->terrain = optarg; break;
        case 'm': if (!num("--cache-mb", optarg, 4, 1 << 20, &v)) return 2; o->cache_mb = v; break;
        case 'o': o->out = optarg; break;
        case 'e': if (!num("--pixel-error", optarg, 0.05, 100, &v)) return 2; o->tau = v; break;
        case 1012: if (!num("--near-pixel-error", optarg, 0.05, 1000, &v)) return 2; o->near_tau = v; break;
        case 1013: if (!num("--near-error-distance", optarg, 0.001, 1e8, &v)) return 2; o->near_distance = v; break;
        case 'w': if (!num("--width", optarg, 16, 8192, &v)) return 2; o->width = (uint32_t)v; break;
        case 'H': if (!num("--height", optarg, 16, 8192, &v)) return 2; o->height = (uint32_t)v; break;
        case 'f':
            if (!num("--frames", optarg, 1, 100000, &v)) return 2;
            o->frames = (uint32_t)v;
            o->frames_given = true;
            break;
        case 'p': o->path = optarg; break;
        case 'J': o->json = true; break;
        case 'q': o->quiet = true; break;
        /* a pyramid over http(s) (docs/serving.md) */
        case 1001: o->remote.disk_cache = optarg; break;
        case 1002:
            if (!num("--disk-cache-mb", optarg, 1, 1 << 24, &v)) return 2;
            o->remote.disk_cache_bytes = (uint64_t)(v * 1048576.0);
            break;
        case 1003:
            if (!num("--http-timeout", optarg, 0.1, 600, &v)) return 2;
            o->remote.timeout_ms = (uint32_t)(v * 1000.0);
            break;
        case 1004: if (!num("--http-retries", optarg, 1, 20, &v)) return 2; o->remote.retries = (uint32_t)v; break;
        case 1005:
            if (!num("--http-connections", optarg, 1, 16, &v)) return 2;
            o->remote.connections = (uint32_t)v;
            break;
        case 1101: o->imagery = optarg; break;
        case 1201: case 1202: case 1203: case 1204: case 1205: case 1206:
            if (strcmp(cmd, "view")) {
                static const char *const names[] = {"script", "screenshot", "speed", "dt", "no-vsync", "no-hud"};
                fprintf(stderr, "horizon %s: --%s is an option of horizon view\n", cmd, names[ch - 1201]);
                return 2;
            }
            if (ch == 1201) o->script = optarg;
            else if (ch == 1202) o->screenshot = optarg;
            else if (ch == 1203) { if (!num("--speed", optarg, 0.01, 1e6, &o->speed)) return 2; }
            else if (ch == 1204) { if (!num("--dt", optarg, 0.0001, 1.0, &o->dt)) return 2; }
            else if (ch == 1205) o->no_vsync = true;
            else o->no_hud = true;
            break;
        case 1102:
            if (!num("--imagery-max", optarg, 64, HZ_IMAGERY_MAX_SIDE, &v)) return 2;
            o->imagery_max = (uint32_t)v;
            break;
        case 1010:
            if (!curv_cli_parse(optarg, &o->curv.mode)) {
                fprintf(stderr, "horizon %s: invalid value '%s' for --curvature: expected on, off or auto\n", cmd,
                        optarg);
                return 2;
            }
            break;
        case 1011:
            if (!cli_parse_water_level(optarg, &o->water_mode, &o->water_level)) {
                fprintf(stderr, "horizon %s: --water-level '%s': expected metres in [-1e5, 1e5], auto or off\n", cmd,
                        optarg);
                return 2;
            }
            break;
        case 1006: o->realtime = true; break;
        case 1007:
            if (!num("--fps", optarg, 1, 1000, &v)) return 2;
            o->fps = v;
            fps_given = true;
            break;
        case 1008: o->deterministic = true; break;
        case 'l':
            if (strcmp(optarg, "cdlod")) {
                fprintf(stderr, "horizon %s: a streamed --terrain is drawn with --lod cdlod only\n", cmd);
                return 2;
            }
            break;
        case 'c': {
            double c[5];
            char *s = optarg, *end;
            for (int k = 0; k < 5; k++) {
                c[k] = strtod(s, &end);
                if (end == s || !isfinite(c[k]) || fabs(c[k]) > 1e8 || (k < 4 && *end != ',') || (k == 4 && *end)) {
                    fprintf(stderr, "horizon %s: --camera '%s': expected x,y,z,yaw,pitch\n", cmd, optarg);
                    return 2;
                }
                s = end + 1;
            }
            for (int k = 0; k < 5; k++)
                o->camera[k] = (float)c[k];
            o->have_camera = true;
            break;
        }
        default:
            fprintf(stderr, "horizon %s --terrain: options are --terrain --cache-mb --out --camera --pixel-error "
                            "--near-pixel-error --near-error-distance "
                            "--width --height --path --frames --json --quiet --disk-cache --disk-cache-mb "
                            "--http-timeout --http-retries --http-connections --curvature --imagery --imagery-max --water-level; bench "
                            "also --realtime --fps --deterministic; view also --speed --dt --script --screenshot "
                            "--no-vsync --no-hud\n", cmd);
            return 2;
        }
    }
    if (fps_given && !o->realtime) {
        fprintf(stderr, "horizon %s: --fps paces a --realtime flight (a streamed bench without --realtime draws "
                        "--frames frames as fast as it can)\n", cmd);
        return 2;
    }
    if (o->realtime && o->deterministic) {
        fprintf(stderr, "horizon %s: --realtime and --deterministic exclude each other (a deterministic flight "
                        "waits for its tiles)\n", cmd);
        return 2;
    }
    if ((o->realtime || o->deterministic) && strcmp(cmd, "bench")) {
        fprintf(stderr, "horizon %s: --realtime and --deterministic are bench options\n", cmd);
        return 2;
    }
    if (optind < argc) {
        fprintf(stderr, "horizon %s: unexpected argument '%s'\n", cmd, argv[optind]);
        return 2;
    }
    if (!o->terrain) {
        fprintf(stderr, "horizon %s: --terrain NAME.hzp is required\n", cmd);
        return 2;
    }
    return 0;
}


void sctx_free(sctx *c)
{
    free(c->pl.data);
    hz_renderer_destroy(c->r);
    hz_gl_destroy(c->gl);
    hz_stream_destroy(c->s);
}

/* --imagery over the pyramid's footprint, placed through its georeference. */
static int stream_imagery(sctx *c, const sopts *o, const char *cmd)
{
    const hz_pyr_info *in = hz_stream_info(c->s);
    hz_err err = {0};
    hz_georef *g = NULL;
    if (in->wkt && in->wkt[0]) {
        g = hz_georef_create(in->wkt, in->geotransform, in->size, in->size, &err);
        if (!g) {
            fprintf(stderr, "horizon %s: %s: %s\n", cmd, o->terrain, err.msg);
            return 1;
        }
    }
    hz_imagery_desc d = {.path = o->imagery, .target = g, .samples = in->size, .spacing = in->spacing,
                         .max_side = o->imagery_max, .max_bytes = hz_mem_budget_default(),
                         .progress = o->quiet ? NULL : hz_progress_stderr};
    hz_imagery im;
    hz_result res = hz_imagery_load(&d, &im, &err);
    hz_georef_destroy(g);
    if (res == HZ_OK) {
        if (im.note[0] && !o->quiet)
            fprintf(stderr, "horizon %s: imagery: %s\n", cmd, im.note);
        res = hz_renderer_set_imagery(c->r, &im, &err);
        hz_imagery_free(&im);
    }
    if (res != HZ_OK) {
        fprintf(stderr, "horizon %s: %s\n", cmd, err.msg);
        return 1;
    }
    return 0;
}

int sctx_open(sctx *c, const sopts *o, const coarse *ground, const char *cmd)
{
    hz_err err = {0};
    memset(c, 0, sizeof *c);
    /* the GL context first: the cache holds no more tiles than an array texture has layers */
    const bool windowed = !strcmp(cmd, "view");
    if (!windowed)
        c->gl = hz_gl_create_headless(&err);
    if (c->gl || windowed)
        c->r = hz_renderer_create(&(hz_renderer_desc){.width = o->width, .height = o->height}, &err);
    if (c->r)
        c->s = hz_stream_create(&(hz_stream_desc){.path = o->terrain,
                                                  .cache_bytes = (uint64_t)(o->cache_mb * 1048576.0),
                                                  .remote = o->remote, .max_slots = hz_gl_query_max_tile_layers(),
                                                  /* one still image, or a deterministic flight (every
                                                   * tile loaded before its frame): tiles as they are */
                                                  .slide_seconds = !strcmp(cmd, "render") || o->deterministic ? -1.0f
                                                                                                               : 0.0f},
                                &err);
    if (!c->r || !c->s || hz_renderer_set_stream(c->r, hz_stream_info(c->s), hz_stream_slots(c->s), hz_stream_texels(c->s),
                                        &err) != HZ_OK) {
        fprintf(stderr, "horizon %s: %s\n", cmd, err.msg);
        sctx_free(c);
        return 1;
    }
    c->lp = (hz_lod_params){.mode = HZ_LOD_CDLOD, .pixel_error = (float)o->tau, .viewport_height = o->height,
                            .near_pixel_error = (float)o->near_tau, .near_distance = (float)o->near_distance};
    if ((o->imagery && stream_imagery(c, o, cmd)) || stream_water(c, o, ground, cmd)) {
        sctx_free(c);
        return 1;
    }
    return 0;
}

/* Transfer figures of a pyramid read over http(s) (NULL for a file), and a
 * line on stderr when reads were retried or failed. */
static json_t *transfer_json(const sctx *c, const char *cmd, double ms)
{
    const hz_pyramid *p = hz_stream_pyramid(c->s);
    if (!hz_pyramid_is_remote(p))
        return NULL;
    const hz_pyr_transfer t = hz_pyramid_query_transfer(p);
    if (t.retries || t.failures || t.offline)
        fprintf(stderr, "horizon %s: http: %llu requests, %llu retried, %llu reads failed (drawn coarser)%s\n", cmd,
                (unsigned long long)t.requests, (unsigned long long)t.retries, (unsigned long long)t.failures,
                t.offline ? "; the server did not answer: read from the disk cache" : "");
    json_t *o = json_object();
    json_object_set_new(o, "requests", json_integer((json_int_t)t.requests));
    json_object_set_new(o, "bytes", json_integer((json_int_t)t.bytes));
    json_object_set_new(o, "retries", json_integer((json_int_t)t.retries));
    json_object_set_new(o, "failures", json_integer((json_int_t)t.failures));
    json_object_set_new(o, "disk_cache_hits", json_integer((json_int_t)t.cache_hits));
    json_object_set_new(o, "disk_cache_bytes", json_integer((json_int_t)t.cache_bytes));
    json_object_set_new(o, "disk_cache_evicted", json_integer((json_int_t)t.cache_evicted));
    json_object_set_new(o, "disk_cache_rejected", json_integer((json_int_t)t.cache_rejected));
    json_object_set_new(o, "offline", json_boolean(t.offline));
    json_object_set_new(o, "mb_per_s", json_real(ms > 0 ? (double)(t.bytes + t.cache_bytes) / 1e3 / ms : 0));
    return o;
}

/* Uploads what the loader finished. */
int upload_ready(sctx *c, uint32_t *n)
{
    uint32_t slot;
    const uint16_t *tex;
    hz_err err = {0};
    *n = 0;
    while (hz_stream_next_upload(c->s, &slot, &tex)) {
        if (hz_renderer_stream_upload(c->r, slot, tex, &err) != HZ_OK) {
            fprintf(stderr, "horizon: %s\n", err.msg);
            return 1;
        }
        hz_stream_uploaded(c->s, slot);
        (*n)++;
    }
    return 0;
}

/* Resolves --curvature for the pyramid: its side, and the WGS84 radius at
 * its centre when it is georeferenced. */
void stream_curvature(sopts *o, const hz_pyr_info *in)
{
    hz_georef *g = in->wkt && in->wkt[0] ? hz_georef_create(in->wkt, in->geotransform, in->data_w, in->data_h, NULL)
                                         : NULL;
    const float ext = (float)((in->data_w > in->data_h ? in->data_w - 1 : in->data_h - 1) * in->spacing);
    curv_cli_resolve(&o->curv, ext, g, 0.5 * (in->data_w - 1) * in->spacing, 0.5 * (in->data_h - 1) * in->spacing);
    hz_georef_destroy(g);
}

/* Selects and loads until the selection asks for nothing more: every tile
 * the view wants (and prefetches) is resident. Adds the rounds and the tiles
 * loaded; sums the requests of the rounds into *requested when given. */
static int load_all(sctx *c, const hz_camera *cam, uint32_t *rounds, uint32_t *loads, uint64_t *requested)
{
    for (uint32_t k = 0; k < 400; k++, (*rounds)++) {
        hz_lod_stats st;
        if (hz_stream_select(c->s, cam, &c->lp, &c->pl, &st) != HZ_OK)
            return 1;
        hz_stream_wait(c->s);
        uint32_t n;
        if (upload_ready(c, &n))
            return 1;
        *loads += n;
        hz_stream_stats ss = hz_stream_take_stats(c->s);
        if (requested)
            *requested += ss.requested;
        if (n == 0 && ss.pending == 0 && ss.requested == 0)
            break;
    }
    return 0;
}

static void sleep_ms(double ms)
{
    struct timespec ts = {.tv_sec = (time_t)(ms / 1000.0), .tv_nsec = (long)(fmod(ms, 1000.0) * 1e6)};
    while (nanosleep(&ts, &ts) != 0 && errno == EINTR) {
    }
}

/* FNV-1a, 64 bits: a frame's fingerprint (frames compared across runs). */
static uint64_t fnv64(const uint8_t *p, size_t n)
{
    uint64_t h = 0xcbf29ce484222325ULL;
    for (size_t k = 0; k < n; k++)
        h = (h ^ p[k]) * 0x100000001b3ULL;
    return h;
}

hz_camera default_camera(const hz_pyr_info *in, uint32_t w, uint32_t h)
{
    const float ex = (float)((in->data_w - 1) * in->spacing), ez = (float)((in->data_h - 1) * in->spacing);
    const float hmax = (float)(in->h_offset + in->h_scale * in->h_max);
    const float hmin = (float)(in->h_offset + in->h_scale * in->h_min);
    hz_camera c = {.fov_y = 60.0f, .aspect = (float)w / (float)h, .znear = 0.25f};
    c.pos[0] = 0.5f * ex;
    c.pos[2] = 0.5f * ez;
    c.pos[1] = hmax + 0.15f * (hmax - hmin) + 0.01f * fmaxf(ex, ez);
    c.yaw = 30.0f;
    c.pitch = -10.0f;
    c.zfar = 1.5f * fmaxf(ex, ez) + (c.pos[1] - hmin);
    return c;
}

static float stream_ground(void *user, float x, float z)
{
    return hz_stream_height_at(user, x, z);
}

static int load_all(sctx *c, const hz_camera *cam, uint32_t *rounds, uint32_t *loads, uint64_t *requested);

/* The first view of a pyramid, as of an in-memory DEM (hz_camera_summit_view):
 * the highest ground, found on the coarse tiles an overview from high above
 * loads (a 256 x 256 grid over the data), seen from 3x the relief away.
 * The plain default_camera when nothing loads. */
static hz_camera summit_camera(sctx *c, const hz_pyr_info *in, uint32_t w, uint32_t h)
{
    hz_camera cam = default_camera(in, w, h);
    const float ex = (float)((in->data_w - 1) * in->spacing), ez = (float)((in->data_h - 1) * in->spacing);
    const float hmax = (float)(in->h_offset + in->h_scale * in->h_max);
    const float hmin = (float)(in->h_offset + in->h_scale * in->h_min);
    hz_camera over = cam;
    over.pos[0] = 0.5f * ex;
    over.pos[2] = 0.5f * ez;
    over.pos[1] = hmax + fmaxf(ex, ez);
    over.pitch = -89.9f;
    over.zfar = 3.0f * fmaxf(ex, ez) + (hmax - hmin);
    uint32_t rounds = 0, loads = 0;
    const int failed = load_all(c, &over, &rounds, &loads, NULL);
    c->first_view_loads += loads;
    c->first_view_rounds += rounds;
    if (failed)
        return cam;
    float focus[3] = {0, -INFINITY, 0};
    for (int j = 0; j < 256; j++)
        for (int i = 0; i < 256; i++) {
            const float x = ex * ((float)i + 0.5f) / 256.0f, z = ez * ((float)j + 0.5f) / 256.0f;
            const float y = hz_stream_height_at(c->s, x, z);
            if (y > focus[1])
                focus[0] = x, focus[1] = y, focus[2] = z;
        }
    if (!(focus[1] > -INFINITY))
        return cam;
    const float rect[4] = {0, 0, ex, ez}, centre[2] = {0.5f * ex, 0.5f * ez};
    hz_camera s = hz_camera_summit_view(rect, centre, focus, hmax - hmin, fmaxf(ex, ez), stream_ground, c->s, w, h);
    s.zfar = fmaxf(s.zfar, 1.5f * fmaxf(ex, ez) + (s.pos[1] - hmin));
    return s;
}

hz_camera stream_camera(sopts *o, sctx *c, uint32_t w, uint32_t h)
{
    const hz_pyr_info *in = hz_stream_info(c->s);
    stream_curvature(o, in);
    hz_camera cam = o->have_camera ? default_camera(in, w, h) : summit_camera(c, in, w, h);
    cam.earth_radius = o->curv.radius;
    if (o->have_camera) {
        cam.pos[0] = o->camera[0], cam.pos[1] = o->camera[1], cam.pos[2] = o->camera[2];
        cam.yaw = o->camera[3], cam.pitch = o->camera[4];
        /* the far plane follows the camera's height */
        const float hmin = (float)(in->h_offset + in->h_scale * in->h_min);
        const float ext = (float)((in->data_w > in->data_h ? in->data_w : in->data_h) * in->spacing);
        cam.zfar = 1.5f * ext + fmaxf(0.0f, cam.pos[1] - hmin);
    }
    return cam;
}

int stream_render(int argc, char **argv)
{
    sopts o;
    int rc = parse_stream(argc, argv, &o, "render");
    if (rc)
        return rc;
    const char *out = o.out ? o.out : "render.png";
    if (hz_same_file(out, o.terrain)) {
        fprintf(stderr, "horizon render: --out '%s' is the --terrain; refusing to overwrite it\n", out);
        return 2;
    }
    sctx c;
    if (sctx_open(&c, &o, NULL, "render"))
        return 1;
    const double t0 = hz_time_ms();
    hz_camera cam = stream_camera(&o, &c, o.width, o.height);
    hz_stream_wrap_camera(c.s, &cam);
    /* One image: load until the selection asks for nothing more (the tiles
     * the first view was found on count too). */
    hz_lod_stats st = {0};
    uint32_t rounds = c.first_view_rounds, loads = c.first_view_loads;
    if (load_all(&c, &cam, &rounds, &loads, NULL)) {
        fprintf(stderr, "horizon render: out of memory in the selection\n");
        sctx_free(&c);
        return 1;
    }
    const double load_ms = hz_time_ms() - t0;
    hz_stream_select(c.s, &cam, &c.lp, &c.pl, &st);
    hz_stream_stats ss = hz_stream_take_stats(c.s);
    hz_err err = {0};
    hz_scene_params sp = {.patches = c.pl.data, .patch_count = (uint32_t)c.pl.count,
                          .morph_scale = st.morph_scale, .morph_start = st.morph_start,
                          .morph_near = st.morph_near, .morph_near_distance = st.morph_near_distance,
                          .fog_density = cli_fog_default(cam.zfar), .effects = stream_effects(&c)};
    hz_draw_stats ds = {0};
    rc = 1;
    for (int k = 0; k < 2; k++)
        if (hz_renderer_draw(c.r, &cam, &sp, NULL, 0, &ds, &err) != HZ_OK)
            goto done;
    uint8_t *rgb = malloc((size_t)o.width * o.height * 3);
    hz_outfile png;
    if (!rgb || hz_renderer_read_rgb(c.r, rgb, &err) != HZ_OK || hz_outfile_begin(&png, out, &err) != HZ_OK) {
        free(rgb);
        goto done;
    }
    if (hz_image_write_png(png.tmp, rgb, o.width, o.height, &err) != HZ_OK || hz_outfile_commit(&png, &err) != HZ_OK) {
        hz_outfile_discard(&png);
        free(rgb);
        goto done;
    }
    free(rgb);
    if (hz_stream_warning(c.s))
        fprintf(stderr, "horizon render: warning: %s\n", hz_stream_warning(c.s));
    json_t *http = transfer_json(&c, "render", load_ms);
    if (c.pl.count == 0)
        fprintf(stderr, "horizon render: the terrain is not in view: the image shows only sky\n");
    if (o.json) {
        json_t *j = json_object();
        json_object_set_new(j, "terrain", jx_str(o.terrain));
        json_object_set_new(j, "out", jx_str(out));
        json_object_set_new(j, "lod_mode", jx_str("cdlod"));
        json_object_set_new(j, "pixel_error", jx_dbl(o.tau));
        cli_near_json(j, &c.lp);
        curv_cli_json(j, &o.curv);
        json_object_set_new(j, "camera", json_pack("[f,f,f,f,f]", (double)cam.pos[0], (double)cam.pos[1],
                                                   (double)cam.pos[2], (double)cam.yaw, (double)cam.pitch));
        json_object_set_new(j, "triangles", json_integer(st.triangles));
        json_object_set_new(j, "nodes_drawn", json_integer((json_int_t)c.pl.count));
        json_object_set_new(j, "forced", json_integer(st.forced));
        json_object_set_new(j, "lod_ms", jx_dbl(st.ms));
        json_object_set_new(j, "draw_ms", jx_dbl(ds.draw_ms));
        json_object_set_new(j, "tiles_loaded", json_integer(loads));
        json_object_set_new(j, "tiles_resident", json_integer(ss.resident));
        json_object_set_new(j, "tiles_failed", json_integer(ss.failed));
        json_object_set_new(j, "cache_slots", json_integer(hz_stream_slots(c.s)));
        json_object_set_new(j, "cache_mb", jx_dbl((double)ss.cache_bytes / 1048576.0));
        json_object_set_new(j, "late_nodes", json_integer(ss.late));
        json_object_set_new(j, "load_rounds", json_integer(rounds));
        json_object_set_new(j, "load_ms", jx_dbl(load_ms));
        json_object_set_new(j, "terrain_in_view", json_boolean(c.pl.count > 0));
        json_object_set_new(j, "water_level", c.water ? jx_dbl(c.water_level) : json_null());
        json_object_set_new(j, "peak_rss_mb", jx_dbl((double)hz_peak_rss_bytes() / 1048576.0));
        if (http)
            json_object_set(j, "http", http);
        print_json(j);
    } else if (!o.quiet) {
        printf("%s: %u triangles in %zu nodes, %u tiles loaded (%u resident, %.0f MB), lod %.2f ms, draw %.1f ms\n",
               out, st.triangles, c.pl.count, loads, ss.resident, (double)ss.cache_bytes / 1048576.0, st.ms,
               ds.draw_ms);
    }
    json_decref(http);
    rc = 0;
done:
    if (rc)
        fprintf(stderr, "horizon render: %s\n", err.msg);
    sctx_free(&c);
    return rc;
}

static int cmp_d(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double pct(double *v, size_t n, double q)
{
    qsort(v, n, sizeof *v, cmp_d);
    size_t k = (size_t)(q * (double)(n - 1) + 0.5);
    return v[k < n ? k : n - 1];
}

int stream_bench(int argc, char **argv)
{
    sopts o;
    int rc = parse_stream(argc, argv, &o, "bench");
    if (rc)
        return rc;
    hz_path path = {0};
    hz_err err = {0};
    coarse g = {0};
    if (coarse_load(&o, &g, "bench"))
        return 1;
    if (o.path && strcmp(o.path, "flyover")) {
        if (hz_path_load_csv(o.path, &path, &err) != HZ_OK) {
            fprintf(stderr, "horizon bench: %s (a streamed --terrain flies flyover or a CSV path)\n", err.msg);
            coarse_free(&g);
            return 2;
        }
    } else {
        /* As the in-memory flyover: 300 m/s for 60 s across the middle of
         * the data, max(60 m, 5 % of the relief) above the highest ground near. */
        hz_pyramid *p;
        if (hz_pyramid_open_with(o.terrain, &o.remote, &p, &err) != HZ_OK) {
            fprintf(stderr, "horizon bench: %s\n", err.msg);
            coarse_free(&g);
            return 1;
        }
        const hz_pyr_info *in = hz_pyramid_info(p);
        const float E = (float)((in->data_w < in->data_h ? in->data_w : in->data_h) - 1) * (float)in->spacing;
        const float cx = 0.5f * (float)(in->data_w - 1) * (float)in->spacing;
        const float cz = 0.5f * (float)(in->data_h - 1) * (float)in->spacing;
        const float relief = (float)(in->h_scale * (in->h_max - in->h_min));
        const float clearance = fmaxf(60.0f, 0.05f * relief);
        const bool wrap = in->wrap;
        hz_pyramid_close(p);
        const float len = fminf(0.8f * E, 300.0f * 60.0f / sqrtf(2.0f));
        hz_path_key k[61];
        for (int n = 0; n < 61; n++) {
            float u = (float)n / 60.0f, x = cx - 0.5f * len + u * len, z = cz - 0.5f * len + u * len;
            float yaw = 135.0f;
            if (wrap) { /* a repeating terrain: straight east across two and a half periods */
                x = (0.1f + 2.5f * u) * E;
                z = 0.37f * E;
                yaw = 90.0f;
            }
            k[n] = (hz_path_key){u * 60.0f, x, coarse_max(&g, x, z, 0.03f * E, wrap) + clearance, z, yaw, -8.0f};
        }
        if (hz_path_from_keys(k, 61, "flyover", &path, &err) != HZ_OK) {
            fprintf(stderr, "horizon bench: %s\n", err.msg);
            coarse_free(&g);
            return 1;
        }
    }
    sctx c;
    const int open_rc = sctx_open(&c, &o, &g, "bench"); /* the sea's coast from the same level */
    coarse_free(&g);
    if (open_rc) {
        hz_path_free(&path);
        return 1;
    }
    stream_curvature(&o, hz_stream_info(c.s));
    const float dur = hz_path_duration(&path);
    /* Frames: unpaced, --frames spread over the path, drawn as fast as they
     * can be (throughput). --realtime: frame slots every 1/fps s of wall
     * time, the camera at the slot's path time; a frame ahead of its slot
     * waits, one that overran skips the slots it missed (the camera follows
     * the wall clock, as a viewer's does). The flight is the whole path, or
     * its first --frames slots. */
    uint32_t F = o.frames;
    if (o.realtime) {
        const double slots = floor((double)dur * o.fps) + 1.0;
        F = o.frames_given && o.frames < slots ? o.frames : (uint32_t)fmin(slots, 1e7);
    }
    double *frame = calloc(F, sizeof *frame), *lod = calloc(F, sizeof *lod), *tris = calloc(F, sizeof *tris);
    uint8_t *rgb = o.deterministic ? malloc((size_t)o.width * o.height * 3) : NULL;
    json_t *frames = json_array();
    uint64_t late_frames = 0, requested = 0, loaded = 0, evicted = 0, late_nodes = 0, drawn_nodes = 0;
    uint64_t dropped = 0, flight_hash = 0xcbf29ce484222325ULL;
    double worst = 0, cache_max = 0;
    uint32_t failed = 0, drawn = 0;
    const double fly0 = hz_time_ms();
    rc = 1;
    if (!frame || !lod || !tris || (o.deterministic && !rgb))
        goto done;
    int64_t last_slot = -1;
    double pace0 = fly0;
    for (uint32_t f = 0; f < F; f++) {
        float t = F > 1 ? dur * (float)f / (float)(F - 1) : 0.0f;
        if (o.realtime) {
            /* the next slot not yet past: wait for it, or skip the missed ones
             * (slot 0 is the first frame's start) */
            if (f == 0)
                pace0 = hz_time_ms();
            const double now = (hz_time_ms() - pace0) / 1000.0;
            int64_t slot = f == 0 ? 0 : (int64_t)ceil(now * o.fps - 1e-3);
            slot = slot > last_slot ? slot : last_slot + 1;
            if ((double)slot > (double)dur * o.fps + 1e-6 || (o.frames_given && slot >= (int64_t)o.frames))
                break;
            dropped += (uint64_t)(slot - last_slot - 1);
            last_slot = slot;
            const double wait_ms = pace0 + 1000.0 * (double)slot / o.fps - hz_time_ms();
            if (wait_ms > 0)
                sleep_ms(wait_ms);
            t = (float)((double)slot / o.fps);
        }
        hz_camera cam = default_camera(hz_stream_info(c.s), o.width, o.height);
        cam.earth_radius = o.curv.radius;
        hz_path_sample(&path, t, &cam);
        hz_stream_set_clock(c.s, t); /* arriving tiles slide in on the flight's clock */
        cam.aspect = (float)o.width / (float)o.height;
        hz_stream_wrap_camera(c.s, &cam); /* re-centred: precision never degrades */
        const double t0 = hz_time_ms();
        hz_lod_stats st = {0};
        uint32_t n;
        uint64_t req_wait = 0;
        if (o.deterministic) {
            /* every tile this view wants is resident before it is drawn */
            uint32_t rounds = 0;
            n = 0;
            if (load_all(&c, &cam, &rounds, &n, &req_wait))
                goto done;
            loaded += n;
        }
        /* what arrived since the last frame first, then the selection over it */
        if (upload_ready(&c, &n))
            goto done;
        if (hz_stream_select(c.s, &cam, &c.lp, &c.pl, &st) != HZ_OK)
            goto done;
        hz_scene_params sp = {.patches = c.pl.data, .patch_count = (uint32_t)c.pl.count,
                              .morph_scale = st.morph_scale, .morph_start = st.morph_start,
                              .morph_near = st.morph_near, .morph_near_distance = st.morph_near_distance,
                              .fog_density = cli_fog_default(cam.zfar), .effects = stream_effects(&c)};
        hz_draw_stats ds = {0};
        if (hz_renderer_draw(c.r, &cam, &sp, NULL, 0, &ds, &err) != HZ_OK) {
            fprintf(stderr, "horizon bench: %s\n", err.msg);
            goto done;
        }
        hz_stream_stats ss = hz_stream_take_stats(c.s);
        frame[f] = hz_time_ms() - t0;
        char hex[17] = "";
        if (o.deterministic) {
            if (hz_renderer_read_rgb(c.r, rgb, &err) != HZ_OK) {
                fprintf(stderr, "horizon bench: %s\n", err.msg);
                goto done;
            }
            const uint64_t h = fnv64(rgb, (size_t)o.width * o.height * 3);
            snprintf(hex, sizeof hex, "%016llx", (unsigned long long)h);
            flight_hash = (flight_hash ^ h) * 0x100000001b3ULL;
        }
        lod[f] = st.ms;
        tris[f] = st.triangles;
        drawn = f + 1;
        worst = frame[f] > worst ? frame[f] : worst;
        late_frames += ss.late > 0;
        late_nodes += ss.late;
        drawn_nodes += ss.drawn;
        failed = ss.failed > failed ? ss.failed : failed;
        requested += ss.requested + req_wait, loaded += ss.loaded, evicted += ss.evicted;
        cache_max = fmax(cache_max, (double)ss.cache_bytes / 1048576.0);
        json_t *pf = json_pack("{s:i,s:f,s:f,s:f,s:i,s:i,s:i,s:i,s:i,s:i,s:i,s:f}", "frame", (int)f, "t", (double)t,
                               "ms", frame[f], "lod_ms", st.ms, "triangles", (int)st.triangles, "nodes",
                               (int)c.pl.count, "requested", (int)(ss.requested + req_wait), "loaded",
                               (int)ss.loaded, "evicted", (int)ss.evicted, "resident", (int)ss.resident,
                               "late_nodes", (int)ss.late, "cache_mb", (double)ss.cache_bytes / 1048576.0);
        if (o.deterministic)
            json_object_set_new(pf, "hash", json_string(hex));
        json_array_append_new(frames, pf);
    }
    F = drawn;
    if (F == 0) {
        fprintf(stderr, "horizon bench: no frame was drawn\n");
        goto done;
    }
    const double med_frame = pct(frame, F, 0.5), p99 = pct(frame, F, 0.99), med_lod = pct(lod, F, 0.5);
    const double med_tris = pct(tris, F, 0.5);
    json_t *j = json_object();
    json_object_set_new(j, "terrain", jx_str(o.terrain));
    json_object_set_new(j, "path", jx_str(path.name[0] ? path.name : "flyover"));
    json_object_set_new(j, "frames", json_integer(F));
    json_object_set_new(j, "pixel_error", jx_dbl(o.tau));
    cli_near_json(j, &c.lp);
    curv_cli_json(j, &o.curv);
    json_object_set_new(j, "cache_mb_limit", jx_dbl(o.cache_mb));
    json_object_set_new(j, "frame_ms_median", jx_dbl(med_frame));
    json_object_set_new(j, "frame_ms_p99", jx_dbl(p99));
    json_object_set_new(j, "frame_ms_worst", jx_dbl(worst));
    json_object_set_new(j, "lod_ms_median", jx_dbl(med_lod));
    json_object_set_new(j, "triangles_median", jx_dbl(med_tris));
    json_object_set_new(j, "tiles_requested", json_integer((json_int_t)requested));
    json_object_set_new(j, "tiles_loaded", json_integer((json_int_t)loaded));
    json_object_set_new(j, "tiles_evicted", json_integer((json_int_t)evicted));
    json_object_set_new(j, "cache_mb_max", jx_dbl(cache_max));
    json_object_set_new(j, "late_frame_fraction", jx_dbl((double)late_frames / F));
    json_object_set_new(j, "late_tile_fraction", jx_dbl(drawn_nodes ? (double)late_nodes / (double)drawn_nodes : 0));
    json_object_set_new(j, "late_nodes", json_integer((json_int_t)late_nodes));
    json_object_set_new(j, "nodes_drawn", json_integer((json_int_t)drawn_nodes));
    json_object_set_new(j, "water_level", c.water ? jx_dbl(c.water_level) : json_null());
    json_object_set_new(j, "pacing", jx_str(o.realtime ? "realtime" : o.deterministic ? "deterministic" : "unpaced"));
    json_object_set_new(j, "path_seconds", jx_dbl(dur));
    json_object_set_new(j, "flight_seconds", jx_dbl((hz_time_ms() - fly0) / 1000.0));
    if (o.realtime) {
        json_object_set_new(j, "fps", jx_dbl(o.fps));
        json_object_set_new(j, "frames_dropped", json_integer((json_int_t)dropped));
    }
    if (o.deterministic) {
        char hex[17];
        snprintf(hex, sizeof hex, "%016llx", (unsigned long long)flight_hash);
        json_object_set_new(j, "flight_hash", json_string(hex));
    }
    json_object_set_new(j, "tiles_failed", jx_int((long long)failed));
    json_t *http = transfer_json(&c, "bench", hz_time_ms() - fly0);
    if (http)
        json_object_set_new(j, "http", http);
    json_object_set_new(j, "peak_rss_mb", jx_dbl((double)hz_peak_rss_bytes() / 1048576.0));
    if (hz_stream_warning(c.s))
        json_object_set_new(j, "warning", jx_str(hz_stream_warning(c.s)));
    json_object_set_new(j, "per_frame", frames);
    frames = NULL;
    if (o.json) {
        print_json(j);
    } else {
        if (!o.quiet)
            printf("%s: %u frames, median %.1f ms (p99 %.1f, worst %.1f), lod %.2f ms, %.0f triangles, tiles %llu "
                   "loaded / %llu evicted, cache <= %.0f MB, late frames %.1f %%, late tiles %.2f %%, peak RSS "
                   "%.0f MB\n",
                   o.terrain, F, med_frame, p99, worst, med_lod, med_tris, (unsigned long long)loaded,
                   (unsigned long long)evicted, cache_max, 100.0 * (double)late_frames / F,
                   drawn_nodes ? 100.0 * (double)late_nodes / (double)drawn_nodes : 0.0,
                   (double)hz_peak_rss_bytes() / 1048576.0);
        json_decref(j);
    }
    if (hz_stream_warning(c.s))
        fprintf(stderr, "horizon bench: warning: %s\n", hz_stream_warning(c.s));
    rc = 0;
done:
    json_decref(frames);
    free(rgb);
    free(frame);
    free(lod);
    free(tris);
    hz_path_free(&path);
    sctx_free(&c);
    return rc;
}
