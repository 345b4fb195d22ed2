/* The .hzp file: header, tiles (zstd, XXH64), index; reading and writing.
 * Layout in docs/pyramid.md. Nothing here knows how the LOD data is made. */
#include "io_internal.h"
#include "pyramid_src.h"

#include "horizon/pyramid.h"
#include "horizon/safety.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <xxhash.h>
#include <zstd.h>

enum { HDR_BYTES = 512, HDR_SUM = 504, IDX_REC = 24, TILE_HDR = 24 };
static const char MAGIC[8] = {'H', 'Z', 'P', 'Y', 'R', 'A', 'M', 'D'};
#define TILE_MAGIC 0x4c545a48u /* "HZTL" */

/* ---- little-endian fields ---- */

static void put16(uint8_t *p, uint16_t v) { p[0] = (uint8_t)v, p[1] = (uint8_t)(v >> 8); }
static void put32(uint8_t *p, uint32_t v) { for (int k = 0; k < 4; k++) p[k] = (uint8_t)(v >> (8 * k)); }
static void put64(uint8_t *p, uint64_t v) { for (int k = 0; k < 8; k++) p[k] = (uint8_t)(v >> (8 * k)); }
static void putd(uint8_t *p, double d) { uint64_t v; memcpy(&v, &d, 8); put64(p, v); }
static uint16_t get16(const uint8_t *p) { return (uint16_t)(p[0] | (p[1] << 8)); }
static uint32_t get32(const uint8_t *p) { uint32_t v = 0; for (int k = 3; k >= 0; k--) v = (v << 8) | p[k]; return v; }
static uint64_t get64(const uint8_t *p) { uint64_t v = 0; for (int k = 7; k >= 0; k--) v = (v << 8) | p[k]; return v; }
static double getd(const uint8_t *p) { uint64_t v = get64(p); double d; memcpy(&d, &v, 8); return d; }

/* ---- geometry ---- */

uint32_t hz_pyr_level_cells(const hz_pyr_info *info, uint32_t level)
{
    const uint32_t all = (info->size - 1) >> level;
    return all < info->tile_cells ? all : info->tile_cells;
}

uint32_t hz_pyr_level_tiles(const hz_pyr_info *info, uint32_t level)
{
    return ((info->size - 1) >> level) / hz_pyr_level_cells(info, level);
}

static size_t raw_tile_bytes(const hz_pyr_info *info, uint32_t level, bool masked)
{
    const size_t c = hz_pyr_level_cells(info, level), n = c + 1, k = c / info->patch_cells;
    return TILE_HDR + n * n * 2 + (4 * c + 8) * 2 + (masked ? (n * n + 7) / 8 : 0) + (k + 2) * (k + 2) * 2 +
           k * k * 4;
}

/* ---- tile codec ---- */

struct hz_pyr_encoder {
    ZSTD_CCtx *zc;
};

hz_pyr_encoder *hz_pyr_encoder_new(void)
{
    hz_pyr_encoder *e = malloc(sizeof *e);
    if (e && !(e->zc = ZSTD_createCCtx())) {
        free(e);
        e = NULL;
    }
    return e;
}

void hz_pyr_encoder_free(hz_pyr_encoder *e)
{
    if (e)
        ZSTD_freeCCtx(e->zc);
    free(e);
}

hz_result hz_pyr_encode_tile(const hz_pyr_info *info, const hz_pyr_tile *t, int zstd_level, void **blob,
                             size_t *bytes, hz_err *err)
{
    return hz_pyr_encoder_tile(NULL, info, t, zstd_level, blob, bytes, err);
}

