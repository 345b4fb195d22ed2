/* CityJSON 2.0 reader (jansson) and placement of a city into a scene graph
 * through the terrain's georeference (GDAL/PROJ). */
#define _GNU_SOURCE
#include "horizon/city.h"

#include "horizon/safety.h"

#include <errno.h>
#include <float.h>
#include <jansson.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cpl_error.h>
#include <ogr_srs_api.h>

typedef struct loader {
    hz_city *c;
    const char *name;
    hz_err *err;
    uint32_t tri_cap;
    uint32_t obj_cap; /* objects allocated in c->obj */
    /* scratch for one polygon */
    double *pts;
    uint32_t pts_cap;
    uint32_t *rs;
    uint32_t rs_cap;
    uint32_t *tbuf;
    uint32_t tbuf_cap;
    /* ring indices address c->verts[vbase + i], i < vcount: the file's
     * vertices, or an instance's transformed template vertices */
    uint32_t vbase, vcount;
    uint32_t vert_cap;    /* doubles allocated in c->verts */
    json_t *templates;    /* geometry-templates.templates, or NULL */
    double *tverts;       /* geometry-templates.vertices-templates (x, y, z each) */
    uint32_t tvert_count;
    uint64_t instanced;   /* vertices added by instances (bounded) */
    uint32_t file_verts;  /* the file's (or the feature's) own vertices: reference points index them */
    uint32_t fbase;       /* where those start in c->verts (a CityJSONFeature's follow the others) */
    double scale[3], translate[3]; /* transform: vertex = quantised * scale + translate */
    char where[32];       /* "line N: " of a CityJSON Text Sequence, else empty */
    double extent[6];     /* metadata.geographicalExtent, when have_extent */
    bool have_extent, translate_checked;
    uint64_t instanced_tris; /* triangles made by instances (bounded) */
    uint32_t surf_material;  /* the appearance material of the surface being read */
    char path[512];
} loader;

static hz_result fail(loader *L, hz_result code, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
static hz_result fail(loader *L, hz_result code, const char *fmt, ...)
{
    char msg[400];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return hz_err_set(L->err, code, "%s: %s%s%s%s", L->name, L->where, L->path, L->path[0] ? ": " : "", msg);
}

void hz_city_destroy(hz_city *c)
{
    if (!c)
        return;
    for (uint32_t k = 0; k < c->obj_count; k++) {
        free(c->obj[k].id);
        free(c->obj[k].type);
        free(c->obj[k].attributes);
    }
    free(c->obj);
    free(c->verts);
    free(c->tris);
    free(c->tri_kind);
    free(c->tri_material);
    free(c->materials);
    free(c);
}

/* "https://www.opengis.net/def/crs/EPSG/0/32734", "urn:ogc:def:crs:EPSG::32734",
 * "EPSG:32734" -> 32734; 0 if none of those. */
static int epsg_of(const char *s)
{
    const char *p = strstr(s, "EPSG");
    if (!p)
        return 0;
    const char *last = s + strlen(s);
    while (last > p && last[-1] >= '0' && last[-1] <= '9')
        last--;
    if (!*last || last <= p + 4)
        return 0;
    char *end;
    errno = 0;
    long v = strtol(last, &end, 10);
    if (*end || errno || v <= 0 || v > 999999)
        return 0;
    return (int)v;
}

static hz_result read_crs(loader *L, json_t *root)
{
    json_t *md = json_object_get(root, "metadata");
    json_t *rs = md ? json_object_get(md, "referenceSystem") : NULL;
    if (!rs)
        return HZ_OK; /* allowed: placed by the caller's origin then */
    snprintf(L->path, sizeof L->path, "metadata.referenceSystem");
    if (!json_is_string(rs))
        return fail(L, HZ_ERR_FORMAT, "not a string");
    const char *s = json_string_value(rs);
    int epsg = epsg_of(s);
    if (!epsg)
        return fail(L, HZ_ERR_VALUE, "unknown CRS \"%.100s\" (expected an EPSG CRS URL such as "
                                     "https://www.opengis.net/def/crs/EPSG/0/7415)", s);
    OGRSpatialReferenceH srs = OSRNewSpatialReference(NULL);
    CPLPushErrorHandler(CPLQuietErrorHandler);
    OGRErr e = srs ? OSRImportFromEPSG(srs, epsg) : OGRERR_FAILURE;
    CPLPopErrorHandler();
    if (srs)
        OSRDestroySpatialReference(srs);
    if (e != OGRERR_NONE)
        return fail(L, HZ_ERR_VALUE, "unknown CRS EPSG:%d (PROJ does not know it)", epsg);
    snprintf(L->c->crs, sizeof L->c->crs, "EPSG:%d", epsg);
    L->path[0] = 0;
    return HZ_OK;
}

static bool get3(json_t *a, double out[3])
{
    if (!json_is_array(a) || json_array_size(a) != 3)
        return false;
    for (size_t k = 0; k < 3; k++) {
        json_t *v = json_array_get(a, k);
        if (!json_is_number(v))
            return false;
        out[k] = json_number_value(v);
        if (!isfinite(out[k]))
            return false;
    }
    return true;
}

/* Appends the quantised vertices vs (a file's or a feature's) to the
 * city's, dequantised by the file's transform; they become the ones that
 * boundaries and reference points index. */
static hz_result append_vertices(loader *L, json_t *vs)
{
    snprintf(L->path, sizeof L->path, "vertices");
    if (!json_is_array(vs))
        return fail(L, HZ_ERR_FORMAT, "missing or not an array");
    size_t n = json_array_size(vs);
    hz_city *c = L->c;
    if (n > UINT32_MAX / 4 || (uint64_t)c->vert_count + n > UINT32_MAX / 4)
        return fail(L, HZ_ERR_VALUE, "%zu vertices is too many", n);
    if (!hz_grow((void **)&c->verts, &L->vert_cap, 3 * ((uint64_t)c->vert_count + (n ? n : 1)), sizeof *c->verts, 64))
        return fail(L, HZ_ERR_MEMORY, "out of memory for %zu vertices", n);
    double *d = c->verts + 3 * (size_t)c->vert_count;
    for (size_t i = 0; i < n; i++) {
        json_t *v = json_array_get(vs, i);
        if (!json_is_array(v) || json_array_size(v) != 3) {
            snprintf(L->path, sizeof L->path, "vertices[%zu]", i);
            return fail(L, HZ_ERR_FORMAT, "not an array of 3 integers");
        }
        for (size_t k = 0; k < 3; k++) {
            json_t *q = json_array_get(v, k);
            if (!json_is_integer(q)) {
                snprintf(L->path, sizeof L->path, "vertices[%zu][%zu]", i, k);
                return fail(L, HZ_ERR_FORMAT, "not an integer (vertices are quantised in CityJSON 2.0)");
            }
            d[3 * i + k] = (double)json_integer_value(q) * L->scale[k] + L->translate[k];
            if (!(fabs(d[3 * i + k]) <= HZ_CITY_MAX_COORD)) {
                snprintf(L->path, sizeof L->path, "vertices[%zu][%zu]", i, k);
                return fail(L, HZ_ERR_VALUE, "lies at %g after the transform, beyond %.0e", d[3 * i + k],
                            HZ_CITY_MAX_COORD);
            }
        }
    }
    L->fbase = L->vbase = c->vert_count;
    L->vcount = L->file_verts = (uint32_t)n;
    c->vert_count += (uint32_t)n;
    L->path[0] = 0;
    return HZ_OK;
}

/* Some writers store absolute quantised vertices and still give a
 * translate (Mamre's file: its vertices land 265 km east of its own
 * metadata.geographicalExtent with it, exactly on it without). When the
 * extent says so for the first vertices read (the file's, or a sequence's
 * first feature's), translate is taken as already applied, with a note:
 * they are moved back, and the vertices read later are dequantised
 * without it. */
static void check_translate(loader *L)
{
    hz_city *c = L->c;
    const size_t first = L->fbase, n = L->file_verts;
    if (L->translate_checked || !n)
        return;
    L->translate_checked = true;
    if (!L->have_extent)
        return;
    const double *ge = L->extent;
    double *trans = L->translate;
    double lo[3] = {DBL_MAX, DBL_MAX, DBL_MAX}, hi[3] = {-DBL_MAX, -DBL_MAX, -DBL_MAX};
    for (size_t i = first; i < first + n; i++)
        for (int k = 0; k < 3; k++) {
            lo[k] = fmin(lo[k], c->verts[3 * i + k]);
            hi[k] = fmax(hi[k], c->verts[3 * i + k]);
        }
    bool fits = true, fits_without = true;
    for (int k = 0; k < 3; k++) {
        double tol = 0.01 * (ge[3 + k] - ge[k]) + 1.0;
        fits = fits && lo[k] >= ge[k] - tol && hi[k] <= ge[3 + k] + tol;
        fits_without = fits_without && lo[k] - trans[k] >= ge[k] - tol && hi[k] - trans[k] <= ge[3 + k] + tol;
    }
    if (fits || !fits_without)
        return;
    for (size_t i = first; i < first + n; i++)
        for (int k = 0; k < 3; k++)
            c->verts[3 * i + k] -= trans[k];
    snprintf(c->note, sizeof c->note,
             "vertices times scale already lie in metadata.geographicalExtent: transform.translate "
             "(%.3f, %.3f, %.3f) ignored", trans[0], trans[1], trans[2]);
    for (int k = 0; k < 3; k++)
        trans[k] = 0;
}

static hz_result read_vertices(loader *L, json_t *root)
{
    json_t *tr = json_object_get(root, "transform");
    double *scale = L->scale, *trans = L->translate;
    snprintf(L->path, sizeof L->path, "transform");
    if (!tr)
        return fail(L, HZ_ERR_FORMAT, "missing (CityJSON 2.0 vertices are quantised: transform.scale and "
                                      "transform.translate are required)");
    if (!json_is_object(tr) || !get3(json_object_get(tr, "scale"), scale) ||
        !get3(json_object_get(tr, "translate"), trans))
        return fail(L, HZ_ERR_FORMAT, "needs scale and translate, three finite numbers each");
    for (int k = 0; k < 3; k++)
        if (!(scale[k] > 0))
            return fail(L, HZ_ERR_VALUE, "scale[%d] = %g must be > 0", k, scale[k]);
    hz_result r = append_vertices(L, json_object_get(root, "vertices"));
    if (r != HZ_OK)
        return r;
    L->translate_checked = false;
    json_t *md = json_object_get(root, "metadata");
    json_t *gej = md ? json_object_get(md, "geographicalExtent") : NULL;
    L->have_extent = json_is_array(gej) && json_array_size(gej) == 6;
    for (size_t k = 0; L->have_extent && k < 6; k++) {
        json_t *q = json_array_get(gej, k);
        L->have_extent = json_is_number(q) && isfinite(L->extent[k] = json_number_value(q));
    }
    check_translate(L);
    L->path[0] = 0;
    return HZ_OK;
}

static hz_surface_kind kind_of_semantic(const char *t)
{
    if (!t)
        return HZ_SURF_WALL;
    if (!strcmp(t, "RoofSurface"))
        return HZ_SURF_ROOF;
    if (!strcmp(t, "GroundSurface") || !strcmp(t, "FloorSurface") || !strcmp(t, "OuterFloorSurface"))
        return HZ_SURF_GROUND;
    return HZ_SURF_WALL;
}

static hz_surface_kind kind_of_normal(const double *a, const double *b, const double *c)
{
    double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
    double l = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(l > 0))
        return HZ_SURF_WALL;
    double z = n[2] / l;
    return z > 0.7 ? HZ_SURF_ROOF : z < -0.7 ? HZ_SURF_GROUND : HZ_SURF_WALL;
}

