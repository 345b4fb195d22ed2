/* Terrain pyramids: the import is exact for 16-bit input and keeps the
 * georeference and the nodata mask; corrupt and truncated files are caught;
 * the streamed selection is crack-free while tiles are missing and under a
 * tiny cache. No GL (tiles are "uploaded" by acknowledging them). */
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

#include "horizon/grid.h"
#include "horizon/heightmap.h"
#include <ogr_srs_api.h>
#include "horizon/metrics.h"
#include "horizon/pyramid.h"
#include "horizon/stream.h"
#include "mesh_check.h"

enum { W = 700, H = 500 };
static const double GT[6] = {500000.0, 30.0, 0.0, 4100000.0, 0.0, -30.0};

static int16_t value_at(uint32_t i, uint32_t j)
{
    if (i >= 300 && i < 340 && j >= 200 && j < 230)
        return -32768; /* a nodata block */
    double v = 800.0 + 700.0 * sin(i * 0.013) * cos(j * 0.017) + 300.0 * sin((i + 2 * j) * 0.051) + (double)((i * 7 + j * 13) % 11);
    return (int16_t)lrint(v);
}

static char tif[512], hzp[512];

static int setup(void **state)
{
    (void)state;
    GDALAllRegister();
    snprintf(tif, sizeof tif, "%s/pyr_src.tif", HZ_TEST_TMP);
    snprintf(hzp, sizeof hzp, "%s/pyr.hzp", HZ_TEST_TMP);
    GDALDriverH drv = GDALGetDriverByName("GTiff");
    GDALDatasetH ds = GDALCreate(drv, tif, W, H, 1, GDT_Int16, NULL);
    if (!ds)
        return -1;
    GDALSetGeoTransform(ds, (double *)GT);
    GDALSetProjection(ds, "EPSG:32633");
    OGRSpatialReferenceH srs = OSRNewSpatialReference(NULL);
    OSRImportFromEPSG(srs, 32633);
    GDALSetSpatialRef(ds, srs);
    OSRDestroySpatialReference(srs);
    GDALRasterBandH b = GDALGetRasterBand(ds, 1);
    GDALSetRasterNoDataValue(b, -32768);
    int16_t *row = malloc(W * sizeof *row);
    for (uint32_t j = 0; j < H; j++) {
        for (uint32_t i = 0; i < W; i++)
            row[i] = value_at(i, j);
        if (GDALRasterIO(b, GF_Write, 0, (int)j, W, 1, row, W, 1, GDT_Int16, 0, 0) != CE_None)
            return -1;
    }
    free(row);
    GDALClose(ds);
    const char *ins[] = {tif};
    hz_pyr_import d = {.out = hzp, .inputs = ins, .input_count = 1, .tile_cells = 64};
    hz_pyr_import_stats st;
    hz_err err = {0};
    if (hz_pyramid_import(&d, &st, &err) != HZ_OK) {
        fprintf(stderr, "import: %s\n", err.msg);
        return -1;
    }
    return 0;
}

/* Every sample of every level of pyramid path (the tif imported) equals the
 * source, or is no data where the source has none or the padding is; so is
 * every apron sample. */
static void check_exact(const char *path)
{
    hz_pyramid *p;
    hz_err err = {0};
    assert_int_equal(hz_pyramid_open(path, &p, &err), HZ_OK);
    const hz_pyr_info *in = hz_pyramid_info(p);
    assert_int_equal(in->data_w, W);
    assert_int_equal(in->data_h, H);
    assert_int_equal(in->size, 1025);
    assert_true(in->max_error == 0.0);
    assert_int_equal(in->nodata, 40 * 30);
    for (int k = 0; k < 6; k++)
        assert_true(in->geotransform[k] == GT[k]);
    assert_non_null(strstr(in->wkt, "32633"));
    uint64_t checked = 0;
    for (uint32_t l = 0; l < in->levels; l++) {
        const uint32_t m = hz_pyr_level_tiles(in, l);
        for (uint32_t tz = 0; tz < m; tz++)
            for (uint32_t tx = 0; tx < m; tx++) {
                hz_pyr_tile t;
                assert_int_equal(hz_pyramid_read_tile(p, l, tx, tz, &t, &err), HZ_OK);
                const uint32_t n = t.cells + 1;
                for (uint32_t b = 0; b < n; b++)
                    for (uint32_t a = 0; a < n; a++) {
                        const uint32_t i = t.x0 + (a << l), j = t.z0 + (b << l);
                        const size_t k = (size_t)b * n + a;
                        const bool inside = i < W && j < H;
                        const int16_t v = inside ? value_at(i, j) : -32768;
                        const bool valid = t.valid ? t.valid[k] : true;
                        if (v == -32768) {
                            assert_false(valid); /* nodata and padding never become heights */
                        } else {
                            assert_true(valid);
                            assert_true(in->h_offset + in->h_scale * t.h[k] == (double)v);
                            checked++;
                        }
                    }
                /* the apron: the samples around the tile (shared by both tiles of an edge) */
                size_t na = 0;
                for (int64_t bz = -1; bz <= (int64_t)t.cells + 1; bz++)
                    for (int64_t a = -1; a <= (int64_t)t.cells + 1; a++) {
                        if (bz >= 0 && bz <= (int64_t)t.cells && a >= 0 && a <= (int64_t)t.cells)
                            continue;
                        const int64_t i = (int64_t)t.x0 + a * ((int64_t)1 << l), j = (int64_t)t.z0 + bz * ((int64_t)1 << l);
                        const uint16_t ah = t.apron[na++];
                        if (i < 0 || j < 0 || i >= W || j >= H || value_at((uint32_t)i, (uint32_t)j) == -32768)
                            continue;
                        assert_true(in->h_offset + in->h_scale * ah == (double)value_at((uint32_t)i, (uint32_t)j));
                        checked++;
                    }
                for (uint32_t q = 0; q < t.nodes * t.nodes; q++)
                    assert_true(t.node_min[q] <= t.node_max[q]);
                hz_pyr_tile_free(&t);
            }
    }
    assert_true(checked > (uint64_t)W * H);
    hz_pyramid_close(p);
}

static void test_round_trip_exact(void **state)
{
    (void)state;
    check_exact(hzp);
}

/* One encoder kept across every tile of the pyramid, coarse levels first
 * (tiles of different sizes, masked and not, through the same zstd context),
 * writes the same bytes as a fresh context per tile, and they decode back to
 * the tile; so does the one-shot call. */
