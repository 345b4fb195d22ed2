/* Trees (SPEC F1), tree files, VMI (F2), hulls (F5), the rate function
 * (F3, F4, F6) and forest selection. CPU only, no GL. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "horizon/forest.h"
#include "horizon/tree.h"

#define assert_double_equal(a, b, eps) assert_true(fabs((double)(a) - (double)(b)) <= (eps))

static hz_tree *small_tree(const char *species, uint64_t seed)
{
    hz_err err = {0};
    hz_tree *t = hz_tree_grow(&(hz_tree_desc){.species = species, .seed = seed, .leaves = 1500}, &err);
    if (!t)
        fail_msg("grow: %s", err.msg);
    return t;
}

/* ---- F1: growth and hierarchy ------------------------------------------------- */

static void test_grow_repeatable(void **state)
{
    (void)state;
    for (const char *const *sp = hz_tree_species_names(); *sp; sp++) {
        hz_tree *a = small_tree(*sp, 7), *b = small_tree(*sp, 7), *c = small_tree(*sp, 8);
        hz_err err = {0};
        uint8_t *da, *db, *dc;
        size_t na, nb, nc;
        assert_int_equal(hz_tree_save_mem(a, &da, &na, &err), HZ_OK);
        assert_int_equal(hz_tree_save_mem(b, &db, &nb, &err), HZ_OK);
        assert_int_equal(hz_tree_save_mem(c, &dc, &nc, &err), HZ_OK);
        assert_int_equal(na, nb);
        assert_memory_equal(da, db, na); /* same seed: the same tree, byte for byte */
        assert_true(nc != na || memcmp(da, dc, na) != 0); /* another seed: another tree */
        free(da);
        free(db);
        free(dc);
        hz_tree_destroy(a);
        hz_tree_destroy(b);
        hz_tree_destroy(c);
    }
}

static void test_hierarchy_consistent(void **state)
{
    (void)state;
    for (const char *const *sp = hz_tree_species_names(); *sp; sp++) {
        hz_tree *t = small_tree(*sp, 3);
        hz_err err = {0};
        assert_int_equal(hz_tree_validate(t, &err), HZ_OK);
        /* Trunk first, levels = parent + 1, leaf nodes only on last-level branches. */
        assert_int_equal(t->branches[0].level, 1);
        assert_int_equal(t->branches[0].parent, HZ_TREE_NONE);
        for (uint32_t b = 1; b < t->branch_count; b++) {
            assert_true(t->branches[b].parent < b);
            assert_int_equal(t->branches[b].level, t->branches[t->branches[b].parent].level + 1);
        }
        /* Every leaf in exactly one node. */
        uint8_t *seen = calloc(t->leaf_count, 1);
        for (uint32_t n = 0; n < t->node_count; n++) {
            const hz_tree_node *nd = &t->nodes[n];
            assert_int_equal(t->branches[nd->branch].level, t->levels);
            assert_int_equal(t->branches[nd->branch].leaf_node, n);
            assert_true(nd->bsl >= 1 && nd->bsl <= 3);
            for (uint32_t k = nd->first; k < nd->first + nd->count; k++) {
                assert_true(k < t->leaf_count);
                assert_int_equal(seen[k], 0);
                seen[k] = 1;
                /* leaves lie in their node's bounding sphere */
                float d = 0;
                for (int c = 0; c < 3; c++)
                    d += (t->leaves[k].c[c] - nd->center[c]) * (t->leaves[k].c[c] - nd->center[c]);
                assert_true(sqrtf(d) <= nd->radius);
            }
        }
        for (uint32_t k = 0; k < t->leaf_count; k++)
            assert_int_equal(seen[k], 1);
        free(seen);
        /* Bark sorted by level: the trunk's triangles come first. */
        assert_true(t->bark_level_end[0] > 0 && t->bark_level_end[0] < t->bark.index_count);
        hz_tree_destroy(t);
    }
}

static void test_species_sizes(void **state)
{
    (void)state;
    /* The species' own sizes are in the seed's range (50 000 .. 300 000 leaves). */
    for (const char *const *sp = hz_tree_species_names(); *sp; sp++) {
        hz_err err = {0};
        hz_tree *t = hz_tree_grow(&(hz_tree_desc){.species = *sp, .seed = 1}, &err);
        assert_non_null(t);
        assert_true(t->leaf_count >= 50000 && t->leaf_count <= 300000);
        assert_true(t->height > 8.0f && t->height < 30.0f);
        hz_tree_destroy(t);
    }
    hz_err err = {0};
    assert_null(hz_tree_grow(&(hz_tree_desc){.species = "baobab"}, &err));
    assert_int_equal(err.code, HZ_ERR_VALUE);
    assert_non_null(strstr(err.msg, "baobab"));
    assert_null(hz_tree_grow(&(hz_tree_desc){.species = "oak", .leaves = 5000000}, &err));
}

/* ---- tree files -------------------------------------------------------------------- */