/* One surface: [ring, ring...], ring = [vertex index...]. kind < 0: by normal. */
static hz_result read_surface(loader *L, json_t *surf, int kind, hz_city_object *o)
{
    hz_city *c = L->c;
    if (!json_is_array(surf) || json_array_size(surf) == 0)
        return fail(L, HZ_ERR_FORMAT, "a surface must be a non-empty array of rings");
    size_t nr = json_array_size(surf);
    uint64_t total = 0;
    if (!hz_grow((void **)&L->rs, &L->rs_cap, nr + 1, sizeof *L->rs, 64))
        return fail(L, HZ_ERR_MEMORY, "out of memory");
    L->rs[0] = 0;
    for (size_t r = 0; r < nr; r++) {
        json_t *ring = json_array_get(surf, r);
        if (!json_is_array(ring))
            return fail(L, HZ_ERR_FORMAT, "ring %zu is not an array of vertex indices", r);
        size_t m = json_array_size(ring);
        if (!hz_grow((void **)&L->pts, &L->pts_cap, 3 * (total + m), sizeof *L->pts, 64))
            return fail(L, HZ_ERR_MEMORY, "out of memory (ring of %zu vertices)", m);
        for (size_t k = 0; k < m; k++) {
            json_t *q = json_array_get(ring, k);
            json_int_t ix = json_is_integer(q) ? json_integer_value(q) : -1;
            if (ix < 0 || ix >= (json_int_t)L->vcount)
                return fail(L, HZ_ERR_FORMAT, "ring %zu, entry %zu: vertex %s%lld out of range (%u vertices)", r, k,
                            json_is_integer(q) ? "" : "(not an integer) ", (long long)ix, L->vcount);
            memcpy(L->pts + 3 * (total + k), c->verts + 3 * (L->vbase + (uint32_t)ix), 3 * sizeof(double));
        }
        total += m;
        L->rs[r + 1] = (uint32_t)total;
    }
    o->faces++;
    c->faces++;
    uint64_t tcap = total + 2 * nr;
    if (!hz_grow((void **)&L->tbuf, &L->tbuf_cap, 3 * tcap, sizeof *L->tbuf, 64))
        return fail(L, HZ_ERR_MEMORY, "out of memory");
    int nt = hz_polygon_triangulate(L->pts, L->rs, (uint32_t)nr, L->tbuf);
    if (nt < 0)
        return fail(L, HZ_ERR_MEMORY, "out of memory triangulating");
    if (!nt)
        return HZ_OK; /* degenerate face: nothing to draw */
    /* The scratch points map back to the file's vertex indices. */
    uint32_t base = c->tri_count, old_cap = L->tri_cap;
    if (!hz_grow((void **)&c->tris, &L->tri_cap, 3 * ((uint64_t)base + (uint32_t)nt), sizeof *c->tris, 64))
        return fail(L, HZ_ERR_MEMORY, "out of memory (%u triangles)", base);
    /* The per-triangle arrays follow the index array's capacity, so they grow
     * when it does, not once per face. */
    if (L->tri_cap != old_cap || !c->tri_kind) {
        uint8_t *nk = realloc(c->tri_kind, (size_t)L->tri_cap / 3 + 1);
        if (!nk)
            return fail(L, HZ_ERR_MEMORY, "out of memory");
        c->tri_kind = nk;
        uint32_t *nm = realloc(c->tri_material, ((size_t)L->tri_cap / 3 + 1) * sizeof *nm);
        if (!nm)
            return fail(L, HZ_ERR_MEMORY, "out of memory");
        c->tri_material = nm;
    }
    /* Which file vertex each scratch point is: re-read the rings. */
    uint32_t *fileix = malloc((size_t)total * sizeof *fileix);
    if (!fileix)
        return fail(L, HZ_ERR_MEMORY, "out of memory");
    for (size_t r = 0, q = 0; r < nr; r++) {
        json_t *ring = json_array_get(surf, r);
        for (size_t k = 0; k < json_array_size(ring); k++)
            fileix[q++] = L->vbase + (uint32_t)json_integer_value(json_array_get(ring, k));
    }
    for (int t = 0; t < nt; t++) {
        uint32_t *d = c->tris + 3 * (base + (uint32_t)t);
        for (int k = 0; k < 3; k++)
            d[k] = fileix[L->tbuf[3 * t + k]];
        c->tri_material[base + (uint32_t)t] = L->surf_material;
        c->tri_kind[base + (uint32_t)t] =
            (uint8_t)(kind >= 0 ? kind
                                : (int)kind_of_normal(c->verts + 3 * d[0], c->verts + 3 * d[1], c->verts + 3 * d[2]));
    }
    free(fileix);
    c->tri_count += (uint32_t)nt;
    o->tri_count += (uint32_t)nt;
    return HZ_OK;
}

