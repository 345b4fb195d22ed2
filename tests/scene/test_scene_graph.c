/* Scene graph (G1, G3, G5): inherited transforms against hand-computed
 * matrices, bounds after moves (only the changed subtree recomputed),
 * hierarchical frustum culling, the render queue's order, ray picking. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <string.h>

#include "horizon/camera.h"
#include "horizon/occlusion.h"
#include "horizon/scene.h"

static void near3(const float *a, float x, float y, float z, float eps)
{
    if (!(fabsf(a[0] - x) < eps && fabsf(a[1] - y) < eps && fabsf(a[2] - z) < eps))
        fail_msg("(%g %g %g) != (%g %g %g)", (double)a[0], (double)a[1], (double)a[2], (double)x, (double)y,
                 (double)z);
}

static void near_mat(mat4 a, const float e[16])
{
    /* e is row-major as written by hand: e[r * 4 + c] = a[c][r]. */
    for (int r = 0; r < 4; r++)
        for (int c = 0; c < 4; c++)
            if (fabsf(a[c][r] - e[r * 4 + c]) > 1e-5f)
                fail_msg("m[row %d][col %d] = %g, expected %g", r, c, (double)a[c][r], (double)e[r * 4 + c]);
}

/* A box mesh [-h, h]^3 (8 vertices, 12 triangles). */
static uint32_t add_box(hz_scene *s, float h)
{
    hz_vertex v[8];
    for (int k = 0; k < 8; k++) {
        v[k] = (hz_vertex){{k & 1 ? h : -h, k & 2 ? h : -h, k & 4 ? h : -h}, {0, 1, 0}};
    }
    static const uint32_t ix[36] = {0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4,
                                    2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5};
    hz_err err = {0};
    uint32_t m = hz_scene_add_mesh(s, v, 8, ix, 36, &err);
    assert_int_not_equal(m, HZ_MESH_NONE);
    return m;
}

/* What stands on the ground: a box turned 45 degrees raises exactly the
 * samples of its own (diamond) footprint to its top, not its world box's; a
 * sloped triangle gives its height at each sample; a triangle smaller than
 * a cell raises the sample nearest its centre to its highest vertex; what
 * is off the grid or not finite raises nothing. */
static void test_ground_heights(void **state)
{
    (void)state;
    enum { N = 101 };
    static float tops[N * N];
    for (int k = 0; k < N * N; k++)
        tops[k] = -INFINITY;
    hz_scene *s = hz_scene_create(NULL);
    uint32_t box = add_box(s, 0.5f);
    uint32_t b = hz_scene_add_node(s, 0, "turned");
    hz_scene_set_mesh(s, b, box, 0);
    hz_scene_set_translation(s, b, (float[3]){30, 5, 30});
    hz_scene_set_scale(s, b, (float[3]){10, 10, 10});
    hz_scene_set_ypr(s, b, 45, 0, 0);
    hz_scene_update(s);
    uint64_t raised = hz_scene_heights(s, N, 1.0f, tops);
    uint64_t inside = 0;
    const float r = 5.0f * sqrtf(2.0f); /* the diamond's half diagonal */
    for (int j = 0; j < N; j++)
        for (int i = 0; i < N; i++) {
            const float d = fabsf((float)i - 30) + fabsf((float)j - 30), h = tops[j * N + i];
            if (d < r - 0.01f) {
                inside++;
                assert_float_equal(h, 10.0f, 1e-3f); /* the roof */
            } else if (d > r + 0.01f) {
                if (h != -INFINITY)
                    fail_msg("sample (%d, %d) outside the footprint raised to %g", i, j, (double)h);
            }
        }
    assert_true(inside > 90 && inside <= raised && raised < inside + 12); /* 100 m^2; the rim's few */
    /* A sloped ground-facing triangle: its plane's height at each sample. */
    const hz_vertex tri[3] = {{{0, 0, 0}, {0, 1, 0}}, {{20, 20, 0}, {0, 1, 0}}, {{0, 0, 20}, {0, 1, 0}}};
    hz_err err = {0};
    uint32_t slope = hz_scene_add_mesh(s, tri, 3, (const uint32_t[3]){0, 1, 2}, 3, &err);
    uint32_t t1 = hz_scene_add_node(s, 0, "slope");
    hz_scene_set_mesh(s, t1, slope, 0);
    hz_scene_set_translation(s, t1, (float[3]){60, 0, 60});
    /* A 0.3 m triangle (a leaf) near sample (80, 10), 7 m up at its highest. */
    const hz_vertex tiny[3] = {{{0, 1, 0}, {0, 1, 0}}, {{0.3f, 7, 0}, {0, 1, 0}}, {{0, 2, 0.3f}, {0, 1, 0}}};
    uint32_t leaf = hz_scene_add_mesh(s, tiny, 3, (const uint32_t[3]){0, 1, 2}, 3, &err);
    assert_int_not_equal(leaf, HZ_MESH_NONE);
    uint32_t t2 = hz_scene_add_node(s, 0, "leaf");
    hz_scene_set_mesh(s, t2, leaf, 0);
    hz_scene_set_translation(s, t2, (float[3]){80.3f, 0, 10.2f});
    /* Off the grid, and not finite. */
    uint32_t t3 = hz_scene_add_node(s, 0, "away"), t4 = hz_scene_add_node(s, 0, "nan");
    hz_scene_set_mesh(s, t3, box, 0);
    hz_scene_set_translation(s, t3, (float[3]){-50, 0, 500});
    hz_scene_set_mesh(s, t4, box, 0);
    hz_scene_set_translation(s, t4, (float[3]){NAN, 0, 50});
    hz_scene_update(s);
    for (int k = 0; k < N * N; k++)
        tops[k] = -INFINITY;
    raised = hz_scene_heights(s, N, 1.0f, tops);
    uint64_t on_slope = 0;
    for (int j = 60; j <= 80; j++)
        for (int i = 60; i <= 80; i++)
            if ((i - 60) + (j - 60) <= 20) {
                on_slope++;
                assert_float_equal(tops[j * N + i], (float)(i - 60), 1e-3f);
            }
    assert_float_equal(tops[10 * N + 80], 7.0f, 0.0f);
    assert_true(tops[10 * N + 81] == -INFINITY && tops[11 * N + 80] == -INFINITY);
    uint64_t standing = 0;
    for (int k = 0; k < N * N; k++)
        standing += tops[k] > -INFINITY;
    assert_int_equal(raised, standing);
    assert_true(standing >= inside + on_slope + 1 && standing < inside + on_slope + 1 + 12);
    /* Nothing on a degenerate grid. */
    assert_int_equal(hz_scene_heights(s, 1, 1.0f, tops), 0);
    assert_int_equal(hz_scene_heights(s, N, 0.0f, tops), 0);
    hz_scene_destroy(s);
}

