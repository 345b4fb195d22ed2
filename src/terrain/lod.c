/* Quadtree LOD after Röttger et al. 1998 and the seed thesis (SPEC T2-T7).
 *
 * Per node (not per sample) we keep d2 (float), min and max height (uint16) and
 * one flag byte, in one compact array per level: about (size-1)^2 / 3 nodes in
 * all. The flag array is never cleared; see select() for why stale flags are
 * never read. */
#include "lod_internal.h"

static float err16(uint16_t mid, uint16_t a, uint16_t b)
{
    return fabsf((float)mid - 0.5f * ((float)a + (float)b));
}

static void progress(const hz_lod_desc *d, uint64_t done, uint64_t total)
{
    if (d->progress)
        d->progress(d->progress_user, "LOD data", done, total);
}

hz_lod *hz_lod_create(const hz_lod_desc *desc, hz_err *err)
{
    const hz_heightmap *hm = desc ? desc->hm : NULL;
    if (!hm || !hm->h || !hz_is_pow2_plus1(hm->size)) {
        hz_err_set(err, HZ_ERR_VALUE, "lod: a square 2^n+1 heightmap is required");
        return NULL;
    }
    float spacing = desc->spacing > 0 ? desc->spacing : 1.0f;
    float zscale = desc->zscale != 0 ? desc->zscale : 1.0f;
    if (!(zscale > 0) || !isfinite(zscale) || !isfinite(spacing)) {
        hz_err_set(err, HZ_ERR_VALUE, "lod: zscale must be finite and > 0, spacing finite (got %g, %g)",
                   (double)zscale, (double)spacing);
        return NULL;
    }
    float pc = desc->propagate_c > 0 ? desc->propagate_c : 25.0f;
    if (pc < 2.0f)
        pc = 2.0f;
    float K = pc / (2.0f * (pc - 1.0f));

    hz_lod *lod = calloc(1, sizeof *lod);
    if (!lod)
        goto oom;
    lod->hm = hm;
    lod->desc = *desc;
    lod->size = hm->size;
    lod->levels = hm->levels;
    lod->spacing = spacing;
    lod->zscale = zscale;
    /* cdlod patches: P x P cells, a power of two no larger than the map. */
    uint32_t pcells = desc->patch_cells ? desc->patch_cells : 8u;
    if (pcells < 2 || (pcells & (pcells - 1))) {
        hz_err_set(err, HZ_ERR_VALUE, "lod: patch cells must be a power of two >= 2 (got %u)", pcells);
        free(lod);
        return NULL;
    }
    while (pcells > hm->size - 1)
        pcells /= 2;
    lod->patch = pcells;
    {
        uint32_t lp = hm->levels - 1, h = pcells / 2;
        while (h > 1) {
            h >>= 1;
            lp--;
        }
        lod->patch_level = lp;
    }
    lod->level_offset = calloc(lod->levels, sizeof *lod->level_offset);
    if (!lod->level_offset)
        goto oom;
    size_t total = 0;
    for (uint32_t l = 0; l < lod->levels; l++) {
        lod->level_offset[l] = total;
        total += (size_t)1 << (2 * l);
    }
    lod->nodes = total;
    lod->d2 = malloc(total * sizeof *lod->d2);
    lod->mn = malloc(total * sizeof *lod->mn);
    lod->mx = malloc(total * sizeof *lod->mx);
    lod->flags = calloc(total, 1);
    /* A level never holds more than 4^(levels-1) nodes. */
    lod->qcap = (size_t)1 << (2 * (lod->levels - 1));
    lod->q[0] = malloc(lod->qcap * sizeof(qnode));
    lod->q[1] = malloc(lod->qcap * sizeof(qnode));
    if (!lod->d2 || !lod->mn || !lod->mx || !lod->flags || !lod->q[0] || !lod->q[1])
        goto oom;

    /* d2 in world units: error metres / node size metres. */
    const float to_world = hm->scale * zscale;
    uint64_t work_total = total, work_done = 0;
    for (uint32_t l = lod->levels; l-- > 0;) {
        uint32_t s = half_of(lod, l), m = 1u << l;
        float d = 2.0f * (float)s * spacing;
        for (uint32_t zi = 0; zi < m; zi++) {
            uint32_t z = zi * 2 * s + s;
            for (uint32_t xi = 0; xi < m; xi++) {
                uint32_t x = xi * 2 * s + s;
                uint16_t c = h16(lod, x, z);
                uint16_t nw = h16(lod, x - s, z - s), ne = h16(lod, x + s, z - s);
                uint16_t sw = h16(lod, x - s, z + s), se = h16(lod, x + s, z + s);
                float e = fmaxf(err16(c, nw, se), err16(c, ne, sw));
                e = fmaxf(e, err16(h16(lod, x, z - s), nw, ne));
                e = fmaxf(e, err16(h16(lod, x, z + s), sw, se));
                e = fmaxf(e, err16(h16(lod, x - s, z), nw, sw));
                e = fmaxf(e, err16(h16(lod, x + s, z), ne, se));
                float d2 = e * to_world / d;
                size_t idx = lod->level_offset[l] + (size_t)zi * m + xi;
                uint16_t lo, hi;
                if (s == 1) {
                    lo = hi = c;
                    for (uint32_t dz = 0; dz < 3; dz++)
                        for (uint32_t dx = 0; dx < 3; dx++) {
                            uint16_t v = h16(lod, x - 1 + dx, z - 1 + dz);
                            lo = v < lo ? v : lo;
                            hi = v > hi ? v : hi;
                        }
                } else {
                    lo = UINT16_MAX;
                    hi = 0;
                    uint32_t h = s / 2;
                    const uint32_t cx[4] = {x - h, x + h, x - h, x + h};
                    const uint32_t cz[4] = {z - h, z - h, z + h, z + h};
                    for (int k = 0; k < 4; k++) {
                        size_t ci = node_index(lod, l + 1, cx[k], cz[k]);
                        lo = lod->mn[ci] < lo ? lod->mn[ci] : lo;
                        hi = lod->mx[ci] > hi ? lod->mx[ci] : hi;
                        /* Röttger's upward propagation keeps the level difference
                         * of neighbours <= 1 for C >= propagate_c. */
                        d2 = fmaxf(d2, K * lod->d2[ci]);
                    }
                }
                lod->d2[idx] = d2;
                lod->mn[idx] = lo;
                lod->mx[idx] = hi;
            }
            work_done += m;
            if ((zi & 63) == 0 || zi + 1 == m)
                progress(desc, work_done, work_total);
        }
    }
    return lod;
oom:
    hz_err_set(err, HZ_ERR_MEMORY, "lod: out of memory for %ux%u samples", hm->size, hm->size);
    hz_lod_destroy(lod);
    return NULL;
}

