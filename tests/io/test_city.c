/* CityJSON: dequantisation, solids, the semantic roof/wall split, the split
 * by normals without semantics, refusals (bad indices, a missing transform,
 * an unknown CRS, bad semantics), polygon triangulation (concave, holes), the
 * real Mamre model and its placement on its own TINRelief. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "horizon/city.h"
#include "horizon/georef.h"

/* A 10 x 8 x 6 m box as a Solid in EPSG:32734, quantised at 1 cm; faces
 * counter-clockwise from outside; semantics: 0 ground, 1 roof, 2 wall. */
#define BOX_VERTS "[[0,0,0],[1000,0,0],[1000,800,0],[0,800,0],[0,0,600],[1000,0,600],[1000,800,600],[0,800,600]]"
#define BOX_FACES                                                                                                  \
    "[[[0,3,2,1]],[[4,5,6,7]],[[0,1,5,4]],[[1,2,6,5]],[[2,3,7,6]],[[3,0,4,7]]]"

static const char *box_json(char *buf, size_t n, const char *transform, const char *crs, const char *faces,
                            const char *semantics)
{
    snprintf(buf, n,
             "{\"type\":\"CityJSON\",\"version\":\"2.0\",%s"
             "\"metadata\":{\"referenceSystem\":\"%s\"},"
             "\"CityObjects\":{\"b1\":{\"type\":\"Building\",\"attributes\":{\"osm_id\":42},"
             "\"geometry\":[{\"type\":\"Solid\",\"lod\":\"1\",\"boundaries\":[%s]%s}]}},"
             "\"vertices\":" BOX_VERTS "}",
             transform, crs, faces, semantics);
    return buf;
}

#define TRANSFORM "\"transform\":{\"scale\":[0.01,0.01,0.01],\"translate\":[265000.0,6289000.0,150.0]},"
#define CRS32734 "https://www.opengis.net/def/crs/EPSG/0/32734"

static double tri_area(const hz_city *c, uint32_t t)
{
    const double *a = c->verts + 3 * c->tris[3 * t], *b = c->verts + 3 * c->tris[3 * t + 1],
                 *d = c->verts + 3 * c->tris[3 * t + 2];
    double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v[3] = {d[0] - a[0], d[1] - a[1], d[2] - a[2]};
    double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
    return 0.5 * sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
}

static void test_box_solid(void **state)
{
    (void)state;
    char buf[4096];
    hz_err err = {0};
    box_json(buf, sizeof buf, TRANSFORM, CRS32734, BOX_FACES, "");
    hz_city *c = hz_city_load_memory(buf, strlen(buf), "box", NULL, &err);
    assert_non_null(c);
    assert_string_equal(c->crs, "EPSG:32734");
    assert_int_equal(c->vert_count, 8);
    /* Dequantised: v = i * scale + translate. */
    assert_true(fabs(c->verts[3 * 6 + 0] - 265010.0) < 1e-6);
    assert_true(fabs(c->verts[3 * 6 + 1] - 6289008.0) < 1e-6);
    assert_true(fabs(c->verts[3 * 6 + 2] - 156.0) < 1e-6);
    assert_int_equal(c->buildings, 1);
    assert_int_equal(c->obj[0].faces, 6);
    assert_int_equal(c->tri_count, 12);
    assert_false(c->semantics);
    /* By normals: 2 roof, 2 ground, 8 wall triangles, with the right areas. */
    double area[HZ_SURF_KINDS] = {0};
    for (uint32_t t = 0; t < c->tri_count; t++)
        area[c->tri_kind[t]] += tri_area(c, t);
    assert_true(fabs(area[HZ_SURF_ROOF] - 80) < 1e-6);
    assert_true(fabs(area[HZ_SURF_GROUND] - 80) < 1e-6);
    assert_true(fabs(area[HZ_SURF_WALL] - 2 * (10 * 6 + 8 * 6)) < 1e-6);
    assert_string_equal(c->obj[0].attributes, "{\"osm_id\":42}");
    assert_true(fabs(c->extent[5] - 156.0) < 1e-9);
    assert_string_equal(c->note, "");
    hz_city_destroy(c);
}

/* Semantics say the "top" is a wall and a side is the roof: the split
 * follows the file, not the normals. */
static void test_semantics(void **state)
{
    (void)state;
    char buf[4096];
    hz_err err = {0};
    box_json(buf, sizeof buf, TRANSFORM, CRS32734, BOX_FACES,
             ",\"semantics\":{\"surfaces\":[{\"type\":\"GroundSurface\"},{\"type\":\"RoofSurface\"},"
             "{\"type\":\"WallSurface\"}],\"values\":[[0,2,1,2,null,2]]}");
    hz_city *c = hz_city_load_memory(buf, strlen(buf), "box", NULL, &err);
    assert_non_null(c);
    assert_true(c->semantics);
    double area[HZ_SURF_KINDS] = {0};
    for (uint32_t t = 0; t < c->tri_count; t++)
        area[c->tri_kind[t]] += tri_area(c, t);
    assert_true(fabs(area[HZ_SURF_ROOF] - 60) < 1e-6);   /* the south side, 10 x 6 */
    assert_true(fabs(area[HZ_SURF_GROUND] - 80) < 1e-6);
    assert_true(fabs(area[HZ_SURF_WALL] - (80 + 48 + 60 + 48)) < 1e-6); /* top, east, null north, west */
    hz_city_destroy(c);
}

static void refused(const char *json, const char *needle)
{
    hz_err err = {0};
    hz_city *c = hz_city_load_memory(json, strlen(json), "bad.city.json", NULL, &err);
    if (c)
        fail_msg("accepted; expected a message with \"%s\"", needle);
    if (!strstr(err.msg, needle))
        fail_msg("message \"%s\" lacks \"%s\"", err.msg, needle);
    assert_non_null(strstr(err.msg, "bad.city.json"));
}

