/* GDAL input: the real georeferenced DEMs (size, CRS, spacing, corners,
 * nodata), reprojection to UTM, mosaics equal to one raster sample for
 * sample, ENVI / ASCII grid / VRT / COG, units, fitting that keeps every
 * sample, the georeference API, and clear errors on broken files. The
 * synthetic rasters are written here with GDAL. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <gdal.h>
#include <ogr_srs_api.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "horizon/dem.h"
#include "horizon/georef.h"
#include "horizon/terrain.h"
#include "io_fixtures.h"

#include <png.h>
#include "io_tests.h"

static const char *tmp(const char *name)
{
    static char buf[4][1024];
    static int k;
    k = (k + 1) % 4;
    snprintf(buf[k], sizeof buf[k], "%s/%s", HZ_TEST_TMP, name);
    return buf[k];
}

/* Writes w x h values with a geotransform and CRS through a GDAL driver
 * (GTiff directly; others as a copy of an in-memory raster). */
static void write_raster(const char *driver, const char *path, const float *v, int w, int h, const double gt[6],
                         const char *crs, const double *nodata, GDALDataType type, const char *unit)
{
    GDALAllRegister();
    GDALDriverH mem = GDALGetDriverByName("MEM");
    GDALDatasetH ds = GDALCreate(mem, "", w, h, 1, type, NULL);
    assert_non_null(ds);
    if (gt)
        GDALSetGeoTransform(ds, (double *)gt);
    if (crs) {
        OGRSpatialReferenceH s = OSRNewSpatialReference(NULL);
        assert_int_equal(OSRSetFromUserInput(s, crs), OGRERR_NONE);
        GDALSetSpatialRef(ds, s);
        OSRDestroySpatialReference(s);
    }
    GDALRasterBandH b = GDALGetRasterBand(ds, 1);
    if (nodata)
        GDALSetRasterNoDataValue(b, *nodata);
    if (unit)
        GDALSetRasterUnitType(b, unit);
    assert_int_equal(GDALRasterIO(b, GF_Write, 0, 0, w, h, (void *)v, w, h, GDT_Float32, 0, 0), CE_None);
    GDALDriverH d = GDALGetDriverByName(driver);
    assert_non_null(d);
    GDALDatasetH out = GDALCreateCopy(d, path, ds, FALSE, NULL, NULL, NULL);
    assert_non_null(out);
    GDALClose(out);
    GDALClose(ds);
}

/* A smooth, non-symmetric test surface. */
static float surf(int i, int j)
{
    return 500.0f + 3.0f * (float)i - 2.0f * (float)j + 40.0f * sinf(0.13f * (float)i) * cosf(0.07f * (float)j);
}

static float *make_surface(int w, int h)
{
    float *v = malloc((size_t)w * (size_t)h * sizeof *v);
    assert_non_null(v);
    for (int j = 0; j < h; j++)
        for (int i = 0; i < w; i++)
            v[(size_t)j * (size_t)w + (size_t)i] = surf(i, j);
    return v;
}

static hz_result load(const hz_dem_desc *d, hz_grid *g, hz_dem_info *info, hz_georef **geo, hz_err *err)
{
    hz_dem_desc dd = *d;
    dd.georef = geo;
    return hz_dem_load(&dd, g, info, err);
}

/* ---- the real DEMs ---- */

typedef struct real_geo {
    const char *file;
    uint32_t w, h;
    int epsg;
    double sx, sy, tol; /* metres per sample at the centre */
    double nw_lon, nw_lat, se_lon, se_lat; /* outer corners, degrees; tolerance below */
    double corner_tol;
    uint64_t voids;
} real_geo;

/* Metres per degree on WGS 84 at latitude phi (the standard series), an
 * independent check of the georeference's spacing. */
static double m_per_deg_lon(double phi)
{
    double p = phi * M_PI / 180.0;
    return 111412.84 * cos(p) - 93.5 * cos(3 * p) + 0.118 * cos(5 * p);
}

static double m_per_deg_lat(double phi)
{
    double p = phi * M_PI / 180.0;
    return 111132.954 - 559.822 * cos(2 * p) + 1.175 * cos(4 * p);
}