static void test_encoder_reused_same_bytes(void **state)
{
    (void)state;
    hz_pyramid *p;
    hz_err err = {0};
    assert_int_equal(hz_pyramid_open(hzp, &p, &err), HZ_OK);
    const hz_pyr_info *in = hz_pyramid_info(p);
    hz_pyr_encoder *enc = hz_pyr_encoder_new();
    assert_non_null(enc);
    uint32_t tiles = 0, masked = 0;
    for (uint32_t l = in->levels; l-- > 0;)
        for (uint32_t tz = 0; tz < hz_pyr_level_tiles(in, l); tz++)
            for (uint32_t tx = 0; tx < hz_pyr_level_tiles(in, l); tx++) {
                hz_pyr_tile t, back;
                assert_int_equal(hz_pyramid_read_tile(p, l, tx, tz, &t, &err), HZ_OK);
                void *a, *b;
                size_t na, nb;
                for (int level = 3; level <= 9; level += 6) {
                    assert_int_equal(hz_pyr_encoder_tile(enc, in, &t, level, &a, &na, &err), HZ_OK);
                    assert_int_equal(hz_pyr_encode_tile(in, &t, level, &b, &nb, &err), HZ_OK);
                    assert_int_equal(na, nb);
                    assert_memory_equal(a, b, na);
                    assert_int_equal(hz_pyr_decode_blob(in, l, tx, tz, a, na, &back, &err), HZ_OK);
                    const size_t n = (size_t)(t.cells + 1) * (t.cells + 1);
                    assert_memory_equal(back.h, t.h, n * sizeof *t.h);
                    assert_true((back.valid == NULL) == (t.valid == NULL));
                    if (t.valid)
                        assert_memory_equal(back.valid, t.valid, n);
                    hz_pyr_tile_free(&back);
                    free(a);
                    free(b);
                }
                tiles++;
                masked += t.valid != NULL;
                hz_pyr_tile_free(&t);
            }
    hz_pyr_encoder_free(enc);
    hz_pyr_encoder_free(NULL);
    assert_true(tiles > 20 && masked > 0 && masked < tiles);
    hz_pyramid_close(p);
}

/* A w x h int16 raster of value_at inside keep_w x keep_h, nodata outside. */
static void write_tif(const char *path, uint32_t w, uint32_t h, uint32_t keep_w, uint32_t keep_h)
{
    GDALDatasetH ds = GDALCreate(GDALGetDriverByName("GTiff"), path, (int)w, (int)h, 1, GDT_Int16, NULL);
    assert_non_null(ds);
    GDALSetGeoTransform(ds, (double *)GT);
    GDALSetProjection(ds, "EPSG:32633");
    GDALRasterBandH band = GDALGetRasterBand(ds, 1);
    GDALSetRasterNoDataValue(band, -32768);
    int16_t *row = malloc(w * sizeof *row);
    for (uint32_t j = 0; j < h; j++) {
        for (uint32_t i = 0; i < w; i++)
            row[i] = i < keep_w && j < keep_h ? value_at(i, j) : -32768;
        assert_int_equal(GDALRasterIO(band, GF_Write, 0, (int)j, (int)w, 1, row, (int)w, 1, GDT_Int16, 0, 0), CE_None);
    }
    free(row);
    GDALClose(ds);
}

/* Imports in with 16-cell tiles (a job covers 256 cells; the finish builds
 * levels 5 and up from the jobs' level-4 samples) into out. */
static hz_pyr_import_stats import16(const char *in, const char *out)
{
    const char *ins[] = {in};
    hz_pyr_import d = {.out = out, .inputs = ins, .input_count = 1, .tile_cells = 16, .threads = 2};
    hz_pyr_import_stats st;
    hz_err err = {0};
    assert_int_equal(hz_pyramid_import(&d, &st, &err), HZ_OK);
    return st;
}

/* Every tile of a and b decodes to the same samples, validity, apron and LOD
 * bounds; returns how many tiles above level 4 were compared. */
static uint32_t same_tiles(const char *a, const char *b)
{
    hz_pyramid *pa, *pb;
    hz_err err = {0};
    assert_int_equal(hz_pyramid_open(a, &pa, &err), HZ_OK);
    assert_int_equal(hz_pyramid_open(b, &pb, &err), HZ_OK);
    const hz_pyr_info *in = hz_pyramid_info(pa);
    assert_int_equal(in->levels, hz_pyramid_info(pb)->levels);
    assert_true(in->h_scale == hz_pyramid_info(pb)->h_scale && in->h_offset == hz_pyramid_info(pb)->h_offset);
    uint32_t above = 0;
    for (uint32_t l = 0; l < in->levels; l++)
        for (uint32_t tz = 0; tz < hz_pyr_level_tiles(in, l); tz++)
            for (uint32_t tx = 0; tx < hz_pyr_level_tiles(in, l); tx++) {
                hz_pyr_tile ta, tb;
                assert_int_equal(hz_pyramid_read_tile(pa, l, tx, tz, &ta, &err), HZ_OK);
                assert_int_equal(hz_pyramid_read_tile(pb, l, tx, tz, &tb, &err), HZ_OK);
                const size_t n = (size_t)(ta.cells + 1) * (ta.cells + 1), k = ta.nodes;
                assert_memory_equal(ta.h, tb.h, n * sizeof *ta.h);
                assert_memory_equal(ta.apron, tb.apron, (4 * (size_t)ta.cells + 8) * sizeof *ta.apron);
                assert_true((ta.valid == NULL) == (tb.valid == NULL));
                if (ta.valid)
                    assert_memory_equal(ta.valid, tb.valid, n);
                assert_memory_equal(ta.node_delta, tb.node_delta, (k + 2) * (k + 2) * sizeof *ta.node_delta);
                assert_memory_equal(ta.node_min, tb.node_min, k * k * sizeof *ta.node_min);
                assert_memory_equal(ta.node_max, tb.node_max, k * k * sizeof *ta.node_max);
                above += l > 4;
                hz_pyr_tile_free(&ta);
                hz_pyr_tile_free(&tb);
            }
    hz_pyramid_close(pa);
    hz_pyramid_close(pb);
    return above;
}

/* A map narrower than its square: the finish holds the jobs' level-4 samples
 * over the data's box only (700x500 of the padded 1025^2: 44x32 of 65x65),
 * and jobs wholly in the padding (a 1025x100 strip: 12 of 16) read nothing.
 * Both give the same tiles, at every level, LOD bounds and aprons included,
 * as the same samples in a full 1025^2 raster with the padding as explicit
 * nodata (whose box is the whole square and whose jobs all read). */
static void test_finish_holds_the_data_box(void **state)
{
    (void)state;
    char out[600], full[600], fullp[600], strip[600];
    snprintf(out, sizeof out, "%s/pyr_box.hzp", HZ_TEST_TMP);
    snprintf(full, sizeof full, "%s/pyr_box_full.tif", HZ_TEST_TMP);
    snprintf(fullp, sizeof fullp, "%s/pyr_box_full.hzp", HZ_TEST_TMP);
    snprintf(strip, sizeof strip, "%s/pyr_box_strip.tif", HZ_TEST_TMP);
    const hz_pyr_import_stats st = import16(tif, out);
    const uint64_t nodes = (1024 / (8 << 4)) * (1024 / (8 << 4)) * 6; /* level-4 node bounds, 8-cell patches */
    assert_true(st.finish_bytes <= (44 * 32 + 1) * 3 + nodes);
    assert_true(st.finish_bytes < (65 * 65 * 3 + nodes) / 2);
    check_exact(out);
    write_tif(full, 1025, 1025, W, H);
    const hz_pyr_import_stats fst = import16(full, fullp);
    assert_true(fst.finish_bytes >= 65 * 65 * 3 + nodes);
    assert_int_equal(same_tiles(out, fullp), 2 * 2 + 1 + 1); /* levels 5, 6 and 7 */
    /* the strip */
    write_tif(strip, 1025, 100, 1025, 100);
    import16(strip, out);
    write_tif(full, 1025, 1025, 1025, 100);
    import16(full, fullp);
    assert_int_equal(same_tiles(out, fullp), 2 * 2 + 1 + 1);
    unlink(full);
    unlink(fullp);
    unlink(strip);
    unlink(out);
}

