/* Imagery draped by its georeference: GDAL warps the image (any CRS PROJ
 * knows, a geotransform, a world file or GCPs) onto the terrain's footprint
 * in the terrain's CRS; the warped VRT is read tile by tile, so memory is the
 * output, never the source. See horizon/imagery.h. */
#include "horizon/imagery.h"
#include "gdal_util.h"

#include <cpl_conv.h>
#include <cpl_error.h>
#include <gdal.h>
#include <gdal_utils.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#define DEFAULT_SIDE 8192u
#define SINGLE_MAX 4096u /* up to this side the overview alone holds the image */
#define MIN_SIDE 64u

uint64_t hz_imagery_bytes(uint32_t side)
{
    if (side <= SINGLE_MAX)
        return (uint64_t)side * side * 4u * 4u / 3u;
    const uint64_t n = (side + HZ_IMAGERY_TILE - 1) / HZ_IMAGERY_TILE, l = HZ_IMAGERY_TILE + 2 * HZ_IMAGERY_BORDER;
    const uint64_t ov = side / 4u;
    /* levels 0..2 of each tile: 1 + 1/4 + 1/16 */
    return n * n * l * l * 4u * 21u / 16u + ov * ov * 4u * 4u / 3u;
}

void hz_imagery_world_to_texel(const hz_imagery *im, double x, double z, double *tx, double *ty)
{
    const double k = (double)im->side / im->extent;
    *tx = (x - im->origin_x) * k - 0.5;
    *ty = (z - im->origin_z) * k - 0.5;
}

void hz_imagery_texel_to_world(const hz_imagery *im, double tx, double ty, double *x, double *z)
{
    const double k = im->extent / (double)im->side;
    *x = im->origin_x + (tx + 0.5) * k;
    *z = im->origin_z + (ty + 0.5) * k;
}

void hz_imagery_free(hz_imagery *im)
{
    if (!im)
        return;
    free(im->tile_rgba);
    free(im->overview_rgba);
    memset(im, 0, sizeof *im);
}

/* GDALWarp into a VRT (nothing is read until RasterIO). args end with NULL. */
static GDALDatasetH warp_vrt(GDALDatasetH src, char **args, hz_err *err)
{
    GDALWarpAppOptions *o = GDALWarpAppOptionsNew(args, NULL);
    if (!o) {
        hz_err_set(err, HZ_ERR_VALUE, "imagery: GDALWarp options: %s", hz_io_gdal_msg("invalid"));
        return NULL;
    }
    int usage = 0;
    GDALDatasetH out = GDALWarp("", NULL, 1, &src, o, &usage);
    GDALWarpAppOptionsFree(o);
    if (!out)
        hz_err_set(err, HZ_ERR_FORMAT, "imagery: reprojection failed: %s", hz_io_gdal_msg("GDALWarp failed"));
    return out;
}

/* A paletted single band as RGBA (a VRT over the source). */
static GDALDatasetH expand_palette(GDALDatasetH src, hz_err *err)
{
    char *args[] = {"-of", "VRT", "-expand", "rgba", NULL};
    GDALTranslateOptions *o = GDALTranslateOptionsNew(args, NULL);
    if (!o) {
        hz_err_set(err, HZ_ERR_VALUE, "imagery: palette expansion: %s", hz_io_gdal_msg("invalid"));
        return NULL;
    }
    int usage = 0;
    GDALDatasetH out = GDALTranslate("", src, o, &usage);
    GDALTranslateOptionsFree(o);
    if (!out)
        hz_err_set(err, HZ_ERR_FORMAT, "imagery: palette expansion failed: %s", hz_io_gdal_msg("GDALTranslate failed"));
    return out;
}

/* Reads the window (x0, y0, n x n) of the warped image into dst (RGBA, n
 * rows of n), replicating the edge where the window leaves the image. */