static void test_file_roundtrip(void **state)
{
    (void)state;
    hz_tree *t = small_tree("maple", 2);
    hz_err err = {0};
    assert_int_equal(hz_hull_build(t, NULL, NULL, &err), HZ_OK);
    char path[512];
    snprintf(path, sizeof path, "%s/roundtrip.hzt", HZ_TEST_TMP);
    assert_int_equal(hz_tree_save(t, path, &err), HZ_OK);
    hz_tree *u = hz_tree_load(path, &err);
    assert_non_null(u);
    assert_string_equal(u->species, "maple");
    assert_int_equal(u->leaf_count, t->leaf_count);
    assert_int_equal(u->node_count, t->node_count);
    assert_int_equal(u->branch_count, t->branch_count);
    assert_int_equal(u->hull.index_count, t->hull.index_count);
    assert_memory_equal(u->leaves, t->leaves, t->leaf_count * sizeof *t->leaves);
    for (uint32_t n = 0; n < t->node_count; n++) {
        assert_int_equal(u->nodes[n].bsl, t->nodes[n].bsl);
        assert_float_equal(u->nodes[n].radius, t->nodes[n].radius, 1e-6);
    }
    hz_tree_destroy(u);
    /* missing file, not a tree file */
    assert_null(hz_tree_load("/nonexistent/x.hzt", &err));
    assert_int_equal(err.code, HZ_ERR_IO);
    assert_non_null(strstr(err.msg, "/nonexistent/x.hzt"));
    const uint8_t junk[64] = "this is not a tree file at all, it is text..";
    assert_null(hz_tree_load_mem(junk, sizeof junk, &err));
    assert_int_equal(err.code, HZ_ERR_FORMAT);
    hz_tree_destroy(t);
}

static uint64_t fz = 0x1234567;
static uint32_t fuzz_rand(void)
{
    fz ^= fz << 13, fz ^= fz >> 7, fz ^= fz << 17;
    return (uint32_t)(fz >> 11);
}

static void fix_crc(uint8_t *d, size_t n)
{
    uint32_t c = hz_tree_crc32(d, n - 4);
    d[n - 4] = (uint8_t)c, d[n - 3] = (uint8_t)(c >> 8), d[n - 2] = (uint8_t)(c >> 16), d[n - 1] = (uint8_t)(c >> 24);
}

static void test_file_fuzz(void **state)
{
    (void)state;
    hz_err err = {0};
    hz_tree *t = hz_tree_grow(&(hz_tree_desc){.species = "birch", .seed = 1, .leaves = 200}, &err);
    assert_non_null(t);
    assert_int_equal(hz_hull_build(t, &(hz_hull_desc){.grid = 16, .triangles = 100}, NULL, &err), HZ_OK);
    uint8_t *good;
    size_t n;
    assert_int_equal(hz_tree_save_mem(t, &good, &n, &err), HZ_OK);
    uint8_t *buf = malloc(n);
    int accepted = 0, rejected = 0;
    for (int it = 0; it < 3000; it++) {
        memcpy(buf, good, n);
        size_t len = n;
        int kind = it % 4;
        if (kind == 0) {
            len = fuzz_rand() % n; /* truncated */
        } else {
            int flips = 1 + (int)(fuzz_rand() % 8);
            /* Mostly the header and tables, where counts and indices live. */
            for (int f = 0; f < flips; f++) {
                size_t at = kind == 1 ? fuzz_rand() % (n < 4096 ? n : 4096) : fuzz_rand() % n;
                buf[at] = kind == 3 ? (uint8_t)0xff : (uint8_t)fuzz_rand();
            }
            if (kind != 2)
                fix_crc(buf, len); /* get past the CRC to the structure checks */
        }
        hz_err e = {0};
        hz_tree *u = hz_tree_load_mem(buf, len, &e);
        if (u) {
            /* Whatever is accepted must be a valid tree. */
            assert_int_equal(hz_tree_validate(u, &e), HZ_OK);
            accepted++;
            hz_tree_destroy(u);
        } else {
            if (e.code != HZ_ERR_FORMAT && e.code != HZ_ERR_MEMORY)
                fail_msg("unexpected error %d: %s", e.code, e.msg);
            assert_true(strlen(e.msg) > 10);
            rejected++;
        }
    }
    assert_true(rejected > 2000);
    (void)accepted;
    free(buf);
    free(good);
    hz_tree_destroy(t);
}

/* ---- F2: VMI ---------------------------------------------------------------------- */

static void test_vmi_hand_computed(void **state)
{
    (void)state;
    /* Two leaves, two views. View 0: leaf 0 covers 3 pixels, leaf 1 covers 1.
     * View 1: leaf 0 covers 1, leaf 1 covers 1.
     * p(o|v): v0 = (3/4, 1/4), v1 = (1/2, 1/2); p(o) = (5/8, 3/8).
     * I(v0) = 3/4 log2((3/4)/(5/8)) + 1/4 log2((1/4)/(3/8))
     * I(v1) = 1/2 log2((1/2)/(5/8)) + 1/2 log2((1/2)/(3/8)) */
    const uint32_t counts[4] = {3, 1, /* leaf 0: views 0, 1 */ 1, 1 /* leaf 1 */};
    double I[2];
    hz_vmi_compute(counts, 2, 2, I);
    double i0 = 0.75 * log2(0.75 / 0.625) + 0.25 * log2(0.25 / 0.375);
    double i1 = 0.5 * log2(0.5 / 0.625) + 0.5 * log2(0.5 / 0.375);
    assert_double_equal(I[0], i0, 1e-12);
    assert_double_equal(I[1], i1, 1e-12);
    assert_double_equal(i0, 0.0510353, 1e-6); /* the numbers, by hand */
    assert_double_equal(i1, 0.0465546, 1e-6);

    /* The same scene as item-buffer pixel lists: ranking must keep leaf 0
     * (more pixels, its removal changes I more) ahead of leaf 1. */
    const uint32_t vs[3] = {0, 4, 6};
    const uint16_t ids[6] = {0, 0, 0, 1, 0, 1};
    uint32_t order[2];
    hz_vmi_input in = {.leaf_count = 2, .view_count = 2, .layers = 1, .view_start = vs, .ids = ids};
    hz_err err = {0};
    assert_int_equal(hz_vmi_rank(&in, order, NULL, &err), HZ_OK);
    assert_int_equal(order[0], 0);
    assert_int_equal(order[1], 1);
}

