/* horizon info: what a DEM file holds — size, CRS, corners, spacing, heights,
 * nodata — as stored, and what --dem makes of it (no GL). */
#include "cli.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int info_one(const char *path, const char *crs, json_t *arr)
{
    hz_grid g = {0};
    hz_dem_info in;
    hz_georef *geo = NULL;
    hz_err err = {0};
    if (hz_dem_load(&(hz_dem_desc){.path = path, .georef = &geo}, &g, &in, &err) != HZ_OK) {
        fprintf(stderr, "horizon info: %s\n", err.msg);
        return 1;
    }
    float lo, hi;
    uint64_t nodata = hz_grid_range(&g, &lo, &hi);
    double c[4][2] = {{0}};
    bool corners = geo && hz_georef_corners_lonlat(geo, c, &err) == HZ_OK;
    double sx = 0, sy = 0;
    if (geo)
        hz_georef_spacing(geo, &sx, &sy);
    const uint32_t w = g.width, h = g.height;
    hz_grid_free(&g);
    /* What --dem makes of it: the metric grid (reprojected when geographic). */
    hz_grid m = {0};
    hz_dem_info mi;
    hz_georef *mgeo = NULL;
    bool metric_ok = hz_dem_load(&(hz_dem_desc){.path = path, .metric = true, .crs = crs, .georef = &mgeo}, &m, &mi,
                                 &err) == HZ_OK;
    uint32_t mw = m.width, mh = m.height;
    hz_grid_free(&m);
    double msx = 0;
    if (mgeo)
        hz_georef_spacing(mgeo, &msx, NULL);
    if (arr) {
        json_t *j = json_object();
        jx_set(j, "file", jx_str(path));
        jx_set(j, "driver", jx_str(in.driver[0] ? in.driver : hz_dem_format_name(in.format)));
        jx_set(j, "files", jx_int(in.files));
        jx_set(j, "width", jx_int(w));
        jx_set(j, "height", jx_int(h));
        jx_set(j, "samples", jx_int((long long)w * h));
        if (geo) {
            jx_set(j, "crs", jx_str(hz_georef_label(geo)));
            jx_set(j, "crs_name", jx_str(hz_georef_name(geo)));
            jx_set(j, "epsg", jx_int(hz_georef_epsg(geo)));
            jx_set(j, "geographic", jx_bool(hz_georef_is_geographic(geo)));
            double gt[6];
            hz_georef_geotransform(geo, gt);
            json_t *g6 = json_array();
            for (int k = 0; k < 6; k++)
                json_array_append_new(g6, jx_dbl(gt[k]));
            jx_set(j, "geotransform", g6);
            if (corners) {
                static const char *const names[4] = {"nw", "ne", "se", "sw"};
                json_t *cj = json_object();
                for (int k = 0; k < 4; k++)
                    jx_set(cj, names[k], json_pack("[oo]", jx_fix(c[k][0], 9), jx_fix(c[k][1], 9)));
                jx_set(j, "corners_lonlat", cj);
            }
            jx_set(j, "spacing_m", json_pack("[oo]", jx_fix(sx, 4), jx_fix(sy, 4)));
        } else {
            jx_set(j, "crs", json_null());
            jx_set(j, "spacing_m", json_null());
            jx_set(j, "spacing_hint_m", jx_num(in.spacing_hint));
        }
        jx_set(j, "units", jx_str(in.units == HZ_UNITS_FT    ? "ft"
                                  : in.units == HZ_UNITS_DM  ? "dm"
                                  : in.units == HZ_UNITS_RAW ? "raw"
                                                             : "m"));
        jx_set(j, "height_min", jx_fix(lo, 3));
        jx_set(j, "height_max", jx_fix(hi, 3));
        jx_set(j, "nodata", jx_int((long long)nodata));
        if (metric_ok && mgeo)
            jx_set(j, "terrain", json_pack("{s:o,s:I,s:I,s:o,s:b}", "crs", jx_str(hz_georef_label(mgeo)), "width",
                                           (json_int_t)mw, "height", (json_int_t)mh, "spacing_m", jx_fix(msx, 4),
                                           "reprojected", (int)mi.reprojected));
        json_array_append_new(arr, j);
    } else {
        printf("%s\n", path);
        printf("  driver      %s%s\n", in.driver[0] ? in.driver : hz_dem_format_name(in.format),
               in.files > 1 ? " (mosaic)" : "");
        if (in.files > 1)
            printf("  files       %u\n", in.files);
        printf("  size        %u x %u (%llu samples)\n", w, h, (unsigned long long)w * h);
        if (geo) {
            printf("  CRS         %s (%s)\n", hz_georef_label(geo), hz_georef_name(geo));
            if (corners) {
                printf("  corners     NW %.7f, %.7f   NE %.7f, %.7f  (lon, lat)\n", c[0][0], c[0][1], c[1][0], c[1][1]);
                printf("              SW %.7f, %.7f   SE %.7f, %.7f\n", c[3][0], c[3][1], c[2][0], c[2][1]);
            }
            printf("  spacing     %.3f m x %.3f m (east-west x north-south%s)\n", sx, sy,
                   hz_georef_is_geographic(geo) ? ", at the centre" : "");
        } else {
            printf("  CRS         none (no georeference)\n");
            if (in.spacing_hint > 0)
                printf("  spacing     %.3f m (from the name or format)\n", (double)in.spacing_hint);
        }
        printf("  heights     %.2f .. %.2f m (units %s)\n", (double)lo, (double)hi,
               in.units == HZ_UNITS_FT ? "ft" : in.units == HZ_UNITS_DM ? "dm" : in.units == HZ_UNITS_RAW ? "raw" : "m");
        printf("  nodata      %llu samples (%.3f %%)\n", (unsigned long long)nodata,
               100.0 * (double)nodata / ((double)w * h));
        if (metric_ok && mgeo)
            printf("  as terrain  %s, %u x %u at %.3f m%s\n", hz_georef_label(mgeo), mw, mh, msx,
                   mi.reprojected ? " (reprojected, bilinear)" : "");
    }
    hz_georef_destroy(geo);
    hz_georef_destroy(mgeo);
    return 0;
}