/* parent: T(10, 0, 0) Ry(90 deg about +y); child: T(0, 0, -5) S(2);
 * grandchild: rotation 90 about +x then T(1, 0, 0). Expected matrices
 * written out by hand. */
static void test_inheritance(void **state)
{
    (void)state;
    hz_scene *s = hz_scene_create(NULL);
    uint32_t p = hz_scene_add_node(s, HZ_NODE_NONE, "parent");
    uint32_t c = hz_scene_add_node(s, p, "child");
    uint32_t g = hz_scene_add_node(s, c, "grandchild");
    hz_scene_set_translation(s, p, (float[3]){10, 0, 0});
    hz_scene_set_axis_angle(s, p, (float[3]){0, 1, 0}, 90);
    hz_scene_set_translation(s, c, (float[3]){0, 0, -5});
    hz_scene_set_scale(s, c, (float[3]){2, 2, 2});
    hz_scene_set_translation(s, g, (float[3]){1, 0, 0});
    hz_scene_set_axis_angle(s, g, (float[3]){1, 0, 0}, 90);
    assert_int_equal(hz_scene_update(s), 3);
    mat4 m;
    /* Ry(90): x -> -z, z -> x. */
    hz_scene_world_matrix(s, p, m);
    near_mat(m, (const float[16]){0, 0, 1, 10, 0, 1, 0, 0, -1, 0, 0, 0, 0, 0, 0, 1});
    /* P * T(0,0,-5) * S(2): translation Ry(90)(0,0,-5) = (-5, 0, 0) + (10, 0, 0). */
    hz_scene_world_matrix(s, c, m);
    near_mat(m, (const float[16]){0, 0, 2, 5, 0, 2, 0, 0, -2, 0, 0, 0, 0, 0, 0, 1});
    /* C * T(1,0,0) * Rx(90) (y -> z, z -> -y): origin at C(1,0,0) = (5, 0, -2);
     * columns: x -> C x = (0,0,-2); y -> C z = (2,0,0); z -> C(-y) = (0,-2,0). */
    hz_scene_world_matrix(s, g, m);
    near_mat(m, (const float[16]){0, 2, 0, 5, 0, 0, -2, 0, -2, 0, 0, -2, 0, 0, 0, 1});
    /* A point through the chain. */
    vec3 w;
    glm_mat4_mulv3(m, (vec3){0, 1, 0}, 1, w);
    near3(w, 7, 0, -2, 1e-5f);
    /* Nothing changed: no work. */
    assert_int_equal(hz_scene_update(s), 0);
    hz_scene_destroy(s);
}

/* Yaw/pitch/roll follow the camera's convention: forward -z turns east
 * with yaw 90, up with pitch; roll banks about forward. */
static void test_ypr(void **state)
{
    (void)state;
    hz_scene *s = hz_scene_create(NULL);
    uint32_t n = hz_scene_add_node(s, 0, "n");
    mat4 m;
    vec3 f;
    hz_scene_set_ypr(s, n, 90, 0, 0);
    hz_scene_update(s);
    hz_scene_world_matrix(s, n, m);
    glm_mat4_mulv3(m, (vec3){0, 0, -1}, 0, f);
    near3(f, 1, 0, 0, 1e-5f);
    hz_scene_set_ypr(s, n, 37, 30, 0);
    hz_scene_update(s);
    hz_scene_world_matrix(s, n, m);
    glm_mat4_mulv3(m, (vec3){0, 0, -1}, 0, f);
    hz_camera cam = {.yaw = 37, .pitch = 30};
    vec3 cf;
    hz_camera_forward(&cam, cf);
    near3(f, cf[0], cf[1], cf[2], 1e-5f);
    /* Roll 90 with yaw 0: the right axis +x goes down. */
    hz_scene_set_ypr(s, n, 0, 0, 90);
    hz_scene_update(s);
    hz_scene_world_matrix(s, n, m);
    glm_mat4_mulv3(m, (vec3){1, 0, 0}, 0, f);
    near3(f, 0, -1, 0, 1e-5f);
    /* rotate() composes: two 45 degree turns about y = yaw -90. */
    hz_scene_set_ypr(s, n, 0, 0, 0);
    hz_scene_rotate(s, n, (float[3]){0, 1, 0}, 45);
    hz_scene_rotate(s, n, (float[3]){0, 1, 0}, 45);
    hz_scene_update(s);
    hz_scene_world_matrix(s, n, m);
    glm_mat4_mulv3(m, (vec3){0, 0, -1}, 0, f);
    near3(f, -1, 0, 0, 1e-5f);
    hz_scene_destroy(s);
}

/* Two groups of two boxes; moving one group recomputes its subtree only, and
 * the boxes follow. */
static void test_bounds_after_move(void **state)
{
    (void)state;
    hz_scene *s = hz_scene_create(NULL);
    uint32_t box = add_box(s, 1);
    uint32_t ga = hz_scene_add_node(s, 0, "a"), gb = hz_scene_add_node(s, 0, "b");
    uint32_t a1 = hz_scene_add_node(s, ga, "a1"), a2 = hz_scene_add_node(s, ga, "a2");
    uint32_t b1 = hz_scene_add_node(s, gb, "b1"), b2 = hz_scene_add_node(s, gb, "b2");
    for (uint32_t k = a1; k <= b2; k++)
        hz_scene_set_mesh(s, k, box, 0);
    hz_scene_set_translation(s, a2, (float[3]){4, 0, 0});
    hz_scene_set_translation(s, gb, (float[3]){0, 0, 100});
    hz_scene_set_translation(s, b2, (float[3]){0, 10, 0});
    assert_int_equal(hz_scene_update(s), 6);
    hz_box b;
    hz_scene_subtree_bounds(s, ga, &b);
    near3(b.min, -1, -1, -1, 1e-5f);
    near3(b.max, 5, 1, 1, 1e-5f);
    hz_scene_subtree_bounds(s, gb, &b);
    near3(b.min, -1, -1, 99, 1e-5f);
    near3(b.max, 1, 11, 101, 1e-5f);
    /* Move group a: a, a1, a2 recomputed (3), b untouched. */
    hz_scene_translate(s, ga, (float[3]){0, 0, -50});
    assert_int_equal(hz_scene_update(s), 3);
    hz_scene_subtree_bounds(s, ga, &b);
    near3(b.min, -1, -1, -51, 1e-5f);
    near3(b.max, 5, 1, -49, 1e-5f);
    hz_scene_node_bounds(s, a2, &b);
    near3(b.min, 3, -1, -51, 1e-5f);
    hz_scene_bounds(s, &b);
    near3(b.min, -1, -1, -51, 1e-5f);
    near3(b.max, 5, 11, 101, 1e-5f);
    /* A leaf move: that node alone; its group's box shrinks back. */
    hz_scene_set_translation(s, b2, (float[3]){0, 0, 0});
    assert_int_equal(hz_scene_update(s), 1);
    hz_scene_subtree_bounds(s, gb, &b);
    near3(b.max, 1, 1, 101, 1e-5f);
    /* A rotation of 45 degrees grows the axis-aligned box of a unit box to sqrt 2. */
    hz_scene_set_axis_angle(s, b1, (float[3]){0, 1, 0}, 45);
    hz_scene_update(s);
    hz_scene_node_bounds(s, b1, &b);
    near3(b.max, sqrtf(2), 1, 100 + sqrtf(2), 1e-4f);
    hz_scene_destroy(s);
}