hz_result hz_pyr_encoder_tile(hz_pyr_encoder *e, const hz_pyr_info *info, const hz_pyr_tile *t, int zstd_level,
                              void **blob, size_t *bytes, hz_err *err)
{
    *blob = NULL;
    const size_t c = t->cells, n = c + 1, nn = n * n, k = t->nodes;
    const bool masked = t->valid != NULL;
    const size_t raw = raw_tile_bytes(info, t->level, masked);
    uint8_t *r = malloc(raw);
    const size_t cap = ZSTD_compressBound(raw);
    void *z = malloc(cap);
    if (!r || !z) {
        free(r);
        free(z);
        return hz_err_set(err, HZ_ERR_MEMORY, "pyramid: out of memory encoding a tile");
    }
    uint8_t *p = r;
    put32(p, TILE_MAGIC), put32(p + 4, t->level), put32(p + 8, t->tx), put32(p + 12, t->tz);
    put32(p + 16, (uint32_t)c), put32(p + 20, masked ? 1u : 0u);
    p += TILE_HDR;
    /* Heights as residuals of the planar predictor (left + up - up-left),
     * low bytes then high bytes: smooth terrain leaves small residuals whose
     * high bytes are mostly 0 or 255, which zstd packs tightly. */
    for (size_t j = 0; j < n; j++)
        for (size_t i = 0; i < n; i++) {
            const uint16_t *h = t->h + j * n + i;
            int pred = i && j ? (int)h[-1] + h[-(ptrdiff_t)n] - h[-(ptrdiff_t)n - 1]
                              : (i ? h[-1] : (j ? h[-(ptrdiff_t)n] : 0));
            const uint16_t d = (uint16_t)((int)h[0] - pred);
            p[j * n + i] = (uint8_t)d;
            p[nn + j * n + i] = (uint8_t)(d >> 8);
        }
    p += 2 * nn;
    for (size_t q = 0; q < 4 * c + 8; q++)
        put16(p + 2 * q, t->apron[q]);
    p += 2 * (4 * c + 8);
    if (masked) {
        memset(p, 0, (nn + 7) / 8);
        for (size_t q = 0; q < nn; q++)
            if (t->valid[q])
                p[q >> 3] |= (uint8_t)(1u << (q & 7));
        p += (nn + 7) / 8;
    }
    for (size_t q = 0; q < (k + 2) * (k + 2); q++)
        put16(p + 2 * q, t->node_delta[q]);
    p += 2 * (k + 2) * (k + 2);
    for (size_t q = 0; q < k * k; q++)
        put16(p + 2 * q, t->node_min[q]);
    p += 2 * k * k;
    for (size_t q = 0; q < k * k; q++)
        put16(p + 2 * q, t->node_max[q]);
    p += 2 * k * k;
    HZ_ASSERT((size_t)(p - r) == raw);
    const int zl = zstd_level > 0 ? zstd_level : 9;
    const size_t zn = e ? ZSTD_compressCCtx(e->zc, z, cap, r, raw, zl) : ZSTD_compress(z, cap, r, raw, zl);
    free(r);
    if (ZSTD_isError(zn)) {
        free(z);
        return hz_err_set(err, HZ_ERR_VALUE, "pyramid: zstd: %s", ZSTD_getErrorName(zn));
    }
    *blob = z;
    *bytes = zn;
    return HZ_OK;
}

void hz_pyr_tile_free(hz_pyr_tile *t)
{
    free(t->h); /* the apron lives in its block */
    free(t->valid);
    free(t->node_delta); /* node_min and node_max live in its block */
    memset(t, 0, sizeof *t);
}

/* ---- reading ---- */

typedef struct idx_rec {
    uint64_t offset;
    uint32_t bytes, raw;
    uint64_t sum;
} idx_rec;

struct hz_pyramid {
    hz_pyr_src *src;
    char path[4096];
    hz_pyr_info info;
    char *wkt;
    uint64_t level_first[HZ_PYR_MAX_LEVELS + 1]; /* index of each level's first tile */
    idx_rec *idx;
};

static hz_result bad_file(hz_err *err, const char *path, const char *why)
{
    return hz_err_set(err, HZ_ERR_FORMAT, "'%s' is not a valid terrain pyramid: %s", path, why);
}

/* ---- byte sources: a local file here, http(s) in pyramid_http.c ---- */

typedef struct file_src {
    hz_pyr_src base;
    int fd;
} file_src;

static hz_result file_read(hz_pyr_src *src, void *buf, size_t n, uint64_t off, const uint64_t *sum, hz_err *err)
{
    (void)sum; /* the caller checks it */
    const int fd = ((file_src *)src)->fd;
    uint8_t *b = buf;
    while (n > 0) {
        ssize_t r = pread(fd, b, n, (off_t)off);
        if (r <= 0) {
            if (r < 0 && errno == EINTR)
                continue;
            return hz_err_set(err, HZ_ERR_IO, "%s", r < 0 ? strerror(errno) : "short read (truncated?)");
        }
        b += r, n -= (size_t)r, off += (uint64_t)r;
    }
    return HZ_OK;
}