static void test_vmi_occluded_ranks_below_exposed(void **state)
{
    (void)state;
    /* Leaf 0 exposed everywhere; leaf 1 always hidden behind leaf 0; leaf 2
     * exposed in its own pixels. Layers front to back. */
    enum { L = 2 };
    uint16_t ids[64 * L];
    uint32_t vs[4] = {0};
    size_t p = 0;
    for (int v = 0; v < 3; v++) {
        vs[v] = (uint32_t)p;
        for (int k = 0; k < 8; k++, p++) {
            ids[p * L] = 0;
            ids[p * L + 1] = 1; /* behind 0 */
        }
        for (int k = 0; k < 3 + v; k++, p++) {
            ids[p * L] = 2;
            ids[p * L + 1] = HZ_VMI_EMPTY;
        }
    }
    vs[3] = (uint32_t)p;
    uint32_t order[3];
    hz_vmi_stats st;
    hz_err err = {0};
    hz_vmi_input in = {.leaf_count = 3, .view_count = 3, .layers = L, .view_start = vs, .ids = ids};
    assert_int_equal(hz_vmi_rank(&in, order, &st, &err), HZ_OK);
    assert_int_equal(order[2], 1); /* the occluded leaf is the least important */
    assert_int_equal(st.steps, 3);
    /* ids out of range are refused */
    ids[0] = 7;
    assert_int_equal(hz_vmi_rank(&in, order, NULL, &err), HZ_ERR_VALUE);
}

/* Reference greedy: recount everything from the pixel lists at each step. */
static void brute_rank(uint32_t n, uint32_t nv, uint32_t L, const uint32_t *vs, const uint16_t *ids, uint32_t *order)
{
    uint8_t removed[64] = {0};
    uint32_t *cnt = malloc(n * nv * sizeof *cnt);
    double I0[16], I1[16];
    for (uint32_t step = 0; step < n; step++) {
        double best = INFINITY;
        uint32_t bx = 0, bvis = UINT32_MAX;
        for (int pass = -1; pass < (int)n; pass++) {
            if (pass >= 0 && removed[pass])
                continue;
            memset(cnt, 0, n * nv * sizeof *cnt);
            for (uint32_t v = 0; v < nv; v++)
                for (uint32_t p = vs[v]; p < vs[v + 1]; p++)
                    for (uint32_t l = 0; l < L; l++) {
                        uint16_t id = ids[p * L + l];
                        if (id == HZ_VMI_EMPTY)
                            break;
                        if (removed[id] || (int)id == pass)
                            continue;
                        cnt[id * nv + v]++;
                        break;
                    }
            if (pass < 0) {
                hz_vmi_compute(cnt, n, nv, I0);
                continue;
            }
            hz_vmi_compute(cnt, n, nv, I1);
            double e = 0;
            for (uint32_t v = 0; v < nv; v++)
                e += fabs(I0[v] - I1[v]);
            /* visible front pixels of the candidate, for the tie-break */
            uint32_t vis = 0;
            for (uint32_t v = 0; v < nv; v++)
                for (uint32_t p = vs[v]; p < vs[v + 1]; p++)
                    for (uint32_t l = 0; l < L; l++) {
                        uint16_t id = ids[p * L + l];
                        if (id == HZ_VMI_EMPTY)
                            break;
                        if (removed[id])
                            continue;
                        vis += id == (uint32_t)pass;
                        break;
                    }
            if (vis == 0)
                e = 0;
            if (e < best - 1e-12 || (fabs(e - best) <= 1e-12 && vis < bvis)) {
                best = e;
                bx = (uint32_t)pass;
                bvis = vis;
            }
        }
        removed[bx] = 1;
        order[n - 1 - step] = bx;
    }
    free(cnt);
}

static void test_vmi_incremental_matches_brute_force(void **state)
{
    (void)state;
    for (int trial = 0; trial < 20; trial++) {
        uint32_t n = 3 + fuzz_rand() % 8, nv = 2 + fuzz_rand() % 5, L = 1 + fuzz_rand() % 3;
        uint32_t vs[17];
        uint16_t *ids = malloc(2000 * L * sizeof *ids);
        uint32_t p = 0;
        for (uint32_t v = 0; v < nv; v++) {
            vs[v] = p;
            uint32_t px = 20 + fuzz_rand() % 60;
            for (uint32_t k = 0; k < px; k++, p++) {
                /* distinct ids front to back */
                uint32_t depth = 1 + fuzz_rand() % L;
                uint16_t used[8];
                for (uint32_t l = 0; l < L; l++) {
                    uint16_t id = HZ_VMI_EMPTY;
                    if (l < depth) {
                        bool dup;
                        do {
                            id = (uint16_t)(fuzz_rand() % n);
                            dup = false;
                            for (uint32_t q = 0; q < l; q++)
                                dup |= used[q] == id;
                        } while (dup);
                    }
                    used[l] = id;
                    ids[p * L + l] = id;
                }
            }
        }
        vs[nv] = p;
        uint32_t a[16], b[16];
        hz_err err = {0};
        hz_vmi_input in = {.leaf_count = n, .view_count = nv, .layers = L, .view_start = vs, .ids = ids};
        assert_int_equal(hz_vmi_rank(&in, a, NULL, &err), HZ_OK);
        brute_rank(n, nv, L, vs, ids, b);
        assert_memory_equal(a, b, n * sizeof *a);
        free(ids);
    }
}

