/* Terrain pyramids (.hzp): a DEM or a generated terrain of any size cut into
 * tiles at every level of detail, compressed (zstd) and checksummed (XXH64),
 * read tile by tile so that a terrain far larger than memory can be flown
 * over. The file layout is documented in docs/pyramid.md. No GL. */
#ifndef HZ_PYRAMID_H
#define HZ_PYRAMID_H

#include "horizon/core.h"
#include "horizon/dem.h"

#ifdef __cplusplus
extern "C" {
#endif

#define HZ_PYR_VERSION 1u
#define HZ_PYR_MAX_LEVELS 24u

/* What a pyramid holds. Level l has samples 2^l apart; every level is cut in
 * tiles of tile_cells x tile_cells cells ((tile_cells + 1)^2 samples, borders
 * shared), or one smaller tile when the whole level is smaller. */
typedef struct hz_pyr_info {
    uint32_t version;
    uint32_t size;        /* samples per side of level 0 (2^k + 1); data at the north-west */
    uint32_t data_w, data_h; /* samples with data in the source (the rest is no data) */
    uint32_t tile_cells;  /* T */
    uint32_t patch_cells; /* P: LOD nodes are P x P cells of their level */
    uint32_t levels;      /* 0 .. levels - 1; the last is one P x P node */
    double spacing;       /* metres between level-0 samples (x and z) */
    double h_scale, h_offset; /* metres = h_offset + h_scale * h16 */
    uint16_t h_min, h_max;    /* over samples with data */
    bool wrap;            /* the terrain repeats in x and z with a period of size - 1 samples */
    double max_error;     /* largest |quantised - source| in metres measured at import (0: lossless) */
    uint64_t tiles;       /* tiles in all levels */
    uint64_t nodata;      /* level-0 samples without data inside data_w x data_h */
    uint64_t file_bytes;
    double geotransform[6]; /* of level 0, as GDAL's; all 0 when not georeferenced */
    const char *wkt;      /* CRS; "" when not georeferenced */
} hz_pyr_info;

/* One decoded tile. Heights of samples without data are filled (smooth) and
 * flagged in valid. */
typedef struct hz_pyr_tile {
    uint32_t level, tx, tz;
    uint32_t cells;       /* c: (c + 1)^2 samples */
    uint32_t x0, z0;      /* level-0 sample of its north-west corner */
    uint16_t *h;          /* (c + 1)^2 */
    uint16_t *apron;      /* 4c + 8: the ring of samples just outside the tile (for normals): row -1
                             (x = -1 .. c + 1), then x = -1 and x = c + 1 of rows 0 .. c, then row
                             c + 1; off the map, extrapolated from the edge */
    uint8_t *valid;       /* (c + 1)^2, 1 = data; NULL when every sample has data */
    uint32_t nodes;       /* k = c / P nodes per side at this level */
    uint16_t *node_delta; /* (k+2)^2: error bound (h16 steps) of each node of this level and of the
                             ring of nodes around the tile (row -1 first; 0 off the map) */
    uint16_t *node_min, *node_max; /* k^2: h16 range under each node */
} hz_pyr_tile;

typedef struct hz_pyramid hz_pyramid;

/* Opens and checks the header and the index (a truncated or corrupt file is
 * refused). Tiles are read on demand; thread-safe reads. path is a file or an
 * http:// or https:// URL (read with hz_pyr_remote's defaults). */
hz_result hz_pyramid_open(const char *path, hz_pyramid **out, hz_err *err);

/* How a pyramid at an http(s) URL is read (docs/serving.md): HTTP range
 * requests on the one file (the header, the index, then one per tile),
 * connections kept alive, retries with exponential backoff, and an optional
 * folder keeping what was fetched, validated by the index's checksums, so a
 * second run (or one offline) reads from disk. Ignored for files. */
typedef struct hz_pyr_remote {
    const char *disk_cache;    /* folder of fetched bytes (created); NULL -> none */
    uint64_t disk_cache_bytes; /* bound of that folder, least recently used out first; 0 -> 1 GB */
    uint32_t timeout_ms;       /* one request, connection included; 0 -> 10000 */
    uint32_t retries;          /* more attempts after a failed one (5xx, 408, 429, a timeout, a dropped
                                * connection, a short or corrupt body); 0 -> 4 */
    uint32_t connections;      /* kept-alive handles (and the stream's loader threads); 0 -> 8 */
} hz_pyr_remote;

/* What reading cost so far (all threads). Zero for a file. */
typedef struct hz_pyr_transfer {
    uint64_t requests;     /* HTTP requests sent, every attempt counted */
    uint64_t bytes;        /* response bytes received for reads */
    uint64_t retries;      /* attempts after a failed one */
    uint64_t failures;     /* reads that failed after every attempt */
    uint64_t cache_hits;   /* reads served by the disk cache */
    uint64_t cache_bytes;  /* bytes served by the disk cache */
    uint64_t cache_evicted; /* entries removed to stay under the bound */
    uint64_t cache_rejected; /* entries that failed their checksum (fetched again) */
    bool offline;          /* opened from the disk cache: the server did not answer */
} hz_pyr_transfer;

/* hz_pyramid_open with the options of a remote pyramid (remote may be NULL:
 * defaults). remote->disk_cache is not retained; the rest is copied. */
hz_result hz_pyramid_open_with(const char *path, const hz_pyr_remote *remote, hz_pyramid **out, hz_err *err);
/* True when p is read over http(s). */
bool hz_pyramid_is_remote(const hz_pyramid *p);
/* Transfer figures since open; all zero for a file. */
hz_pyr_transfer hz_pyramid_query_transfer(const hz_pyramid *p);
void hz_pyramid_close(hz_pyramid *p);
const hz_pyr_info *hz_pyramid_info(const hz_pyramid *p);
/* Tiles per side of level l. */
uint32_t hz_pyramid_tiles_per_side(const hz_pyramid *p, uint32_t level);
/* Cells per side of a tile of level l. */
uint32_t hz_pyramid_tile_cells(const hz_pyramid *p, uint32_t level);
/* Compressed bytes of a tile (what a read costs). */
uint32_t hz_pyramid_tile_bytes(const hz_pyramid *p, uint32_t level, uint32_t tx, uint32_t tz);
/* Reads, verifies (checksum) and decodes a tile into t (buffers allocated
 * here; hz_pyr_tile_free). A corrupt tile is an HZ_ERR_FORMAT naming it. */
hz_result hz_pyramid_read_tile(hz_pyramid *p, uint32_t level, uint32_t tx, uint32_t tz, hz_pyr_tile *t, hz_err *err);
void hz_pyr_tile_free(hz_pyr_tile *t);
/* Checks every tile's checksum and decoding; returns the first error. bad
 * receives the count of bad tiles. */
hz_result hz_pyramid_verify(hz_pyramid *p, uint64_t *bad, hz_progress_fn progress, void *user, hz_err *err);

/* ---- import ---- */

typedef struct hz_pyr_import {
    const char *out;             /* the .hzp file to write (never one of the inputs) */
    const char *const *inputs;   /* GDAL rasters or folders, mosaicked; or NULL with generate */
    uint32_t input_count;
    bool generate;               /* Perlin terrain of gen.size samples instead of inputs */
    hz_gen_desc gen;
    const char *crs;             /* reproject geographic input to this CRS; NULL -> UTM of the centre */
    double spacing;              /* metres per sample after reprojection / of a generated terrain; 0 -> auto (generated: 10) */
    double zscale;               /* metres per source unit (e.g. 0.3048 for feet); 0 -> 1 */
    double max_error;            /* metres; 0 -> lossless for 16-bit integer input, else range / 65535 / 2 */
    const char *tiles;           /* "A-B": write only jobs A..B (0-based, see hz_pyramid_jobs) to
                                    out.part-A-B; NULL: everything */
    bool finish;                 /* join the part files of every job into out */
    bool wrap;                   /* a repeating terrain: generated Perlin is made periodic; a DEM
                                    must be square, 2^k+1, and its last row and column become its
                                    first (the seam joins) */
    uint32_t tile_cells;         /* 0 -> 256 */
    uint32_t patch_cells;        /* 0 -> 8 */
    uint32_t threads;            /* 0 -> every core */
    int zstd_level;              /* 0 -> 9 */
    hz_progress_fn progress;
    void *progress_user;
} hz_pyr_import;

typedef struct hz_pyr_import_stats {
    uint64_t samples;       /* level 0, with the padding */
    uint64_t tiles;
    uint64_t bytes;
    double ms;
    double max_error;       /* measured quantisation error, metres */
    uint64_t finish_bytes;  /* what the finish holds for the levels above the jobs': the level-J
                               heights over the data's bounding box and the level-J node bounds */
} hz_pyr_import_stats;

/* Jobs an import of d splits into (independent: each reads its own window
 * and writes its own tiles); 0 on error. */
uint32_t hz_pyramid_jobs(const hz_pyr_import *d, hz_err *err);

/* Writes a pyramid, window by window (never the whole raster in memory;
 * about 6 bytes per 64 level-0 samples for the LOD bounds). The output is
 * written to a temporary file and renamed into place. */
hz_result hz_pyramid_import(const hz_pyr_import *d, hz_pyr_import_stats *stats, hz_err *err);

/* ---- low level (the import and tests): tile layout and the writer ---- */

/* Geometry of a level from the info alone. */
uint32_t hz_pyr_level_tiles(const hz_pyr_info *info, uint32_t level);
uint32_t hz_pyr_level_cells(const hz_pyr_info *info, uint32_t level);

/* Compresses a tile (thread-safe); *blob is malloc'ed. */
hz_result hz_pyr_encode_tile(const hz_pyr_info *info, const hz_pyr_tile *t, int zstd_level, void **blob,
                             size_t *bytes, hz_err *err);

/* The same, reusing one thread's compression state across tiles: a fresh zstd
 * context at level 9 is megabytes of new pages per tile. One encoder per
 * thread; hz_pyr_encoder_new returns NULL when out of memory. */
typedef struct hz_pyr_encoder hz_pyr_encoder;
hz_pyr_encoder *hz_pyr_encoder_new(void);
void hz_pyr_encoder_free(hz_pyr_encoder *e);
hz_result hz_pyr_encoder_tile(hz_pyr_encoder *e, const hz_pyr_info *info, const hz_pyr_tile *t, int zstd_level,
                              void **blob, size_t *bytes, hz_err *err);

/* Decompresses and decodes one tile's blob (as written by hz_pyr_encode_tile). */
hz_result hz_pyr_decode_blob(const hz_pyr_info *info, uint32_t level, uint32_t tx, uint32_t tz, const void *blob,
                             size_t bytes, hz_pyr_tile *t, hz_err *err);

typedef struct hz_pyr_writer hz_pyr_writer;
/* Starts writing path (through a temporary file in the same folder). */
hz_result hz_pyr_writer_open(const char *path, const hz_pyr_info *info, hz_pyr_writer **out, hz_err *err);
/* Appends one compressed tile; every tile must be put once. */
hz_result hz_pyr_writer_put(hz_pyr_writer *w, uint32_t level, uint32_t tx, uint32_t tz, const void *blob, size_t bytes,
                            hz_err *err);
/* Writes the index, the CRS and the header (info's final figures), then
 * renames the file into place. Frees w. */
hz_result hz_pyr_writer_finish(hz_pyr_writer *w, const hz_pyr_info *info, hz_err *err);
/* Removes the temporary file. Frees w. */
void hz_pyr_writer_abort(hz_pyr_writer *w);

#ifdef __cplusplus
}
#endif

#endif