static void test_refusals(void **state)
{
    (void)state;
    char buf[4096];
    /* A vertex index past the end, with the JSON path of the ring. */
    refused(box_json(buf, sizeof buf, TRANSFORM, CRS32734,
                     "[[[0,3,2,1]],[[4,5,6,7]],[[0,1,5,4]],[[1,2,6,5]],[[2,3,7,6]],[[3,0,4,8]]]", ""),
            "CityObjects.b1.geometry[0].boundaries[0][5]: ring 0, entry 3: vertex 8 out of range (8 vertices)");
    refused(box_json(buf, sizeof buf, TRANSFORM, CRS32734, "[[[0,3,-1,1]]]", ""), "out of range");
    refused(box_json(buf, sizeof buf, TRANSFORM, CRS32734, "[[[0,3,\"2\",1]]]", ""), "not an integer");
    refused(box_json(buf, sizeof buf, "", CRS32734, BOX_FACES, ""), "transform: missing");
    refused(box_json(buf, sizeof buf, "\"transform\":{\"scale\":[0,1,1],\"translate\":[0,0,0]},", CRS32734,
                     BOX_FACES, ""),
            "scale[0] = 0 must be > 0");
    /* Finite but absurd once dequantised: a scale of 1e30, or one vertex 2e9 m out. */
    refused(box_json(buf, sizeof buf, "\"transform\":{\"scale\":[1e30,1,1],\"translate\":[0,0,0]},", CRS32734,
                     BOX_FACES, ""),
            "vertices[1][0]: lies at 1e+33 after the transform, beyond 1e+09");
    refused(box_json(buf, sizeof buf, "\"transform\":{\"scale\":[1,1,1],\"translate\":[-1999999000,0,0]},",
                     CRS32734, BOX_FACES, ""),
            "vertices[0][0]: lies at -2e+09 after the transform");
    refused(box_json(buf, sizeof buf, TRANSFORM, "https://www.opengis.net/def/crs/EPSG/0/999999", BOX_FACES, ""),
            "unknown CRS EPSG:999999");
    refused(box_json(buf, sizeof buf, TRANSFORM, "my local grid", BOX_FACES, ""), "unknown CRS");
    refused(box_json(buf, sizeof buf, TRANSFORM, CRS32734, BOX_FACES,
                     ",\"semantics\":{\"surfaces\":[],\"values\":[[0,0,0,0,0,0]]}"),
            "semantics value out of range");
    refused("{\"type\":\"CityJSON\",", "line 1");
    refused("{\"type\":\"GeoJSON\"}", "not a CityJSON file");
    hz_err err = {0};
    assert_null(hz_city_load("/nonexistent/x.city.json", NULL, &err));
    assert_int_equal(err.code, HZ_ERR_IO);
}

/* GeometryInstance: a 1 m cube template (Solid, LoD 2) placed twice, at
 * reference points 50 m apart: scaled by 2 and shifted 1 m east, and turned
 * 90 degrees about z. Each object's triangles span the transformed cube. */
#define TEMPLATE_CITY(tmpl_index, matrix, ref, tverts)                                                           \
    "{\"type\":\"CityJSON\",\"version\":\"2.0\"," TRANSFORM "\"metadata\":{\"referenceSystem\":\"" CRS32734 "\"}," \
    "\"geometry-templates\":{\"templates\":[{\"type\":\"Solid\",\"lod\":\"2\",\"boundaries\":[[[[0,3,2,1]],"        \
    "[[4,5,6,7]],[[0,1,5,4]],[[1,2,6,5]],[[2,3,7,6]],[[3,0,4,7]]]]}],\"vertices-templates\":" tverts "},"          \
    "\"CityObjects\":{\"a\":{\"type\":\"Building\",\"geometry\":[{\"type\":\"GeometryInstance\",\"template\":"     \
    tmpl_index ",\"boundaries\":[" ref "],\"transformationMatrix\":" matrix "}]},"                                \
    "\"b\":{\"type\":\"Building\",\"geometry\":[{\"type\":\"GeometryInstance\",\"template\":0,"                   \
    "\"boundaries\":[1],\"transformationMatrix\":[0,-1,0,0, 1,0,0,0, 0,0,1,0, 0,0,0,1]}]}},"                      \
    "\"vertices\":[[0,0,0],[5000,0,0]]}"
#define UNIT_CUBE "[[0,0,0],[1,0,0],[1,1,0],[0,1,0],[0,0,1],[1,0,1],[1,1,1],[0,1,1]]"
#define SCALE2 "[2,0,0,1, 0,2,0,0, 0,0,2,0, 0,0,0,1]"

static void object_bounds(const hz_city *c, const hz_city_object *o, double lo[3], double hi[3])
{
    for (int k = 0; k < 3; k++)
        lo[k] = 1e300, hi[k] = -1e300;
    for (uint32_t t = o->first_tri; t < o->first_tri + o->tri_count; t++)
        for (int v = 0; v < 3; v++)
            for (int k = 0; k < 3; k++) {
                const double x = c->verts[3 * c->tris[3 * t + v] + k];
                lo[k] = fmin(lo[k], x);
                hi[k] = fmax(hi[k], x);
            }
}

