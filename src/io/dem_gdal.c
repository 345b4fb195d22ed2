/* DEMs through GDAL: any raster GDAL reads, several of them mosaicked
 * (GDALBuildVRT, in memory), nodata to NaN, band scale/offset, and the
 * reprojection of geographic (or rotated, or non-square) grids to a metric
 * CRS with square cells (GDALWarp). The georeference goes to hz_georef. */
#include "io_internal.h"
#include "gdal_util.h"

#include "horizon/safety.h"

#include <cpl_conv.h>
#include <cpl_error.h>
#include <cpl_string.h>
#include <cpl_vsi.h>
#include <gdal.h>
#include <gdal_utils.h>
#include <math.h>
#include <ogr_srs_api.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* Folders with more rasters than this are refused (a typo'd root folder). */
#define HZ_GDAL_MAX_FILES 100000u


static bool ends_with(const char *s, const char *suffix)
{
    size_t n = strlen(s), k = strlen(suffix);
    if (k > n)
        return false;
    for (size_t i = 0; i < k; i++) {
        char a = s[n - k + i], b = suffix[i];
        if (a >= 'A' && a <= 'Z')
            a = (char)(a - 'A' + 'a');
        if (a != b)
            return false;
    }
    return true;
}

static bool is_dir(const char *path)
{
    struct stat st;
    return path && stat(path, &st) == 0 && S_ISDIR(st.st_mode);
}

/* The name GDAL opens for path: compressed single files through /vsigzip/
 * (SRTM .hgt.zip opens directly; other .zip through /vsizip/). */
static void gdal_name(const char *path, char *out, size_t cap)
{
    if (ends_with(path, ".gz") && strncmp(path, "/vsi", 4))
        snprintf(out, cap, "/vsigzip/%s", path);
    else if (ends_with(path, ".zip") && !ends_with(path, ".hgt.zip") && strncmp(path, "/vsi", 4))
        snprintf(out, cap, "/vsizip/%s", path);
    else
        snprintf(out, cap, "%s", path);
}

/* The GDAL drivers allowed to open name, or NULL for any. A name that says
 * SRTM (.hgt, .hgt.gz, .hgt.zip) is read as SRTM or refused: a tile whose
 * bytes look like another format (netCDF, HDF) must not reach that driver. */
static const char *const *drivers_for(const char *name)
{
    static const char *const srtm[] = {"SRTMHGT", NULL};
    if (ends_with(name, ".hgt") || ends_with(name, ".hgt.gz") || ends_with(name, ".hgt.zip"))
        return srtm;
    return NULL;
}

/* Opens name (band 1 is what a DEM reads), or NULL with err set. */
static GDALDatasetH open_raster(const char *name, hz_err *err)
{
    GDALDatasetH ds = GDALOpenEx(name, GDAL_OF_RASTER | GDAL_OF_READONLY, drivers_for(name), NULL, NULL);
    if (!ds) {
        hz_err_set(err, HZ_ERR_FORMAT, "'%s': %s", name, hz_io_gdal_msg("GDAL cannot read it"));
        return NULL;
    }
    char label[4200];
    snprintf(label, sizeof label, "'%s'", name);
    if (hz_io_gdal_blocks_ok(ds, 1, label, err) != HZ_OK) {
        GDALClose(ds);
        return NULL;
    }
    return ds;
}

static bool identifies(const char *path)
{
    char name[4096];
    gdal_name(path, name, sizeof name);
    CPLPushErrorHandler(CPLQuietErrorHandler);
    GDALDriverH drv = GDALIdentifyDriverEx(name, GDAL_OF_RASTER, drivers_for(name), NULL);
    CPLPopErrorHandler();
    if (!drv)
        return false;
    /* The PNG driver would claim our heightmap PNGs: those stay on libpng.
     * NOTE: GDAL before 3.10.1 (Debian 12 has 3.6.2) decodes 16-bit
     * interlaced PNGs wrongly on little-endian machines (OSGeo/gdal#11553);
     * our round-trip test caught it when PNGs went through GDAL. */
    const char *d = GDALGetDriverShortName(drv);
    return d && strcmp(d, "PNG") != 0;
}

