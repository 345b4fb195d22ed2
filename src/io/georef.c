/* hz_georef: a CRS (OGR spatial reference) and a geotransform, with PROJ
 * transformations to the CRS's own geographic lon/lat. */
#include "horizon/georef.h"

#include <math.h>
#include <cpl_conv.h>
#include <ogr_srs_api.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define HZ_PI 3.14159265358979323846

struct hz_georef {
    OGRSpatialReferenceH srs, geog;
    OGRCoordinateTransformationH to_geog, from_geog;
    double gt[6], inv[6];
    uint32_t width, height;
    double sx, sy; /* metres per sample along x (column) and z (row) */
    bool geographic;
    int epsg;
    char *wkt;
    char name[160];
    char label[192];
};

/* Inverse of the affine part of a geotransform. False if degenerate. */
static bool invert_gt(const double gt[6], double inv[6])
{
    double det = gt[1] * gt[5] - gt[2] * gt[4];
    if (!isfinite(det) || fabs(det) < 1e-300)
        return false;
    inv[1] = gt[5] / det;
    inv[2] = -gt[2] / det;
    inv[4] = -gt[4] / det;
    inv[5] = gt[1] / det;
    inv[0] = -(inv[1] * gt[0] + inv[2] * gt[3]);
    inv[3] = -(inv[4] * gt[0] + inv[5] * gt[3]);
    return true;
}

static void compute_spacing(hz_georef *g)
{
    double dxc = hypot(g->gt[1], g->gt[4]), dyr = hypot(g->gt[2], g->gt[5]);
    if (!g->geographic) {
        double lu = OSRGetLinearUnits(g->srs, NULL);
        if (!(lu > 0))
            lu = 1.0;
        g->sx = dxc * lu;
        g->sy = dyr * lu;
        return;
    }
    /* Degrees at the centre latitude on the CRS's ellipsoid. */
    OGRErr e1 = OGRERR_NONE, e2 = OGRERR_NONE;
    double a = OSRGetSemiMajor(g->srs, &e1), invf = OSRGetInvFlattening(g->srs, &e2);
    if (e1 != OGRERR_NONE || !(a > 0))
        a = 6378137.0;
    double f = e2 == OGRERR_NONE && invf > 0 ? 1.0 / invf : 0.0;
    double e2s = f * (2.0 - f);
    double cx = 0.5 * g->width, cy = 0.5 * g->height;
    double lat = g->gt[3] + cx * g->gt[4] + cy * g->gt[5];
    double au = OSRGetAngularUnits(g->srs, NULL);
    double rad = au > 0 ? au : HZ_PI / 180.0; /* radians per CRS unit */
    double phi = lat * rad, s = sin(phi);
    double w = sqrt(1.0 - e2s * s * s);
    double m_lon = a * cos(phi) / w * rad;              /* metres per unit of longitude */
    double m_lat = a * (1.0 - e2s) / (w * w * w) * rad; /* metres per unit of latitude */
    g->sx = hypot(g->gt[1] * m_lon, g->gt[4] * m_lat);
    g->sy = hypot(g->gt[2] * m_lon, g->gt[5] * m_lat);
}

