/* libFuzzer: terrain pyramids (.hzp): the header, the index and every tile
 * (hz_pyramid_open, hz_pyramid_read_tile: zstd and the tile decoder). Each
 * input is opened as it is and once more with its checksums made right (the
 * header's, every tile's in the index when the tile lies in the file, then
 * the index's), so mutations reach the parsers behind the checksums. A file
 * is refused with a message, or opens into figures that hold together, and
 * each tile reads into a tile of the documented shape or is refused with a
 * message; never a crash, a leak or a hang.
 *
 * Seed corpus fuzz/corpus/pyramid: tiny generated pyramids (w65 with --wrap; tile payload of
 * the format version they were written with; regenerate them after a format
 * change):
 *   horizon import --generate perlin --size 33 --tile 16 --out fuzz/corpus/pyramid/s33
 *   horizon import --generate perlin --size 129 --tile 16 --out fuzz/corpus/pyramid/s129 */
#include <string.h>
#include <xxhash.h>

#include "fuzz_util.h"
#include "horizon/pyramid.h"

static uint64_t get64(const uint8_t *p)
{
    uint64_t v = 0;
    for (int k = 7; k >= 0; k--)
        v = (v << 8) | p[k];
    return v;
}

static uint32_t get32(const uint8_t *p)
{
    return (uint32_t)(p[0] | (p[1] << 8) | (p[2] << 16) | ((uint32_t)p[3] << 24));
}

static void put64(uint8_t *p, uint64_t v)
{
    for (int k = 0; k < 8; k++)
        p[k] = (uint8_t)(v >> (8 * k));
}

static void check(const uint8_t *data, size_t size)
{
    const char *path = fuzz_tmp_file("pyramid.hzp", data, size);
    if (!path)
        return;
    hz_pyramid *p = NULL;
    hz_err err = {0};
    if (hz_pyramid_open(path, &p, &err) != HZ_OK) {
        if (!err.msg[0])
            abort(); /* a refusal names its reason */
        return;
    }
    const hz_pyr_info *in = hz_pyramid_info(p);
    if (in->levels == 0 || in->levels > HZ_PYR_MAX_LEVELS || in->file_bytes != size || !in->wkt)
        abort();
    /* Every tile (a fuzzed file holds few: the index is 24 bytes a tile). */
    for (uint32_t l = 0; l < in->levels; l++) {
        const uint32_t m = hz_pyramid_tiles_per_side(p, l), c = hz_pyramid_tile_cells(p, l);
        for (uint32_t tz = 0; tz < m; tz++)
            for (uint32_t tx = 0; tx < m; tx++) {
                hz_pyr_tile t;
                hz_err e = {0};
                if (hz_pyramid_read_tile(p, l, tx, tz, &t, &e) != HZ_OK) {
                    if (!e.msg[0])
                        abort();
                    continue;
                }
                if (t.level != l || t.tx != tx || t.tz != tz || t.cells != c || !t.h || !t.node_delta ||
                    t.nodes != c / in->patch_cells)
                    abort();
                /* touch every sample and bound: ASan sees a short buffer */
                uint64_t s = 0;
                for (size_t k = 0; k < (size_t)(c + 1) * (c + 1); k++)
                    s += t.h[k] + (t.valid ? t.valid[k] : 0u);
                for (size_t k = 0; k < 4 * (size_t)c + 8; k++)
                    s += t.apron[k];
                for (size_t k = 0; k < (size_t)(t.nodes + 2) * (t.nodes + 2); k++)
                    s += t.node_delta[k];
                for (size_t k = 0; k < (size_t)t.nodes * t.nodes; k++)
                    s += t.node_min[k] + t.node_max[k];
                if (s == UINT64_MAX)
                    abort();
                hz_pyr_tile_free(&t);
            }
    }
    hz_pyramid_close(p);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    check(data, size);
    if (size < 512)
        return 0;
    uint8_t *c = malloc(size);
    if (!c)
        return 0;
    memcpy(c, data, size);
    /* The layout of docs/pyramid.md: index offset and bytes at 144, records
     * of 24 bytes (offset, bytes, raw, XXH64), then the XXH64 of the records. */
    const uint64_t io = get64(c + 144), ib = get64(c + 152);
    if (io <= size && ib >= 8 && ib <= size - io && (ib - 8) % 24 == 0) {
        const uint64_t n = (ib - 8) / 24;
        for (uint64_t k = 0; k < n; k++) {
            uint8_t *r = c + io + 24 * k;
            const uint64_t off = get64(r);
            const uint32_t bytes = get32(r + 8);
            if (off <= size && bytes <= size - off)
                put64(r + 16, XXH64(c + off, bytes, 0));
        }
        put64(c + io + 24 * n, XXH64(c + io, 24 * n, 0));
    }
    put64(c + 504, XXH64(c, 504, 0));
    if (memcmp(c, data, size))
        check(c, size);
    free(c);
    return 0;
}