static void file_close(hz_pyr_src *src)
{
    close(((file_src *)src)->fd);
    free(src);
}

static const hz_pyr_src_vt FILE_VT = {.read = file_read, .close = file_close};

static hz_result file_open(const char *path, hz_pyr_src **out, hz_err *err)
{
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0)
        return hz_err_set(err, HZ_ERR_IO, "cannot open '%s': %s", path, strerror(errno));
    struct stat st;
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        close(fd);
        return hz_err_set(err, HZ_ERR_IO, "'%s' is not a regular file", path);
    }
    file_src *f = calloc(1, sizeof *f);
    if (!f) {
        close(fd);
        return hz_err_set(err, HZ_ERR_MEMORY, "out of memory");
    }
    *f = (file_src){.base = {.vt = &FILE_VT, .size = (uint64_t)st.st_size}, .fd = fd};
    *out = &f->base;
    return HZ_OK;
}

static bool read_at(hz_pyr_src *src, void *buf, size_t n, uint64_t off, hz_err *e)
{
    return src->vt->read(src, buf, n, off, NULL, e) == HZ_OK;
}

static bool is_pow2_plus1(uint32_t v)
{
    return v >= 3 && ((v - 1) & (v - 2)) == 0;
}

hz_result hz_pyramid_open(const char *path, hz_pyramid **out, hz_err *err)
{
    return hz_pyramid_open_with(path, NULL, out, err);
}

