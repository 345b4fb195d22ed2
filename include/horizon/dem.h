/* horizon DEM loading and terrain generation. No GL. */
#ifndef HORIZON_DEM_H
#define HORIZON_DEM_H

#include "horizon/georef.h"
#include "horizon/grid.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum hz_dem_format {
    HZ_DEM_AUTO = 0,   /* from the file name (extension, after stripping .gz) and contents */
    HZ_DEM_PNG,        /* 16-bit grey (or 8-bit grey/palette) PNG; value * units */
    HZ_DEM_TERRARIUM,  /* 8-bit RGB PNG, h = R*256 + G + B/256 - 32768 metres */
    HZ_DEM_HGT,        /* SRTM .hgt: int16 big-endian, square, side = sqrt(bytes/2), void -32768 */
    HZ_DEM_R16,        /* raw uint16 little-endian, side from desc.size (or sqrt(bytes/2)) */
    HZ_DEM_R32,        /* raw float32 little-endian, side from desc.size (or sqrt(bytes/4)) */
    HZ_DEM_GDAL        /* anything GDAL reads (GeoTIFF, SRTM .hgt/.hgt.zip, ENVI, ASCII grid, VRT...);
                          chosen by auto for every file GDAL identifies except PNG, and for
                          several files or a folder (a mosaic) */
} hz_dem_format;

typedef enum hz_dem_units {
    HZ_UNITS_AUTO = 0, /* from the file name: "_ft16" feet, "_dm16" decimetres, else metres */
    HZ_UNITS_M,
    HZ_UNITS_FT,
    HZ_UNITS_DM,
    HZ_UNITS_RAW       /* the stored value as is */
} hz_dem_units;

typedef struct hz_dem_desc {
    const char *path;      /* required unless path_count > 0; a trailing ".gz" means gzip-compressed;
                              a folder means every raster GDAL identifies in it, mosaicked */
    const char *const *paths; /* optional: path_count files or folders mosaicked as one terrain
                                 (GDALBuildVRT; later files win where they overlap) */
    uint32_t path_count;   /* 0 -> use path */
    bool metric;           /* GDAL inputs: reproject (GDALWarp, bilinear) a geographic, rotated or
                              non-square-cell grid to a metric CRS with square cells; false keeps the
                              stored grid */
    const char *crs;       /* target CRS for metric ("EPSG:32633", WKT, PROJ); NULL -> the input's own
                              CRS if projected, else the WGS 84 UTM zone of the centre */
    double spacing;        /* metres per sample of the reprojected grid; 0 -> the finer of the input's
                              two spacings at its centre, so no detail is lost */
    hz_georef **georef;    /* optional out: the georeference of the returned grid (NULL when the file
                              has none); free with hz_georef_destroy */
    hz_dem_format format;  /* 0 -> auto */
    hz_dem_units units;    /* 0 -> auto */
    uint32_t width;        /* raw formats: samples per row; 0 -> square from the byte count */
    uint32_t height;       /* raw formats: rows; 0 -> same as width */
    hz_progress_fn progress; /* optional */
    void *progress_user;
    uint64_t max_memory;   /* bytes the decoded grid (and decompressed data) may take, checked
                              before allocating; 0 -> hz_mem_budget_default() */
    /* optional: GDAL inputs call it with the size the returned grid will have
     * (and its metres per sample, 0 if unknown, and whether it has a
     * georeference) before reading or reprojecting a sample; a result other
     * than HZ_OK ends the load with it. The caller's own limits are refused
     * at once, not after the work. */
    hz_result (*size_check)(void *user, uint32_t width, uint32_t height, double spacing, bool georef, hz_err *err);
    void *size_check_user;
} hz_dem_desc;

typedef struct hz_dem_info {
    hz_dem_format format;  /* format actually read */
    hz_dem_units units;    /* units actually applied */
    uint64_t voids;        /* samples that were void/nodata (stored as NaN in the grid) */
    float spacing_hint;    /* metres between samples if known from the format or name
                              (SRTM 1201 -> 90, 3601 -> 30, "_3as_" 90, "_1as_" 30,
                              "_10m" 10 ...), else 0; for georeferenced files the
                              grid's spacing in metres (the finer of x and y) */
    char driver[32];       /* GDAL driver that read it ("GTiff", "SRTMHGT", "VRT"...); "" for ours */
    uint32_t files;        /* inputs read (several for a mosaic) */
    uint32_t file_width, file_height; /* the raster as stored (or the mosaic before reprojection) */
    double file_spacing_x, file_spacing_y; /* its metres per sample at the centre; 0 if not georeferenced */
    uint64_t file_voids;   /* nodata samples in the stored raster (before reprojection) */
    bool reprojected;      /* GDALWarp made the returned grid (its voids include the area outside
                              the input's footprint) */
    double full_scale;     /* the largest value of the stored sample type, what a normalised
                              file's top maps to: 255 or 65535 (8/16-bit unsigned: grey PNG,
                              .r16, GDAL Byte/UInt16), 32767 (int16: .hgt, GDAL Int16),
                              4294967295 / 2147483647 (GDAL UInt32 / Int32), 1 for float
                              samples (.r32, GDAL Float32/64: normalised floats are 0..1);
                              0 when there is none (Terrarium, which stores metres) */
} hz_dem_info;

