/* horizon/safety.h and the memory budget of the loaders: sizes, the budget
 * refusal, file identity, atomic outputs, and the 298-byte file that asked
 * for 17 GB (issue 14, defect 1). */
#define _DEFAULT_SOURCE
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <png.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "horizon/blob.h"
#include "horizon/safety.h"
#include "horizon/terrain.h"
#include "io_fixtures.h"

static void test_size_parse(void **state)
{
    (void)state;
    uint64_t v = 0;
    assert_true(hz_size_parse("512M", 0, UINT64_MAX / 2, &v));
    assert_int_equal(v, (uint64_t)512 << 20);
    assert_true(hz_size_parse("1.5G", 0, UINT64_MAX / 2, &v));
    assert_int_equal(v, (uint64_t)3 << 29);
    assert_true(hz_size_parse("8g", 0, UINT64_MAX / 2, &v));
    assert_int_equal(v, (uint64_t)8 << 30);
    assert_true(hz_size_parse("2TB", 0, UINT64_MAX / 2, &v));
    assert_int_equal(v, (uint64_t)2 << 40);
    assert_true(hz_size_parse("4096", 0, UINT64_MAX / 2, &v));
    assert_int_equal(v, 4096);
    /* Both ends of a range are accepted, just outside refused. */
    assert_true(hz_size_parse("1M", (uint64_t)1 << 20, (uint64_t)1 << 50, &v));
    assert_true(hz_size_parse("1024T", (uint64_t)1 << 20, (uint64_t)1 << 50, &v));
    assert_false(hz_size_parse("1023K", (uint64_t)1 << 20, (uint64_t)1 << 50, &v));
    assert_false(hz_size_parse("1025T", (uint64_t)1 << 20, (uint64_t)1 << 50, &v));
    const char *bad[] = {"", "-1G", "+1G", "1X", "1GG", "G", "nan", "inf", "1e400", "1 G", "0x10"};
    for (size_t k = 0; k < sizeof bad / sizeof *bad; k++) {
        v = 77;
        if (hz_size_parse(bad[k], 0, UINT64_MAX / 2, &v))
            fail_msg("'%s' accepted as %llu", bad[k], (unsigned long long)v);
        assert_int_equal(v, 77);
    }
}

static void test_mem_check(void **state)
{
    (void)state;
    hz_err err = {0};
    assert_int_equal(hz_mem_check((uint64_t)1 << 30, (uint64_t)1 << 30, "x", &err), HZ_OK);
    assert_int_equal(hz_mem_check(((uint64_t)1 << 30) + 1, (uint64_t)1 << 30, "a 9x9 grid", &err), HZ_ERR_MEMORY);
    assert_non_null(strstr(err.msg, "a 9x9 grid"));
    assert_non_null(strstr(err.msg, "1.0 GB"));
    assert_non_null(strstr(err.msg, "--max-memory"));
    /* 0 = the default: half the RAM, never 0. */
    assert_true(hz_mem_budget_default() > ((uint64_t)64 << 20));
    assert_int_equal(hz_mem_check(hz_mem_budget_default(), 0, "x", &err), HZ_OK);
    assert_int_equal(hz_mem_check(hz_mem_budget_default() + 1, 0, "x", &err), HZ_ERR_MEMORY);
}

/* hz_grow: doubling from the first capacity, the contents kept; a count
 * beyond UINT32_MAX / 2 refused with the array untouched. */