/* The camera at the origin looks north (-z). A group of boxes behind it is
 * culled whole with one test; boxes ahead survive, one to the side does not. */
static void test_frustum_culling(void **state)
{
    (void)state;
    hz_scene *s = hz_scene_create(NULL);
    uint32_t box = add_box(s, 1);
    uint32_t front = hz_scene_add_node(s, 0, "front"), back = hz_scene_add_node(s, 0, "back");
    uint32_t ids[8];
    for (int k = 0; k < 4; k++) {
        ids[k] = hz_scene_add_node(s, front, NULL);
        hz_scene_set_mesh(s, ids[k], box, 0);
        hz_scene_set_translation(s, ids[k], (float[3]){0, 0, -20.0f - 10.0f * (float)k});
    }
    /* Far to the east, beyond the 60 degree field of view. */
    hz_scene_set_translation(s, ids[3], (float[3]){200, 0, -20});
    for (int k = 4; k < 8; k++) {
        ids[k] = hz_scene_add_node(s, back, NULL);
        hz_scene_set_mesh(s, ids[k], box, 0);
        hz_scene_set_translation(s, ids[k], (float[3]){(float)k, 0, 30});
    }
    hz_scene_update(s);
    hz_camera cam = {.pos = {0, 0, 0}, .fov_y = 60, .aspect = 1, .znear = 0.5f, .zfar = 1000};
    vec4 planes[6];
    hz_camera_frustum(&cam, planes);
    uint32_t out[8];
    hz_cull_stats st;
    uint32_t n = hz_scene_cull(s, planes, out, 8, &st);
    assert_int_equal(n, 3);
    assert_int_equal(out[0], ids[0]);
    assert_int_equal(out[1], ids[1]);
    assert_int_equal(out[2], ids[2]);
    assert_int_equal(st.objects, 8);
    assert_int_equal(st.subtrees_culled, 2); /* "back" whole, ids[3] */
    assert_int_equal(st.nodes_tested, 2 + 4); /* two groups, the front group's four boxes */
    /* Turn around: the back group is entirely inside, accepted with one test. */
    cam.yaw = 180;
    hz_camera_frustum(&cam, planes);
    n = hz_scene_cull(s, planes, out, 8, &st);
    assert_int_equal(n, 4);
    assert_int_equal(out[0], ids[4]);
    assert_int_equal(st.subtrees_inside, 1);
    assert_int_equal(st.nodes_tested, 2);
    /* cap smaller than the count: the count is still right. */
    assert_int_equal(hz_scene_cull(s, planes, out, 2, NULL), 4);
    /* The object count follows meshes set, replaced and taken away. */
    hz_scene_set_mesh(s, ids[4], box, 0);           /* replaced: still one */
    hz_scene_set_mesh(s, ids[5], HZ_MESH_NONE, 0);  /* taken away */
    hz_scene_set_mesh(s, ids[5], HZ_MESH_NONE, 0);  /* again: no change */
    hz_scene_set_mesh(s, back, box, 0);             /* a group node gets one */
    hz_scene_update(s);
    hz_scene_cull(s, planes, out, 8, &st);
    assert_int_equal(st.objects, 8);
    hz_scene_destroy(s);
}

/* Sorted: grouped by shader, then material, then mesh, stable within a
 * group; equal (material, mesh) runs become one instanced item. */
static void test_render_queue(void **state)
{
    (void)state;
    hz_scene *s = hz_scene_create(NULL);
    uint32_t m0 = add_box(s, 1), m1 = add_box(s, 2);
    hz_material mat = {.color = {1, 1, 1}};
    hz_scene_add_material(s, &mat);     /* 0, shader 0 */
    mat.shader = 1;
    hz_scene_add_material(s, &mat);     /* 1, shader 1 */
    mat.shader = 0;
    hz_scene_add_material(s, &mat);     /* 2, shader 0 */
    /* node k: material, mesh */
    static const uint32_t spec[10][2] = {{1, 0}, {0, 1}, {2, 0}, {0, 0}, {1, 0},
                                         {0, 1}, {2, 1}, {0, 0}, {2, 0}, {0, 1}};
    uint32_t nodes[10];
    for (int k = 0; k < 10; k++) {
        nodes[k] = hz_scene_add_node(s, 0, NULL);
        hz_scene_set_mesh(s, nodes[k], spec[k][1] ? m1 : m0, spec[k][0]);
    }
    uint32_t order[10];
    hz_draw_item items[10];
    hz_queue_stats st;
    uint32_t ni = hz_scene_queue_build(s, nodes, 10, true, order, items, &st);
    /* shader 0: mat 0 (mesh 0: nodes 3, 7; mesh 1: 1, 5, 9), mat 2 (mesh 0: 2, 8;
     * mesh 1: 6); shader 1: mat 1 (mesh 0: 0, 4). */
    const uint32_t expect[10] = {3, 7, 1, 5, 9, 2, 8, 6, 0, 4};
    for (int k = 0; k < 10; k++)
        assert_int_equal(order[k], nodes[expect[k]]);
    assert_int_equal(ni, 5);
    const uint32_t counts[5] = {2, 3, 2, 1, 2};
    uint32_t first = 0;
    for (uint32_t k = 0; k < ni; k++) {
        assert_int_equal(items[k].count, counts[k]);
        assert_int_equal(items[k].first, first);
        first += items[k].count;
        if (k)
            assert_true(items[k - 1].shader < items[k].shader ||
                        (items[k - 1].shader == items[k].shader && items[k - 1].material <= items[k].material));
    }
    assert_int_equal(st.shader_changes, 2);
    assert_int_equal(st.material_changes, 3);
    /* Unsorted: one item per node in the given order; every neighbour with
     * another material is a change. */
    ni = hz_scene_queue_build(s, nodes, 10, false, order, items, &st);
    assert_int_equal(ni, 10);
    for (int k = 0; k < 10; k++)
        assert_int_equal(order[k], nodes[k]);
    assert_int_equal(st.material_changes, 10);
    assert_int_equal(st.shader_changes, 4);
    /* Materials as instance data: one item per (shader, mesh), its nodes in
     * the given order whatever their material. */
    ni = hz_scene_queue_build_instanced(s, nodes, 10, true, order, items, &st);
    const uint32_t expect_i[10] = {2, 3, 7, 8, 1, 5, 6, 9, 0, 4};
    for (int k = 0; k < 10; k++)
        assert_int_equal(order[k], nodes[expect_i[k]]);
    assert_int_equal(ni, 3);
    const uint32_t counts_i[3] = {4, 4, 2}, mesh_i[3] = {m0, m1, m0}, shader_i[3] = {0, 0, 1};
    for (uint32_t k = 0, f = 0; k < ni; f += items[k++].count) {
        assert_int_equal(items[k].count, counts_i[k]);
        assert_int_equal(items[k].first, f);
        assert_int_equal(items[k].mesh, mesh_i[k]);
        assert_int_equal(items[k].shader, shader_i[k]);
        assert_int_equal(items[k].material, HZ_MATERIAL_PER_INSTANCE);
    }
    assert_int_equal(st.shader_changes, 2);
    assert_int_equal(st.material_changes, 0);
    hz_scene_destroy(s);
}

