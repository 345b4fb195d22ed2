/* Forest GL side: item-buffer VMI ranking, coverage precision/recall and
 * forest drawing through the renderer hook. Headless EGL on llvmpipe. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "horizon/forest_render.h"

static hz_gl *gl;

static int setup(void **state)
{
    (void)state;
    hz_err err = {0};
    gl = hz_gl_create_headless(&err);
    if (!gl) {
        fprintf(stderr, "no headless GL: %s\n", err.msg);
        return -1;
    }
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    hz_gl_destroy(gl);
    return 0;
}

/* A hand-built tree's storage: nb branches, nl leaves, nn leaf nodes, all
 * zeroed; the caller fills them and calls hz_tree_finish. */
static hz_tree *tree_alloc(const char *species, uint32_t levels, uint32_t nb, uint32_t nl, uint32_t nn)
{
    hz_tree *t = calloc(1, sizeof *t);
    snprintf(t->species, sizeof t->species, "%s", species);
    t->levels = levels;
    t->branch_count = nb;
    t->branches = calloc(nb, sizeof *t->branches);
    t->leaf_count = nl;
    t->leaves = calloc(nl, sizeof *t->leaves);
    t->node_count = nn;
    t->nodes = calloc(nn, sizeof *t->nodes);
    return t;
}

/* The trunk of a hand-built tree: 1 m long, straight up to height tip_y,
 * carrying leaf node 0. */
static hz_tree_branch trunk(float tip_y)
{
    return (hz_tree_branch){.parent = HZ_TREE_NONE, .level = 1, .leaf_node = 0, .length = 1, .radius = 0.05f,
                            .tip = {0, tip_y, 0}, .dir = {0, 1, 0}};
}

/* Six leaves forming a closed box centred at (0, 1, 0), 1 m wide; a quad is
 * c +- u +- v. The leaf cut-out is almond shaped, so each face is two
 * crossed leaves' worth: faces larger than the box close the corners. */
static void box_faces(hz_tree_leaf *out)
{
    const float h = 0.5f, big = 0.75f;
    const hz_tree_leaf faces[6] = {
        {{h, 1, 0}, {0, big, 0}, {0, 0, big}},  {{-h, 1, 0}, {0, big, 0}, {0, 0, big}},
        {{0, 1 + h, 0}, {big, 0, 0}, {0, 0, big}}, {{0, 1 - h, 0}, {big, 0, 0}, {0, 0, big}},
        {{0, 1, h}, {big, 0, 0}, {0, big, 0}},  {{0, 1, -h}, {big, 0, 0}, {0, big, 0}},
    };
    memcpy(out, faces, sizeof faces);
}

/* One branch, one leaf node: six leaves forming a closed box around a
 * seventh leaf in its middle, plus one leaf sticking out above. */
static hz_tree *box_tree(void)
{
    hz_tree *t = tree_alloc("box", 1, 1, 8, 1);
    t->branches[0] = trunk(1.0f);
    box_faces(t->leaves);
    t->leaves[6] = (hz_tree_leaf){{0, 1, 0}, {0.1f, 0, 0}, {0, 0.1f, 0}};   /* hidden inside */
    t->leaves[7] = (hz_tree_leaf){{0, 2.2f, 0}, {0.3f, 0, 0}, {0, 0.3f, 0}}; /* exposed above */
    t->nodes[0] = (hz_tree_node){.branch = 0, .first = 0, .count = 8};
    hz_tree_finish(t);
    return t;
}

static void test_rank_hidden_leaf_last(void **state)
{
    (void)state;
    hz_tree *t = box_tree();
    hz_err err = {0};
    assert_int_equal(hz_tree_validate(t, &err), HZ_OK);
    float hidden[3] = {t->leaves[6].c[0], t->leaves[6].c[1], t->leaves[6].c[2]};
    hz_rank_stats st;
    hz_result r = hz_tree_rank(t, &(hz_rank_desc){.views = 42, .res = 48, .layers = 4, .min_elevation = -90}, &st, &err);
    if (r != HZ_OK)
        fail_msg("rank: %s", err.msg);
    assert_true(t->ranked);
    assert_int_equal(t->rank_views, 42);
    assert_true(st.pixels > 42 * 100);
    /* The leaf inside the closed box is never seen: it ranks last. */
    assert_memory_equal(t->leaves[7].c, hidden, sizeof hidden);
    assert_float_equal(t->leaves[7].u[0], 0.1f, 1e-6);
    /* The big exposed leaf above ranks ahead of at least... it is not last,
     * and the ranking is a permutation. */
    int found_top = 0;
    for (int k = 0; k < 8; k++)
        found_top += fabsf(t->leaves[k].c[1] - 2.2f) < 1e-6f;
    assert_int_equal(found_top, 1);
    assert_int_equal(hz_tree_validate(t, &err), HZ_OK);
    hz_tree_destroy(t);
}

/* Where among leaves first .. first + count - 1 (a node, ranked) the leaf
 * whose half axis along is u ended up: 0 = most important; count if none. */
static uint32_t rank_of(const hz_tree *t, uint32_t first, uint32_t count, float u)
{
    for (uint32_t k = 0; k < count; k++)
        if (fabsf(t->leaves[first + k].u[0] - u) < 1e-6f)
            return k;
    return count;
}

/* One leaf node of three horizontal leaves: a big one, a smaller one just
 * under it (seen only from below: from above the big one hides it, from the
 * side all are edge-on) and a small one just over it (seen only from above). */
static hz_tree *underside_tree(void)
{
    hz_tree *t = tree_alloc("underside", 1, 1, 3, 1);
    t->branches[0] = trunk(2.0f);
    t->leaves[0] = (hz_tree_leaf){{0, 2, 0}, {2.0f, 0, 0}, {0, 0, 2.0f}};      /* top */
    t->leaves[1] = (hz_tree_leaf){{0, 1.95f, 0}, {0.8f, 0, 0}, {0, 0, 0.8f}};  /* under it */
    t->leaves[2] = (hz_tree_leaf){{0.5f, 2.05f, 0.5f}, {0.1f, 0, 0}, {0, 0, 0.1f}}; /* small, over it */
    t->nodes[0] = (hz_tree_node){.branch = 0, .first = 0, .count = 3};
    hz_tree_finish(t);
    return t;
}

/* Viewpoints below min_elevation are left out of the ranking: a leaf seen
 * only from below ranks last from the side and above (the default), not
 * over the whole sphere, where from below it hides much of the top one. */