static int semantic_kind(json_t *surfaces, json_t *val)
{
    if (!val || json_is_null(val) || !json_is_integer(val))
        return -1;
    json_int_t i = json_integer_value(val);
    if (i < 0 || (size_t)i >= json_array_size(surfaces))
        return -2;
    json_t *t = json_object_get(json_array_get(surfaces, (size_t)i), "type");
    return (int)kind_of_semantic(json_is_string(t) ? json_string_value(t) : NULL);
}

/* The appearance material of a surface: a material value (an index or
 * null). -2 when out of range or not an index. */
static int64_t material_of(const loader *L, json_t *val)
{
    if (!val || json_is_null(val))
        return -1;
    if (!json_is_integer(val) || json_integer_value(val) < 0 ||
        (uint64_t)json_integer_value(val) >= L->c->material_count)
        return -2;
    return json_integer_value(val);
}

/* depth: 1 = array of surfaces (MultiSurface), 2 = shells (Solid), 3 = solids.
 * sv, mv: the semantics and material values nested alike (or NULL);
 * mat_all: one material for every surface (-1: none, or per mv). */
static hz_result read_nested(loader *L, json_t *b, json_t *sv, json_t *mv, int64_t mat_all, json_t *surfaces,
                             int depth, hz_city_object *o)
{
    if (!json_is_array(b))
        return fail(L, HZ_ERR_FORMAT, "boundaries: expected an array");
    size_t plen = strlen(L->path);
    for (size_t k = 0; k < json_array_size(b); k++) {
        json_t *e = json_array_get(b, k);
        json_t *v = json_is_array(sv) ? json_array_get(sv, k) : NULL;
        json_t *m = json_is_array(mv) ? json_array_get(mv, k) : NULL;
        snprintf(L->path + plen, sizeof L->path - plen, "[%zu]", k);
        hz_result r;
        if (depth == 1) {
            int kind = semantic_kind(surfaces, v);
            if (kind == -2)
                return fail(L, HZ_ERR_FORMAT, "semantics value out of range (%zu surfaces)",
                            json_array_size(surfaces));
            if (kind >= 0)
                L->c->semantics = true;
            const int64_t mat = mat_all >= 0 ? mat_all : material_of(L, m);
            if (mat == -2)
                return fail(L, HZ_ERR_FORMAT, "material value is not an index below %u (appearance.materials)",
                            L->c->material_count);
            L->surf_material = mat >= 0 ? (uint32_t)mat : HZ_CITY_NO_MATERIAL;
            r = read_surface(L, e, o->terrain ? (int)HZ_SURF_GROUND : kind, o);
        } else {
            r = read_nested(L, e, v, m, mat_all, surfaces, depth - 1, o);
        }
        if (r != HZ_OK)
            return r;
    }
    L->path[plen] = 0;
    return HZ_OK;
}

/* The material theme of geometry g: its "material" object's entry for the
 * file's default theme, else its first; NULL when it has none. On a theme
 * with a single "value", *all is that material (checked), else -1. */
static hz_result material_theme(loader *L, json_t *g, json_t **values, int64_t *all)
{
    *values = NULL;
    *all = -1;
    json_t *mo = json_object_get(g, "material");
    if (!mo)
        return HZ_OK;
    size_t plen = strlen(L->path);
    snprintf(L->path + plen, sizeof L->path - plen, ".material");
    if (!json_is_object(mo))
        return fail(L, HZ_ERR_FORMAT, "not an object of themes");
    const char *name = L->c->material_theme[0] ? L->c->material_theme : NULL;
    json_t *th = name ? json_object_get(mo, name) : NULL;
    if (!th) {
        void *it = json_object_iter(mo);
        if (!it) {
            L->path[plen] = 0;
            return HZ_OK;
        }
        th = json_object_iter_value(it);
        if (!name)
            snprintf(L->c->material_theme, sizeof L->c->material_theme, "%s", json_object_iter_key(it));
    }
    json_t *val = json_object_get(th, "value"), *vals = json_object_get(th, "values");
    if (val) {
        if ((*all = material_of(L, val)) == -2)
            return fail(L, HZ_ERR_FORMAT, "value is not an index below %u (appearance.materials)",
                        L->c->material_count);
    } else if (json_is_array(vals)) {
        *values = vals;
    } else {
        return fail(L, HZ_ERR_FORMAT, "a theme needs \"value\" or the array \"values\"");
    }
    L->path[plen] = 0;
    return HZ_OK;
}

/* appearance.materials: diffuse colours (optional). */
static hz_result read_materials(loader *L, json_t *root)
{
    json_t *ap = json_object_get(root, "appearance");
    if (!ap)
        return HZ_OK;
    snprintf(L->path, sizeof L->path, "appearance");
    if (!json_is_object(ap))
        return fail(L, HZ_ERR_FORMAT, "not an object");
    json_t *dt = json_object_get(ap, "default-theme-material");
    if (json_is_string(dt))
        snprintf(L->c->material_theme, sizeof L->c->material_theme, "%s", json_string_value(dt));
    json_t *ms = json_object_get(ap, "materials");
    if (!ms) {
        L->path[0] = 0;
        return HZ_OK;
    }
    if (!json_is_array(ms) || json_array_size(ms) > 65536)
        return fail(L, HZ_ERR_FORMAT, "materials: not an array (of at most 65 536)");
    hz_city *c = L->c;
    c->materials = calloc(json_array_size(ms) + 1, sizeof *c->materials);
    if (!c->materials)
        return fail(L, HZ_ERR_MEMORY, "out of memory");
    for (size_t k = 0; k < json_array_size(ms); k++) {
        json_t *m = json_array_get(ms, k), *dc = json_object_get(m, "diffuseColor");
        hz_city_material *cm = &c->materials[k];
        snprintf(L->path, sizeof L->path, "appearance.materials[%zu]", k);
        if (!json_is_object(m))
            return fail(L, HZ_ERR_FORMAT, "not an object");
        double rgb[3] = {0.8, 0.8, 0.8};
        if (dc && (!get3(dc, rgb) || rgb[0] < 0 || rgb[0] > 1 || rgb[1] < 0 || rgb[1] > 1 || rgb[2] < 0 ||
                   rgb[2] > 1))
            return fail(L, HZ_ERR_FORMAT, "diffuseColor: three numbers in [0, 1]");
        for (int a = 0; a < 3; a++)
            cm->color[a] = (float)rgb[a];
        json_t *nm = json_object_get(m, "name");
        snprintf(cm->name, sizeof cm->name, "%s", json_is_string(nm) ? json_string_value(nm) : "");
        c->material_count++;
    }
    L->path[0] = 0;
    return HZ_OK;
}