static void copy_file(const char *from, const char *to)
{
    FILE *a = fopen(from, "rb"), *b = fopen(to, "wb");
    assert_non_null(a);
    assert_non_null(b);
    char buf[65536];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, a)) > 0)
        assert_int_equal(fwrite(buf, 1, n, b), n);
    fclose(a);
    fclose(b);
}

static void test_corrupt_and_truncated(void **state)
{
    (void)state;
    char bad[600];
    snprintf(bad, sizeof bad, "%s/pyr_bad.hzp", HZ_TEST_TMP);
    copy_file(hzp, bad);
    /* flip one byte of the first tile written (right after the header) */
    FILE *f = fopen(bad, "r+b");
    assert_non_null(f);
    fseek(f, 512 + 40, SEEK_SET);
    int c = fgetc(f);
    fseek(f, 512 + 40, SEEK_SET);
    fputc(c ^ 0x5a, f);
    fclose(f);
    hz_pyramid *p;
    hz_err err = {0};
    assert_int_equal(hz_pyramid_open(bad, &p, &err), HZ_OK); /* header and index intact */
    uint64_t nbad = 0;
    assert_int_not_equal(hz_pyramid_verify(p, &nbad, NULL, NULL, &err), HZ_OK);
    assert_int_equal(nbad, 1);
    assert_non_null(strstr(err.msg, "checksum"));
    hz_pyramid_close(p);
    /* truncated: refused at open */
    copy_file(hzp, bad);
    f = fopen(hzp, "rb");
    fseek(f, 0, SEEK_END);
    long size = ftell(f);
    fclose(f);
    assert_int_equal(truncate(bad, size - 10), 0);
    err = (hz_err){0};
    assert_int_not_equal(hz_pyramid_open(bad, &p, &err), HZ_OK);
    assert_non_null(strstr(err.msg, "truncated"));
    unlink(bad);
}

/* The full-resolution heights, for the mesh checker's positions. */
static void full_heightmap(hz_heightmap *hm)
{
    hz_grid g = {0};
    hz_err err = {0};
    assert_int_equal(hz_grid_alloc(&g, 1025, 1025, &err), HZ_OK);
    for (uint32_t j = 0; j < 1025; j++)
        for (uint32_t i = 0; i < 1025; i++) {
            const int16_t v = i < W && j < H ? value_at(i, j) : 0;
            g.z[j * 1025 + i] = v == -32768 ? 0.0f : (float)v;
        }
    assert_int_equal(hz_heightmap_create(hm, &g, HZ_LAYOUT_LINEAR, &err), HZ_OK);
    hz_grid_free(&g);
}

static void test_stream_crack_free_while_tiles_missing(void **state)
{
    (void)state;
    hz_err err = {0};
    /* the smallest cache: 8 tiles per level */
    hz_stream *s = hz_stream_create(&(hz_stream_desc){.path = hzp, .cache_bytes = 1, .synchronous = true}, &err);
    assert_non_null(s);
    const hz_pyr_info *in = hz_stream_info(s);
    assert_int_equal(hz_stream_slots(s), 8 * in->levels);
    hz_heightmap hm;
    full_heightmap(&hm);
    hz_patch_list pl = {0};
    hz_index_list il = {0};
    uint32_t late_frames = 0, evicted = 0, frames_drawn = 0;
    for (uint32_t f = 0; f < 120; f++) {
        const float u = (float)f / 119.0f;
        hz_camera cam = {.pos = {30.0f * (50.0f + 550.0f * u), 2400.0f - 1000.0f * u, 30.0f * (60.0f + 380.0f * u)},
                         .yaw = 120.0f + 90.0f * u, .pitch = -25.0f, .fov_y = 60.0f, .aspect = 16.0f / 9.0f,
                         .znear = 1.0f, .zfar = 60000.0f};
        hz_lod_stats st;
        /* every third frame with a near bound (3 px within 800 m) */
        const hz_lod_params lp = {.mode = HZ_LOD_CDLOD, .pixel_error = 0.5f,
                                  .near_pixel_error = f % 3 == 1 ? 3.0f : 0.0f, .near_distance = 800.0f};
        assert_int_equal(hz_stream_select(s, &cam, &lp, &pl, &st), HZ_OK);
        assert_true(f % 3 == 1 ? st.morph_near < 0.2f : st.morph_near == 1.0f);
        /* Late tiles: acknowledge at most two decoded tiles per frame. */
        uint32_t slot;
        const uint16_t *tex;
        for (int k = 0; k < 2 && hz_stream_next_upload(s, &slot, &tex); k++) {
            /* the texels carry the tile's heights (channel 0) */
            assert_non_null(tex);
            hz_stream_uploaded(s, slot);
        }
        hz_stream_stats ss = hz_stream_take_stats(s);
        late_frames += ss.late > 0;
        evicted += ss.evicted;
        assert_true(ss.resident <= hz_stream_slots(s));
        if (pl.count == 0)
            continue;
        frames_drawn++;
        il.count = 0;
        assert_int_equal(hz_patches_to_indices(in->size, in->patch_cells, pl.data, pl.count, &il), HZ_OK);
        vec4 planes[6];
        hz_camera_frustum(&cam, planes);
        mesh_report r = mesh_check(&hm, 30.0f, 1.0f, il.data, il.count, (const vec4 *)planes, NULL);
        char label[64];
        snprintf(label, sizeof label, "streamed frame %u", f);
        mesh_assert_valid(&r, false, label);
    }
    /* the test really saw missing tiles and a full cache */
    assert_true(late_frames > 0);
    assert_true(evicted > 0);
    assert_true(frames_drawn > 100);
    free(pl.data);
    free(il.data);
    hz_heightmap_destroy(&hm);
    hz_stream_destroy(s);
}

/* The late count (hz_stream_stats.late: nodes drawn coarser than the LOD
 * wanted because a tile was missing), on a case where the answer is known.
 * 1025^2 in 64-cell tiles: levels 0..3 have 16^2, 8^2, 4^2, 2^2 tiles, the
 * levels above one; the cache starts with levels 3 and up. Frame A: a node of shift 3 that wants to
 * split cannot (its level-2 tile is missing), so it is late, and nothing else
 * is (shifts 4 and up split over resident tiles). Then level 2 alone is made
 * resident; in frame B a shift-3 node splits exactly when it wants to (level
 * 2 is resident, and no shift-2 node can split and force one: level 1 is
 * missing). So late(A) = A's shift-3 leaves that B splits. Once everything
 * is resident nothing is late. */
