/* The LOD modes (quadtree, remedy, bidirectional, roam, cdlod): crack-free
 * meshes on many random cameras over rough synthetic, generated and real
 * terrain; the pixel-error bound of roam and cdlod; cdlod's geomorphing keeps
 * the surface continuous while the camera moves (no popping); roam's frame
 * coherence and budget; bidirectional's two repairs. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "horizon/dem.h"
#include "horizon/lod.h"
#include "horizon/metrics.h"
#include "mesh_check.h"

static uint64_t rng_state = 0x1234567887654321ULL;
static float frand(float lo, float hi)
{
    return test_frand(&rng_state, lo, hi);
}

typedef struct terrain {
    const char *name;
    hz_heightmap hm;
    hz_lod *lod;
    float spacing;
} terrain;

static void make_random_grid(hz_grid *g, uint32_t n, float amp)
{
    assert_int_equal(hz_grid_alloc(g, n, n, NULL), HZ_OK);
    for (uint32_t j = 0; j < n; j++)
        for (uint32_t i = 0; i < n; i++) {
            float x = (float)i / (float)n, z = (float)j / (float)n;
            float h = amp * (0.5f + 0.25f * sinf(9.0f * x) * cosf(7.0f * z) + 0.1f * sinf(31.0f * x + 3 * z));
            /* rough patches next to smooth ones: large level differences */
            float rough = (sinf(5.0f * x + 1.0f) * cosf(4.0f * z) > 0.3f) ? 0.08f : 0.0005f;
            g->z[(size_t)j * n + i] = h + frand(0, amp * rough);
        }
}

static void terrain_init(terrain *t, const char *name, hz_grid *g, float spacing)
{
    hz_err err = {0};
    t->name = name;
    t->spacing = spacing;
    assert_int_equal(hz_heightmap_create(&t->hm, g, HZ_LAYOUT_BLOCKED, &err), HZ_OK);
    t->lod = hz_lod_create(&(hz_lod_desc){.hm = &t->hm, .spacing = spacing, .zscale = 1.0f}, &err);
    assert_non_null(t->lod);
}

static void terrain_free(terrain *t)
{
    hz_lod_destroy(t->lod);
    hz_heightmap_destroy(&t->hm);
}

static hz_camera random_camera(const terrain *t)
{
    return test_random_camera(&rng_state, &t->hm, t->spacing);
}

static hz_lod_params random_params(hz_lod_mode mode, int k)
{
    hz_lod_params p = {.mode = mode, .no_cull = (k % 5) == 0};
    if (mode == HZ_LOD_ROAM || mode == HZ_LOD_CDLOD || (k & 2)) {
        p.pixel_error = frand(0.3f, 8.0f);
        p.viewport_height = (uint32_t)frand(200, 1200);
    } else {
        p.c = frand(2, 60);
        p.c2 = frand(0.5f, 10);
        p.criterion = (k & 1) ? HZ_LOD_UNCLAMPED : HZ_LOD_CLAMPED;
    }
    if (mode == HZ_LOD_BIDIRECTIONAL)
        p.bidir_distance = frand(0, 2) * (float)(k % 3); /* 0 = default */
    if (mode == HZ_LOD_ROAM && (k % 4) == 3)
        p.roam_budget = (uint32_t)frand(50, 5000);
    if (mode == HZ_LOD_CDLOD)
        p.morph_start = frand(0.5f, 0.98f); /* below 0.8 is clamped */
    if (mode == HZ_LOD_CDLOD && (k % 3) == 1) { /* a looser bound near the eye */
        p.near_pixel_error = p.pixel_error * frand(1.2f, 6.0f);
        p.near_distance = frand(20.0f, 1500.0f);
    }
    return p;
}

typedef struct mode_totals {
    size_t triangles, jumps_frames, empty, forced_frames;
} mode_totals;

static void check_mode(terrain *t, hz_lod_mode mode, int cameras, mode_totals *tot)
{
    hz_index_list il = {0};
    hz_node_list leaves = {0};
    const bool restricted = mode == HZ_LOD_QUADTREE || mode == HZ_LOD_BIDIRECTIONAL || mode == HZ_LOD_CDLOD;
    for (int k = 0; k < cameras; k++) {
        hz_camera cam = random_camera(t);
        hz_lod_params p = random_params(mode, k);
        hz_lod_stats st;
        assert_int_equal(hz_lod_select(t->lod, &cam, &p, &il, &leaves, NULL, &st), HZ_OK);
        assert_int_equal(il.count, (size_t)st.triangles * 3);
        if (mode == HZ_LOD_ROAM && p.roam_budget)
            assert_true(st.triangles <= p.roam_budget);
        vec4 planes[6];
        hz_camera_frustum(&cam, planes);
        mesh_report r = mesh_check(&t->hm, t->spacing, 1.0f, il.data, il.count,
                                   p.no_cull ? NULL : (const vec4 *)planes, mode == HZ_LOD_ROAM ? NULL : &leaves);
        char label[96];
        snprintf(label, sizeof label, "%s %s camera %d", t->name, hz_lod_mode_name(mode), k);
        mesh_assert_valid(&r, restricted, label);
        if (p.no_cull && !(mode == HZ_LOD_ROAM && p.roam_budget))
            assert_true(fabs(r.area - (double)(t->hm.size - 1) * (double)(t->hm.size - 1)) < 1e-6);
        tot->triangles += r.triangles;
        tot->jumps_frames += r.level_jumps > 0;
        tot->empty += r.triangles == 0;
        tot->forced_frames += st.forced > 0;
    }
    free(il.data);
    free(leaves.data);
}

static void test_mode_names(void **state)
{
    (void)state;
    for (int m = 0; m < HZ_LOD_MODE_COUNT; m++) {
        hz_lod_mode back;
        assert_true(hz_lod_mode_from_name(hz_lod_mode_name((hz_lod_mode)m), &back));
        assert_int_equal(back, m);
    }
    hz_lod_mode x;
    assert_false(hz_lod_mode_from_name("rottger", &x));
    assert_false(hz_lod_mode_from_name(NULL, &x));
}

static void test_modes_valid_synthetic(void **state)
{
    (void)state;
    const uint32_t sizes[] = {33, 257};
    mode_totals tot[HZ_LOD_MODE_COUNT] = {0};
    for (size_t si = 0; si < 2; si++) {
        hz_grid g;
        make_random_grid(&g, sizes[si], 400.0f);
        terrain t;
        terrain_init(&t, "random", &g, 10.0f);
        for (int m = 0; m < HZ_LOD_MODE_COUNT; m++)
            check_mode(&t, (hz_lod_mode)m, 50, &tot[m]);
        terrain_free(&t);
        hz_grid_free(&g);
    }
    for (int m = 0; m < HZ_LOD_MODE_COUNT; m++) {
        assert_true(tot[m].triangles > 1000);
        /* the cameras look at the terrain: at most 1 in 10 sees none of it */
        fprintf(stderr, "%-13s %zu of 100 cameras saw no terrain, %zu forced splits\n",
                hz_lod_mode_name((hz_lod_mode)m), tot[m].empty, tot[m].forced_frames);
        assert_true(tot[m].empty <= 10);
    }
    /* remedy really meets neighbours two or more levels apart (and stays
     * crack-free); the repairs of the other modes leave none. */
    assert_true(tot[HZ_LOD_REMEDY].jumps_frames > 5);
}

