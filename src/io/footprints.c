/* Vector building footprints (OGR) extruded to closed LoD1 solids, as a
 * hz_city so they place, draw and pick like CityJSON buildings. */
#define _GNU_SOURCE
#include "horizon/city.h"
#include "horizon/safety.h"
#include "gdal_util.h"

#include <float.h>
#include <jansson.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cpl_error.h>
#include <gdal.h>
#include <ogr_api.h>
#include <ogr_srs_api.h>

typedef struct fp_build {
    hz_city *c;
    uint32_t vcap, tcap, ocap;
    hz_err *err;
    const char *path;
} fp_build;

static uint32_t add_vert(fp_build *b, double x, double y, double z)
{
    hz_city *c = b->c;
    if (!hz_grow((void **)&c->verts, &b->vcap, 3ull * (c->vert_count + 1), sizeof *c->verts, 256))
        return UINT32_MAX;
    c->verts[3 * c->vert_count] = x;
    c->verts[3 * c->vert_count + 1] = y;
    c->verts[3 * c->vert_count + 2] = z;
    return c->vert_count++;
}

static bool add_tri(fp_build *b, uint32_t a, uint32_t d, uint32_t e, hz_surface_kind k)
{
    hz_city *c = b->c;
    uint32_t cap = b->tcap;
    if (!hz_grow((void **)&c->tris, &b->tcap, 3ull * (c->tri_count + 1), sizeof *c->tris, 256))
        return false;
    if (b->tcap != cap) {
        uint8_t *nk = realloc(c->tri_kind, b->tcap / 3 + 1);
        if (!nk)
            return false;
        c->tri_kind = nk;
    }
    c->tris[3 * c->tri_count] = a;
    c->tris[3 * c->tri_count + 1] = d;
    c->tris[3 * c->tri_count + 2] = e;
    c->tri_kind[c->tri_count++] = (uint8_t)k;
    return true;
}

static double ring_area2(const double *xy, uint32_t n)
{
    double a = 0;
    for (uint32_t k = 0; k < n; k++)
        a += xy[2 * k] * xy[2 * ((k + 1) % n) + 1] - xy[2 * ((k + 1) % n)] * xy[2 * k + 1];
    return a;
}

