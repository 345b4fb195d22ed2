/* The real DEMs in HZ_DATA_DIR: sizes, formats, units and value ranges as
 * given in PROVENANCE.md (within 0.1 m), spacing hints, and void filling on
 * the 103,743 voids of N46E008 (read from its GeoTIFF by a minimal reader
 * here, since the loader does not do TIFF). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "horizon/dem.h"
#include "io_fixtures.h"
#include "io_tests.h"

typedef struct real_dem {
    const char *file;
    uint32_t w, h;
    float lo, hi;
    hz_dem_format format;
    hz_dem_units units;
    float spacing; /* expected hint; < 0: only check > 0 */
} real_dem;

static void check_real(const real_dem *r)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", HZ_DATA_DIR, r->file);
    hz_grid g;
    hz_err err = {0};
    hz_dem_info info;
    double t0 = hz_time_ms();
    hz_result res = hz_dem_load(&(hz_dem_desc){.path = path}, &g, &info, &err);
    double ms = hz_time_ms() - t0;
    if (res != HZ_OK)
        fail_msg("%s: %s", r->file, err.msg);
    float lo, hi;
    uint64_t bad = hz_grid_range(&g, &lo, &hi);
    print_message("%-66s %5ux%-5u %-9s %8.2f .. %8.2f m  spacing %6.1f  %5.0f ms\n", r->file, g.width, g.height,
                  hz_dem_format_name(info.format), (double)lo, (double)hi, (double)info.spacing_hint, ms);
    assert_int_equal(g.width, r->w);
    assert_int_equal(g.height, r->h);
    assert_int_equal(bad, 0);
    assert_int_equal(info.voids, 0);
    assert_int_equal(info.format, r->format);
    assert_int_equal(info.units, r->units);
    if (fabsf(lo - r->lo) > 0.1f || fabsf(hi - r->hi) > 0.1f)
        fail_msg("%s: range %.3f..%.3f, expected %.1f..%.1f", r->file, (double)lo, (double)hi, (double)r->lo,
                 (double)r->hi);
    if (r->spacing >= 0)
        assert_float_equal(info.spacing_hint, r->spacing, 0.01f);
    else
        assert_true(info.spacing_hint > 0.0f);
    hz_grid_free(&g);
}

void test_real_hgt(void **state)
{
    (void)state;
    const real_dem d[] = {
        /* Read by GDAL (SRTMHGT): the hint is the finer (east-west) spacing at the centre. */
        {"N44W072.hgt", 1201, 1201, 115.0f, 1908.0f, HZ_DEM_HGT, HZ_UNITS_M, 66.27f},
        {"S46W066.hgt.gz", 3601, 3601, -3.0f, 146.0f, HZ_DEM_HGT, HZ_UNITS_M, 21.71f},
    };
    for (size_t i = 0; i < sizeof d / sizeof *d; i++)
        check_real(&d[i]);
}