static void test_modes_valid_generated_and_real(void **state)
{
    (void)state;
    for (int f = 0; f < 2; f++) {
        hz_grid g;
        hz_err err = {0};
        if (f == 0) {
            assert_int_equal(hz_generate(&(hz_gen_desc){.kind = HZ_GEN_DIAMOND, .size = 513, .seed = 3}, &g, &err),
                             HZ_OK);
        } else {
            hz_dem_info info;
            if (hz_dem_load(&(hz_dem_desc){.path = HZ_DATA_DIR "/N44W072.hgt"}, &g, &info, &err) != HZ_OK)
                fail_msg("N44W072.hgt: %s", err.msg);
            assert_int_equal(hz_grid_fill_voids(&g, NULL, &err), HZ_OK);
            assert_int_equal(hz_grid_fit_pow2(&g, HZ_FIT_AUTO, NULL, 0, &err), HZ_OK);
        }
        terrain t;
        terrain_init(&t, f ? "N44W072" : "diamond", &g, f ? 90.0f : 10.0f);
        mode_totals tot = {0};
        for (int m = 0; m < HZ_LOD_MODE_COUNT; m++)
            check_mode(&t, (hz_lod_mode)m, 16, &tot);
        terrain_free(&t);
        hz_grid_free(&g);
    }
}

/* ---- error bound ---- */

typedef struct morph_user {
    hz_lod *lod;
    const hz_camera *cam;
    const hz_lod_stats *st;
} morph_user;

static float morph_h(void *user, uint32_t index)
{
    morph_user *u = user;
    return hz_lod_morph_height(u->lod, u->cam, u->st, index);
}

/* A 257^2 Perlin terrain at 10 m for the error-bound tests. */
static void perlin_terrain(hz_grid *g, terrain *t)
{
    hz_err err = {0};
    assert_int_equal(hz_generate(&(hz_gen_desc){.kind = HZ_GEN_PERLIN, .size = 257, .seed = 11}, g, &err), HZ_OK);
    terrain_init(t, "perlin", g, 10.0f);
}

/* cdlod patches for cam and p into pl: nearest first (to within 1/32 of a
 * doubling, 3 %), and the selection's invariant, exactly: no node is drawn
 * inside its split range (a 1 % shorter range would break it). Returns the
 * nodes checked against their range (the finest patches are exact). */
static size_t check_patch_ranges(terrain *t, const hz_camera *cam, const hz_lod_params *p, int k, hz_patch_list *pl,
                                 hz_lod_stats *st)
{
    assert_int_equal(hz_lod_select_patches(t->lod, cam, p, pl, st), HZ_OK);
    const uint32_t lp_level = (uint32_t)(log2((t->hm.size - 1) / hz_lod_patch_cells(t->lod)));
    size_t ranged = 0;
    for (size_t q = 0; q < pl->count; q++) {
        if (q)
            assert_true(pl->data[q].dist >= (pl->data[q - 1].dist + 1.0f) * 0.969f - 1.0f);
        if (pl->data[q].level >= lp_level)
            continue;
        const float range = hz_lod_morph_range(st, hz_lod_patch_error(t->lod, &pl->data[q]));
        if (pl->data[q].dist < range * 0.99f)
            fprintf(stderr, "cdlod camera %d: a level-%u node at %.1f m inside its range %.1f m\n", k,
                    pl->data[q].level, (double)pl->data[q].dist, (double)range);
        assert_true(pl->data[q].dist >= range * 0.99f);
        ranged++;
    }
    return ranged;
}

/* roam's wedgies and cdlod's nested bounds are strict: no sample in the
 * frustum is off by more than tau pixels on the surface as drawn. */
static void test_pixel_error_bound(void **state)
{
    (void)state;
    hz_grid g;
    terrain t;
    perlin_terrain(&g, &t);
    hz_index_list il = {0};
    hz_patch_list pl = {0};
    hz_float_buf scratch = {0};
    double worst[2] = {0, 0};
    size_t ranged = 0;
    const hz_lod_mode modes[2] = {HZ_LOD_ROAM, HZ_LOD_CDLOD};
    for (int mi = 0; mi < 2; mi++)
        for (int k = 0; k < 25; k++) {
            hz_camera cam = random_camera(&t);
            const float tau = frand(0.5f, 6.0f);
            const uint32_t H = 720;
            hz_lod_params p = {.mode = modes[mi], .pixel_error = tau, .viewport_height = H};
            hz_lod_stats st;
            assert_int_equal(hz_lod_select(t.lod, &cam, &p, &il, NULL, NULL, &st), HZ_OK);
            morph_user mu = {t.lod, &cam, &st};
            hz_px_error pe;
            assert_int_equal(hz_metrics_px_error_ex(&t.hm, t.spacing, 1.0f, il.data, il.count,
                                                    modes[mi] == HZ_LOD_CDLOD ? morph_h : NULL, &mu, &cam, H,
                                                    &scratch, &pe),
                             HZ_OK);
            if (pe.max_px > tau * 1.001 + 1e-4)
                fprintf(stderr, "%s camera %d: tau %.3f max %.4f px\n", hz_lod_mode_name(modes[mi]), k, tau,
                        pe.max_px);
            assert_true(pe.max_px <= tau * 1.001 + 1e-4);
            assert_int_equal(pe.uncovered, 0);
            /* a camera that sees next to nothing proves nothing */
            assert_true(pe.samples >= 500);
            worst[mi] = pe.max_px / tau > worst[mi] ? pe.max_px / tau : worst[mi];
            if (modes[mi] == HZ_LOD_CDLOD)
                ranged += check_patch_ranges(&t, &cam, &p, k, &pl, &st);
        }
    fprintf(stderr, "largest error / tau: roam %.3f, cdlod %.3f; %zu cdlod nodes checked against their range\n",
            worst[0], worst[1], ranged);
    assert_true(ranged > 100);
    free(il.data);
    free(pl.data);
    hz_float_buf_free(&scratch);
    terrain_free(&t);
    hz_grid_free(&g);
}

/* A rough 257^2 terrain for the patch tests. */
static void rough_terrain(hz_grid *g, terrain *t)
{
    make_random_grid(g, 257, 400.0f);
    terrain_init(t, "rough", g, 10.0f);
}

/* cdlod patches for cam at a random bound; every other k at a random morph
 * start, the others at the default. */
static void random_patches(terrain *t, int k, const hz_camera *cam, hz_patch_list *pl, hz_lod_stats *st)
{
    hz_lod_params p = {.mode = HZ_LOD_CDLOD, .pixel_error = frand(0.5f, 4.0f), .viewport_height = 720,
                       .morph_start = (k & 1) ? 0.0f : frand(0.8f, 0.98f)};
    if (k % 4 == 2) { /* a near bound */
        p.near_pixel_error = 4.0f * p.pixel_error;
        p.near_distance = frand(50.0f, 800.0f);
    }
    assert_int_equal(hz_lod_select_patches(t->lod, cam, &p, pl, st), HZ_OK);
}

/* Asserts that every vertex of the square of patch vertices at (x0, z0),
 * side samples wide and step apart, lies in box as drawn for cam and st,
 * and that box has the square's footprint; true when a vertex lies beyond
 * the heights of the square's own samples. */