static void test_geometry_instance(void **state)
{
    (void)state;
    const char *json = TEMPLATE_CITY("0", SCALE2, "0", UNIT_CUBE);
    hz_err err = {0};
    hz_city *c = hz_city_load_memory(json, strlen(json), "inst", NULL, &err);
    if (!c)
        fail_msg("%s", err.msg);
    assert_int_equal(c->instances, 2);
    assert_int_equal(c->buildings, 2);
    assert_int_equal(c->tri_count, 24);
    assert_int_equal(c->vert_count, 2 + 16);
    const hz_city_object *a = NULL, *b = NULL;
    for (uint32_t k = 0; k < c->obj_count; k++)
        if (!strcmp(c->obj[k].id, "a"))
            a = &c->obj[k];
        else if (!strcmp(c->obj[k].id, "b"))
            b = &c->obj[k];
    assert_true(a && b && a->tri_count == 12 && b->tri_count == 12);
    assert_true(fabs(a->lod - 2.0f) < 1e-6);
    double lo[3], hi[3];
    object_bounds(c, a, lo, hi); /* reference (265000, 6289000, 150); 2x, +1 m in x */
    const double wa[6] = {265001, 6289000, 150, 265003, 6289002, 152};
    for (int k = 0; k < 3; k++)
        assert_true(fabs(lo[k] - wa[k]) < 1e-6 && fabs(hi[k] - wa[3 + k]) < 1e-6);
    object_bounds(c, b, lo, hi); /* reference 50 m east; x' = -y, y' = x */
    const double wb[6] = {265049, 6289000, 150, 265050, 6289001, 151};
    for (int k = 0; k < 3; k++)
        assert_true(fabs(lo[k] - wb[k]) < 1e-6 && fabs(hi[k] - wb[3 + k]) < 1e-6);
    /* Roofs and walls by normal, turned with the template: 1 m^2 roof each (2 x 2 = 4 for a). */
    double roof = 0;
    for (uint32_t t = 0; t < c->tri_count; t++)
        if (c->tri_kind[t] == HZ_SURF_ROOF)
            roof += tri_area(c, t);
    assert_true(fabs(roof - 5.0) < 1e-9);
    hz_city_destroy(c);
    /* Refusals, with the path. */
    refused(TEMPLATE_CITY("3", SCALE2, "0", UNIT_CUBE), "CityObjects.a.geometry[0]: template: out of range (1 geometry templates)");
    refused(TEMPLATE_CITY("0", "[1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0]", "0", UNIT_CUBE), "transformationMatrix: missing or not 16 numbers");
    refused(TEMPLATE_CITY("0", SCALE2, "7", UNIT_CUBE), "boundaries: must be [the reference point's vertex index] (2 vertices)");
    refused(TEMPLATE_CITY("0", SCALE2, "0", "[[0,0,0],[1,0,0]]"),
            "geometry-templates.templates[0].boundaries[0][0]: ring 0, entry 1: vertex 3 out of range (2 vertices)");
    refused(TEMPLATE_CITY("0", SCALE2, "0", "[[0,0,\"x\"]]"), "geometry-templates.vertices-templates[0]: not three finite numbers");
    refused(TEMPLATE_CITY("0", "[1e300,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]", "0", UNIT_CUBE),
            "template vertex 1 lies at 1e+300 once transformed, beyond 1e+09");
}

/* Appearance materials: faces 0, 1 red, 2, 3, 5 blue, 4 none (theme
 * "paint", the file's default); the scene gets one mesh per material on
 * the building's node and its children, with the file's colours. A single
 * "value" paints every face; an index past the materials is refused. */
#define APPEARANCE "\"appearance\":{\"default-theme-material\":\"paint\",\"materials\":[" \
                   "{\"name\":\"red\",\"diffuseColor\":[1,0,0]},{\"name\":\"blue\",\"diffuseColor\":[0,0,1]}]},"

static float zero_ground(void *u, float x, float z)
{
    (void)u, (void)x, (void)z;
    return 0.0f;
}

static void test_materials(void **state)
{
    (void)state;
    char buf[4096];
    hz_err err = {0};
    box_json(buf, sizeof buf, TRANSFORM APPEARANCE, CRS32734, BOX_FACES,
             ",\"material\":{\"other\":{\"value\":0},\"paint\":{\"values\":[[0,0,1,1,null,1]]}}");
    hz_city *c = hz_city_load_memory(buf, strlen(buf), "box", NULL, &err);
    if (!c)
        fail_msg("%s", err.msg);
    assert_int_equal(c->material_count, 2);
    assert_string_equal(c->material_theme, "paint");
    assert_string_equal(c->materials[1].name, "blue");
    uint32_t per[3] = {0};
    for (uint32_t t = 0; t < c->tri_count; t++)
        per[c->tri_material[t] == HZ_CITY_NO_MATERIAL ? 2 : c->tri_material[t]]++;
    assert_int_equal(per[0], 4);
    assert_int_equal(per[1], 6);
    assert_int_equal(per[2], 2);
    /* Into a scene: red, blue and (the face without) the wall material. */
    hz_scene *s = hz_scene_create(NULL);
    hz_city_placed pl;
    hz_city_place p = {.origin = {c->extent[0], c->extent[4]}, .ground = zero_ground};
    assert_int_equal(hz_city_to_scene(c, s, &p, &pl, &err), HZ_OK);
    hz_scene_update(s);
    float seen[3] = {0};
    uint32_t meshes = 0;
    for (uint32_t id = 1; id <= hz_scene_node_count(s); id++) {
        if (hz_scene_node_mesh(s, id) == HZ_MESH_NONE)
            continue;
        meshes++;
        const uint32_t m = hz_scene_node_material(s, id);
        const hz_mesh_range *r = hz_scene_mesh(s, hz_scene_node_mesh(s, id));
        if (m == pl.first_material) {
            assert_true(hz_scene_material(s, m)->color[0] == 1.0f && hz_scene_material(s, m)->color[2] == 0.0f);
            seen[0] += (float)r->index_count / 3;
        } else if (m == pl.first_material + 1) {
            assert_true(hz_scene_material(s, m)->color[2] == 1.0f && hz_scene_material(s, m)->color[0] == 0.0f);
            seen[1] += (float)r->index_count / 3;
        } else {
            assert_int_equal(m, pl.materials[HZ_SURF_WALL]);
            seen[2] += (float)r->index_count / 3;
        }
    }
    assert_int_equal(meshes, 3);
    assert_true(seen[0] == 4 && seen[1] == 6 && seen[2] == 2);
    hz_scene_destroy(s);
    hz_city_destroy(c);
    /* Without a default theme the geometry's first ("other": value 0) paints every face red. */
    char buf2[4096];
    box_json(buf2, sizeof buf2,
             TRANSFORM "\"appearance\":{\"materials\":[{\"name\":\"red\",\"diffuseColor\":[1,0,0]}]},",
             CRS32734, BOX_FACES, ",\"material\":{\"other\":{\"value\":0},\"paint\":{\"values\":[[0,0,0,0,0,0]]}}");
    c = hz_city_load_memory(buf2, strlen(buf2), "box", NULL, &err);
    if (!c)
        fail_msg("%s", err.msg);
    for (uint32_t t = 0; t < c->tri_count; t++)
        assert_int_equal(c->tri_material[t], 0);
    assert_string_equal(c->material_theme, "other");
    hz_city_destroy(c);
    refused(box_json(buf, sizeof buf, TRANSFORM APPEARANCE, CRS32734, BOX_FACES,
                     ",\"material\":{\"paint\":{\"values\":[[0,0,2,1,null,1]]}}"),
            "CityObjects.b1.geometry[0].boundaries[0][2]: material value is not an index below 2");
    refused(box_json(buf, sizeof buf, TRANSFORM "\"appearance\":{\"materials\":[{\"diffuseColor\":[2,0,0]}]},",
                     CRS32734, BOX_FACES, ""),
            "appearance.materials[0]: diffuseColor: three numbers in [0, 1]");
    refused(box_json(buf, sizeof buf, TRANSFORM APPEARANCE, CRS32734, BOX_FACES, ",\"material\":{\"paint\":{}}"),
            "CityObjects.b1.geometry[0].material: a theme needs");
}