static void test_sphere_views(void **state)
{
    (void)state;
    const uint32_t counts[3] = {12, 42, 162};
    float d[162 * 3];
    for (int k = 0; k < 3; k++) {
        assert_true(hz_sphere_views(counts[k], d));
        float minsep = 10;
        for (uint32_t i = 0; i < counts[k]; i++) {
            float l = sqrtf(d[i * 3] * d[i * 3] + d[i * 3 + 1] * d[i * 3 + 1] + d[i * 3 + 2] * d[i * 3 + 2]);
            assert_float_equal(l, 1.0f, 1e-5);
            for (uint32_t j = 0; j < i; j++) {
                float dx = d[i * 3] - d[j * 3], dy = d[i * 3 + 1] - d[j * 3 + 1], dz = d[i * 3 + 2] - d[j * 3 + 2];
                minsep = fminf(minsep, sqrtf(dx * dx + dy * dy + dz * dz));
            }
        }
        assert_true(minsep > 0.8f * 4.0f / sqrtf((float)counts[k])); /* roughly even */
    }
    assert_false(hz_sphere_views(20, d));
}

/* ---- F5: hull ------------------------------------------------------------------------ */

static void test_hull_closed_manifold(void **state)
{
    (void)state;
    for (const char *const *sp = hz_tree_species_names(); *sp; sp++) {
        hz_tree *t = small_tree(*sp, 5);
        hz_err err = {0};
        hz_hull_stats hs;
        assert_int_equal(hz_hull_build(t, &(hz_hull_desc){.triangles = 1500}, &hs, &err), HZ_OK);
        hz_mesh_topology topo;
        assert_int_equal(hz_mesh_check(t->hull.idx, t->hull.index_count, t->hull.vertex_count, &topo, &err), HZ_OK);
        assert_true(t->hull.index_count >= 3 * 16);
        assert_int_equal(topo.bad_edges, 0);
        assert_int_equal(topo.bad_vertices, 0);
        assert_int_equal(topo.degenerate, 0);
        assert_true(hs.triangles <= hs.raw_triangles / 2); /* simplified, not the raw fallback */
        /* Normals point outwards: the signed volume is positive. */
        double vol = 0;
        for (uint32_t k = 0; k < t->hull.index_count; k += 3) {
            const float *a = &t->hull.pos[t->hull.idx[k] * 3], *b = &t->hull.pos[t->hull.idx[k + 1] * 3],
                        *c = &t->hull.pos[t->hull.idx[k + 2] * 3];
            vol += (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
                    a[2] * (b[0] * c[1] - b[1] * c[0])) / 6.0;
        }
        assert_true(vol > 0);
        assert_int_equal(hz_tree_validate(t, &err), HZ_OK);
        hz_tree_destroy(t);
    }
}

static void test_mesh_check_detects_holes(void **state)
{
    (void)state;
    /* A tetrahedron is closed; without one face it is open. */
    const uint32_t tet[12] = {0, 2, 1, 0, 1, 3, 1, 2, 3, 2, 0, 3};
    hz_mesh_topology t;
    hz_err err = {0};
    assert_int_equal(hz_mesh_check(tet, 12, 4, &t, &err), HZ_OK);
    assert_int_equal(t.bad_edges, 0);
    assert_int_equal(t.bad_vertices, 0);
    assert_int_equal(t.euler, 2);
    assert_int_equal(hz_mesh_check(tet, 9, 4, &t, &err), HZ_OK);
    assert_int_equal(t.bad_edges, 3);
    /* Two tetrahedra sharing one vertex: edges fine, the vertex is pinched. */
    const uint32_t two[24] = {0, 2, 1, 0, 1, 3, 1, 2, 3, 2, 0, 3, 0, 5, 4, 0, 4, 6, 4, 5, 6, 5, 0, 6};
    assert_int_equal(hz_mesh_check(two, 24, 7, &t, &err), HZ_OK);
    assert_int_equal(t.bad_edges, 0);
    assert_int_equal(t.bad_vertices, 1);
}

/* ---- F3, F4, F6 ---------------------------------------------------------------------- */

