/* Private to src/io: shared between the DEM loader and the PNG codec. */
#ifndef HZ_IO_INTERNAL_H
#define HZ_IO_INTERNAL_H

#include "horizon/dem.h"
#include "horizon/georef.h"

/* Largest accepted side of any grid or image, from any header. */
#define HZ_IO_MAX_SIDE 65537u

/* Throttled progress: forwards to fn at most ~100 times per job. */
typedef struct hz_io_progress {
    hz_progress_fn fn;
    void *user;
    const char *label;
    uint64_t total;
    int last_pct;
} hz_io_progress;

void hz_io_progress_step(hz_io_progress *p, uint64_t done);

/* What the PNG decoder found. */
typedef struct hz_png_result {
    bool terrarium;  /* values are Terrarium metres (else the grey sample value) */
    uint32_t bit_depth; /* of the decoded grey samples: 8 or 16 */
} hz_png_result;

/* Decodes a PNG held in memory into g (allocated here). want is HZ_DEM_AUTO,
 * HZ_DEM_PNG or HZ_DEM_TERRARIUM; name_terrarium says the file name contains
 * "terrarium". Grey (and grey-palette) images give the sample value,
 * colour images the Terrarium height (R*256 + G + B/256 - 32768). Errors name
 * path. */
hz_result hz_io_png_decode(const char *path, const uint8_t *data, size_t size, hz_dem_format want,
                           bool name_terrarium, hz_io_progress *prog, hz_grid *g, hz_png_result *res,
                           hz_err *err);

/* True if auto detection should hand path to GDAL: a folder, or a file a GDAL
 * driver other than PNG identifies (raw .r16/.r32/.raw and non-SRTM .gz stay ours). */
bool hz_io_gdal_wants(const char *path);

/* Reads d->path (or d->paths, mosaicked) through GDAL into out: band 1 as
 * float, nodata -> NaN, band scale/offset applied, reprojected when d->metric
 * asks; fills info's GDAL fields, voids and spacing_hint, and *d->georef.
 * units receives the band's unit string ("m", "ft", "" ...). */
hz_result hz_io_gdal_load(const hz_dem_desc *d, hz_grid *out, hz_dem_info *info, char *units, size_t units_cap,
                          hz_err *err);

#endif
