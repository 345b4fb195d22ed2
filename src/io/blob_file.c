/* Checked, compressed one-block files for caches (include/horizon/blob.h):
 * zstd for the bytes, XXH64 to know they came back whole. */
#include "horizon/blob.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <xxhash.h>
#include <zstd.h>

#include "horizon/safety.h"

static const char MAGIC[8] = {'H', 'Z', 'B', 'L', 'O', 'B', '1', '\n'};

static void put64(uint8_t *p, uint64_t v)
{
    for (int k = 0; k < 8; k++)
        p[k] = (uint8_t)(v >> (8 * k));
}

static uint64_t get64(const uint8_t *p)
{
    uint64_t v = 0;
    for (int k = 0; k < 8; k++)
        v |= (uint64_t)p[k] << (8 * k);
    return v;
}

hz_result hz_blob_save(const char *path, uint64_t key, const void *data, size_t size, hz_err *err)
{
    const size_t bound = ZSTD_compressBound(size);
    uint8_t *buf = malloc(HZ_BLOB_HEADER + bound);
    if (!buf)
        return hz_err_set(err, HZ_ERR_MEMORY, "%s: out of memory for %zu bytes", path, bound);
    const size_t z = ZSTD_compress(buf + HZ_BLOB_HEADER, bound, data, size, 3);
    if (ZSTD_isError(z)) {
        free(buf);
        return hz_err_set(err, HZ_ERR_VALUE, "%s: zstd: %s", path, ZSTD_getErrorName(z));
    }
    memcpy(buf, MAGIC, 8);
    put64(buf + 8, key);
    put64(buf + 16, (uint64_t)size);
    put64(buf + 24, XXH64(data, size, 0));
    put64(buf + 32, (uint64_t)z);
    hz_outfile of = {0};
    FILE *f = hz_outfile_open(&of, path, err);
    if (!f) {
        free(buf);
        return err ? err->code : HZ_ERR_IO;
    }
    const size_t n = HZ_BLOB_HEADER + z;
    if (fwrite(buf, 1, n, f) != n) {
        fclose(f);
        hz_outfile_discard(&of);
        free(buf);
        return hz_err_set(err, HZ_ERR_IO, "%s: write failed: %s", path, strerror(errno));
    }
    free(buf);
    return hz_outfile_close(&of, f, err);
}

hz_result hz_blob_load_mem(const uint8_t *buf, size_t n, const char *name, uint64_t key, void *data, size_t size,
                           hz_err *err)
{
    if (n < HZ_BLOB_HEADER || memcmp(buf, MAGIC, 8) != 0)
        return hz_err_set(err, HZ_ERR_FORMAT, "%s: not a horizon cache blob", name);
    if (get64(buf + 8) != key)
        return hz_err_set(err, HZ_ERR_FORMAT, "%s: made for other data (key %016llx, not %016llx)", name,
                          (unsigned long long)get64(buf + 8), (unsigned long long)key);
    if (get64(buf + 16) != (uint64_t)size)
        return hz_err_set(err, HZ_ERR_FORMAT, "%s: holds %llu bytes, not %zu", name,
                          (unsigned long long)get64(buf + 16), size);
    const uint64_t z = get64(buf + 32);
    if (z != (uint64_t)(n - HZ_BLOB_HEADER))
        return hz_err_set(err, HZ_ERR_FORMAT, "%s: truncated or padded (%zu compressed bytes, the header says %llu)",
                          name, n - HZ_BLOB_HEADER, (unsigned long long)z);
    const uint8_t *frame = buf + HZ_BLOB_HEADER;
    const unsigned long long content = ZSTD_getFrameContentSize(frame, (size_t)z);
    if (content != (unsigned long long)size)
        return hz_err_set(err, HZ_ERR_FORMAT, "%s: damaged compressed data", name);
    const size_t got = ZSTD_decompress(data, size, frame, (size_t)z);
    if (ZSTD_isError(got) || got != size)
        return hz_err_set(err, HZ_ERR_FORMAT, "%s: damaged compressed data (%s)", name,
                          ZSTD_isError(got) ? ZSTD_getErrorName(got) : "short");
    if (XXH64(data, size, 0) != get64(buf + 24))
        return hz_err_set(err, HZ_ERR_FORMAT, "%s: checksum mismatch", name);
    return HZ_OK;
}

hz_result hz_blob_load(const char *path, uint64_t key, void *data, size_t size, hz_err *err)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return hz_err_set(err, HZ_ERR_IO, "cannot open '%s': %s", path, strerror(errno));
    struct stat st;
    if (fstat(fileno(f), &st) != 0 || !S_ISREG(st.st_mode)) {
        fclose(f);
        return hz_err_set(err, HZ_ERR_IO, "'%s' is not a regular file", path);
    }
    const size_t cap = HZ_BLOB_HEADER + ZSTD_compressBound(size);
    if (st.st_size < 0 || (uint64_t)st.st_size > cap) {
        fclose(f);
        return hz_err_set(err, HZ_ERR_FORMAT, "%s: %lld bytes, more than a blob of %zu bytes can take", path,
                          (long long)st.st_size, size);
    }
    const size_t n = (size_t)st.st_size;
    uint8_t *buf = malloc(n ? n : 1);
    if (!buf) {
        fclose(f);
        return hz_err_set(err, HZ_ERR_MEMORY, "%s: out of memory", path);
    }
    const size_t r = fread(buf, 1, n, f);
    fclose(f);
    hz_result res = r == n ? hz_blob_load_mem(buf, n, path, key, data, size, err)
                           : hz_err_set(err, HZ_ERR_IO, "%s: short read", path);
    free(buf);
    return res;
}