static float lod_value(json_t *g)
{
    json_t *l = json_object_get(g, "lod");
    if (json_is_string(l))
        return strtof(json_string_value(l), NULL);
    if (json_is_number(l))
        return (float)json_number_value(l);
    return -1;
}

/* The template a GeometryInstance g names (checked). */
static hz_result instance_template(loader *L, json_t *g, json_t **tmpl)
{
    json_t *t = json_object_get(g, "template");
    const size_t nt = L->templates ? json_array_size(L->templates) : 0;
    if (!json_is_integer(t) || json_integer_value(t) < 0 || (size_t)json_integer_value(t) >= nt)
        return fail(L, HZ_ERR_FORMAT, "template: %s (%zu geometry templates)",
                    json_is_integer(t) ? "out of range" : "missing or not an integer", nt);
    *tmpl = json_array_get(L->templates, (size_t)json_integer_value(t));
    if (!json_is_object(*tmpl))
        return fail(L, HZ_ERR_FORMAT, "template %lld is not a geometry", (long long)json_integer_value(t));
    return HZ_OK;
}

/* A GeometryInstance: its template's vertices, transformed by the
 * row-major 4 x 4 transformationMatrix and moved to the reference point
 * (boundaries[0], a vertex of the file), are appended to the city's
 * vertices; the template's rings then address them (L->vbase). */
static hz_result instance_vertices(loader *L, json_t *g, json_t **tmpl)
{
    hz_city *c = L->c;
    hz_result r = instance_template(L, g, tmpl);
    if (r != HZ_OK)
        return r;
    json_t *b = json_object_get(g, "boundaries");
    json_t *ref = json_array_get(b, 0);
    if (!json_is_array(b) || json_array_size(b) != 1 || !json_is_integer(ref) || json_integer_value(ref) < 0 ||
        json_integer_value(ref) >= (json_int_t)L->file_verts)
        return fail(L, HZ_ERR_FORMAT, "boundaries: must be [the reference point's vertex index] (%u vertices)",
                    L->file_verts);
    json_t *mj = json_object_get(g, "transformationMatrix");
    double m[16];
    if (!json_is_array(mj) || json_array_size(mj) != 16)
        return fail(L, HZ_ERR_FORMAT, "transformationMatrix: missing or not 16 numbers");
    for (size_t k = 0; k < 16; k++) {
        json_t *q = json_array_get(mj, k);
        if (!json_is_number(q) || !isfinite(m[k] = json_number_value(q)))
            return fail(L, HZ_ERR_FORMAT, "transformationMatrix[%zu]: not a finite number", k);
    }
    if (!L->tvert_count)
        return fail(L, HZ_ERR_FORMAT, "geometry-templates.vertices-templates: missing or empty");
    const uint64_t limit = 8u << 20; /* 192 MB of vertices */
    if (L->instanced + L->tvert_count > limit)
        return fail(L, HZ_ERR_VALUE, "geometry instances add more than %llu vertices", (unsigned long long)limit);
    if (!hz_grow((void **)&c->verts, &L->vert_cap, 3 * ((uint64_t)c->vert_count + L->tvert_count),
                 sizeof *c->verts, 64))
        return fail(L, HZ_ERR_MEMORY, "out of memory for the instance's %u vertices", L->tvert_count);
    const double *p0 = c->verts + 3 * ((size_t)L->fbase + (size_t)json_integer_value(ref));
    const double px = p0[0], py = p0[1], pz = p0[2];
    double *d = c->verts + 3 * (size_t)c->vert_count;
    for (uint32_t v = 0; v < L->tvert_count; v++) {
        const double *t = L->tverts + 3 * (size_t)v;
        d[3 * v + 0] = m[0] * t[0] + m[1] * t[1] + m[2] * t[2] + m[3] + px;
        d[3 * v + 1] = m[4] * t[0] + m[5] * t[1] + m[6] * t[2] + m[7] + py;
        d[3 * v + 2] = m[8] * t[0] + m[9] * t[1] + m[10] * t[2] + m[11] + pz;
        for (int k = 0; k < 3; k++)
            if (!(fabs(d[3 * v + k]) <= HZ_CITY_MAX_COORD))
                return fail(L, HZ_ERR_VALUE, "template vertex %u lies at %g once transformed, beyond %.0e", v,
                            d[3 * v + k], HZ_CITY_MAX_COORD);
    }
    L->vbase = c->vert_count;
    L->vcount = L->tvert_count;
    c->vert_count += L->tvert_count;
    L->instanced += L->tvert_count;
    c->instances++;
    return HZ_OK;
}

/* geometry-templates: the templates and their vertices (real coordinates,
 * not quantised). Optional. */
static hz_result read_templates(loader *L, json_t *root)
{
    json_t *gt = json_object_get(root, "geometry-templates");
    if (!gt)
        return HZ_OK;
    snprintf(L->path, sizeof L->path, "geometry-templates");
    json_t *t = json_object_get(gt, "templates"), *v = json_object_get(gt, "vertices-templates");
    if (!json_is_object(gt) || !json_is_array(t) || !json_is_array(v))
        return fail(L, HZ_ERR_FORMAT, "needs the arrays templates and vertices-templates");
    const size_t n = json_array_size(v);
    if (n > (1u << 20))
        return fail(L, HZ_ERR_VALUE, "%zu template vertices is too many (at most 1 M)", n);
    L->tverts = malloc((n ? n : 1) * 3 * sizeof *L->tverts);
    if (!L->tverts)
        return fail(L, HZ_ERR_MEMORY, "out of memory for %zu template vertices", n);
    for (size_t i = 0; i < n; i++) {
        double p[3];
        if (!get3(json_array_get(v, i), p)) {
            snprintf(L->path, sizeof L->path, "geometry-templates.vertices-templates[%zu]", i);
            return fail(L, HZ_ERR_FORMAT, "not three finite numbers");
        }
        memcpy(L->tverts + 3 * i, p, sizeof p);
    }
    L->tvert_count = (uint32_t)n;
    L->templates = t;
    L->path[0] = 0;
    return HZ_OK;
}