static void test_rank_min_elevation(void **state)
{
    (void)state;
    hz_err err = {0};
    float dirs[42 * 3];
    assert_true(hz_sphere_views(42, dirs));
    uint32_t upper = 0;
    for (int v = 0; v < 42; v++)
        upper += dirs[v * 3 + 1] >= -1e-4f;
    assert_true(upper > 2 && upper < 42);
    for (int whole = 0; whole < 2; whole++) {
        hz_tree *t = underside_tree();
        if (hz_tree_validate(t, &err) != HZ_OK)
            fail_msg("underside tree: %s", err.msg);
        hz_rank_desc d = {.views = 42, .res = 48, .layers = 4, .min_elevation = whole ? -90 : 0};
        if (hz_tree_rank(t, &d, NULL, &err) != HZ_OK)
            fail_msg("rank: %s", err.msg);
        assert_int_equal(t->rank_views, whole ? 42u : upper);
        const uint32_t at = rank_of(t, 0, 3, 0.8f);
        print_message("%s: the leaf under the top one ranks %u of 3\n", whole ? "whole sphere" : "from above", at + 1);
        if (whole)
            assert_true(at < 2);
        else
            assert_int_equal(at, 2);
        hz_tree_destroy(t);
    }
    hz_tree *t = underside_tree();
    assert_int_equal(hz_tree_rank(t, &(hz_rank_desc){.min_elevation = 91}, NULL, &err), HZ_ERR_VALUE);
    assert_int_equal(hz_tree_rank(t, &(hz_rank_desc){.views = 12, .min_elevation = 89}, NULL, &err), HZ_ERR_VALUE);
    assert_non_null(strstr(err.msg, "elevation"));
    hz_tree_destroy(t);
}

/* Two leaf nodes: node 0 is a closed box of six leaves; node 1 has a big
 * leaf inside the box and two small ones outside, above it. */
static hz_tree *boxed_tree(void)
{
    hz_tree *t = tree_alloc("boxed", 2, 2, 9, 2);
    t->branches[0] = trunk(1.0f);
    t->branches[1] = (hz_tree_branch){.parent = 0, .level = 2, .leaf_node = 1, .length = 1, .radius = 0.02f,
                                      .base = {0, 1, 0}, .tip = {0, 2, 0}, .dir = {0, 1, 0}};
    box_faces(t->leaves);
    t->leaves[6] = (hz_tree_leaf){{0, 1, 0}, {0.3f, 0, 0}, {0, 0.3f, 0}};        /* big, inside the box */
    t->leaves[7] = (hz_tree_leaf){{-0.2f, 2.2f, 0}, {0.05f, 0, 0}, {0, 0, 0.05f}}; /* small, outside */
    t->leaves[8] = (hz_tree_leaf){{0.2f, 2.2f, 0}, {0.05f, 0, 0}, {0, 0, 0.05f}};
    t->nodes[0] = (hz_tree_node){.branch = 0, .first = 0, .count = 6};
    t->nodes[1] = (hz_tree_node){.branch = 1, .first = 6, .count = 3};
    hz_tree_finish(t);
    return t;
}

/* Ranked in the tree, a leaf that another node hides from every side ranks
 * last in its node; ranked alone, the same (big) leaf does not. */
static void test_rank_in_tree(void **state)
{
    (void)state;
    hz_err err = {0};
    for (int in_tree = 0; in_tree < 2; in_tree++) {
        hz_tree *t = boxed_tree();
        if (hz_tree_validate(t, &err) != HZ_OK)
            fail_msg("nested tree: %s", err.msg);
        hz_rank_stats st;
        hz_rank_desc d = {.views = 42, .res = 48, .layers = 4, .tree_res = in_tree ? 512 : 0};
        if (hz_tree_rank(t, &d, &st, &err) != HZ_OK)
            fail_msg("rank: %s", err.msg);
        assert_int_equal(t->rank_res, in_tree ? 512u : 48u);
        assert_true(st.pixels > 42 * 50);
        const uint32_t at = rank_of(t, 6, 3, 0.3f); /* node 1's big leaf in its order */
        print_message("%s: the hidden big leaf ranks %u of 3\n", in_tree ? "in the tree" : "alone", at + 1);
        if (in_tree)
            assert_int_equal(at, 2);
        else
            assert_true(at < 2);
        assert_int_equal(hz_tree_validate(t, &err), HZ_OK);
        hz_tree_destroy(t);
    }
    hz_tree *t = boxed_tree();
    assert_int_equal(hz_tree_rank(t, &(hz_rank_desc){.tree_res = 100}, NULL, &err), HZ_ERR_VALUE);
    hz_tree_destroy(t);
}

static void test_pr(void **state)
{
    (void)state;
    hz_err err = {0};
    hz_tree *t = hz_tree_grow(&(hz_tree_desc){.species = "maple", .seed = 3, .leaves = 2000}, &err);
    assert_non_null(t);
    assert_int_equal(hz_tree_rank(t, &(hz_rank_desc){.views = 12, .res = 16, .layers = 2}, NULL, &err), HZ_OK);
    hz_pr_result self, half, half_big;
    /* A tree against itself: 1 / 1. */
    assert_int_equal(hz_tree_pr(t, &(hz_pr_desc){.views = 8, .res = 128}, &self, &err), HZ_OK);
    assert_true(self.tp > 1000);
    assert_int_equal(self.fp, 0);
    assert_int_equal(self.fn, 0);
    assert_float_equal(self.precision, 1.0, 0);
    assert_float_equal(self.recall, 1.0, 0);
    /* Half the leaves: nothing new appears (precision 1), some coverage is lost. */
    assert_int_equal(hz_tree_pr(t, &(hz_pr_desc){.views = 8, .res = 128, .rate = 0.5f}, &half, &err), HZ_OK);
    assert_float_equal(half.precision, 1.0, 0);
    assert_true(half.recall < 0.99 && half.recall > 0.3);
    /* Enlarged leaves win coverage back and spill a little. */
    assert_int_equal(hz_tree_pr(t, &(hz_pr_desc){.views = 8, .res = 128, .rate = 0.5f, .enlarge = true}, &half_big,
                                &err),
                     HZ_OK);
    assert_true(half_big.recall > half.recall);
    assert_true(half_big.precision < 1.0);
    /* Bad parameters are refused. */
    assert_int_equal(hz_tree_pr(t, &(hz_pr_desc){.rate = 1.5f}, &half, &err), HZ_ERR_VALUE);
    assert_int_equal(hz_tree_rank(t, &(hz_rank_desc){.views = 20}, NULL, &err), HZ_ERR_VALUE);
    hz_tree_destroy(t);
}


/* One branch, one leaf node of two coplanar leaves with the same centre:
 * `small` and, twice as large in both directions, `big` (which covers it).
 * small_first: the order small, big (else big, small). */