void hz_lod_destroy(hz_lod *lod)
{
    if (!lod)
        return;
    hz__lod_roam_free(lod);
    free(lod->level_offset);
    free(lod->d2);
    free(lod->mn);
    free(lod->mx);
    free(lod->flags);
    free(lod->q[0]);
    free(lod->q[1]);
    free(lod->stamp);
    free(lod->stack);
    free(lod->stack_lv);
    free(lod->cd_err);
    free(lod->cd_qmin);
    free(lod->morph_err);
    free(lod->patch_tmp);
    free(lod->hz_cells);
    free(lod->hz_sorted);
    free(lod->hz_hidden);
    free(lod->hz_sub);
    for (int l = 0; l < 32; l++)
        free(lod->lv[l]);
    free(lod);
}

size_t hz_lod_memory_bytes(const hz_lod *lod)
{
    size_t b = lod->hm->size_bytes + lod->nodes * (sizeof(float) + 2 * sizeof(uint16_t) + 1);
    if (lod->stamp)
        b += lod->nodes;
    if (lod->cd_err)
        b += lod->cd_nodes * (sizeof(float) + 2 * sizeof(uint16_t));
    if (lod->morph_err)
        b += (size_t)lod->size * lod->size * sizeof(uint16_t);
    return b + hz__lod_roam_bytes(lod);
}

double hz_lod_bytes_per_sample(const hz_lod *lod)
{
    return (double)hz_lod_memory_bytes(lod) / ((double)lod->size * lod->size);
}

static const char *const mode_names[HZ_LOD_MODE_COUNT] = {"quadtree", "remedy", "bidirectional", "roam",
                                                          "cdlod"};

const char *hz_lod_mode_name(hz_lod_mode mode)
{
    return (unsigned)mode < HZ_LOD_MODE_COUNT ? mode_names[mode] : "?";
}

bool hz_lod_mode_from_name(const char *name, hz_lod_mode *mode)
{
    for (int m = 0; m < HZ_LOD_MODE_COUNT; m++)
        if (name && !strcmp(name, mode_names[m])) {
            *mode = (hz_lod_mode)m;
            return true;
        }
    return false;
}