static double poly_area(const double *pts, const uint32_t *tris, int n)
{
    double a = 0;
    for (int t = 0; t < n; t++) {
        const double *p = pts + 3 * tris[3 * t], *q = pts + 3 * tris[3 * t + 1], *r = pts + 3 * tris[3 * t + 2];
        a += 0.5 * ((q[0] - p[0]) * (r[1] - p[1]) - (r[0] - p[0]) * (q[1] - p[1]));
    }
    return a;
}

static void test_triangulate(void **state)
{
    (void)state;
    /* An L (concave), counter-clockwise in x-y: area 3. */
    const double L[] = {0, 0, 5, 2, 0, 5, 2, 1, 5, 1, 1, 5, 1, 2, 5, 0, 2, 5};
    uint32_t rs[3] = {0, 6}, tris[64];
    int n = hz_polygon_triangulate(L, rs, 1, tris);
    assert_int_equal(n, 4);
    assert_true(fabs(poly_area(L, tris, n) - 3) < 1e-12); /* positive: winding kept */
    /* Clockwise input keeps its (clockwise) winding. */
    const double Lr[] = {0, 2, 5, 1, 2, 5, 1, 1, 5, 2, 1, 5, 2, 0, 5, 0, 0, 5};
    n = hz_polygon_triangulate(Lr, rs, 1, tris);
    assert_int_equal(n, 4);
    assert_true(fabs(poly_area(Lr, tris, n) + 3) < 1e-12);
    /* A 4 x 4 square with a 2 x 2 hole (hole given counter-clockwise too): 12. */
    const double H[] = {0, 0, 0, 4, 0, 0, 4, 4, 0, 0, 4, 0, 1, 1, 0, 3, 1, 0, 3, 3, 0, 1, 3, 0};
    uint32_t rh[3] = {0, 4, 8};
    n = hz_polygon_triangulate(H, rh, 2, tris);
    assert_int_equal(n, 8);
    assert_true(fabs(poly_area(H, tris, n) - 12) < 1e-12);
    /* No triangle covers the hole's centre. */
    for (int t = 0; t < n; t++) {
        double c[2] = {2, 2}, s = 0;
        for (int k = 0; k < 3; k++) {
            const double *p = H + 3 * tris[3 * t + k], *q = H + 3 * tris[3 * t + (k + 1) % 3];
            s += (q[0] - p[0]) * (c[1] - p[1]) - (c[0] - p[0]) * (q[1] - p[1]) > 0 ? 1 : -1;
        }
        assert_true(fabs(s) < 3);
    }
    /* A vertical wall (x-z plane) and a degenerate (collinear) ring. */
    const double W[] = {0, 0, 0, 3, 0, 0, 3, 0, 2, 0, 0, 2};
    uint32_t rw[2] = {0, 4};
    assert_int_equal(hz_polygon_triangulate(W, rw, 1, tris), 2);
    const double D[] = {0, 0, 0, 1, 0, 0, 2, 0, 0};
    uint32_t rd[2] = {0, 3};
    assert_int_equal(hz_polygon_triangulate(D, rd, 1, tris), 0);
}

#define MAMRE HZ_DATA_DIR "/city/mamre_lod1_epsg32734.city.json"

static float tin_ground(void *user, float x, float z)
{
    /* The TIN grid as a ground: nearest cell of the rasterised TIN. */
    const float *g = ((const float **)user)[0];
    const uint32_t *wh = ((const uint32_t **)user)[1];
    long i = lroundf(x / 5.0f), j = lroundf(z / 5.0f); /* sample (i, j) at (5 i, 5 j) */
    i = i < 0 ? 0 : i >= (long)wh[0] ? (long)wh[0] - 1 : i;
    j = j < 0 ? 0 : j >= (long)wh[1] ? (long)wh[1] - 1 : j;
    return g[(size_t)j * wh[0] + (size_t)i];
}

/* The real model: 2 344 LoD1 buildings, one TIN. Buildings placed on the
 * TIN stand on it: their base meets the ground the TIN gives under them. */