/* Distance from e to the node's world box, 0 inside. */
static float box_dist(const hz_scene *s, uint32_t node, const float e[3])
{
    hz_box b;
    hz_scene_node_bounds(s, node, &b);
    float d2 = 0;
    for (int c = 0; c < 3; c++) {
        float v = fmaxf(fmaxf(b.min[c] - e[c], e[c] - b.max[c]), 0.0f);
        d2 += v * v;
    }
    return sqrtf(d2);
}

/* Near-first order: distances never decrease, it is a permutation, and
 * equal distances keep the given order; the queue then keeps it within an
 * item. 2 000 boxes spread over 20 km (every byte of the keys matters), a
 * run of boxes at the same distance, one box around the eye. */
static void test_sort_near_first(void **state)
{
    (void)state;
    hz_scene *s = hz_scene_create(NULL);
    uint32_t box = add_box(s, 1);
    enum { N = 2000 };
    uint32_t nodes[N], given[N], tmp[3 * N];
    uint32_t rng = 12345;
    for (int k = 0; k < N; k++) {
        nodes[k] = hz_scene_add_node(s, 0, NULL);
        hz_scene_set_mesh(s, nodes[k], box, 0);
        float p[3];
        if (k % 10 == 3) {
            p[0] = 100, p[1] = 0, p[2] = 0; /* ten percent at one place: equal distances */
        } else if (k == 1000) {
            p[0] = p[1] = p[2] = 0; /* around the eye */
        } else {
            for (int c = 0; c < 3; c++) {
                rng = rng * 1664525u + 1013904223u;
                p[c] = ((float)(rng >> 8) / 16777216.0f - 0.5f) * (c == 1 ? 200.0f : 20000.0f);
            }
        }
        hz_scene_set_translation(s, nodes[k], p);
    }
    hz_scene_update(s);
    memcpy(given, nodes, sizeof nodes);
    const float eye[3] = {0.2f, 0.3f, -0.1f};
    hz_scene_sort_near_first(s, eye, nodes, N, tmp);
    assert_int_equal(nodes[0], given[1000]);
    assert_true(box_dist(s, nodes[0], eye) == 0.0f);
    uint32_t seen[N + 1] = {0};
    uint32_t last_tie = 0, ties = 0;
    for (int k = 0; k < N; k++) {
        seen[nodes[k]]++;
        if (k)
            assert_true(box_dist(s, nodes[k - 1], eye) <= box_dist(s, nodes[k], eye));
        const uint32_t id = nodes[k];
        if ((id - given[0]) % 10 == 3) { /* the tied boxes, in the given (id) order */
            assert_true(id > last_tie);
            last_tie = id;
            ties++;
        }
    }
    assert_int_equal(ties, N / 10);
    for (int k = 0; k < N; k++)
        assert_int_equal(seen[given[k]], 1);
    /* The queue keeps that order within its one item. */
    uint32_t order[N];
    hz_draw_item items[N];
    assert_int_equal(hz_scene_queue_build(s, nodes, N, true, order, items, NULL), 1);
    assert_memory_equal(order, nodes, sizeof order);
    hz_scene_destroy(s);
}

static void test_raycast(void **state)
{
    (void)state;
    hz_scene *s = hz_scene_create(NULL);
    uint32_t box = add_box(s, 1);
    uint32_t g = hz_scene_add_node(s, 0, "g");
    uint32_t near = hz_scene_add_node(s, g, "near"), far = hz_scene_add_node(s, g, "far");
    hz_scene_set_mesh(s, near, box, 0);
    hz_scene_set_mesh(s, far, box, 0);
    hz_scene_set_translation(s, far, (float[3]){0, 0, -20});
    hz_scene_set_translation(s, near, (float[3]){0.5f, 0, -10});
    hz_scene_set_attributes(s, near, "{\"osm_id\":7}", NULL);
    hz_scene_update(s);
    hz_scene_hit h;
    assert_true(hz_scene_raycast(s, (float[3]){0, 0, 0}, (float[3]){0, 0, -1}, 1000, &h));
    assert_int_equal(h.node, near);
    near3(h.pos, 0, 0, -9, 1e-4f);
    assert_string_equal(hz_scene_attributes(s, h.node), "{\"osm_id\":7}");
    /* Beside the near box: the far one. */
    assert_true(hz_scene_raycast(s, (float[3]){-0.75f, 0, 0}, (float[3]){0, 0, -1}, 1000, &h));
    assert_int_equal(h.node, far);
    near3(h.pos, -0.75f, 0, -19, 1e-4f);
    /* Limited by t_max, or aimed away: nothing. */
    assert_false(hz_scene_raycast(s, (float[3]){0, 0, 0}, (float[3]){0, 0, -1}, 5, &h));
    assert_false(hz_scene_raycast(s, (float[3]){0, 0, 0}, (float[3]){0, 1, 0}, 1000, &h));
    assert_int_equal(hz_scene_find(s, "far"), far);
    assert_int_equal(hz_scene_find(s, "none"), HZ_NODE_NONE);
    hz_scene_destroy(s);
}

static bool visit_rec(void *user, const hz_scene *s, uint32_t node, uint32_t depth)
{
    char *buf = user;
    char tmp[32];
    snprintf(tmp, sizeof tmp, "%s:%u ", hz_scene_name(s, node), depth);
    strcat(buf, tmp);
    return strcmp(hz_scene_name(s, node), "skip") != 0;
}