static hz_result read_object(loader *L, const char *key, json_t *obj, float want_lod)
{
    hz_city *c = L->c;
    hz_city_object *o = &c->obj[c->obj_count];
    memset(o, 0, sizeof *o);
    o->first_tri = c->tri_count;
    snprintf(L->path, sizeof L->path, "CityObjects.%.200s", key);
    if (!json_is_object(obj))
        return fail(L, HZ_ERR_FORMAT, "not an object");
    json_t *type = json_object_get(obj, "type");
    if (!json_is_string(type))
        return fail(L, HZ_ERR_FORMAT, "type: missing or not a string");
    json_t *attr = json_object_get(obj, "attributes");
    o->id = strdup(key);
    o->type = strdup(json_string_value(type));
    o->attributes = attr && json_is_object(attr) ? json_dumps(attr, JSON_COMPACT) : strdup("{}");
    c->obj_count++;
    if (!o->id || !o->type || !o->attributes)
        return fail(L, HZ_ERR_MEMORY, "out of memory");
    o->terrain = !strcmp(o->type, "TINRelief");
    json_t *geoms = json_object_get(obj, "geometry");
    if (!geoms)
        return HZ_OK;
    if (!json_is_array(geoms))
        return fail(L, HZ_ERR_FORMAT, "geometry: not an array");
    /* The geometry to read: the asked LoD, else the highest. A
     * GeometryInstance counts with its template's LoD. */
    size_t pick = SIZE_MAX;
    float best = -1;
    const size_t plen = strlen(L->path);
    for (size_t g = 0; g < json_array_size(geoms); g++) {
        json_t *gg = json_array_get(geoms, g);
        json_t *gt = json_object_get(gg, "type");
        if (!json_is_string(gt))
            continue;
        json_t *shape = gg;
        if (!strcmp(json_string_value(gt), "GeometryInstance")) {
            snprintf(L->path + plen, sizeof L->path - plen, ".geometry[%zu]", g);
            hz_result r = instance_template(L, gg, &shape);
            if (r != HZ_OK)
                return r;
            L->path[plen] = 0;
        }
        float l = lod_value(shape);
        if (want_lod > 0 ? fabsf(l - want_lod) < 1e-3f : l > best) {
            best = l;
            pick = g;
            if (want_lod > 0)
                break;
        }
    }
    if (pick == SIZE_MAX)
        return HZ_OK;
    json_t *g = json_array_get(geoms, pick);
    json_t *shape = g; /* what holds the boundaries: the geometry or its template */
    const bool inst = !strcmp(json_string_value(json_object_get(g, "type")), "GeometryInstance");
    if (inst) {
        snprintf(L->path + plen, sizeof L->path - plen, ".geometry[%zu]", pick);
        hz_result r = instance_vertices(L, g, &shape);
        if (r != HZ_OK)
            return r;
    }
    json_t *st = json_object_get(shape, "type");
    const char *gt = json_is_string(st) ? json_string_value(st) : "";
    int depth = !strcmp(gt, "MultiSurface") || !strcmp(gt, "CompositeSurface") ? 1
                : !strcmp(gt, "Solid")                                         ? 2
                : !strcmp(gt, "MultiSolid") || !strcmp(gt, "CompositeSolid")  ? 3
                                                                                : 0;
    if (!depth) {
        L->vbase = L->fbase, L->vcount = L->file_verts;
        return HZ_OK; /* points and lines: nothing to draw */
    }
    o->lod = best;
    json_t *sem = json_object_get(shape, "semantics");
    json_t *surfaces = sem ? json_object_get(sem, "surfaces") : NULL;
    json_t *values = sem ? json_object_get(sem, "values") : NULL;
    if (inst) /* errors in the template's boundaries name the template */
        snprintf(L->path, sizeof L->path, "geometry-templates.templates[%lld]",
                 (long long)json_integer_value(json_object_get(g, "template")));
    else
        snprintf(L->path + plen, sizeof L->path - plen, ".geometry[%zu]", pick);
    if (sem && (!json_is_array(surfaces) || !json_is_array(values))) {
        snprintf(L->path + strlen(L->path), sizeof L->path - strlen(L->path), ".semantics");
        return fail(L, HZ_ERR_FORMAT, "needs the arrays surfaces and values");
    }
    json_t *mvals;
    int64_t mat_all;
    hz_result r = material_theme(L, shape, &mvals, &mat_all);
    if (r != HZ_OK)
        return r;
    snprintf(L->path + strlen(L->path), sizeof L->path - strlen(L->path), ".boundaries");
    r = read_nested(L, json_object_get(shape, "boundaries"), values, mvals, mat_all, surfaces, depth, o);
    L->vbase = L->fbase, L->vcount = L->file_verts;
    if (r != HZ_OK)
        return r;
    /* A small instance may repeat a big template: bounded like the vertices. */
    if (inst && (L->instanced_tris += o->tri_count) > (16u << 20))
        return fail(L, HZ_ERR_VALUE, "geometry instances make more than %u triangles", 16u << 20);
    if (o->terrain && o->tri_count)
        c->terrain_objects++;
    else if (o->tri_count && (!strcmp(o->type, "Building") || !strcmp(o->type, "BuildingPart")))
        c->buildings++;
    return HZ_OK;
}

/* The CityObjects of a file or a feature, appended to the city's. */
static hz_result read_objects(loader *L, json_t *objs, float want_lod)
{
    hz_city *c = L->c;
    if (!json_is_object(objs)) {
        snprintf(L->path, sizeof L->path, "CityObjects");
        return fail(L, HZ_ERR_FORMAT, "missing or not an object");
    }
    const size_t n = json_object_size(objs);
    if ((uint64_t)c->obj_count + n > UINT32_MAX / 2) {
        snprintf(L->path, sizeof L->path, "CityObjects");
        return fail(L, HZ_ERR_VALUE, "too many objects");
    }
    /* Grown by doubling: a CityJSONSeq calls this once per feature. */
    if (!hz_grow((void **)&c->obj, &L->obj_cap, (uint64_t)c->obj_count + n + 1, sizeof *c->obj, 64))
        return fail(L, HZ_ERR_MEMORY, "out of memory");
    const char *key;
    json_t *val;
    json_object_foreach(objs, key, val)
    {
        hz_result r = read_object(L, key, val, want_lod);
        if (r != HZ_OK)
            return r;
    }
    return HZ_OK;
}

/* The header of a file or of a CityJSON Text Sequence (its first line):
 * type, version, transform and vertices, CRS, templates, materials, objects. */
static hz_result read_header(loader *L, json_t *root, const hz_city_desc *desc)
{
    hz_city *c = L->c;
    json_t *type = json_object_get(root, "type");
    if (!json_is_object(root) || !json_is_string(type) || strcmp(json_string_value(type), "CityJSON"))
        return fail(L, HZ_ERR_FORMAT, "not a CityJSON file (no \"type\": \"CityJSON\")");
    json_t *ver = json_object_get(root, "version");
    snprintf(c->version, sizeof c->version, "%s", json_is_string(ver) ? json_string_value(ver) : "?");
    hz_result r;
    if ((r = read_vertices(L, root)) != HZ_OK || (r = read_crs(L, root)) != HZ_OK ||
        (r = read_templates(L, root)) != HZ_OK || (r = read_materials(L, root)) != HZ_OK)
        return r;
    return read_objects(L, json_object_get(root, "CityObjects"), desc ? desc->lod : 0);
}

/* One line of a sequence after the first: a CityJSONFeature, whose
 * vertices (quantised by the first line's transform) its objects index. */
static hz_result read_feature(loader *L, json_t *f, const hz_city_desc *desc)
{
    json_t *type = json_object_get(f, "type");
    if (!json_is_object(f) || !json_is_string(type) || strcmp(json_string_value(type), "CityJSONFeature"))
        return fail(L, HZ_ERR_FORMAT, "not a CityJSONFeature (no \"type\": \"CityJSONFeature\")");
    if (json_object_get(f, "appearance")) {
        snprintf(L->path, sizeof L->path, "appearance");
        return fail(L, HZ_ERR_UNSUPPORTED, "materials of a feature's own are not supported (put them in the "
                                           "first line's appearance)");
    }
    hz_result r = append_vertices(L, json_object_get(f, "vertices"));
    if (r != HZ_OK)
        return r;
    check_translate(L);
    r = read_objects(L, json_object_get(f, "CityObjects"), desc ? desc->lod : 0);
    L->c->features++;
    return r;
}

/* A CityJSON Text Sequence (CityJSONL, .city.jsonl): one JSON text per
 * line, a CityJSON header then CityJSONFeatures. */