static bool square_holds_drawn(terrain *t, const hz_camera *cam, const hz_lod_stats *st, uint32_t x0, uint32_t z0,
                               uint32_t side, uint32_t step, vec3 box[2], size_t *vertices, size_t *moved)
{
    assert_true(box[0][0] == (float)x0 * t->spacing && box[1][0] == (float)(x0 + side) * t->spacing);
    assert_true(box[0][2] == (float)z0 * t->spacing && box[1][2] == (float)(z0 + side) * t->spacing);
    vec3 nb[2];
    assert_true(hz_lod_node_box(t->lod, x0 + side / 2, z0 + side / 2, side / 2, nb));
    const uint32_t n = t->hm.size;
    bool out = false;
    for (uint32_t j = z0; j <= z0 + side; j += step)
        for (uint32_t i = x0; i <= x0 + side; i += step) {
            const float h = hz_lod_morph_height(t->lod, cam, st, j * n + i);
            assert_true(h >= box[0][1] - 1e-3f && h <= box[1][1] + 1e-3f);
            out |= h < nb[0][1] - 1e-3f || h > nb[1][1] + 1e-3f;
            (*vertices)++;
            *moved += fabsf(h - hz_heightmap_get(&t->hm, i, j)) > 1e-3f;
        }
    return out;
}

/* Every block of patch pt (hz_lod_patch_block_box, at every cut up to
 * hz_lod_patch_blocks per side) holds its vertices as drawn and lies within
 * the box of the block of the coarser cut holding it (the patch's first);
 * the number of finest blocks with a vertex beyond their samples' heights. */
static size_t blocks_hold_drawn(terrain *t, const hz_camera *cam, const hz_lod_stats *st, const hz_patch *pt,
                                vec3 pbox[2], size_t *vertices, size_t *moved)
{
    const uint32_t P = hz_lod_patch_cells(t->lod), B = hz_lod_patch_blocks(P);
    vec3 prev[4][4][2], cur[4][4][2];
    assert_true(hz_lod_patch_block_box(t->lod, pt, 1, 0, 0, cam, st, prev[0][0]));
    assert_memory_equal(prev[0][0], pbox, sizeof(vec3[2]));
    size_t out = 0;
    for (uint32_t per = 2; per <= B; per *= 2) {
        const uint32_t side = (P / per) << pt->shift;
        for (uint32_t bz = 0; bz < per; bz++)
            for (uint32_t bx = 0; bx < per; bx++) {
                float(*box)[3] = cur[bz][bx];
                const float(*up)[3] = prev[bz / 2][bx / 2];
                assert_true(hz_lod_patch_block_box(t->lod, pt, per, bx, bz, cam, st, box));
                assert_true(box[0][1] >= up[0][1] - 1e-3f && box[1][1] <= up[1][1] + 1e-3f);
                const bool o = square_holds_drawn(t, cam, st, pt->x0 + bx * side, pt->z0 + bz * side, side,
                                                  1u << pt->shift, box, vertices, moved);
                out += per == B && o;
            }
        memcpy(prev, cur, sizeof prev);
    }
    vec3 none[2];
    assert_false(hz_lod_patch_block_box(t->lod, pt, B, B, 0, cam, st, none));
    assert_false(hz_lod_patch_block_box(t->lod, pt, 2 * B, 0, 0, cam, st, none));
    assert_false(hz_lod_patch_block_box(t->lod, pt, 3, 0, 0, cam, st, none));
    assert_false(hz_lod_patch_block_box(t->lod, pt, 0, 0, 0, cam, st, none));
    return out;
}

/* The boxes occlusion culling tests a patch and its blocks by
 * (hz_lod_patch_box, hz_lod_patch_block_box) hold every vertex of them as
 * drawn, morphed, for any camera and bound; and they are tight: a patch's
 * within the heights of its node and its eight neighbours of the same size
 * (a patch's corners may collapse toward samples beyond it), not those of a
 * far larger ancestor; a block's within its patch's. */
static void test_cdlod_patch_box_holds_drawn(void **state)
{
    (void)state;
    hz_grid g;
    terrain t;
    rough_terrain(&g, &t);
    hz_patch_list pl = {0};
    size_t vertices = 0, moved = 0, near = 0, patches = 0;
    assert_int_equal(hz_lod_patch_cells(t.lod), 8);
    assert_int_equal(hz_lod_patch_blocks(8), 4);
    assert_int_equal(hz_lod_patch_blocks(64), 4);
    assert_int_equal(hz_lod_patch_blocks(4), 2);
    assert_int_equal(hz_lod_patch_blocks(2), 1);
    for (int k = 0; k < 40; k++) {
        hz_camera cam = random_camera(&t);
        hz_lod_stats st;
        random_patches(&t, k, &cam, &pl, &st);
        for (size_t q = 0; q < pl.count; q++) {
            const hz_patch *pt = &pl.data[q];
            vec3 box[2];
            assert_true(hz_lod_patch_box(t.lod, pt, &cam, &st, box));
            const uint32_t side = hz_lod_patch_cells(t.lod) << pt->shift;
            square_holds_drawn(&t, &cam, &st, pt->x0, pt->z0, side, 1u << pt->shift, box, &vertices, &moved);
            blocks_hold_drawn(&t, &cam, &st, pt, box, &vertices, &moved);
            /* the heights of the 3 x 3 nodes of the patch's size around it */
            const uint32_t half = side / 2;
            float nlo = INFINITY, nhi = -INFINITY;
            for (int dz = -1; dz <= 1; dz++)
                for (int dx = -1; dx <= 1; dx++) {
                    const int64_t cx = (int64_t)pt->x0 + half + dx * (int64_t)side;
                    const int64_t cz = (int64_t)pt->z0 + half + dz * (int64_t)side;
                    vec3 nb[2];
                    if (cx > 0 && cz > 0 && hz_lod_node_box(t.lod, (uint32_t)cx, (uint32_t)cz, half, nb))
                        nlo = fminf(nlo, nb[0][1]), nhi = fmaxf(nhi, nb[1][1]);
                }
            assert_true(nlo <= nhi); /* the patch's own node */
            near += box[0][1] >= nlo - 1e-3f && box[1][1] <= nhi + 1e-3f;
            patches++;
        }
        assert_true(pl.count > 0);
    }
    fprintf(stderr,
            "patch boxes: %zu vertices inside (patches and blocks), %zu of them morphed; of %zu patch boxes %zu "
            "within their 3 x 3 nodes' heights\n",
            vertices, moved, patches, near);
    assert_true(moved > 1000);
    assert_true((double)near >= 0.95 * (double)patches);
    /* The selection never had a patch corner morphing in these frames, but
     * a corner collapses toward samples beyond its square: with every range
     * a thousandth as long, all vertices are fully morphed, and the boxes
     * must still hold them, beyond their samples' heights where a corner
     * moves out. */
    hz_camera cam = random_camera(&t);
    hz_lod_stats st;
    random_patches(&t, 1, &cam, &pl, &st);
    st.morph_scale *= 1e-3f;
    size_t outside = 0, blocks_outside = 0;
    for (size_t q = 0; q < pl.count; q++) {
        hz_patch *pt = &pl.data[q];
        pt->still = 0; /* the selection's flag, for other ranges */
        vec3 box[2];
        assert_true(hz_lod_patch_box(t.lod, pt, &cam, &st, box));
        outside += square_holds_drawn(&t, &cam, &st, pt->x0, pt->z0, hz_lod_patch_cells(t.lod) << pt->shift,
                                      1u << pt->shift, box, &vertices, &moved);
        blocks_outside += blocks_hold_drawn(&t, &cam, &st, pt, box, &vertices, &moved);
    }
    fprintf(stderr,
            "fully morphed: %zu of %zu patches and %zu of %zu blocks draw a vertex beyond their samples' heights\n",
            outside, pl.count, blocks_outside, 16 * pl.count);
    assert_true(outside > 0 && blocks_outside > 0);
    hz_lod_stats st0 = {0};
    assert_false(hz_lod_patch_box(t.lod, &(hz_patch){.x0 = 3, .z0 = 0, .level = 3}, &(hz_camera){0}, &st0,
                                  (vec3[2]){{0}})); /* no node */
    free(pl.data);
    terrain_free(&t);
    hz_grid_free(&g);
}