static void test_stream_late_count(void **state)
{
    (void)state;
    hz_err err = {0};
    hz_stream *s = hz_stream_create(&(hz_stream_desc){.path = hzp, .synchronous = true}, &err);
    assert_non_null(s);
    const hz_pyr_info *in = hz_stream_info(s);
    assert_int_equal(hz_pyr_level_tiles(in, 2), 4); /* levels 3 and up (2 x 2 tiles or fewer) load at creation */
    assert_int_equal(hz_pyr_level_tiles(in, 3), 2);
    const hz_camera cam = {.pos = {30.0f * 300.0f, 1900.0f, 30.0f * 420.0f}, .yaw = 60.0f, .pitch = -20.0f,
                           .fov_y = 60.0f, .aspect = 16.0f / 9.0f, .znear = 1.0f, .zfar = 60000.0f};
    const hz_lod_params lp = {.mode = HZ_LOD_CDLOD, .pixel_error = 1.0f, .viewport_height = 720};
    hz_patch_list pl = {0};
    hz_lod_stats st;
    uint32_t slot, lv, tx, tz, up = 0;
    const uint16_t *tex;
    while (hz_stream_next_upload(s, &slot, &tex)) { /* the tiles loaded at creation */
        hz_stream_tile_key(s, slot, &lv, &tx, &tz);
        assert_true(lv >= 3);
        hz_stream_uploaded(s, slot);
    }
    hz_stream_take_stats(s);
    /* frame A: levels 3 and up */
    assert_int_equal(hz_stream_select(s, &cam, &lp, &pl, &st), HZ_OK);
    hz_stream_stats a = hz_stream_take_stats(s);
    assert_int_equal(a.drawn, pl.count);
    for (size_t k = 0; k < pl.count; k++)
        assert_true(pl.data[k].shift >= 3);
    const uint32_t G3 = in->patch_cells << 3; /* a shift-3 node's side, samples */
    uint32_t a3[256], na3 = 0;
    for (size_t k = 0; k < pl.count; k++)
        if (pl.data[k].shift == 3 && na3 < 256)
            a3[na3++] = (pl.data[k].z0 / G3) * 1024u + pl.data[k].x0 / G3;
    assert_true(na3 > 0 && na3 < 256);
    /* level 2 only becomes resident */
    while (hz_stream_next_upload(s, &slot, &tex)) {
        hz_stream_tile_key(s, slot, &lv, &tx, &tz);
        assert_int_equal(lv, 2); /* frame A asked for level-2 tiles only */
        hz_stream_uploaded(s, slot);
        up++;
    }
    assert_true(up > 0);
    hz_stream_take_stats(s);
    /* frame B: levels 2 and up */
    assert_int_equal(hz_stream_select(s, &cam, &lp, &pl, &st), HZ_OK);
    hz_stream_stats b = hz_stream_take_stats(s);
    assert_int_equal(b.drawn, pl.count);
    /* A's shift-3 leaves that B splits (no longer drawn at shift 3; the
     * same camera culls the same nodes) */
    uint32_t np = 0;
    for (uint32_t i = 0; i < na3; i++) {
        bool leaf = false;
        for (size_t k = 0; k < pl.count && !leaf; k++)
            leaf = pl.data[k].shift == 3 && a3[i] == (pl.data[k].z0 / G3) * 1024u + pl.data[k].x0 / G3;
        np += !leaf;
    }
    printf("late: frame A %u of %u nodes; frame B splits %u shift-3 nodes, %u of %u late\n", a.late, a.drawn, np,
           b.late, b.drawn);
    assert_true(a.late > 0 && a.late < a.drawn);
    assert_int_equal(a.late, np);
    /* everything resident: nothing late */
    for (int f = 0; f < 40; f++) {
        while (hz_stream_next_upload(s, &slot, &tex))
            hz_stream_uploaded(s, slot);
        assert_int_equal(hz_stream_select(s, &cam, &lp, &pl, &st), HZ_OK);
    }
    hz_stream_stats z = hz_stream_take_stats(s);
    hz_stream_select(s, &cam, &lp, &pl, &st);
    z = hz_stream_take_stats(s);
    assert_int_equal(z.requested, 0);
    assert_int_equal(z.late, 0);
    assert_int_equal(z.drawn, pl.count);
    free(pl.data);
    hz_stream_destroy(s);
}

/* Float input with --max-error stays within it, sample for sample. */
static void test_lossy_within_max_error(void **state)
{
    (void)state;
    char ftif[600], fhzp[600];
    snprintf(ftif, sizeof ftif, "%s/pyr_float.tif", HZ_TEST_TMP);
    snprintf(fhzp, sizeof fhzp, "%s/pyr_float.hzp", HZ_TEST_TMP);
    enum { FW = 300, FH = 211 };
    GDALDatasetH ds = GDALCreate(GDALGetDriverByName("GTiff"), ftif, FW, FH, 1, GDT_Float32, NULL);
    assert_non_null(ds);
    GDALSetGeoTransform(ds, (double *)GT);
    float *z = malloc((size_t)FW * FH * sizeof *z);
    for (uint32_t j = 0; j < FH; j++)
        for (uint32_t i = 0; i < FW; i++)
            z[j * FW + i] = (float)(1234.567 + 2100.0 * sin(i * 0.021) * sin(j * 0.033) + 0.37 * (double)((i * 31 + j * 17) % 29));
    assert_int_equal(GDALRasterIO(GDALGetRasterBand(ds, 1), GF_Write, 0, 0, FW, FH, z, FW, FH, GDT_Float32, 0, 0), CE_None);
    GDALClose(ds);
    const char *ins[] = {ftif};
    hz_err err = {0};
    const double me = 0.5;
    hz_pyr_import d = {.out = fhzp, .inputs = ins, .input_count = 1, .tile_cells = 64, .max_error = me};
    hz_pyr_import_stats st;
    assert_int_equal(hz_pyramid_import(&d, &st, &err), HZ_OK);
    assert_true(st.max_error <= me);
    hz_pyramid *p;
    assert_int_equal(hz_pyramid_open(fhzp, &p, &err), HZ_OK);
    const hz_pyr_info *in = hz_pyramid_info(p);
    double worst = 0;
    for (uint32_t tz = 0; tz < hz_pyr_level_tiles(in, 0); tz++)
        for (uint32_t tx = 0; tx < hz_pyr_level_tiles(in, 0); tx++) {
            hz_pyr_tile t;
            assert_int_equal(hz_pyramid_read_tile(p, 0, tx, tz, &t, &err), HZ_OK);
            for (uint32_t b = 0; b <= t.cells; b++)
                for (uint32_t a = 0; a <= t.cells; a++) {
                    const uint32_t i = t.x0 + a, j = t.z0 + b;
                    if (i >= FW || j >= FH)
                        continue;
                    const double got = in->h_offset + in->h_scale * t.h[(size_t)b * (t.cells + 1) + a];
                    const double e = fabs(got - (double)z[j * FW + i]);
                    worst = e > worst ? e : worst;
                }
            hz_pyr_tile_free(&t);
        }
    assert_true(worst <= me + 1e-6);
    assert_true(worst > 0.1); /* really lossy: the step is 2 x max error */
    assert_true(fabs(in->max_error - worst) < 1e-3);
    hz_pyramid_close(p);
    free(z);
    unlink(ftif);
    unlink(fhzp);
}