static void test_rate_break_points(void **state)
{
    (void)state;
    hz_rate_params p = hz_rate_params_defaults(NULL);
    assert_float_equal(p.w[0] + p.w[1] + p.w[2] + p.w[3] + p.w[4], 1.0f, 1e-6);
    assert_float_equal(p.w[3], 0.3f, 1e-6);
    /* f1: layers */
    assert_float_equal(hz_rate_f1(1), 0.0f, 0);
    assert_float_equal(hz_rate_f1(2), 0.4f, 1e-6);
    assert_float_equal(hz_rate_f1(3), 0.8f, 1e-6);
    /* f4: 0 up to near, k3 log10(d) between, 1 from far */
    assert_float_equal(hz_rate_f4(&p, p.near_m), 0.0f, 0);
    assert_float_equal(hz_rate_f4(&p, 50.0f), log10f(50.0f) / log10f(p.far_m), 1e-6);
    assert_float_equal(hz_rate_f4(&p, p.far_m - 1e-3f), 1.0f, 1e-4);
    assert_float_equal(hz_rate_f4(&p, p.far_m), 1.0f, 0);
    assert_float_equal(hz_rate_f4(&p, 1e6f), 1.0f, 0);
    /* f2: 0 up to near, k1 BL log_h(d) between (<= 0.5), 0.5 beyond far */
    assert_float_equal(hz_rate_f2(&p, 4, p.near_m), 0.0f, 0);
    float k1 = 0.5f / ((float)p.bl_max * (logf(p.far_m) / logf(p.h)));
    assert_float_equal(hz_rate_f2(&p, 2, 40.0f), k1 * 2.0f * logf(40.0f) / logf(p.h), 1e-6);
    assert_float_equal(hz_rate_f2(&p, p.bl_max, p.far_m), 0.5f, 1e-5);
    assert_float_equal(hz_rate_f2(&p, 1, p.far_m + 1), 0.5f, 0);
    assert_true(hz_rate_f2(&p, 1, 40.0f) < hz_rate_f2(&p, 3, 40.0f)); /* low branches simplify less */
    /* f3: zero at ld0, positive above, negative below, k2 = 1/ld0 */
    assert_float_equal(hz_rate_f3(2.0f, 2.0f), 0.0f, 0);
    assert_float_equal(hz_rate_f3(3.0f, 2.0f), 0.5f, 1e-6);
    assert_float_equal(hz_rate_f3(1.0f, 2.0f), -0.5f, 1e-6);
    /* f5: cos in [0, pi/2], 0 beyond */
    assert_float_equal(hz_rate_f5(1.0f), 1.0f, 0);
    assert_float_equal(hz_rate_f5(cosf(1.0f)), cosf(1.0f), 1e-6);
    assert_float_equal(hz_rate_f5(0.0f), 0.0f, 0);
    assert_float_equal(hz_rate_f5(-0.5f), 0.0f, 0);
    /* The weighted sum. */
    float rs = hz_rate_node(&p, 2, 3, 40.0f, 3.0f, 2.0f, 0.5f);
    float want = 0.2f * 0.4f + 0.1f * hz_rate_f2(&p, 3, 40.0f) + 0.2f * 0.5f + 0.3f * hz_rate_f4(&p, 40.0f) + 0.2f * 0.5f;
    assert_float_equal(rs, want, 1e-6);
    assert_float_equal(hz_rate_node(&p, 1, 1, 1.0f, 1.0f, 2.0f, -1.0f), 0.0f, 0); /* clamped at 0 */
    /* The fixed point: the rate computed with LD = ld x (1 - that rate). */
    for (int k = 0; k < 4; k++) {
        float ld = 2.0f + 3.0f * (float)k, dist = 10.0f + 15.0f * (float)k;
        float R = hz_rate_node_fixed(&p, 2, 3, dist, ld, 2.0f, 0.3f);
        assert_true(R > 0.0f && R < p.max_rate);
        assert_float_equal(hz_rate_node(&p, 2, 3, dist, ld * (1.0f - R), 2.0f, 0.3f), R, 1e-5);
    }
    assert_float_equal(hz_rate_node(&p, 3, 4, 1e5f, 50.0f, 1.0f, 1.0f), p.max_rate, 0);
    /* F4: s = sqrt((1-Rl)/(1-Rc)) compounded from R = 0 */
    assert_float_equal(hz_enlarge(&p, 100, 50), sqrtf(2.0f), 1e-6);
    assert_float_equal(hz_enlarge(&p, 100, 100), 1.0f, 0);
    assert_float_equal(hz_enlarge(&p, 100, 1), p.max_enlarge, 0);
    /* F6: near always; far needs big changes held long */
    assert_true(hz_hysteresis_allows(&p, p.near_m, 0.001f, 0.0f));
    float x = 60.0f - p.near_m, span = p.far_m - p.near_m;
    float thr_rate = powf(x / span, p.hyst_k1), thr_time = powf(x / span, p.hyst_k2);
    assert_true(hz_hysteresis_allows(&p, 60.0f, thr_rate * 1.01f, thr_time * 1.01f));
    assert_false(hz_hysteresis_allows(&p, 60.0f, thr_rate * 0.99f, thr_time * 1.01f));
    assert_false(hz_hysteresis_allows(&p, 60.0f, thr_rate * 1.01f, thr_time * 0.99f));
}

/* ---- placement and selection ------------------------------------------------------ */

static float hill(void *user, float x, float z)
{
    (void)user;
    /* flat west half, a 60-degree slope east of x = 500 */
    return x > 500.0f ? (x - 500.0f) * 1.732f : 0.0f * z;
}