static hz_result read_window(GDALDatasetH ds, const int bands[4], uint32_t side, int64_t x0, int64_t y0, uint32_t n,
                             uint8_t *dst, uint8_t *tmp, hz_err *err)
{
    const int64_t cx0 = x0 < 0 ? 0 : x0, cy0 = y0 < 0 ? 0 : y0;
    const int64_t cx1 = x0 + n > side ? side : x0 + n, cy1 = y0 + n > side ? side : y0 + n;
    const int w = (int)(cx1 - cx0), h = (int)(cy1 - cy0);
    if (GDALDatasetRasterIO(ds, GF_Read, (int)cx0, (int)cy0, w, h, tmp, w, h, GDT_Byte, 4, (int *)bands, 4,
                            (GSpacing)4 * w, 1) != CE_None)
        return hz_err_set(err, HZ_ERR_IO, "imagery: read failed: %s", hz_io_gdal_msg("RasterIO failed"));
    for (uint32_t j = 0; j < n; j++) {
        int64_t sy = y0 + j < cy0 ? cy0 : (y0 + j >= cy1 ? cy1 - 1 : y0 + j);
        const uint8_t *row = tmp + (size_t)(sy - cy0) * (size_t)w * 4;
        uint8_t *out = dst + (size_t)j * n * 4;
        for (uint32_t i = 0; i < n; i++) {
            int64_t sx = x0 + i < cx0 ? cx0 : (x0 + i >= cx1 ? cx1 - 1 : x0 + i);
            memcpy(out + (size_t)i * 4, row + (size_t)(sx - cx0) * 4, 4);
        }
    }
    return HZ_OK;
}

/* The 4x4 box average (colour weighted by alpha) of a tile's core into its
 * block of the overview. */
static void box4(const uint8_t *tile, uint32_t stride, uint32_t core, uint8_t *ov, uint32_t ov_side)
{
    for (uint32_t j = 0; j < core / 4; j++)
        for (uint32_t i = 0; i < core / 4; i++) {
            uint32_t sum[4] = {0, 0, 0, 0};
            for (uint32_t b = 0; b < 4; b++)
                for (uint32_t a = 0; a < 4; a++) {
                    const uint8_t *p = tile + ((size_t)(4 * j + b) * stride + 4 * i + a) * 4;
                    for (int c = 0; c < 3; c++)
                        sum[c] += (uint32_t)p[c] * p[3];
                    sum[3] += p[3];
                }
            uint8_t *o = ov + ((size_t)j * ov_side + i) * 4;
            for (int c = 0; c < 3; c++)
                o[c] = (uint8_t)(sum[3] ? (sum[c] + sum[3] / 2) / sum[3] : 0);
            o[3] = (uint8_t)((sum[3] + 8) / 16);
        }
}

static bool is_dir(const char *p)
{
    struct stat st;
    return stat(p, &st) == 0 && S_ISDIR(st.st_mode);
}