static void test_grow(void **state)
{
    (void)state;
    uint32_t *a = NULL, cap = 0;
    assert_true(hz_grow((void **)&a, &cap, 0, sizeof *a, 16));
    assert_null(a); /* nothing needed, nothing allocated */
    assert_true(hz_grow((void **)&a, &cap, 5, sizeof *a, 16));
    assert_int_equal(cap, 16);
    for (uint32_t k = 0; k < 16; k++)
        a[k] = k * 7;
    assert_true(hz_grow((void **)&a, &cap, 17, sizeof *a, 16));
    assert_int_equal(cap, 32);
    assert_true(hz_grow((void **)&a, &cap, 100, sizeof *a, 16));
    assert_int_equal(cap, 128);
    for (uint32_t k = 0; k < 16; k++)
        assert_int_equal(a[k], k * 7);
    uint32_t *keep = a;
    assert_false(hz_grow((void **)&a, &cap, (uint64_t)UINT32_MAX / 2 + 1, sizeof *a, 16));
    assert_ptr_equal(a, keep);
    assert_int_equal(cap, 128);
    assert_true(hz_grow((void **)&a, &cap, 128, sizeof *a, 16)); /* already enough */
    assert_int_equal(cap, 128);
    free(a);
}

static void test_fit_side(void **state)
{
    (void)state;
    assert_int_equal(hz_grid_fit_side(65537, 2, HZ_FIT_AUTO), 65537);
    assert_int_equal(hz_grid_fit_side(65537, 2, HZ_FIT_PAD), 65537);
    assert_int_equal(hz_grid_fit_side(65537, 2, HZ_FIT_CROP), 0);
    assert_int_equal(hz_grid_fit_side(1025, 1025, HZ_FIT_REFUSE), 1025);
    assert_int_equal(hz_grid_fit_side(1000, 1000, HZ_FIT_REFUSE), 0);
    /* The side announced is the side fitting makes. */
    const uint32_t sz[][2] = {{5, 7}, {9, 9}, {10, 3}, {100, 40}, {33, 200}, {2, 30}, {70, 70}};
    /* against what the terrain does (hz_grid_fit: auto keeps every sample) */
    const hz_fit fits[] = {HZ_FIT_AUTO, HZ_FIT_CROP, HZ_FIT_PAD, HZ_FIT_NEAREST};
    for (size_t k = 0; k < sizeof sz / sizeof *sz; k++)
        for (size_t f = 0; f < 4; f++) {
            hz_grid g;
            assert_int_equal(hz_grid_alloc(&g, sz[k][0], sz[k][1], NULL), HZ_OK);
            uint32_t want = hz_grid_fit_side(sz[k][0], sz[k][1], fits[f]);
            hz_grid_fit_info fi = {0};
            hz_result r = hz_grid_fit(&g, fits[f], &fi, NULL, 0, NULL);
            if (want == 0)
                assert_int_not_equal(r, HZ_OK);
            else {
                assert_int_equal(r, HZ_OK);
                assert_int_equal(g.width, want);
            }
            free(fi.valid);
            hz_grid_free(&g);
        }
}

/* Loads the terrain of desc, expecting a refusal within 1 s and 200 MB. */
static void expect_refused(const hz_terrain_desc *d, hz_result code, const char *must1, const char *must2)
{
    hz_err err = {0};
    double t0 = hz_time_ms();
    hz_terrain *t = hz_terrain_create(d, &err);
    double ms = hz_time_ms() - t0;
    uint64_t rss = hz_peak_rss_bytes();
    print_message("%s: refused in %.1f ms, peak RSS %.1f MB: %s\n", d->dem_path ? d->dem_path : "generated", ms,
                  (double)rss / 1048576.0, err.msg);
    assert_null(t);
    assert_int_equal(err.code, code);
    if (must1 && !strstr(err.msg, must1))
        fail_msg("message lacks '%s': %s", must1, err.msg);
    if (must2 && !strstr(err.msg, must2))
        fail_msg("message lacks '%s': %s", must2, err.msg);
    assert_true(ms < 1000.0);
    assert_true(rss < ((uint64_t)200 << 20));
}