/* What horizon culling builds on: a drawn (morphed) vertex of a patch leaves
 * the range of the samples of the two-cell block around it by at most
 * d / (a lambda) (d its distance, a the morph start, lambda = K / tau): a
 * vertex morphs toward two neighbours in the block, each moved at most its
 * morph error, which it only does beyond a lambda times that error. Checked
 * for every vertex of every patch over random cameras and bounds; not
 * vacuous: many vertices are morphing. (None left its block's range in these
 * runs: the bound covers a coarse vertex of a patch that reaches far beyond
 * its parent's range, which may itself be morphing toward samples beyond
 * the block.) */
static void test_cdlod_morph_stays_near_samples(void **state)
{
    (void)state;
    hz_grid g;
    terrain t;
    rough_terrain(&g, &t);
    hz_patch_list pl = {0};
    const uint32_t n = t.hm.size, P = hz_lod_patch_cells(t.lod);
    size_t vertices = 0, outside = 0, moved = 0;
    for (int k = 0; k < 30; k++) {
        hz_camera cam = random_camera(&t);
        hz_lod_stats st;
        const float tau = frand(0.5f, 4.0f);
        hz_lod_params p = {.mode = HZ_LOD_CDLOD, .pixel_error = tau, .viewport_height = 720,
                           .morph_start = (k & 1) ? 0.0f : frand(0.8f, 0.98f), .no_cull = true};
        if (k % 3 == 1) { /* a near bound: the reach is that of near_pixel_error */
            p.near_pixel_error = tau * frand(1.5f, 5.0f);
            p.near_distance = frand(50.0f, 1000.0f);
        }
        assert_int_equal(hz_lod_select_patches(t.lod, &cam, &p, &pl, &st), HZ_OK);
        const float lambda = 720.0f / (2.0f * tanf(glm_rad(cam.fov_y > 0 ? cam.fov_y : 60.0f) * 0.5f)) /
                             (p.near_pixel_error > tau ? p.near_pixel_error : tau);
        /* the near vertices' widened morph zones start earlier, at 0.8 at the earliest */
        const float qn = p.near_pixel_error > tau ? p.near_pixel_error / tau : 1.0f;
        const float amin = qn > 1.0f ? fmaxf(0.8f, 1.0f - (1.0f - st.morph_start) * qn * qn) : st.morph_start;
        for (size_t q = 0; q < pl.count; q++) {
            const hz_patch *pt = &pl.data[q];
            const uint32_t step = 1u << pt->shift;
            for (uint32_t b = 0; b <= P; b++)
                for (uint32_t a = 0; a <= P; a++) {
                    const uint32_t i = pt->x0 + a * step, j = pt->z0 + b * step;
                    const uint32_t bi = pt->x0 + (a / 2 < P / 2 ? a / 2 : P / 2 - 1) * 2 * step;
                    const uint32_t bj = pt->z0 + (b / 2 < P / 2 ? b / 2 : P / 2 - 1) * 2 * step;
                    float lo = INFINITY, hi = -INFINITY;
                    for (uint32_t y = bj; y <= bj + 2 * step; y++)
                        for (uint32_t x = bi; x <= bi + 2 * step; x++) {
                            const float h = hz_heightmap_get(&t.hm, x, y);
                            lo = fminf(lo, h), hi = fmaxf(hi, h);
                        }
                    const float dx = (float)i * t.spacing - cam.pos[0], dz = (float)j * t.spacing - cam.pos[2];
                    const float dy = hz_heightmap_get(&t.hm, i, j) - cam.pos[1];
                    const float reach = sqrtf(dx * dx + dy * dy + dz * dz) / (amin * lambda);
                    const float h = hz_lod_morph_height(t.lod, &cam, &st, j * n + i);
                    assert_true(h >= lo - reach - 1e-3f && h <= hi + reach + 1e-3f);
                    outside += h < lo - 1e-3f || h > hi + 1e-3f;
                    moved += fabsf(h - hz_heightmap_get(&t.hm, i, j)) > 1e-3f;
                    vertices++;
                }
        }
    }
    fprintf(stderr, "morphed vertices near their samples: %zu vertices, %zu morphed, %zu outside the samples' range\n",
            vertices, moved, outside);
    assert_true(moved > 1000);
    free(pl.data);
    terrain_free(&t);
    hz_grid_free(&g);
}

/* Horizon culling needs the eye above the ground, no ground nearer than the
 * near plane can clip, and the map drawn whole: flying low over the ridges it
 * hides patches; the same camera under the ground, half a metre over it (1 m
 * near plane), off the map, or over a map with samples not drawn, hides none
 * (a ray may pass under the ground through a hole, a clipped piece of it, or
 * from under it). */
