/* hz_imagery: an image aligned texel for texel with a terrain footprint comes
 * back exactly, cut into tiles whose borders hold their neighbours' texels
 * (seamless filtering), with an overview that is the 4x4 average; texels off
 * the image are transparent; world <-> texel round trips. No GL. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <gdal.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "horizon/imagery.h"
#include "io_fixtures.h"

#define SAMPLES 513u
#define SPACING 10.0
#define SIDE 5120u /* five tiles per side */

static char dir[256];

static uint8_t pattern(uint32_t x, uint32_t y, int c)
{
    uint32_t v = c == 0 ? x * 7u + y * 13u : (c == 1 ? x ^ (y * 3u) : (x * y) >> 3);
    return (uint8_t)(v & 255u);
}

/* An RGB GeoTIFF in EPSG:32632 of w x h pixels from (x0, y0) of the texel
 * grid of the footprint (one pixel per texel). */
static void write_image(const char *path, const double tgt[6], uint32_t x0, uint32_t y0, uint32_t w, uint32_t h)
{
    GDALAllRegister();
    const double px = SAMPLES * SPACING / SIDE;
    double gt[6] = {tgt[0] + x0 * px, px, 0, tgt[3] - y0 * px, 0, -px};
    GDALDatasetH ds = GDALCreate(GDALGetDriverByName("GTiff"), path, (int)w, (int)h, 3, GDT_Byte, NULL);
    assert_non_null(ds);
    GDALSetGeoTransform(ds, gt);
    GDALSetProjection(ds, "EPSG:32632");
    uint8_t *row = malloc(w);
    for (int c = 0; c < 3; c++)
        for (uint32_t y = 0; y < h; y++) {
            for (uint32_t x = 0; x < w; x++)
                row[x] = pattern(x0 + x, y0 + y, c);
            assert_int_equal(GDALRasterIO(GDALGetRasterBand(ds, c + 1), GF_Write, 0, (int)y, (int)w, 1, row, (int)w, 1,
                                          GDT_Byte, 0, 0),
                             CE_None);
        }
    free(row);
    GDALClose(ds);
}

static hz_georef *terrain_georef(double gt[6])
{
    /* sample (0, 0) centred at (500000, 5200000) */
    double g[6] = {500000.0 - 0.5 * SPACING, SPACING, 0, 5200000.0 + 0.5 * SPACING, 0, -SPACING};
    memcpy(gt, g, sizeof g);
    hz_err err = {0};
    hz_georef *geo = hz_georef_create("EPSG:32632", g, SAMPLES, SAMPLES, &err);
    assert_non_null(geo);
    return geo;
}