static void test_place(void **state)
{
    (void)state;
    hz_forest_tree a[300], b[300];
    uint32_t na, nb;
    hz_err err = {0};
    hz_forest_desc d = {.count = 300, .seed = 4, .center = {500, 500}, .density = 300, .model_count = 3,
                        .height = hill};
    assert_int_equal(hz_forest_place(&d, a, &na, &err), HZ_OK);
    assert_int_equal(hz_forest_place(&d, b, &nb, &err), HZ_OK);
    assert_int_equal(na, 300);
    assert_int_equal(nb, na);
    assert_memory_equal(a, b, na * sizeof *a);
    const float min_dist = 0.6f * 100.0f / sqrtf(300.0f);
    for (uint32_t i = 0; i < na; i++) {
        assert_true(a[i].pos[0] <= 500.0f + 5.0f); /* none on the steep side */
        assert_true(a[i].model < 3);
        assert_true(a[i].scale >= 0.8f && a[i].scale <= 1.2f);
        for (uint32_t j = 0; j < i; j++) {
            float dx = a[i].pos[0] - a[j].pos[0], dz = a[i].pos[2] - a[j].pos[2];
            assert_true(dx * dx + dz * dz >= min_dist * min_dist * 0.999f);
        }
    }
    d.count = 0;
    assert_int_equal(hz_forest_place(&d, a, &na, &err), HZ_OK);
    assert_int_equal(na, 0);
}

static void test_select(void **state)
{
    (void)state;
    hz_tree *t = small_tree("oak", 1);
    hz_err err = {0};
    assert_int_equal(hz_hull_build(t, NULL, NULL, &err), HZ_OK);
    /* A row of trees along -z from the camera, and one behind it. */
    hz_forest_tree trees[6];
    const float zs[5] = {-12, -21, -30, -200, -260};
    for (int k = 0; k < 5; k++)
        trees[k] = (hz_forest_tree){.pos = {0, 0, zs[k]}, .scale = 1};
    trees[5] = (hz_forest_tree){.pos = {0, 0, 200}, .scale = 1};
    const hz_tree *models[1] = {t};
    hz_forest *f = hz_forest_create(models, 1, trees, 6, &err);
    assert_non_null(f);
    hz_camera cam = {.pos = {0, 6, 0}, .yaw = 0, .pitch = 0, .fov_y = 60, .aspect = 1.5f, .znear = 0.3f,
                     .zfar = 5000};
    hz_forest_frame fr;
    hz_forest_params full = {.simplify = false};
    assert_int_equal(hz_forest_update(f, &cam, &full, 0, &fr, &err), HZ_OK);
    assert_int_equal(fr.trees, 6);
    assert_int_equal(fr.trees_in_frustum, 5); /* the one behind is culled */
    assert_int_equal(fr.triangles_drawn, fr.triangles_full);
    assert_int_equal(fr.triangles_full, 5 * hz_tree_triangles(t));
    hz_forest_params simp = {.simplify = true, .enlarge = true, .hysteresis = false, .node_culling = true,
                             .hull_dist = 40};
    assert_int_equal(hz_forest_update(f, &cam, &simp, 0, &fr, &err), HZ_OK);
    assert_true(fr.triangles_drawn < fr.triangles_full);
    /* 200 m and more: beyond the impostor distance, max(far / 2, 2 x 40 m) */
    assert_int_equal(fr.trees_impostor, 2);
    assert_int_equal(fr.trees_hull, 0);
    assert_int_equal(fr.draw_count, 3);
    /* Farther detailed trees keep fewer leaves. */
    uint64_t kept[5] = {0};
    for (uint32_t d = 0; d < fr.draw_count; d++)
        if (!fr.draws[d].hull)
            for (uint32_t n = 0; n < t->node_count; n++)
                kept[fr.draws[d].tree] += fr.counts[fr.draws[d].node_base + n];
    assert_true(kept[0] > kept[1] && kept[1] > kept[2]);
    /* Enlargement gives back the coverage the kept prefix lost (F4 by coverage). */
    float *cov = malloc(t->leaf_count * sizeof *cov);
    assert_int_equal(hz_tree_prefix_coverage(t, cov, &err), HZ_OK);
    uint32_t enlarged = 0;
    for (uint32_t n = 0; n < t->node_count; n++)
        if (fr.counts[n] && fr.counts[n] < t->nodes[n].count) {
            float c = cov[t->nodes[n].first + fr.counts[n] - 1];
            assert_float_equal(fr.scales[n], fminf(sqrtf(1.0f / c), 3.0f), 1e-5);
            enlarged += fr.scales[n] > 1.0f;
        }
    assert_true(enlarged > 0);
    free(cov);
    /* Nothing changed, nothing to upload: rates are a function of the view
     * (F3's density at the rate being set), so the same view again leaves
     * every node's count as it was, hysteresis or not. */
    hz_forest_params fx = simp;
    assert_true(fr.upload_bytes > 0);
    assert_true(fr.upload_bytes > 0);
    uint32_t prefix0 = fr.draws[0].prefix;
    assert_true(prefix0 > 0 && prefix0 <= t->leaf_count);
    assert_int_equal(hz_forest_update(f, &cam, &fx, 0.5, &fr, &err), HZ_OK);
    assert_int_equal(fr.upload_bytes, 0);
    assert_int_equal(fr.nodes_changed, 0);
    for (uint32_t d = 0; d < fr.draw_count; d++)
        assert_true(fr.draws[d].dirty_lo >= fr.draws[d].dirty_hi);
    assert_int_equal(fr.draws[0].prefix, prefix0);
    /* The drawn ranges hold every node's kept leaves (in interleaved order,
     * per group), and not many more. */
    const uint32_t *pos = hz_forest_model_pos(f, 0), *gf = hz_forest_model_groups(f, 0);
    const hz_forest_draw *d0 = &fr.draws[0];
    assert_ptr_equal(d0->group_first, gf);
    uint32_t sum = 0;
    uint64_t kept_leaves = 0;
    for (uint32_t g = 0; g < HZ_FOREST_GROUPS; g++) {
        assert_true(gf[g] <= gf[g + 1] && d0->group_count[g] <= gf[g + 1] - gf[g]);
        sum += d0->group_count[g];
    }
    assert_int_equal(sum, d0->prefix);
    for (uint32_t n = 0; n < t->node_count; n++)
        for (uint32_t i = 0; i < fr.counts[d0->node_base + n]; i++) {
            uint32_t p = pos[t->nodes[n].first + i], g = 0;
            while (g < HZ_FOREST_GROUPS && p >= gf[g + 1])
                g++;
            assert_true(g < HZ_FOREST_GROUPS);
            assert_true(p < gf[g] + d0->group_count[g]);
            kept_leaves++;
        }
    print_message("drawn %u leaf positions for %llu kept leaves (%.2fx)\n", d0->prefix, (unsigned long long)kept_leaves,
                  (double)d0->prefix / (double)kept_leaves);
    assert_true((double)d0->prefix <= 1.3 * (double)kept_leaves);
    /* Hysteresis: a small move later does not change far nodes' rates. */
    hz_forest_params hy = simp;
    hy.hysteresis = true;
    hz_forest_reset(f);
    assert_int_equal(hz_forest_update(f, &cam, &hy, 0.0, &fr, &err), HZ_OK);
    cam.pos[2] -= 1.0f;
    assert_int_equal(hz_forest_update(f, &cam, &hy, 0.05, &fr, &err), HZ_OK);
    assert_true(fr.nodes_held > 0);
    hz_forest_reset(f);
    assert_int_equal(hz_forest_update(f, &cam, &simp, 0.0, &fr, &err), HZ_OK);
    cam.pos[2] += 1.0f;
    assert_int_equal(hz_forest_update(f, &cam, &simp, 0.05, &fr, &err), HZ_OK);
    assert_int_equal(fr.nodes_held, 0);
    hz_forest_destroy(f);
    hz_tree_destroy(t);
}

