/* Scene files: a scene with every kind of placement builds the expected
 * tree (positions, inherited rotation and scale, ground clamping, CRS and
 * lon/lat through PROJ, an OBJ model through assimp, attributes); every
 * malformed example is refused with the file, the JSON path and the reason. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "horizon/scene_file.h"

static float slope(void *user, float x, float z)
{
    (void)user;
    return 100.0f + 0.1f * x + 0.05f * z; /* a plane rising east and south */
}

static hz_scene_file *open_str(const char *json, hz_err *err)
{
    return hz_scene_file_open_memory(json, strlen(json), "t.scene.json", HZ_TEST_TMP, NULL, err);
}

static void near3(const float *a, double x, double y, double z, double eps)
{
    if (!(fabs(a[0] - x) < eps && fabs(a[1] - y) < eps && fabs(a[2] - z) < eps))
        fail_msg("(%g %g %g) != (%g %g %g)", (double)a[0], (double)a[1], (double)a[2], x, y, z);
}

static void test_build(void **state)
{
    (void)state;
    FILE *fp = fopen(HZ_TEST_TMP "/tetra.obj", "w");
    assert_non_null(fp);
    fputs("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n", fp);
    fclose(fp);
    const char *json =
        "{\"horizon_scene\": 1,"
        " \"lights\": {\"sun\": [200, 35]},"
        " \"materials\": {\"brick\": {\"color\": [0.6, 0.3, 0.2]}, \"glass\": {\"color\": [0.3, 0.5, 0.6]}},"
        " \"models\": {\"house\": {\"box\": [10, 6, 8], \"material\": \"brick\"}, \"tetra\": {\"file\": \"tetra.obj\"}},"
        " \"nodes\": ["
        "  {\"name\": \"block\", \"position\": [100, 0, 200], \"yaw\": 90, \"children\": ["
        "    {\"name\": \"h1\", \"model\": \"house\", \"position\": [0, 0, -20], \"clamp\": \"ground\","
        "     \"attributes\": {\"osm_id\": 5}},"
        "    {\"name\": \"h2\", \"model\": \"house\", \"material\": \"glass\", \"position\": [0, 3, 0], \"scale\": 2}]},"
        "  {\"name\": \"t\", \"model\": \"tetra\", \"position\": [0, 50, 0], \"axis\": [0, 0, 1], \"angle\": 90,"
        "   \"scale\": [1, 2, 3]}"
        " ]}";
    hz_err err = {0};
    hz_scene_file_info info;
    hz_scene_file *f = hz_scene_file_open_memory(json, strlen(json), "t.scene.json", HZ_TEST_TMP, &info, &err);
    if (!f)
        fail_msg("%s", err.msg);
    assert_int_equal(info.nodes, 4);
    assert_int_equal(info.models, 2);
    assert_int_equal(info.materials, 3); /* default, brick, glass */
    assert_true(info.has_sun && info.sun[0] == 200 && info.sun[1] == 35);
    hz_scene *s = hz_scene_create(NULL);
    hz_scene_file_stats st;
    hz_scene_file_place p = {.ground = slope};
    assert_int_equal(hz_scene_file_build(f, s, &p, &st, &err), HZ_OK);
    assert_int_equal(st.nodes, 4);
    assert_int_equal(st.objects, 3);
    assert_int_equal(st.meshes, 2); /* the house once, instanced */
    assert_int_equal(st.clamped, 1);
    mat4 m;
    /* h1: yaw 90 turns the block's -z (north) to +x: (0, 0, -20) -> (120, y, 200). */
    uint32_t h1 = hz_scene_find(s, "h1");
    hz_scene_world_matrix(s, h1, m);
    /* Its 8 x 10 footprint turned: x 116..124, z 195..205; the lowest ground
     * is at its north-west corner: 100 + 11.6 + 9.75. */
    near3(m[3], 120, 100 + 0.1 * 116 + 0.05 * 195, 200, 1e-3);
    assert_string_equal(hz_scene_attributes(s, h1), "{\"osm_id\":5}");
    hz_box b;
    hz_scene_node_bounds(s, h1, &b);
    near3(b.min, 116, 100 + 11.6 + 9.75, 195, 1e-3); /* 8 wide along x after the turn */
    near3(b.max, 124, 100 + 11.6 + 9.75 + 6, 205, 1e-3);
    /* h2: scaled 2, 3 m up, not clamped; the glass material, the house mesh. */
    uint32_t h2 = hz_scene_find(s, "h2");
    hz_scene_node_bounds(s, h2, &b);
    near3(b.min, 92, 3, 190, 1e-3);
    near3(b.max, 108, 15, 210, 1e-3);
    assert_int_equal(hz_scene_node_mesh(s, h1), hz_scene_node_mesh(s, h2));
    assert_int_not_equal(hz_scene_node_material(s, h1), hz_scene_node_material(s, h2));
    assert_string_equal(hz_scene_material(s, hz_scene_node_material(s, h2))->name, "glass");
    /* The tetrahedron through assimp: axis z 90 degrees turns x into y. */
    uint32_t t = hz_scene_find(s, "t");
    hz_scene_node_bounds(s, t, &b);
    near3(b.min, -2, 50, 0, 1e-4);
    near3(b.max, 0, 51, 3, 1e-4);
    hz_scene_destroy(s);
    hz_scene_file_destroy(f);
}