hz_result hz_pyramid_open_with(const char *path, const hz_pyr_remote *remote, hz_pyramid **out, hz_err *err)
{
    *out = NULL;
    hz_pyr_src *src = NULL;
    hz_result r = hz_pyr_is_url(path) ? hz_pyr_http_open(path, remote, &src, err) : file_open(path, &src, err);
    if (r != HZ_OK)
        return r;
    hz_pyramid *p = calloc(1, sizeof *p);
    if (!p) {
        src->vt->close(src);
        return hz_err_set(err, HZ_ERR_MEMORY, "out of memory");
    }
    p->src = src;
    snprintf(p->path, sizeof p->path, "%s", path);
    uint8_t h[HDR_BYTES];
    const uint64_t fsize = src->size;
    hz_pyr_info *in = &p->info;
    hz_err re = {0};
    if (fsize < HDR_BYTES || !read_at(src, h, HDR_BYTES, 0, &re)) {
        r = src->remote && re.msg[0] ? hz_err_set(err, HZ_ERR_IO, "'%s': cannot read the header: %s", path, re.msg)
                                     : bad_file(err, path, "shorter than its header (truncated?)");
        goto fail;
    }
    if (memcmp(h, MAGIC, 8) != 0) {
        r = bad_file(err, path, "no HZPYRAMD signature");
        goto fail;
    }
    in->version = get32(h + 8);
    if (in->version != HZ_PYR_VERSION) {
        r = hz_err_set(err, HZ_ERR_UNSUPPORTED, "'%s': pyramid version %u; this horizon reads version %u", path,
                       in->version, HZ_PYR_VERSION);
        goto fail;
    }
    if (XXH64(h, HDR_SUM, 0) != get64(h + HDR_SUM)) {
        r = bad_file(err, path, "header checksum mismatch (corrupt)");
        goto fail;
    }
    in->size = get32(h + 16), in->data_w = get32(h + 20), in->data_h = get32(h + 24);
    in->tile_cells = get32(h + 28), in->patch_cells = get32(h + 32), in->levels = get32(h + 36);
    in->spacing = getd(h + 40), in->h_scale = getd(h + 48), in->h_offset = getd(h + 56);
    in->h_min = get16(h + 64), in->h_max = get16(h + 66);
    const uint32_t flags = get32(h + 68);
    in->wrap = flags & 1u;
    if (flags & ~1u) {
        r = bad_file(err, path, "unknown header flags (a newer horizon wrote it?)");
        goto fail;
    }
    in->max_error = getd(h + 72);
    in->tiles = get64(h + 80), in->nodata = get64(h + 88);
    for (int k = 0; k < 6; k++)
        in->geotransform[k] = getd(h + 96 + 8 * k);
    const uint64_t idx_off = get64(h + 144), idx_bytes = get64(h + 152), wkt_off = get64(h + 160);
    const uint32_t wkt_bytes = get32(h + 168);
    in->file_bytes = get64(h + 176);
    /* Every figure bounded before it sizes anything. */
    const uint32_t P = in->patch_cells, T = in->tile_cells;
    if (!is_pow2_plus1(in->size) || in->size > 1048577u || P < 2 || P > 64 || (P & (P - 1)) || T < P || T > 4096 ||
        (T & (T - 1)) || in->size - 1 < P || in->data_w > in->size || in->data_h > in->size || in->data_w < 2 ||
        in->data_h < 2 || !(in->spacing > 0 && in->spacing < 1e7) || !(in->h_scale > 0 && in->h_scale < 1e6) ||
        !(in->h_offset > -1e9 && in->h_offset < 1e9) || !(in->max_error >= 0 && in->max_error < 1e9)) {
        r = bad_file(err, path, "header values out of range");
        goto fail;
    }
    uint32_t lv = 0;
    while (((uint64_t)P << lv) < in->size - 1)
        lv++;
    if (((uint64_t)P << lv) != in->size - 1 || in->levels != lv + 1 || in->levels > HZ_PYR_MAX_LEVELS) {
        r = bad_file(err, path, "level count does not match the size");
        goto fail;
    }
    uint64_t tiles = 0;
    for (uint32_t l = 0; l < in->levels; l++) {
        p->level_first[l] = tiles;
        const uint64_t m = hz_pyr_level_tiles(in, l);
        tiles += m * m;
    }
    p->level_first[in->levels] = tiles;
    if (tiles != in->tiles || idx_bytes != tiles * IDX_REC + 8 || in->file_bytes != fsize ||
        idx_off < HDR_BYTES || idx_off > fsize || idx_bytes > fsize - idx_off || wkt_off > fsize ||
        wkt_bytes > fsize - wkt_off || wkt_bytes > (1u << 20)) {
        r = bad_file(err, path, in->file_bytes != fsize ? "file size differs from the header's (truncated?)"
                                                        : "index does not match the header");
        goto fail;
    }
    uint8_t *raw = malloc(idx_bytes);
    p->idx = malloc(tiles * sizeof *p->idx);
    p->wkt = calloc(1, (size_t)wkt_bytes + 1);
    if (!raw || !p->idx || !p->wkt) {
        free(raw);
        r = hz_err_set(err, HZ_ERR_MEMORY, "out of memory for the index of '%s' (%llu tiles)", path,
                       (unsigned long long)tiles);
        goto fail;
    }
    if (!read_at(src, raw, idx_bytes, idx_off, &re) || (wkt_bytes && !read_at(src, p->wkt, wkt_bytes, wkt_off, &re))) {
        free(raw);
        r = src->remote ? hz_err_set(err, HZ_ERR_IO, "'%s': cannot read the index: %s", path, re.msg)
                        : bad_file(err, path, "cannot read the index (truncated?)");
        goto fail;
    }
    if (XXH64(raw, tiles * IDX_REC, 0) != get64(raw + tiles * IDX_REC)) {
        free(raw);
        r = bad_file(err, path, "index checksum mismatch (corrupt)");
        goto fail;
    }
    for (uint64_t k = 0; k < tiles; k++) {
        const uint8_t *q = raw + k * IDX_REC;
        idx_rec *e = &p->idx[k];
        e->offset = get64(q), e->bytes = get32(q + 8), e->raw = get32(q + 12), e->sum = get64(q + 16);
        if (e->offset < HDR_BYTES || e->offset > fsize || e->bytes > fsize - e->offset || e->bytes == 0 ||
            e->raw > (64u << 20)) {
            free(raw);
            r = bad_file(err, path, "a tile lies outside the file");
            goto fail;
        }
    }
    free(raw);
    in->wkt = p->wkt;
    *out = p;
    return HZ_OK;
fail:
    hz_pyramid_close(p);
    return r;
}