static void test_cdlod_horizon_culling_conditions(void **state)
{
    (void)state;
    hz_grid g;
    terrain t;
    rough_terrain(&g, &t);
    hz_err err = {0};
    hz_lod *holes = hz_lod_create(&(hz_lod_desc){.hm = &t.hm, .spacing = t.spacing, .zscale = 1.0f, .holes = true}, &err);
    assert_non_null(holes);
    hz_patch_list pl = {0};
    size_t hidden = 0, views = 0;
    const float side = t.spacing * (float)(t.hm.size - 1);
    rng_state = 0x9876543210abcdefULL; /* its own cameras, whatever the tests before drew */
    for (int k = 0; k < 16; k++) {
        hz_camera cam = {.fov_y = 60, .aspect = 16.0f / 9, .znear = 1, .zfar = 1e5f, .yaw = 22.5f * (float)k,
                         .pitch = -2};
        cam.pos[0] = side * frand(0.3f, 0.7f), cam.pos[2] = side * frand(0.3f, 0.7f);
        const float ground = hz_heightmap_get(&t.hm, (uint32_t)(cam.pos[0] / t.spacing + 0.5f),
                                              (uint32_t)(cam.pos[2] / t.spacing + 0.5f));
        cam.pos[1] = ground + 20.0f;
        hz_lod_params p = {.mode = HZ_LOD_CDLOD, .pixel_error = 1.0f, .viewport_height = 720, .horizon_cull = true};
        hz_lod_stats st;
        assert_int_equal(hz_lod_select_patches(t.lod, &cam, &p, &pl, &st), HZ_OK);
        hidden += st.hidden;
        views += st.hidden > 0;
        p.horizon_cull = false; /* the default: off */
        assert_int_equal(hz_lod_select_patches(t.lod, &cam, &p, &pl, &st), HZ_OK);
        assert_int_equal(st.hidden, 0);
        p.horizon_cull = true;
        assert_int_equal(hz_lod_select_patches(holes, &cam, &p, &pl, &st), HZ_OK);
        assert_int_equal(st.hidden, 0);
        p.no_cull = true;
        assert_int_equal(hz_lod_select_patches(t.lod, &cam, &p, &pl, &st), HZ_OK);
        assert_int_equal(st.hidden, 0);
        p.no_cull = false;
        cam.pos[1] = ground - 5.0f; /* inside the hill */
        assert_int_equal(hz_lod_select_patches(t.lod, &cam, &p, &pl, &st), HZ_OK);
        assert_int_equal(st.hidden, 0);
        cam.pos[1] = ground + 0.5f; /* over the ground, but it is nearer than the near plane below */
        assert_int_equal(hz_lod_select_patches(t.lod, &cam, &p, &pl, &st), HZ_OK);
        assert_int_equal(st.hidden, 0);
        cam.pos[0] = -100.0f, cam.pos[1] = ground + 20.0f; /* off the map */
        assert_int_equal(hz_lod_select_patches(t.lod, &cam, &p, &pl, &st), HZ_OK);
        assert_int_equal(st.hidden, 0);
    }
    /* A plain with a 100 m wall across: from 10 m up the ground behind the
     * wall is hidden; from 0.5 m up, over the flat plain (every sample near
     * the eye below it), a ray down may meet the ground nearer than the 1 m
     * near plane, which clips it away: nothing is culled. */
    {
        hz_grid w;
        assert_int_equal(hz_grid_alloc(&w, 257, 257, NULL), HZ_OK);
        for (uint32_t j = 0; j < 257; j++)
            for (uint32_t i = 0; i < 257; i++)
                w.z[(size_t)j * 257 + i] = j >= 150 && j <= 155 ? 100.0f : 0.0f;
        terrain wt;
        terrain_init(&wt, "wall", &w, 10.0f);
        hz_camera cam = {.pos = {1280.0f, 10.0f, 600.0f}, .yaw = 180.0f, .fov_y = 60, .aspect = 16.0f / 9,
                         .znear = 1, .zfar = 1e5f};
        hz_lod_params p = {.mode = HZ_LOD_CDLOD, .pixel_error = 1.0f, .viewport_height = 720, .horizon_cull = true};
        hz_lod_stats st;
        assert_int_equal(hz_lod_select_patches(wt.lod, &cam, &p, &pl, &st), HZ_OK);
        fprintf(stderr, "behind a wall, from 10 m up: %u of %zu patches hidden\n", st.hidden, pl.count + st.hidden);
        assert_true(st.hidden > 0);
        cam.pos[1] = 0.5f;
        assert_int_equal(hz_lod_select_patches(wt.lod, &cam, &p, &pl, &st), HZ_OK);
        assert_int_equal(st.hidden, 0);
        terrain_free(&wt);
        hz_grid_free(&w);
    }
    fprintf(stderr, "horizon culling: %zu patches hidden in %d of 16 views 20 m over the ground\n", hidden, (int)views);
    assert_true(views >= 5); /* 7 to 10 of 16 with other seeds */
    free(pl.data);
    hz_lod_destroy(holes);
    terrain_free(&t);
    hz_grid_free(&g);
}

/* A patch the selection marks still (drawn without the morph code) has no
 * vertex that morphs, and one it marks simple (drawn with the simple morph)
 * no even vertex that morphs, for any camera, bound, morph start and Earth
 * curvature; and the marks are not vacuous: many patches carry each, many
 * of the others do morph, and so do many of the simple ones. */
static void test_cdlod_still_patches_do_not_morph(void **state)
{
    (void)state;
    hz_grid g;
    terrain t;
    rough_terrain(&g, &t);
    hz_patch_list pl = {0};
    size_t still = 0, moving = 0, morphing = 0, checked = 0, simple = 0, simple_morphing = 0, checked_even = 0;
    size_t within = 0; /* morphing vertices of simple patches checked within their block */
    for (int k = 0; k < 60; k++) {
        hz_camera cam = random_camera(&t);
        if (k % 3 == 2)
            cam.earth_radius = 20000.0f; /* a strong curvature: the shader measures to the lowered vertex */
        hz_lod_stats st;
        random_patches(&t, k, &cam, &pl, &st);
        const uint32_t n = t.hm.size;
        uint32_t marked = 0, marked_simple = 0;
        for (size_t q = 0; q < pl.count; q++) {
            const hz_patch *pt = &pl.data[q];
            const uint32_t step = 1u << pt->shift, side = hz_lod_patch_cells(t.lod) << pt->shift;
            bool any = false;
            assert_true(!pt->still || pt->simple);
            for (uint32_t j = pt->z0; j <= pt->z0 + side; j += step)
                for (uint32_t i = pt->x0; i <= pt->x0 + side; i += step) {
                    const float m = hz_lod_morph_factor(t.lod, &cam, &st, j * n + i);
                    any = any || m > 0.0f;
                    if (pt->still) {
                        assert_true(m == 0.0f);
                        checked++;
                    }
                    if (pt->simple && !((((i - pt->x0) | (j - pt->z0)) >> pt->shift) & 1)) {
                        assert_true(m == 0.0f); /* an even vertex: still */
                        checked_even++;
                    }
                    if (pt->simple) {
                        /* drawn within the samples of its block of 2 x 2 grid cells (the
                         * horizon cull's cells allow no morph for it) */
                        const uint32_t bi = pt->x0 + (((i - pt->x0) >> (pt->shift + 1)) << (pt->shift + 1));
                        const uint32_t bj = pt->z0 + (((j - pt->z0) >> (pt->shift + 1)) << (pt->shift + 1));
                        float lo = INFINITY, hi = -INFINITY;
                        for (uint32_t b = 0; b <= 2; b++)
                            for (uint32_t a = 0; a <= 2; a++) {
                                const uint32_t si = bi + (a << pt->shift), sj = bj + (b << pt->shift);
                                if (si >= n || sj >= n)
                                    continue;
                                const float hs = hz_heightmap_get(&t.hm, si, sj);
                                lo = fminf(lo, hs);
                                hi = fmaxf(hi, hs);
                            }
                        const float hd = hz_lod_morph_height(t.lod, &cam, &st, j * n + i);
                        assert_true(hd >= lo - 1e-3f && hd <= hi + 1e-3f);
                        within += m > 0.0f;
                    }
                }
            marked += pt->still != 0;
            marked_simple += pt->simple != 0;
            simple += pt->simple && !pt->still;
            simple_morphing += pt->simple && !pt->still && any;
            still += pt->still != 0;
            moving += pt->still == 0;
            morphing += !pt->still && any;
        }
        assert_int_equal(st.still, marked);
        assert_int_equal(st.simple, marked_simple);
    }
    fprintf(stderr, "still patches: %zu (%zu vertices, none morphing); others %zu, %zu of them morphing\n", still,
            checked, moving, morphing);
    fprintf(stderr, "simple patches not still: %zu (%zu even vertices, none morphing), %zu of them morphing; %zu "
            "morphing vertices within their blocks' samples\n", simple, checked_even, simple_morphing, within);
    assert_true(within > 1000);
    assert_true(still > 0.3 * (double)(still + moving));
    assert_true(morphing > 0.5 * (double)moving);
    assert_true(simple > 0.5 * (double)moving);
    assert_true(simple_morphing > 0.5 * (double)simple);
    free(pl.data);
    terrain_free(&t);
    hz_grid_free(&g);
}

/* ---- popping ---- */

/* The surface as drawn at every sample (NAN where uncovered). */
static void raster_surface(const terrain *t, const uint32_t *idx, size_t count, hz_lod_stats *st, hz_camera *cam,
                           float *out)
{
    morph_user mu = {t->lod, cam, st};
    assert_int_equal(hz_metrics_surface(&t->hm, 1.0f, idx, count, morph_h, &mu, out), HZ_OK);
}

/* Largest change of the drawn surface between two frames, in pixels at the
 * second frame's camera, over samples both frames cover. */