static void test_mamre(void **state)
{
    (void)state;
    hz_err err = {0};
    hz_city *c = hz_city_load(MAMRE, NULL, &err);
    if (!c)
        fail_msg("%s", err.msg);
    assert_int_equal(c->buildings, 2344);
    assert_int_equal(c->terrain_objects, 1);
    assert_string_equal(c->crs, "EPSG:32734");
    /* The file's vertices are absolute: translate is not applied again. */
    assert_non_null(strstr(c->note, "translate"));
    /* Inside metadata.geographicalExtent (263698.09 6287743.43 138.27 266820.59
     * 6290344.54 270.69, padded 250 m): the vertices' own extent. */
    assert_true(fabs(c->extent[0] - 263948.088) < 0.01 && fabs(c->extent[3] - 266570.587) < 0.01);
    assert_true(fabs(c->extent[1] - 6287993.433) < 0.01 && fabs(c->extent[4] - 6290094.540) < 0.01);
    assert_true(fabs(c->extent[2] - 145.120) < 0.01 && fabs(c->extent[5] - 252.570) < 0.01);
    /* osm_328118446: footprint of 5 corners -> walls 5 quads (10 triangles),
     * roof and floor pentagons (3 each). */
    const hz_city_object *o = NULL;
    for (uint32_t k = 0; k < c->obj_count; k++)
        if (!strcmp(c->obj[k].id, "osm_328118446"))
            o = &c->obj[k];
    assert_non_null(o);
    assert_int_equal(o->faces, 7);
    assert_int_equal(o->tri_count, 16);
    uint32_t kinds[HZ_SURF_KINDS] = {0};
    for (uint32_t t = o->first_tri; t < o->first_tri + o->tri_count; t++)
        kinds[c->tri_kind[t]]++;
    assert_int_equal(kinds[HZ_SURF_ROOF], 3);
    assert_int_equal(kinds[HZ_SURF_GROUND], 3);
    assert_non_null(strstr(o->attributes, "\"osm_id\":328118446"));

    float *g = NULL;
    uint32_t w, h;
    double gt[6];
    assert_int_equal(hz_city_tin_grid(c, 5.0, &g, &w, &h, gt, &err), HZ_OK);
    assert_true(w >= 500 && w <= 530 && h >= 400 && h <= 430); /* 2.6 x 2.1 km */
    uint32_t wh[2] = {w, h};
    const void *user[2] = {g, wh};
    hz_scene *s = hz_scene_create(NULL);
    hz_city_placed pl;
    /* Local = CRS - the grid's north-west sample centre, z south. */
    hz_city_place p = {.origin = {gt[0] + 2.5, gt[3] - 2.5}, .ground = tin_ground, .ground_user = (void *)user};
    assert_int_equal(hz_city_to_scene(c, s, &p, &pl, &err), HZ_OK);
    assert_int_equal(pl.buildings, 2344);
    hz_scene_update(s);
    /* Each building's box bottom is at the lowest TIN ground under it, at most
     * a few metres below its centre's ground (slopes), never above. */
    uint32_t n = hz_scene_find(s, "osm_328118446");
    assert_int_not_equal(n, HZ_NODE_NONE);
    hz_box b;
    hz_scene_subtree_bounds(s, n, &b);
    /* The TIN has holes at the footprints and shares their base vertices: a
     * building's base is the TIN's height at its corners, so clamping it on the
     * (5 m nearest-cell) TIN grid moves it little, and it stays 4.1 m tall. */
    printf("clamping: mean %.3f m, max %.3f m, %u clamped, %u without ground\n", pl.mean_shift, pl.max_shift,
           pl.clamped, pl.outside);
    assert_int_equal(pl.clamped + pl.outside, 2344);
    assert_true(pl.clamped > 2300);
    assert_true(fabsf(b.min[1] - 179.18f) < 0.5f);  /* its ground_height */
    assert_true(fabsf(b.max[1] - b.min[1] - 4.1f) < 0.01f); /* building_height 4.1 */
    assert_true(pl.mean_shift < 0.5 && pl.max_shift < 10);
    /* Corners stand on ground at or above the base: nothing floats. */
    for (int k = 0; k < 4; k++) {
        float gx = k & 1 ? b.max[0] : b.min[0], gz = k & 2 ? b.max[2] : b.min[2];
        float gk = tin_ground((void *)user, gx, gz);
        assert_true(isnan(gk) || gk >= b.min[1] - 0.5f);
    }
    free(g);
    hz_scene_destroy(s);
    hz_city_destroy(c);
}

/* Closed and outward: every directed edge of an object's triangles has its
 * reverse exactly once, and the divergence-theorem volume is positive. */
static double solid_volume(const hz_city *c, const hz_city_object *o)
{
    double vol = 0;
    for (uint32_t t = o->first_tri; t < o->first_tri + o->tri_count; t++) {
        const double *a = c->verts + 3 * c->tris[3 * t], *b = c->verts + 3 * c->tris[3 * t + 1],
                     *d = c->verts + 3 * c->tris[3 * t + 2];
        /* relative to the first vertex: keeps UTM coordinates exact */
        const double *o0 = c->verts + 3 * c->tris[3 * o->first_tri];
        double p[3] = {a[0] - o0[0], a[1] - o0[1], a[2] - o0[2]}, q[3] = {b[0] - o0[0], b[1] - o0[1], b[2] - o0[2]},
               r[3] = {d[0] - o0[0], d[1] - o0[1], d[2] - o0[2]};
        vol += (p[0] * (q[1] * r[2] - q[2] * r[1]) - p[1] * (q[0] * r[2] - q[2] * r[0]) +
                p[2] * (q[0] * r[1] - q[1] * r[0])) / 6.0;
        for (int k = 0; k < 3; k++) {
            uint32_t u = c->tris[3 * t + (uint32_t)k], v = c->tris[3 * t + (uint32_t)(k + 1) % 3];
            int fwd = 0, rev = 0;
            for (uint32_t s2 = o->first_tri; s2 < o->first_tri + o->tri_count; s2++)
                for (int m = 0; m < 3; m++) {
                    uint32_t x = c->tris[3 * s2 + (uint32_t)m], y = c->tris[3 * s2 + (uint32_t)(m + 1) % 3];
                    fwd += x == u && y == v;
                    rev += x == v && y == u;
                }
            if (fwd != 1 || rev != 1)
                fail_msg("%s: edge %u-%u used %d times forward, %d reversed", o->id, u, v, fwd, rev);
        }
    }
    return vol;
}

/* Writes geojson to HZ_TEST_TMP/name and checks that the footprint loader
 * refuses it with a message holding needle. */
static void footprints_refused(const char *name, const char *geojson, const char *needle)
{
    char path[512];
    snprintf(path, sizeof path, "%s/%s", HZ_TEST_TMP, name);
    FILE *fp = fopen(path, "w");
    assert_non_null(fp);
    fputs(geojson, fp);
    fclose(fp);
    hz_err err = {0};
    assert_null(hz_city_load_footprints(path, NULL, &err));
    print_message("%s: %s\n", name, err.msg);
    if (!strstr(err.msg, needle))
        fail_msg("message \"%s\" lacks \"%s\"", err.msg, needle);
}