void test_real_png(void **state)
{
    (void)state;
    const real_dem d[] = {
        {"sthelens_10m_dm16.png", 2000, 2000, 567.5f, 2538.2f, HZ_DEM_PNG, HZ_UNITS_DM, 10.0f},
        {"himalaya-everest_3as_ft16.png", 648, 648, 2362.2f, 8837.4f, HZ_DEM_PNG, HZ_UNITS_FT, 90.0f},
        {"pyrenees_1as_ft16.png", 1933, 1433, 659.3f, 3364.4f, HZ_DEM_PNG, HZ_UNITS_FT, 30.0f},
        {"sahara_3as_ft16.png", 648, 648, 189.9f, 474.9f, HZ_DEM_PNG, HZ_UNITS_FT, 90.0f},
        {"allgaeu_terrarium_z9_x270_y178.png", 256, 256, 532.5f, 1716.2f, HZ_DEM_TERRARIUM, HZ_UNITS_M, -1.0f},
        {"puget_sound_ps-e.lg_8bit_512.png", 512, 512, 0.0f, 255.0f, HZ_DEM_PNG, HZ_UNITS_M, 0.0f},
        {"alps-montblanc_norm16.png", 647, 647, 0.0f, 65535.0f, HZ_DEM_PNG, HZ_UNITS_M, 0.0f},
    };
    for (size_t i = 0; i < sizeof d / sizeof *d; i++)
        check_real(&d[i]);

    /* Terrarium z9 tile at ~47.8 N: 40075 km * cos(lat) / 2^9 / 256 ~ 205 m. */
    hz_grid g;
    hz_dem_info info;
    assert_int_equal(hz_dem_load(&(hz_dem_desc){.path = HZ_DATA_DIR "/allgaeu_terrarium_z9_x270_y178.png"}, &g,
                                 &info, NULL),
                     HZ_OK);
    assert_float_equal(info.spacing_hint, 205.5f, 2.0f);
    hz_grid_free(&g);

    /* The non-square Pyrenees pad to 2049 with a note; the GeoTIFFs are refused clearly. */
    hz_err err = {0};
    char note[256];
    assert_int_equal(hz_dem_load(&(hz_dem_desc){.path = HZ_DATA_DIR "/pyrenees_1as_ft16.png"}, &g, NULL, &err), HZ_OK);
    assert_int_equal(hz_grid_fit_pow2(&g, HZ_FIT_AUTO, note, sizeof note, &err), HZ_OK);
    assert_int_equal(g.width, 2049);
    assert_non_null(strstr(note, "padded 1933x1433 to 2049x2049"));
    hz_grid_free(&g);
    /* GeoTIFFs read (through GDAL). */
    assert_int_equal(hz_dem_load(&(hz_dem_desc){.path = HZ_DATA_DIR "/N46E008.tif"}, &g, NULL, &err), HZ_OK);
    assert_int_equal(g.width, 1201);
    hz_grid_free(&g);
    assert_int_equal(hz_dem_load(&(hz_dem_desc){.path = HZ_DATA_DIR "/PROVENANCE.md"}, &g, NULL, &err),
                     HZ_ERR_FORMAT);
    assert_non_null(strstr(err.msg, "--format"));
}

typedef struct prog_count {
    int calls;
    uint64_t last_done, last_total;
} prog_count;

static void count_progress(void *user, const char *label, uint64_t done, uint64_t total)
{
    (void)label;
    prog_count *p = user;
    p->calls++;
    p->last_done = done;
    p->last_total = total;
}

void test_real_sierra_mosaic(void **state)
{
    (void)state;
    real_dem d = {"sierra_nevada_N36-N40_W122-W118_srtm3_4801x4801_int16be.raw.gz", 4801, 4801, -3.0f, 4404.0f,
                  HZ_DEM_HGT, HZ_UNITS_M, 90.0f};
    check_real(&d);
    /* With progress, then fitted: 4801 is nearer 4097 than 8193. */
    hz_grid g;
    hz_err err = {0};
    prog_count pc = {0};
    char note[256];
    assert_int_equal(hz_dem_load(&(hz_dem_desc){.path = HZ_DATA_DIR "/" "sierra_nevada_N36-N40_W122-W118_srtm3_"
                                                        "4801x4801_int16be.raw.gz",
                                                .progress = count_progress, .progress_user = &pc},
                                 &g, NULL, &err),
                     HZ_OK);
    assert_true(pc.calls >= 10 && pc.calls <= 110);
    assert_int_equal(pc.last_done, pc.last_total);
    assert_int_equal(hz_grid_fit_pow2(&g, HZ_FIT_AUTO, note, sizeof note, &err), HZ_OK);
    assert_int_equal(g.width, 4097);
    assert_non_null(strstr(note, "cropped 4801x4801 to centred 4097x4097"));
    hz_grid_free(&g);
}