static hz_tree *nested_tree(bool small_first)
{
    hz_tree *t = tree_alloc("nested", 1, 1, 2, 1);
    t->branches[0] = trunk(1.0f);
    /* tilted so that no view of the measure sees it edge-on */
    const hz_tree_leaf small = {{0, 1, 0}, {0.5f, 0.2f, 0.1f}, {-0.1f, 0.25f, 0.45f}};
    hz_tree_leaf big = small;
    for (int c = 0; c < 3; c++)
        big.u[c] *= 2, big.v[c] *= 2;
    t->leaves[small_first ? 0 : 1] = small;
    t->leaves[small_first ? 1 : 0] = big;
    t->nodes[0] = (hz_tree_node){.branch = 0, .first = 0, .count = 2};
    hz_tree_finish(t);
    return t;
}

/* The measure on a case whose answer is known: keeping the small leaf of
 * the nested pair keeps a quarter of the area (P 1, R 0.25); enlarged by the
 * coverage it lost (x2), it is the big leaf again (P 1, R 1). Keeping the
 * big one loses nothing (P 1, R 1) and needs no enlargement. */
static void test_pr_hand_made(void **state)
{
    (void)state;
    hz_err err = {0};
    for (int order = 0; order < 2; order++) {
        hz_tree *t = nested_tree(order == 0);
        assert_int_equal(hz_tree_validate(t, &err), HZ_OK);
        float cov[2];
        assert_int_equal(hz_tree_prefix_coverage(t, cov, &err), HZ_OK);
        assert_float_equal(cov[0], order == 0 ? 0.25 : 1.0, 0.03);
        assert_float_equal(cov[1], 1.0, 1e-6);
        hz_pr_result half, big;
        assert_int_equal(hz_tree_pr(t, &(hz_pr_desc){.views = 16, .res = 256, .rate = 0.5f}, &half, &err), HZ_OK);
        assert_true(half.tp > 10000);
        assert_float_equal(half.precision, 1.0, 1e-9);
        assert_float_equal(half.recall, order == 0 ? 0.25 : 1.0, 0.01);
        assert_int_equal(hz_tree_pr(t, &(hz_pr_desc){.views = 16, .res = 256, .rate = 0.5f, .enlarge = true}, &big,
                                    &err),
                         HZ_OK);
        assert_float_equal(big.precision, 1.0, 0.02);
        assert_float_equal(big.recall, 1.0, 0.02);
        hz_tree_destroy(t);
    }
}

/* The same-leaf measure on cases whose answer is known. One leaf node of
 * two equal coplanar leaves side by side, apart: keeping the first keeps
 * half the foliage, P 1 and R 0.5 by either measure. Enlarged by the
 * coverage it lost (x sqrt 2 each way, twice its area), the kept leaf still
 * shows itself over its own pixels and spills over as much again: P 0.5,
 * R 0.5. */
static void test_pr_same_leaf(void **state)
{
    (void)state;
    hz_err err = {0};
    hz_tree *t = tree_alloc("pair", 1, 1, 2, 1);
    t->branches[0] = trunk(1.0f);
    const hz_tree_leaf a = {{0, 1, 0}, {0.5f, 0.2f, 0.1f}, {-0.1f, 0.25f, 0.45f}}; /* tilted as nested_tree's */
    for (int k = 0; k < 2; k++) {
        t->leaves[k] = a;
        for (int c = 0; c < 3; c++) /* 1.2 half-widths to either side: blades 0.9 wide do not touch */
            t->leaves[k].c[c] += (k ? 1.2f : -1.2f) * a.v[c];
    }
    t->nodes[0] = (hz_tree_node){.branch = 0, .first = 0, .count = 2};
    hz_tree_finish(t);
    assert_int_equal(hz_tree_validate(t, &err), HZ_OK);
    hz_pr_result half, big;
    assert_int_equal(hz_tree_pr(t, &(hz_pr_desc){.views = 16, .res = 256, .rate = 0.5f}, &half, &err), HZ_OK);
    assert_true(half.leaf_tp > 10000);
    assert_float_equal(half.precision, 1.0, 1e-9);
    assert_float_equal(half.recall, 0.5, 0.02);
    assert_float_equal(half.leaf_precision, 1.0, 1e-9);
    assert_float_equal(half.leaf_recall, 0.5, 0.02);
    assert_true(half.leaf_tp == half.tp && half.leaf_fn == half.fn); /* nothing else shows where A was */
    assert_int_equal(hz_tree_pr(t, &(hz_pr_desc){.views = 16, .res = 256, .rate = 0.5f, .enlarge = true}, &big, &err),
                     HZ_OK);
    print_message("pair enlarged: coverage %.3f/%.3f, same leaf %.3f/%.3f\n", big.precision, big.recall,
                  big.leaf_precision, big.leaf_recall);
    assert_float_equal(big.leaf_precision, 0.5, 0.03);
    assert_float_equal(big.leaf_recall, 0.5, 0.02);
    assert_true(big.tp >= big.leaf_tp);
    hz_tree_destroy(t);
    /* The closed box keeping four of its six faces (+-x, +-y): through the
     * missing +-z faces the views see its inside, foliage still (coverage
     * finds it) but other leaves than the full box shows there. */
    t = box_tree();
    assert_int_equal(hz_tree_pr(t, &(hz_pr_desc){.views = 16, .res = 256, .rate = 0.5f}, &half, &err), HZ_OK);
    print_message("box half: coverage %.3f/%.3f, same leaf %.3f/%.3f\n", half.precision, half.recall,
                  half.leaf_precision, half.leaf_recall);
    assert_true(half.leaf_recall < half.recall - 0.1 && half.leaf_precision < half.precision - 0.1);
    hz_tree_destroy(t);
}

/* VMI against random pruning on small trees, ranked node by node and in the
 * whole tree (as the commands do): at 50 % VMI keeps more of the crown's
 * coverage (recall), and with enlargement by lost coverage it also spills
 * less (precision) and still covers more; by the same-leaf measure too. */