static hz_georef *make(OGRSpatialReferenceH srs, const double gt[6], uint32_t width, uint32_t height, hz_err *err)
{
    hz_georef *g = calloc(1, sizeof *g);
    if (!g) {
        OSRDestroySpatialReference(srs);
        hz_err_set(err, HZ_ERR_MEMORY, "georeference: out of memory");
        return NULL;
    }
    g->srs = srs;
    OSRSetAxisMappingStrategy(g->srs, OAMS_TRADITIONAL_GIS_ORDER);
    memcpy(g->gt, gt, sizeof g->gt);
    g->width = width;
    g->height = height;
    if (!invert_gt(gt, g->inv)) {
        hz_err_set(err, HZ_ERR_VALUE, "georeference: degenerate geotransform (%g %g %g %g %g %g)", gt[0], gt[1],
                   gt[2], gt[3], gt[4], gt[5]);
        hz_georef_destroy(g);
        return NULL;
    }
    g->geographic = OSRIsGeographic(g->srs) != 0;
    g->geog = OSRCloneGeogCS(g->srs);
    if (g->geog)
        OSRSetAxisMappingStrategy(g->geog, OAMS_TRADITIONAL_GIS_ORDER);
    g->to_geog = g->geog ? OCTNewCoordinateTransformation(g->srs, g->geog) : NULL;
    g->from_geog = g->geog ? OCTNewCoordinateTransformation(g->geog, g->srs) : NULL;
    const char *opts[] = {"FORMAT=WKT2_2019", NULL};
    if (OSRExportToWktEx(g->srs, &g->wkt, opts) != OGRERR_NONE || !g->wkt) {
        hz_err_set(err, HZ_ERR_VALUE, "georeference: cannot export the CRS as WKT");
        hz_georef_destroy(g);
        return NULL;
    }
    const char *auth = OSRGetAuthorityName(g->srs, NULL), *code = OSRGetAuthorityCode(g->srs, NULL);
    if (auth && code && !strcmp(auth, "EPSG"))
        g->epsg = atoi(code);
    if (!g->epsg && OSRAutoIdentifyEPSG(g->srs) == OGRERR_NONE) {
        auth = OSRGetAuthorityName(g->srs, NULL);
        code = OSRGetAuthorityCode(g->srs, NULL);
        if (auth && code && !strcmp(auth, "EPSG"))
            g->epsg = atoi(code);
    }
    const char *nm = OSRGetName(g->srs);
    snprintf(g->name, sizeof g->name, "%s", nm ? nm : "unnamed CRS");
    if (g->epsg)
        snprintf(g->label, sizeof g->label, "EPSG:%d", g->epsg);
    else
        snprintf(g->label, sizeof g->label, "%s", g->name);
    compute_spacing(g);
    return g;
}

hz_georef *hz_georef_create(const char *crs, const double gt[6], uint32_t width, uint32_t height, hz_err *err)
{
    HZ_ASSERT(gt);
    if (!crs || !crs[0]) {
        hz_err_set(err, HZ_ERR_VALUE, "georeference: no CRS given");
        return NULL;
    }
    OGRSpatialReferenceH srs = OSRNewSpatialReference(NULL);
    if (!srs) {
        hz_err_set(err, HZ_ERR_MEMORY, "georeference: out of memory");
        return NULL;
    }
    if (OSRSetFromUserInput(srs, crs) != OGRERR_NONE) {
        OSRDestroySpatialReference(srs);
        hz_err_set(err, HZ_ERR_VALUE, "unknown CRS '%.80s'", crs);
        return NULL;
    }
    return make(srs, gt, width, height, err);
}

hz_georef *hz_georef_clone(const hz_georef *g)
{
    return g ? hz_georef_shifted(g, 0, 0, g->width, g->height) : NULL;
}

hz_georef *hz_georef_shifted(const hz_georef *g, int64_t dx, int64_t dy, uint32_t width, uint32_t height)
{
    if (!g)
        return NULL;
    double gt[6];
    memcpy(gt, g->gt, sizeof gt);
    gt[0] = g->gt[0] + (double)dx * g->gt[1] + (double)dy * g->gt[2];
    gt[3] = g->gt[3] + (double)dx * g->gt[4] + (double)dy * g->gt[5];
    OGRSpatialReferenceH srs = OSRClone(g->srs);
    if (!srs)
        return NULL;
    hz_georef *n = make(srs, gt, width, height, NULL);
    if (n && g->epsg && !n->epsg) { /* keep an identified code */
        n->epsg = g->epsg;
        snprintf(n->label, sizeof n->label, "EPSG:%d", n->epsg);
    }
    return n;
}

void hz_georef_destroy(hz_georef *g)
{
    if (!g)
        return;
    if (g->to_geog)
        OCTDestroyCoordinateTransformation(g->to_geog);
    if (g->from_geog)
        OCTDestroyCoordinateTransformation(g->from_geog);
    if (g->geog)
        OSRDestroySpatialReference(g->geog);
    if (g->srs)
        OSRDestroySpatialReference(g->srs);
    CPLFree(g->wkt);
    free(g);
}

const char *hz_georef_wkt(const hz_georef *g) { return g->wkt; }
int hz_georef_epsg(const hz_georef *g) { return g->epsg; }
const char *hz_georef_name(const hz_georef *g) { return g->name; }
const char *hz_georef_label(const hz_georef *g) { return g->label; }
bool hz_georef_is_geographic(const hz_georef *g) { return g->geographic; }

void hz_georef_geotransform(const hz_georef *g, double gt[6])
{
    memcpy(gt, g->gt, sizeof g->gt);
}