static bool same_bytes(const char *a, const char *b)
{
    FILE *f = fopen(a, "rb"), *g = fopen(b, "rb");
    bool same = f && g;
    while (same) {
        int x = fgetc(f), y = fgetc(g);
        same = x == y;
        if (x == EOF || y == EOF)
            break;
    }
    if (f)
        fclose(f);
    if (g)
        fclose(g);
    return same;
}

/* Jobs run apart (--tiles) and joined (--finish) give the one-run file. */
static void test_jobs_byte_identical(void **state)
{
    (void)state;
    char one[600], many[600];
    snprintf(one, sizeof one, "%s/pyr_one.hzp", HZ_TEST_TMP);
    snprintf(many, sizeof many, "%s/pyr_many.hzp", HZ_TEST_TMP);
    const char *ins[] = {tif};
    hz_err err = {0};
    hz_pyr_import d = {.out = one, .inputs = ins, .input_count = 1, .tile_cells = 16, .threads = 2};
    assert_int_equal(hz_pyramid_jobs(&d, &err), 16);
    assert_int_equal(hz_pyramid_import(&d, NULL, &err), HZ_OK);
    d.out = many;
    d.threads = 1;
    /* out of order, uneven ranges */
    const char *ranges[] = {"6-15", "0-0", "1-5"};
    for (int k = 0; k < 3; k++) {
        d.tiles = ranges[k];
        assert_int_equal(hz_pyramid_import(&d, NULL, &err), HZ_OK);
    }
    d.tiles = NULL;
    /* a missing part is named */
    char part[700];
    snprintf(part, sizeof part, "%s.part-000001-000005", many);
    char hold[760];
    snprintf(hold, sizeof hold, "%s.held", part);
    assert_int_equal(rename(part, hold), 0);
    d.finish = true;
    assert_int_not_equal(hz_pyramid_import(&d, NULL, &err), HZ_OK);
    assert_non_null(strstr(err.msg, "missing"));
    assert_int_equal(rename(hold, part), 0);
    assert_int_equal(hz_pyramid_import(&d, NULL, &err), HZ_OK);
    assert_true(same_bytes(one, many));
    assert_int_not_equal(access(part, F_OK), 0); /* the parts are gone */
    hz_pyramid *p;
    assert_int_equal(hz_pyramid_open(many, &p, &err), HZ_OK);
    uint64_t bad = 9;
    assert_int_equal(hz_pyramid_verify(p, &bad, NULL, NULL, &err), HZ_OK);
    assert_int_equal(bad, 0);
    hz_pyramid_close(p);
    unlink(one);
    unlink(many);
}

/* The morph data of a sample is the same in every tile that holds it (else
 * a morphing vertex would open a crack between two patches). */
static void test_texels_agree_across_tiles(void **state)
{
    (void)state;
    hz_err err = {0};
    hz_stream *s = hz_stream_create(&(hz_stream_desc){.path = hzp, .cache_bytes = 1ull << 30, .synchronous = true},
                                    &err);
    assert_non_null(s);
    const hz_pyr_info *in = hz_stream_info(s);
    const uint32_t N = in->size;
    uint32_t *seen = calloc((size_t)N * N, sizeof *seen); /* q | t2 << 16 packed as q + 1 */
    uint32_t *seen_t2 = calloc((size_t)N * N, sizeof *seen_t2);
    hz_patch_list pl = {0};
    uint64_t compared = 0, tiles = 0;
    for (uint32_t f = 0; f < 40; f++) {
        const float u = (float)f / 39.0f;
        hz_camera cam = {.pos = {30.0f * (20.0f + 600.0f * u), 300.0f, 30.0f * (20.0f + 450.0f * u)},
                         .yaw = 135.0f, .pitch = -20.0f, .fov_y = 60.0f, .aspect = 16.0f / 9.0f, .znear = 1.0f,
                         .zfar = 60000.0f};
        hz_stream_select(s, &cam, &(hz_lod_params){.mode = HZ_LOD_CDLOD, .pixel_error = 0.25f}, &pl, NULL);
        uint32_t slot;
        const uint16_t *tex;
        while (hz_stream_next_upload(s, &slot, &tex)) {
            /* which tile: find it among the patches is not possible before use;
             * the texels carry the heights, so match samples by the info */
            tiles++;
            uint32_t l, tx, tz;
            hz_stream_tile_key(s, slot, &l, &tx, &tz);
            const uint32_t c = hz_pyr_level_cells(in, l), T1 = hz_stream_texels(s);
            for (uint32_t b = 0; b <= c; b++)
                for (uint32_t a = 0; a <= c; a++) {
                    const uint32_t X = ((tx * c) << l) + (a << l), Z = ((tz * c) << l) + (b << l);
                    const uint16_t *o = tex + ((size_t)(b + 1) * T1 + a + 1) * 4; /* the apron around */
                    const size_t k = (size_t)Z * N + X;
                    const uint32_t t2 = o[2] | ((uint32_t)(o[3] & 1u) << 16);
                    if (seen[k]) {
                        assert_int_equal(seen[k], (uint32_t)o[1] + 1u);
                        assert_int_equal(seen_t2[k], t2);
                        compared++;
                    } else {
                        seen[k] = (uint32_t)o[1] + 1u;
                        seen_t2[k] = t2;
                    }
                }
            hz_stream_uploaded(s, slot);
        }
    }
    assert_true(tiles > 20);
    assert_true(compared > 10000);
    free(seen);
    free(seen_t2);
    free(pl.data);
    hz_stream_destroy(s);
}

/* Earth curvature on the streamed path: with every tile loaded, the patches
 * of a curved camera cover every sample whose curved position is in view. A
 * low telephoto whose top plane is level: hills just above the eye, outside
 * a flat view, sink into it (node boxes that were not lowered would be culled). */