static void test_depth_first(void **state)
{
    (void)state;
    hz_scene *s = hz_scene_create(NULL);
    uint32_t a = hz_scene_add_node(s, 0, "a");
    uint32_t b = hz_scene_add_node(s, a, "b");
    hz_scene_add_node(s, b, "c");
    uint32_t k = hz_scene_add_node(s, a, "skip");
    hz_scene_add_node(s, k, "hidden");
    hz_scene_add_node(s, a, "d");
    hz_scene_add_node(s, 0, "e");
    char buf[256] = "";
    hz_scene_visit(s, visit_rec, buf);
    assert_string_equal(buf, "a:0 b:1 c:2 skip:1 d:1 e:0 ");
    /* A mesh with a bad index is refused. */
    hz_err err = {0};
    hz_vertex v[3] = {0};
    assert_int_equal(hz_scene_add_mesh(s, v, 3, (const uint32_t[3]){0, 1, 3}, 3, &err), HZ_MESH_NONE);
    assert_non_null(strstr(err.msg, "out of range"));
    hz_scene_destroy(s);
}

/* G4: a wall 10 m wide and 4 m high 10 m ahead. A box behind it is hidden;
 * one peeking over it, one beside it and one in front of it are not. */
static void test_occlusion(void **state)
{
    (void)state;
    hz_occlusion o;
    assert_true(hz_occlusion_init(&o, 128, 72));
    hz_camera cam = {.pos = {0, 1, 0}, .fov_y = 60, .aspect = 16.0f / 9.0f, .znear = 0.5f, .zfar = 1000};
    hz_occlusion_begin(&o, &cam);
    const float wall[18] = {-5, -1, -10, 5, -1, -10, 5, 3, -10, -5, -1, -10, 5, 3, -10, -5, 3, -10};
    /* As two triangles the cells along the diagonal stay open (a cell must
     * be inside one triangle): the box straddling it is kept. */
    hz_occlusion_rasterize(&o, wall, 2, NULL);
    assert_int_equal(o.triangles, 2);
    assert_true(o.cells_written > 100);
    hz_box behind = {{-1, 0, -21}, {1, 2, -19}};
    assert_false(hz_occlusion_box_hidden(&o, &behind));
    /* As one quad: covered. */
    const float quad[12] = {-5, -1, -10, 5, -1, -10, 5, 3, -10, -5, 3, -10};
    hz_occlusion_begin(&o, &cam);
    assert_false(hz_occlusion_rect_covered(&o, -0.3f, -0.2f, 0.3f, 0.2f)); /* nothing yet */
    hz_occlusion_rasterize_quads(&o, quad, 1, NULL);
    hz_box over = {{-1, 0, -21}, {1, 10, -19}};
    hz_box beside = {{8, 0, -21}, {10, 2, -19}};
    hz_box front = {{-1, 0, -6}, {1, 2, -4}};
    hz_box just_behind = {{-1, 0, -10.5f}, {1, 2, -10.1f}};
    assert_true(hz_occlusion_box_hidden(&o, &behind));
    assert_true(hz_occlusion_box_hidden(&o, &just_behind));
    assert_false(hz_occlusion_box_hidden(&o, &over));
    assert_false(hz_occlusion_box_hidden(&o, &beside));
    assert_false(hz_occlusion_box_hidden(&o, &front));
    /* Screen rectangles (what the sky skips): the wall spans NDC x +-0.49,
     * y +-0.35; one inside it is covered, one reaching past its side or off
     * the screen is not. */
    assert_true(hz_occlusion_rect_covered(&o, -0.3f, -0.2f, 0.3f, 0.2f));
    assert_false(hz_occlusion_rect_covered(&o, -0.3f, -0.2f, 0.6f, 0.2f));
    assert_false(hz_occlusion_rect_covered(&o, -0.3f, 0.2f, 0.3f, 0.5f));
    assert_false(hz_occlusion_rect_covered(&o, -0.3f, -0.2f, 0.3f, 1.2f));
    assert_false(hz_occlusion_rect_covered(&o, 0.3f, -0.2f, -0.3f, 0.2f));
    /* A tilted wall (a model matrix turning it 60 degrees about y): its far end
     * is farther, and a box just behind its near end but nearer than its far
     * end is kept (the cell's depth is the triangle's farthest vertex). */
    mat4 m;
    glm_translate_make(m, (vec3){0, 0, -10});
    glm_rotate(m, glm_rad(60), (vec3){0, 1, 0});
    glm_translate(m, (vec3){0, 0, 10});
    hz_occlusion_begin(&o, &cam);
    hz_occlusion_rasterize_quads(&o, quad, 1, m);
    hz_box mid = {{-0.5f, 0, -11.5f}, {0.5f, 1, -11}};
    assert_false(hz_occlusion_box_hidden(&o, &mid));
    hz_box far = {{-0.5f, 0, -40}, {0.5f, 1, -39}};
    assert_true(hz_occlusion_box_hidden(&o, &far));
    /* A box reaching behind the eye is never hidden. */
    hz_box around = {{-1, 0, -30}, {1, 1, 2}};
    assert_false(hz_occlusion_box_hidden(&o, &around));
    /* Back faces (cull_back): the wall turns counter-clockwise on screen, its
     * front; given the other way round it is a back face, which the
     * renderer's face culling would not draw: it then hides nothing. With
     * cull_back off both windings hide. */
    const float back[12] = {-5, 3, -10, 5, 3, -10, 5, -1, -10, -5, -1, -10};
    const float back_tri[18] = {-5, -1, -10, 5, 3, -10, 5, -1, -10, -5, -1, -10, -5, 3, -10, 5, 3, -10};
    o.cull_back = true;
    hz_occlusion_begin(&o, &cam);
    hz_occlusion_rasterize_quads(&o, quad, 1, NULL);
    assert_int_equal(o.triangles, 1);
    assert_true(hz_occlusion_box_hidden(&o, &behind));
    hz_occlusion_begin(&o, &cam);
    hz_occlusion_rasterize_quads(&o, back, 1, NULL);
    hz_occlusion_rasterize(&o, back_tri, 2, NULL);
    assert_int_equal(o.triangles, 0);
    assert_int_equal(o.cells_written, 0);
    assert_false(hz_occlusion_box_hidden(&o, &behind));
    assert_false(hz_occlusion_rect_covered(&o, -0.3f, -0.2f, 0.3f, 0.2f));
    /* Seen from behind (the camera turned around, beyond the wall), the
     * front-facing quad is a back face too. */
    hz_camera rear = {.pos = {0, 1, -20}, .yaw = 180, .fov_y = 60, .aspect = 16.0f / 9.0f, .znear = 0.5f,
                      .zfar = 1000};
    hz_occlusion_begin(&o, &rear);
    hz_occlusion_rasterize_quads(&o, quad, 1, NULL);
    assert_int_equal(o.triangles, 0);
    hz_occlusion_begin(&o, &rear);
    hz_occlusion_rasterize_quads(&o, back, 1, NULL);
    assert_int_equal(o.triangles, 1);
    hz_box before = {{-1, 0, 1}, {1, 2, 3}}; /* behind the wall for the rear camera */
    assert_true(hz_occlusion_box_hidden(&o, &before));
    o.cull_back = false;
    hz_occlusion_begin(&o, &cam);
    hz_occlusion_rasterize_quads(&o, back, 1, NULL);
    assert_int_equal(o.triangles, 1);
    assert_true(hz_occlusion_box_hidden(&o, &behind));
    /* Two buffers filled apart and merged: the nearer occluder per cell. The
     * wall at 10 m in one, a wider one at 30 m in the other: behind the near
     * wall's middle the merged buffer hides a box at 20 m (the far wall
     * alone would not), and beside it, behind the far wall, a box at 40 m. */
    hz_occlusion far_o;
    assert_true(hz_occlusion_init(&far_o, 128, 72));
    const float wide[12] = {-30, -3, -30, 30, -3, -30, 30, 9, -30, -30, 9, -30};
    hz_occlusion_begin(&o, &cam);
    hz_occlusion_begin(&far_o, &cam);
    hz_occlusion_rasterize_quads(&o, quad, 1, NULL);
    hz_occlusion_rasterize_quads(&far_o, wide, 1, NULL);
    hz_box mid20 = {{-1, 0, -21}, {1, 2, -19}}, side40 = {{25, 0, -41}, {27, 2, -39}};
    assert_false(hz_occlusion_box_hidden(&far_o, &mid20));
    assert_false(hz_occlusion_box_hidden(&o, &side40));
    assert_true(hz_occlusion_merge(&o, &far_o));
    assert_int_equal(o.triangles, 2);
    assert_true(hz_occlusion_box_hidden(&o, &mid20));
    assert_true(hz_occlusion_box_hidden(&o, &side40));
    hz_box side20 = {{12, 0, -21}, {14, 2, -19}}; /* in front of the far wall, beside the near one */
    assert_false(hz_occlusion_box_hidden(&o, &side20));
    hz_occlusion_free(&far_o);
    assert_true(hz_occlusion_init(&far_o, 64, 36));
    assert_false(hz_occlusion_merge(&o, &far_o)); /* another size: refused */
    assert_int_equal(o.triangles, 2);
    hz_occlusion_free(&far_o);
    /* A box around the eye, or within twice the near distance of it. */
    hz_box at_eye = {{-1, 0, -1}, {1, 2, 1}}, close = {{-1, 0, -1.9f}, {1, 2, -0.95f}};
    assert_true(hz_box_around_eye(&at_eye, &cam));
    assert_true(hz_box_around_eye(&close, &cam));  /* 0.95 m ahead, znear 0.5 */
    assert_false(hz_box_around_eye(&behind, &cam));
    hz_occlusion_free(&o);
}