static void test_footprints(void **state)
{
    (void)state;
    FILE *fp = fopen(HZ_TEST_TMP "/fp.geojson", "w");
    assert_non_null(fp);
    /* A 20 x 10 m block with a 4 x 4 m courtyard, 12 m high; an L of 3 x 2 units
     * of 10 m (area 400 m2) with 4 levels (12 m); a point (skipped). Rings are
     * given clockwise on purpose: the extrusion orients them itself. */
    fputs("{\"type\":\"FeatureCollection\",\"crs\":{\"type\":\"name\",\"properties\":{\"name\":"
          "\"urn:ogc:def:crs:EPSG::32633\"}},\"features\":["
          "{\"type\":\"Feature\",\"properties\":{\"osm_id\":11,\"height\":12},\"geometry\":{\"type\":\"Polygon\","
          "\"coordinates\":[[[500000,4000000],[500000,4000010],[500020,4000010],[500020,4000000],[500000,4000000]],"
          "[[500008,4000003],[500012,4000003],[500012,4000007],[500008,4000007],[500008,4000003]]]}},"
          "{\"type\":\"Feature\",\"properties\":{\"osm_id\":12,\"building:levels\":\"4\"},\"geometry\":{"
          "\"type\":\"MultiPolygon\",\"coordinates\":[[[[500100,4000000],[500100,4000020],[500110,4000020],"
          "[500110,4000010],[500130,4000010],[500130,4000000],[500100,4000000]]]]}},"
          "{\"type\":\"Feature\",\"properties\":{},\"geometry\":{\"type\":\"Point\",\"coordinates\":[500000,4000000]}}"
          "]}", fp);
    fclose(fp);
    hz_err err = {0};
    hz_city *c = hz_city_load_footprints(HZ_TEST_TMP "/fp.geojson", NULL, &err);
    if (!c)
        fail_msg("%s", err.msg);
    assert_string_equal(c->crs, "EPSG:32633");
    assert_int_equal(c->buildings, 2);
    assert_int_equal(c->obj_count, 2);
    assert_string_equal(c->obj[0].id, "11");
    assert_non_null(strstr(c->obj[1].attributes, "\"building:levels\":\"4\""));
    double v0 = solid_volume(c, &c->obj[0]), v1 = solid_volume(c, &c->obj[1]);
    assert_true(fabs(v0 - (200 - 16) * 12) < 1e-6);
    assert_true(fabs(v1 - 400 * 12) < 1e-6);
    assert_true(fabs(c->extent[5] - 12) < 1e-9 && fabs(c->extent[2]) < 1e-9);
    hz_city_destroy(c);
    /* lon/lat (GeoJSON's default CRS): projected to the UTM zone, in metres. */
    fp = fopen(HZ_TEST_TMP "/fp_ll.geojson", "w");
    fputs("{\"type\":\"FeatureCollection\",\"features\":[{\"type\":\"Feature\",\"properties\":{\"height\":5},"
          "\"geometry\":{\"type\":\"Polygon\",\"coordinates\":[[[8.69,49.41],[8.6903,49.41],[8.6903,49.4102],"
          "[8.69,49.4102],[8.69,49.41]]]}}]}", fp);
    fclose(fp);
    c = hz_city_load_footprints(HZ_TEST_TMP "/fp_ll.geojson", NULL, &err);
    if (!c)
        fail_msg("%s", err.msg);
    assert_string_equal(c->crs, "EPSG:32632");
    double w = c->extent[3] - c->extent[0], d = c->extent[4] - c->extent[1];
    assert_true(w > 20 && w < 24 && d > 21 && d < 24); /* 0.0003 deg lon = 21.8 m, 0.0002 lat = 22.2 m */
    assert_true(solid_volume(c, &c->obj[0]) > 0);
    hz_city_destroy(c);
    /* Refusals: not a vector file, no polygon. */
    assert_null(hz_city_load_footprints(MAMRE "x", NULL, &err));
    assert_non_null(strstr(err.msg, "not a vector file"));
    footprints_refused("fp_pt.geojson",
                       "{\"type\":\"FeatureCollection\",\"features\":[{\"type\":\"Feature\",\"properties\":{},"
                       "\"geometry\":{\"type\":\"Point\",\"coordinates\":[8.69,49.41]}}]}",
                       "no polygon");
    /* lon/lat off the Earth: refused by name, not placed in a made-up UTM zone. */
    footprints_refused("fp_off.geojson",
                       "{\"type\":\"FeatureCollection\",\"features\":[{\"type\":\"Feature\",\"properties\":{},"
                       "\"geometry\":{\"type\":\"Polygon\",\"coordinates\":[[[8.69,149.41],[8.6903,149.41],"
                       "[8.6903,149.4102],[8.69,149.41]]]}}]}",
                       "not on the Earth");
    /* A projected vertex at 1e30 m: refused with the building, not extruded
     * into a box that the camera then frames from 1e30 m away. */
    footprints_refused("fp_far.geojson",
                       "{\"type\":\"FeatureCollection\",\"crs\":{\"type\":\"name\",\"properties\":{\"name\":"
                       "\"urn:ogc:def:crs:EPSG::32633\"}},\"features\":[{\"type\":\"Feature\",\"properties\":"
                       "{\"osm_id\":13},\"geometry\":{\"type\":\"Polygon\",\"coordinates\":[[[500000,4000000],"
                       "[1e30,4000000],[500000,4000100],[500000,4000000]]]}}]}",
                       "building 13 has a vertex at (1e+30, 4e+06), beyond 1e+09");
    /* The UTM zone of a point: 0 for what is no position on the Earth. */
    assert_int_equal(hz_georef_utm_epsg(8.69, 49.41), 32632);
    assert_int_equal(hz_georef_utm_epsg(-70.5, -33.4), 32719);
    assert_int_equal(hz_georef_utm_epsg(180.0, 0.0), 32601);
    assert_int_equal(hz_georef_utm_epsg(NAN, 10.0), 0);
    assert_int_equal(hz_georef_utm_epsg(-INFINITY, 10.0), 0);
    assert_int_equal(hz_georef_utm_epsg(10.0, 91.0), 0);
    assert_int_equal(hz_georef_utm_epsg(10.0, NAN), 0);
}

/* Where footprint heights come from: an OSM file's tags (GDAL's OSM driver
 * keeps height and building:levels in other_tags), Overture's num_floors,
 * a field in capitals, a field named by the caller; a named field that is
 * not there is refused with the layer's fields. The counts say which
 * source each building took. */
static double object_top(const hz_city *c, const char *id)
{
    for (uint32_t k = 0; k < c->obj_count; k++)
        if (!strcmp(c->obj[k].id, id)) {
            double lo[3], hi[3];
            object_bounds(c, &c->obj[k], lo, hi);
            return hi[2] - lo[2];
        }
    fail_msg("no object %s", id);
    return NAN;
}