static void test_tiles_exact_and_seamless(void **state)
{
    (void)state;
    double gt[6];
    hz_georef *geo = terrain_georef(gt);
    char path[320];
    snprintf(path, sizeof path, "%s/aligned.tif", dir);
    write_image(path, gt, 0, 0, SIDE, SIDE);
    hz_imagery_desc d = {.path = path, .target = geo, .samples = SAMPLES, .spacing = SPACING, .max_side = SIDE};
    hz_imagery im;
    hz_err err = {0};
    assert_int_equal(hz_imagery_load(&d, &im, &err), HZ_OK);
    assert_int_equal(im.side, SIDE);
    assert_int_equal(im.tiles, SIDE / HZ_IMAGERY_TILE);
    assert_true(fabs(im.native_m - SAMPLES * SPACING / SIDE) < 1e-6);
    assert_true(im.coverage > 0.999);
    const uint32_t T = im.tile, B = im.border, L = T + 2 * B, n = im.tiles;
    uint64_t wrong_core = 0, wrong_border = 0;
    for (uint32_t ty = 0; ty < n; ty++)
        for (uint32_t tx = 0; tx < n; tx++) {
            const uint8_t *t = im.tile_rgba + (size_t)L * L * 4 * (ty * n + tx);
            for (uint32_t j = 0; j < L; j++)
                for (uint32_t i = 0; i < L; i++) {
                    /* the global texel, clamped to the image at its edges */
                    int64_t gx = (int64_t)tx * T + i - B, gy = (int64_t)ty * T + j - B;
                    gx = gx < 0 ? 0 : (gx >= SIDE ? SIDE - 1 : gx);
                    gy = gy < 0 ? 0 : (gy >= SIDE ? SIDE - 1 : gy);
                    const uint8_t *p = t + ((size_t)j * L + i) * 4;
                    bool same = p[3] == 255;
                    for (int c = 0; c < 3; c++)
                        same = same && p[c] == pattern((uint32_t)gx, (uint32_t)gy, c);
                    const bool core = i >= B && i < B + T && j >= B && j < B + T;
                    if (!same && core)
                        wrong_core++;
                    else if (!same)
                        wrong_border++;
                }
        }
    assert_int_equal(wrong_core, 0);
    assert_int_equal(wrong_border, 0);
    /* the overview: the 4x4 average */
    assert_int_equal(im.overview_side, SIDE / 4);
    uint64_t wrong_ov = 0;
    for (uint32_t y = 0; y < im.overview_side; y += 37)
        for (uint32_t x = 0; x < im.overview_side; x += 29)
            for (int c = 0; c < 3; c++) {
                uint32_t s = 0;
                for (uint32_t b = 0; b < 4; b++)
                    for (uint32_t a = 0; a < 4; a++)
                        s += pattern(4 * x + a, 4 * y + b, c);
                int want = (int)((s + 8) / 16), got = im.overview_rgba[((size_t)y * im.overview_side + x) * 4 + c];
                wrong_ov += abs(want - got) > 1;
            }
    assert_int_equal(wrong_ov, 0);
    /* world <-> texel */
    double x, z, tx, ty;
    hz_imagery_texel_to_world(&im, 0, 0, &x, &z);
    assert_true(fabs(x - (-0.5 * SPACING + 0.5 * SAMPLES * SPACING / SIDE)) < 1e-9);
    hz_imagery_world_to_texel(&im, 1234.5, 4321.25, &tx, &ty);
    hz_imagery_texel_to_world(&im, tx, ty, &x, &z);
    assert_true(fabs(x - 1234.5) < 1e-9 && fabs(z - 4321.25) < 1e-9);
    hz_imagery_free(&im);
    hz_georef_destroy(geo);
    unlink(path);
}

/* An image over part of the footprint: transparent elsewhere, the coverage
 * is the share it covers, and its texels sit where its georeference says. */
static void test_partial_transparent(void **state)
{
    (void)state;
    double gt[6];
    hz_georef *geo = terrain_georef(gt);
    char path[320];
    snprintf(path, sizeof path, "%s/part.tif", dir);
    /* pixels of a 1024-texel grid: x 256..767, y 512..1023 */
    const uint32_t side = 1024;
    const double px = SAMPLES * SPACING / side;
    double g2[6] = {gt[0] + 256 * px, px, 0, gt[3] - 512 * px, 0, -px};
    GDALAllRegister();
    GDALDatasetH ds = GDALCreate(GDALGetDriverByName("GTiff"), path, 512, 512, 3, GDT_Byte, NULL);
    assert_non_null(ds);
    GDALSetGeoTransform(ds, g2);
    GDALSetProjection(ds, "EPSG:32632");
    uint8_t *buf = malloc(512 * 512);
    memset(buf, 200, 512 * 512);
    for (int c = 1; c <= 3; c++)
        assert_int_equal(GDALRasterIO(GDALGetRasterBand(ds, c), GF_Write, 0, 0, 512, 512, buf, 512, 512, GDT_Byte, 0, 0),
                         CE_None);
    free(buf);
    GDALClose(ds);
    hz_imagery_desc d = {.path = path, .target = geo, .samples = SAMPLES, .spacing = SPACING, .max_side = side};
    hz_imagery im;
    hz_err err = {0};
    assert_int_equal(hz_imagery_load(&d, &im, &err), HZ_OK);
    assert_int_equal(im.side, side);
    assert_int_equal(im.tiles, 0);
    assert_true(fabs(im.coverage - 0.25) < 0.01);
    /* inside / outside, away from the edges */
    const uint8_t *in = im.overview_rgba + ((size_t)700 * side + 400) * 4;
    const uint8_t *out = im.overview_rgba + ((size_t)300 * side + 400) * 4;
    assert_int_equal(in[3], 255);
    assert_int_equal(in[0], 200);
    assert_int_equal(out[3], 0);
    hz_imagery_free(&im);

    /* refusals */
    d.max_side = 10;
    assert_int_not_equal(hz_imagery_load(&d, &im, &err), HZ_OK);
    d.max_side = 0;
    d.max_bytes = 1000;
    assert_int_equal(hz_imagery_load(&d, &im, &err), HZ_ERR_MEMORY);
    assert_non_null(strstr(err.msg, "budget"));
    d.max_bytes = 0;
    d.target = NULL;
    assert_int_not_equal(hz_imagery_load(&d, &im, &err), HZ_OK);
    assert_non_null(strstr(err.msg, "no georeference"));
    hz_georef_destroy(geo);
    unlink(path);
}