void hz_pyramid_close(hz_pyramid *p)
{
    if (!p)
        return;
    if (p->src)
        p->src->vt->close(p->src);
    free(p->idx);
    free(p->wkt);
    free(p);
}

bool hz_pyramid_is_remote(const hz_pyramid *p)
{
    return p->src->remote;
}

hz_pyr_transfer hz_pyramid_query_transfer(const hz_pyramid *p)
{
    return p->src->vt->transfer ? p->src->vt->transfer(p->src) : (hz_pyr_transfer){0};
}

const hz_pyr_info *hz_pyramid_info(const hz_pyramid *p)
{
    return &p->info;
}

uint32_t hz_pyramid_tiles_per_side(const hz_pyramid *p, uint32_t level)
{
    return level < p->info.levels ? hz_pyr_level_tiles(&p->info, level) : 0;
}

uint32_t hz_pyramid_tile_cells(const hz_pyramid *p, uint32_t level)
{
    return level < p->info.levels ? hz_pyr_level_cells(&p->info, level) : 0;
}

static const idx_rec *rec_of(const hz_pyramid *p, uint32_t level, uint32_t tx, uint32_t tz)
{
    const uint32_t m = hz_pyr_level_tiles(&p->info, level);
    return &p->idx[p->level_first[level] + (uint64_t)tz * m + tx];
}

uint32_t hz_pyramid_tile_bytes(const hz_pyramid *p, uint32_t level, uint32_t tx, uint32_t tz)
{
    if (level >= p->info.levels || tx >= hz_pyr_level_tiles(&p->info, level) ||
        tz >= hz_pyr_level_tiles(&p->info, level))
        return 0;
    return rec_of(p, level, tx, tz)->bytes;
}

static hz_result decode(const hz_pyr_info *in, const char *path, uint32_t level, uint32_t tx, uint32_t tz,
                        const uint8_t *r, size_t raw, hz_pyr_tile *t, hz_err *err)
{
    const uint32_t c = hz_pyr_level_cells(in, level), n = c + 1, k = c / in->patch_cells;
    const size_t nn = (size_t)n * n, k2 = (size_t)(k + 2) * (k + 2);
    if (raw < TILE_HDR || get32(r) != TILE_MAGIC || get32(r + 4) != level || get32(r + 8) != tx ||
        get32(r + 12) != tz || get32(r + 16) != c || get32(r + 20) > 1)
        return hz_err_set(err, HZ_ERR_FORMAT, "'%s': tile %u/%u/%u has a wrong tile header", path, level, tx, tz);
    const bool masked = get32(r + 20) & 1u;
    if (raw != raw_tile_bytes(in, level, masked))
        return hz_err_set(err, HZ_ERR_FORMAT, "'%s': tile %u/%u/%u has %zu bytes, expected %zu", path, level, tx,
                          tz, raw, raw_tile_bytes(in, level, masked));
    memset(t, 0, sizeof *t);
    t->level = level, t->tx = tx, t->tz = tz, t->cells = c, t->nodes = k;
    t->x0 = (tx * c) << level, t->z0 = (tz * c) << level;
    t->h = malloc((nn + 4 * (size_t)c + 8) * sizeof *t->h); /* the apron follows the heights */
    t->node_delta = malloc((k2 + (size_t)k * k * 2) * sizeof(uint16_t));
    t->valid = masked ? malloc(nn) : NULL;
    if (!t->h || !t->node_delta || (masked && !t->valid)) {
        hz_pyr_tile_free(t);
        return hz_err_set(err, HZ_ERR_MEMORY, "out of memory decoding a tile");
    }
    t->node_min = t->node_delta + k2;
    t->node_max = t->node_min + (size_t)k * k;
    const uint8_t *q = r + TILE_HDR;
    for (size_t j = 0; j < n; j++)
        for (size_t i = 0; i < n; i++) {
            uint16_t *h = t->h + j * n + i;
            const uint16_t d = (uint16_t)(q[j * n + i] | (q[nn + j * n + i] << 8));
            int pred = i && j ? (int)h[-1] + h[-(ptrdiff_t)n] - h[-(ptrdiff_t)n - 1]
                              : (i ? h[-1] : (j ? h[-(ptrdiff_t)n] : 0));
            h[0] = (uint16_t)(pred + d);
        }
    q += 2 * nn;
    t->apron = t->h + nn;
    for (size_t s = 0; s < 4 * (size_t)c + 8; s++)
        t->apron[s] = get16(q + 2 * s);
    q += 2 * (4 * (size_t)c + 8);
    if (masked) {
        for (size_t s = 0; s < nn; s++)
            t->valid[s] = (q[s >> 3] >> (s & 7)) & 1u;
        q += (nn + 7) / 8;
    }
    for (size_t s = 0; s < k2 + (size_t)k * k * 2; s++)
        t->node_delta[s] = get16(q + 2 * s);
    for (size_t s = 0; s < (size_t)k * k; s++)
        if (t->node_min[s] > t->node_max[s]) {
            hz_pyr_tile_free(t);
            return hz_err_set(err, HZ_ERR_FORMAT,
                              "'%s': tile %u/%u/%u has a node whose minimum exceeds its maximum", path, level,
                              tx, tz);
        }
    return HZ_OK;
}