/* One polygon (outer ring + holes) extruded from 0 to h. */
static hz_result extrude(fp_build *b, OGRGeometryH poly, OGRCoordinateTransformationH ct, double h, hz_city_object *o)
{
    const int nr = OGR_G_GetGeometryCount(poly);
    if (nr < 1)
        return HZ_OK;
    /* Rings without their closing vertex, outer counter-clockwise, holes clockwise. */
    double *pts = NULL;
    uint32_t *rs = calloc((size_t)nr + 1, sizeof *rs);
    uint32_t total = 0, kept = 0;
    if (!rs)
        return hz_err_set(b->err, HZ_ERR_MEMORY, "%s: out of memory", b->path);
    for (int r = 0; r < nr; r++) {
        OGRGeometryH ring = OGR_G_GetGeometryRef(poly, r);
        int n = OGR_G_GetPointCount(ring);
        double *xy = malloc((size_t)(n > 0 ? n : 1) * 2 * sizeof *xy);
        if (!xy) {
            free(pts);
            free(rs);
            return hz_err_set(b->err, HZ_ERR_MEMORY, "%s: out of memory", b->path);
        }
        int m = 0;
        for (int k = 0; k < n; k++) {
            double x = OGR_G_GetX(ring, k), y = OGR_G_GetY(ring, k), z = 0;
            if (ct && !OCTTransform(ct, 1, &x, &y, &z))
                continue;
            if (!isfinite(x) || !isfinite(y))
                continue;
            if (!(fabs(x) <= HZ_CITY_MAX_COORD && fabs(y) <= HZ_CITY_MAX_COORD)) {
                free(xy);
                free(pts);
                free(rs);
                return hz_err_set(b->err, HZ_ERR_VALUE, "%s: building %s has a vertex at (%g, %g), beyond %.0e", b->path,
                                  o->id, x, y, HZ_CITY_MAX_COORD);
            }
            if (m && xy[2 * (m - 1)] == x && xy[2 * (m - 1) + 1] == y)
                continue;
            xy[2 * m] = x;
            xy[2 * m + 1] = y;
            m++;
        }
        if (m > 1 && xy[0] == xy[2 * (m - 1)] && xy[1] == xy[2 * (m - 1) + 1])
            m--; /* the closing vertex */
        double a = m >= 3 ? ring_area2(xy, (uint32_t)m) : 0;
        if (m < 3 || a == 0 || (r > 0 && kept == 0)) {
            free(xy);
            continue;
        }
        const bool reverse = r == 0 ? a < 0 : a > 0;
        double *np = realloc(pts, ((size_t)total + (size_t)m) * 3 * sizeof *np);
        if (!np) {
            free(xy);
            free(pts);
            free(rs);
            return hz_err_set(b->err, HZ_ERR_MEMORY, "%s: out of memory", b->path);
        }
        pts = np;
        for (int k = 0; k < m; k++) {
            int s = reverse ? m - 1 - k : k;
            pts[3 * (total + (uint32_t)k)] = xy[2 * s];
            pts[3 * (total + (uint32_t)k) + 1] = xy[2 * s + 1];
            pts[3 * (total + (uint32_t)k) + 2] = 0;
        }
        free(xy);
        total += (uint32_t)m;
        rs[++kept] = total;
    }
    hz_result res = HZ_OK;
    if (!kept)
        goto out;
    /* Vertices: each ring point at 0 and at h. */
    uint32_t base = b->c->vert_count;
    for (uint32_t k = 0; k < total; k++)
        if (add_vert(b, pts[3 * k], pts[3 * k + 1], 0) == UINT32_MAX ||
            add_vert(b, pts[3 * k], pts[3 * k + 1], h) == UINT32_MAX) {
            res = hz_err_set(b->err, HZ_ERR_MEMORY, "%s: out of memory", b->path);
            goto out;
        }
    /* Walls: per ring edge, outward (outer ring CCW, holes CW seen from above). */
    for (uint32_t r = 0; r < kept; r++)
        for (uint32_t k = rs[r]; k < rs[r + 1]; k++) {
            uint32_t n = k + 1 < rs[r + 1] ? k + 1 : rs[r];
            uint32_t p0 = base + 2 * k, p1 = base + 2 * n;
            if (!add_tri(b, p0, p1, p1 + 1, HZ_SURF_WALL) || !add_tri(b, p0, p1 + 1, p0 + 1, HZ_SURF_WALL)) {
                res = hz_err_set(b->err, HZ_ERR_MEMORY, "%s: out of memory", b->path);
                goto out;
            }
            o->faces++;
        }
    /* Roof up, floor down. */
    uint32_t *t = malloc(((size_t)total + 2 * kept) * 3 * sizeof *t);
    int nt = t ? hz_polygon_triangulate(pts, rs, kept, t) : -1;
    if (nt < 0) {
        free(t);
        res = hz_err_set(b->err, HZ_ERR_MEMORY, "%s: out of memory", b->path);
        goto out;
    }
    for (int k = 0; k < nt; k++) {
        uint32_t a = base + 2 * t[3 * k], d = base + 2 * t[3 * k + 1], e = base + 2 * t[3 * k + 2];
        if (!add_tri(b, a + 1, d + 1, e + 1, HZ_SURF_ROOF) || !add_tri(b, a, e, d, HZ_SURF_GROUND)) {
            free(t);
            res = hz_err_set(b->err, HZ_ERR_MEMORY, "%s: out of memory", b->path);
            goto out;
        }
    }
    free(t);
    o->faces += 2;
out:
    free(pts);
    free(rs);
    return res;
}

/* The index of the field a layer has, of `given` when set, else of the
 * first of `names` it has; -1 when none. */
static int field_of(OGRFeatureDefnH defn, const char *given, const char *const *names)
{
    if (given)
        return OGR_FD_GetFieldIndex(defn, given);
    for (; *names; names++) {
        const int i = OGR_FD_GetFieldIndex(defn, *names);
        if (i >= 0)
            return i;
    }
    return -1;
}

/* The number under key in an hstore string ("k"=>"v","k2"=>"v2"), as
 * GDAL's OSM driver gives the tags without a field of their own in
 * other_tags; NAN when absent or not a number. */
static double hstore_number(const char *s, const char *key)
{
    char tok[2][128];
    int t = 0;
    while (s && *s) {
        while (*s && *s != '"')
            s++;
        if (!*s)
            break;
        s++;
        size_t n = 0;
        while (*s && *s != '"') {
            if (*s == '\\' && s[1])
                s++;
            if (n + 1 < sizeof tok[0])
                tok[t][n++] = *s;
            s++;
        }
        tok[t][n] = 0;
        if (*s)
            s++;
        if (t == 1 && !strcmp(tok[0], key)) {
            char *end;
            double v = strtod(tok[1], &end);
            return end != tok[1] && isfinite(v) ? v : NAN;
        }
        t ^= 1;
    }
    return NAN;
}