static void test_vmi_beats_random(void **state)
{
    (void)state;
    hz_err err = {0};
    const char *species[2] = {"oak", "conifer"};
    for (int k = 0; k < 4; k++) {
        hz_tree *t = hz_tree_grow(&(hz_tree_desc){.species = species[k % 2], .seed = 1, .leaves = 3000}, &err);
        assert_non_null(t);
        const hz_rank_desc rd = {.res = 32, .layers = 4, .tree_res = k < 2 ? 0 : HZ_RANK_TREE_RES};
        assert_int_equal(hz_tree_rank(t, &rd, NULL, &err), HZ_OK);
        printf("ranked %s\n", k < 2 ? "node by node" : "in the tree");
        hz_pr_result v, r, ve, re;
        const hz_pr_desc plain = {.views = 16, .res = 256, .rate = 0.5f};
        const hz_pr_desc enl = {.views = 16, .res = 256, .rate = 0.5f, .enlarge = true};
        assert_int_equal(hz_tree_pr(t, &plain, &v, &err), HZ_OK);
        assert_int_equal(hz_tree_pr_random(t, &plain, 4, 7, &r, NULL, &err), HZ_OK);
        assert_int_equal(hz_tree_pr(t, &enl, &ve, &err), HZ_OK);
        assert_int_equal(hz_tree_pr_random(t, &enl, 4, 7, &re, NULL, &err), HZ_OK);
        printf("%s: VMI %.3f/%.3f enlarged %.3f/%.3f, random %.3f/%.3f enlarged %.3f/%.3f\n", species[k % 2],
               v.precision, v.recall, ve.precision, ve.recall, r.precision, r.recall, re.precision, re.recall);
        printf("%s same leaf: VMI %.3f/%.3f enlarged %.3f/%.3f, random %.3f/%.3f enlarged %.3f/%.3f\n",
               species[k % 2], v.leaf_precision, v.leaf_recall, ve.leaf_precision, ve.leaf_recall, r.leaf_precision,
               r.leaf_recall, re.leaf_precision, re.leaf_recall);
        assert_true(v.recall > r.recall + 0.01);
        assert_true(ve.recall > re.recall);
        assert_true(ve.precision > re.precision + 0.01);
        /* By what the pixels show: VMI's half keeps more of the leaves seen,
         * and its enlarged half covers fewer of the removed leaves' pixels. */
        assert_true(v.leaf_recall > r.leaf_recall + 0.01);
        assert_true(ve.leaf_precision > re.leaf_precision + 0.02);
        assert_true(ve.leaf_recall > re.leaf_recall + 0.01);
        hz_tree_destroy(t);
    }
}

/* The random baseline pooled over several orders: its counts are the sums
 * of those of the shuffles it names (seeds seed, seed + 1, ...), its ratios
 * those of the sums, and each order's own result comes back. */
static void test_pr_random_pooled(void **state)
{
    (void)state;
    hz_err err = {0};
    hz_tree *t = hz_tree_grow(&(hz_tree_desc){.species = "birch", .seed = 2, .leaves = 800}, &err);
    assert_non_null(t);
    const hz_pr_desc d = {.views = 8, .res = 128, .rate = 0.5f, .enlarge = true};
    hz_pr_result pooled, each[3], one[3];
    assert_int_equal(hz_tree_pr_random(t, &d, 3, 40, &pooled, each, &err), HZ_OK);
    uint64_t tp = 0, fp = 0, fn = 0, ltp = 0, lfp = 0, lfn = 0;
    for (int k = 0; k < 3; k++) {
        hz_tree *rnd = hz_tree_shuffled(t, 40 + (uint64_t)k, &err);
        assert_non_null(rnd);
        assert_int_equal(hz_tree_pr(rnd, &d, &one[k], &err), HZ_OK);
        hz_tree_destroy(rnd);
        assert_int_equal(each[k].tp, one[k].tp);
        assert_int_equal(each[k].leaf_fp, one[k].leaf_fp);
        assert_int_equal(each[k].leaf_fn, one[k].leaf_fn);
        tp += one[k].tp, fp += one[k].fp, fn += one[k].fn;
        ltp += one[k].leaf_tp, lfp += one[k].leaf_fp, lfn += one[k].leaf_fn;
    }
    /* Different orders: the shuffles are not one order three times. */
    assert_true(one[0].leaf_fn != one[1].leaf_fn || one[1].leaf_fn != one[2].leaf_fn);
    assert_int_equal(pooled.tp, tp);
    assert_int_equal(pooled.fp, fp);
    assert_int_equal(pooled.fn, fn);
    assert_int_equal(pooled.leaf_tp, ltp);
    assert_int_equal(pooled.leaf_fp, lfp);
    assert_int_equal(pooled.leaf_fn, lfn);
    assert_true(fabs(pooled.leaf_recall - (double)ltp / (double)(ltp + lfn)) < 1e-12);
    assert_true(fabs(pooled.leaf_precision - (double)ltp / (double)(ltp + lfp)) < 1e-12);
    assert_true(fabs(pooled.recall - (double)tp / (double)(tp + fn)) < 1e-12);
    assert_int_equal(pooled.views, 8);
    assert_int_equal(pooled.res, 128);
    assert_int_equal(hz_tree_pr_random(t, &d, 0, 1, &pooled, NULL, &err), HZ_ERR_VALUE);
    assert_int_equal(hz_tree_pr_random(t, &d, 65, 1, &pooled, NULL, &err), HZ_ERR_VALUE);
    hz_tree_destroy(t);
}

static uint64_t count_diff(const uint8_t *a, const uint8_t *b, size_t npx)
{
    uint64_t n = 0;
    for (size_t p = 0; p < npx; p++)
        n += abs(a[p * 3] - b[p * 3]) + abs(a[p * 3 + 1] - b[p * 3 + 1]) + abs(a[p * 3 + 2] - b[p * 3 + 2]) > 24;
    return n;
}

/* A grown model with its hull, a forest of it at `trees`, its GPU side. */
typedef struct one_model {
    hz_tree *t;
    hz_forest *f;
    hz_forest_gpu *gpu;
} one_model;

static one_model one_model_forest(const hz_tree_desc *td, const hz_forest_tree *trees, uint32_t n)
{
    hz_err err = {0};
    one_model m = {hz_tree_grow(td, &err), NULL, NULL};
    assert_non_null(m.t);
    assert_int_equal(hz_hull_build(m.t, NULL, NULL, &err), HZ_OK);
    const hz_tree *models[1] = {m.t};
    m.f = hz_forest_create(models, 1, trees, n, &err);
    assert_non_null(m.f);
    m.gpu = hz_forest_gpu_create(m.f, &err);
    if (!m.gpu)
        fail_msg("gpu: %s", err.msg);
    return m;
}

static void one_model_free(one_model *m)
{
    hz_forest_gpu_destroy(m->gpu);
    hz_forest_destroy(m->f);
    hz_tree_destroy(m->t);
}

/* Draws the empty frame into sky (tree pixels are those that differ from it)
 * and points sp's object hook at the forest f on gpu, its selection in fr. */
static void forest_scene(hz_renderer *ren, const hz_camera *cam, hz_forest_gpu *gpu, hz_forest *f, hz_forest_frame *fr,
                         hz_forest_hook *hook, hz_scene_params *sp, uint8_t *sky)
{
    hz_err err = {0};
    hz_scene_params none = {.fog_density = -1};
    assert_int_equal(hz_renderer_draw(ren, cam, &none, NULL, 0, NULL, &err), HZ_OK);
    assert_int_equal(hz_renderer_read_rgb(ren, sky, &err), HZ_OK);
    *hook = (hz_forest_hook){.gpu = gpu, .forest = f, .frame = fr};
    *sp = (hz_scene_params){.fog_density = -1, .draw_objects = hz_forest_draw_hook, .draw_objects_user = hook};
}