bool hz_io_gdal_wants(const char *path)
{
    if (!path)
        return false;
    hz_io_gdal_setup();
    if (is_dir(path))
        return true;
    /* Raw layouts without a header are ours; gzip only for SRTM tiles. */
    if (ends_with(path, ".png") || ends_with(path, ".png.gz") || ends_with(path, ".r16") ||
        ends_with(path, ".r32") || ends_with(path, ".raw") || ends_with(path, ".r16.gz") ||
        ends_with(path, ".r32.gz") || ends_with(path, ".raw.gz"))
        return false;
    if (ends_with(path, ".gz") && !ends_with(path, ".hgt.gz"))
        return false;
    return identifies(path);
}

/* ---- inputs: files and folders ---- */

typedef struct name_list {
    char **v;
    uint32_t n, cap;
} name_list;

static void list_free(name_list *l)
{
    for (uint32_t k = 0; k < l->n; k++)
        free(l->v[k]);
    free(l->v);
    l->v = NULL;
    l->n = l->cap = 0;
}

static bool list_add(name_list *l, const char *s)
{
    if (l->n == l->cap) {
        uint32_t nc = l->cap ? l->cap * 2 : 16;
        char **nv = realloc(l->v, nc * sizeof *nv);
        if (!nv)
            return false;
        l->v = nv;
        l->cap = nc;
    }
    size_t n = strlen(s) + 1;
    l->v[l->n] = malloc(n);
    if (!l->v[l->n])
        return false;
    memcpy(l->v[l->n], s, n);
    l->n++;
    return true;
}