/* G3 + G4 in one pass (hz_scene_cull_occluded): behind a wall 10 m ahead a
 * group of five boxes is dropped with one test of its box; in a second
 * group one box peeks over the wall, so the group is tested box by box and
 * only that one is kept; a group beside the wall is kept whole. The result
 * is the frustum's list less exactly the boxes the buffer hides one by one,
 * and in_frustum counts the hidden ones too. */
static void test_cull_occluded(void **state)
{
    (void)state;
    hz_scene *s = hz_scene_create(NULL);
    const uint32_t box = add_box(s, 1); /* 2 m cubes */
    const uint32_t hid = hz_scene_add_node(s, 0, "behind"), peek = hz_scene_add_node(s, 0, "peeking"),
                   side = hz_scene_add_node(s, 0, "beside");
    uint32_t ids[12];
    for (int k = 0; k < 12; k++) {
        const uint32_t g = k < 5 ? hid : (k < 9 ? peek : side);
        ids[k] = hz_scene_add_node(s, g, NULL);
        hz_scene_set_mesh(s, ids[k], box, 0);
        const float x = k < 9 ? (float)(k % 5) - 2.0f : 14.0f + 2.0f * (float)(k - 9);
        hz_scene_set_translation(s, ids[k], (float[3]){x * 0.8f, k == 6 ? 8.0f : 0.0f, -20.0f - (float)(k % 3)});
    }
    hz_scene_update(s);
    hz_camera cam = {.pos = {0, 1, 0}, .fov_y = 60, .aspect = 16.0f / 9.0f, .znear = 0.5f, .zfar = 1000};
    hz_occlusion o;
    assert_true(hz_occlusion_init(&o, 128, 72));
    hz_occlusion_begin(&o, &cam);
    const float wall[12] = {-5, -1, -10, 5, -1, -10, 5, 3, -10, -5, 3, -10};
    hz_occlusion_rasterize_quads(&o, wall, 1, NULL);
    vec4 planes[6];
    hz_camera_frustum(&cam, planes);
    uint32_t all[12], out[12];
    hz_cull_stats fs, st;
    const uint32_t nf = hz_scene_cull_curved(s, &cam, planes, all, 12, &fs);
    assert_int_equal(nf, 12);
    assert_int_equal(fs.occlusion_tests, 0);
    const uint32_t n = hz_scene_cull_occluded(s, &cam, planes, &o, out, 12, &st);
    /* the same as testing each box of the frustum's list alone */
    uint32_t m = 0;
    for (uint32_t k = 0; k < nf; k++) {
        hz_box b;
        hz_scene_node_bounds(s, all[k], &b);
        if (!hz_occlusion_box_hidden(&o, &b)) {
            assert_true(m < n);
            assert_int_equal(out[m++], all[k]);
        }
    }
    assert_int_equal(m, n);
    assert_int_equal(n, 1 + 3); /* the peeking box and the group beside */
    assert_int_equal(out[0], ids[6]);
    assert_int_equal(st.in_frustum, 12);
    assert_int_equal(st.visible, n);
    assert_int_equal(st.subtrees_hidden, 1);
    /* three groups, then the peeking group's four boxes and the side group's three */
    assert_int_equal(st.occlusion_tests, 3 + 4 + 3);
    /* no buffer: frustum culling alone */
    assert_int_equal(hz_scene_cull_occluded(s, &cam, planes, NULL, out, 12, &st), 12);
    hz_occlusion_free(&o);
    hz_scene_destroy(s);
}

/* Signed distance in cells from point (x, y) to the inside of the convex
 * screen polygon s (n vertices, either winding): > 0 inside. */
static double poly_margin(const double s[4][2], int n, double x, double y)
{
    double area = 0;
    for (int k = 0; k < n; k++)
        area += s[k][0] * s[(k + 1) % n][1] - s[(k + 1) % n][0] * s[k][1];
    double m = INFINITY;
    for (int k = 0; k < n; k++) {
        const double *a = s[k], *b = s[(k + 1) % n];
        double ex = b[0] - a[0], ey = b[1] - a[1], len = sqrt(ex * ex + ey * ey);
        double e = (ex * (y - a[1]) - ey * (x - a[0])) / len * (area > 0 ? 1 : -1);
        m = fmin(m, e);
    }
    return m;
}