static void test_wide_file_refused(void **state)
{
    (void)state;
    /* The reproducer: 65537x2 zeros as r16, gzipped (298 bytes). */
    size_t n = (size_t)65537 * 2 * 2;
    uint8_t *zero = calloc(n, 1);
    assert_non_null(zero);
    assert_true(fx_write_gz(fx_tmp("wide.r16.gz"), zero, n));
    free(zero);
    struct stat st;
    assert_int_equal(stat(fx_tmp("wide.r16.gz"), &st), 0);
    print_message("wide.r16.gz: %lld bytes\n", (long long)st.st_size);
    assert_true(st.st_size < 1000);
    hz_terrain_desc d = {.dem_path = fx_tmp("wide.r16.gz"), .raw_width = 65537, .raw_height = 2};
    /* The default budget (half the RAM) refuses the 65537^2 pad on any machine
     * with less than ~200 GB; an explicit one everywhere. */
    if (hz_mem_budget_default() < (uint64_t)65537 * 65537 * 24)
        expect_refused(&d, HZ_ERR_MEMORY, "65537x65537", "--max-memory");
    d.max_memory = (uint64_t)1 << 30;
    expect_refused(&d, HZ_ERR_MEMORY, "65537x65537", "--max-memory");
    d.fit = HZ_FIT_PAD;
    expect_refused(&d, HZ_ERR_MEMORY, "65537x65537", "--max-memory");

    /* The same as a 16-bit PNG of 65537x2. */
    uint16_t *s = calloc((size_t)65537 * 2, sizeof *s);
    assert_non_null(s);
    assert_true(fx_write_png(fx_tmp("wide.png"), 65537, 2, 16, PNG_COLOR_TYPE_GRAY, false, s));
    free(s);
    hz_terrain_desc p = {.dem_path = fx_tmp("wide.png"), .max_memory = (uint64_t)1 << 30};
    expect_refused(&p, HZ_ERR_MEMORY, "65537x65537", "--max-memory");

    /* Generated terrains are checked before generating. */
    hz_terrain_desc gd = {.generate = HZ_GEN_PERLIN, .gen_size = 16385, .max_memory = (uint64_t)256 << 20};
    expect_refused(&gd, HZ_ERR_MEMORY, "16385x16385", "--max-memory");
    /* And against a sample limit (the GPU's), before any work. */
    hz_terrain_desc gs = {.generate = HZ_GEN_PERLIN, .gen_size = 16385, .max_samples = (uint64_t)1 << 27,
                          .max_memory = (uint64_t)1 << 40};
    expect_refused(&gs, HZ_ERR_UNSUPPORTED, "16385x16385", "GL_MAX_TEXTURE_BUFFER_SIZE");
}

static void test_gunzip_budget(void **state)
{
    (void)state;
    /* 32 MB of zeros (2896^2 floats) gzip to ~32 KB; within an 8 MB budget
     * the loader stops decompressing and says why. */
    size_t n = (size_t)2896 * 2896 * 4;
    uint8_t *zero = calloc(n, 1);
    assert_non_null(zero);
    assert_true(fx_write_gz(fx_tmp("bomb.r32.gz"), zero, n));
    free(zero);
    hz_grid g;
    hz_err err = {0};
    assert_int_equal(hz_dem_load(&(hz_dem_desc){.path = fx_tmp("bomb.r32.gz"), .max_memory = (uint64_t)8 << 20},
                                 &g, NULL, &err),
                     HZ_ERR_MEMORY);
    assert_null(g.z);
    assert_non_null(strstr(err.msg, "--max-memory"));
    assert_non_null(strstr(err.msg, "decompressing"));
    /* With room it loads: 2896^2 floats. */
    assert_int_equal(hz_dem_load(&(hz_dem_desc){.path = fx_tmp("bomb.r32.gz"), .max_memory = (uint64_t)1 << 30},
                                 &g, NULL, &err),
                     HZ_OK);
    assert_int_equal(g.width, 2896);
    hz_grid_free(&g);
}

/* Found by fuzz_dem in an hour's campaign: 45 bytes that GDAL reads as an
 * NGS geoid grid of 12288 x 65293 floats (3.2 GB), placed by a geotransform
 * of NaNs. That geotransform refuses it at once; a grid of the same size
 * without a georeference (a VRT over a small file) meets the budget, which
 * the GDAL path checks before allocating, as the others do. */