static double max_change_px(const terrain *t, const float *a, const float *b, const hz_camera *cam, float k)
{
    const uint32_t n = t->hm.size;
    double worst = 0;
    for (uint32_t z = 0; z < n; z++)
        for (uint32_t x = 0; x < n; x++) {
            size_t i = (size_t)z * n + x;
            if (isnan(a[i]) || isnan(b[i]))
                continue;
            double dx = (double)x * t->spacing - cam->pos[0], dy = b[i] - cam->pos[1], dz = (double)z * t->spacing - cam->pos[2];
            double px = fabs((double)b[i] - a[i]) * k / sqrt(dx * dx + dy * dy + dz * dz);
            worst = px > worst ? px : worst;
        }
    return worst;
}

/* A camera flies low over rough terrain in 2 m steps. The quadtree's surface
 * jumps where nodes split and merge (by up to tau, however small the step);
 * cdlod's moves by a small fraction of a pixel per 2 m step, because every vertex arrives on (and leaves) the coarser
 * surface continuously. */
static void test_cdlod_no_popping(void **state)
{
    (void)state;
    hz_grid g;
    hz_err err = {0};
    assert_int_equal(hz_generate(&(hz_gen_desc){.kind = HZ_GEN_PERLIN, .size = 513, .seed = 5, .amplitude = 400},
                                 &g, &err),
                     HZ_OK);
    terrain t;
    terrain_init(&t, "perlin", &g, 10.0f);
    const uint32_t n = t.hm.size;
    float *s[2] = {malloc((size_t)n * n * sizeof(float)), malloc((size_t)n * n * sizeof(float))};
    hz_index_list il = {0};
    const float H = 720, tau = 2.0f;
    const float k = H / (2.0f * tanf(glm_rad(60.0f) * 0.5f));
    double worst[4] = {0, 0, 0, 0};
    uint32_t changes[4] = {0, 0, 0, 0};
    /* the third: cdlod with a near bound (8 px within 150 m, 2 px from 2.4 km);
     * the fourth: cdlod at 8 px everywhere */
    const hz_lod_mode modes[4] = {HZ_LOD_QUADTREE, HZ_LOD_CDLOD, HZ_LOD_CDLOD, HZ_LOD_CDLOD};
    for (int mi = 0; mi < 4; mi++) {
        uint32_t prev_tris = 0;
        for (int step = 0; step < 400; step++) {
            hz_camera cam = {.pos = {1000.0f + (float)step * 1.6f, 0, 1000.0f + (float)step * 1.2f},
                             .yaw = 127.0f, .pitch = -12.0f, .fov_y = 60.0f, .aspect = 16.0f / 9.0f,
                             .znear = 1.0f, .zfar = 4000.0f};
            cam.pos[1] = t.hm.offset + 65535.0f * t.hm.scale + 30.0f; /* above the highest peak */
            hz_lod_params p = {.mode = modes[mi], .pixel_error = mi == 3 ? 4.0f * tau : tau,
                               .viewport_height = (uint32_t)H, .no_cull = true,
                               .near_pixel_error = mi == 2 ? 4.0f * tau : 0.0f, .near_distance = 150.0f};
            hz_lod_stats st;
            assert_int_equal(hz_lod_select(t.lod, &cam, &p, &il, NULL, NULL, &st), HZ_OK);
            raster_surface(&t, il.data, il.count, &st, &cam, s[step & 1]);
            if (step > 0) {
                double w = max_change_px(&t, s[(step + 1) & 1], s[step & 1], &cam, k);
                worst[mi] = w > worst[mi] ? w : worst[mi];
                changes[mi] += st.triangles != prev_tris;
                if (getenv("HZ_TEST_VERBOSE"))
                    fprintf(stderr, "%s step %d: %u tris, change %.4f px\n", hz_lod_mode_name(modes[mi]), step,
                            st.triangles, w);
            }
            prev_tris = st.triangles;
        }
    }
    fprintf(stderr, "largest surface change per 2 m step: quadtree %.3f px, cdlod %.3f px, with a near bound of 4 tau "
                    "%.3f px, at 4 tau %.3f px (%u / %u / %u / %u frames changed the mesh)\n",
            worst[0], worst[1], worst[2], worst[3], changes[0], changes[1], changes[2], changes[3]);
    assert_true(changes[1] > 10);           /* cdlod does change its selection along the way (patches:
                                               fewer, larger changes than the quadtree's fans) */
    assert_true(worst[0] > 0.5);            /* the quadtree pops */
    assert_true(worst[1] < 0.2);            /* cdlod glides */
    assert_true(worst[1] * 20.0 < worst[0]);
    /* The near bound depends on the distance alone: no popping either. Its
     * looser vertices morph over wider zones, so its surface glides about as
     * slowly as cdlod's at tau, not as fast as at the near bound's 4 tau
     * everywhere (0.285 px with the zones of tau). */
    assert_true(changes[2] > 10);
    assert_true(worst[2] < 0.2);
    assert_true(worst[2] * 2.0 < worst[3]);
    free(il.data);
    for (int q = 0; q < 2; q++)
        free(s[q]);
    terrain_free(&t);
    hz_grid_free(&g);
}

/* The near bound (hz_lod_params.near_pixel_error): every sample as drawn
 * is within tau(d) pixels, tau(d) = near_pixel_error up to near_distance,
 * falling as 1 / sqrt(d) to pixel_error; the near ground does get errors
 * above pixel_error (fewer triangles than the uniform bound) and the far
 * ground does not; no node is drawn inside its range. */