static bool lookup(const hz_lod *lod, uint32_t x, uint32_t z, uint32_t half, size_t *idx,
                   uint32_t *level)
{
    if (half == 0 || (half & (half - 1)) || x < half || z < half || x + half >= lod->size + 0u ||
        z + half >= lod->size)
        return false;
    if ((x - half) % (2 * half) || (z - half) % (2 * half))
        return false;
    uint32_t l = 0;
    while (l < lod->levels && half_of(lod, l) != half)
        l++;
    if (l == lod->levels)
        return false;
    *idx = node_index(lod, l, x, z);
    *level = l;
    return true;
}

bool hz_lod_query_node(const hz_lod *lod, uint32_t x, uint32_t z, uint32_t half, float *d2,
                       float *min_h, float *max_h)
{
    size_t i;
    uint32_t l;
    if (!lookup(lod, x, z, half, &i, &l))
        return false;
    if (d2)
        *d2 = lod->d2[i];
    if (min_h)
        *min_h = lod->hm->offset + lod->hm->scale * lod->mn[i];
    if (max_h)
        *max_h = lod->hm->offset + lod->hm->scale * lod->mx[i];
    return true;
}

bool hz_lod_node_box(const hz_lod *lod, uint32_t x, uint32_t z, uint32_t half, vec3 box[2])
{
    size_t i;
    uint32_t l;
    if (!lookup(lod, x, z, half, &i, &l))
        return false;
    box_flat(lod, i, x, z, half, box);
    return true;
}

void hz_lod_set_progress(hz_lod *lod, hz_progress_fn fn, void *user)
{
    lod->desc.progress = fn;
    lod->desc.progress_user = user;
}

hz_result hz_lod_prepare(hz_lod *lod, hz_lod_mode mode)
{
    if (mode == HZ_LOD_CDLOD)
        return hz__lod_cdlod_prepare(lod);
    if (mode == HZ_LOD_ROAM)
        return hz__lod_roam_prepare(lod);
    return (unsigned)mode < HZ_LOD_MODE_COUNT ? HZ_OK : HZ_ERR_VALUE;
}

hz_result hz_lod_select(hz_lod *lod, const hz_camera *cam, const hz_lod_params *params, hz_index_list *out,
                        hz_node_list *leaves, hz_node_list *culled, hz_lod_stats *stats)
{
    double t0 = hz_time_ms();
    hz_lod_params p = params ? *params : (hz_lod_params){0};
    hz_lod_stats st = {0};
    out->count = 0;
    if (leaves)
        leaves->count = 0;
    if (culled)
        culled->count = 0;
    lod->curv = *cam;
    hz_result r;
    switch (p.mode) {
    case HZ_LOD_QUADTREE: r = hz__lod_select_quadtree(lod, cam, &p, out, leaves, culled, &st); break;
    case HZ_LOD_REMEDY: r = hz__lod_select_remedy(lod, cam, &p, out, leaves, culled, &st); break;
    case HZ_LOD_BIDIRECTIONAL: r = hz__lod_select_bidir(lod, cam, &p, out, leaves, culled, &st); break;
    case HZ_LOD_ROAM: r = hz__lod_select_roam(lod, cam, &p, out, &st); break;
    case HZ_LOD_CDLOD: r = hz__lod_select_cdlod(lod, cam, &p, out, leaves, culled, &st); break;
    default: return HZ_ERR_VALUE;
    }
    st.ms = hz_time_ms() - t0;
    if (stats)
        *stats = st;
    return r;
}

hz_result hz_lod_full_mesh(const hz_heightmap *hm, hz_index_list *out)
{
    const uint32_t n = hm->size;
    size_t need = (size_t)(n - 1) * (n - 1) * 6;
    out->count = 0;
    if (list_reserve((void **)&out->data, &out->cap, need, sizeof(uint32_t)))
        return HZ_ERR_MEMORY;
    uint32_t *o = out->data;
    for (uint32_t j = 0; j + 1 < n; j++)
        for (uint32_t i = 0; i + 1 < n; i++) {
            uint32_t a = j * n + i, b = (j + 1) * n + i, c = j * n + i + 1, d = (j + 1) * n + i + 1;
            hz_lod_cell_triangles(((i + j) & 1u) == 0, a, b, c, d, o);
            o += 6;
        }
    out->count = need;
    return HZ_OK;
}