void test_gdal_real_native(void **state)
{
    (void)state;
    const double s3x44 = m_per_deg_lon(44.5) / 1200, s3y44 = m_per_deg_lat(44.5) / 1200;
    const double s3x46 = m_per_deg_lon(46.5) / 1200, s3y46 = m_per_deg_lat(46.5) / 1200;
    const double s3x32 = m_per_deg_lon(-32.5) / 1200, s3y32 = m_per_deg_lat(-32.5) / 1200;
    const double s1x45 = m_per_deg_lon(-45.5) / 3600, s1y45 = m_per_deg_lat(-45.5) / 3600;
    const double h3 = 1.0 / 2400.0, h1 = 1.0 / 7200.0; /* half a 3" / 1" sample */
    const real_geo d[] = {
        {"N44W072.hgt", 1201, 1201, 4326, s3x44, s3y44, 0.01, -72 - h3, 45 + h3, -71 + h3, 44 - h3, 1e-7, 0},
        {"N46E008.tif", 1201, 1201, 4326, s3x46, s3y46, 0.01, 8 - h3, 47 + h3, 9 + h3, 46 - h3, 1e-7, 103743},
        {"S33W071.tif", 1201, 1201, 4326, s3x32, s3y32, 0.01, -71 - h3, -32 + h3, -70 + h3, -33 - h3, 1e-7, 0},
        {"S46W066.hgt.gz", 3601, 3601, 4326, s1x45, s1y45, 0.01, -66 - h1, -45 + h1, -65 + h1, -46 - h1, 1e-7, 0},
        /* UTM 32N: gdalinfo prints the corners to 0.01" (2.8e-6 deg). */
        {"heidelberg_dem_hd_utm32n_25m_float32.tif", 1041, 713, 32632, 25.0, 25.0, 1e-9,
         8 + 31 / 60.0 + 16.00 / 3600.0, 49 + 29 / 60.0 + 48.65 / 3600.0, 8 + 52 / 60.0 + 51.23 / 3600.0,
         49 + 20 / 60.0 + 14.79 / 3600.0, 6e-6, 0},
    };
    for (size_t k = 0; k < sizeof d / sizeof *d; k++) {
        char path[1024];
        snprintf(path, sizeof path, "%s/%s", HZ_DATA_DIR, d[k].file);
        hz_grid g;
        hz_dem_info info;
        hz_georef *geo = NULL;
        hz_err err = {0};
        if (load(&(hz_dem_desc){.path = path}, &g, &info, &geo, &err) != HZ_OK)
            fail_msg("%s: %s", d[k].file, err.msg);
        assert_non_null(geo);
        double sx, sy, c[4][2];
        hz_georef_spacing(geo, &sx, &sy);
        assert_int_equal(hz_georef_corners_lonlat(geo, c, &err), HZ_OK);
        print_message("%-42s %ux%u %-10s %s spacing %.3f x %.3f m, NW %.7f %.7f SE %.7f %.7f, %llu voids\n",
                      d[k].file, g.width, g.height, hz_georef_label(geo), info.driver, sx, sy, c[0][0], c[0][1],
                      c[2][0], c[2][1], (unsigned long long)info.voids);
        assert_int_equal(g.width, d[k].w);
        assert_int_equal(g.height, d[k].h);
        assert_int_equal(hz_georef_epsg(geo), d[k].epsg);
        assert_true(fabs(sx - d[k].sx) <= d[k].tol);
        assert_true(fabs(sy - d[k].sy) <= d[k].tol);
        assert_true(fabs(c[0][0] - d[k].nw_lon) <= d[k].corner_tol);
        assert_true(fabs(c[0][1] - d[k].nw_lat) <= d[k].corner_tol);
        assert_true(fabs(c[2][0] - d[k].se_lon) <= d[k].corner_tol);
        assert_true(fabs(c[2][1] - d[k].se_lat) <= d[k].corner_tol);
        assert_int_equal(info.voids, d[k].voids);
        assert_int_equal(info.file_voids, d[k].voids);
        assert_false(info.reprojected);
        /* The voids are NaN, nothing else is. */
        float lo, hi;
        assert_int_equal(hz_grid_range(&g, &lo, &hi), d[k].voids);
        assert_true(lo > -500.0f && hi < 9000.0f);
        hz_grid_free(&g);
        hz_georef_destroy(geo);
    }
}

void test_gdal_spacing_44n(void **state)
{
    (void)state;
    /* A 3" tile at 44.5 N: 66 +- 1 m east-west, 92.7 m north-south. */
    hz_grid g;
    hz_dem_info info;
    hz_georef *geo = NULL;
    hz_err err = {0};
    assert_int_equal(load(&(hz_dem_desc){.path = HZ_DATA_DIR "/N44W072.hgt"}, &g, &info, &geo, &err), HZ_OK);
    double sx, sy;
    hz_georef_spacing(geo, &sx, &sy);
    assert_true(fabs(sx - 66.0) <= 1.0);
    assert_true(fabs(sy - 92.60) <= 0.1);
    hz_grid_free(&g);
    hz_georef_destroy(geo);

    /* Reprojected for the terrain: UTM 19N, square cells at the finer spacing. */
    if (load(&(hz_dem_desc){.path = HZ_DATA_DIR "/N44W072.hgt", .metric = true}, &g, &info, &geo, &err) != HZ_OK)
        fail_msg("%s", err.msg);
    assert_true(info.reprojected);
    assert_int_equal(hz_georef_epsg(geo), 32619);
    hz_georef_spacing(geo, &sx, &sy);
    assert_true(fabs(sx - 66.27) < 0.05);
    assert_true(fabs(sx - sy) < 1e-9);
    assert_float_equal(info.spacing_hint, sx, 1e-3);
    /* 1 degree of latitude is ~111 km: ~1680 rows at 66 m; ~79.5 km of longitude: ~1200 columns;
     * more for the grid convergence (2.5 deg from the zone's central meridian). */
    print_message("N44W072 in UTM 19N: %ux%u at %.3f m, %llu samples outside the footprint\n", g.width, g.height, sx,
                  (unsigned long long)info.voids);
    assert_true(g.height >= 1678 && g.height < 1760);
    assert_true(g.width >= 1200 && g.width < 1300);
    /* The tile's centre (44.5 N, 71.5 W) is inside and maps back to itself. */
    double x, z, lon, lat;
    assert_int_equal(hz_georef_lonlat_to_local(geo, -71.5, 44.5, &x, &z, &err), HZ_OK);
    assert_int_equal(hz_georef_local_to_lonlat(geo, x, z, &lon, &lat, &err), HZ_OK);
    assert_true(fabs(lon + 71.5) < 1e-9 && fabs(lat - 44.5) < 1e-9);
    assert_true(x > 0 && z > 0 && x < sx * g.width && z < sy * g.height);
    /* Same height there as the native grid (bilinear, within the local relief). */
    float h = g.z[(size_t)lround(z / sy) * g.width + (size_t)lround(x / sx)];
    assert_false(isnan(h));
    hz_grid_free(&g);
    hz_georef_destroy(geo);

    /* --spacing resamples a projected DEM (heidelberg, 25 m) to 50 m cells. */
    if (load(&(hz_dem_desc){.path = HZ_DATA_DIR "/heidelberg_dem_hd_utm32n_25m_float32.tif", .metric = true,
                            .spacing = 50},
             &g, &info, &geo, &err) != HZ_OK)
        fail_msg("%s", err.msg);
    hz_georef_spacing(geo, &sx, &sy);
    assert_float_equal(sx, 50.0, 1e-9);
    assert_float_equal(sy, 50.0, 1e-9);
    assert_true(info.reprojected);
    assert_int_equal(hz_georef_epsg(geo), 32632);
    assert_true(abs((int)g.width - 521) <= 1 && abs((int)g.height - 357) <= 1);
    hz_grid_free(&g);
    hz_georef_destroy(geo);

    /* --crs picks another zone; a geographic one is refused. */
    assert_int_equal(load(&(hz_dem_desc){.path = HZ_DATA_DIR "/N44W072.hgt", .metric = true, .crs = "EPSG:32618"}, &g,
                          &info, &geo, &err),
                     HZ_OK);
    assert_int_equal(hz_georef_epsg(geo), 32618);
    hz_grid_free(&g);
    hz_georef_destroy(geo);
    assert_int_equal(load(&(hz_dem_desc){.path = HZ_DATA_DIR "/N44W072.hgt", .metric = true, .crs = "EPSG:4326"}, &g,
                          &info, &geo, &err),
                     HZ_ERR_VALUE);
    assert_non_null(strstr(err.msg, "not a projected CRS"));
    assert_int_equal(load(&(hz_dem_desc){.path = HZ_DATA_DIR "/N44W072.hgt", .metric = true, .crs = "EPSG:999999"}, &g,
                          &info, &geo, &err),
                     HZ_ERR_VALUE);
    assert_non_null(strstr(err.msg, "EPSG:999999"));
}