static void test_georef(void **state)
{
    (void)state;
    hz_err err = {0};
    const double gt[6] = {500000, 10, 0, 4000000, 0, -10};
    hz_georef *g = hz_georef_create("EPSG:32633", gt, 1001, 1001, &err);
    assert_non_null(g);
    double lon, lat;
    assert_int_equal(hz_georef_local_to_lonlat(g, 3000, 4000, &lon, &lat, &err), HZ_OK);
    char json[512];
    snprintf(json, sizeof json,
             "{\"nodes\": [{\"name\": \"a\", \"crs\": [503005, 3995995, 12]},"
             " {\"name\": \"b\", \"lonlat\": [%.10f, %.10f, 7]}]}", lon, lat);
    hz_scene_file *f = open_str(json, &err);
    assert_non_null(f);
    hz_scene *s = hz_scene_create(NULL);
    hz_scene_file_place p = {.georef = g};
    assert_int_equal(hz_scene_file_build(f, s, &p, NULL, &err), HZ_OK);
    float t[3];
    hz_scene_query_translation(s, hz_scene_find(s, "a"), t);
    near3(t, 3000, 12, 4000, 1e-3); /* pixel corner 500000 + 5 m = sample 0 centre */
    hz_scene_query_translation(s, hz_scene_find(s, "b"), t);
    near3(t, 3000, 7, 4000, 1e-2);
    hz_scene_destroy(s);
    /* Without a georeference the same file is refused at build time. */
    s = hz_scene_create(NULL);
    assert_int_not_equal(hz_scene_file_build(f, s, &(hz_scene_file_place){0}, NULL, &err), HZ_OK);
    assert_non_null(strstr(err.msg, "nodes[0].crs: needs a terrain with a georeference"));
    hz_scene_destroy(s);
    hz_scene_file_destroy(f);
    hz_georef_destroy(g);
}

static void refused(const char *json, const char *needle)
{
    hz_err err = {0};
    hz_scene_file *f = open_str(json, &err);
    if (f) {
        hz_scene_file_destroy(f);
        fail_msg("accepted %s", json);
    }
    if (!strstr(err.msg, needle))
        fail_msg("message \"%s\" lacks \"%s\"", err.msg, needle);
    assert_non_null(strstr(err.msg, "t.scene.json"));
}