/* Minimal reader for the striped, uncompressed little-endian int16 GeoTIFF. */
static bool read_tiff_int16(const char *path, hz_grid *g, int16_t nodata, uint64_t *voids)
{
    size_t n;
    uint8_t *b = fx_read(path, &n);
    if (!b || n < 8 || memcmp(b, "II*\0", 4))
        return false;
#define U16(p) ((uint32_t)b[p] | (uint32_t)b[(p) + 1] << 8)
#define U32(p) (U16(p) | U16((p) + 2) << 16)
    uint32_t ifd = U32(4), w = 0, h = 0, rps = 0, nstrips = 0, offs = 0, bits = 0, comp = 0;
    uint32_t entries = U16(ifd);
    for (uint32_t e = 0; e < entries; e++) {
        uint32_t p = ifd + 2 + 12 * e, tag = U16(p), type = U16(p + 2), cnt = U32(p + 4);
        uint32_t val = type == 3 ? U16(p + 8) : U32(p + 8);
        if (tag == 256) w = val;
        if (tag == 257) h = val;
        if (tag == 258) bits = val;
        if (tag == 259) comp = val;
        if (tag == 278) rps = val;
        if (tag == 273) { nstrips = cnt; offs = val; }
    }
    bool ok = bits == 16 && comp == 1 && w && h && rps && nstrips == (h + rps - 1) / rps &&
              hz_grid_alloc(g, w, h, NULL) == HZ_OK;
    *voids = 0;
    for (uint32_t sidx = 0; ok && sidx < nstrips; sidx++) {
        uint32_t so = U32(offs + 4 * sidx);
        for (uint32_t r = 0; r < rps && sidx * rps + r < h; r++) {
            uint32_t row = sidx * rps + r;
            if ((size_t)so + ((size_t)r + 1) * w * 2 > n) {
                ok = false;
                break;
            }
            for (uint32_t i = 0; i < w; i++) {
                int16_t v = (int16_t)U16(so + (r * w + i) * 2);
                if (v == nodata)
                    (*voids)++;
                g->z[(size_t)row * w + i] = v == nodata ? NAN : (float)v;
            }
        }
    }
#undef U16
#undef U32
    free(b);
    return ok;
}

void test_real_fill_voids_n46e008(void **state)
{
    (void)state;
    hz_grid g;
    uint64_t voids;
    assert_true(read_tiff_int16(HZ_DATA_DIR "/N46E008.tif", &g, -32767, &voids));
    assert_int_equal(g.width, 1201);
    assert_int_equal(voids, 103743);
    float *orig = malloc((size_t)1201 * 1201 * sizeof(float));
    memcpy(orig, g.z, (size_t)1201 * 1201 * sizeof(float));
    float lo, hi;
    hz_grid_range(&g, &lo, &hi);
    assert_true(lo == 187.0f && hi == 4173.0f);
    uint64_t filled = 0;
    hz_err err = {0};
    double t0 = hz_time_ms();
    assert_int_equal(hz_grid_fill_voids(&g, &filled, &err), HZ_OK);
    double ms = hz_time_ms() - t0;
    print_message("fill_voids N46E008: %llu voids in %.1f ms\n", (unsigned long long)filled, ms);
    assert_int_equal(filled, 103743);
    float flo, fhi;
    assert_int_equal(hz_grid_range(&g, &flo, &fhi), 0);
    /* Averages of valid heights cannot leave their range. */
    assert_true(flo >= lo && fhi <= hi);
    /* Valid samples unchanged; filled samples continuous with their valid
     * neighbours (no seams: a void next to a valid sample is within the
     * local relief, here at most 600 m over one 90 m step in the Alps). */
    size_t seams = 0;
    for (size_t k = 0; k < (size_t)1201 * 1201; k++) {
        if (!isnan(orig[k])) {
            assert_true(g.z[k] == orig[k]);
            continue;
        }
        size_t i = k % 1201;
        if (i + 1 < 1201 && !isnan(orig[k + 1]) && fabsf(g.z[k] - orig[k + 1]) > 600.0f)
            seams++;
    }
    assert_int_equal(seams, 0);
    free(orig);
    hz_grid_free(&g);
}
