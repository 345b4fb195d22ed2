/* horizon info: what a DEM file holds — size, CRS, corners, spacing, heights,
 * nodata — as stored, and what --dem makes of it (no GL). */
#include "cli.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void json_str(const char *s)
{
    putchar('"');
    for (; *s; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\')
            printf("\\%c", c);
        else if (c < 0x20)
            printf("\\u%04x", c);
        else
            putchar(c);
    }
    putchar('"');
}

static int info_one(const char *path, const char *crs, bool json, bool first)
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
    if (json) {
        printf("%s{\"file\":", first ? "" : ",");
        json_str(path);
        printf(",\"driver\":");
        json_str(in.driver[0] ? in.driver : hz_dem_format_name(in.format));
        printf(",\"files\":%u,\"width\":%u,\"height\":%u,\"samples\":%llu", in.files, w, h,
               (unsigned long long)w * h);
        if (geo) {
            printf(",\"crs\":");
            json_str(hz_georef_label(geo));
            printf(",\"crs_name\":");
            json_str(hz_georef_name(geo));
            printf(",\"epsg\":%d,\"geographic\":%s", hz_georef_epsg(geo), hz_georef_is_geographic(geo) ? "true" : "false");
            double gt[6];
            hz_georef_geotransform(geo, gt);
            printf(",\"geotransform\":[%.17g,%.17g,%.17g,%.17g,%.17g,%.17g]", gt[0], gt[1], gt[2], gt[3], gt[4], gt[5]);
            if (corners)
                printf(",\"corners_lonlat\":{\"nw\":[%.9f,%.9f],\"ne\":[%.9f,%.9f],\"se\":[%.9f,%.9f],\"sw\":[%.9f,%.9f]}",
                       c[0][0], c[0][1], c[1][0], c[1][1], c[2][0], c[2][1], c[3][0], c[3][1]);
            printf(",\"spacing_m\":[%.4f,%.4f]", sx, sy);
        } else {
            printf(",\"crs\":null,\"spacing_m\":null,\"spacing_hint_m\":%g", (double)in.spacing_hint);
        }
        printf(",\"units\":\"%s\",\"height_min\":%.3f,\"height_max\":%.3f,\"nodata\":%llu",
               in.units == HZ_UNITS_FT ? "ft" : in.units == HZ_UNITS_DM ? "dm" : in.units == HZ_UNITS_RAW ? "raw" : "m",
               (double)lo, (double)hi, (unsigned long long)nodata);
        if (metric_ok && mgeo) {
            printf(",\"terrain\":{\"crs\":");
            json_str(hz_georef_label(mgeo));
            printf(",\"width\":%u,\"height\":%u,\"spacing_m\":%.4f,\"reprojected\":%s}", mw, mh, msx,
                   mi.reprojected ? "true" : "false");
        }
        printf("}");
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
    bool first = true;
    if (json)
        printf("[");
    for (int i = 2; i < argc; i++) {
        if (!strcmp(argv[i], "--crs")) {
            i++;
            continue;
        }
        if (argv[i][0] == '-' && argv[i][1])
            continue;
        const size_t len = strlen(argv[i]);
        if (len > 4 && !strcmp(argv[i] + len - 4, ".hzp")) {
            if (json && !first)
                printf(",");
            fflush(stdout);
            if (pyramid_info(argv[i], verify, json))
                rc = 1;
            first = false;
            continue;
        }
        if (info_one(argv[i], crs, json, first))
            rc = 1;
        else
            first = false;
    }
    if (json)
        printf("]\n");
    return rc;
}