void test_gdal_nodata_terrain(void **state)
{
    (void)state;
    /* N46E008: 103 743 voids (-32767). Through the terrain pipeline none of
     * them reaches the heights: everything stays within the valid range. */
    hz_err err = {0};
    hz_terrain *t = hz_terrain_create(&(hz_terrain_desc){.dem_path = HZ_DATA_DIR "/N46E008.tif"}, &err);
    if (!t)
        fail_msg("%s", err.msg);
    print_message("N46E008: heightmap %u, data %ux%u, %llu valid, range %.1f .. %.1f m, %s\n", t->hm.size, t->data_w,
                  t->data_h, (unsigned long long)t->valid_count, (double)t->min_h, (double)t->max_h,
                  hz_georef_label(t->georef));
    assert_true(t->min_h >= 186.0f && t->max_h <= 4175.0f);
    for (uint32_t j = 0; j < t->hm.size; j += 7)
        for (uint32_t i = 0; i < t->hm.size; i += 7) {
            float h = hz_heightmap_get(&t->hm, i, j);
            assert_true(h >= 186.0f && h <= 4175.0f);
        }
    assert_non_null(t->valid);
    assert_int_equal(hz_georef_epsg(t->georef), 32632);
    /* At least the tile's valid samples are shown (reprojection at the finer
     * spacing has more samples than the file). */
    assert_true(t->valid_count >= 1201ull * 1201ull - 103743ull);
    hz_terrain_destroy(t);

    /* A float32 GeoTIFF with the heidelberg nodata (-3.4028235e38) in a block:
     * those samples are voids, masked, and filled within the data's range. */
    const int w = 41, h = 29;
    float *v = make_surface(w, h);
    const double nd = -3.4028234663852886e+38;
    for (int j = 10; j < 20; j++)
        for (int i = 5; i < 25; i++)
            v[j * w + i] = (float)nd;
    const double gt[6] = {465000, 25, 0, 5480000, 0, -25};
    write_raster("GTiff", tmp("nodata_f32.tif"), v, w, h, gt, "EPSG:32632", &nd, GDT_Float32, NULL);
    t = hz_terrain_create(&(hz_terrain_desc){.dem_path = tmp("nodata_f32.tif")}, &err);
    if (!t)
        fail_msg("%s", err.msg);
    assert_int_equal(t->voids_filled, 200);
    assert_int_equal(t->hm.size, 65);
    assert_int_equal(t->data_w, w);
    assert_int_equal(t->data_h, h);
    assert_int_equal(t->valid_count, (uint64_t)(w * h - 200));
    assert_float_equal(t->spacing, 25.0f, 0.0f);
    for (uint32_t j = 0; j < t->hm.size; j++)
        for (uint32_t i = 0; i < t->hm.size; i++) {
            float hh = hz_heightmap_get(&t->hm, i, j);
            assert_true(hh > 300.0f && hh < 700.0f);
            bool in = i < (uint32_t)w && j < (uint32_t)h;
            bool hole = in && j >= 10 && j < 20 && i >= 5 && i < 25;
            assert_int_equal(t->valid[j * t->hm.size + i], in && !hole);
            if (in && !hole)
                assert_float_equal(hh, surf((int)i, (int)j), 0.02f);
        }
    /* Triangles touching the hole or the padding are dropped, the others kept. */
    const uint32_t n = t->hm.size;
    uint32_t idx[] = {0, 1, n,                         /* valid corner */
                      10 * n + 5, 10 * n + 6, 11 * n + 5, /* in the hole */
                      0, 1, (uint32_t)w,               /* touches padding column w */
                      2 * n, 2 * n + 1, 3 * n};        /* valid */
    size_t kept = hz_terrain_filter_triangles(t, idx, 12);
    assert_int_equal(kept, 6);
    assert_int_equal(idx[3], 2 * n);
    /* By world position: real data, the hole, the padding, off the map (25 m samples). */
    assert_true(hz_terrain_valid_at(t, 0.0f, 0.0f));
    assert_true(hz_terrain_valid_at(t, -12.0f, 28 * 25.0f - 40.0f)); /* within half a sample */
    assert_false(hz_terrain_valid_at(t, -13.0f, 0.0f));
    assert_false(hz_terrain_valid_at(t, 10 * 25.0f, 15 * 25.0f));      /* in the hole */
    assert_true(hz_terrain_valid_at(t, 4 * 25.0f + 12.0f, 15 * 25.0f)); /* nearest: column 4 */
    assert_false(hz_terrain_valid_at(t, 4 * 25.0f + 13.0f, 15 * 25.0f)); /* nearest: column 5 */
    assert_true(hz_terrain_valid_at(t, 40 * 25.0f, 28 * 25.0f));       /* the last sample */
    assert_false(hz_terrain_valid_at(t, 41 * 25.0f, 28 * 25.0f));      /* padding */
    assert_false(hz_terrain_valid_at(t, 64 * 25.0f + 13.0f, 0.0f));    /* off the map */
    assert_false(hz_terrain_valid_at(t, NAN, 0.0f));
    /* The local origin is the north-west sample: its CRS position is the pixel centre. */
    double cx, cy;
    hz_georef_local_to_crs(t->georef, 0, 0, &cx, &cy);
    assert_float_equal(cx, 465012.5, 1e-6);
    assert_float_equal(cy, 5479987.5, 1e-6);
    hz_georef_local_to_crs(t->georef, 25.0 * 3, 25.0 * 2, &cx, &cy);
    assert_float_equal(cx, 465012.5 + 75, 1e-6);
    assert_float_equal(cy, 5479987.5 - 50, 1e-6);
    hz_terrain_destroy(t);
    /* --voids fill: the enclosed hole is drawn (filled), the padding stays masked;
     * a void touching the edge (row 0) stays masked too. */
    for (int i = 30; i < 35; i++)
        v[i] = (float)nd;
    write_raster("GTiff", tmp("nodata_f32_edge.tif"), v, w, h, gt, "EPSG:32632", &nd, GDT_Float32, NULL);
    t = hz_terrain_create(&(hz_terrain_desc){.dem_path = tmp("nodata_f32_edge.tif"), .fill_voids = true}, &err);
    if (!t)
        fail_msg("%s", err.msg);
    assert_int_equal(t->voids_filled, 205);
    assert_int_equal(t->valid_count, (uint64_t)(w * h - 5));
    for (uint32_t j = 0; j < t->hm.size; j++)
        for (uint32_t i = 0; i < t->hm.size; i++) {
            bool in = i < (uint32_t)w && j < (uint32_t)h, edge_void = j == 0 && i >= 30 && i < 35;
            assert_int_equal(t->valid[j * t->hm.size + i], in && !edge_void);
        }
    hz_terrain_destroy(t);
    free(v);
}

