/* Checked, compressed files of one block of bytes, for caches: what took
 * seconds to compute (a forest model's baked impostors) is kept on disk and
 * read back only when it is exactly what the caller asks for.
 *
 * Layout (little-endian): the magic "HZBLOB1\n", u64 key (the caller's hash
 * of everything the bytes depend on), u64 size, u64 XXH64 of the bytes,
 * u64 compressed size, then the bytes as one zstd frame. Written through a
 * temporary file renamed into place, so a reader never sees half a file. */
#ifndef HORIZON_BLOB_H
#define HORIZON_BLOB_H

#include <stddef.h>
#include <stdint.h>

#include "horizon/core.h"

#ifdef __cplusplus
extern "C" {
#endif

#define HZ_BLOB_HEADER 40u

/* Writes size bytes of data under key to path (replacing it in one step). */
hz_result hz_blob_save(const char *path, uint64_t key, const void *data, size_t size, hz_err *err);

/* Reads exactly size bytes into data when path holds them under key.
 * HZ_ERR_IO when the file is missing or unreadable; HZ_ERR_FORMAT (with the
 * reason) when it is not a blob, holds another key or size, is truncated,
 * or its bytes fail the checksum. Never reads more than the header and the
 * compressed bound of size. */
hz_result hz_blob_load(const char *path, uint64_t key, void *data, size_t size, hz_err *err);
/* The same from memory (name is used in messages). */
hz_result hz_blob_load_mem(const uint8_t *buf, size_t n, const char *name, uint64_t key, void *data, size_t size,
                           hz_err *err);

#ifdef __cplusplus
}
#endif
#endif
