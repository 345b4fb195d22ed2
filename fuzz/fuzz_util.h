/* Shared by the libFuzzer targets: the loaders under test read files, so an
 * input is written to a per-process temporary file first. */
#ifndef HZ_FUZZ_UTIL_H
#define HZ_FUZZ_UTIL_H

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* Writes data to $TMPDIR/hz_fuzz_<pid>_<name> and returns that path (static
 * storage), or NULL. */
static inline const char *fuzz_tmp_file(const char *name, const uint8_t *data, size_t size)
{
    static char path[512];
    const char *t = getenv("TMPDIR");
    snprintf(path, sizeof path, "%s/hz_fuzz_%d_%s", t ? t : "/tmp", (int)getpid(), name);
    FILE *f = fopen(path, "wb");
    if (!f)
        return NULL;
    if (size && fwrite(data, 1, size, f) != size) {
        fclose(f);
        return NULL;
    }
    fclose(f);
    return path;
}

#endif