hz_result hz_imagery_load(const hz_imagery_desc *d, hz_imagery *out, hz_err *err)
{
    HZ_ASSERT(d && out);
    memset(out, 0, sizeof *out);
    if (!d->path || !d->path[0])
        return hz_err_set(err, HZ_ERR_VALUE, "imagery: no file given");
    if (!d->target)
        return hz_err_set(err, HZ_ERR_VALUE,
                          "imagery: the terrain has no georeference, so %s cannot be placed by its own (use a "
                          "georeferenced DEM, or --colormap to stretch an image over the whole map)",
                          d->path);
    if (d->samples < 2 || !(d->spacing > 0) || !isfinite(d->spacing))
        return hz_err_set(err, HZ_ERR_VALUE, "imagery: bad terrain grid (%u samples, spacing %g)", d->samples,
                          d->spacing);
    const uint32_t max_side = d->max_side ? d->max_side : DEFAULT_SIDE;
    if (max_side < MIN_SIDE || max_side > HZ_IMAGERY_MAX_SIDE)
        return hz_err_set(err, HZ_ERR_VALUE, "imagery: the largest side must be in [%u, %u] texels (got %u)",
                          MIN_SIDE, HZ_IMAGERY_MAX_SIDE, max_side);
    struct stat st;
    if (stat(d->path, &st) != 0 && strncmp(d->path, "/vsi", 4) != 0)
        return hz_err_set(err, HZ_ERR_IO, "imagery: cannot open %s: no such file", d->path);
    if (is_dir(d->path))
        return hz_err_set(err, HZ_ERR_VALUE, "imagery: %s is a folder, not an image", d->path);
    double tgt[6];
    hz_georef_geotransform(d->target, tgt);
    if (tgt[2] != 0.0 || tgt[4] != 0.0)
        return hz_err_set(err, HZ_ERR_UNSUPPORTED, "imagery: the terrain's grid is rotated");

    hz_io_gdal_setup();
    CPLErrorReset();
    CPLPushErrorHandler(CPLQuietErrorHandler);
    hz_result res = HZ_OK;
    GDALDatasetH src = GDALOpenEx(d->path, GDAL_OF_RASTER | GDAL_OF_READONLY, NULL, NULL, NULL);
    GDALDatasetH expanded = NULL, probe = NULL, warped = NULL;
    uint8_t *tmp = NULL;
    if (!src) {
        res = hz_err_set(err, HZ_ERR_FORMAT, "imagery: %s is not an image GDAL reads: %s", d->path,
                         hz_io_gdal_msg("unknown format"));
        goto done;
    }
    const int nb = GDALGetRasterCount(src);
    if (nb < 1) {
        res = hz_err_set(err, HZ_ERR_FORMAT, "imagery: %s has no raster band", d->path);
        goto done;
    }
    /* Every band is warped, and the drape uses at most four (grey or RGB,
     * and alpha): a 477-byte TIFF claiming 65 282 bands kept the warp busy
     * for minutes. */
    if (nb > HZ_IMAGERY_MAX_BANDS) {
        res = hz_err_set(err, HZ_ERR_UNSUPPORTED,
                         "imagery: %s has %d bands, more than the %d supported (keep the colour ones with "
                         "gdal_translate -b 1 -b 2 -b 3)",
                         d->path, nb, HZ_IMAGERY_MAX_BANDS);
        goto done;
    }
    for (int b = 1; b <= nb; b++)
        if (GDALGetRasterDataType(GDALGetRasterBand(src, b)) != GDT_Byte) {
            res = hz_err_set(err, HZ_ERR_UNSUPPORTED,
                             "imagery: %s band %d is %s; imagery must be 8-bit (convert with gdal_translate -ot Byte "
                             "-scale)",
                             d->path, b, GDALGetDataTypeName(GDALGetRasterDataType(GDALGetRasterBand(src, b))));
            goto done;
        }
    {
        char label[1100];
        snprintf(label, sizeof label, "imagery: %s", d->path);
        res = hz_io_gdal_blocks_ok(src, nb, label, err);
        if (res != HZ_OK)
            goto done;
    }
    double sgt[6];
    const bool has_gt = GDALGetGeoTransform(src, sgt) == CE_None;
    const bool has_gcps = GDALGetGCPCount(src) > 0;
    if (!has_gt && !has_gcps) {
        res = hz_err_set(err, HZ_ERR_VALUE,
                         "imagery: %s has no georeference (no geotransform, world file or ground control points)",
                         d->path);
        goto done;
    }
    /* A pixel of next to no size (or not a number) makes the warper read a
     * source window of absurd size: GDAL allocated 960 MB for a 345-byte
     * GeoTIFF of 8 x 170 pixels of about 1e-300 units. 1e-9 is 0.1 mm in
     * degrees, a nanometre in metres. A pixel of absurd size means nothing
     * either (the same image with pixels of 1.7e98 units took fuzz_imagery
     * over its 1 GB under ASan); 1e8 units is 2.5 times round the Earth in
     * metres, in feet 0.8 times. */
    if (has_gt) {
        const double px = fabs(sgt[1]) + fabs(sgt[2]), py = fabs(sgt[4]) + fabs(sgt[5]);
        if (!(px >= 1e-9 && py >= 1e-9 && px <= 1e8 && py <= 1e8 &&
              isfinite(sgt[0] + sgt[1] + sgt[2] + sgt[3] + sgt[4] + sgt[5]))) {
            res = hz_err_set(err, HZ_ERR_VALUE,
                             "imagery: %s has a degenerate geotransform (pixel size %g x %g; expected 1e-9 to 1e8 "
                             "units)",
                             d->path, sgt[1], sgt[5]);
            goto done;
        }
    }
    const char *srs = has_gt ? GDALGetProjectionRef(src) : GDALGetGCPProjection(src);
    const bool assume_crs = !srs || !srs[0];
    if (assume_crs)
        snprintf(out->note, sizeof out->note, "%s has no CRS: taken to be the terrain's (%s)", d->path,
                 hz_georef_label(d->target));
    GDALDatasetH in = src;
    if (nb == 1 && GDALGetRasterColorTable(GDALGetRasterBand(src, 1))) {
        expanded = expand_palette(src, err);
        if (!expanded) {
            res = HZ_ERR_FORMAT;
            goto done;
        }
        in = expanded;
    }
    char *wkt = (char *)hz_georef_wkt(d->target);

    /* The image's own resolution on the terrain's CRS: GDAL's suggested output. */
    {
        char *args[16];
        int k = 0;
        args[k++] = "-of", args[k++] = "VRT", args[k++] = "-t_srs", args[k++] = wkt;
        if (assume_crs)
            args[k++] = "-s_srs", args[k++] = wkt;
        args[k] = NULL;
        probe = warp_vrt(in, args, err);
        if (!probe) {
            res = HZ_ERR_FORMAT;
            goto done;
        }
    }
    double pgt[6];
    GDALGetGeoTransform(probe, pgt);
    const double unit = d->spacing / fabs(tgt[1]); /* world metres per CRS unit */
    out->native_m = fmin(fabs(pgt[1]), fabs(pgt[5])) * unit;
    GDALClose(probe);
    probe = NULL;

    const double extent = (double)d->samples * d->spacing;
    double want = out->native_m > 0 ? ceil(extent / out->native_m) : (double)max_side;
    uint32_t side = want > max_side ? max_side : (want < MIN_SIDE ? MIN_SIDE : (uint32_t)want);
    uint32_t tiles = 0;
    if (side > SINGLE_MAX) {
        tiles = (side + HZ_IMAGERY_TILE - 1) / HZ_IMAGERY_TILE;
        if (tiles * HZ_IMAGERY_TILE > max_side)
            tiles = max_side / HZ_IMAGERY_TILE;
        side = tiles * HZ_IMAGERY_TILE;
    }
    /* What the warp reads: every pixel of the image over the terrain, from
     * the coarsest overview still as fine as the output (gdalwarp's -ovr
     * AUTO). A fine image without overviews is read whole: 3.6 G pixels
     * took 25 s, and a 1e6 x 1e6 mosaic at 3 cm ran for over ten minutes
     * and 8 GB before it was stopped. */
    if (out->native_m > 0) {
        GDALRasterBandH b1 = GDALGetRasterBand(in, 1);
        const double iw = GDALGetRasterBandXSize(b1), ih = GDALGetRasterBandYSize(b1);
        const double out_m = extent / side; /* metres per output texel */
        double f = 1.0;
        for (int o = 0; o < GDALGetOverviewCount(b1); o++) {
            GDALRasterBandH ov = GDALGetOverview(b1, o);
            const double fo = ov && GDALGetRasterBandXSize(ov) > 0 ? iw / GDALGetRasterBandXSize(ov) : 1.0;
            if (fo > f && out->native_m * fo <= out_m)
                f = fo;
        }
        const double over = extent / out->native_m, read = fmin(iw * ih, over * over) / (f * f);
        if (read > HZ_IMAGERY_MAX_READ) {
            res = hz_err_set(err, HZ_ERR_UNSUPPORTED,
                             "imagery: %s: draping it at %u texels a side would read about %.1f G of its pixels "
                             "(%.3g m each, %.0f times finer than needed), more than the %.0f G allowed: add "
                             "overviews (gdaladdo -r average %s) or give a coarser copy (gdal_translate -tr)",
                             d->path, side, read / 1e9, out->native_m * f, out_m / (out->native_m * f),
                             HZ_IMAGERY_MAX_READ / 1e9, d->path);
            goto done;
        }
    }
    /* CPU copy plus the GPU's */
    const uint64_t need = 2u * hz_imagery_bytes(side);
    if (d->max_bytes && need > d->max_bytes) {
        res = hz_err_set(err, HZ_ERR_MEMORY,
                         "imagery: %s at %u texels per side needs about %.0f MB, over the %.0f MB budget (lower "
                         "--imagery-max or raise --max-memory)",
                         d->path, side, (double)need / 1048576.0, (double)d->max_bytes / 1048576.0);
        goto done;
    }
    out->side = side;
    out->tiles = tiles;
    out->origin_x = out->origin_z = -0.5 * d->spacing;
    out->extent = extent;

    {
        char te[4][40], ts[24], *args[32];
        const double x0 = tgt[0], x1 = tgt[0] + (double)d->samples * tgt[1];
        const double y0 = tgt[3], y1 = tgt[3] + (double)d->samples * tgt[5];
        snprintf(te[0], sizeof te[0], "%.17g", fmin(x0, x1));
        snprintf(te[1], sizeof te[1], "%.17g", fmin(y0, y1));
        snprintf(te[2], sizeof te[2], "%.17g", fmax(x0, x1));
        snprintf(te[3], sizeof te[3], "%.17g", fmax(y0, y1));
        snprintf(ts, sizeof ts, "%u", side);
        /* Averaging when the image is finer than the output, else bilinear. */
        const bool shrink = out->native_m > 0 && out->native_m < extent / side;
        int k = 0;
        args[k++] = "-of", args[k++] = "VRT", args[k++] = "-t_srs", args[k++] = wkt;
        if (assume_crs)
            args[k++] = "-s_srs", args[k++] = wkt;
        args[k++] = "-te", args[k++] = te[0], args[k++] = te[1], args[k++] = te[2], args[k++] = te[3];
        args[k++] = "-ts", args[k++] = ts, args[k++] = ts;
        args[k++] = "-r", args[k++] = shrink ? "average" : "bilinear";
        args[k++] = "-dstalpha", args[k++] = "-ot", args[k++] = "Byte", args[k++] = "-wm", args[k++] = "256";
        args[k] = NULL;
        warped = warp_vrt(in, args, err);
        if (!warped) {
            res = HZ_ERR_FORMAT;
            goto done;
        }
    }
    const int m = GDALGetRasterCount(warped);
    int bands[4] = {1, 1, 1, m};
    if (m - 1 >= 3)
        bands[1] = 2, bands[2] = 3;

    const uint32_t ovs = tiles ? side / 4 : side;
    out->overview_side = ovs;
    out->overview_rgba = malloc((size_t)ovs * ovs * 4);
    if (!out->overview_rgba) {
        res = hz_err_set(err, HZ_ERR_MEMORY, "imagery: out of memory for %ux%u texels", ovs, ovs);
        goto done;
    }
    if (!tiles) {
        tmp = malloc((size_t)side * side * 4);
        if (!tmp) {
            res = hz_err_set(err, HZ_ERR_MEMORY, "imagery: out of memory for %ux%u texels", side, side);
            goto done;
        }
        if (d->progress)
            d->progress(d->progress_user, "imagery", 0, 1);
        res = read_window(warped, bands, side, 0, 0, side, out->overview_rgba, tmp, err);
        if (res != HZ_OK)
            goto done;
        if (d->progress)
            d->progress(d->progress_user, "imagery", 1, 1);
    } else {
        const uint32_t L = HZ_IMAGERY_TILE + 2 * HZ_IMAGERY_BORDER;
        const size_t layer = (size_t)L * L * 4;
        out->tile = HZ_IMAGERY_TILE;
        out->border = HZ_IMAGERY_BORDER;
        out->tile_rgba = malloc(layer * tiles * tiles);
        tmp = malloc(layer);
        if (!out->tile_rgba || !tmp) {
            res = hz_err_set(err, HZ_ERR_MEMORY, "imagery: out of memory for %u tiles of %u texels", tiles * tiles, L);
            goto done;
        }
        for (uint32_t ty = 0; ty < tiles; ty++)
            for (uint32_t tx = 0; tx < tiles; tx++) {
                uint8_t *t = out->tile_rgba + layer * (ty * tiles + tx);
                res = read_window(warped, bands, side, (int64_t)tx * HZ_IMAGERY_TILE - HZ_IMAGERY_BORDER,
                                  (int64_t)ty * HZ_IMAGERY_TILE - HZ_IMAGERY_BORDER, L, t, tmp, err);
                if (res != HZ_OK)
                    goto done;
                box4(t + ((size_t)HZ_IMAGERY_BORDER * L + HZ_IMAGERY_BORDER) * 4, L, HZ_IMAGERY_TILE,
                     out->overview_rgba + ((size_t)ty * (HZ_IMAGERY_TILE / 4) * ovs + tx * (HZ_IMAGERY_TILE / 4)) * 4,
                     ovs);
                if (d->progress)
                    d->progress(d->progress_user, "imagery", (uint64_t)ty * tiles + tx + 1, (uint64_t)tiles * tiles);
            }
    }
    uint64_t covered = 0;
    for (size_t i = 0; i < (size_t)ovs * ovs; i++)
        covered += out->overview_rgba[i * 4 + 3] > 0;
    out->coverage = (double)covered / ((double)ovs * ovs);
    if (covered == 0)
        res = hz_err_set(err, HZ_ERR_VALUE, "imagery: %s does not overlap the terrain (%s)", d->path,
                         hz_georef_label(d->target));
done:
    free(tmp);
    if (warped)
        GDALClose(warped);
    if (probe)
        GDALClose(probe);
    if (expanded)
        GDALClose(expanded);
    if (src)
        GDALClose(src);
    CPLPopErrorHandler();
    if (res != HZ_OK)
        hz_imagery_free(out);
    return res;
}