static void test_footprint_heights(void **state)
{
    (void)state;
    FILE *fp = fopen(HZ_TEST_TMP "/fp.osm", "w");
    assert_non_null(fp);
    fputs("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<osm version=\"0.6\" generator=\"test\">\n"
          " <node id=\"1\" lat=\"49.4100\" lon=\"8.6940\"/><node id=\"2\" lat=\"49.4100\" lon=\"8.6950\"/>\n"
          " <node id=\"3\" lat=\"49.4106\" lon=\"8.6950\"/><node id=\"4\" lat=\"49.4106\" lon=\"8.6940\"/>\n"
          " <node id=\"5\" lat=\"49.4110\" lon=\"8.6960\"/><node id=\"6\" lat=\"49.4110\" lon=\"8.6966\"/>\n"
          " <node id=\"7\" lat=\"49.4114\" lon=\"8.6966\"/><node id=\"8\" lat=\"49.4120\" lon=\"8.6970\"/>\n"
          " <node id=\"9\" lat=\"49.4120\" lon=\"8.6975\"/><node id=\"10\" lat=\"49.4124\" lon=\"8.6975\"/>\n"
          " <way id=\"20\"><nd ref=\"1\"/><nd ref=\"2\"/><nd ref=\"3\"/><nd ref=\"4\"/><nd ref=\"1\"/>"
          "<tag k=\"building\" v=\"yes\"/><tag k=\"note\" v=\"a &quot;height&quot;=&gt;&quot;99\"/>"
          "<tag k=\"building:levels\" v=\"5\"/></way>\n"
          " <way id=\"21\"><nd ref=\"5\"/><nd ref=\"6\"/><nd ref=\"7\"/><nd ref=\"5\"/>"
          "<tag k=\"building\" v=\"house\"/><tag k=\"height\" v=\"12.5\"/><tag k=\"roof:height\" v=\"3\"/></way>\n"
          " <way id=\"22\"><nd ref=\"8\"/><nd ref=\"9\"/><nd ref=\"10\"/><nd ref=\"8\"/>"
          "<tag k=\"building\" v=\"shed\"/></way>\n"
          " <way id=\"23\"><nd ref=\"1\"/><nd ref=\"5\"/><tag k=\"highway\" v=\"residential\"/></way>\n</osm>\n",
          fp);
    fclose(fp);
    hz_err err = {0};
    hz_city *c = hz_city_load_footprints(HZ_TEST_TMP "/fp.osm", NULL, &err);
    if (!c)
        fail_msg("%s", err.msg);
    assert_int_equal(c->buildings, 3);
    assert_int_equal(c->height_from_field, 1);
    assert_int_equal(c->height_from_levels, 1);
    assert_int_equal(c->height_default, 1);
    assert_string_equal(c->height_field, "height");
    assert_string_equal(c->levels_field, "building:levels");
    double tops[3] = {0};
    for (uint32_t k = 0; k < c->obj_count; k++) {
        double lo[3], hi[3];
        object_bounds(c, &c->obj[k], lo, hi);
        tops[k] = hi[2] - lo[2];
    }
    /* (the OSM driver may order the ways as it likes) */
    double want[3] = {15, 12.5, 10};
    for (int w = 0; w < 3; w++) {
        bool found = false;
        for (int k = 0; k < 3; k++)
            found = found || fabs(tops[k] - want[w]) < 1e-6;
        if (!found)
            fail_msg("no building %g m high (%g, %g, %g)", want[w], tops[0], tops[1], tops[2]);
    }
    hz_city_destroy(c);

    /* Overture's num_floors, a height field in capitals, and a field named by the caller. */
    fp = fopen(HZ_TEST_TMP "/fp_fields.geojson", "w");
    fputs("{\"type\":\"FeatureCollection\",\"crs\":{\"type\":\"name\",\"properties\":{\"name\":"
          "\"urn:ogc:def:crs:EPSG::32633\"}},\"features\":["
          "{\"type\":\"Feature\",\"properties\":{\"id\":\"a\",\"num_floors\":6,\"hoehe\":7},\"geometry\":{\"type\":"
          "\"Polygon\",\"coordinates\":[[[500000,4000000],[500010,4000000],[500010,4000010],[500000,4000000]]]}},"
          "{\"type\":\"Feature\",\"properties\":{\"id\":\"b\",\"HEIGHT\":21,\"hoehe\":9},\"geometry\":{\"type\":"
          "\"Polygon\",\"coordinates\":[[[500100,4000000],[500110,4000000],[500110,4000010],[500100,4000000]]]}}]}",
          fp);
    fclose(fp);
    c = hz_city_load_footprints(HZ_TEST_TMP "/fp_fields.geojson", NULL, &err);
    if (!c)
        fail_msg("%s", err.msg);
    assert_true(fabs(object_top(c, "a") - 18) < 1e-6);
    assert_true(fabs(object_top(c, "b") - 21) < 1e-6);
    assert_int_equal(c->height_from_levels, 1);
    assert_string_equal(c->levels_field, "num_floors");
    hz_city_destroy(c);
    const hz_footprint_desc named = {.height_field = "hoehe"};
    c = hz_city_load_footprints(HZ_TEST_TMP "/fp_fields.geojson", &named, &err);
    if (!c)
        fail_msg("%s", err.msg);
    assert_true(fabs(object_top(c, "a") - 7) < 1e-6);
    assert_true(fabs(object_top(c, "b") - 9) < 1e-6);
    assert_int_equal(c->height_from_field, 2);
    hz_city_destroy(c);
    const hz_footprint_desc typo = {.height_field = "hoeh"};
    assert_null(hz_city_load_footprints(HZ_TEST_TMP "/fp_fields.geojson", &typo, &err));
    assert_non_null(strstr(err.msg, "has no field 'hoeh' (its fields: "));
    assert_non_null(strstr(err.msg, "hoehe"));
    assert_non_null(strstr(err.msg, "num_floors"));
}

/* CityJSON Text Sequences (CityJSONL): a header line, then one
 * CityJSONFeature per line whose boundaries and reference points index its
 * own vertices (quantised by the header's transform). The same two boxes
 * as one file and as a sequence give the same triangles; a GeometryInstance
 * in a feature stands on the feature's vertex. Errors name the line. */