static hz_result read_sequence(loader *L, const char *data, size_t size, json_t *header, size_t first_end,
                               const hz_city_desc *desc)
{
    hz_result r = read_header(L, header, desc);
    size_t line = 1;
    for (size_t at = first_end; r == HZ_OK && at < size;) {
        const char *nl = memchr(data + at, '\n', size - at);
        const size_t end = nl ? (size_t)(nl - data) : size;
        line++;
        size_t b = at, e = end;
        while (b < e && (data[b] == ' ' || data[b] == '\t' || data[b] == '\r'))
            b++;
        at = end + 1;
        if (b == e)
            continue; /* blank lines between features */
        snprintf(L->where, sizeof L->where, "line %zu: ", line);
        L->path[0] = 0;
        json_error_t je;
        json_t *f = json_loadb(data + b, e - b, JSON_REJECT_DUPLICATES, &je);
        if (!f)
            return fail(L, HZ_ERR_FORMAT, "column %d: %s", je.column, je.text);
        r = read_feature(L, f, desc);
        json_decref(f);
    }
    return r;
}

hz_city *hz_city_load_memory(const char *data, size_t size, const char *name, const hz_city_desc *desc, hz_err *err)
{
    double t0 = hz_time_ms();
    loader L = {.name = name ? name : "CityJSON", .err = err};
    json_error_t je;
    json_t *root = json_loadb(data, size, JSON_REJECT_DUPLICATES, &je);
    /* More than one JSON text: a sequence when its first line is a CityJSON
     * object on its own. */
    size_t first_end = 0;
    if (!root) {
        const char *nl = memchr(data, '\n', size);
        json_error_t je1;
        json_t *first = nl ? json_loadb(data, (size_t)(nl - data), JSON_REJECT_DUPLICATES, &je1) : NULL;
        json_t *type = first ? json_object_get(first, "type") : NULL;
        if (json_is_string(type) && !strcmp(json_string_value(type), "CityJSON")) {
            root = first;
            first_end = (size_t)(nl - data) + 1;
        } else {
            json_decref(first);
            hz_err_set(err, HZ_ERR_FORMAT, "%s: line %d, column %d: %s", L.name, je.line, je.column, je.text);
            return NULL;
        }
    }
    hz_city *c = calloc(1, sizeof *c);
    L.c = c;
    hz_result r = HZ_OK;
    if (!c) {
        r = hz_err_set(err, HZ_ERR_MEMORY, "%s: out of memory", L.name);
        goto out;
    }
    if (first_end)
        snprintf(L.where, sizeof L.where, "line 1: ");
    r = first_end ? read_sequence(&L, data, size, root, first_end, desc) : read_header(&L, root, desc);
    if (r != HZ_OK)
        goto out;
    L.where[0] = 0;
    /* The extent of the vertices the triangles use. */
    for (int k = 0; k < 3; k++) {
        c->extent[k] = DBL_MAX;
        c->extent[3 + k] = -DBL_MAX;
    }
    for (uint32_t t = 0; t < 3 * c->tri_count; t++)
        for (int k = 0; k < 3; k++) {
            double v = c->verts[3 * c->tris[t] + k];
            c->extent[k] = fmin(c->extent[k], v);
            c->extent[3 + k] = fmax(c->extent[3 + k], v);
        }
    if (!c->tri_count) {
        L.path[0] = 0;
        r = fail(&L, HZ_ERR_VALUE, "no surface to draw (no CityObject has a surface geometry)");
    }
out:
    json_decref(root);
    free(L.pts);
    free(L.rs);
    free(L.tbuf);
    free(L.tverts);
    if (r != HZ_OK) {
        hz_city_destroy(c);
        return NULL;
    }
    c->load_ms = hz_time_ms() - t0;
    return c;
}

hz_city *hz_city_load(const char *path, const hz_city_desc *desc, hz_err *err)
{
    const uint64_t max = desc && desc->max_bytes ? desc->max_bytes : (1ull << 30);
    FILE *f = fopen(path, "rb");
    if (!f) {
        hz_err_set(err, HZ_ERR_IO, "%s: %s", path, strerror(errno));
        return NULL;
    }
    char *buf = NULL;
    size_t len = 0, cap = 0;
    for (;;) {
        if (len == cap) {
            if (cap >= max) {
                fclose(f);
                free(buf);
                hz_err_set(err, HZ_ERR_VALUE, "%s: larger than %llu bytes", path, (unsigned long long)max);
                return NULL;
            }
            cap = cap ? cap * 2 : 1 << 20;
            char *nb = realloc(buf, cap);
            if (!nb) {
                fclose(f);
                free(buf);
                hz_err_set(err, HZ_ERR_MEMORY, "%s: out of memory", path);
                return NULL;
            }
            buf = nb;
        }
        size_t got = fread(buf + len, 1, cap - len, f);
        len += got;
        if (!got)
            break;
    }
    bool bad = ferror(f);
    fclose(f);
    if (bad) {
        free(buf);
        hz_err_set(err, HZ_ERR_IO, "%s: read error", path);
        return NULL;
    }
    const char *base = strrchr(path, '/');
    hz_city *c = hz_city_load_memory(buf, len, base ? base + 1 : path, desc, err);
    free(buf);
    return c;
}

/* ---- placement -------------------------------------------------------------- */

static const hz_material surf_mat[HZ_SURF_KINDS] = {
    {.color = {0.78f, 0.74f, 0.66f}, .name = "wall"},
    {.color = {0.62f, 0.30f, 0.22f}, .name = "roof"},
    {.color = {0.45f, 0.43f, 0.40f}, .name = "ground"},
};

/* City vertices (CRS) -> local metres: x, z and y (height). */
static hz_result to_local(const hz_city *c, const hz_city_place *p, double *lx, double *lz, hz_err *err)
{
    const uint32_t n = c->vert_count;
    for (uint32_t i = 0; i < n; i++) {
        lx[i] = c->verts[3 * i];
        lz[i] = c->verts[3 * i + 1];
    }
    if (!p->georef) {
        for (uint32_t i = 0; i < n; i++) {
            lx[i] -= p->origin[0];
            lz[i] = -(lz[i] - p->origin[1]);
        }
        return HZ_OK;
    }
    if (!c->crs[0])
        return hz_err_set(err, HZ_ERR_VALUE, "city: the model has no CRS (metadata.referenceSystem), so it cannot be "
                                             "placed on a georeferenced terrain");
    OGRSpatialReferenceH src = OSRNewSpatialReference(NULL), dst = OSRNewSpatialReference(NULL);
    hz_result r = HZ_OK;
    if (!src || !dst || OSRSetFromUserInput(src, c->crs) != OGRERR_NONE ||
        OSRSetFromUserInput(dst, hz_georef_wkt(p->georef)) != OGRERR_NONE) {
        r = hz_err_set(err, HZ_ERR_VALUE, "city: cannot read the CRS %s or the terrain's", c->crs);
        goto done;
    }
    OSRSetAxisMappingStrategy(src, OAMS_TRADITIONAL_GIS_ORDER);
    OSRSetAxisMappingStrategy(dst, OAMS_TRADITIONAL_GIS_ORDER);
    if (!OSRIsSame(src, dst)) {
        OGRCoordinateTransformationH ct = OCTNewCoordinateTransformation(src, dst);
        if (!ct) {
            r = hz_err_set(err, HZ_ERR_VALUE, "city: PROJ cannot convert %s to the terrain's %s", c->crs,
                           hz_georef_label(p->georef));
            goto done;
        }
        int *ok = malloc((n ? n : 1) * sizeof *ok);
        if (!ok || !OCTTransformEx(ct, (int)n, lx, lz, NULL, ok)) {
            free(ok);
            OCTDestroyCoordinateTransformation(ct);
            r = hz_err_set(err, HZ_ERR_VALUE, "city: PROJ failed converting %s to %s", c->crs,
                           hz_georef_label(p->georef));
            goto done;
        }
        free(ok);
        OCTDestroyCoordinateTransformation(ct);
    }
    for (uint32_t i = 0; i < n; i++)
        hz_georef_crs_to_local(p->georef, lx[i], lz[i], &lx[i], &lz[i]);
done:
    if (src)
        OSRDestroySpatialReference(src);
    if (dst)
        OSRDestroySpatialReference(dst);
    return r;
}