void hz_georef_size(const hz_georef *g, uint32_t *width, uint32_t *height)
{
    if (width)
        *width = g->width;
    if (height)
        *height = g->height;
}

void hz_georef_spacing(const hz_georef *g, double *spacing_x, double *spacing_y)
{
    if (spacing_x)
        *spacing_x = g->sx;
    if (spacing_y)
        *spacing_y = g->sy;
}

void hz_georef_local_to_crs(const hz_georef *g, double x, double z, double *cx, double *cy)
{
    /* local metres -> pixel coordinates of the sample centre. */
    double c = x / g->sx + 0.5, r = z / g->sy + 0.5;
    *cx = g->gt[0] + c * g->gt[1] + r * g->gt[2];
    *cy = g->gt[3] + c * g->gt[4] + r * g->gt[5];
}

void hz_georef_crs_to_local(const hz_georef *g, double cx, double cy, double *x, double *z)
{
    double c = g->inv[0] + cx * g->inv[1] + cy * g->inv[2];
    double r = g->inv[3] + cx * g->inv[4] + cy * g->inv[5];
    *x = (c - 0.5) * g->sx;
    *z = (r - 0.5) * g->sy;
}

static hz_result transform(OGRCoordinateTransformationH ct, double a, double b, double *oa, double *ob, hz_err *err)
{
    double x = a, y = b, zz = 0.0;
    int ok = 0;
    if (!ct || !OCTTransformEx(ct, 1, &x, &y, &zz, &ok) || !ok || !isfinite(x) || !isfinite(y))
        return hz_err_set(err, HZ_ERR_VALUE, "cannot transform the point (%.6f, %.6f) between the CRS and lon/lat", a,
                          b);
    *oa = x;
    *ob = y;
    return HZ_OK;
}

hz_result hz_georef_crs_to_lonlat(const hz_georef *g, double cx, double cy, double *lon, double *lat, hz_err *err)
{
    if (g->geographic) {
        *lon = cx;
        *lat = cy;
        return HZ_OK;
    }
    return transform(g->to_geog, cx, cy, lon, lat, err);
}

hz_result hz_georef_lonlat_to_crs(const hz_georef *g, double lon, double lat, double *cx, double *cy, hz_err *err)
{
    if (g->geographic) {
        *cx = lon;
        *cy = lat;
        return HZ_OK;
    }
    return transform(g->from_geog, lon, lat, cx, cy, err);
}

hz_result hz_georef_local_to_lonlat(const hz_georef *g, double x, double z, double *lon, double *lat, hz_err *err)
{
    double cx = 0, cy = 0;
    hz_georef_local_to_crs(g, x, z, &cx, &cy);
    return hz_georef_crs_to_lonlat(g, cx, cy, lon, lat, err);
}

hz_result hz_georef_lonlat_to_local(const hz_georef *g, double lon, double lat, double *x, double *z, hz_err *err)
{
    double cx = 0, cy = 0;
    hz_result r = hz_georef_lonlat_to_crs(g, lon, lat, &cx, &cy, err);
    if (r == HZ_OK)
        hz_georef_crs_to_local(g, cx, cy, x, z);
    return r;
}

hz_result hz_georef_corners_lonlat(const hz_georef *g, double corners[4][2], hz_err *err)
{
    const double pc[4][2] = {{0, 0}, {g->width, 0}, {g->width, g->height}, {0, g->height}};
    for (int k = 0; k < 4; k++) {
        double cx = g->gt[0] + pc[k][0] * g->gt[1] + pc[k][1] * g->gt[2];
        double cy = g->gt[3] + pc[k][0] * g->gt[4] + pc[k][1] * g->gt[5];
        hz_result r = hz_georef_crs_to_lonlat(g, cx, cy, &corners[k][0], &corners[k][1], err);
        if (r != HZ_OK)
            return r;
    }
    return HZ_OK;
}

int hz_georef_utm_epsg(double lon, double lat)
{
    if (!isfinite(lon) || !(fabs(lat) <= 90.0))
        return 0;
    double l = fmod(lon + 180.0, 360.0);
    if (l < 0)
        l += 360.0;
    int zone = (int)floor(l / 6.0) + 1;
    if (zone > 60)
        zone = 60;
    return (lat >= 0 ? 32600 : 32700) + zone;
}