/* The first of the keys (the one given, else the list) in the feature's
 * other_tags (field io); its name in *which. */
static double tags_number(OGRFeatureH f, int io, const char *given, const char *const *names, const char **which)
{
    if (io < 0 || !OGR_F_IsFieldSetAndNotNull(f, io))
        return NAN;
    const char *s = OGR_F_GetFieldAsString(f, io);
    const char *const one[] = {given, NULL};
    for (const char *const *k = given ? one : names; *k; k++) {
        const double v = hstore_number(s, *k);
        if (!isnan(v)) {
            *which = *k;
            return v;
        }
    }
    return NAN;
}

static double field_number(OGRFeatureH f, int i)
{
    if (i < 0 || !OGR_F_IsFieldSetAndNotNull(f, i))
        return NAN;
    const char *s = OGR_F_GetFieldAsString(f, i);
    char *end;
    double v = strtod(s, &end);
    return end != s && isfinite(v) ? v : NAN;
}

hz_city *hz_city_load_footprints(const char *path, const hz_footprint_desc *desc, hz_err *err)
{
    double t0 = hz_time_ms();
    static const char *const heights[] = {"height", "building:height", "measuredHeight", NULL};
    static const char *const levels[] = {"building:levels", "num_floors", "building_l", "levels", NULL};
    const char *hf = desc ? desc->height_field : NULL, *lf = desc ? desc->levels_field : NULL;
    const double lh = desc && desc->level_height > 0 ? desc->level_height : 3.0;
    const double dh = desc && desc->default_height > 0 ? desc->default_height : 10.0;
    hz_io_gdal_setup();
    CPLPushErrorHandler(CPLQuietErrorHandler);
    /* The formats footprints come in, and no others: every driver GDAL has
     * would be every parser GDAL has exposed to a user's file (fuzzing found
     * a leak in the NAS driver's probe of an XML file). */
    static const char *const drivers[] = {"GeoJSON", "GeoJSONSeq", "ESRIJSON", "GPKG", "SQLite", "ESRI Shapefile",
                                          "OSM", "CSV", "KML", "LIBKML", "GML", "FlatGeobuf", "OpenFileGDB",
                                          "MapInfo File", "Parquet", "Arrow", NULL};
    GDALDatasetH ds = GDALOpenEx(path, GDAL_OF_VECTOR | GDAL_OF_READONLY, drivers, NULL, NULL);
    CPLPopErrorHandler();
    if (!ds) {
        hz_err_set(err, HZ_ERR_IO,
                   "%s: not a vector file of a footprint format GDAL reads here (GeoJSON, GeoPackage, Shapefile, "
                   "OSM PBF/XML, CSV with WKT, KML, GML, FlatGeobuf, FileGDB, MapInfo, GeoParquet)",
                   path);
        return NULL;
    }
    hz_city *c = calloc(1, sizeof *c);
    fp_build b = {.c = c, .err = err, .path = path};
    hz_result r = HZ_OK;
    OGRSpatialReferenceH dst = NULL;
    OGRCoordinateTransformationH ct = NULL;
    if (!c) {
        r = hz_err_set(err, HZ_ERR_MEMORY, "%s: out of memory", path);
        goto out;
    }
    snprintf(c->version, sizeof c->version, "footprints");
    for (int li = 0; li < GDALDatasetGetLayerCount(ds); li++) {
        OGRLayerH layer = GDALDatasetGetLayer(ds, li);
        OGRFeatureDefnH defn = OGR_L_GetLayerDefn(layer);
        const int ih = field_of(defn, hf, heights), il = field_of(defn, lf, levels);
        const int io = OGR_FD_GetFieldIndex(defn, "other_tags"); /* GDAL's OSM driver: the other tags */
        int iid = OGR_FD_GetFieldIndex(defn, "osm_id");
        if (iid < 0)
            iid = OGR_FD_GetFieldIndex(defn, "id");
        OGRSpatialReferenceH src = OGR_L_GetSpatialRef(layer);
        OGR_L_ResetReading(layer);
        OGRFeatureH f;
        while ((f = OGR_L_GetNextFeature(layer)) != NULL) {
            OGRGeometryH g = OGR_F_GetGeometryRef(f);
            OGRwkbGeometryType gt = g ? wkbFlatten(OGR_G_GetGeometryType(g)) : wkbUnknown;
            if (gt != wkbPolygon && gt != wkbMultiPolygon) {
                OGR_F_Destroy(f);
                continue;
            }
            /* The output CRS from the first polygon: the layer's own when
             * projected, else the UTM zone of that polygon. */
            if (!c->crs[0]) {
                if (!src) {
                    OGR_F_Destroy(f);
                    r = hz_err_set(err, HZ_ERR_VALUE, "%s: layer %s has no CRS", path, OGR_L_GetName(layer));
                    goto out;
                }
                OGRSpatialReferenceH s2 = OSRClone(src);
                OSRSetAxisMappingStrategy(s2, OAMS_TRADITIONAL_GIS_ORDER);
                int epsg = 0;
                if (OSRIsGeographic(s2)) {
                    OGREnvelope env;
                    OGR_G_GetEnvelope(g, &env);
                    const double lon = 0.5 * (env.MinX + env.MaxX), lat = 0.5 * (env.MinY + env.MaxY);
                    epsg = hz_georef_utm_epsg(lon, lat);
                    if (!epsg) {
                        r = hz_err_set(err, HZ_ERR_VALUE,
                                       "%s: layer %s: feature %lld lies at lon %g, lat %g, not on the Earth", path,
                                       OGR_L_GetName(layer), (long long)OGR_F_GetFID(f), lon, lat);
                        OSRDestroySpatialReference(s2);
                        OGR_F_Destroy(f);
                        goto out;
                    }
                } else {
                    const char *auth = OSRGetAuthorityName(s2, NULL), *code = OSRGetAuthorityCode(s2, NULL);
                    if (!(auth && code && !strcmp(auth, "EPSG")) && OSRAutoIdentifyEPSG(s2) == OGRERR_NONE) {
                        auth = OSRGetAuthorityName(s2, NULL);
                        code = OSRGetAuthorityCode(s2, NULL);
                    }
                    if (auth && code && !strcmp(auth, "EPSG"))
                        epsg = atoi(code);
                }
                OSRDestroySpatialReference(s2);
                if (epsg <= 0) {
                    OGR_F_Destroy(f);
                    r = hz_err_set(err, HZ_ERR_VALUE, "%s: the CRS of layer %s has no EPSG code", path,
                                   OGR_L_GetName(layer));
                    goto out;
                }
                snprintf(c->crs, sizeof c->crs, "EPSG:%d", epsg);
                dst = OSRNewSpatialReference(NULL);
                if (!dst || OSRImportFromEPSG(dst, epsg) != OGRERR_NONE) {
                    OGR_F_Destroy(f);
                    r = hz_err_set(err, HZ_ERR_VALUE, "%s: unknown CRS EPSG:%d", path, epsg);
                    goto out;
                }
                OSRSetAxisMappingStrategy(dst, OAMS_TRADITIONAL_GIS_ORDER);
            }
            /* Per layer: a transform when its CRS is not the output's. */
            if (ct) {
                OCTDestroyCoordinateTransformation(ct);
                ct = NULL;
            }
            if (src) {
                OGRSpatialReferenceH s2 = OSRClone(src);
                OSRSetAxisMappingStrategy(s2, OAMS_TRADITIONAL_GIS_ORDER);
                if (!OSRIsSame(s2, dst))
                    ct = OCTNewCoordinateTransformation(s2, dst);
                OSRDestroySpatialReference(s2);
            }
            /* A field asked for by name must be there (a typo would give
             * every building the default height). */
            const char *missing = io >= 0 ? NULL : hf && ih < 0 ? hf : lf && il < 0 ? lf : NULL;
            if (missing) {
                char names[256] = "";
                for (int fi = 0; fi < OGR_FD_GetFieldCount(defn); fi++) {
                    const size_t len = strlen(names);
                    snprintf(names + len, sizeof names - len, "%s%s", fi ? ", " : "",
                             OGR_Fld_GetNameRef(OGR_FD_GetFieldDefn(defn, fi)));
                }
                OGR_F_Destroy(f);
                r = hz_err_set(err, HZ_ERR_VALUE, "%s: layer %s has no field '%s' (its fields: %s)", path,
                               OGR_L_GetName(layer), missing, names[0] ? names : "none");
                goto out;
            }
            const char *hname = ih >= 0 ? OGR_Fld_GetNameRef(OGR_FD_GetFieldDefn(defn, ih)) : NULL;
            const char *lname = il >= 0 ? OGR_Fld_GetNameRef(OGR_FD_GetFieldDefn(defn, il)) : NULL;
            double h = ih >= 0 ? field_number(f, ih) : tags_number(f, io, hf, heights, &hname);
            int from = 0; /* the height's source: 0 the height field, 1 levels, 2 the default */
            if (!(h > 0)) {
                double lv = il >= 0 ? field_number(f, il) : tags_number(f, io, lf, levels, &lname);
                from = lv > 0 ? 1 : 2;
                h = lv > 0 ? lv * lh : dh;
            }
            if (h > 2000)
                h = 2000;
            if (!hz_grow((void **)&c->obj, &b.ocap, (uint64_t)c->obj_count + 1, sizeof *c->obj, 256)) {
                OGR_F_Destroy(f);
                r = hz_err_set(err, HZ_ERR_MEMORY, "%s: out of memory", path);
                goto out;
            }
            hz_city_object *o = &c->obj[c->obj_count++];
            memset(o, 0, sizeof *o);
            o->first_tri = c->tri_count;
            o->lod = 1;
            char idb[96];
            if (iid >= 0 && OGR_F_IsFieldSetAndNotNull(f, iid))
                snprintf(idb, sizeof idb, "%s", OGR_F_GetFieldAsString(f, iid));
            else
                snprintf(idb, sizeof idb, "%s_%lld", OGR_L_GetName(layer), (long long)OGR_F_GetFID(f));
            json_t *at = json_object();
            for (int fi = 0; at && fi < OGR_FD_GetFieldCount(defn); fi++) {
                if (!OGR_F_IsFieldSetAndNotNull(f, fi))
                    continue;
                OGRFieldType ft = OGR_Fld_GetType(OGR_FD_GetFieldDefn(defn, fi));
                const char *nm = OGR_Fld_GetNameRef(OGR_FD_GetFieldDefn(defn, fi));
                json_t *v = ft == OFTInteger || ft == OFTInteger64 ? json_integer(OGR_F_GetFieldAsInteger64(f, fi))
                            : ft == OFTReal                        ? json_real(OGR_F_GetFieldAsDouble(f, fi))
                                                                   : json_string(OGR_F_GetFieldAsString(f, fi));
                if (v && (ft != OFTReal || isfinite(OGR_F_GetFieldAsDouble(f, fi))))
                    json_object_set_new(at, nm, v);
                else
                    json_decref(v);
            }
            if (at)
                json_object_set_new(at, "extruded_height", json_real(h));
            o->id = strdup(idb);
            o->type = strdup("Building");
            o->attributes = at ? json_dumps(at, JSON_COMPACT) : NULL;
            json_decref(at);
            if (!o->id || !o->type || !o->attributes) {
                OGR_F_Destroy(f);
                r = hz_err_set(err, HZ_ERR_MEMORY, "%s: out of memory", path);
                goto out;
            }
            const int np = gt == wkbPolygon ? 1 : OGR_G_GetGeometryCount(g);
            for (int k = 0; k < np && r == HZ_OK; k++)
                r = extrude(&b, gt == wkbPolygon ? g : OGR_G_GetGeometryRef(g, k), ct, h, o);
            OGR_F_Destroy(f);
            if (r != HZ_OK)
                goto out;
            o->tri_count = c->tri_count - o->first_tri;
            c->faces += o->faces;
            if (o->tri_count) {
                c->buildings++;
                if (from == 0) {
                    c->height_from_field++;
                    if (!c->height_field[0])
                        snprintf(c->height_field, sizeof c->height_field, "%s", hname);
                } else if (from == 1) {
                    c->height_from_levels++;
                    if (!c->levels_field[0])
                        snprintf(c->levels_field, sizeof c->levels_field, "%s", lname);
                } else {
                    c->height_default++;
                }
            }
        }
    }
    if (!c->buildings)
        r = hz_err_set(err, HZ_ERR_VALUE, "%s: no polygon to extrude", path);
    for (int k = 0; k < 3; k++) {
        c->extent[k] = DBL_MAX;
        c->extent[3 + k] = -DBL_MAX;
    }
    for (uint32_t v = 0; r == HZ_OK && v < c->vert_count; v++)
        for (int k = 0; k < 3; k++) {
            c->extent[k] = fmin(c->extent[k], c->verts[3 * v + k]);
            c->extent[3 + k] = fmax(c->extent[3 + k], c->verts[3 * v + k]);
        }
out:
    if (ct)
        OCTDestroyCoordinateTransformation(ct);
    if (dst)
        OSRDestroySpatialReference(dst);
    GDALClose(ds);
    if (r != HZ_OK) {
        hz_city_destroy(c);
        return NULL;
    }
    c->load_ms = hz_time_ms() - t0;
    return c;
}