static void test_forest_draw(void **state)
{
    (void)state;
    enum { W = 192, H = 144 };
    hz_err err = {0};
    hz_renderer *ren = hz_renderer_create(&(hz_renderer_desc){.width = W, .height = H}, &err);
    assert_non_null(ren);
    hz_forest_tree trees[2] = {{.pos = {0, 0, 0}, .scale = 1}, {.pos = {0, 0, -400}, .scale = 1}};
    one_model om = one_model_forest(&(hz_tree_desc){.species = "oak", .seed = 1, .leaves = 8000}, trees, 2);
    hz_forest *f = om.f;
    hz_forest_gpu *gpu = om.gpu;
    hz_camera cam = {.pos = {0, 8, 16}, .yaw = 0, .pitch = 0, .fov_y = 60, .aspect = (float)W / H, .znear = 0.3f,
                     .zfar = 3000};
    uint8_t *sky = malloc(W * H * 3), *full = malloc(W * H * 3), *simp = malloc(W * H * 3), *big = malloc(W * H * 3);
    hz_forest_frame fr;
    hz_forest_hook hook;
    hz_scene_params sp;
    forest_scene(ren, &cam, gpu, f, &fr, &hook, &sp, sky);
    uint8_t *outs[3] = {full, simp, big};
    hz_forest_params ps[3] = {{.simplify = false},
                              {.simplify = true, .fixed_rate = true, .fixed = 0.8f},
                              {.simplify = true, .fixed_rate = true, .fixed = 0.8f, .enlarge = true}};
    for (int k = 0; k < 3; k++) {
        assert_int_equal(hz_forest_update(f, &cam, &ps[k], 0, &fr, &err), HZ_OK);
        assert_int_equal(hz_renderer_draw(ren, &cam, &sp, NULL, 0, NULL, &err), HZ_OK);
        if (hook.failed)
            fail_msg("forest draw: %s", hook.err.msg);
        assert_int_equal(hz_renderer_read_rgb(ren, outs[k], &err), HZ_OK);
    }
    /* The simplified frame selected the far tree as an impostor. */
    assert_int_equal(fr.trees_impostor, 1);
    char path[512];
    snprintf(path, sizeof path, "%s/forest_full.png", HZ_TEST_TMP);
    hz_image_write_png(path, full, W, H, &err);
    snprintf(path, sizeof path, "%s/forest_simplified.png", HZ_TEST_TMP);
    hz_image_write_png(path, simp, W, H, &err);
    uint64_t c_full = count_diff(full, sky, W * H), c_simp = count_diff(simp, sky, W * H),
             c_big = count_diff(big, sky, W * H);
    /* The tree covers a good part of the frame, green where leaves are. */
    assert_true(c_full > (uint64_t)(W * H) / 20);
    uint64_t green = 0;
    for (size_t p = 0; p < W * H; p++)
        green += full[p * 3 + 1] > full[p * 3] && full[p * 3 + 1] > full[p * 3 + 2] + 8;
    assert_true(green > (uint64_t)(W * H) / 100);
    /* Pruning 80% of the leaves uncovers sky; enlargement covers some back. */
    assert_true(c_simp < c_full);
    assert_true(c_big > c_simp);
    free(sky);
    free(full);
    free(simp);
    free(big);
    one_model_free(&om);
    hz_renderer_destroy(ren);
}

/* Leaves drawn as points cut to the leaf's projected outline give the picture
 * the quads give: the same tree pixels, the same colours. Looked at from a
 * zoom where the forest's own threshold (POINT_LEAF_PX) draws them as points:
 * a view field of 20 degrees, and 10, the narrowest where it still does. */
static void point_leaves_at(float fov, double max_one_only)
{
    enum { W = 320, H = 240 };
    hz_err err = {0};
    hz_renderer *ren = hz_renderer_create(&(hz_renderer_desc){.width = W, .height = H}, &err);
    assert_non_null(ren);
    hz_forest_tree trees[1] = {{.pos = {0, 0, 0}, .scale = 1, .yaw = 0.7f}};
    one_model om = one_model_forest(&(hz_tree_desc){.species = "maple", .seed = 3, .leaves = 20000}, trees, 1);
    const hz_tree *t = om.t;
    hz_forest *f = om.f;
    hz_forest_gpu *gpu = om.gpu;
    /* Looking at the crown from a little above it, zoomed in. */
    const float *bc = t->bound_center, r = t->bound_radius;
    hz_camera cam = {.pos = {bc[0], bc[1] + 0.4f * r, bc[2] + 1.8f * r}, .yaw = 0, .pitch = -12, .fov_y = fov,
                     .aspect = (float)W / H, .znear = 0.3f, .zfar = 3000};
    uint8_t *sky = malloc(W * H * 3), *quads = malloc(W * H * 3), *points = malloc(W * H * 3);
    hz_forest_frame fr;
    hz_forest_hook hook;
    hz_scene_params sp;
    forest_scene(ren, &cam, gpu, f, &fr, &hook, &sp, sky);
    /* Leaves only: every tree in the leaf state, half the leaves, enlarged. */
    hz_forest_params fp = {.simplify = true, .fixed_rate = true, .fixed = 0.5f, .enlarge = true,
                           .hull_dist = 1e4f, .impostor_dist = 2e4f};
    assert_int_equal(hz_forest_update(f, &cam, &fp, 0, &fr, &err), HZ_OK);
    assert_int_equal(fr.trees_detailed, 1);
    uint8_t *outs[2] = {quads, points};
    const float px[2] = {0.0f, 1e6f};
    uint32_t drawn_as_points[2];
    const float default_px = hz_forest_gpu_point_leaves(gpu, 0.0f);
    for (int k = 0; k < 2; k++) {
        hz_forest_gpu_point_leaves(gpu, px[k]);
        assert_int_equal(hz_renderer_draw(ren, &cam, &sp, NULL, 0, NULL, &err), HZ_OK);
        if (hook.failed)
            fail_msg("forest draw: %s", hook.err.msg);
        assert_int_equal(hz_renderer_read_rgb(ren, outs[k], &err), HZ_OK);
        drawn_as_points[k] = hz_forest_gpu_point_trees(gpu);
    }
    assert_int_equal(drawn_as_points[0], 0);
    assert_int_equal(drawn_as_points[1], 1);
    /* At this zoom the forest's own threshold draws them as points too. */
    hz_forest_gpu_point_leaves(gpu, default_px);
    assert_int_equal(hz_renderer_draw(ren, &cam, &sp, NULL, 0, NULL, &err), HZ_OK);
    assert_int_equal(hz_forest_gpu_point_trees(gpu), 1);
    char path[512];
    snprintf(path, sizeof path, "%s/forest_leaf_quads_fov%.0f.png", HZ_TEST_TMP, (double)fov);
    hz_image_write_png(path, quads, W, H, &err);
    snprintf(path, sizeof path, "%s/forest_leaf_points_fov%.0f.png", HZ_TEST_TMP, (double)fov);
    hz_image_write_png(path, points, W, H, &err);
    /* Tree pixels: differ from the empty frame. */
    uint64_t tq = 0, tp = 0, both = 0, either = 0;
    double colour = 0;
    for (size_t p = 0; p < (size_t)W * H; p++) {
        bool a = count_diff(quads + p * 3, sky + p * 3, 1) > 0, b = count_diff(points + p * 3, sky + p * 3, 1) > 0;
        tq += a, tp += b, both += a && b, either += a || b;
        if (a && b)
            for (int c = 0; c < 3; c++)
                colour += abs(quads[p * 3 + c] - points[p * 3 + c]);
    }
    double xor_frac = (double)(either - both) / (double)either, mean_colour = colour / (3.0 * (double)(both ? both : 1));
    print_message("fov %.0f: tree pixels: quads %llu, points %llu, in one only %.2f %%, mean colour difference %.2f\n",
                  (double)fov, (unsigned long long)tq, (unsigned long long)tp, 100.0 * xor_frac, mean_colour);
    assert_true(tq > (uint64_t)(W * H) / 20);
    assert_true(xor_frac < max_one_only);
    assert_true(mean_colour < 6.0);
    free(sky);
    free(quads);
    free(points);
    one_model_free(&om);
    hz_renderer_destroy(ren);
}

