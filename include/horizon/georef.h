/* horizon georeference: where a terrain grid lies on Earth. A CRS (any that
 * GDAL/PROJ know: WKT, "EPSG:n", PROJ strings) plus the grid's geotransform,
 * and conversions between the terrain's local metres, the CRS and lon/lat.
 * No GL.
 *
 * Local metres (the renderer's world x and z): the origin is the centre of the
 * grid's sample (0, 0), the north-west corner sample of the data; x grows
 * east (with the column), z grows south (with the row); one sample is
 * spacing_x metres in x and spacing_y metres in z (hz_georef_spacing). Heights
 * (y) are not transformed: they stay the DEM's heights in metres. */
#ifndef HORIZON_GEOREF_H
#define HORIZON_GEOREF_H

#include "horizon/core.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct hz_georef hz_georef; /* opaque CPU object */

/* Creates a georeference for a width x height grid. crs: anything
 * OSRSetFromUserInput accepts (WKT, "EPSG:32632", PROJ string); gt: the GDAL
 * geotransform of the grid (pixel-corner convention: the CRS position of
 * pixel corner (c, r) is X = gt[0] + c*gt[1] + r*gt[2], Y = gt[3] + c*gt[4] +
 * r*gt[5]; sample (i, j) is the centre of pixel (i + 0.5, j + 0.5)).
 * NULL + err on an unknown CRS or a degenerate geotransform. */
hz_georef *hz_georef_create(const char *crs, const double gt[6], uint32_t width, uint32_t height, hz_err *err);
/* A copy (NULL on failure or when g is NULL). */
hz_georef *hz_georef_clone(const hz_georef *g);
/* The same CRS for a grid shifted by (dx, dy) samples (dx > 0: the new grid's
 * sample 0 is the old sample dx) and resized to width x height. */
hz_georef *hz_georef_shifted(const hz_georef *g, int64_t dx, int64_t dy, uint32_t width, uint32_t height);
void hz_georef_destroy(hz_georef *g);

/* The CRS as WKT2 (never NULL), its EPSG code (0 if it has none) and name
 * ("WGS 84 / UTM zone 32N"). */
const char *hz_georef_wkt(const hz_georef *g);
int hz_georef_epsg(const hz_georef *g);
const char *hz_georef_name(const hz_georef *g);
/* "EPSG:32632", or the CRS name when it has no EPSG code. */
const char *hz_georef_label(const hz_georef *g);
/* True if the CRS is geographic (degrees). */
bool hz_georef_is_geographic(const hz_georef *g);
void hz_georef_geotransform(const hz_georef *g, double gt[6]);
void hz_georef_size(const hz_georef *g, uint32_t *width, uint32_t *height);
/* Metres between samples along x (east-west, one column) and along z (one
 * row): exact for a projected CRS (geotransform times the linear unit), and
 * for a geographic CRS the geodesic length of one sample step at the grid's
 * centre. */
void hz_georef_spacing(const hz_georef *g, double *spacing_x, double *spacing_y);

/* Conversions. local: metres as in the header comment; crs: the CRS's own
 * x/y (easting/northing, or lon/lat degrees for a geographic CRS); lonlat:
 * degrees on the CRS's own datum (WGS 84 for SRTM and UTM/WGS 84), longitude
 * first. The lon/lat ones return HZ_ERR_VALUE with a message when PROJ cannot
 * transform the point (err may be NULL). */
void hz_georef_local_to_crs(const hz_georef *g, double x, double z, double *cx, double *cy);
void hz_georef_crs_to_local(const hz_georef *g, double cx, double cy, double *x, double *z);
hz_result hz_georef_crs_to_lonlat(const hz_georef *g, double cx, double cy, double *lon, double *lat, hz_err *err);
hz_result hz_georef_lonlat_to_crs(const hz_georef *g, double lon, double lat, double *cx, double *cy, hz_err *err);
hz_result hz_georef_local_to_lonlat(const hz_georef *g, double x, double z, double *lon, double *lat, hz_err *err);
hz_result hz_georef_lonlat_to_local(const hz_georef *g, double lon, double lat, double *x, double *z, hz_err *err);

/* Corner lon/lat of the grid's outer pixel edges (the area the file covers):
 * corners[0..3] = north-west, north-east, south-east, south-west, each
 * {lon, lat}. */
hz_result hz_georef_corners_lonlat(const hz_georef *g, double corners[4][2], hz_err *err);

/* The EPSG code of the WGS 84 UTM zone containing (lon, lat): 326zz north of
 * the equator, 327zz south (zz = 1..60); 0 when lon is not finite or lat is
 * not a latitude (finite, within +-90 degrees). */
int hz_georef_utm_epsg(double lon, double lat);

#ifdef __cplusplus
}
#endif
#endif
