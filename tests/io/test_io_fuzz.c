/* Deterministic mutation fuzzing of every small fixture file: byte flips,
 * truncations, header bit flips, overwritten runs, appended junk, and for
 * PNGs the same with chunk CRCs recomputed so libpng parses the mutated
 * header and zlib stream instead of stopping at the CRC. Every load must
 * either succeed with sane values or fail cleanly with a message. Fixed seed:
 * a failure reproduces. HZ_IO_FUZZ_ITERS overrides the 2000 per file. */
#define _POSIX_C_SOURCE 200809L
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <zlib.h>

#include "horizon/dem.h"
#include "io_fixtures.h"
#include "io_tests.h"

/* Recomputes the CRC of every complete chunk of a (mutated) PNG. */
static void fix_png_crcs(uint8_t *b, size_t n)
{
    size_t p = 8;
    while (p + 12 <= n) {
        uint32_t len = (uint32_t)b[p] << 24 | (uint32_t)b[p + 1] << 16 | (uint32_t)b[p + 2] << 8 | b[p + 3];
        if (len > n - p - 12)
            break;
        uint32_t crc = (uint32_t)crc32(0, b + p + 4, len + 4);
        for (int q = 0; q < 4; q++)
            b[p + 8 + len + (size_t)q] = (uint8_t)(crc >> (24 - 8 * q));
        p += 12 + len;
    }
}

static size_t mutate(uint8_t *b, size_t n, size_t cap, uint64_t *s)
{
    switch (fx_rand(s) % 6) {
    case 0: { /* a few random bytes */
        int k = 1 + (int)(fx_rand(s) % 4);
        for (int i = 0; i < k; i++)
            b[fx_rand(s) % n] = (uint8_t)fx_rand(s);
        return n;
    }
    case 1: /* truncate */
        return 1 + (size_t)(fx_rand(s) % (n - 1));
    case 2: { /* bit flips in the header region */
        size_t h = n < 64 ? n : 64;
        int k = 1 + (int)(fx_rand(s) % 3);
        for (int i = 0; i < k; i++)
            b[fx_rand(s) % h] ^= (uint8_t)(1u << (fx_rand(s) % 8));
        return n;
    }
    case 3: { /* a run of 0x00 or 0xff */
        size_t at = fx_rand(s) % n, len = 1 + fx_rand(s) % 16;
        if (at + len > n)
            len = n - at;
        memset(b + at, fx_rand(s) & 1 ? 0xff : 0x00, len);
        return n;
    }
    case 4: { /* junk appended */
        size_t add = 1 + fx_rand(s) % 64;
        if (n + add > cap)
            add = cap - n;
        for (size_t i = 0; i < add; i++)
            b[n + i] = (uint8_t)fx_rand(s);
        return n + add;
    }
    default: /* flip then truncate */
        b[fx_rand(s) % n] = (uint8_t)fx_rand(s);
        return 1 + (size_t)(fx_rand(s) % (n - 1));
    }
}

void test_mutation_fuzz(void **state)
{
    (void)state;
    int iters = 2000;
    if (getenv("HZ_IO_FUZZ_ITERS"))
        iters = atoi(getenv("HZ_IO_FUZZ_ITERS"));
    fx_case *cases;
    size_t ncases = fx_make_cases(&cases);
    uint64_t s = 0xf022f022ULL;
    size_t ok = 0, failed = 0, by_code[8] = {0};
    double t0 = hz_time_ms();
    for (size_t c = 0; c < ncases; c++) {
        size_t n;
        uint8_t *orig = fx_read(fx_tmp(cases[c].name), &n);
        assert_non_null(orig);
        assert_true(n > 8);
        const size_t cap = n + 64;
        uint8_t *b = malloc(cap);
        char name[128], shm[256];
        snprintf(name, sizeof name, "fz_%s", cases[c].name);
        /* tmpfs if there is one: this loop writes 44,000 files. */
        snprintf(shm, sizeof shm, "/dev/shm/hz_io_%d_%s", (int)getpid(), name);
        const char *path = fx_write(shm, "", 0) ? shm : fx_tmp(name);
        bool is_png = !memcmp(orig, "\x89PNG", 4);
        for (int it = 0; it < iters; it++) {
            memcpy(b, orig, n);
            size_t m = mutate(b, n, cap, &s);
            if (is_png && (it & 1))
                fix_png_crcs(b, m);
            assert_true(fx_write(path, b, m));
            hz_grid g;
            hz_err err = {0};
            hz_dem_info info;
            hz_dem_desc d = {.path = path, .width = cases[c].raw_w, .height = cases[c].raw_h};
            hz_result r = hz_dem_load(&d, &g, &info, &err);
            by_code[r & 7]++;
            if (r == HZ_OK) {
                ok++;
                assert_true(g.width >= 1 && g.width <= 65537 && g.height >= 1 && g.height <= 65537);
                assert_non_null(g.z);
                uint64_t nan = 0;
                for (size_t k = 0; k < (size_t)g.width * g.height; k++) {
                    float v = g.z[k];
                    if (isnan(v)) {
                        nan++;
                        continue;
                    }
                    if (!isfinite(v) || fabsf(v) > 100000.0f)
                        fail_msg("%s iteration %d: sample %zu = %g", name, it, k, (double)v);
                }
                assert_int_equal(nan, info.voids);
                hz_grid_free(&g);
            } else {
                failed++;
                assert_null(g.z);
                if (r != HZ_ERR_FORMAT && r != HZ_ERR_VALUE && r != HZ_ERR_UNSUPPORTED)
                    fail_msg("%s iteration %d: unexpected %s: %s", name, it, hz_result_name(r), err.msg);
                if (!strstr(err.msg, name))
                    fail_msg("%s iteration %d: message does not name the file: %s", name, it, err.msg);
            }
        }
        if (path == shm)
            unlink(shm);
        free(b);
        free(orig);
    }
    print_message("mutation fuzz: %zu files x %d: %zu loaded, %zu refused (format %zu, value %zu) in %.0f ms\n",
                  ncases, iters, ok, failed, by_code[HZ_ERR_FORMAT], by_code[HZ_ERR_VALUE], hz_time_ms() - t0);
    /* Both paths must actually be exercised. */
    assert_true(ok > (size_t)iters);
    assert_true(failed > (size_t)iters);
    fx_free_cases(cases, ncases);
}