static void test_point_leaves_match_quads(void **state)
{
    (void)state;
    point_leaves_at(20.0f, 0.005); /* 0.20 % of the tree pixels in one picture only */
    point_leaves_at(10.0f, 0.005); /* 0.34 %; at 9 degrees the forest keeps quads */
}

/* A crown hull is shaded from the tree's own impostor: drawn as a hull and
 * as an impostor from the same place, one tree covers about as many pixels in
 * nearly the same colours (a hull drawn with the bark's shading would be
 * solid and bark-coloured). */
static void test_hull_looks_like_impostor(void **state)
{
    (void)state;
    enum { W = 256, H = 192 };
    hz_err err = {0};
    hz_renderer *ren = hz_renderer_create(&(hz_renderer_desc){.width = W, .height = H}, &err);
    assert_non_null(ren);
    hz_forest_tree trees[1] = {{.pos = {0, 0, 0}, .scale = 1, .yaw = 0.3f}};
    one_model om = one_model_forest(&(hz_tree_desc){.species = "oak", .seed = 2, .leaves = 8000}, trees, 1);
    const hz_tree *t = om.t;
    const float *bc = t->bound_center, r = t->bound_radius;
    hz_camera cam = {.pos = {bc[0], bc[1], bc[2] + 3.0f * r}, .yaw = 0, .pitch = 0, .fov_y = 45,
                     .aspect = (float)W / H, .znear = 0.3f, .zfar = 3000};
    uint8_t *sky = malloc(W * H * 3), *hull = malloc(W * H * 3), *imp = malloc(W * H * 3);
    hz_forest_frame fr;
    hz_forest_hook hook;
    hz_scene_params sp;
    forest_scene(ren, &cam, om.gpu, om.f, &fr, &hook, &sp, sky);
    /* The tree is 3 radii away: a hull beyond 0.1 radius, or an impostor
     * beyond 0.2 radius (both well past their fade bands). */
    const hz_forest_params fp[2] = {{.simplify = true, .hull_dist = 0.1f * r, .impostor_dist = 1e4f},
                                    {.simplify = true, .hull_dist = 0.1f * r, .impostor_dist = 0.2f * r}};
    uint8_t *outs[2] = {hull, imp};
    for (int k = 0; k < 2; k++) {
        assert_int_equal(hz_forest_update(om.f, &cam, &fp[k], 0, &fr, &err), HZ_OK);
        assert_int_equal(k ? fr.trees_impostor : fr.trees_hull, 1);
        assert_int_equal(fr.trees_fading, 0);
        assert_int_equal(hz_renderer_draw(ren, &cam, &sp, NULL, 0, NULL, &err), HZ_OK);
        if (hook.failed)
            fail_msg("forest draw: %s", hook.err.msg);
        assert_int_equal(hz_renderer_read_rgb(ren, outs[k], &err), HZ_OK);
    }
    char path[512];
    snprintf(path, sizeof path, "%s/forest_hull.png", HZ_TEST_TMP);
    hz_image_write_png(path, hull, W, H, &err);
    snprintf(path, sizeof path, "%s/forest_impostor.png", HZ_TEST_TMP);
    hz_image_write_png(path, imp, W, H, &err);
    uint64_t th = 0, ti = 0, both = 0;
    double mh[3] = {0}, mi[3] = {0};
    for (size_t p = 0; p < (size_t)W * H; p++) {
        bool a = count_diff(hull + p * 3, sky + p * 3, 1) > 0, b = count_diff(imp + p * 3, sky + p * 3, 1) > 0;
        th += a, ti += b, both += a && b;
        for (int c = 0; c < 3; c++) {
            mh[c] += a ? hull[p * 3 + c] : 0;
            mi[c] += b ? imp[p * 3 + c] : 0;
        }
    }
    assert_true(th > 0 && ti > 0);
    double dmax = 0;
    for (int c = 0; c < 3; c++) {
        mh[c] /= (double)th, mi[c] /= (double)ti;
        dmax = fmax(dmax, fabs(mh[c] - mi[c]));
    }
    /* Not pixel for pixel: the hull is nearer than the impostor's plane, so
     * its holes fall elsewhere (about 40 % of the tree pixels are shared). */
    const double ratio = (double)th / (double)ti;
    print_message("tree pixels: hull %llu, impostor %llu, both %llu; mean colour hull %.0f,%.0f,%.0f impostor "
                  "%.0f,%.0f,%.0f\n",
                  (unsigned long long)th, (unsigned long long)ti, (unsigned long long)both, mh[0], mh[1], mh[2], mi[0],
                  mi[1], mi[2]);
    assert_true(ti > (uint64_t)(W * H) / 20);
    assert_true(ratio > 0.8 && ratio < 1.25);
    assert_true(dmax < 10.0);
    free(sky);
    free(hull);
    free(imp);
    one_model_free(&om);
    hz_renderer_destroy(ren);
}

