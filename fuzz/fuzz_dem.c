/* libFuzzer entry: the first byte picks a file name (and so the format the
 * loader detects), the rest is written to a temp file and loaded. Must never
 * crash, leak or read out of bounds; a successful load must give sane values.
 * Build with clang (see CMakeLists.txt); hz_io should be built with
 * -fsanitize=address too (-DHZ_SANITIZE=ON) so its reads are checked. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "horizon/dem.h"

static const char *const names[] = {
    "f.png", "f_terrarium_z9_x270_y178.png", "f_dm16.png", "f.hgt", "f.r16", "f.r32", "f_int16be.raw",
    "f.png.gz", "f.hgt.gz", "f.r16.gz", "f.r32.gz", "f_terrarium.png.gz", "f.bin",
};

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1)
        return 0;
    static char dir[256];
    if (!dir[0]) {
        const char *t = getenv("TMPDIR");
        snprintf(dir, sizeof dir, "%s/hz_fuzz_%d", t ? t : "/tmp", (int)getpid());
    }
    const size_t nn = sizeof names / sizeof *names;
    const char *name = names[data[0] % nn];
    /* A new name per input: GDAL keeps what it learnt about the last
     * /vsigzip/ file by name (its size), so reusing one name would make an
     * input's outcome depend on the one before, and a finding would not
     * reproduce on its own. */
    static unsigned long serial;
    char path[512];
    snprintf(path, sizeof path, "%s_%lu_%s", dir, serial++, name);
    FILE *f = fopen(path, "wb");
    if (!f)
        return 0;
    fwrite(data + 1, 1, size - 1, f);
    fclose(f);
    hz_grid g;
    hz_err err;
    hz_dem_info info;
    /* r16/r32 sometimes with an explicit size from the second byte. */
    uint32_t w = size > 2 && (data[1] & 1) ? data[1] / 2u + 1u : 0;
    /* A budget under libFuzzer's -malloc_limit_mb (1024): a file claiming
     * more must be refused, not allocated. */
    hz_result r = hz_dem_load(&(hz_dem_desc){.path = path, .width = w, .max_memory = (uint64_t)256 << 20}, &g, &info,
                              &err);
    if (r == HZ_OK) {
        size_t n = (size_t)g.width * g.height, nan = 0;
        for (size_t k = 0; k < n; k++) {
            if (isnan(g.z[k]))
                nan++;
            else if (!isfinite(g.z[k]) || fabsf(g.z[k]) > 100000.0f)
                abort();
        }
        if (nan != info.voids)
            abort();
        hz_grid_free(&g);
    } else if (g.z != NULL || err.msg[0] == 0) {
        abort();
    }
    unlink(path);
    return 0;
}