static void test_stream_curved_culling(void **state)
{
    (void)state;
    hz_err err = {0};
    hz_stream *s = hz_stream_create(&(hz_stream_desc){.path = hzp, .cache_bytes = 1ull << 30, .synchronous = true},
                                    &err);
    assert_non_null(s);
    const hz_pyr_info *in = hz_stream_info(s);
    hz_heightmap hm;
    full_heightmap(&hm);
    hz_patch_list pl = {0};
    hz_index_list il = {0};
    float *surf = malloc(sizeof(float) * 1025 * 1025);
    uint64_t sunk_in = 0, checked = 0;
    for (int k = 0; k < 24; k++) {
        hz_camera cam = {.pos = {30.0f * 2, 150.0f + 60.0f * (float)k, 30.0f * (60.0f + 17.0f * (float)k)},
                         .yaw = 90.0f, .pitch = -2.0f, .fov_y = 4.0f, .aspect = 16.0f / 9.0f, .znear = 1.0f,
                         .zfar = 60000.0f, .earth_radius = 6371008.8f};
        /* Select until every wanted tile is resident. */
        for (int round = 0; round < 64; round++) {
            assert_int_equal(hz_stream_select(s, &cam, &(hz_lod_params){.mode = HZ_LOD_CDLOD, .pixel_error = 1}, &pl,
                                              NULL),
                             HZ_OK);
            uint32_t slot, n = 0;
            const uint16_t *tex;
            while (hz_stream_next_upload(s, &slot, &tex)) {
                hz_stream_uploaded(s, slot);
                n++;
            }
            if (!n && round > 0)
                break;
        }
        il.count = 0;
        assert_int_equal(hz_patches_to_indices(in->size, in->patch_cells, pl.data, pl.count, &il), HZ_OK);
        assert_int_equal(hz_metrics_surface(&hm, 1.0f, il.data, il.count, NULL, NULL, surf), HZ_OK);
        vec4 planes[6];
        hz_camera_frustum(&cam, planes);
        for (uint32_t j = 0; j < H; j++)
            for (uint32_t i = 0; i < W; i++) {
                if (value_at(i, j) == -32768)
                    continue;
                const float x = 30.0f * (float)i, z = 30.0f * (float)j, y = (float)value_at(i, j);
                const float p[3] = {x, y - hz_camera_drop(&cam, x, z), z};
                float inside = INFINITY, flat_inside = INFINITY;
                for (int q = 0; q < 6; q++) {
                    inside = fminf(inside, planes[q][0] * p[0] + planes[q][1] * p[1] + planes[q][2] * p[2] + planes[q][3]);
                    flat_inside = fminf(flat_inside, planes[q][0] * x + planes[q][1] * y + planes[q][2] * z + planes[q][3]);
                }
                if (inside <= 0.5f)
                    continue;
                checked++;
                sunk_in += flat_inside < 0;
                if (isnan(surf[(size_t)j * 1025 + i]))
                    fail_msg("camera %d: sample (%u, %u) is drawn %.2f m inside the view but no patch covers it", k, i,
                             j, (double)inside);
            }
    }
    printf("curved stream: %llu samples in view covered, %llu of them outside a flat view\n",
           (unsigned long long)checked, (unsigned long long)sunk_in);
    assert_true(checked > 1000 && sunk_in > 100);
    free(surf);
    free(pl.data);
    free(il.data);
    hz_heightmap_destroy(&hm);
    hz_stream_destroy(s);
}

/* ---- --wrap ---- */

typedef struct vkey {
    int64_t x, z;
} vkey;

static uint64_t vhash(int64_t x, int64_t z)
{
    return ((uint64_t)x * 0x9e3779b97f4a7c15ULL) ^ ((uint64_t)z * 0xc2b2ae3d27d4eb4fULL);
}

typedef struct vset {
    vkey *k;
    uint8_t *used;
    size_t cap;
} vset;

static void vset_add(vset *v, int64_t x, int64_t z)
{
    for (size_t h = vhash(x, z) & (v->cap - 1);; h = (h + 1) & (v->cap - 1)) {
        if (!v->used[h]) {
            v->used[h] = 1, v->k[h] = (vkey){x, z};
            return;
        }
        if (v->k[h].x == x && v->k[h].z == z)
            return;
    }
}

static bool vset_has(const vset *v, int64_t x, int64_t z)
{
    for (size_t h = vhash(x, z) & (v->cap - 1);; h = (h + 1) & (v->cap - 1)) {
        if (!v->used[h])
            return false;
        if (v->k[h].x == x && v->k[h].z == z)
            return true;
    }
}

typedef struct ekey {
    int64_t a[2], b[2];
    uint32_t n;
} ekey;

/* Triangles of the patches in sample coordinates (images included), as the
 * vertex shader places them (stitched edges). */
static size_t patch_tris(const hz_patch *p, size_t count, uint32_t P, int64_t (**out)[2])
{
    int64_t(*t)[2] = malloc(count * P * P * 6 * sizeof *t);
    size_t n = 0;
    for (size_t k = 0; k < count; k++) {
        const int64_t x0 = (int32_t)p[k].x0, z0 = (int32_t)p[k].z0, st = (int64_t)1 << p[k].shift;
        for (uint32_t w = 0; w < P; w++)
            for (uint32_t u = 0; u < P; u++) {
                int64_t vx[4], vz[4];
                const uint32_t cu[4] = {u, u, u + 1, u + 1}, cw[4] = {w, w + 1, w, w + 1};
                for (int c = 0; c < 4; c++) {
                    uint32_t uu = cu[c], ww = cw[c];
                    if ((uu & 1) && ((ww == 0 && (p[k].coarse & 4)) || (ww == P && (p[k].coarse & 8))))
                        uu--;
                    if ((ww & 1) && ((uu == 0 && (p[k].coarse & 1)) || (uu == P && (p[k].coarse & 2))))
                        ww--;
                    vx[c] = x0 + uu * st, vz[c] = z0 + ww * st;
                }
                uint32_t tri[6];
                hz_lod_cell_triangles(((u + w) & 1u) == 0, 0, 1, 2, 3, tri);
                for (int q = 0; q < 6; q += 3) {
                    const uint32_t a = tri[q], b = tri[q + 1], c = tri[q + 2];
                    if ((vx[a] == vx[b] && vz[a] == vz[b]) || (vx[b] == vx[c] && vz[b] == vz[c]) ||
                        (vx[a] == vx[c] && vz[a] == vz[c]))
                        continue;
                    t[n][0] = vx[a], t[n][1] = vz[a], t[n + 1][0] = vx[b], t[n + 1][1] = vz[b];
                    t[n + 2][0] = vx[c], t[n + 2][1] = vz[c];
                    n += 3;
                }
            }
    }
    *out = t;
    return n;
}

static int cmp_edge(const void *x, const void *y)
{
    const ekey *a = x, *b = y;
    for (int k = 0; k < 2; k++) {
        if (a->a[k] != b->a[k])
            return a->a[k] < b->a[k] ? -1 : 1;
    }
    for (int k = 0; k < 2; k++)
        if (a->b[k] != b->b[k])
            return a->b[k] < b->b[k] ? -1 : 1;
    return 0;
}

/* A repeating terrain: the seam's samples are equal, its slope like any
 * other, and the streamed mesh across it has no T-junction, no overlap and
 * no hole near the eye; the same sample has the same morph data on both
 * sides of the seam. */