/* G4, the rasteriser against a brute-force reference: for random triangles
 * and rectangles in front of the camera, a cell is written exactly when its
 * four corners lie inside the polygon's projection (cells within 1e-3 of an
 * edge may go either way), at the polygon's farthest depth; nothing else. */
static void test_occlusion_raster_exact(void **state)
{
    (void)state;
    hz_occlusion o;
    assert_true(hz_occlusion_init(&o, 160, 90));
    hz_camera cam = {.pos = {0, 0, 0}, .fov_y = 60, .aspect = 16.0f / 9.0f, .znear = 0.5f, .zfar = 1000};
    uint32_t rng = 12345, written = 0;
    for (int t = 0; t < 400; t++) {
        const int n = t & 1 ? 4 : 3;
        float p[12];
        float c[3], u[3], v[3];
        for (int a = 0; a < 3; a++) {
            rng = rng * 1664525u + 1013904223u;
            c[a] = (float)(rng >> 8) / 16777216.0f;
            rng = rng * 1664525u + 1013904223u;
            u[a] = (float)(rng >> 8) / 16777216.0f - 0.5f;
            rng = rng * 1664525u + 1013904223u;
            v[a] = (float)(rng >> 8) / 16777216.0f - 0.5f;
        }
        /* centre 2-40 m ahead, within the view; edges up to 16 m */
        const float z = -2.0f - 38.0f * c[2];
        const float cx = (c[0] - 0.5f) * 1.6f * -z, cy = (c[1] - 0.5f) * 0.9f * -z;
        for (int a = 0; a < 3; a++) {
            u[a] *= 16.0f;
            v[a] *= 16.0f;
        }
        const float corner[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
        for (int k = 0; k < n; k++) {
            float fu = n == 4 ? corner[k][0] : (k == 0 ? 0.0f : (k == 1 ? 1.0f : 0.0f));
            float fv = n == 4 ? corner[k][1] : (k == 2 ? 1.0f : (k == 0 ? -0.5f : 0.3f));
            p[3 * k] = cx + fu * u[0] + fv * v[0];
            p[3 * k + 1] = cy + fu * u[1] + fv * v[1];
            p[3 * k + 2] = z + fu * u[2] + fv * v[2];
        }
        hz_occlusion_begin(&o, &cam);
        double sc[4][2], dmax = 0;
        bool front = true;
        for (int k = 0; k < n; k++) {
            double cl[4];
            for (int r = 0; r < 4; r++)
                cl[r] = o.viewproj[0][r] * p[3 * k] + o.viewproj[1][r] * p[3 * k + 1] +
                        o.viewproj[2][r] * p[3 * k + 2] + o.viewproj[3][r];
            front = front && cl[3] >= cam.znear;
            sc[k][0] = (cl[0] / cl[3] * 0.5 + 0.5) * o.w;
            sc[k][1] = (cl[1] / cl[3] * 0.5 + 0.5) * o.h;
            dmax = fmax(dmax, cl[3]);
        }
        if (n == 3)
            hz_occlusion_rasterize(&o, p, 1, NULL);
        else
            hz_occlusion_rasterize_quads(&o, p, 1, NULL);
        for (uint32_t j = 0; j < o.h; j++)
            for (uint32_t i = 0; i < o.w; i++) {
                double m = INFINITY;
                for (int k = 0; k < 4; k++)
                    m = fmin(m, poly_margin(sc, n, (double)(i + (k & 1)), (double)(j + (k >> 1))));
                const float d = o.depth[(size_t)j * o.w + i];
                if (!front || m < -1e-3) {
                    assert_true(isinf(d));
                } else if (m > 1e-3) {
                    assert_false(isinf(d));
                    assert_float_equal(d, dmax, 1e-3f * (float)dmax);
                    written++;
                }
            }
    }
    assert_true(written > 20000); /* the polygons cover cells */
    hz_occlusion_free(&o);
}

/* Pixel samples (hz_occlusion_set_viewport). World x of pixel column x at
 * 10 m ahead of a camera at the origin looking down -z (60 degrees, 16:9),
 * for an image W pixels wide. */
static float wall_x(float x, float W)
{
    return (x / W * 2.0f - 1.0f) * tanf(glm_rad(30.0f)) * (16.0f / 9.0f) * 10.0f;
}

/* A wall at 10 m from pixel column x0 to x1, image rows 180-540 of 720. */
static void wall_quad(float x0, float x1, float W, float q[12])
{
    const float y0 = -0.25f * tanf(glm_rad(30.0f)) * 20.0f, y1 = -y0;
    const float v[12] = {wall_x(x0, W), y0, -10, wall_x(x1, W), y0, -10,
                         wall_x(x1, W), y1, -10, wall_x(x0, W), y1, -10};
    memcpy(q, v, sizeof v);
}

/* G4 with pixel samples: walls side by side, their common edges through
 * the cells, hide what is behind them together; a gap that holds pixel
 * centres does not, one between two centres does (nothing drawn shows
 * there); two buffers merge their partial cells. */
static void test_occlusion_samples(void **state)
{
    (void)state;
    hz_occlusion o, o2;
    assert_true(hz_occlusion_init(&o, 160, 90));
    assert_true(hz_occlusion_init(&o2, 160, 90));
    /* Cells of more than 8 x 8 pixels, or no image: no samples. */
    assert_false(hz_occlusion_set_viewport(&o, 1600, 900));
    assert_null(o.mask);
    assert_false(hz_occlusion_set_viewport(&o, 0, 0));
    hz_camera cam = {.pos = {0, 0, 0}, .fov_y = 60, .aspect = 16.0f / 9.0f, .znear = 0.5f, .zfar = 1000};
    const float W = 1280;
    /* Seven walls side by side from column 300.3 to 980.3, each edge
     * inside a cell (8 pixels a cell). */
    float strips[7 * 12];
    for (int k = 0; k < 7; k++)
        wall_quad(300.3f + 97.1f * (float)k, 300.3f + 97.1f * (float)(k + 1), W, strips + 12 * k);
    /* A box 2 m wide behind the walls, 20 m away, across the seams. */
    hz_box behind = {{-4, -1, -21}, {4, 1, -19}};
    for (int samples = 0; samples < 2; samples++) {
        assert_int_equal(hz_occlusion_set_viewport(&o, samples ? 1280 : 0, samples ? 720 : 0), samples);
        hz_occlusion_begin(&o, &cam);
        hz_occlusion_rasterize_quads(&o, strips, 7, NULL);
        assert_int_equal(hz_occlusion_box_hidden(&o, &behind), samples);
    }
    /* Two walls with a gap between: 640.2-640.8 holds the centres of
     * column 640 (640.5): the box behind shows through it. 640.6-641.4
     * holds none: hidden. */
    const float gaps[2][2] = {{640.2f, 640.8f}, {640.6f, 641.4f}};
    for (int g = 0; g < 2; g++) {
        float two[24];
        wall_quad(300.3f, gaps[g][0], W, two);
        wall_quad(gaps[g][1], 980.3f, W, two + 12);
        hz_occlusion_begin(&o, &cam);
        hz_occlusion_rasterize_quads(&o, two, 2, NULL);
        assert_int_equal(hz_occlusion_box_hidden(&o, &behind), g == 1);
    }
    /* Merged: the odd walls in one buffer, the even ones in the other. */
    for (int samples = 0; samples < 2; samples++) {
        hz_occlusion_set_viewport(&o, samples ? 1280 : 0, samples ? 720 : 0);
        hz_occlusion_set_viewport(&o2, samples ? 1280 : 0, samples ? 720 : 0);
        hz_occlusion_begin(&o, &cam);
        hz_occlusion_begin(&o2, &cam);
        for (int k = 0; k < 7; k++)
            hz_occlusion_rasterize_quads(k & 1 ? &o2 : &o, strips + 12 * k, 1, NULL);
        assert_false(hz_occlusion_box_hidden(&o, &behind));
        assert_true(hz_occlusion_merge(&o, &o2));
        assert_int_equal(hz_occlusion_box_hidden(&o, &behind), samples);
    }
    hz_occlusion_free(&o2);
    /* Against brute force, for random polygons and polygons cut in pieces
     * (sharing edges), at 1280 x 720 (8 pixels a cell) and 1000 x 600
     * (6.25 x 6.67): every cell covered has each of its pixel centres
     * inside a polygon no farther than the cell's depth, and no cell is
     * farther than the whole-cell rule alone makes it. */
    const uint32_t sizes[2][2] = {{1280, 720}, {1000, 600}};
    hz_occlusion ref;
    assert_true(hz_occlusion_init(&ref, 160, 90));
    uint32_t rng = 777;
    long gained = 0, checked = 0;
    for (int scene = 0; scene < 60; scene++) {
        const uint32_t PW = sizes[scene & 1][0], PH = sizes[scene & 1][1];
        assert_true(hz_occlusion_set_viewport(&o, PW, PH));
        float q[8 * 12];
        int nq = 0;
        while (nq < 8) {
            float c[3], u[3], v[3];
            for (int a = 0; a < 3; a++) {
                rng = rng * 1664525u + 1013904223u;
                c[a] = (float)(rng >> 8) / 16777216.0f;
                rng = rng * 1664525u + 1013904223u;
                u[a] = ((float)(rng >> 8) / 16777216.0f - 0.5f) * 16.0f;
                rng = rng * 1664525u + 1013904223u;
                v[a] = ((float)(rng >> 8) / 16777216.0f - 0.5f) * 16.0f;
            }
            const float z = -2.0f - 38.0f * c[2];
            const float cx = (c[0] - 0.5f) * 1.6f * -z, cy = (c[1] - 0.5f) * 0.9f * -z;
            /* a quad (u, v parallelogram) in 1 to 4 pieces along u */
            const int pieces = 1 + (int)(rng >> 30);
            float cut[5] = {-1, 0, 0, 0, 1};
            for (int k = 1; k < pieces; k++)
                cut[k] = -1.0f + 2.0f * (float)k / (float)pieces + 0.13f;
            cut[pieces] = 1;
            for (int k = 0; k < pieces && nq < 8; k++, nq++) {
                const float fu[4] = {cut[k], cut[k + 1], cut[k + 1], cut[k]}, fv[4] = {-1, -1, 1, 1};
                for (int m = 0; m < 4; m++)
                    for (int a = 0; a < 3; a++)
                        q[12 * nq + 3 * m + a] = (a == 0 ? cx : a == 1 ? cy : z) + fu[m] * u[a] + fv[m] * v[a];
            }
        }
        hz_occlusion_begin(&o, &cam);
        hz_occlusion_begin(&ref, &cam);
        hz_occlusion_rasterize_quads(&o, q, (size_t)nq, NULL);
        hz_occlusion_rasterize_quads(&ref, q, (size_t)nq, NULL);
        /* Each polygon on screen, in pixels (double), and its depth. */
        double sc[8][4][2], dmax[8];
        bool front[8];
        for (int t = 0; t < nq; t++) {
            dmax[t] = 0;
            front[t] = true;
            for (int k = 0; k < 4; k++) {
                const float *pk = q + 12 * t + 3 * k;
                double cl[4];
                for (int r = 0; r < 4; r++)
                    cl[r] = o.viewproj[0][r] * pk[0] + o.viewproj[1][r] * pk[1] + o.viewproj[2][r] * pk[2] +
                            o.viewproj[3][r];
                front[t] = front[t] && cl[3] >= cam.znear;
                sc[t][k][0] = (cl[0] / cl[3] * 0.5 + 0.5) * PW;
                sc[t][k][1] = (cl[1] / cl[3] * 0.5 + 0.5) * PH;
                dmax[t] = fmax(dmax[t], cl[3]);
            }
        }
        for (uint32_t py = 0; py < PH; py++) {
            const uint32_t j = (uint32_t)(((double)py + 0.5) * o.h / PH);
            for (uint32_t px = 0; px < PW; px++) {
                const uint32_t i = (uint32_t)(((double)px + 0.5) * o.w / PW);
                const float d = o.depth[(size_t)j * o.w + i];
                if (isinf(d))
                    continue;
                bool ok = false;
                for (int t = 0; t < nq && !ok; t++)
                    ok = front[t] && dmax[t] <= (double)d * (1 + 1e-5) &&
                         poly_margin(sc[t], 4, px + 0.5, py + 0.5) >= -1e-4;
                assert_true(ok);
                checked++;
            }
        }
        for (size_t k = 0; k < (size_t)o.w * o.h; k++) {
            assert_true(o.depth[k] <= ref.depth[k]);
            gained += o.depth[k] < ref.depth[k];
        }
    }
    assert_true(checked > 1000000); /* covered pixels checked */
    assert_true(gained > 2000);     /* cells only the samples cover (or cover nearer) */
    hz_occlusion_free(&ref);
    hz_occlusion_free(&o);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_inheritance),     cmocka_unit_test(test_ypr),
        cmocka_unit_test(test_bounds_after_move), cmocka_unit_test(test_frustum_culling),
        cmocka_unit_test(test_render_queue),    cmocka_unit_test(test_raycast), cmocka_unit_test(test_ground_heights),
        cmocka_unit_test(test_sort_near_first),
        cmocka_unit_test(test_depth_first),     cmocka_unit_test(test_occlusion), cmocka_unit_test(test_occlusion_raster_exact),
        cmocka_unit_test(test_occlusion_samples),
        cmocka_unit_test(test_cull_occluded),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