/* Across the leaves-to-hull band the hull is dithered in on the pixels the
 * leaves give up, and the leaves thin out by rank, to (1 - fade) of what
 * they keep outside it (in steps of 1/16): the crown costs fewer leaves as
 * it nears its hull, and its foliage does not thin on screen, because F4
 * enlarges the leaves that are left. */
static void test_leaves_fade_to_hull(void **state)
{
    (void)state;
    enum { W = 256, H = 192, N = 6 };
    hz_err err = {0};
    hz_renderer *ren = hz_renderer_create(&(hz_renderer_desc){.width = W, .height = H}, &err);
    assert_non_null(ren);
    hz_forest_tree trees[1] = {{.pos = {0, 0, 0}, .scale = 1}}; /* no yaw: the bounding centre is bc */
    one_model om = one_model_forest(&(hz_tree_desc){.species = "oak", .seed = 2, .leaves = 8000}, trees, 1);
    const hz_tree *t = om.t;
    const float *bc = t->bound_center, r = t->bound_radius;
    const float dist = 1.8f * r, ff = 0.15f;
    hz_camera cam = {.pos = {bc[0], bc[1], bc[2] + dist}, .yaw = 0, .pitch = 0, .fov_y = 45,
                     .aspect = (float)W / H, .znear = 0.3f, .zfar = 3000};
    uint8_t *sky = malloc(W * H * 3), *img = malloc(W * H * 3);
    hz_forest_frame fr;
    hz_forest_hook hook;
    hz_scene_params sp;
    forest_scene(ren, &cam, om.gpu, om.f, &fr, &hook, &sp, sky);
    /* Where the tree sits in the band: fade 0 (leaves only) ... past the
     * band (the hull only). */
    const float fades[N] = {0.0f, 0.2f, 0.45f, 0.7f, 0.97f, 1.5f};
    uint64_t leaves[N], cover[N];
    for (int k = 0; k < N; k++) {
        /* dist = hull_dist (1 - ff) + fade hull_dist ff */
        const hz_forest_params fp = {.simplify = true, .enlarge = true, .fixed_rate = true, .fixed = 0.3f,
                                     .fade_frac = ff, .hull_dist = dist / (1.0f - ff + ff * fades[k]),
                                     .impostor_dist = 1e4f};
        assert_int_equal(hz_forest_update(om.f, &cam, &fp, 0, &fr, &err), HZ_OK);
        assert_int_equal(fr.draw_count, 1);
        if (fades[k] < 1.0f) {
            assert_false(fr.draws[0].hull);
            assert_float_equal(fr.draws[0].fade, fades[k], 1e-3);
        } else {
            assert_true(fr.draws[0].hull);
        }
        leaves[k] = fr.leaves_drawn;
        assert_int_equal(hz_renderer_draw(ren, &cam, &sp, NULL, 0, NULL, &err), HZ_OK);
        if (hook.failed)
            fail_msg("forest draw: %s", hook.err.msg);
        assert_int_equal(hz_renderer_read_rgb(ren, img, &err), HZ_OK);
        cover[k] = 0; /* foliage pixels: green, where the sky is blue and bark brown */
        for (size_t p = 0; p < (size_t)W * H; p++)
            cover[k] += img[p * 3 + 1] > img[p * 3] && img[p * 3 + 1] > img[p * 3 + 2] + 8;
        if (k == 2) {
            char path[512];
            snprintf(path, sizeof path, "%s/forest_fade_mid.png", HZ_TEST_TMP);
            hz_image_write_png(path, img, W, H, &err);
        }
        print_message("fade %.2f: %llu leaves, %llu foliage pixels\n", (double)fades[k], (unsigned long long)leaves[k],
                      (unsigned long long)cover[k]);
    }
    /* Leaves: (1 - step) of the count at fade 0, give or take one per node
     * (each node keeps a whole number, at least one). */
    for (int k = 1; k < N - 1; k++) {
        const double keep = 1.0 - floor(fades[k] * 16.0) / 16.0;
        assert_true(fabs((double)leaves[k] - keep * (double)leaves[0]) <= (double)t->node_count);
        assert_true(leaves[k] < leaves[k - 1]);
    }
    assert_int_equal(leaves[N - 1], 0); /* the hull alone */
    /* The crown's foliage neither thins nor swells through the band: the
     * leaves left are enlarged to the node's coverage, and the dither hands
     * their pixels over to the hull (none pops out at the band's end). */
    const uint64_t lo = cover[0] < cover[N - 1] ? cover[0] : cover[N - 1];
    const uint64_t hi = cover[0] > cover[N - 1] ? cover[0] : cover[N - 1];
    assert_true(lo > (uint64_t)(W * H) / 40);
    for (int k = 1; k < N - 1; k++)
        assert_true((double)cover[k] > 0.93 * (double)lo && (double)cover[k] < 1.07 * (double)hi);
    free(sky);
    free(img);
    one_model_free(&om);
    hz_renderer_destroy(ren);
}

/* The effects' billboards show the forest's trees: a sprite from the
 * impostor's side view stands on its trunk at the bottom centre, reaches the
 * top of the image, and is mostly foliage-coloured where it is opaque. */
static void test_forest_sprite(void **state)
{
    (void)state;
    enum { W = 64, H = 128 };
    hz_err err = {0};
    hz_renderer *ren = hz_renderer_create(&(hz_renderer_desc){.width = 64, .height = 64}, &err);
    assert_non_null(ren);
    static const char *const species[2] = {"conifer", "oak"};
    static const float width[2] = {0.5f, 0.85f}; /* as the billboards of each kind */
    for (int k = 0; k < 2; k++) {
        hz_forest_tree trees[1] = {{.scale = 1}};
        one_model om = one_model_forest(&(hz_tree_desc){.species = species[k], .seed = 2}, trees, 1);
        hz_forest *f = om.f;
        hz_forest_gpu *gpu = om.gpu;
        uint8_t *px = malloc(W * H * 4);
        assert_int_equal(hz_forest_gpu_sprite(gpu, f, 1, width[k], W, H, px, &err), HZ_ERR_VALUE);
        assert_int_equal(hz_forest_gpu_sprite(gpu, f, 0, NAN, W, H, px, &err), HZ_ERR_VALUE);
        assert_int_equal(hz_forest_gpu_sprite(gpu, f, 0, width[k], W, H, px, &err), HZ_OK);
        uint32_t opaque = 0, green = 0, top = H, edge = 0;
        for (uint32_t y = 0; y < H; y++)
            for (uint32_t x = 0; x < W; x++) {
                const uint8_t *p = px + (y * W + x) * 4;
                if (p[3] < 128)
                    continue;
                opaque++;
                green += p[1] > p[0] && p[1] > p[2];
                top = y < top ? y : top;
                edge += x == 0 || x == W - 1;
            }
        /* the trunk at the foot, in the middle */
        uint32_t foot = 0;
        for (uint32_t x = W / 2 - 3; x <= W / 2 + 2; x++)
            foot += px[((H - 2) * W + x) * 4 + 3] >= 128;
        char path[512];
        snprintf(path, sizeof path, "%s/forest_sprite_%s.png", HZ_TEST_TMP, species[k]);
        uint8_t *rgb = malloc(W * H * 3); /* over magenta, to look at */
        for (uint32_t i = 0; i < W * H; i++)
            for (int c = 0; c < 3; c++)
                rgb[i * 3 + c] = px[i * 4 + 3] >= 128 ? px[i * 4 + c] : (c == 1 ? 0 : 255);
        hz_image_write_png(path, rgb, W, H, &err);
        free(rgb);
        print_message("%s sprite: %.1f %% opaque, %.1f %% of it green, top row %u, foot %u, edge %u\n", species[k],
                      100.0 * opaque / (W * H), 100.0 * green / (opaque ? opaque : 1), top, foot, edge);
        assert_true(opaque > W * H / 10);
        assert_true(green > opaque / 2);
        assert_true(top <= H / 12);
        assert_true(foot > 0);
        assert_true(edge < H / 4);
        free(px);
        one_model_free(&om);
    }
    hz_renderer_destroy(ren);
}

