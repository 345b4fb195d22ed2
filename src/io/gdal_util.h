/* Private to src/io: what every GDAL reader of ours (DEMs, imagery,
 * footprints) shares. gdal_util.c. */
#ifndef HZ_IO_GDAL_UTIL_H
#define HZ_IO_GDAL_UTIL_H

#include <gdal.h>

#include "horizon/core.h"

/* Registers GDAL's drivers and sets what our readers need: no side files
 * written beside the inputs. Call before any GDAL read. */
void hz_io_gdal_setup(void);

/* The last GDAL error message, or fallback when there is none. */
const char *hz_io_gdal_msg(const char *fallback);

/* GDAL reads a raster block by block: a file whose blocks are huge (one
 * compressed strip for a whole large raster, or a corrupt header claiming
 * so) would take that much memory at once, whatever is read of it. Checks
 * bands 1..bands of ds, each block counted with all `bands` interleaved,
 * against 256 MB; refuses with a message starting with label. */
hz_result hz_io_gdal_blocks_ok(GDALDatasetH ds, int bands, const char *label, hz_err *err);

#endif
