/* libFuzzer: cache blobs (hz_blob_load_mem, include/horizon/blob.h). The key
 * and size asked for are the ones the input's header claims (the size
 * capped at 1 MiB), so mutations get past the header checks into zstd and
 * the checksum; also through a file (hz_blob_load). A blob is refused with a
 * message or loads exactly the bytes asked for; never a crash, a leak or an
 * allocation beyond the asked size. */
#include <string.h>

#include "fuzz_util.h"
#include "horizon/blob.h"

static uint64_t get64(const uint8_t *p)
{
    uint64_t v = 0;
    for (int k = 0; k < 8; k++)
        v |= (uint64_t)p[k] << (8 * k);
    return v;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    uint64_t key = size >= 16 ? get64(data + 8) : 0;
    uint64_t want = size >= 24 ? get64(data + 16) : 16;
    if (want > (1u << 20))
        want = 1u << 20;
    uint8_t *out = malloc(want ? want : 1);
    if (!out)
        return 0;
    hz_err err = {0};
    if (hz_blob_load_mem(data, size, "fuzz", key, out, (size_t)want, &err) != HZ_OK && !err.msg[0])
        abort(); /* a refusal names its reason */
    const char *path = fuzz_tmp_file("blob", data, size);
    if (path) {
        hz_err e2 = {0};
        if (hz_blob_load(path, key, out, (size_t)want, &e2) != HZ_OK && !e2.msg[0])
            abort();
        unlink(path);
    }
    free(out);
    return 0;
}