/* A GeoTIFF claiming a 2^28-pixel-wide RGB image in one uncompressed strip:
 * GDAL would read it in blocks of a row (768 MB), which must be refused
 * before any is allocated. */
static void test_huge_blocks_refused(void **state)
{
    (void)state;
    double gt[6];
    hz_georef *geo = terrain_georef(gt);
    char path[320];
    snprintf(path, sizeof path, "%s/wide.tif", dir);
    assert_true(fx_write_tiff_claim(path, 1u << 28, 4, 3, 8, 1, 1, 499995, 5200005, 1, 32632));
    hz_imagery_desc d = {.path = path, .target = geo, .samples = SAMPLES, .spacing = SPACING, .max_side = 256};
    hz_imagery im;
    hz_err err = {0};
    assert_int_equal(hz_imagery_load(&d, &im, &err), HZ_ERR_UNSUPPORTED);
    print_message("%s\n", err.msg);
    assert_non_null(strstr(err.msg, "re-tile"));
    hz_georef_destroy(geo);
    unlink(path);
}

/* Writes a blank w x h GeoTIFF of nb bands at the footprint's corner with
 * pixels of px metres in EPSG:32632, loads it over the terrain of gt and
 * removes it. */
static hz_result load_blank(hz_georef *geo, const double gt[6], int w, int h, int nb, double px, hz_imagery *im,
                            hz_err *err)
{
    char path[320];
    snprintf(path, sizeof path, "%s/blank.tif", dir);
    double g[6] = {gt[0], px, 0, gt[3], 0, -px};
    GDALAllRegister();
    GDALDatasetH ds = GDALCreate(GDALGetDriverByName("GTiff"), path, w, h, nb, GDT_Byte, NULL);
    assert_non_null(ds);
    GDALSetGeoTransform(ds, g);
    GDALSetProjection(ds, "EPSG:32632");
    GDALClose(ds);
    hz_imagery_desc d = {.path = path, .target = geo, .samples = SAMPLES, .spacing = SPACING, .max_side = 256,
                         .max_bytes = (uint64_t)64 << 20};
    const hz_result r = hz_imagery_load(&d, im, err);
    print_message("%d bands, pixel %g: %s\n", nb, px, r == HZ_OK ? "loaded" : err->msg);
    unlink(path);
    return r;
}

/* Pixels of next to no size or of absurd size make GDAL's warper read (and
 * allocate) an absurd source window: both are refused with a message, before
 * any warp; a sane pixel size over the same footprint loads. */
static void test_absurd_pixel_sizes_refused(void **state)
{
    (void)state;
    double gt[6];
    hz_georef *geo = terrain_georef(gt);
    hz_imagery im;
    hz_err err = {0};
    assert_int_equal(load_blank(geo, gt, 8, 170, 3, 1e-300, &im, &err), HZ_ERR_VALUE);
    assert_non_null(strstr(err.msg, "degenerate geotransform"));
    assert_int_equal(load_blank(geo, gt, 8, 170, 3, 1.7e98, &im, &err), HZ_ERR_VALUE);
    assert_non_null(strstr(err.msg, "degenerate geotransform"));
    assert_int_equal(load_blank(geo, gt, 8, 170, 3, 10.0, &im, &err), HZ_OK);
    hz_imagery_free(&im);
    hz_georef_destroy(geo);
}

/* A VRT of 200 000 x 200 000 pixels of 2.6 cm over the footprint (the
 * pixels of a small GeoTIFF): draped at 256 texels it would be read whole,
 * 40 G pixels, and is refused with the advice to add overviews. With an
 * overview 500 times coarser (as fine as the 20 m texels still) the warp
 * reads that instead, and it loads. */