hz_result hz_pyramid_read_tile(hz_pyramid *p, uint32_t level, uint32_t tx, uint32_t tz, hz_pyr_tile *t, hz_err *err)
{
    memset(t, 0, sizeof *t);
    if (level >= p->info.levels || tx >= hz_pyr_level_tiles(&p->info, level) ||
        tz >= hz_pyr_level_tiles(&p->info, level))
        return hz_err_set(err, HZ_ERR_VALUE, "'%s' has no tile %u/%u/%u", p->path, level, tx, tz);
    const idx_rec *e = rec_of(p, level, tx, tz);
    uint8_t *z = malloc(e->bytes);
    uint8_t *r = malloc(e->raw ? e->raw : 1);
    if (!z || !r) {
        free(z);
        free(r);
        return hz_err_set(err, HZ_ERR_MEMORY, "out of memory reading a tile");
    }
    hz_result res = HZ_OK;
    hz_err re = {0};
    if (p->src->vt->read(p->src, z, e->bytes, e->offset, &e->sum, &re) != HZ_OK)
        res = hz_err_set(err, re.code ? re.code : HZ_ERR_IO, "'%s': cannot read tile %u/%u/%u: %s", p->path, level, tx,
                         tz, re.msg);
    else if (XXH64(z, e->bytes, 0) != e->sum)
        res = hz_err_set(err, HZ_ERR_FORMAT, "'%s': tile %u/%u/%u fails its checksum (corrupt)", p->path, level, tx, tz);
    if (res == HZ_OK) {
        const size_t got = ZSTD_decompress(r, e->raw, z, e->bytes);
        if (ZSTD_isError(got) || got != e->raw)
            res = hz_err_set(err, HZ_ERR_FORMAT, "'%s': tile %u/%u/%u does not decompress (%s)", p->path, level, tx,
                             tz, ZSTD_isError(got) ? ZSTD_getErrorName(got) : "wrong size");
    }
    if (res == HZ_OK)
        res = decode(&p->info, p->path, level, tx, tz, r, e->raw, t, err);
    free(z);
    free(r);
    return res;
}

hz_result hz_pyr_decode_blob(const hz_pyr_info *info, uint32_t level, uint32_t tx, uint32_t tz, const void *blob,
                             size_t bytes, hz_pyr_tile *t, hz_err *err)
{
    memset(t, 0, sizeof *t);
    unsigned long long raw = ZSTD_getFrameContentSize(blob, bytes);
    if (raw == ZSTD_CONTENTSIZE_ERROR || raw == ZSTD_CONTENTSIZE_UNKNOWN || raw > (64u << 20))
        return hz_err_set(err, HZ_ERR_FORMAT, "tile %u/%u/%u is not a zstd frame", level, tx, tz);
    uint8_t *r = malloc(raw ? raw : 1);
    if (!r)
        return hz_err_set(err, HZ_ERR_MEMORY, "out of memory decoding a tile");
    const size_t got = ZSTD_decompress(r, raw, blob, bytes);
    hz_result res = ZSTD_isError(got) || got != raw
                        ? hz_err_set(err, HZ_ERR_FORMAT, "tile %u/%u/%u does not decompress", level, tx, tz)
                        : decode(info, "part", level, tx, tz, r, raw, t, err);
    free(r);
    return res;
}