/* Flat-shaded mesh of one object's triangles of the kinds in mask, relative
 * to (ox, oy, oz). HZ_MESH_NONE when there are none (err untouched). */
/* What a triangle is drawn with: its appearance material (HZ_SURF_KINDS +
 * index), else roofs with the roof material and walls and floors with the
 * wall material. */
static uint32_t draw_material(const hz_city *c, uint32_t t)
{
    if (c->tri_material && c->tri_material[t] != HZ_CITY_NO_MATERIAL)
        return HZ_SURF_KINDS + c->tri_material[t];
    return c->tri_kind[t] == HZ_SURF_ROOF ? HZ_SURF_ROOF : HZ_SURF_WALL;
}

/* A mesh of the object's triangles drawn with draw material dm, in local
 * metres about (ox, oy, oz); HZ_MESH_NONE when it has none (or on error). */
static uint32_t build_mesh(hz_scene *s, const hz_city *c, const hz_city_object *o, uint32_t dm, const double *lx,
                           const double *lz, double ox, double oy, double oz, hz_vertex *vb, uint32_t *ib,
                           uint64_t *tris, hz_err *err)
{
    uint32_t nv = 0;
    for (uint32_t t = o->first_tri; t < o->first_tri + o->tri_count; t++) {
        if (draw_material(c, t) != dm)
            continue;
        vec3 p[3];
        for (int k = 0; k < 3; k++) {
            uint32_t v = c->tris[3 * t + (uint32_t)k];
            p[k][0] = (float)(lx[v] - ox);
            p[k][1] = (float)(c->verts[3 * v + 2] - oy);
            p[k][2] = (float)(lz[v] - oz);
        }
        /* CRS (x east, y north, z up) -> local (x east, y up, z south) is a
         * rotation: CityJSON's outward counter-clockwise rings stay so. */
        vec3 e1, e2, nrm;
        glm_vec3_sub(p[1], p[0], e1);
        glm_vec3_sub(p[2], p[0], e2);
        glm_vec3_cross(e1, e2, nrm);
        glm_vec3_normalize(nrm);
        for (int k = 0; k < 3; k++) {
            vb[nv] = (hz_vertex){{p[k][0], p[k][1], p[k][2]}, {nrm[0], nrm[1], nrm[2]}};
            ib[nv] = nv;
            nv++;
        }
    }
    if (!nv)
        return HZ_MESH_NONE;
    *tris += nv / 3;
    return hz_scene_add_mesh(s, vb, nv, ib, nv, err);
}

hz_result hz_city_to_scene(const hz_city *c, hz_scene *s, const hz_city_place *p, hz_city_placed *out, hz_err *err)
{
    hz_city_placed res = {0};
    const uint32_t n = c->vert_count;
    double *lx = malloc((n ? n : 1) * sizeof *lx), *lz = malloc((n ? n : 1) * sizeof *lz);
    uint32_t maxtri = 0;
    for (uint32_t k = 0; k < c->obj_count; k++)
        maxtri = c->obj[k].tri_count > maxtri ? c->obj[k].tri_count : maxtri;
    hz_vertex *vb = malloc(((size_t)maxtri * 3 + 1) * sizeof *vb);
    uint32_t *ib = malloc(((size_t)maxtri * 3 + 1) * sizeof *ib);
    uint32_t *tile_node = NULL;
    /* per draw material: the last object (+ 1) that listed it; the object's list */
    const size_t ndraw = (size_t)HZ_SURF_KINDS + c->material_count;
    uint32_t *dm_stamp = calloc(ndraw, sizeof *dm_stamp), *dm_list = malloc(ndraw * sizeof *dm_list);
    hz_result r = HZ_OK;
    if (!lx || !lz || !vb || !ib || !dm_stamp || !dm_list) {
        r = hz_err_set(err, HZ_ERR_MEMORY, "city: out of memory placing %u vertices", n);
        goto done;
    }
    if ((r = to_local(c, p, lx, lz, err)) != HZ_OK)
        goto done;
    for (int k = 0; k < HZ_SURF_KINDS; k++) {
        res.materials[k] = hz_scene_add_material(s, &surf_mat[k]);
        if (res.materials[k] == HZ_MESH_NONE) {
            r = hz_err_set(err, HZ_ERR_MEMORY, "city: out of memory");
            goto done;
        }
    }
    /* The file's appearance materials follow, in order. */
    res.first_material = HZ_MESH_NONE;
    for (uint32_t k = 0; k < c->material_count; k++) {
        hz_material m = {.color = {c->materials[k].color[0], c->materials[k].color[1], c->materials[k].color[2]}};
        snprintf(m.name, sizeof m.name, "%s", c->materials[k].name);
        uint32_t id = hz_scene_add_material(s, &m);
        if (id == HZ_MESH_NONE) {
            r = hz_err_set(err, HZ_ERR_MEMORY, "city: out of memory");
            goto done;
        }
        if (!k)
            res.first_material = id;
    }
    uint32_t root = hz_scene_add_node(s, HZ_NODE_NONE, "city");
    res.nodes++;
    /* Tiles over the objects' local extent. */
    const uint32_t tiles = p->tiles ? p->tiles : 16;
    double ex[4] = {DBL_MAX, DBL_MAX, -DBL_MAX, -DBL_MAX};
    for (uint32_t t = 0; t < 3 * c->tri_count; t++) {
        uint32_t v = c->tris[t];
        ex[0] = fmin(ex[0], lx[v]);
        ex[1] = fmin(ex[1], lz[v]);
        ex[2] = fmax(ex[2], lx[v]);
        ex[3] = fmax(ex[3], lz[v]);
    }
    tile_node = calloc((size_t)tiles * tiles, sizeof *tile_node);
    if (!root || !tile_node) {
        r = hz_err_set(err, HZ_ERR_MEMORY, "city: out of memory");
        goto done;
    }
    double shift_sum = 0;
    for (uint32_t k = 0; k < c->obj_count; k++) {
        const hz_city_object *o = &c->obj[k];
        if (o->terrain || !o->tri_count)
            continue;
        double bmin[3] = {DBL_MAX, DBL_MAX, DBL_MAX}, bmax[3] = {-DBL_MAX, -DBL_MAX, -DBL_MAX};
        for (uint32_t t = 3 * o->first_tri; t < 3 * (o->first_tri + o->tri_count); t++) {
            uint32_t v = c->tris[t];
            double q[3] = {lx[v], c->verts[3 * v + 2], lz[v]};
            for (int a = 0; a < 3; a++) {
                bmin[a] = fmin(bmin[a], q[a]);
                bmax[a] = fmax(bmax[a], q[a]);
            }
        }
        double cx = 0.5 * (bmin[0] + bmax[0]), cz = 0.5 * (bmin[2] + bmax[2]), base = bmin[1];
        double shift = 0;
        if (p->ground) {
            /* The lowest ground under the footprint (its vertices at the base
             * and its centre): nothing floats; on a slope the uphill side sinks. */
            double g = p->ground(p->ground_user, (float)cx, (float)cz);
            for (uint32_t t = 3 * o->first_tri; t < 3 * (o->first_tri + o->tri_count); t++) {
                uint32_t v = c->tris[t];
                if (c->verts[3 * v + 2] < base + 0.5)
                    g = fmin(g, p->ground(p->ground_user, (float)lx[v], (float)lz[v]));
            }
            if (isfinite(g)) {
                shift = g - base;
                res.max_shift = fmax(res.max_shift, fabs(shift));
                shift_sum += fabs(shift);
                res.clamped++;
            } else {
                res.outside++; /* no ground under it: left at its own heights */
            }
        }
        uint32_t ti = (uint32_t)fmin(tiles - 1, fmax(0, (cx - ex[0]) / fmax(ex[2] - ex[0], 1e-9) * tiles));
        uint32_t tj = (uint32_t)fmin(tiles - 1, fmax(0, (cz - ex[1]) / fmax(ex[3] - ex[1], 1e-9) * tiles));
        uint32_t *tn = &tile_node[tj * tiles + ti];
        if (!*tn) {
            char nm[32];
            snprintf(nm, sizeof nm, "tile_%u_%u", ti, tj);
            *tn = hz_scene_add_node(s, root, nm);
            res.nodes++;
        }
        uint32_t node = *tn ? hz_scene_add_node(s, *tn, o->id) : HZ_NODE_NONE;
        if (!node) {
            r = hz_err_set(err, HZ_ERR_MEMORY, "city: out of memory adding nodes");
            goto done;
        }
        res.nodes++;
        res.buildings++;
        hz_scene_set_translation(s, node, (float[3]){(float)cx, (float)(base + shift), (float)cz});
        if ((r = hz_scene_set_attributes(s, node, o->attributes, err)) != HZ_OK)
            goto done;
        /* One mesh per draw material (walls, roofs, each appearance
         * material) in order of appearance: the first on the building's
         * node, the others on children. */
        uint32_t ndm = 0;
        for (uint32_t t = o->first_tri; t < o->first_tri + o->tri_count; t++) {
            const uint32_t dm = draw_material(c, t);
            if (dm_stamp[dm] != k + 1) {
                dm_stamp[dm] = k + 1;
                dm_list[ndm++] = dm;
            }
        }
        for (uint32_t q = 0; q < ndm; q++) {
            hz_err e2 = {0};
            uint32_t mesh = build_mesh(s, c, o, dm_list[q], lx, lz, cx, base, cz, vb, ib, &res.triangles, &e2);
            if (mesh == HZ_MESH_NONE) {
                if (e2.msg[0]) {
                    r = hz_err_set(err, e2.code, "city: %s: %s", o->id, e2.msg);
                    goto done;
                }
                continue;
            }
            const uint32_t mat = dm_list[q] >= HZ_SURF_KINDS ? res.first_material + (dm_list[q] - HZ_SURF_KINDS)
                                                             : res.materials[dm_list[q]];
            uint32_t at = node;
            if (hz_scene_node_mesh(s, node) != HZ_MESH_NONE) {
                at = hz_scene_add_node(s, node, NULL);
                if (!at) {
                    r = hz_err_set(err, HZ_ERR_MEMORY, "city: out of memory adding nodes");
                    goto done;
                }
                res.nodes++;
            }
            hz_scene_set_mesh(s, at, mesh, mat);
        }
    }
    res.mean_shift = res.clamped ? shift_sum / res.clamped : 0;
done:
    free(lx);
    free(lz);
    free(vb);
    free(ib);
    free(tile_node);
    free(dm_stamp);
    free(dm_list);
    if (out)
        *out = res;
    return r;
}