static void test_import_obj(void **state)
{
    (void)state;
    hz_err err = {0};
    hz_tree *t = hz_tree_import(&(hz_tree_import_desc){.path = HZ_DATA_DIR "/trees/white_birch.obj"}, &err);
    if (!t)
        fail_msg("import: %s", err.msg);
    /* 1 295 separate leaves (PROVENANCE.md), bark in 215 pieces. */
    assert_int_equal(t->leaf_count, 1295);
    assert_int_equal(hz_tree_validate(t, &err), HZ_OK);
    assert_true(t->height > 2.0f);
    assert_true(t->branches[0].level == 1 && t->levels == 3);
    hz_tree_destroy(t);
    /* A file with no leaf meshes under that name. */
    assert_null(hz_tree_import(&(hz_tree_import_desc){.path = HZ_DATA_DIR "/trees/white_birch.obj",
                                                      .leaf_match = "petal"}, &err));
    assert_int_equal(err.code, HZ_ERR_FORMAT);
    assert_non_null(strstr(err.msg, "petal"));
    assert_null(hz_tree_import(&(hz_tree_import_desc){.path = "/nonexistent.obj"}, &err));
    /* A leaf mesh whose second face points past its 3 vertices (assimp's
     * PLY reader passes it on): refused, not read out of bounds. */
    FILE *ply = fopen(HZ_TEST_TMP "/bad_index_leaf.ply", "w");
    assert_non_null(ply);
    fputs("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
          "element face 2\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"
          "3 0 1 7\n", ply);
    fclose(ply);
    assert_null(hz_tree_import(&(hz_tree_import_desc){.path = HZ_TEST_TMP "/bad_index_leaf.ply"}, &err));
    print_message("bad index: %s\n", err.msg);
    assert_non_null(strstr(err.msg, "out of range"));
    /* A trunk 1e38 m tall, with a leaf: finite, but no tree. Refused with the
     * file's name, as the .hzt reader would refuse the file. */
    FILE *obj = fopen(HZ_TEST_TMP "/tall_trunk.obj", "w");
    assert_non_null(obj);
    fputs("o trunk\nv 0 0 0\nv 0.1 0 0\nv 0 1e38 0\nf 1 2 3\no leaves\nv 0 1 0\nv 0.1 1 0\nv 0 1.1 0\nf 4 5 6\n",
          obj);
    fclose(obj);
    assert_null(hz_tree_import(&(hz_tree_import_desc){.path = HZ_TEST_TMP "/tall_trunk.obj"}, &err));
    print_message("tall trunk: %s\n", err.msg);
    assert_int_equal(err.code, HZ_ERR_FORMAT);
    assert_non_null(strstr(err.msg, "tall_trunk.obj"));
    assert_non_null(strstr(err.msg, "beyond 1000000 m"));
    /* A NaN in a leaf: refused naming the mesh and its vertex, not an inner
     * branch of the hierarchy built from it. */
    obj = fopen(HZ_TEST_TMP "/nan_leaf.obj", "w");
    assert_non_null(obj);
    fputs("o trunk\nv 0 0 0\nv 0.1 0 0\nv 0 3 0\nf 1 2 3\no leaves\nv 0 1 0\nv 0.1 nan 0\nv 0 1.1 0\nf 4 5 6\n", obj);
    fclose(obj);
    assert_null(hz_tree_import(&(hz_tree_import_desc){.path = HZ_TEST_TMP "/nan_leaf.obj"}, &err));
    print_message("nan leaf: %s\n", err.msg);
    assert_int_equal(err.code, HZ_ERR_FORMAT);
    assert_non_null(strstr(err.msg, "vertex 1 of mesh 'leaves' is not a finite point"));
}