hz_result hz_pyramid_verify(hz_pyramid *p, uint64_t *bad, hz_progress_fn progress, void *user, hz_err *err)
{
    *bad = 0;
    hz_result first = HZ_OK;
    uint64_t done = 0;
    for (uint32_t l = 0; l < p->info.levels; l++) {
        const uint32_t m = hz_pyr_level_tiles(&p->info, l);
        for (uint32_t tz = 0; tz < m; tz++)
            for (uint32_t tx = 0; tx < m; tx++) {
                hz_pyr_tile t;
                hz_err e = {0};
                hz_result r = hz_pyramid_read_tile(p, l, tx, tz, &t, &e);
                if (r != HZ_OK) {
                    if (first == HZ_OK) {
                        first = r;
                        if (err)
                            *err = e;
                    }
                    (*bad)++;
                } else {
                    hz_pyr_tile_free(&t);
                }
                if (progress && (++done % 256 == 0 || done == p->info.tiles))
                    progress(user, "verify", done, p->info.tiles);
            }
    }
    return first;
}

/* ---- writing ---- */

struct hz_pyr_writer {
    hz_outfile of;
    FILE *f;
    uint64_t pos;
    hz_pyr_info info;
    uint64_t level_first[HZ_PYR_MAX_LEVELS + 1];
    idx_rec *idx;
    uint8_t *seen;
};

hz_result hz_pyr_writer_open(const char *path, const hz_pyr_info *info, hz_pyr_writer **out, hz_err *err)
{
    *out = NULL;
    hz_pyr_writer *w = calloc(1, sizeof *w);
    if (!w)
        return hz_err_set(err, HZ_ERR_MEMORY, "out of memory");
    w->info = *info;
    uint64_t tiles = 0;
    for (uint32_t l = 0; l < info->levels; l++) {
        w->level_first[l] = tiles;
        const uint64_t m = hz_pyr_level_tiles(info, l);
        tiles += m * m;
    }
    w->level_first[info->levels] = tiles;
    w->info.tiles = tiles;
    w->idx = calloc(tiles, sizeof *w->idx);
    w->seen = calloc(tiles, 1);
    if (!w->idx || !w->seen) {
        free(w->idx);
        free(w->seen);
        free(w);
        return hz_err_set(err, HZ_ERR_MEMORY, "out of memory for a %llu-tile index", (unsigned long long)tiles);
    }
    w->f = hz_outfile_open(&w->of, path, err);
    if (!w->f) {
        free(w->idx);
        free(w->seen);
        free(w);
        return HZ_ERR_IO;
    }
    uint8_t zero[HDR_BYTES] = {0};
    if (fwrite(zero, 1, HDR_BYTES, w->f) != HDR_BYTES) {
        hz_pyr_writer_abort(w);
        return hz_err_set(err, HZ_ERR_IO, "cannot write '%s': %s", path, strerror(errno));
    }
    w->pos = HDR_BYTES;
    *out = w;
    return HZ_OK;
}

hz_result hz_pyr_writer_put(hz_pyr_writer *w, uint32_t level, uint32_t tx, uint32_t tz, const void *blob, size_t bytes,
                            hz_err *err)
{
    const uint32_t m = level < w->info.levels ? hz_pyr_level_tiles(&w->info, level) : 0;
    if (tx >= m || tz >= m || bytes == 0 || bytes > UINT32_MAX)
        return hz_err_set(err, HZ_ERR_VALUE, "pyramid writer: no tile %u/%u/%u", level, tx, tz);
    const uint64_t k = w->level_first[level] + (uint64_t)tz * m + tx;
    if (w->seen[k])
        return hz_err_set(err, HZ_ERR_VALUE, "pyramid writer: tile %u/%u/%u written twice", level, tx, tz);
    unsigned long long raw = ZSTD_getFrameContentSize(blob, bytes);
    if (raw == ZSTD_CONTENTSIZE_ERROR || raw == ZSTD_CONTENTSIZE_UNKNOWN || raw > (64u << 20))
        return hz_err_set(err, HZ_ERR_VALUE, "pyramid writer: tile %u/%u/%u is not a zstd frame", level, tx, tz);
    if (fwrite(blob, 1, bytes, w->f) != bytes)
        return hz_err_set(err, HZ_ERR_IO, "cannot write '%s': %s", w->of.path, strerror(errno));
    w->idx[k] = (idx_rec){.offset = w->pos, .bytes = (uint32_t)bytes, .raw = (uint32_t)raw, .sum = XXH64(blob, bytes, 0)};
    w->seen[k] = 1;
    w->pos += bytes;
    return HZ_OK;
}