/* Reads path(s) with metric on or off and compares two grids sample for sample. */
static void assert_same_grid(const hz_grid *a, const hz_grid *b)
{
    assert_int_equal(a->width, b->width);
    assert_int_equal(a->height, b->height);
    size_t n = (size_t)a->width * a->height, diff = 0;
    for (size_t k = 0; k < n; k++) {
        float x = a->z[k], y = b->z[k];
        if (!(x == y || (isnan(x) && isnan(y))))
            diff++;
    }
    if (diff)
        fail_msg("%zu of %zu samples differ", diff, n);
}

static void check_mosaic(const char *crs, const double gt[6], const char *prefix, bool metric)
{
    /* One 97x73 raster, and the same area as 2x2 tiles sharing their edge
     * row and column (like SRTM), and as 3 strips that only touch. */
    const int W = 97, H = 73;
    float *v = make_surface(W, H);
    char name[256];
    snprintf(name, sizeof name, "%s_whole.tif", prefix);
    write_raster("GTiff", tmp(name), v, W, H, gt, crs, NULL, GDT_Float32, NULL);
    const char *paths[8];
    char names[8][256];
    int np = 0;
    const int xs[2][2] = {{0, 49}, {48, 97}}, ys[2][2] = {{0, 37}, {36, 73}}; /* [x0, x1) */
    for (int ty = 0; ty < 2; ty++)
        for (int tx = 0; tx < 2; tx++) {
            int x0 = xs[tx][0], x1 = xs[tx][1], y0 = ys[ty][0], y1 = ys[ty][1], w = x1 - x0, h = y1 - y0;
            float *t = malloc((size_t)w * (size_t)h * sizeof *t);
            for (int j = 0; j < h; j++)
                for (int i = 0; i < w; i++)
                    t[j * w + i] = v[(y0 + j) * W + x0 + i];
            double tg[6] = {gt[0] + x0 * gt[1], gt[1], 0, gt[3] + y0 * gt[5], 0, gt[5]};
            snprintf(names[np], sizeof names[np], "%s_tile_%d_%d.tif", prefix, tx, ty);
            write_raster("GTiff", tmp(names[np]), t, w, h, tg, crs, NULL, GDT_Float32, NULL);
            paths[np] = strdup(tmp(names[np]));
            np++;
            free(t);
        }
    hz_grid whole, mosaic;
    hz_dem_info iw, im;
    hz_err err = {0};
    snprintf(name, sizeof name, "%s_whole.tif", prefix);
    if (hz_dem_load(&(hz_dem_desc){.path = tmp(name), .metric = metric}, &whole, &iw, &err) != HZ_OK)
        fail_msg("%s", err.msg);
    if (hz_dem_load(&(hz_dem_desc){.paths = paths, .path_count = (uint32_t)np, .metric = metric}, &mosaic, &im,
                    &err) != HZ_OK)
        fail_msg("%s", err.msg);
    assert_int_equal(im.files, 4);
    assert_int_equal(iw.reprojected, metric);
    assert_same_grid(&whole, &mosaic);
    hz_grid_free(&mosaic);
    /* Strips that touch without sharing a column. */
    const int sx[4] = {0, 30, 61, 97};
    const char *spaths[3];
    for (int s = 0; s < 3; s++) {
        int x0 = sx[s], w = sx[s + 1] - sx[s];
        float *t = malloc((size_t)w * (size_t)H * sizeof *t);
        for (int j = 0; j < H; j++)
            for (int i = 0; i < w; i++)
                t[j * w + i] = v[j * W + x0 + i];
        double tg[6] = {gt[0] + x0 * gt[1], gt[1], 0, gt[3], 0, gt[5]};
        char sn[256];
        snprintf(sn, sizeof sn, "%s_strip_%d.tif", prefix, s);
        write_raster("GTiff", tmp(sn), t, w, H, tg, crs, NULL, GDT_Float32, NULL);
        spaths[s] = strdup(tmp(sn));
        free(t);
    }
    if (hz_dem_load(&(hz_dem_desc){.paths = spaths, .path_count = 3, .metric = metric}, &mosaic, &im, &err) != HZ_OK)
        fail_msg("%s", err.msg);
    assert_same_grid(&whole, &mosaic);
    hz_grid_free(&mosaic);
    /* A folder holding the 4 tiles is the same mosaic. */
    char dir[900];
    snprintf(dir, sizeof dir, "%s/%s_dir", HZ_TEST_TMP, prefix);
    mkdir(dir, 0755);
    for (int k = 0; k < np; k++) {
        char dst[3000];
        snprintf(dst, sizeof dst, "%s/%s", dir, names[k]);
        rename(paths[k], dst);
    }
    if (hz_dem_load(&(hz_dem_desc){.path = dir, .metric = metric}, &mosaic, &im, &err) != HZ_OK)
        fail_msg("%s", err.msg);
    assert_int_equal(im.files, 4);
    assert_same_grid(&whole, &mosaic);
    hz_grid_free(&mosaic);
    hz_grid_free(&whole);
    for (int k = 0; k < np; k++)
        free((void *)paths[k]);
    for (int s = 0; s < 3; s++)
        free((void *)spaths[s]);
    free(v);
}