/* A tree of two leaves (a small import) still gets a crown hull: the iso
 * level that keeps 90 % of the leaf centres inside is then the field's peak,
 * and the builder lowers it until the surface encloses them. Closed and
 * manifold, around both leaves. */
static void test_hull_few_leaves(void **state)
{
    (void)state;
    FILE *obj = fopen(HZ_TEST_TMP "/two_leaves.obj", "w");
    assert_non_null(obj);
    fputs("g bark\nv 0 0 0\nv 1 0 0\nv 1 4 0\nv 0 4 0\nf 1 2 3 4\ng foliage\nv 0 4 0\nv 0.5 4 0.1\n"
          "v 0.5 4.5 0.1\nv 0 4.5 0\nv 1 4 0\nv 1.5 4 0.1\nv 1.5 4.5 0.1\nv 1 4.5 0\nf 5 6 7 8\nf 9 10 11 12\n",
          obj);
    fclose(obj);
    hz_err err = {0};
    hz_tree *t = hz_tree_import(&(hz_tree_import_desc){.path = HZ_TEST_TMP "/two_leaves.obj"}, &err);
    if (!t)
        fail_msg("import: %s", err.msg);
    assert_int_equal(t->leaf_count, 2);
    if (hz_hull_build(t, NULL, NULL, &err) != HZ_OK)
        fail_msg("hull: %s", err.msg);
    hz_mesh_topology topo;
    assert_int_equal(hz_mesh_check(t->hull.idx, t->hull.index_count, t->hull.vertex_count, &topo, &err), HZ_OK);
    assert_true(t->hull.index_count >= 3 * 4);
    assert_int_equal(topo.bad_edges, 0);
    assert_int_equal(topo.bad_vertices, 0);
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (uint32_t v = 0; v < t->hull.vertex_count; v++)
        for (int c = 0; c < 3; c++) {
            lo[c] = fminf(lo[c], t->hull.pos[v * 3 + c]);
            hi[c] = fmaxf(hi[c], t->hull.pos[v * 3 + c]);
        }
    for (uint32_t k = 0; k < t->leaf_count; k++)
        for (int c = 0; c < 3; c++)
            assert_true(t->leaves[k].c[c] > lo[c] && t->leaves[k].c[c] < hi[c]);
    assert_int_equal(hz_tree_validate(t, &err), HZ_OK);
    hz_tree_destroy(t);
}

/* hz_tree_validate bounds every coordinate by HZ_TREE_MAX_COORD: a bark,
 * hull or leaf coordinate just inside passes, just beyond fails, and
 * hz_tree_save_mem refuses to write such a tree. */
static void test_validate_bounds(void **state)
{
    (void)state;
    hz_tree *t = small_tree("oak", 1);
    hz_err err = {0};
    assert_true(t->bark.vertex_count > 0 && t->leaf_count > 0);
    float *coord[3] = {&t->bark.pos[1], &t->leaves[t->leaf_count / 2].c[0], NULL};
    if (t->hull.vertex_count)
        coord[2] = &t->hull.pos[2];
    for (int k = 0; k < 3; k++) {
        if (!coord[k])
            continue;
        const float keep = *coord[k];
        *coord[k] = 0.99f * HZ_TREE_MAX_COORD;
        assert_int_equal(hz_tree_validate(t, &err), HZ_OK);
        *coord[k] = -1.01f * HZ_TREE_MAX_COORD;
        assert_int_equal(hz_tree_validate(t, &err), HZ_ERR_FORMAT);
        assert_non_null(strstr(err.msg, "beyond"));
        uint8_t *data = NULL;
        size_t n = 0;
        assert_int_equal(hz_tree_save_mem(t, &data, &n, &err), HZ_ERR_FORMAT);
        assert_null(data);
        *coord[k] = keep;
    }
    assert_int_equal(hz_tree_validate(t, &err), HZ_OK);
    hz_tree_destroy(t);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_grow_repeatable),
        cmocka_unit_test(test_hierarchy_consistent),
        cmocka_unit_test(test_species_sizes),
        cmocka_unit_test(test_file_roundtrip),
        cmocka_unit_test(test_file_fuzz),
        cmocka_unit_test(test_vmi_hand_computed),
        cmocka_unit_test(test_vmi_occluded_ranks_below_exposed),
        cmocka_unit_test(test_vmi_incremental_matches_brute_force),
        cmocka_unit_test(test_sphere_views),
        cmocka_unit_test(test_hull_closed_manifold),
        cmocka_unit_test(test_mesh_check_detects_holes),
        cmocka_unit_test(test_rate_break_points),
        cmocka_unit_test(test_place),
        cmocka_unit_test(test_select),
        cmocka_unit_test(test_import_obj),
        cmocka_unit_test(test_hull_few_leaves),
        cmocka_unit_test(test_validate_bounds),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