hz_result hz_city_tin_grid(const hz_city *c, double cell, float **heights, uint32_t *w, uint32_t *h, double gt[6],
                           hz_err *err)
{
    double mn[2] = {DBL_MAX, DBL_MAX}, mx[2] = {-DBL_MAX, -DBL_MAX};
    uint64_t nt = 0;
    for (uint32_t k = 0; k < c->obj_count; k++) {
        const hz_city_object *o = &c->obj[k];
        if (!o->terrain)
            continue;
        for (uint32_t t = 3 * o->first_tri; t < 3 * (o->first_tri + o->tri_count); t++)
            for (int a = 0; a < 2; a++) {
                mn[a] = fmin(mn[a], c->verts[3 * c->tris[t] + a]);
                mx[a] = fmax(mx[a], c->verts[3 * c->tris[t] + a]);
            }
        nt += o->tri_count;
    }
    if (!nt)
        return hz_err_set(err, HZ_ERR_VALUE, "city: no TINRelief terrain in the model");
    if (!(cell > 0))
        return hz_err_set(err, HZ_ERR_VALUE, "city: TIN grid cell %g must be > 0", cell);
    double fw = ceil((mx[0] - mn[0]) / cell), fh = ceil((mx[1] - mn[1]) / cell);
    if (!(fw >= 1 && fh >= 1 && fw * fh <= 64.0 * 1024 * 1024))
        return hz_err_set(err, HZ_ERR_VALUE, "city: a TIN grid of %.0f x %.0f cells of %g m is out of range", fw, fh,
                          cell);
    uint32_t W = (uint32_t)fw, H = (uint32_t)fh;
    float *g = malloc((size_t)W * H * sizeof *g);
    if (!g)
        return hz_err_set(err, HZ_ERR_MEMORY, "city: out of memory for the TIN grid");
    for (size_t k = 0; k < (size_t)W * H; k++)
        g[k] = NAN;
    gt[0] = mn[0];
    gt[1] = cell;
    gt[2] = 0;
    gt[3] = mn[1] + (double)H * cell;
    gt[4] = 0;
    gt[5] = -cell;
    for (uint32_t k = 0; k < c->obj_count; k++) {
        const hz_city_object *o = &c->obj[k];
        if (!o->terrain)
            continue;
        for (uint32_t t = o->first_tri; t < o->first_tri + o->tri_count; t++) {
            const double *a = c->verts + 3 * c->tris[3 * t], *b = c->verts + 3 * c->tris[3 * t + 1],
                         *d = c->verts + 3 * c->tris[3 * t + 2];
            double det = (b[0] - a[0]) * (d[1] - a[1]) - (d[0] - a[0]) * (b[1] - a[1]);
            if (det == 0)
                continue;
            double x0 = fmin(a[0], fmin(b[0], d[0])), x1 = fmax(a[0], fmax(b[0], d[0]));
            double y0 = fmin(a[1], fmin(b[1], d[1])), y1 = fmax(a[1], fmax(b[1], d[1]));
            int64_t i0 = (int64_t)floor((x0 - gt[0]) / cell - 0.5), i1 = (int64_t)ceil((x1 - gt[0]) / cell - 0.5);
            int64_t j0 = (int64_t)floor((gt[3] - y1) / cell - 0.5), j1 = (int64_t)ceil((gt[3] - y0) / cell - 0.5);
            for (int64_t j = j0 < 0 ? 0 : j0; j <= j1 && j < H; j++)
                for (int64_t i = i0 < 0 ? 0 : i0; i <= i1 && i < W; i++) {
                    double px = gt[0] + ((double)i + 0.5) * cell, py = gt[3] - ((double)j + 0.5) * cell;
                    double l1 = ((px - a[0]) * (d[1] - a[1]) - (d[0] - a[0]) * (py - a[1])) / det;
                    double l2 = ((b[0] - a[0]) * (py - a[1]) - (px - a[0]) * (b[1] - a[1])) / det;
                    double l0 = 1 - l1 - l2;
                    const double eps = -1e-9;
                    if (l0 < eps || l1 < eps || l2 < eps)
                        continue;
                    g[(size_t)j * W + (size_t)i] = (float)(l0 * a[2] + l1 * b[2] + l2 * d[2]);
                }
        }
    }
    *heights = g;
    *w = W;
    *h = H;
    return HZ_OK;
}