void test_gdal_mosaic_equals_single(void **state)
{
    (void)state;
    /* Projected, read as stored: the mosaic is the raster, bit for bit. */
    const double utm[6] = {500000, 30, 0, 4500000, 0, -30};
    check_mosaic("EPSG:32633", utm, "utm", false);
    /* Geographic 3" cells, reprojected to UTM: still identical. */
    const double geo[6] = {12.0 - 1.0 / 2400, 1.0 / 1200, 0, 45.0 + 1.0 / 2400, 0, -1.0 / 1200};
    check_mosaic("EPSG:4326", geo, "geo", true);
}

void test_gdal_formats(void **state)
{
    (void)state;
    /* The same int16 raster as ENVI (.hdr), ASCII grid, VRT, COG and a zipped
     * GeoTIFF-free SRTM-named tile: every one reads back the same samples
     * and georeference. */
    const int w = 33, h = 21;
    float *v = make_surface(w, h);
    for (int k = 0; k < w * h; k++)
        v[k] = roundf(v[k]);
    const double gt[6] = {300000, 10, 0, 5000000, 0, -10};
    const double nd = -9999;
    struct {
        const char *driver, *name;
        bool crs;
    } f[] = {{"GTiff", "fmt.tif", true}, {"ENVI", "fmt.bil", true}, {"AAIGrid", "fmt.asc", true},
             {"VRT", "fmt.vrt", true},   {"COG", "fmt_cog.tif", true}};
    v[5] = (float)nd;
    for (size_t k = 0; k < sizeof f / sizeof *f; k++) {
        if (!strcmp(f[k].driver, "VRT")) {
            /* A VRT over the GeoTIFF written first. */
            GDALDatasetH src = GDALOpen(tmp("fmt.tif"), GA_ReadOnly);
            assert_non_null(src);
            GDALDatasetH vrt = GDALCreateCopy(GDALGetDriverByName("VRT"), tmp(f[k].name), src, FALSE, NULL, NULL, NULL);
            assert_non_null(vrt);
            GDALClose(vrt);
            GDALClose(src);
        } else {
            write_raster(f[k].driver, tmp(f[k].name), v, w, h, gt, f[k].crs ? "EPSG:32631" : NULL, &nd,
                         !strcmp(f[k].driver, "AAIGrid") ? GDT_Int32 : GDT_Int16, NULL);
        }
        hz_grid g;
        hz_dem_info info;
        hz_georef *geo = NULL;
        hz_err err = {0};
        if (load(&(hz_dem_desc){.path = tmp(f[k].name), .metric = true}, &g, &info, &geo, &err) != HZ_OK)
            fail_msg("%s: %s", f[k].name, err.msg);
        print_message("%-12s driver %-8s %ux%u %s\n", f[k].name, info.driver, g.width, g.height,
                      geo ? hz_georef_label(geo) : "-");
        assert_int_equal(info.format, HZ_DEM_GDAL);
        assert_string_equal(info.driver, !strcmp(f[k].driver, "COG") ? "GTiff" : f[k].driver);
        assert_int_equal(g.width, w);
        assert_int_equal(g.height, h);
        assert_int_equal(info.voids, 1);
        assert_true(isnan(g.z[5]));
        for (int k2 = 0; k2 < w * h; k2++)
            if (k2 != 5)
                assert_float_equal(g.z[k2], v[k2], 0.0f);
        assert_non_null(geo);
        assert_int_equal(hz_georef_epsg(geo), 32631);
        double gg[6];
        hz_georef_geotransform(geo, gg);
        for (int i = 0; i < 6; i++)
            assert_float_equal(gg[i], gt[i], 1e-6);
        hz_grid_free(&g);
        hz_georef_destroy(geo);
    }
    free(v);
}