/* Impostors given back (from a cache) instead of baked: the frame is the
 * baked one's, byte for byte; the given bytes are what is drawn (zeros draw
 * nothing); the key follows what the bake depends on. */
static void test_impostor_given(void **state)
{
    (void)state;
    enum { W = 160, H = 120 };
    hz_err err = {0};
    hz_renderer *ren = hz_renderer_create(&(hz_renderer_desc){.width = W, .height = H}, &err);
    assert_non_null(ren);
    hz_forest_tree tree = {.pos = {0, 0, -400}, .scale = 1};
    one_model om = one_model_forest(&(hz_tree_desc){.species = "oak", .seed = 1, .leaves = 8000}, &tree, 1);
    assert_true(hz_forest_gpu_impostor_baked(om.gpu, 0));
    const size_t bytes = hz_forest_gpu_impostor_bytes();
    uint8_t *imp = malloc(bytes), *zero = calloc(1, bytes);
    assert_non_null(imp);
    assert_non_null(zero);
    assert_int_equal(hz_forest_gpu_impostor_read(om.gpu, 0, imp, &err), HZ_OK);
    assert_int_equal(hz_forest_gpu_impostor_read(om.gpu, 1, imp, &err), HZ_ERR_VALUE);
    size_t covered = 0;
    for (size_t k = 3; k < bytes / 2; k += 4)
        covered += imp[k] != 0;
    assert_true(covered > 1000); /* the albedo atlas holds the tree's views */
    hz_camera cam = {.pos = {0, 8, 16}, .yaw = 0, .pitch = 0, .fov_y = 5, .aspect = (float)W / H, .znear = 0.3f,
                     .zfar = 3000};
    hz_forest_params fp = {.simplify = true};
    uint8_t *px[4];
    const uint8_t *given[3][1] = {{NULL}, {imp}, {zero}};
    for (int k = 0; k < 4; k++) {
        px[k] = malloc(W * H * 3);
        assert_non_null(px[k]);
        hz_forest_gpu *g = k == 0 ? om.gpu : NULL;
        if (k > 0 && k < 4) {
            g = hz_forest_gpu_create_with(om.f, &(hz_forest_gpu_desc){.impostors = k == 3 ? NULL : given[k]}, &err);
            assert_non_null(g);
            assert_true(hz_forest_gpu_impostor_baked(g, 0) == (k == 3));
        }
        hz_forest_frame fr;
        hz_forest_hook hook = {.gpu = g, .forest = om.f, .frame = &fr};
        hz_scene_params sp = {.fog_density = -1, .draw_objects = hz_forest_draw_hook, .draw_objects_user = &hook};
        assert_int_equal(hz_forest_update(om.f, &cam, &fp, 0, &fr, &err), HZ_OK);
        assert_int_equal(fr.trees_impostor, 1);
        assert_int_equal(hz_renderer_draw(ren, &cam, &sp, NULL, 0, NULL, &err), HZ_OK);
        assert_false(hook.failed);
        assert_int_equal(hz_renderer_read_rgb(ren, px[k], &err), HZ_OK);
        if (g != om.gpu)
            hz_forest_gpu_destroy(g);
    }
    /* 0 baked, 1 given its bytes, 2 given zeros, 3 baked again (NULL array). */
    assert_memory_equal(px[0], px[1], W * H * 3);
    assert_memory_equal(px[0], px[3], W * H * 3);
    assert_true(count_diff(px[0], px[2], W * H) > 200); /* the tree is there, and drawn from what was given */
    /* The key: the same for the same tree, another when the leaves or colours change. */
    const uint64_t key = hz_forest_gpu_impostor_key(om.t);
    assert_true(key == hz_forest_gpu_impostor_key(om.t));
    om.t->leaves[17].c[1] += 0.01f;
    assert_true(key != hz_forest_gpu_impostor_key(om.t));
    om.t->leaves[17].c[1] -= 0.01f;
    assert_true(key == hz_forest_gpu_impostor_key(om.t));
    om.t->leaf_color[0] *= 1.01f;
    assert_true(key != hz_forest_gpu_impostor_key(om.t));
    hz_tree *other = hz_tree_grow(&(hz_tree_desc){.species = "oak", .seed = 2, .leaves = 8000}, &err);
    assert_non_null(other);
    assert_true(key != hz_forest_gpu_impostor_key(other));
    hz_tree_destroy(other);
    for (int k = 0; k < 4; k++)
        free(px[k]);
    free(imp);
    free(zero);
    one_model_free(&om);
    hz_renderer_destroy(ren);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rank_hidden_leaf_last),
        cmocka_unit_test(test_rank_in_tree),
        cmocka_unit_test(test_rank_min_elevation),
        cmocka_unit_test(test_pr),
        cmocka_unit_test(test_pr_hand_made),
        cmocka_unit_test(test_pr_same_leaf),
        cmocka_unit_test(test_vmi_beats_random),
        cmocka_unit_test(test_pr_random_pooled),
        cmocka_unit_test(test_forest_draw),
        cmocka_unit_test(test_point_leaves_match_quads),
        cmocka_unit_test(test_hull_looks_like_impostor),
        cmocka_unit_test(test_leaves_fade_to_hull),
        cmocka_unit_test(test_forest_sprite),
        cmocka_unit_test(test_impostor_given),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