/* A terrain pyramid: by its name (.hzp, also over http) or its signature. */
static bool is_pyramid(const char *path)
{
    const size_t len = strlen(path);
    if (len > 4 && !strcmp(path + len - 4, ".hzp"))
        return true;
    FILE *f = fopen(path, "rb");
    char magic[8] = {0};
    const bool got = f && fread(magic, 1, 8, f) == 8;
    if (f)
        fclose(f);
    return got && !memcmp(magic, "HZPYRAMD", 8);
}

int cmd_info(int argc, char **argv)
{
    bool json = false, verify = false;
    const char *crs = NULL;
    int files = 0;
    for (int i = 2; i < argc; i++) {
        if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) {
            fprintf(stderr, "usage: horizon info [--json] [--crs EPSG:N] FILE|FOLDER...\n"
                            "Prints each DEM's size, CRS, corner lon/lat, spacing x/y in metres, height range\n"
                            "and nodata count as stored, and the grid --dem makes of it (a folder is read\n"
                            "as one mosaic).\n"
                            "  --json        one JSON array on stdout\n"
                            "  --crs EPSG:N  the metric CRS for geographic files (default: UTM of the centre)\n"
                            "  --verify      terrain pyramids (.hzp): check every tile's checksum\n");
            return 0;
        }
        if (!strcmp(argv[i], "--")) {
            files += argc - i - 1; /* the rest are files, whatever their names */
            break;
        }
        if (!strcmp(argv[i], "--json"))
            json = true;
        else if (!strcmp(argv[i], "--verify"))
            verify = true;
        else if (!strcmp(argv[i], "--crs")) {
            if (i + 1 >= argc) {
                fprintf(stderr, "horizon info: option --crs needs a value\n");
                return 2;
            }
            crs = argv[++i];
        } else if (argv[i][0] == '-' && argv[i][1]) {
            fprintf(stderr, "horizon info: unknown option '%s' (see horizon info --help)\n", argv[i]);
            return 2;
        } else
            files++;
    }
    if (!files) {
        fprintf(stderr, "horizon info: no file given (usage: horizon info [--json] FILE...)\n");
        return 2;
    }
    int rc = 0;
    json_t *arr = json ? json_array() : NULL;
    bool operands = false; /* after "--" */
    for (int i = 2; i < argc; i++) {
        if (!operands && !strcmp(argv[i], "--")) {
            operands = true;
            continue;
        }
        if (!operands && !strcmp(argv[i], "--crs")) {
            i++;
            continue;
        }
        if (!operands && argv[i][0] == '-' && argv[i][1])
            continue;
        if (is_pyramid(argv[i])) {
            if (pyramid_info(argv[i], verify, arr))
                rc = 1;
            continue;
        }
        if (info_one(argv[i], crs, arr))
            rc = 1;
    }
    if (arr && jx_print(arr, stdout))
        rc = 1;
    return rc;
}