void test_gdal_units(void **state)
{
    (void)state;
    const int w = 9, h = 7;
    float *v = make_surface(w, h);
    const double gt[6] = {0, 5, 0, 0, 0, -5};
    write_raster("GTiff", tmp("feet.tif"), v, w, h, gt, "EPSG:32631", NULL, GDT_Float32, "ft");
    hz_grid g;
    hz_dem_info info;
    hz_err err = {0};
    assert_int_equal(hz_dem_load(&(hz_dem_desc){.path = tmp("feet.tif")}, &g, &info, &err), HZ_OK);
    assert_int_equal(info.units, HZ_UNITS_FT);
    assert_float_equal(g.z[10], v[10] * 0.3048f, 1e-3f);
    hz_grid_free(&g);
    /* A band scale and offset apply, also through a reprojection. */
    {
        const double geo[6] = {10.0, 1.0 / 1200, 0, 45.0, 0, -1.0 / 1200};
        GDALAllRegister();
        GDALDatasetH ds = GDALCreate(GDALGetDriverByName("GTiff"), tmp("scaled.tif"), w, h, 1, GDT_Float32, NULL);
        assert_non_null(ds);
        GDALSetGeoTransform(ds, (double *)geo);
        OGRSpatialReferenceH srs = OSRNewSpatialReference(NULL);
        OSRSetFromUserInput(srs, "EPSG:4326");
        GDALSetSpatialRef(ds, srs);
        OSRDestroySpatialReference(srs);
        GDALRasterBandH b = GDALGetRasterBand(ds, 1);
        float c[9 * 7];
        for (int k = 0; k < w * h; k++)
            c[k] = 1000.0f; /* flat: reprojection keeps the value */
        assert_int_equal(GDALRasterIO(b, GF_Write, 0, 0, w, h, c, w, h, GDT_Float32, 0, 0), CE_None);
        GDALSetRasterScale(b, 0.5);
        GDALSetRasterOffset(b, 100.0);
        GDALClose(ds);
        for (int metric = 0; metric < 2; metric++) {
            assert_int_equal(hz_dem_load(&(hz_dem_desc){.path = tmp("scaled.tif"), .metric = metric}, &g, &info, &err),
                             HZ_OK);
            float lo, hi;
            hz_grid_range(&g, &lo, &hi);
            assert_float_equal(lo, 600.0f, 1e-3f);
            assert_float_equal(hi, 600.0f, 1e-3f);
            assert_int_equal(info.reprojected, metric);
            hz_grid_free(&g);
        }
    }
    /* --units overrides the band's unit. */
    assert_int_equal(hz_dem_load(&(hz_dem_desc){.path = tmp("feet.tif"), .units = HZ_UNITS_M}, &g, &info, &err), HZ_OK);
    assert_float_equal(g.z[10], v[10], 1e-3f);
    hz_grid_free(&g);
    free(v);
}

void test_fit_keeps_every_sample(void **state)
{
    (void)state;
    /* Non-square and odd sizes: every sample stays, at the north-west corner. */
    const uint32_t sizes[][2] = {{1041, 713}, {5, 3}, {2, 2}, {1201, 1201}, {17, 17}, {18, 1}};
    for (size_t k = 0; k < sizeof sizes / sizeof *sizes; k++) {
        uint32_t w = sizes[k][0], h = sizes[k][1];
        hz_grid g;
        assert_int_equal(hz_grid_alloc(&g, w, h, NULL), HZ_OK);
        for (uint32_t j = 0; j < h; j++)
            for (uint32_t i = 0; i < w; i++)
                g.z[j * w + i] = surf((int)i, (int)j);
        hz_grid_fit_info fi;
        char note[256];
        assert_int_equal(hz_grid_fit(&g, HZ_FIT_AUTO, &fi, note, sizeof note, NULL), HZ_OK);
        uint32_t s = g.width;
        assert_int_equal(g.height, s);
        assert_true(s >= w && s >= h && (s - 1) / 2 < (w > h ? w : h));
        assert_int_equal(fi.valid_count, (uint64_t)w * h);
        assert_int_equal(fi.data_w, w);
        assert_int_equal(fi.data_h, h);
        uint64_t c = 0;
        float lo = 1e9f, hi = -1e9f;
        for (uint32_t j = 0; j < h; j++)
            for (uint32_t i = 0; i < w; i++) {
                lo = fminf(lo, surf((int)i, (int)j));
                hi = fmaxf(hi, surf((int)i, (int)j));
            }
        for (uint32_t j = 0; j < s; j++)
            for (uint32_t i = 0; i < s; i++) {
                float z = g.z[j * s + i];
                bool in = i < w && j < h;
                assert_true(isfinite(z));
                assert_true(z >= lo - 1e-3f && z <= hi + 1e-3f); /* padding is filled within the data's range */
                if (fi.valid) {
                    assert_int_equal(fi.valid[j * s + i], in);
                    c += fi.valid[j * s + i];
                } else {
                    assert_true(in);
                    c++;
                }
                if (in)
                    assert_float_equal(z, surf((int)i, (int)j), 0.0f);
            }
        assert_int_equal(c, (uint64_t)w * h);
        free(fi.valid);
        hz_grid_free(&g);
    }
}

/* Nothing is written beside the inputs: GDAL's /vsigzip/ would leave an
 * index (FILE.gz.properties) next to a large .hgt.gz it read. */
void test_gdal_leaves_inputs_alone(void **state)
{
    (void)state;
    char dir[1024];
    snprintf(dir, sizeof dir, "%s/untouched", HZ_TEST_TMP);
    mkdir(dir, 0755);
    char path[1100], side[1200];
    snprintf(path, sizeof path, "%s/S46W066.hgt.gz", dir);
    snprintf(side, sizeof side, "%s.properties", path);
    remove(side);
    size_t n = 0;
    uint8_t *gz = fx_read(HZ_DATA_DIR "/S46W066.hgt.gz", &n);
    assert_non_null(gz);
    assert_true(fx_write(path, gz, n));
    free(gz);
    hz_grid g;
    hz_dem_info info;
    hz_err err = {0};
    assert_int_equal(hz_dem_load(&(hz_dem_desc){.path = path, .format = HZ_DEM_GDAL}, &g, &info, &err), HZ_OK);
    assert_int_equal(g.width, 3601);
    hz_grid_free(&g);
    struct stat st;
    assert_int_not_equal(stat(side, &st), 0);
    /* the folder holds the input and nothing else */
    char cmd[1300];
    snprintf(cmd, sizeof cmd, "test \"$(ls -A '%s' | wc -l)\" = 1", dir);
    assert_int_equal(system(cmd), 0);
}