static int cmp_str(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

static hz_result add_input(name_list *l, const char *path, hz_err *err)
{
    if (!is_dir(path)) {
        struct stat st;
        if (strncmp(path, "/vsi", 4) && stat(path, &st) != 0)
            return hz_err_set(err, HZ_ERR_IO, "cannot open '%s': no such file or folder", path);
        char name[4096];
        gdal_name(path, name, sizeof name);
        return list_add(l, name) ? HZ_OK : hz_err_set(err, HZ_ERR_MEMORY, "out of memory listing inputs");
    }
    char **entries = VSIReadDir(path);
    uint32_t before = l->n;
    for (char **e = entries; e && *e; e++) {
        if ((*e)[0] == '.')
            continue;
        size_t n = strlen(path) + strlen(*e) + 2;
        char *full = malloc(n);
        if (!full) {
            CSLDestroy(entries);
            return hz_err_set(err, HZ_ERR_MEMORY, "out of memory listing '%s'", path);
        }
        snprintf(full, n, "%s%s%s", path, ends_with(path, "/") ? "" : "/", *e);
        struct stat st;
        bool take = stat(full, &st) == 0 && S_ISREG(st.st_mode) && !ends_with(full, ".aux.xml") &&
                    !ends_with(full, ".hdr") && !ends_with(full, ".md") && !ends_with(full, ".txt") &&
                    !ends_with(full, ".prj") && !ends_with(full, ".ovr") && identifies(full);
        if (take) {
            char name[4096];
            gdal_name(full, name, sizeof name);
            if (l->n - before >= HZ_GDAL_MAX_FILES || !list_add(l, name)) {
                free(full);
                CSLDestroy(entries);
                return hz_err_set(err, HZ_ERR_VALUE, "'%s': too many rasters (or out of memory)", path);
            }
        }
        free(full);
    }
    CSLDestroy(entries);
    if (l->n == before)
        return hz_err_set(err, HZ_ERR_FORMAT, "folder '%s' holds no raster GDAL can read", path);
    qsort(l->v + before, l->n - before, sizeof *l->v, cmp_str);
    return HZ_OK;
}

/* ---- progress ---- */

static int CPL_STDCALL gdal_progress(double done, const char *msg, void *user)
{
    (void)msg;
    hz_io_progress *p = user;
    hz_io_progress_step(p, (uint64_t)(done * 1000.0));
    return TRUE;
}

/* ---- opening ---- */

static GDALDatasetH open_inputs(const name_list *l, hz_err *err)
{
    if (l->n == 1)
        return open_raster(l->v[0], err);
    /* Every input must open on its own first: a clear message naming the
     * broken file instead of a hole in the mosaic. */
    for (uint32_t k = 0; k < l->n; k++) {
        GDALDatasetH ds = open_raster(l->v[k], err);
        if (!ds)
            return NULL;
        GDALClose(ds);
    }
    char *argv[] = {"-resolution", "highest", NULL};
    GDALBuildVRTOptions *o = GDALBuildVRTOptionsNew(argv, NULL);
    int usage = 0;
    GDALDatasetH vrt = o ? GDALBuildVRT("", (int)l->n, NULL, (const char *const *)l->v, o, &usage) : NULL;
    GDALBuildVRTOptionsFree(o);
    if (!vrt)
        hz_err_set(err, HZ_ERR_FORMAT, "cannot mosaic %u inputs (%s ...): %s", l->n, l->v[0],
                   hz_io_gdal_msg("GDALBuildVRT failed"));
    return vrt;
}

/* The raster's georeference; NULL without a CRS or a geotransform. A CRS
 * with a geotransform that cannot place a pixel (zero pixel size, a
 * singular matrix) is a broken file: NULL, *bad set and err says so, so
 * that it is not read as an ungeoreferenced grid at the default spacing. */
static hz_georef *georef_of(GDALDatasetH ds, const char *label, hz_result *bad, hz_err *err)
{
    *bad = HZ_OK;
    double gt[6];
    OGRSpatialReferenceH srs = GDALGetSpatialRef(ds);
    if (!srs || GDALGetGeoTransform(ds, gt) != CE_None)
        return NULL;
    char *wkt = NULL;
    const char *opts[] = {"FORMAT=WKT2_2019", NULL};
    if (OSRExportToWktEx(srs, &wkt, opts) != OGRERR_NONE || !wkt) {
        CPLFree(wkt);
        return NULL;
    }
    hz_err why = {0};
    hz_georef *g = hz_georef_create(wkt, gt, (uint32_t)GDALGetRasterXSize(ds), (uint32_t)GDALGetRasterYSize(ds), &why);
    CPLFree(wkt);
    const char *pre = "georeference: ";
    if (!g && why.code != HZ_ERR_MEMORY)
        *bad = hz_err_set(err, HZ_ERR_FORMAT, "'%s' has a CRS but cannot be placed by it: %s", label,
                          strncmp(why.msg, pre, strlen(pre)) ? why.msg : why.msg + strlen(pre));
    else if (!g)
        *bad = hz_err_set(err, HZ_ERR_MEMORY, "%s", why.msg);
    return g;
}

/* The target CRS of a reprojection as WKT in *out (CPLFree), or an error. */
static hz_result target_crs(const hz_dem_desc *d, const hz_georef *src, char **out, hz_err *err)
{
    OGRSpatialReferenceH t = OSRNewSpatialReference(NULL);
    if (!t)
        return hz_err_set(err, HZ_ERR_MEMORY, "out of memory");
    hz_result r = HZ_OK;
    if (d->crs) {
        if (OSRSetFromUserInput(t, d->crs) != OGRERR_NONE)
            r = hz_err_set(err, HZ_ERR_VALUE, "--crs '%s': unknown CRS (%s)", d->crs, hz_io_gdal_msg("PROJ does not know it"));
        else if (!OSRIsProjected(t))
            r = hz_err_set(err, HZ_ERR_VALUE,
                           "--crs '%s' is not a projected CRS: the terrain needs metres (e.g. a UTM zone, EPSG:326zz)",
                           d->crs);
    } else {
        uint32_t w, h;
        hz_georef_size(src, &w, &h);
        /* The zone of the grid's centre. */
        double lon, lat, sx, sy;
        hz_georef_spacing(src, &sx, &sy);
        if (hz_georef_local_to_lonlat(src, 0.5 * (double)(w - 1) * sx, 0.5 * (double)(h - 1) * sy, &lon, &lat,
                                      err) != HZ_OK) {
            OSRDestroySpatialReference(t);
            return HZ_ERR_VALUE;
        }
        int epsg = hz_georef_utm_epsg(lon, lat);
        if (!epsg)
            r = hz_err_set(err, HZ_ERR_VALUE, "the raster's centre (lon %g, lat %g) is not on the Earth: no UTM zone",
                           lon, lat);
        else if (OSRImportFromEPSG(t, epsg) != OGRERR_NONE)
            r = hz_err_set(err, HZ_ERR_VALUE, "cannot set up EPSG:%d (%s)", epsg, hz_io_gdal_msg("PROJ database?"));
    }
    if (r == HZ_OK && OSRExportToWkt(t, out) != OGRERR_NONE)
        r = hz_err_set(err, HZ_ERR_VALUE, "cannot export the target CRS");
    OSRDestroySpatialReference(t);
    return r;
}

static bool needs_warp(const hz_dem_desc *d, GDALDatasetH ds, const hz_georef *g)
{
    if (!d->metric || !g)
        return false;
    if (d->crs) {
        OGRSpatialReferenceH t = OSRNewSpatialReference(NULL);
        bool same = t && OSRSetFromUserInput(t, d->crs) == OGRERR_NONE && OSRIsSame(t, GDALGetSpatialRef(ds));
        if (t)
            OSRDestroySpatialReference(t);
        if (!same)
            return true;
    }
    if (hz_georef_is_geographic(g))
        return true;
    double gt[6], sx, sy;
    hz_georef_geotransform(g, gt);
    hz_georef_spacing(g, &sx, &sy);
    if (gt[2] != 0.0 || gt[4] != 0.0 || gt[5] > 0.0 || gt[1] < 0.0)
        return true; /* rotated or not north-up */
    if (d->spacing > 0 && fabs(d->spacing - sx) > 1e-9 * sx)
        return true; /* asked for another spacing */
    return fabs(sx - sy) > 1e-6 * (sx > sy ? sx : sy);
}

static GDALDatasetH warp(const hz_dem_desc *d, GDALDatasetH src, const hz_georef *g, double *spacing, hz_io_progress *prog,
                         const char *format, hz_err *err)
{
    char *wkt = NULL;
    if (target_crs(d, g, &wkt, err) != HZ_OK)
        return NULL;
    OGRSpatialReferenceH t = OSRNewSpatialReference(wkt);
    double lu = t ? OSRGetLinearUnits(t, NULL) : 1.0;
    if (t)
        OSRDestroySpatialReference(t);
    if (!(lu > 0))
        lu = 1.0;
    double sx, sy;
    hz_georef_spacing(g, &sx, &sy);
    double s = d->spacing > 0 ? d->spacing : (sx < sy ? sx : sy);
    *spacing = s;
    /* Refuse before GDALWarp allocates it: the output is at least the input's
     * extent at that spacing. */
    uint32_t w, h;
    hz_georef_size(g, &w, &h);
    double ow = (double)w * sx / s, oh = (double)h * sy / s;
    char what[96];
    snprintf(what, sizeof what, "the reprojected DEM (about %.0fx%.0f samples)", ow, oh);
    if (!strcmp(format, "MEM") && ow <= HZ_IO_MAX_SIDE && oh <= HZ_IO_MAX_SIDE &&
        hz_mem_check((uint64_t)(ow + 2) * (uint64_t)(oh + 2) * sizeof(float), d->max_memory, what, err) != HZ_OK) {
        CPLFree(wkt);
        return NULL;
    }
    if (ow > HZ_IO_MAX_SIDE || oh > HZ_IO_MAX_SIDE) {
        CPLFree(wkt);
        hz_err_set(err, HZ_ERR_VALUE,
                   "reprojected at %g m per sample the DEM would be about %.0fx%.0f samples; sides must be at "
                   "most %u (pass a coarser --spacing)",
                   s, ow, oh, HZ_IO_MAX_SIDE);
        return NULL;
    }
    char tr[64];
    snprintf(tr, sizeof tr, "%.17g", s / lu);
    char *argv[] = {"-of", (char *)format, "-t_srs", wkt, "-tr", tr, tr, "-r", "bilinear", "-ot", "Float32",
                    "-dstnodata", "nan", "-wm", "256", NULL};
    GDALWarpAppOptions *o = GDALWarpAppOptionsNew(argv, NULL);
    if (!o) {
        CPLFree(wkt);
        hz_err_set(err, HZ_ERR_VALUE, "GDALWarp options: %s", hz_io_gdal_msg("invalid"));
        return NULL;
    }
    prog->label = "reproject";
    prog->total = 1000;
    prog->last_pct = -1;
    if (prog->fn && strcmp(format, "VRT") != 0) /* a virtual warp does no work yet */
        GDALWarpAppOptionsSetProgress(o, gdal_progress, prog);
    int usage = 0;
    GDALDatasetH out = GDALWarp("", NULL, 1, &src, o, &usage);
    GDALWarpAppOptionsFree(o);
    CPLFree(wkt);
    if (!out)
        hz_err_set(err, HZ_ERR_FORMAT, "reprojection failed: %s", hz_io_gdal_msg("GDALWarp failed"));
    return out;
}

/* Reads band 1 into g with nodata as NaN and scale/offset applied. */
static hz_result read_band(GDALDatasetH ds, const char *label, hz_grid *g, uint64_t *voids, hz_io_progress *prog,
                           uint64_t budget, hz_err *err)
{
    int w = GDALGetRasterXSize(ds), h = GDALGetRasterYSize(ds);
    if (GDALGetRasterCount(ds) < 1)
        return hz_err_set(err, HZ_ERR_FORMAT, "'%s' has no raster band", label);
    if (w < 2 || h < 2 || (uint32_t)w > HZ_IO_MAX_SIDE || (uint32_t)h > HZ_IO_MAX_SIDE)
        return hz_err_set(err, HZ_ERR_VALUE,
                          "'%s' is %dx%d samples; sides must be 2..%u (pass a coarser --spacing)", label, w, h,
                          HZ_IO_MAX_SIDE);
    /* The size is the file's word (a 46-byte header may claim 12288 x 65293):
     * within the memory budget before allocating. */
    char what[600];
    snprintf(what, sizeof what, "'%s' (%dx%d samples)", label, w, h);
    hz_result r = hz_mem_check((uint64_t)w * (uint64_t)h * sizeof(float), budget, what, err);
    if (r != HZ_OK)
        return r;
    r = hz_grid_alloc(g, (uint32_t)w, (uint32_t)h, err);
    if (r != HZ_OK)
        return r;
    GDALRasterBandH b = GDALGetRasterBand(ds, 1);
    int has_nd = 0, has_scale = 0, has_off = 0;
    double nd = GDALGetRasterNoDataValue(b, &has_nd);
    double scale = GDALGetRasterScale(b, &has_scale), off = GDALGetRasterOffset(b, &has_off);
    if (!has_scale || scale == 0.0)
        scale = 1.0;
    if (!has_off)
        off = 0.0;
    float ndf = (float)nd;
    bool nd_nan = has_nd && isnan(nd);
    prog->label = "read";
    prog->total = (uint64_t)h;
    prog->last_pct = -1;
    uint64_t nv = 0;
    const int rows = 256;
    for (int y = 0; y < h; y += rows) {
        int n = h - y < rows ? h - y : rows;
        float *dst = g->z + (size_t)y * (size_t)w;
        if (GDALRasterIO(b, GF_Read, 0, y, w, n, dst, w, n, GDT_Float32, 0, 0) != CE_None) {
            hz_grid_free(g);
            return hz_err_set(err, HZ_ERR_FORMAT, "'%s': cannot read rows %d..%d: %s", label, y, y + n - 1,
                              hz_io_gdal_msg("corrupt or truncated"));
        }
        for (size_t k = 0; k < (size_t)n * (size_t)w; k++) {
            float v = dst[k];
            if (isnan(v) || (has_nd && !nd_nan && v == ndf)) {
                dst[k] = NAN;
                nv++;
            } else if (has_scale || has_off) {
                dst[k] = (float)((double)v * scale + off);
            }
        }
        hz_io_progress_step(prog, (uint64_t)(y + n));
    }
    *voids = nv;
    return HZ_OK;
}

static uint64_t count_nodata(GDALDatasetH ds, bool *ok)
{
    int w = GDALGetRasterXSize(ds), h = GDALGetRasterYSize(ds);
    GDALRasterBandH b = GDALGetRasterBand(ds, 1);
    int has_nd = 0;
    double nd = GDALGetRasterNoDataValue(b, &has_nd);
    float *row = malloc((size_t)w * sizeof *row);
    uint64_t n = 0;
    *ok = row != NULL;
    for (int y = 0; y < h && *ok; y++) {
        if (GDALRasterIO(b, GF_Read, 0, y, w, 1, row, w, 1, GDT_Float32, 0, 0) != CE_None) {
            *ok = false;
            break;
        }
        for (int x = 0; x < w; x++)
            if (isnan(row[x]) || (has_nd && row[x] == (float)nd))
                n++;
    }
    free(row);
    return n;
}

hz_result hz_io_gdal_load(const hz_dem_desc *d, hz_grid *out, hz_dem_info *info, char *units, size_t units_cap,
                          hz_err *err)
{
    hz_io_gdal_setup();
    out->z = NULL;
    out->width = out->height = 0;
    units[0] = 0;
    name_list inputs = {0};
    hz_result r = HZ_OK;
    GDALDatasetH src = NULL, warped = NULL;
    hz_georef *g = NULL;
    CPLPushErrorHandler(CPLQuietErrorHandler);
    CPLErrorReset();
    if (d->path_count > 0) {
        for (uint32_t k = 0; k < d->path_count && r == HZ_OK; k++)
            r = add_input(&inputs, d->paths[k], err);
    } else {
        r = add_input(&inputs, d->path, err);
    }
    if (r != HZ_OK)
        goto done;
    src = open_inputs(&inputs, err);
    if (!src) {
        r = err && err->code ? err->code : HZ_ERR_FORMAT;
        goto done;
    }
    const char *label = inputs.n == 1 ? inputs.v[0] : "mosaic";
    g = georef_of(src, label, &r, err);
    if (r != HZ_OK)
        goto done;
    info->files = inputs.n;
    info->file_width = (uint32_t)GDALGetRasterXSize(src);
    info->file_height = (uint32_t)GDALGetRasterYSize(src);
    GDALDriverH drv = GDALGetDatasetDriver(src);
    snprintf(info->driver, sizeof info->driver, "%s", drv ? GDALGetDriverShortName(drv) : "?");
    if (g)
        hz_georef_spacing(g, &info->file_spacing_x, &info->file_spacing_y);
    if (GDALGetRasterCount(src) >= 1) {
        const char *u = GDALGetRasterUnitType(GDALGetRasterBand(src, 1));
        snprintf(units, units_cap, "%s", u ? u : "");
        switch (GDALGetRasterDataType(GDALGetRasterBand(src, 1))) {
        case GDT_Byte: info->full_scale = 255.0; break;
        case GDT_UInt16: info->full_scale = 65535.0; break;
        case GDT_Int16: info->full_scale = 32767.0; break;
        case GDT_UInt32: info->full_scale = 4294967295.0; break;
        case GDT_Int32: info->full_scale = 2147483647.0; break;
        default: info->full_scale = 1.0; break; /* floats */
        }
    }
    hz_io_progress prog = {d->progress, d->progress_user, "read", 0, -1};
    if (needs_warp(d, src, g)) {
        double s = 0;
        bool ok = true;
        info->file_voids = count_nodata(src, &ok);
        if (!ok) {
            r = hz_err_set(err, HZ_ERR_FORMAT, "'%s': cannot read: %s", label, hz_io_gdal_msg("corrupt or truncated"));
            goto done;
        }
        if (d->size_check) {
            /* A virtual warp has the real warp's exact size at no cost. */
            GDALDatasetH v = warp(d, src, g, &s, &prog, "VRT", err);
            if (!v) {
                r = err && err->code ? err->code : HZ_ERR_FORMAT;
                goto done;
            }
            r = d->size_check(d->size_check_user, (uint32_t)GDALGetRasterXSize(v), (uint32_t)GDALGetRasterYSize(v), s,
                              true, err);
            GDALClose(v);
            if (r != HZ_OK)
                goto done;
        }
        warped = warp(d, src, g, &s, &prog, "MEM", err);
        if (!warped) {
            r = err && err->code ? err->code : HZ_ERR_FORMAT;
            goto done;
        }
        hz_georef_destroy(g);
        g = georef_of(warped, label, &r, err);
        if (r != HZ_OK)
            goto done;
        info->reprojected = true;
        r = read_band(warped, label, out, &info->voids, &prog, d->max_memory, err);
    } else {
        if (d->size_check) {
            double sx = 0, sy = 0;
            if (g)
                hz_georef_spacing(g, &sx, &sy);
            r = d->size_check(d->size_check_user, info->file_width, info->file_height, sx < sy ? sx : sy, g != NULL,
                              err);
            if (r != HZ_OK)
                goto done;
        }
        r = read_band(src, label, out, &info->voids, &prog, d->max_memory, err);
        info->file_voids = info->voids;
    }
    if (r != HZ_OK)
        goto done;
    if (g) {
        double sx, sy;
        hz_georef_spacing(g, &sx, &sy);
        info->spacing_hint = (float)(sx < sy ? sx : sy);
    }
    if (d->georef) {
        *d->georef = g;
        g = NULL;
    }
done:
    CPLPopErrorHandler();
    if (warped)
        GDALClose(warped);
    if (src)
        GDALClose(src);
    hz_georef_destroy(g);
    list_free(&inputs);
    return r;
}

/* ---- windowed sources (pyramid import): never the whole raster ---- */

struct hz_io_src {
    GDALDatasetH src, warped; /* warped: a VRT that reprojects on read */
    GDALRasterBandH band;
    hz_georef *g;
    uint32_t w, h;
    bool has_nd, nd_nan, has_scale;
    double nd, scale, off;
    GDALDataType type;
    char label[256];
};

hz_result hz_io_src_open(const hz_dem_desc *d, hz_io_src **out, hz_err *err)
{
    hz_io_gdal_setup();
    /* Windows are read once each: GDAL's block cache need not grow to its
     * default (5 % of RAM) and would only raise the import's footprint. */
    if (GDALGetCacheMax64() > ((GIntBig)128 << 20))
        GDALSetCacheMax64((GIntBig)128 << 20);
    *out = NULL;
    hz_io_src *s = calloc(1, sizeof *s);
    name_list inputs = {0};
    if (!s)
        return hz_err_set(err, HZ_ERR_MEMORY, "out of memory");
    hz_result r = HZ_OK;
    CPLPushErrorHandler(CPLQuietErrorHandler);
    CPLErrorReset();
    if (d->path_count > 0) {
        for (uint32_t k = 0; k < d->path_count && r == HZ_OK; k++)
            r = add_input(&inputs, d->paths[k], err);
    } else {
        r = add_input(&inputs, d->path, err);
    }
    if (r == HZ_OK) {
        s->src = open_inputs(&inputs, err);
        if (!s->src)
            r = HZ_ERR_FORMAT;
    }
    if (r == HZ_OK) {
        snprintf(s->label, sizeof s->label, "%s", inputs.n == 1 ? inputs.v[0] : "mosaic");
        s->g = georef_of(s->src, s->label, &r, err);
        if (r == HZ_OK && GDALGetRasterCount(s->src) < 1)
            r = hz_err_set(err, HZ_ERR_FORMAT, "'%s' has no raster band", s->label);
    }
    if (r == HZ_OK && needs_warp(d, s->src, s->g)) {
        double sp = 0;
        hz_io_progress prog = {0};
        s->warped = warp(d, s->src, s->g, &sp, &prog, "VRT", err);
        if (!s->warped) {
            r = err && err->code ? err->code : HZ_ERR_FORMAT;
        } else {
            hz_georef_destroy(s->g);
            s->g = georef_of(s->warped, s->label, &r, err);
        }
    }
    if (r == HZ_OK) {
        GDALDatasetH ds = s->warped ? s->warped : s->src;
        s->w = (uint32_t)GDALGetRasterXSize(ds);
        s->h = (uint32_t)GDALGetRasterYSize(ds);
        s->band = GDALGetRasterBand(ds, 1);
        int has_nd = 0, has_scale = 0, has_off = 0;
        s->nd = GDALGetRasterNoDataValue(s->band, &has_nd);
        s->has_nd = has_nd != 0;
        s->nd_nan = has_nd && isnan(s->nd);
        s->scale = GDALGetRasterScale(s->band, &has_scale);
        s->off = GDALGetRasterOffset(s->band, &has_off);
        if (!has_scale || s->scale == 0.0)
            s->scale = 1.0;
        if (!has_off)
            s->off = 0.0;
        s->has_scale = has_scale || has_off;
        s->type = GDALGetRasterDataType(GDALGetRasterBand(s->src, 1));
        if (s->w < 2 || s->h < 2)
            r = hz_err_set(err, HZ_ERR_VALUE, "'%s' is %ux%u samples; it needs at least 2x2", s->label, s->w, s->h);
    }
    CPLPopErrorHandler();
    list_free(&inputs);
    if (r != HZ_OK) {
        hz_io_src_close(s);
        return r;
    }
    *out = s;
    return HZ_OK;
}

void hz_io_src_close(hz_io_src *s)
{
    if (!s)
        return;
    if (s->warped)
        GDALClose(s->warped);
    if (s->src)
        GDALClose(s->src);
    hz_georef_destroy(s->g);
    free(s);
}

void hz_io_src_size(const hz_io_src *s, uint32_t *w, uint32_t *h)
{
    *w = s->w;
    *h = s->h;
}

const hz_georef *hz_io_src_georef(const hz_io_src *s)
{
    return s->g;
}

bool hz_io_src_integer16(const hz_io_src *s, double *offset)
{
    *offset = s->type == GDT_Int16 ? -32768.0 : 0.0;
    return !s->has_scale && !s->warped && (s->type == GDT_Int16 || s->type == GDT_UInt16 || s->type == GDT_Byte);
}

hz_result hz_io_src_read(hz_io_src *s, uint32_t x0, uint32_t y0, uint32_t w, uint32_t h, float *out, hz_err *err)
{
    if (x0 >= s->w || y0 >= s->h || w > s->w - x0 || h > s->h - y0)
        return hz_err_set(err, HZ_ERR_VALUE, "'%s': window %u,%u %ux%u outside the %ux%u raster", s->label, x0, y0, w,
                          h, s->w, s->h);
    CPLPushErrorHandler(CPLQuietErrorHandler);
    CPLErr e = GDALRasterIO(s->band, GF_Read, (int)x0, (int)y0, (int)w, (int)h, out, (int)w, (int)h, GDT_Float32, 0, 0);
    CPLPopErrorHandler();
    if (e != CE_None)
        return hz_err_set(err, HZ_ERR_FORMAT, "'%s': cannot read rows %u..%u: %s", s->label, y0, y0 + h - 1,
                          hz_io_gdal_msg("corrupt or truncated"));
    const float ndf = (float)s->nd;
    for (size_t k = 0; k < (size_t)w * h; k++) {
        float v = out[k];
        if (isnan(v) || (s->has_nd && !s->nd_nan && v == ndf))
            out[k] = NAN;
        else if (s->has_scale)
            out[k] = (float)((double)v * s->scale + s->off);
    }
    return HZ_OK;
}

hz_result hz_io_src_range(hz_io_src *s, double *lo, double *hi, hz_err *err)
{
    double mm[2] = {0, 0};
    CPLPushErrorHandler(CPLQuietErrorHandler);
    CPLErr e = GDALComputeRasterMinMax(s->band, FALSE, mm);
    CPLPopErrorHandler();
    if (e != CE_None || !isfinite(mm[0]) || !isfinite(mm[1]))
        return hz_err_set(err, HZ_ERR_FORMAT, "'%s': cannot compute its height range: %s", s->label,
                          hz_io_gdal_msg("no sample with data?"));
    *lo = mm[0] * s->scale + s->off;
    *hi = mm[1] * s->scale + s->off;
    if (*lo > *hi) {
        double t = *lo;
        *lo = *hi;
        *hi = t;
    }
    return HZ_OK;
}
