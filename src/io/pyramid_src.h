/* Private to src/io: where the bytes of a pyramid come from. pyramid_file.c
 * parses and decodes; a source only reads byte ranges: a local file
 * (pread, in pyramid_file.c) or an http(s) URL (pyramid_http.c). */
#ifndef HZ_PYRAMID_SRC_H
#define HZ_PYRAMID_SRC_H

#include "horizon/pyramid.h"

typedef struct hz_pyr_src hz_pyr_src;

typedef struct hz_pyr_src_vt {
    /* Reads exactly n bytes at off into buf. sum, when not NULL, is the
     * XXH64 the bytes must have (a tile, from the index): a source that
     * caches validates its copy with it, one that retries retries on a
     * mismatch. The caller checks it again. Thread-safe. Errors say why
     * (the caller adds which tile). */
    hz_result (*read)(hz_pyr_src *s, void *buf, size_t n, uint64_t off, const uint64_t *sum, hz_err *err);
    hz_pyr_transfer (*transfer)(const hz_pyr_src *s); /* NULL: nothing to report */
    void (*close)(hz_pyr_src *s);
} hz_pyr_src_vt;

struct hz_pyr_src {
    const hz_pyr_src_vt *vt;
    uint64_t size;  /* bytes of the whole file */
    bool remote;
};

/* True for http:// and https:// (any case). */
bool hz_pyr_is_url(const char *path);

/* Opens url: fetches the header (bytes 0..511, which the first read gets
 * back without a request) and the file size; falls back to opt->disk_cache
 * when the server does not answer. */
hz_result hz_pyr_http_open(const char *url, const hz_pyr_remote *opt, hz_pyr_src **out, hz_err *err);

#endif