void test_gdal_broken(void **state)
{
    (void)state;
    /* A truncated GeoTIFF: a clear error naming it, in the loader and in a mosaic. */
    FILE *in = fopen(HZ_DATA_DIR "/N46E008.tif", "rb");
    assert_non_null(in);
    char *buf = malloc(1500000);
    size_t n = fread(buf, 1, 1500000, in);
    fclose(in);
    assert_int_equal(n, 1500000);
    FILE *out = fopen(tmp("N46E008_truncated.tif"), "wb");
    fwrite(buf, 1, n, out);
    fclose(out);
    free(buf);
    hz_grid g;
    hz_err err = {0};
    assert_int_equal(hz_dem_load(&(hz_dem_desc){.path = tmp("N46E008_truncated.tif")}, &g, NULL, &err), HZ_ERR_FORMAT);
    print_message("truncated: %s\n", err.msg);
    assert_non_null(strstr(err.msg, "N46E008_truncated.tif"));
    const char *two[] = {HZ_DATA_DIR "/N46E008.tif", tmp("N46E008_truncated.tif")};
    assert_int_equal(hz_dem_load(&(hz_dem_desc){.paths = two, .path_count = 2}, &g, NULL, &err), HZ_ERR_FORMAT);
    assert_non_null(strstr(err.msg, "N46E008_truncated.tif"));
    /* A zip that is not one, with an SRTM name. */
    out = fopen(tmp("N10E010.hgt.zip"), "wb");
    fwrite("PK\3\4garbage garbage garbage", 1, 27, out);
    fclose(out);
    assert_int_not_equal(hz_dem_load(&(hz_dem_desc){.path = tmp("N10E010.hgt.zip")}, &g, NULL, &err), HZ_OK);
    print_message("bad zip: %s\n", err.msg);
    assert_non_null(strstr(err.msg, "N10E010.hgt.zip"));
    /* Other formats under an SRTM name are refused, not read as what their
     * bytes say: a GeoTIFF and a netCDF named .hgt, the netCDF gzipped. */
    float *v = make_surface(64, 64);
    const double gt[6] = {10.0, 1.0 / 64, 0, 11.0, 0, -1.0 / 64};
    write_raster("GTiff", tmp("N10E010.hgt"), v, 64, 64, gt, "EPSG:4326", NULL, GDT_Float32, NULL);
    assert_int_not_equal(hz_dem_load(&(hz_dem_desc){.path = tmp("N10E010.hgt")}, &g, NULL, &err), HZ_OK);
    print_message("GeoTIFF named .hgt: %s\n", err.msg);
    assert_null(g.z);
    assert_non_null(strstr(err.msg, "N10E010.hgt"));
    write_raster("netCDF", tmp("N11E010.nc"), v, 64, 64, gt, "EPSG:4326", NULL, GDT_Float32, NULL);
    free(v);
    size_t nc_n = 0;
    uint8_t *nc = fx_read(tmp("N11E010.nc"), &nc_n);
    assert_non_null(nc);
    assert_true(fx_write_gz(tmp("N11E010.hgt.gz"), nc, nc_n));
    free(nc);
    assert_int_not_equal(hz_dem_load(&(hz_dem_desc){.path = tmp("N11E010.hgt.gz")}, &g, NULL, &err), HZ_OK);
    print_message("netCDF named .hgt.gz: %s\n", err.msg);
    assert_null(g.z);
    /* A 40000 x 40000 float DEM in one deflated strip, 700 bytes of file: GDAL
     * would read the strip as one 6 GB block. Refused before reading. */
    assert_true(fx_write_tiff_claim(tmp("one_strip.tif"), 40000, 40000, 1, 32, 3, 8, 400000, 5000000, 30, 32632));
    hz_result one = hz_dem_load(&(hz_dem_desc){.path = tmp("one_strip.tif")}, &g, NULL, &err);
    print_message("one strip: %s\n", err.msg);
    assert_int_equal(one, HZ_ERR_UNSUPPORTED);
    assert_null(g.z);
    assert_non_null(strstr(err.msg, "re-tile"));
    /* A CRS with a geotransform whose pixels have no width: refused, not read
     * as an ungeoreferenced grid at the default spacing. */
    /* (A VRT: GeoTIFF's tags cannot hold such a geotransform.) */
    v = make_surface(64, 64);
    const double good[6] = {500000.0, 30.0, 0, 4000000.0, 0, -30.0};
    write_raster("GTiff", tmp("zero_width_src.tif"), v, 64, 64, good, "EPSG:32633", NULL, GDT_Float32, NULL);
    free(v);
    out = fopen(tmp("zero_width.vrt"), "w");
    assert_non_null(out);
    fprintf(out,
            "<VRTDataset rasterXSize=\"64\" rasterYSize=\"64\"><SRS>EPSG:32633</SRS>"
            "<GeoTransform>500000, 0, 0, 4000000, 0, -30</GeoTransform>"
            "<VRTRasterBand dataType=\"Float32\" band=\"1\"><SimpleSource><SourceFilename relativeToVRT=\"0\">%s"
            "</SourceFilename><SourceBand>1</SourceBand></SimpleSource></VRTRasterBand></VRTDataset>\n",
            tmp("zero_width_src.tif"));
    fclose(out);
    assert_int_equal(hz_dem_load(&(hz_dem_desc){.path = tmp("zero_width.vrt")}, &g, NULL, &err), HZ_ERR_FORMAT);
    print_message("zero pixel width: %s\n", err.msg);
    assert_null(g.z);
    assert_non_null(strstr(err.msg, "zero_width.vrt' has a CRS but cannot be placed by it: degenerate geotransform"));
    /* A missing input of a mosaic. */
    const char *missing[] = {HZ_DATA_DIR "/N46E008.tif", tmp("nope.tif")};
    assert_int_equal(hz_dem_load(&(hz_dem_desc){.paths = missing, .path_count = 2}, &g, NULL, &err), HZ_ERR_IO);
    assert_non_null(strstr(err.msg, "nope.tif"));
    /* A raster too large after reprojection at the asked spacing. */
    assert_int_equal(hz_dem_load(&(hz_dem_desc){.path = HZ_DATA_DIR "/N46E008.tif", .metric = true, .spacing = 0.5},
                                 &g, NULL, &err),
                     HZ_ERR_VALUE);
    assert_non_null(strstr(err.msg, "--spacing"));
}