static void test_gdal_header_budget(void **state)
{
    (void)state;
    static const uint8_t geoid[] = {0x89, 0x50, 0x4e, 0x7f, 0xff, 0xff, 0xff, 0x44, 0x41, 0x4c, 0x5f, 0x57, 0x28, 0x4d, 0x54,
                                    0x53, 0x7f, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xd6, 0xff, 0xff,
                                    0xff, 0xff, 0x0d, 0xff, 0x00, 0x00, 0x00, 0x30, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x10};
    assert_true(fx_write(fx_tmp("geoid.bin"), geoid, sizeof geoid));
    hz_grid g;
    hz_err err = {0};
    const double t0 = hz_time_ms();
    assert_int_equal(hz_dem_load(&(hz_dem_desc){.path = fx_tmp("geoid.bin"), .max_memory = (uint64_t)256 << 20}, &g,
                                 NULL, &err),
                     HZ_ERR_FORMAT);
    assert_true(hz_time_ms() - t0 < 5000.0);
    assert_null(g.z);
    assert_non_null(strstr(err.msg, "geoid.bin' has a CRS but cannot be placed by it"));
    FILE *vrt = fopen(fx_tmp("geoid_size.vrt"), "w");
    assert_non_null(vrt);
    fputs("<VRTDataset rasterXSize=\"12288\" rasterYSize=\"65293\"><VRTRasterBand dataType=\"Float32\" band=\"1\">"
          "<SimpleSource><SourceFilename relativeToVRT=\"0\">" HZ_DATA_DIR "/N46E008.tif</SourceFilename>"
          "<SourceBand>1</SourceBand></SimpleSource></VRTRasterBand></VRTDataset>\n",
          vrt);
    fclose(vrt);
    const double t1 = hz_time_ms();
    assert_int_equal(hz_dem_load(&(hz_dem_desc){.path = fx_tmp("geoid_size.vrt"), .max_memory = (uint64_t)256 << 20},
                                 &g, NULL, &err),
                     HZ_ERR_MEMORY);
    assert_true(hz_time_ms() - t1 < 5000.0);
    assert_null(g.z);
    assert_non_null(strstr(err.msg, "--max-memory"));
    assert_non_null(strstr(err.msg, "12288x65293"));
}

static void write_text(const char *path, const char *s)
{
    assert_true(fx_write(path, s, strlen(s)));
}

static char *read_text(const char *path)
{
    size_t n;
    uint8_t *b = fx_read(path, &n);
    if (!b)
        return NULL;
    char *s = realloc(b, n + 1);
    s[n] = 0;
    return s;
}

static void test_same_file(void **state)
{
    (void)state;
    char a[1024], dotted[1200], sym[1024], hard[1024], other[1024], missing[1024], missing2[1200];
    snprintf(a, sizeof a, "%s", fx_tmp("same_a.txt"));
    snprintf(sym, sizeof sym, "%s", fx_tmp("same_link.txt"));
    snprintf(hard, sizeof hard, "%s", fx_tmp("same_hard.txt"));
    snprintf(other, sizeof other, "%s", fx_tmp("same_other.txt"));
    snprintf(missing, sizeof missing, "%s", fx_tmp("same_missing.txt"));
    write_text(a, "a");
    write_text(other, "a");
    unlink(sym);
    unlink(hard);
    unlink(missing);
    assert_int_equal(symlink(a, sym), 0);
    assert_int_equal(link(a, hard), 0);
    /* dir/../dir/name */
    const char *slash = strrchr(a, '/');
    const char *dir_name = slash;
    while (dir_name > a && dir_name[-1] != '/')
        dir_name--;
    snprintf(dotted, sizeof dotted, "%.*s/../%s", (int)(slash - a), a, dir_name);
    snprintf(missing2, sizeof missing2, "%.*s/./%s", (int)(slash - a), a, "same_missing.txt");
    assert_true(hz_same_file(a, a));
    assert_true(hz_same_file(a, dotted));
    assert_true(hz_same_file(a, sym));
    assert_true(hz_same_file(a, hard));
    assert_false(hz_same_file(a, other));
    assert_true(hz_same_file(missing, missing2)); /* the same name, not yet written */
    assert_false(hz_same_file(missing, a));
    assert_false(hz_same_file(a, NULL));
    assert_false(hz_same_file("", a));
}