#define SEQ_HEADER                                                                                                 \
    "{\"type\":\"CityJSON\",\"version\":\"2.0\"," TRANSFORM "\"metadata\":{\"referenceSystem\":\"" CRS32734 "\"}," \
    "\"geometry-templates\":{\"templates\":[{\"type\":\"Solid\",\"lod\":\"2\",\"boundaries\":[" BOX_FACES "]}],"  \
    "\"vertices-templates\":" UNIT_CUBE "},\"CityObjects\":{},\"vertices\":[]}"
#define SEQ_BOX(id, verts)                                                                                          \
    "{\"type\":\"CityJSONFeature\",\"id\":\"" id "\",\"CityObjects\":{\"" id "\":{\"type\":\"Building\","          \
    "\"attributes\":{\"osm_id\":7},\"geometry\":[{\"type\":\"Solid\",\"lod\":\"1\",\"boundaries\":[" BOX_FACES     \
    "]}]}},\"vertices\":" verts "}"
#define BOX_VERTS_EAST                                                                                              \
    "[[5000,0,0],[6000,0,0],[6000,800,0],[5000,800,0],[5000,0,600],[6000,0,600],[6000,800,600],[5000,800,600]]"

static void test_sequence(void **state)
{
    (void)state;
    const char *seq = SEQ_HEADER "\n" SEQ_BOX("b1", BOX_VERTS) "\r\n\n" SEQ_BOX("b2", BOX_VERTS_EAST) "\n"
                                 "{\"type\":\"CityJSONFeature\",\"id\":\"t\",\"CityObjects\":{\"t\":{\"type\":"
                                 "\"Building\",\"geometry\":[{\"type\":\"GeometryInstance\",\"template\":0,"
                                 "\"boundaries\":[1],\"transformationMatrix\":" SCALE2 "}]}},"
                                 "\"vertices\":[[100,100,100],[20000,0,0]]}\n";
    hz_err err = {0};
    hz_city *c = hz_city_load_memory(seq, strlen(seq), "seq.city.jsonl", NULL, &err);
    if (!c)
        fail_msg("%s", err.msg);
    assert_int_equal(c->features, 3);
    assert_int_equal(c->buildings, 3);
    assert_int_equal(c->instances, 1);
    assert_int_equal(c->tri_count, 36);
    assert_int_equal(c->vert_count, 8 + 8 + 2 + 8);
    assert_string_equal(c->crs, "EPSG:32734");
    /* The same two boxes in one file: the same triangles, corner for corner. */
    char one[8192];
    snprintf(one, sizeof one,
             "{\"type\":\"CityJSON\",\"version\":\"2.0\"," TRANSFORM "\"metadata\":{\"referenceSystem\":\"" CRS32734
             "\"},\"CityObjects\":{\"b1\":{\"type\":\"Building\",\"geometry\":[{\"type\":\"Solid\",\"lod\":\"1\","
             "\"boundaries\":[" BOX_FACES "]}]},\"b2\":{\"type\":\"Building\",\"geometry\":[{\"type\":\"Solid\","
             "\"lod\":\"1\",\"boundaries\":[%s]}]}},\"vertices\":[%.*s,%.*s]}",
             "[[[8,11,10,9]],[[12,13,14,15]],[[8,9,13,12]],[[9,10,14,13]],[[10,11,15,14]],[[11,8,12,15]]]",
             (int)strlen(BOX_VERTS) - 2, BOX_VERTS + 1, (int)strlen(BOX_VERTS_EAST) - 2, BOX_VERTS_EAST + 1);
    hz_city *f = hz_city_load_memory(one, strlen(one), "one", NULL, &err);
    if (!f)
        fail_msg("%s", err.msg);
    assert_int_equal(f->features, 0);
    assert_int_equal(f->tri_count, 24);
    for (uint32_t t = 0; t < 3 * f->tri_count; t++)
        for (int k = 0; k < 3; k++)
            assert_true(fabs(c->verts[3 * c->tris[t] + k] - f->verts[3 * f->tris[t] + k]) < 1e-9);
    hz_city_destroy(f);
    /* The instance: 2x the unit cube, +1 m in x, on the feature's vertex 1 (200 m east). */
    const hz_city_object *o = &c->obj[2];
    assert_string_equal(o->id, "t");
    double lo[3], hi[3];
    object_bounds(c, o, lo, hi);
    const double want[6] = {265201, 6289000, 150, 265203, 6289002, 152};
    for (int k = 0; k < 3; k++)
        assert_true(fabs(lo[k] - want[k]) < 1e-6 && fabs(hi[k] - want[3 + k]) < 1e-6);
    assert_string_equal(c->obj[1].attributes, "{\"osm_id\":7}");
    hz_city_destroy(c);

    /* Errors, by line. */
    refused(SEQ_HEADER "\n" SEQ_BOX("b1", BOX_VERTS) "\n{\"type\":\"CityJSONFeature\",\n",
            "bad.city.json: line 3: column");
    refused(SEQ_HEADER "\n" SEQ_BOX("b1", "[[0,0,0],[1,0,0]]"),
            "line 2: CityObjects.b1.geometry[0].boundaries[0][0]: ring 0, entry 1: vertex 3 out of range (2 vertices)");
    refused(SEQ_HEADER "\n{\"type\":\"CityJSON\",\"CityObjects\":{},\"vertices\":[]}",
            "line 2: not a CityJSONFeature");
    refused(SEQ_HEADER "\n{\"type\":\"CityJSONFeature\",\"appearance\":{},\"CityObjects\":{},\"vertices\":[]}",
            "line 2: appearance: materials of a feature's own are not supported");
    refused(SEQ_HEADER "\n{\"type\":\"CityJSONFeature\",\"CityObjects\":{}}", "line 2: vertices: missing");
    /* A first line that is not a CityJSON header: the plain JSON error. */
    refused("{\"type\":\"Feature\"}\n{}", "line 2, column");
    /* A header alone draws nothing. */
    refused(SEQ_HEADER "\n", "no surface to draw");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_box_solid),  cmocka_unit_test(test_semantics), cmocka_unit_test(test_refusals),
        cmocka_unit_test(test_geometry_instance), cmocka_unit_test(test_sequence), cmocka_unit_test(test_materials),
        cmocka_unit_test(test_triangulate), cmocka_unit_test(test_mamre),  cmocka_unit_test(test_footprints), cmocka_unit_test(test_footprint_heights),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