hz_result hz_pyr_writer_finish(hz_pyr_writer *w, const hz_pyr_info *info, hz_err *err)
{
    const uint64_t tiles = w->info.tiles;
    for (uint64_t k = 0; k < tiles; k++)
        if (!w->seen[k]) {
            hz_pyr_writer_abort(w);
            return hz_err_set(err, HZ_ERR_VALUE, "pyramid writer: tile %llu of %llu was never written",
                              (unsigned long long)k, (unsigned long long)tiles);
        }
    const char *wkt = info->wkt ? info->wkt : "";
    const uint32_t wkt_bytes = (uint32_t)strlen(wkt);
    const uint64_t wkt_off = w->pos, idx_off = wkt_off + wkt_bytes, idx_bytes = tiles * IDX_REC + 8;
    uint8_t *raw = malloc(idx_bytes);
    if (!raw) {
        hz_pyr_writer_abort(w);
        return hz_err_set(err, HZ_ERR_MEMORY, "out of memory for the index");
    }
    for (uint64_t k = 0; k < tiles; k++) {
        uint8_t *q = raw + k * IDX_REC;
        put64(q, w->idx[k].offset), put32(q + 8, w->idx[k].bytes), put32(q + 12, w->idx[k].raw);
        put64(q + 16, w->idx[k].sum);
    }
    put64(raw + tiles * IDX_REC, XXH64(raw, tiles * IDX_REC, 0));
    uint8_t h[HDR_BYTES] = {0};
    memcpy(h, MAGIC, 8);
    put32(h + 8, HZ_PYR_VERSION), put32(h + 12, HDR_BYTES);
    put32(h + 16, info->size), put32(h + 20, info->data_w), put32(h + 24, info->data_h);
    put32(h + 28, info->tile_cells), put32(h + 32, info->patch_cells), put32(h + 36, info->levels);
    putd(h + 40, info->spacing), putd(h + 48, info->h_scale), putd(h + 56, info->h_offset);
    put16(h + 64, info->h_min), put16(h + 66, info->h_max);
    put32(h + 68, info->wrap ? 1u : 0u);
    putd(h + 72, info->max_error);
    put64(h + 80, tiles), put64(h + 88, info->nodata);
    for (int k = 0; k < 6; k++)
        putd(h + 96 + 8 * k, info->geotransform[k]);
    put64(h + 144, idx_off), put64(h + 152, idx_bytes), put64(h + 160, wkt_off), put32(h + 168, wkt_bytes);
    put64(h + 176, idx_off + idx_bytes);
    put64(h + HDR_SUM, XXH64(h, HDR_SUM, 0));
    bool ok = fwrite(wkt, 1, wkt_bytes, w->f) == wkt_bytes && fwrite(raw, 1, idx_bytes, w->f) == idx_bytes &&
              fseek(w->f, 0, SEEK_SET) == 0 && fwrite(h, 1, HDR_BYTES, w->f) == HDR_BYTES;
    free(raw);
    if (!ok) {
        hz_err_set(err, HZ_ERR_IO, "cannot write '%s': %s", w->of.path, strerror(errno));
        hz_pyr_writer_abort(w);
        return HZ_ERR_IO;
    }
    hz_result r = hz_outfile_close(&w->of, w->f, err);
    free(w->idx);
    free(w->seen);
    free(w);
    return r;
}

void hz_pyr_writer_abort(hz_pyr_writer *w)
{
    if (!w)
        return;
    if (w->f)
        fclose(w->f);
    hz_outfile_discard(&w->of);
    free(w->idx);
    free(w->seen);
    free(w);
}