static void test_outfile(void **state)
{
    (void)state;
    char path[1024];
    snprintf(path, sizeof path, "%s", fx_tmp("out_atomic.txt"));
    write_text(path, "old");
    assert_int_equal(chmod(path, 0640), 0);
    hz_outfile of;
    hz_err err = {0};
    /* Discarded: the old file stays as it was, the temporary file goes. */
    assert_int_equal(hz_outfile_begin(&of, path, &err), HZ_OK);
    assert_false(of.direct);
    assert_string_not_equal(of.tmp, path);
    assert_memory_equal(of.tmp, path, (size_t)(strrchr(path, '/') - path)); /* same folder */
    assert_non_null(strstr(of.tmp, ".txt"));                              /* extension kept */
    write_text(of.tmp, "half-writ");
    char *s = read_text(path);
    assert_string_equal(s, "old");
    free(s);
    char tmp[4096];
    snprintf(tmp, sizeof tmp, "%s", of.tmp);
    hz_outfile_discard(&of);
    assert_int_not_equal(access(tmp, F_OK), 0);
    s = read_text(path);
    assert_string_equal(s, "old");
    free(s);
    /* Committed: replaced in one step, mode kept. */
    FILE *f = hz_outfile_open(&of, path, &err);
    assert_non_null(f);
    fputs("new", f);
    assert_int_equal(hz_outfile_close(&of, f, &err), HZ_OK);
    s = read_text(path);
    assert_string_equal(s, "new");
    free(s);
    struct stat st;
    assert_int_equal(stat(path, &st), 0);
    assert_int_equal(st.st_mode & 0777, 0640);
    assert_int_not_equal(access(of.tmp, F_OK), 0);
    /* A device is written in place; a folder or a missing folder refused. */
    assert_int_equal(hz_outfile_begin(&of, "/dev/null", &err), HZ_OK);
    assert_true(of.direct);
    assert_int_equal(hz_outfile_commit(&of, &err), HZ_OK);
    char dir[1100];
    snprintf(dir, sizeof dir, "%.*s", (int)(strrchr(path, '/') - path), path);
    assert_int_equal(hz_outfile_begin(&of, dir, &err), HZ_ERR_IO);
    assert_non_null(strstr(err.msg, "directory"));
    assert_int_equal(hz_outfile_begin(&of, "/nonexistent_dir_hz/x.png", &err), HZ_ERR_IO);
    assert_non_null(strstr(err.msg, "/nonexistent_dir_hz/x.png"));
    /* A symbolic link: written through to its file, the link stays a link. */
    char link_path[1100];
    snprintf(link_path, sizeof link_path, "%s", fx_tmp("out_link.txt"));
    unlink(link_path);
    assert_int_equal(symlink(path, link_path), 0);
    f = hz_outfile_open(&of, link_path, &err);
    assert_non_null(f);
    fputs("through", f);
    assert_int_equal(hz_outfile_close(&of, f, &err), HZ_OK);
    assert_int_equal(lstat(link_path, &st), 0);
    assert_true(S_ISLNK(st.st_mode));
    s = read_text(path);
    assert_string_equal(s, "through");
    free(s);
    unlink(link_path);
}

/* Cache blobs: what went in comes out, under its key and size only; a
 * truncated, padded, damaged, foreign or oversized file is refused with its
 * reason, never read into the caller's buffer as if whole. */