/* Reads a DEM into out (allocated here; free with hz_grid_free). Voids become
 * NaN; the caller fills them (hz_grid_fill_voids). Never reads out of bounds:
 * truncated, oversized or garbage files return HZ_ERR_FORMAT with a message
 * naming the file, the expected and the actual size. info may be NULL. */
hz_result hz_dem_load(const hz_dem_desc *desc, hz_grid *out, hz_dem_info *info, hz_err *err);

/* Writes a grid as a 16-bit grey PNG (values mapped linearly from [lo, hi] to
 * 0..65535; pass lo == hi to use the grid's range) — used by tests and import. */
hz_result hz_dem_write_png16(const char *path, const hz_grid *g, float lo, float hi, hz_err *err);

/* Names for the CLI: "png", "terrarium", "hgt", "r16", "r32", "gdal"; parse returns false if unknown. */
const char *hz_dem_format_name(hz_dem_format f);
bool hz_dem_format_parse(const char *s, hz_dem_format *out);

typedef enum hz_gen_kind {
    HZ_GEN_PERLIN = 1, /* fBm of gradient noise: low octaves mountains, high octaves roughness */
    HZ_GEN_DIAMOND     /* diamond-square midpoint displacement */
} hz_gen_kind;

typedef struct hz_gen_desc {
    hz_gen_kind kind;   /* required */
    uint32_t size;      /* side, must be 2^n+1, >= 3 */
    uint64_t seed;      /* same seed -> same terrain, bit for bit, on every machine */
    float amplitude;    /* metres from lowest to highest; 0 -> 1800 */
    uint32_t octaves;   /* perlin only; 0 -> enough to reach ~2-sample detail */
    float roughness;    /* amplitude ratio per octave (perlin persistence) or per level (diamond, = 2^-H); 0 -> 0.5 */
    float feature_size; /* perlin: wavelength of the lowest octave in samples; 0 -> size/2 */
    hz_progress_fn progress; /* optional */
    void *progress_user;
    bool periodic;      /* windowed Perlin (pyramid import --wrap): the terrain repeats with a
                           period of size - 1 samples in x and z, seamlessly */
} hz_gen_desc;

/* Generates a terrain into out (allocated; free with hz_grid_free), values in
 * metres in [0, amplitude]. Fails on sizes that are not 2^n+1 or > 16385. */
hz_result hz_generate(const hz_gen_desc *desc, hz_grid *out, hz_err *err);
bool hz_gen_kind_parse(const char *s, hz_gen_kind *out);

/* ---- windowed reading (the pyramid import) ---- */

/* A raster read window by window (the pyramid import never holds it whole):
 * d's inputs (one file, files or folders mosaicked), reprojected on read when
 * d->metric asks (a warped VRT). Reads give floats, nodata as NaN, band
 * scale/offset applied. Not thread-safe: one reader at a time. */
typedef struct hz_io_src hz_io_src;
hz_result hz_io_src_open(const hz_dem_desc *d, hz_io_src **out, hz_err *err);
void hz_io_src_close(hz_io_src *s);
void hz_io_src_size(const hz_io_src *s, uint32_t *w, uint32_t *h);
const hz_georef *hz_io_src_georef(const hz_io_src *s);
/* True when the stored samples are 8/16-bit integers with no scaling or
 * reprojection: 16-bit steps of 1 from *offset (the type's lowest value)
 * hold them exactly. */
bool hz_io_src_integer16(const hz_io_src *s, double *offset);
/* Smallest and largest height with data (reads the whole raster once). */
hz_result hz_io_src_range(hz_io_src *s, double *lo, double *hi, hz_err *err);
hz_result hz_io_src_read(hz_io_src *s, uint32_t x0, uint32_t y0, uint32_t w, uint32_t h, float *out, hz_err *err);

/* A generated terrain read window by window (Perlin only: every sample is a
 * local function of its position). Heights in [0, amplitude] metres, the
 * curve applied to the fixed raw range (not the map's own). Thread-safe. */
typedef struct hz_gen_window hz_gen_window;
hz_result hz_gen_window_open(const hz_gen_desc *d, hz_gen_window **out, hz_err *err);
void hz_gen_window_close(hz_gen_window *w);
float hz_gen_window_amplitude(const hz_gen_window *w);
void hz_gen_window_read(const hz_gen_window *w, uint32_t x0, uint32_t y0, uint32_t w_, uint32_t h, float *out);

#ifdef __cplusplus
}
#endif
#endif