void test_gdal_sierra_coast(void **state)
{
    (void)state;
    /* 24 SRTM .hgt.zip with ocean gaps, as a folder, read as stored. */
    hz_grid g;
    hz_dem_info info;
    hz_georef *geo = NULL;
    hz_err err = {0};
    if (load(&(hz_dem_desc){.path = HZ_DATA_DIR "/srtm_sierra_coast"}, &g, &info, &geo, &err) != HZ_OK)
        fail_msg("%s", err.msg);
    double c[4][2];
    assert_int_equal(hz_georef_corners_lonlat(geo, c, &err), HZ_OK);
    print_message("sierra coast: %u files, %ux%u, %s, NW %.7f %.7f SE %.7f %.7f, %llu voids\n", info.files, g.width,
                  g.height, hz_georef_label(geo), c[0][0], c[0][1], c[2][0], c[2][1],
                  (unsigned long long)info.voids);
    assert_int_equal(info.files, 24);
    assert_int_equal(g.width, 7 * 1200 + 1);
    assert_int_equal(g.height, 4 * 1200 + 1);
    const double h3 = 1.0 / 2400.0;
    assert_true(fabs(c[0][0] - (-125 - h3)) < 1e-7 && fabs(c[0][1] - (40 + h3)) < 1e-7);
    assert_true(fabs(c[2][0] - (-118 + h3)) < 1e-7 && fabs(c[2][1] - (36 - h3)) < 1e-7);
    /* The 4 missing ocean tiles are voids; the data has none of its own. */
    assert_true(info.voids >= 4ull * 1199 * 1199 && info.voids <= 4ull * 1201 * 1201);
    /* A sample of N39W122 (row 1, column 3 of the block) equals that tile read alone. */
    hz_grid one;
    assert_int_equal(hz_dem_load(&(hz_dem_desc){.path = HZ_DATA_DIR "/srtm_sierra_coast/N39W122.hgt.zip"}, &one,
                                 NULL, &err),
                     HZ_OK);
    for (uint32_t j = 1; j < 1200; j += 37)
        for (uint32_t i = 1; i < 1200; i += 41)
            assert_float_equal(g.z[(size_t)j * g.width + 3 * 1200 + i], one.z[(size_t)j * 1201 + i], 0.0f);
    hz_grid_free(&one);
    hz_grid_free(&g);
    hz_georef_destroy(geo);
}

/* Counts progress steps that did work (done > 0) on the samples. */
static void count_work(void *user, const char *label, uint64_t done, uint64_t total)
{
    (void)total;
    if (done > 0 && (!strcmp(label, "reproject") || !strcmp(label, "read")))
        ++*(uint64_t *)user;
}

/* A DEM larger than the GPU takes in memory: the refusal names the
 * --spacing that fits a georeferenced one (and --fit crop for another), and
 * loading with that advice works and fits. */
void test_gpu_limit_advice(void **state)
{
    (void)state;
    const int w = 300, h = 200;
    float *v = make_surface(w, h);
    const double gt[6] = {465000, 10, 0, 5480000, 0, -10};
    write_raster("GTiff", tmp("big_utm.tif"), v, w, h, gt, "EPSG:32632", NULL, GDT_Float32, NULL);
    const uint64_t limit = 257 * 257; /* a 300-wide DEM pads to 513 */
    hz_err err = {0};
    hz_terrain_desc d = {.dem_path = tmp("big_utm.tif"), .max_samples = limit, .max_memory = (uint64_t)1 << 32};
    assert_null(hz_terrain_create(&d, &err));
    assert_int_equal(err.code, HZ_ERR_UNSUPPORTED);
    const char *adv = strstr(err.msg, "--spacing ");
    if (!adv)
        fail_msg("no --spacing advice in: %s", err.msg);
    const float s = strtof(adv + 10, NULL);
    /* 299 cells of 10 m in 256: 11.68 m, rounded up to 0.1 m */
    assert_float_equal(s, 11.7f, 1e-4f);
    d.spacing = s;
    hz_terrain *t = hz_terrain_create(&d, &err);
    if (!t)
        fail_msg("%s", err.msg);
    assert_int_equal(t->hm.size, 257);
    assert_true(t->data_w > 250); /* resampled, not cropped: all 3 km are there */
    hz_terrain_destroy(t);

    /* Without a georeference the spacing resamples nothing: crop it. */
    uint16_t *p = calloc((size_t)w * h, sizeof *p);
    assert_non_null(p);
    assert_true(fx_write_png(tmp("big.png"), (uint32_t)w, (uint32_t)h, 16, PNG_COLOR_TYPE_GRAY, false, p));
    free(p);
    hz_terrain_desc pd = {.dem_path = tmp("big.png"), .max_samples = limit, .max_memory = (uint64_t)1 << 32};
    assert_null(hz_terrain_create(&pd, &err));
    assert_int_equal(err.code, HZ_ERR_UNSUPPORTED);
    assert_non_null(strstr(err.msg, "keep its centred 129x129 square with --fit crop"));
    assert_null(strstr(err.msg, "--spacing"));
    pd.fit = HZ_FIT_CROP;
    t = hz_terrain_create(&pd, &err);
    if (!t)
        fail_msg("%s", err.msg);
    assert_int_equal(t->hm.size, 129);
    hz_terrain_destroy(t);

    /* A geographic DEM is refused before a sample is reprojected or read:
     * the refusal costs no work. */
    const double geo_gt[6] = {8.0, 0.0001, 0, 49.5, 0, -0.0001};
    write_raster("GTiff", tmp("big_geo.tif"), v, w, h, geo_gt, "EPSG:4326", NULL, GDT_Float32, NULL);
    uint64_t steps = 0;
    hz_terrain_desc gd = {.dem_path = tmp("big_geo.tif"), .max_samples = limit, .max_memory = (uint64_t)1 << 32,
                          .progress = count_work, .progress_user = &steps};
    assert_null(hz_terrain_create(&gd, &err));
    assert_int_equal(err.code, HZ_ERR_UNSUPPORTED);
    assert_non_null(strstr(err.msg, "--spacing "));
    assert_int_equal(steps, 0);
    /* and with room, the same file is reprojected with progress */
    gd.max_samples = 0;
    t = hz_terrain_create(&gd, &err);
    if (!t)
        fail_msg("%s", err.msg);
    assert_true(steps > 0);
    hz_terrain_destroy(t);
    free(v);
}
