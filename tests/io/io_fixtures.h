/* Small DEM files written by the tests themselves (libpng, zlib), so every
 * format can be round-tripped and mutated without external tools. */
#ifndef HZ_TEST_IO_FIXTURES_H
#define HZ_TEST_IO_FIXTURES_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "horizon/dem.h"

/* Deterministic test RNG (splitmix64). */
uint64_t fx_rand(uint64_t *s);

/* Full path of a file in the test's temp dir (static buffer per call slot 0..7). */
const char *fx_tmp(const char *name);

/* Raw bytes to / from a file. Return false on failure. */
bool fx_write(const char *path, const void *data, size_t n);
uint8_t *fx_read(const char *path, size_t *n);
/* gzip the bytes with zlib's gzopen/gzwrite. */
bool fx_write_gz(const char *path, const void *data, size_t n);

/* PNG writers (libpng). samples: w*h*channels values, 8 or 16 bit depth.
 * color_type is a PNG_COLOR_TYPE_*; interlace true -> Adam7. */
bool fx_write_png(const char *path, uint32_t w, uint32_t h, int depth, int color_type, bool interlace,
                  const uint16_t *samples);
/* 8-bit palette PNG: indices w*h, palette of n RGB triples; depth 1/2/4/8. */
bool fx_write_png_palette(const char *path, uint32_t w, uint32_t h, int depth, const uint8_t *indices,
                          const uint8_t *rgb, int n);

/* A GeoTIFF header (little-endian, one strip) claiming a w x h raster of
 * `bands` samples of `bits` bits (sample_format 1 unsigned, 3 float) with
 * `compression` (1 none, 8 deflate), in EPSG:epsg with its top-left corner at
 * (x0, y0) and square pixels of `px`, followed by only 12 bytes of data: a
 * file whose size has nothing to do with what it claims. */
bool fx_write_tiff_claim(const char *path, uint32_t w, uint32_t h, uint16_t bands, uint16_t bits,
                         uint16_t sample_format, uint16_t compression, double x0, double y0, double px, uint16_t epsg);

/* Terrarium encoding of a height in metres. */
void fx_terrarium(float h, uint8_t rgb[3]);

/* Sample file set used by the round-trip and mutation tests: writes each
 * file under fx_tmp() and fills the expected values. */
typedef struct fx_case {
    const char *name;     /* file name in the temp dir */
    hz_dem_format want;   /* format expected in info */
    uint32_t w, h;        /* expected size */
    float *z;             /* expected metres (NaN = void), w*h; owned */
    float tol;            /* allowed abs error */
    uint32_t raw_w, raw_h;/* desc.width/height to pass */
} fx_case;

/* Builds all cases; returns the count. *cases is malloc'd; free with fx_free_cases. */
size_t fx_make_cases(fx_case **cases);
void fx_free_cases(fx_case *cases, size_t n);

#endif