static void test_cdlod_near_bound(void **state)
{
    (void)state;
    hz_grid g;
    terrain t;
    perlin_terrain(&g, &t);
    const uint32_t n = t.hm.size, H = 720;
    float *surf = malloc((size_t)n * n * sizeof *surf);
    hz_index_list il = {0};
    hz_patch_list pl = {0};
    double worst = 0, above_far = 0;
    size_t loose = 0, far_checked = 0, ranged = 0, tris[3] = {0, 0, 0};
    rng_state = 0x0a11ce5eedULL; /* its own cameras */
    for (int k = 0; k < 25; k++) {
        hz_camera cam = random_camera(&t);
        const float tau = frand(0.5f, 3.0f), tau_n = tau * frand(2.0f, 5.0f), d0 = frand(100.0f, 800.0f);
        const float K = (float)H / (2.0f * tanf(glm_rad(cam.fov_y > 0 ? cam.fov_y : 60.0f) * 0.5f));
        const float d1 = d0 * (tau_n / tau) * (tau_n / tau); /* pixel_error from here on */
        hz_lod_params p = {.mode = HZ_LOD_CDLOD, .pixel_error = tau, .viewport_height = H, .no_cull = true,
                           .near_pixel_error = tau_n, .near_distance = d0};
        hz_lod_stats st;
        for (int v = 0; v < 3; v++) { /* uniform tau, uniform tau_n, the near bound */
            hz_lod_params u = p;
            u.near_pixel_error = 0.0f;
            u.pixel_error = v == 1 ? tau_n : tau;
            assert_int_equal(hz_lod_select(t.lod, &cam, v == 2 ? &p : &u, &il, NULL, NULL, &st), HZ_OK);
            tris[v] += st.triangles;
        }
        assert_true(st.morph_near > 0.0f && fabsf(st.morph_near - tau / tau_n) < 1e-6f);
        morph_user mu = {t.lod, &cam, &st};
        assert_int_equal(hz_metrics_surface(&t.hm, 1.0f, il.data, il.count, morph_h, &mu, surf), HZ_OK);
        for (uint32_t z = 0; z < n; z++)
            for (uint32_t x = 0; x < n; x++) {
                const float h = hz_heightmap_get(&t.hm, x, z), drawn = surf[(size_t)z * n + x];
                assert_false(isnan(drawn)); /* no_cull: the whole map */
                const float dx = (float)x * t.spacing - cam.pos[0], dy = h - cam.pos[1],
                            dz = (float)z * t.spacing - cam.pos[2];
                const float d = sqrtf(dx * dx + dy * dy + dz * dz);
                const float bound = d <= d0 ? tau_n : fmaxf(tau, tau_n * sqrtf(d0 / d));
                const double px = fabs((double)drawn - h) * K / d;
                if (px > bound * 1.001 + 1e-4)
                    fprintf(stderr, "camera %d: sample (%u, %u) at %.1f m off by %.4f px, bound %.4f\n", k, x, z,
                            (double)d, px, (double)bound);
                assert_true(px <= bound * 1.001 + 1e-4);
                worst = px / bound > worst ? px / bound : worst;
                loose += px > tau * 1.001 + 1e-4;
                if (d >= d1) {
                    far_checked++;
                    above_far = px / tau > above_far ? px / tau : above_far;
                }
            }
        ranged += check_patch_ranges(&t, &cam, &p, k, &pl, &st);
        for (size_t q = 0; q < pl.count; q++) {
            /* the range is where the node's error projects to tau(range) */
            const float e = hz_lod_patch_error(t.lod, &pl.data[q]) * t.hm.scale;
            const float range = hz_lod_morph_range(&st, hz_lod_patch_error(t.lod, &pl.data[q]));
            const float b = range <= d0 ? tau_n : fmaxf(tau, tau_n * sqrtf(d0 / range));
            if (range > 1.0f)
                assert_true(fabsf(e * K / range - b) <= 2e-3f * b);
        }
    }
    fprintf(stderr, "near bound: largest error / tau(d) %.3f, %zu samples above the far tau, far ones at most %.3f "
                    "tau (%zu); triangles uniform %zu, near %zu, uniform near tau %zu; %zu nodes against their range\n",
            worst, loose, above_far, far_checked, tris[0], tris[2], tris[1], ranged);
    assert_true(worst > 0.5);     /* the bound is used, not just met */
    assert_true(loose > 500);     /* the near ground is coarser than tau allows */
    assert_true(far_checked > 1000 && above_far <= 1.001);
    assert_true((double)tris[2] < 0.98 * (double)tris[0] && tris[2] > tris[1]);
    assert_true(ranged > 100);
    free(surf);
    free(il.data);
    free(pl.data);
    terrain_free(&t);
    hz_grid_free(&g);
}

/* Forced splits: a camera a few metres above rough ground next to smooth
 * ground at a small tau makes nodes split whose coarser neighbours' own
 * ranges do not reach the eye; the restricted quadtree forces those
 * neighbours to split. The forced meshes stay valid (no T-junction, no
 * hole, neighbours at most one level apart). */
static void test_cdlod_forced_splits(void **state)
{
    (void)state;
    /* Gentle ground with centimetre noise: short split ranges (tens of
     * metres) against 160 m patches, so a split next to the eye does not
     * reach the neighbour's range. */
    hz_grid g;
    assert_int_equal(hz_grid_alloc(&g, 257, 257, NULL), HZ_OK);
    uint64_t rs = 99;
    for (uint32_t j = 0; j < 257; j++)
        for (uint32_t i = 0; i < 257; i++)
            g.z[(size_t)j * 257 + i] = 0.02f * (float)i + 0.01f * (float)j + test_frand(&rs, 0.0f, 0.03f);
    terrain t;
    terrain_init(&t, "gentle", &g, 10.0f);
    hz_index_list il = {0};
    hz_node_list leaves = {0};
    size_t forced = 0, frames_forced = 0;
    for (int k = 0; k < 64; k++) {
        const uint32_t i = 8 + (uint32_t)(k % 8) * 30, j = 8 + (uint32_t)(k / 8) * 30;
        hz_camera cam = {.pos = {(float)i * t.spacing + 3.0f, hz_heightmap_get(&t.hm, i, j) + 3.0f,
                                 (float)j * t.spacing + 3.0f},
                         .yaw = (float)(k * 47 % 360), .pitch = -25.0f, .fov_y = 60.0f, .aspect = 16.0f / 9.0f,
                         .znear = 0.5f, .zfar = 5000.0f};
        hz_lod_params p = {.mode = HZ_LOD_CDLOD, .pixel_error = 0.5f, .viewport_height = 720, .no_cull = k & 1};
        hz_lod_stats st;
        assert_int_equal(hz_lod_select(t.lod, &cam, &p, &il, &leaves, NULL, &st), HZ_OK);
        forced += st.forced;
        frames_forced += st.forced > 0;
        vec4 planes[6];
        hz_camera_frustum(&cam, planes);
        mesh_report r = mesh_check(&t.hm, t.spacing, 1.0f, il.data, il.count, p.no_cull ? NULL : (const vec4 *)planes,
                                   &leaves);
        mesh_assert_valid(&r, true, "cdlod low camera");
    }
    fprintf(stderr, "cdlod: %zu forced splits in %zu of 64 low cameras\n", forced, frames_forced);
    assert_true(frames_forced >= 8);
    free(il.data);
    free(leaves.data);
    terrain_free(&t);
    hz_grid_free(&g);
}

/* A vertex at morph factor 1 lies on the straight line between the two
 * neighbours it collapses to; at 0 on the true height. */
static void test_cdlod_morph_targets(void **state)
{
    (void)state;
    hz_grid g;
    make_random_grid(&g, 65, 300.0f);
    terrain t;
    terrain_init(&t, "random", &g, 10.0f);
    const uint16_t *me = hz_lod_morph_errors(t.lod);
    assert_non_null(me);
    const uint32_t n = t.hm.size;
    /* The root patch's (P + 1)^2 vertices never morph; every other sample does. */
    const uint32_t P = hz_lod_patch_cells(t.lod);
    size_t never = 0;
    for (size_t i = 0; i < (size_t)n * n; i++)
        never += me[i] == UINT16_MAX;
    assert_int_equal(never, (size_t)(P + 1) * (P + 1));
    hz_camera cam = {.pos = {-1e7f, 0, 0}, .fov_y = 60, .aspect = 1, .znear = 1, .zfar = 1e8f};
    hz_lod_stats far = {.morph_scale = 1e-3f, .morph_start = 0.8f}; /* tiny ranges: all at m = 1 */
    hz_lod_stats near = {.morph_scale = 1e9f, .morph_start = 0.8f}; /* huge ranges: all at m = 0 */
    hz_lod_stats none = {0};
    /* The true-height target of a sample by hand: its two neighbours at the
     * spacing where it first appears, on the coarser cell's diagonal for its centre. */
    for (uint32_t j = 0; j < n; j++)
        for (uint32_t i = 0; i < n; i++) {
            const uint32_t idx = j * n + i;
            const float h = hz_heightmap_get(&t.hm, i, j);
            assert_float_equal(hz_lod_morph_height(t.lod, &cam, &none, idx), h, 1e-3);
            assert_float_equal(hz_lod_morph_height(t.lod, &cam, &near, idx), h, 1e-3);
            if (me[idx] == UINT16_MAX)
                continue;
            const uint32_t li = i ? (i & (~i + 1u)) : 1u << 31, lj = j ? (j & (~j + 1u)) : 1u << 31;
            uint32_t a[2], b[2];
            if (li == lj) {
                /* union jack: the coarser cell's main diagonal when its index sum is even */
                if ((((i - li) / (2 * li) + (j - li) / (2 * li)) & 1u) == 0)
                    a[0] = i - li, b[0] = j - li, a[1] = i + li, b[1] = j + li;
                else
                    a[0] = i - li, b[0] = j + li, a[1] = i + li, b[1] = j - li;
            } else if (li < lj) {
                a[0] = i - li, b[0] = j, a[1] = i + li, b[1] = j;
            } else {
                a[0] = i, b[0] = j - lj, a[1] = i, b[1] = j + lj;
            }
            float t2 = 0.0f, mt = 0.0f;
            for (int k = 0; k < 2; k++) {
                t2 += hz_heightmap_get(&t.hm, a[k], b[k]);
                /* at m = 1 everywhere each neighbour sits on its own target */
                mt += me[b[k] * n + a[k]] == UINT16_MAX
                          ? hz_heightmap_get(&t.hm, a[k], b[k])
                          : 0.5f * (float)hz_lod_morph_target2(t.lod, a[k], b[k]) * t.hm.scale + t.hm.offset;
            }
            const float want_t2 = (t2 - 2.0f * t.hm.offset) / t.hm.scale;
            assert_true(fabsf((float)hz_lod_morph_target2(t.lod, i, j) - want_t2) < 0.05f);
            assert_float_equal(hz_lod_morph_height(t.lod, &cam, &far, idx), 0.5f * mt, 1e-3);
        }
    terrain_free(&t);
    hz_grid_free(&g);
}