static void test_wrap_seamless(void **state)
{
    (void)state;
    char whzp[600];
    snprintf(whzp, sizeof whzp, "%s/pyr_wrap.hzp", HZ_TEST_TMP);
    hz_err err = {0};
    hz_pyr_import d = {.out = whzp, .generate = true, .gen = {.kind = HZ_GEN_PERLIN, .size = 1025, .seed = 11},
                       .tile_cells = 64, .wrap = true};
    assert_int_equal(hz_pyramid_import(&d, NULL, &err), HZ_OK);
    /* a DEM that is not square 2^k+1 is refused */
    const char *ins[] = {tif};
    hz_pyr_import bad = {.out = whzp, .inputs = ins, .input_count = 1, .wrap = true};
    assert_int_not_equal(hz_pyramid_import(&bad, NULL, &err), HZ_OK);
    assert_non_null(strstr(err.msg, "square"));
    /* heights across the seam */
    hz_pyramid *p;
    assert_int_equal(hz_pyramid_open(whzp, &p, &err), HZ_OK);
    const hz_pyr_info info = *hz_pyramid_info(p); /* used after the close below */
    const hz_pyr_info *in = &info;
    assert_true(in->wrap);
    const uint32_t N = in->size, m = hz_pyr_level_tiles(in, 0), c = hz_pyr_level_cells(in, 0);
    uint16_t *hh = malloc((size_t)N * N * sizeof *hh);
    for (uint32_t tz = 0; tz < m; tz++)
        for (uint32_t tx = 0; tx < m; tx++) {
            hz_pyr_tile t;
            assert_int_equal(hz_pyramid_read_tile(p, 0, tx, tz, &t, &err), HZ_OK);
            for (uint32_t b = 0; b <= c; b++)
                for (uint32_t a = 0; a <= c; a++)
                    hh[(size_t)(t.z0 + b) * N + t.x0 + a] = t.h[(size_t)b * (c + 1) + a];
            hz_pyr_tile_free(&t);
        }
    hz_pyramid_close(p);
    int max_in = 0, max_seam = 0;
    for (uint32_t j = 0; j < N; j++) {
        assert_int_equal(hh[(size_t)j * N + N - 1], hh[(size_t)j * N]); /* x seam: the same samples */
        assert_int_equal(hh[(size_t)(N - 1) * N + j], hh[j]);           /* z seam */
        for (uint32_t i = 0; i + 2 < N; i++) {
            const int dd = abs((int)hh[(size_t)j * N + i + 1] - (int)hh[(size_t)j * N + i]);
            max_in = dd > max_in ? dd : max_in;
        }
        const int ds = abs((int)hh[(size_t)j * N + N - 1] - (int)hh[(size_t)j * N + N - 2]);
        max_seam = ds > max_seam ? ds : max_seam;
    }
    assert_true(max_seam <= max_in); /* continuous: no step at the seam */
    free(hh);

    hz_stream *s = hz_stream_create(&(hz_stream_desc){.path = whzp, .cache_bytes = 1ull << 30, .synchronous = true},
                                    &err);
    assert_non_null(s);
    const int64_t per = N - 1;
    uint32_t *seen = calloc((size_t)per * per, sizeof *seen), *seen2 = calloc((size_t)per * per, sizeof *seen2);
    hz_patch_list pl = {0};
    const float cams[][4] = {{5, 9000, 600, 270}, {10230, 8000, 300, 45}, {5120, 20, 1200, 0}, {3, 10237, 400, 225}};
    uint64_t compared = 0;
    for (int cc = 0; cc < 4; cc++) {
        hz_camera cam = {.pos = {cams[cc][0], cams[cc][2], cams[cc][1]}, .yaw = cams[cc][3], .pitch = -20.0f,
                         .fov_y = 60.0f, .aspect = 16.0f / 9.0f, .znear = 1.0f, .zfar = 60000.0f};
        hz_stream_wrap_camera(s, &cam);
        for (int f = 0; f < 30; f++) {
            hz_lod_stats st;
            assert_int_equal(hz_stream_select(s, &cam, &(hz_lod_params){.mode = HZ_LOD_CDLOD, .pixel_error = 0.5f,
                                                                       .no_cull = true},
                                              &pl, &st),
                             HZ_OK);
            uint32_t slot;
            const uint16_t *tex;
            bool any = false;
            while (hz_stream_next_upload(s, &slot, &tex)) {
                uint32_t l, tx, tz;
                hz_stream_tile_key(s, slot, &l, &tx, &tz);
                const uint32_t tc = hz_pyr_level_cells(in, l), T1 = hz_stream_texels(s);
                for (uint32_t b = 0; b <= tc; b++)
                    for (uint32_t a = 0; a <= tc; a++) {
                        const int64_t X = (((int64_t)tx * tc) << l) + (a << l), Z = (((int64_t)tz * tc) << l) + (b << l);
                        const size_t k = (size_t)(Z % per) * per + (size_t)(X % per);
                        const uint16_t *o = tex + ((size_t)(b + 1) * T1 + a + 1) * 4; /* the apron around */
                        const uint32_t t2 = o[2] | ((uint32_t)(o[3] & 1u) << 16);
                        if (seen[k]) {
                            assert_int_equal(seen[k], (uint32_t)o[1] + 1u);
                            assert_int_equal(seen2[k], t2);
                            compared++;
                        } else {
                            seen[k] = (uint32_t)o[1] + 1u, seen2[k] = t2;
                        }
                    }
                hz_stream_uploaded(s, slot);
                any = true;
            }
            if (!any)
                break;
        }
        /* the mesh around the eye, across the seam */
        int64_t(*tri)[2];
        const size_t nv = patch_tris(pl.data, pl.count, in->patch_cells, &tri);
        assert_true(nv > 300);
        vset vs = {.cap = 1};
        while (vs.cap < 4 * nv)
            vs.cap *= 2;
        vs.k = malloc(vs.cap * sizeof *vs.k);
        vs.used = calloc(vs.cap, 1);
        ekey *e = malloc(nv * sizeof *e);
        for (size_t k = 0; k < nv; k++) {
            vset_add(&vs, tri[k][0], tri[k][1]);
            const size_t a = k, b = (k % 3 == 2) ? k - 2 : k + 1;
            const bool lt = tri[a][0] < tri[b][0] || (tri[a][0] == tri[b][0] && tri[a][1] < tri[b][1]);
            const size_t lo = lt ? a : b, hi = lt ? b : a;
            e[k] = (ekey){{tri[lo][0], tri[lo][1]}, {tri[hi][0], tri[hi][1]}, 1};
        }
        qsort(e, nv, sizeof *e, cmp_edge);
        const double ex = cam.pos[0] / 10.0, ez = cam.pos[2] / 10.0;
        size_t tj = 0, over2 = 0, holes = 0;
        for (size_t k = 0; k < nv;) {
            size_t r = 1;
            while (k + r < nv && !cmp_edge(&e[k], &e[k + r]))
                r++;
            if (r > 2)
                over2++;
            if (r == 1) {
                /* a drawn vertex strictly inside an edge used once: a T-junction */
                const int64_t dx = e[k].b[0] - e[k].a[0], dz = e[k].b[1] - e[k].a[1];
                const int64_t g = llabs(dx) > llabs(dz) ? llabs(dx) : llabs(dz);
                for (int64_t q = 1; q < g; q++)
                    if ((dx * q) % g == 0 && (dz * q) % g == 0 &&
                        vset_has(&vs, e[k].a[0] + dx * q / g, e[k].a[1] + dz * q / g)) {
                        if (tj < 5 && getenv("HZ_TEST_VERBOSE"))
                            fprintf(stderr, "T-junction on edge (%lld,%lld)-(%lld,%lld), eye (%.0f,%.0f)\n",
                                    (long long)e[k].a[0], (long long)e[k].a[1], (long long)e[k].b[0],
                                    (long long)e[k].b[1], ex, ez);
                        tj++;
                        break;
                    }
                /* an open edge near the eye: a hole */
                const double mx = 0.5 * (double)(e[k].a[0] + e[k].b[0]), mz = 0.5 * (double)(e[k].a[1] + e[k].b[1]);
                if (fabs(mx - ex) < (double)per / 4.0 && fabs(mz - ez) < (double)per / 4.0)
                    holes++;
            }
            k += r;
        }
        if (tj || over2 || holes)
            fprintf(stderr, "wrap camera %d: %zu T-junctions, %zu edges over two, %zu holes near the eye\n", cc, tj,
                    over2, holes);
        assert_int_equal(tj, 0);
        assert_int_equal(over2, 0);
        assert_int_equal(holes, 0);
        free(tri);
        free(e);
        free(vs.k);
        free(vs.used);
    }
    assert_true(compared > 1000);
    free(seen);
    free(seen2);
    free(pl.data);
    hz_stream_destroy(s);
    unlink(whzp);
}