static void test_fine_image_needs_overviews(void **state)
{
    (void)state;
    double gt[6];
    hz_georef *geo = terrain_georef(gt);
    char small[320], ovr[320], vrt[320];
    snprintf(small, sizeof small, "%s/small.tif", dir);
    snprintf(ovr, sizeof ovr, "%s/ovr.tif", dir);
    snprintf(vrt, sizeof vrt, "%s/fine.vrt", dir);
    GDALAllRegister();
    const char *files[2] = {small, ovr};
    const int sides[2] = {64, 400};
    for (int k = 0; k < 2; k++) {
        GDALDatasetH ds = GDALCreate(GDALGetDriverByName("GTiff"), files[k], sides[k], sides[k], 1, GDT_Byte, NULL);
        assert_non_null(ds);
        GDALClose(ds);
    }
    const int n = 200000;
    const double px = SAMPLES * SPACING / n;
    hz_imagery im;
    hz_err err = {0};
    hz_imagery_desc d = {.path = vrt, .target = geo, .samples = SAMPLES, .spacing = SPACING, .max_side = 256,
                         .max_bytes = (uint64_t)64 << 20};
    for (int with_ovr = 0; with_ovr < 2; with_ovr++) {
        char ov[800] = "";
        if (with_ovr)
            snprintf(ov, sizeof ov,
                     "<Overview><SourceFilename relativeToVRT=\"0\">%s</SourceFilename><SourceBand>1</SourceBand>"
                     "</Overview>",
                     ovr);
        FILE *f = fopen(vrt, "w");
        assert_non_null(f);
        fprintf(f,
                "<VRTDataset rasterXSize=\"%d\" rasterYSize=\"%d\"><SRS>EPSG:32632</SRS>"
                "<GeoTransform>%.17g, %.17g, 0, %.17g, 0, %.17g</GeoTransform>"
                "<VRTRasterBand dataType=\"Byte\" band=\"1\"><SimpleSource><SourceFilename relativeToVRT=\"0\">%s"
                "</SourceFilename><SourceBand>1</SourceBand><SrcRect xOff=\"0\" yOff=\"0\" xSize=\"64\" "
                "ySize=\"64\"/><DstRect xOff=\"0\" yOff=\"0\" xSize=\"%d\" ySize=\"%d\"/></SimpleSource>%s"
                "</VRTRasterBand></VRTDataset>\n",
                n, n, gt[0], px, gt[3], -px, small, n, n, ov);
        fclose(f);
        const double t0 = hz_time_ms();
        const hz_result r = hz_imagery_load(&d, &im, &err);
        print_message("%s: %s in %.0f ms\n", with_ovr ? "with an overview" : "without", r == HZ_OK ? "loaded" : err.msg,
                      hz_time_ms() - t0);
        if (with_ovr) {
            assert_int_equal(r, HZ_OK);
            hz_imagery_free(&im);
        } else {
            assert_int_equal(r, HZ_ERR_UNSUPPORTED);
            assert_non_null(strstr(err.msg, "would read about 40.0 G of its pixels"));
            assert_non_null(strstr(err.msg, "gdaladdo"));
        }
    }
    unlink(small);
    unlink(ovr);
    unlink(vrt);
    hz_georef_destroy(geo);
}

/* An image of more bands than HZ_IMAGERY_MAX_BANDS is refused before it is
 * warped (every band would be); one of that many loads. */
static void test_many_bands_refused(void **state)
{
    (void)state;
    double gt[6];
    hz_georef *geo = terrain_georef(gt);
    hz_imagery im;
    hz_err err = {0};
    assert_int_equal(load_blank(geo, gt, 16, 16, HZ_IMAGERY_MAX_BANDS, 10.0, &im, &err), HZ_OK);
    hz_imagery_free(&im);
    assert_int_equal(load_blank(geo, gt, 16, 16, HZ_IMAGERY_MAX_BANDS + 1, 10.0, &im, &err), HZ_ERR_UNSUPPORTED);
    assert_non_null(strstr(err.msg, "bands"));
    hz_georef_destroy(geo);
}

int main(void)
{
    snprintf(dir, sizeof dir, "%s", "/tmp/hz_imagery_XXXXXX");
    if (!mkdtemp(dir))
        return 1;
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_tiles_exact_and_seamless),
                                       cmocka_unit_test(test_partial_transparent),
                                       cmocka_unit_test(test_huge_blocks_refused),
                                       cmocka_unit_test(test_absurd_pixel_sizes_refused),
                                       cmocka_unit_test(test_many_bands_refused),
                                       cmocka_unit_test(test_fine_image_needs_overviews)};
    int rc = cmocka_run_group_tests(tests, NULL, NULL);
    rmdir(dir);
    return rc;
}