/* ---- roam coherence and budget ---- */

static void test_roam_coherence(void **state)
{
    (void)state;
    hz_grid g;
    hz_err err = {0};
    assert_int_equal(hz_generate(&(hz_gen_desc){.kind = HZ_GEN_PERLIN, .size = 513, .seed = 2}, &g, &err), HZ_OK);
    terrain t;
    terrain_init(&t, "perlin", &g, 10.0f);
    hz_index_list il = {0};
    hz_lod_params p = {.mode = HZ_LOD_ROAM, .pixel_error = 1.5f};
    uint32_t first_changes = 0, later_changes = 0, tris = 0;
    for (int step = 0; step < 60; step++) {
        hz_camera cam = {.pos = {1000.0f + 10.0f * (float)step, 2500, 1200.0f + 6.0f * (float)step},
                         .yaw = 120, .pitch = -20, .fov_y = 60, .aspect = 16.0f / 9.0f, .znear = 1, .zfar = 8000};
        hz_lod_stats st;
        assert_int_equal(hz_lod_select(t.lod, &cam, &p, &il, NULL, NULL, &st), HZ_OK);
        vec4 planes[6];
        hz_camera_frustum(&cam, planes);
        mesh_report r = mesh_check(&t.hm, t.spacing, 1.0f, il.data, il.count, (const vec4 *)planes, NULL);
        assert_int_equal(r.open_interior + r.t_junctions + r.edges_over_two + r.degenerate + r.flipped, 0);
        uint32_t ch = st.forced + st.merged;
        if (step == 0)
            first_changes = st.triangles;
        else
            later_changes = ch > later_changes ? ch : later_changes;
        tris = st.triangles;
    }
    /* From the second frame on, a small move changes a small part of the mesh. */
    fprintf(stderr, "roam: first frame %u triangles, then at most %u forced+merged per frame, %u triangles\n",
            first_changes, later_changes, tris);
    assert_true(tris > 1000);
    assert_true(later_changes * 5 < tris);
    /* A budget is respected, and the mesh stays valid under it. */
    p.roam_budget = 600;
    for (int step = 0; step < 5; step++) {
        hz_camera cam = {.pos = {2000, 2500, 2000}, .yaw = 45.0f * (float)step, .pitch = -20, .fov_y = 60,
                         .aspect = 1.5f, .znear = 1, .zfar = 8000};
        hz_lod_stats st;
        assert_int_equal(hz_lod_select(t.lod, &cam, &p, &il, NULL, NULL, &st), HZ_OK);
        assert_true(st.triangles <= 600);
        mesh_report r = mesh_check(&t.hm, t.spacing, 1.0f, il.data, il.count, NULL, NULL);
        (void)r; /* culled leaves leave open edges; the conformity checks: */
        assert_int_equal(r.t_junctions + r.edges_over_two + r.degenerate + r.flipped, 0);
    }
    free(il.data);
    terrain_free(&t);
    hz_grid_free(&g);
}

/* ---- bidirectional ---- */

static void test_bidirectional_repairs(void **state)
{
    (void)state;
    hz_grid g;
    make_random_grid(&g, 257, 400.0f);
    terrain t;
    terrain_init(&t, "random", &g, 10.0f);
    hz_index_list il = {0};
    hz_node_list leaves = {0};
    uint32_t splits_near = 0, merges_near = 0, splits_far = 0, merges_far = 0;
    size_t tris_near = 0, tris_far = 0;
    for (int k = 0; k < 30; k++) {
        hz_camera cam = random_camera(&t);
        const float cc = frand(5, 60), cc2 = frand(1, 10);
        for (int far = 0; far < 2; far++) {
            /* m tiny: every conflict is far, the fine side coarsens; m huge:
             * every conflict is near, the coarse side splits. */
            hz_lod_params p = {.mode = HZ_LOD_BIDIRECTIONAL, .c = cc, .c2 = cc2, .no_cull = true,
                               .bidir_distance = far ? 1e-3f : 1e9f};
            hz_lod_stats st;
            assert_int_equal(hz_lod_select(t.lod, &cam, &p, &il, &leaves, NULL, &st), HZ_OK);
            mesh_report r = mesh_check(&t.hm, t.spacing, 1.0f, il.data, il.count, NULL, &leaves);
            assert_int_equal(r.level_jumps + r.t_junctions + r.open_interior + r.edges_over_two, 0);
            if (far) {
                splits_far += st.forced;
                merges_far += st.merged;
                tris_far += st.triangles;
            } else {
                splits_near += st.forced;
                merges_near += st.merged;
                tris_near += st.triangles;
            }
        }
    }
    assert_int_equal(merges_near, 0);
    assert_int_equal(splits_far, 0);
    assert_true(splits_near > 0 && merges_far > 0);
    assert_true(tris_near > tris_far);
    free(il.data);
    free(leaves.data);
    terrain_free(&t);
    hz_grid_free(&g);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_mode_names),
        cmocka_unit_test(test_modes_valid_synthetic),
        cmocka_unit_test(test_modes_valid_generated_and_real),
        cmocka_unit_test(test_cdlod_patch_box_holds_drawn),
        cmocka_unit_test(test_cdlod_still_patches_do_not_morph),
        cmocka_unit_test(test_cdlod_morph_stays_near_samples),
        cmocka_unit_test(test_cdlod_horizon_culling_conditions),
        cmocka_unit_test(test_pixel_error_bound),
        cmocka_unit_test(test_cdlod_no_popping),
        cmocka_unit_test(test_cdlod_near_bound),
        cmocka_unit_test(test_cdlod_morph_targets),
        cmocka_unit_test(test_cdlod_forced_splits),
        cmocka_unit_test(test_roam_coherence),
        cmocka_unit_test(test_bidirectional_repairs),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