/* Tiles that arrive slide in (their nodes start at the parent's shape), and
 * the shader's crack-freeness rests on what the selection hands it: two
 * leaves of one level sharing an edge agree on its slide value, an edge
 * toward a finer leaf has none, a tile starts at 255 and reaches 0 after
 * slide_seconds of the stream's clock. */
static void test_slide_in_edges_agree(void **state)
{
    (void)state;
    hz_err err = {0};
    hz_stream *s = hz_stream_create(&(hz_stream_desc){.path = hzp, .cache_bytes = 64u << 20, .synchronous = true,
                                                      .slide_seconds = 0.5f},
                                    &err);
    assert_non_null(s);
    const hz_pyr_info *in = hz_stream_info(s);
    const uint32_t P = in->patch_cells;
    hz_patch_list pl = {0};
    uint32_t sliding = 0, fresh = 0, shared = 0, toward_finer = 0;
    for (uint32_t f = 0; f < 90; f++) {
        const float u = (float)f / 89.0f;
        hz_camera cam = {.pos = {30.0f * (50.0f + 550.0f * u), 2400.0f - 1000.0f * u, 30.0f * (60.0f + 380.0f * u)},
                         .yaw = 120.0f + 90.0f * u, .pitch = -25.0f, .fov_y = 60.0f, .aspect = 16.0f / 9.0f,
                         .znear = 1.0f, .zfar = 60000.0f};
        const double clock = f / 30.0; /* 30 frames per second */
        hz_stream_set_clock(s, clock);
        hz_lod_stats st;
        assert_int_equal(hz_stream_select(s, &cam, &(hz_lod_params){.mode = HZ_LOD_CDLOD, .pixel_error = 0.5f}, &pl,
                                          &st),
                         HZ_OK);
        uint32_t slot;
        const uint16_t *tex;
        for (int k = 0; k < 3 && hz_stream_next_upload(s, &slot, &tex); k++)
            hz_stream_uploaded(s, slot);
        for (size_t a = 0; a < pl.count; a++) {
            const hz_patch *p = &pl.data[a];
            sliding += p->slide > 0 && p->slide < 255;
            fresh += p->slide == 255;
            for (size_t b = 0; b < pl.count; b++) {
                const hz_patch *q = &pl.data[b];
                const int64_t sp = (int64_t)P << p->shift, sq = (int64_t)P << q->shift;
                const int64_t px = p->x0, pz = p->z0, qx = q->x0, qz = q->z0;
                /* q across p's east edge (dir 1), or p's south edge (dir 3) */
                for (int dir = 1; dir <= 3; dir += 2) {
                    const bool touches = dir == 1 ? (qx == px + sp && qz < pz + sp && qz + sq > pz)
                                                  : (qz == pz + sp && qx < px + sp && qx + sq > px);
                    if (!touches)
                        continue;
                    if (q->shift == p->shift) { /* same level: both sides agree */
                        assert_int_equal(p->slide_edge[dir], q->slide_edge[dir - 1]);
                        shared += p->slide_edge[dir] > 0;
                    } else if (q->shift < p->shift) { /* q finer: p's edge does not slide */
                        assert_int_equal(p->slide_edge[dir], 0);
                        toward_finer++;
                    } else { /* p finer */
                        assert_int_equal(q->slide_edge[dir - 1], 0);
                        toward_finer++;
                    }
                }
            }
        }
    }
    /* the flight really saw tiles arrive and slide, and shared sliding edges */
    assert_true(fresh > 0);
    assert_true(sliding > 0);
    assert_true(shared > 0);
    assert_true(toward_finer > 0);
    /* standing still for longer than the slide: everything has slid in */
    hz_camera cam = {.pos = {30.0f * 600.0f, 1400.0f, 30.0f * 440.0f}, .yaw = 210.0f, .pitch = -25.0f, .fov_y = 60.0f,
                     .aspect = 16.0f / 9.0f, .znear = 1.0f, .zfar = 60000.0f};
    for (int k = 0; k < 3; k++) {
        hz_stream_set_clock(s, 100.0 + k);
        assert_int_equal(hz_stream_select(s, &cam, &(hz_lod_params){.mode = HZ_LOD_CDLOD, .pixel_error = 0.5f}, &pl,
                                          NULL),
                         HZ_OK);
        uint32_t slot;
        const uint16_t *tex;
        while (hz_stream_next_upload(s, &slot, &tex))
            hz_stream_uploaded(s, slot);
    }
    hz_stream_set_clock(s, 110.0);
    assert_int_equal(
        hz_stream_select(s, &cam, &(hz_lod_params){.mode = HZ_LOD_CDLOD, .pixel_error = 0.5f}, &pl, NULL), HZ_OK);
    for (size_t a = 0; a < pl.count; a++) {
        assert_int_equal(pl.data[a].slide, 0);
        for (int d = 0; d < 4; d++)
            assert_int_equal(pl.data[a].slide_edge[d], 0);
    }
    free(pl.data);
    hz_stream_destroy(s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_round_trip_exact),
        cmocka_unit_test(test_encoder_reused_same_bytes),
        cmocka_unit_test(test_finish_holds_the_data_box),
        cmocka_unit_test(test_corrupt_and_truncated),
        cmocka_unit_test(test_stream_crack_free_while_tiles_missing),
        cmocka_unit_test(test_stream_late_count),
        cmocka_unit_test(test_jobs_byte_identical),
        cmocka_unit_test(test_lossy_within_max_error),
        cmocka_unit_test(test_texels_agree_across_tiles),
        cmocka_unit_test(test_wrap_seamless),
        cmocka_unit_test(test_slide_in_edges_agree),
        cmocka_unit_test(test_stream_curved_culling),
    };
    return cmocka_run_group_tests(tests, setup, NULL);
}
