/* Private to src/io: a folder keeping byte ranges fetched from a remote file
 * (pyramid_http.c), bounded in size, least recently used out first.
 *
 * DIR/<XXH64 of the URL, hex>/ holds one file per range, "<offset>-<bytes>"
 * (hex), its bytes followed by their XXH64; and "meta" (what identifies the
 * remote file's version: its size, ETag and header). Entries are written to
 * a temporary name and renamed, so a reader never sees half an entry, and
 * every read checks the stored XXH64 (and the one the caller expects, a
 * tile's from the index): a damaged entry is removed and fetched again.
 * Several processes may share a folder; the bound is then approximate. */
#ifndef HZ_DISK_CACHE_H
#define HZ_DISK_CACHE_H

#include "horizon/core.h"

typedef struct hz_dcache hz_dcache;

/* Opens (creates) dir for the remote file key (its URL); limit in bytes.
 * Sums what the folder holds already (every key) for the bound. */
hz_dcache *hz_dcache_open(const char *dir, const char *key, uint64_t limit, hz_err *err);
void hz_dcache_close(hz_dcache *c);

/* Reads the range [off, off + n) into buf. sum: the XXH64 it must have, or
 * NULL. False on a miss, or on a damaged entry (removed; *rejected set). */
bool hz_dcache_get(hz_dcache *c, uint64_t off, void *buf, size_t n, const uint64_t *sum, bool *rejected);
/* Stores a range (best effort: a full disk only loses the entry); evicts the
 * least recently used entries past the bound (not this key's meta data: the
 * ranges read without a sum). Returns the count evicted. */
uint32_t hz_dcache_put(hz_dcache *c, uint64_t off, const void *buf, size_t n, bool pinned);

/* The remote file's version as last seen: size, ETag ("" if none) and the
 * 512-byte header. False when none is stored. */
bool hz_dcache_get_meta(hz_dcache *c, uint64_t *size, char *etag, size_t etag_cap, uint8_t header[512]);
/* Stores the version seen now; when it differs from the stored one, every
 * range of this key is removed first (the file changed on the server). */
void hz_dcache_put_meta(hz_dcache *c, uint64_t size, const char *etag, const uint8_t header[512]);

#endif