static void test_malformed(void **state)
{
    (void)state;
    refused("{\"nodes\": [", "line 1");
    refused("[1, 2]", "a scene is a JSON object");
    refused("{}", "nodes: missing");
    refused("{\"nodes\": [], \"colour\": 1}", "unknown member \"colour\"");
    refused("{\"nodes\": [{\"model\": \"house\"}]}", "nodes[0].model: unknown model \"house\"");
    refused("{\"models\": {\"m\": {\"box\": [1, 1, 1]}}, \"nodes\": [{\"children\": [{\"model\": \"m\", "
            "\"material\": \"gold\"}]}]}",
            "nodes[0].children[0].material: unknown material \"gold\"");
    refused("{\"nodes\": [{\"position\": [1, \"2\", 3]}]}", "nodes[0].position[1]: must be a number");
    refused("{\"nodes\": [{\"position\": [1, 2]}]}", "nodes[0].position: must be an array of 3 numbers");
    refused("{\"nodes\": [{\"scale\": -1}]}", "nodes[0].scale: must be in");
    refused("{\"nodes\": [{\"scale\": [1, 0, 1]}]}", "nodes[0].scale[1]: must be in");
    refused("{\"nodes\": [{\"yaw\": 1e300}]}", "nodes[0].yaw: must be in");
    refused("{\"nodes\": [{\"axis\": [0, 0, 0], \"angle\": 3}]}", "nodes[0].axis: must not be zero");
    refused("{\"nodes\": [{\"axis\": [0, 1, 0]}]}", "\"axis\" needs \"angle\"");
    refused("{\"nodes\": [{\"axis\": [0, 1, 0], \"angle\": 3, \"yaw\": 2}]}", "either yaw/pitch/roll or axis/angle");
    refused("{\"nodes\": [{\"position\": [0, 0, 0], \"crs\": [1, 2, 3]}]}", "one of \"position\", \"crs\"");
    refused("{\"nodes\": [{\"children\": [{\"lonlat\": [10, 50, 0]}]}]}", "nodes[0].children[0]: \"crs\" and \"lonlat\"");
    refused("{\"nodes\": [{\"lonlat\": [200, 50, 0]}]}", "nodes[0].lonlat: longitude in [-180, 180]");
    refused("{\"nodes\": [{\"clamp\": \"sky\"}]}", "nodes[0].clamp: must be \"ground\" or \"none\"");
    refused("{\"nodes\": [{\"children\": 3}]}", "nodes[0].children: must be an array");
    refused("{\"nodes\": [{\"attributes\": [1]}]}", "nodes[0].attributes: must be an object");
    refused("{\"nodes\": [{\"name\": 7}]}", "nodes[0].name: must be a string");
    refused("{\"nodes\": [{\"name\": \"a\", \"name\": \"b\"}]}", "duplicate");
    refused("{\"models\": {\"m\": {\"file\": \"missing.glb\"}}, \"nodes\": []}", "models.m: cannot read model");
    /* A PLY whose second face points past its 3 vertices (assimp's PLY
     * reader passes it on): refused, not read out of bounds. */
    FILE *ply = fopen(HZ_TEST_TMP "/bad_index.ply", "w");
    assert_non_null(ply);
    fputs("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
          "element face 2\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"
          "3 0 1 7\n", ply);
    fclose(ply);
    refused("{\"models\": {\"m\": {\"file\": \"bad_index.ply\"}}, \"nodes\": []}", "out of range");
    /* Models whose vertices are NaN or lie beyond 1e8 m (as node positions
     * may not): refused, not placed with a box that culls them away. */
    const char *far_obj[][2] = {{"nan_vertex.obj", "v 0 0 0\nv nan 0 0\nv 0 10 0\nf 1 2 3\n"},
                                {"far_vertex.obj", "v 0 0 0\nv 10 0 0\nv 0 1.01e8 0\nf 1 2 3\n"}};
    for (int k = 0; k < 2; k++) {
        char path[512], json[256];
        snprintf(path, sizeof path, "%s/%s", HZ_TEST_TMP, far_obj[k][0]);
        FILE *fo = fopen(path, "w");
        assert_non_null(fo);
        fputs(far_obj[k][1], fo);
        fclose(fo);
        snprintf(json, sizeof json, "{\"models\": {\"m\": {\"file\": \"%s\"}}, \"nodes\": []}", far_obj[k][0]);
        refused(json, "is not finite or lies beyond 1e+08 m");
    }
    refused("{\"models\": {\"m\": {\"box\": [1, 1, 1], \"file\": \"x.obj\"}}, \"nodes\": []}", "exactly one of");
    refused("{\"models\": {\"m\": {\"box\": [1, -1, 1]}}, \"nodes\": []}", "models.m.box[1]: must be in");
    refused("{\"materials\": {\"m\": {\"color\": [2, 0, 0]}}, \"nodes\": []}", "materials.m.color[0]: must be in [0, 1]");
    refused("{\"terrain\": {\"dem\": \"a.tif\", \"generate\": \"perlin\"}, \"nodes\": []}", "terrain: needs exactly one");
    refused("{\"terrain\": {\"generate\": \"fractal\"}, \"nodes\": []}", "terrain: generate: must be");
    refused("{\"lights\": {\"sun\": [10, 95]}, \"nodes\": []}", "lights.sun: elevation must be in [-90, 90]");
    /* Clamping without a terrain is refused at build time. */
    hz_err err = {0};
    hz_scene_file *f = open_str("{\"nodes\": [{\"clamp\": \"ground\"}]}", &err);
    assert_non_null(f);
    hz_scene *s = hz_scene_create(NULL);
    assert_int_not_equal(hz_scene_file_build(f, s, NULL, NULL, &err), HZ_OK);
    assert_non_null(strstr(err.msg, "nodes[0].clamp: needs a terrain"));
    hz_scene_destroy(s);
    hz_scene_file_destroy(f);
    /* A missing file. */
    assert_null(hz_scene_file_open("/nonexistent/x.scene.json", NULL, &err));
    assert_int_equal(err.code, HZ_ERR_IO);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_build),
        cmocka_unit_test(test_georef),
        cmocka_unit_test(test_malformed),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