static void test_blob(void **state)
{
    (void)state;
    const size_t n = 200000;
    uint8_t *data = malloc(n), *back = malloc(n);
    assert_non_null(data);
    assert_non_null(back);
    for (size_t k = 0; k < n; k++)
        data[k] = (uint8_t)((k * 2654435761u) >> 13 & (k % 7 ? 0x0f : 0xff)); /* some entropy, compressible */
    char path[1024];
    snprintf(path, sizeof path, "%s", fx_tmp("cache.hzb"));
    hz_err err = {0};
    assert_int_equal(hz_blob_save(path, 0x1234u, data, n, &err), HZ_OK);
    memset(back, 0, n);
    assert_int_equal(hz_blob_load(path, 0x1234u, back, n, &err), HZ_OK);
    assert_memory_equal(back, data, n);
    /* Another key or size. */
    assert_int_equal(hz_blob_load(path, 0x1235u, back, n, &err), HZ_ERR_FORMAT);
    assert_non_null(strstr(err.msg, "other data"));
    assert_int_equal(hz_blob_load(path, 0x1234u, back, n - 1, &err), HZ_ERR_FORMAT);
    assert_int_equal(hz_blob_load("/nonexistent_dir_hz/x.hzb", 0x1234u, back, n, &err), HZ_ERR_IO);
    /* The file's bytes, damaged in every way a cache file gets damaged. */
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    uint8_t *file = malloc(n + 1000);
    assert_non_null(file);
    size_t fn = fread(file, 1, n + 1000, f);
    fclose(f);
    assert_true(fn > HZ_BLOB_HEADER && fn < n); /* compressed */
    assert_int_equal(hz_blob_load_mem(file, fn, "m", 0x1234u, back, n, &err), HZ_OK);
    for (size_t cut = 0; cut < fn; cut += 997) { /* truncated */
        assert_int_equal(hz_blob_load_mem(file, cut, "m", 0x1234u, back, n, &err), HZ_ERR_FORMAT);
        assert_true(err.msg[0] != 0);
    }
    file[fn] = 0; /* padded */
    assert_int_equal(hz_blob_load_mem(file, fn + 1, "m", 0x1234u, back, n, &err), HZ_ERR_FORMAT);
    assert_non_null(strstr(err.msg, "truncated or padded"));
    /* A flipped bit anywhere is caught: by the header checks, by zstd or by the checksum. */
    for (size_t k = 0; k < fn; k += fn / 97 + 1) {
        file[k] ^= 0x10;
        assert_int_equal(hz_blob_load_mem(file, fn, "m", 0x1234u, back, n, &err), HZ_ERR_FORMAT);
        file[k] ^= 0x10;
    }
    /* The checksum guards the bytes even when the frame decodes: the same
     * frame under a header whose XXH64 is another. */
    file[24] ^= 1;
    assert_int_equal(hz_blob_load_mem(file, fn, "m", 0x1234u, back, n, &err), HZ_ERR_FORMAT);
    assert_non_null(strstr(err.msg, "checksum"));
    file[24] ^= 1;
    /* A file larger than any blob of that size is not read at all. */
    f = fopen(path, "ab");
    assert_non_null(f);
    for (int k = 0; k < 4096; k++)
        fwrite(file, 1, 1000 < fn ? 1000 : fn, f);
    fclose(f);
    assert_int_equal(hz_blob_load(path, 0x1234u, back, n, &err), HZ_ERR_FORMAT);
    assert_non_null(strstr(err.msg, "more than"));
    unlink(path);
    free(file);
    free(data);
    free(back);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_size_parse),      cmocka_unit_test(test_mem_check),       cmocka_unit_test(test_grow),
        cmocka_unit_test(test_fit_side),        cmocka_unit_test(test_wide_file_refused),
        cmocka_unit_test(test_gunzip_budget),   cmocka_unit_test(test_gdal_header_budget),   cmocka_unit_test(test_same_file),
        cmocka_unit_test(test_outfile),         cmocka_unit_test(test_blob),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
