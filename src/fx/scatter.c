/* Vegetation scatter and the automatic water level (CPU, deterministic). */
#include "horizon/fx.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "fx_noise.h"

typedef struct tree_rules {
    hz_scatter_desc d;
    float lo, hi;        /* metres: lowest and highest ground (zscale applied) */
    float extent;
} tree_rules;

static hz_scatter_desc tree_defaults(const hz_scatter_desc *in)
{
    hz_scatter_desc d = in ? *in : (hz_scatter_desc){0};
    if (d.density <= 0.0f)
        d.density = 12.0f;
    if (d.cover <= 0.0f)
        d.cover = 0.45f;
    d.cover = d.cover > 1.0f ? 1.0f : d.cover;
    if (d.min_size <= 0.0f)
        d.min_size = 9.0f;
    if (d.max_size <= 0.0f)
        d.max_size = 24.0f;
    if (d.max_size < d.min_size)
        d.max_size = d.min_size;
    if (d.tree_line <= 0.0f)
        d.tree_line = 0.6f;
    if (d.max_slope <= 0.0f)
        d.max_slope = 0.25f;
    if (d.max_count == 0)
        d.max_count = 500000;
    if (d.kinds == 0)
        d.kinds = 2;
    return d;
}

static float smooth(float e0, float e1, float x)
{
    float t = (x - e0) / (e1 - e0);
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    return t * t * (3 - 2 * t);
}

float hz_forest_density(const hz_scatter_desc *in, float x, float z)
{
    hz_scatter_desc d = tree_defaults(in);
    uint32_t seed = (uint32_t)(d.seed * 2654435761u) ^ 0x5eedu;
    /* Patches a few km across with ragged edges. The fBm is roughly normal
     * with sd ~0.22: shift it so about `cover` of the land is forest. */
    float n = fxn_fbm(x / 2200.0f, z / 2200.0f, 5, 0, seed);
    float thr = 0.22f * 1.8f * (0.5f - d.cover);
    return smooth(thr - 0.05f, thr + 0.05f, n);
}

/* Metres, bilinear, with the gradient (dh/dx, dh/dz). */
static float ground(const hz_heightmap *hm, float spacing, float zscale, float x, float z, float *gx, float *gz)
{
    const uint32_t n = hm->size;
    float u = x / spacing, v = z / spacing;
    u = u < 0 ? 0 : u > (float)(n - 1) ? (float)(n - 1) : u;
    v = v < 0 ? 0 : v > (float)(n - 1) ? (float)(n - 1) : v;
    uint32_t i = (uint32_t)u, j = (uint32_t)v;
    i = i + 1 < n ? i : n - 2, j = j + 1 < n ? j : n - 2;
    float fu = u - (float)i, fv = v - (float)j;
    float a = hz_heightmap_get(hm, i, j), b = hz_heightmap_get(hm, i + 1, j);
    float c = hz_heightmap_get(hm, i, j + 1), e = hz_heightmap_get(hm, i + 1, j + 1);
    if (gx)
        *gx = zscale * ((b - a) * (1 - fv) + (e - c) * fv) / spacing;
    if (gz)
        *gz = zscale * ((c - a) * (1 - fu) + (e - b) * fu) / spacing;
    return zscale * ((a + (b - a) * fu) * (1 - fv) + (c + (e - c) * fu) * fv);
}

/* 0..1: how well a tree grows here (slope, tree line, water), soft edges. */
static float suitability(const tree_rules *r, float h, float gx, float gz)
{
    float slope = 1.0f - 1.0f / sqrtf(1.0f + gx * gx + gz * gz);
    float t = (h - r->lo) / fmaxf(r->hi - r->lo, 1e-3f);
    float s = 1.0f - smooth(r->d.max_slope * 0.7f, r->d.max_slope, slope);
    s *= 1.0f - smooth(r->d.tree_line - 0.06f, r->d.tree_line, t);
    if (isfinite(r->d.water_level))
        s *= smooth(r->d.water_level + 2.0f, r->d.water_level + 6.0f, h);
    return s;
}

static tree_rules rules(const hz_heightmap *hm, float spacing, float zscale, const hz_scatter_desc *d)
{
    tree_rules r = {.d = tree_defaults(d)};
    float a = hm->offset * zscale, b = (hm->offset + hm->scale * 65535.0f) * zscale;
    /* The quantisation range is the height range (hz_heightmap_create). */
    r.lo = fminf(a, b), r.hi = fmaxf(a, b);
    r.extent = (float)(hm->size - 1) * spacing;
    return r;
}

hz_result hz_trees_scatter(const hz_heightmap *hm, float spacing, float zscale, const hz_scatter_desc *in,
                           hz_billboard **out, size_t *count, hz_err *err)
{
    if (!out || !count)
        return hz_err_set(err, HZ_ERR_VALUE, "trees: no output");
    *out = NULL;
    *count = 0;
    if (!hm || !hm->h || hm->size < 2 || !(spacing > 0.0f) || !isfinite(spacing) || !(zscale > 0.0f))
        return hz_err_set(err, HZ_ERR_VALUE, "trees: bad heightmap, spacing or zscale");
    if (in && (!isfinite(in->density) || in->density > 10000.0f || !isfinite(in->min_size) ||
               !isfinite(in->max_size) || in->max_size > 1000.0f))
        return hz_err_set(err, HZ_ERR_VALUE, "trees: absurd density %g or size %g..%g", (double)in->density,
                          (double)in->min_size, (double)in->max_size);
    tree_rules r = rules(hm, spacing, zscale, in);
    /* A jittered grid: one candidate per cell of 1 / density hectares. */
    double g = sqrt(10000.0 / (double)r.d.density);
    double cells = ((double)r.extent / g + 1) * ((double)r.extent / g + 1);
    double expect = cells * r.d.cover;
    if (expect > r.d.max_count)
        g *= sqrt(expect / r.d.max_count);
    uint32_t nc = (uint32_t)((double)r.extent / g) + 1;
    size_t cap = (size_t)r.d.max_count, n = 0;
    hz_billboard *b = malloc(cap * sizeof *b);
    if (!b)
        return hz_err_set(err, HZ_ERR_MEMORY, "trees: out of memory for %zu trees", cap);
    const uint32_t seed = (uint32_t)(r.d.seed * 0x9e3779b9u) ^ 0x74ee5u;
    for (uint32_t cz = 0; cz < nc && n < cap; cz++)
        for (uint32_t cx = 0; cx < nc && n < cap; cx++) {
            uint32_t h0 = fxn_hash(cx, cz, seed), h1 = fxn_hash(cx, cz, seed + 1), h2 = fxn_hash(cx, cz, seed + 2);
            float x = (float)(((double)cx + fxn_u01(h0)) * g), z = (float)(((double)cz + fxn_u01(h1)) * g);
            if (x > r.extent || z > r.extent)
                continue;
            float gx, gz, h = ground(hm, spacing, zscale, x, z, &gx, &gz);
            /* Accept with probability density x suitability; the cheap factor first. */
            float u = fxn_u01(h2), suit = suitability(&r, h, gx, gz);
            if (u >= suit || u >= suit * hz_forest_density(&r.d, x, z))
                continue;
            uint32_t h3 = fxn_hash(cx, cz, seed + 3), h4 = fxn_hash(cx, cz, seed + 4);
            float t = (h - r.lo) / fmaxf(r.hi - r.lo, 1e-3f);
            /* Conifers up the slopes, broadleaf trees in the lowlands. */
            uint16_t kind = 0;
            if (r.d.kinds > 1)
                kind = fxn_u01(h3) < smooth(0.12f, 0.42f, t) ? 0 : 1;
            float size = r.d.min_size + (r.d.max_size - r.d.min_size) * fxn_u01(h4);
            float shade = 0.82f + 0.18f * fxn_u01(h3 * 7u + 1u);
            uint8_t cr = (uint8_t)(255.0f * shade * (0.95f + 0.05f * fxn_u01(h4 ^ 0x55u)));
            uint8_t cg = (uint8_t)(255.0f * shade);
            uint8_t cb = (uint8_t)(255.0f * shade * 0.92f);
            b[n++] = (hz_billboard){.pos = {x, h - 0.05f * size, z},
                                    .width = size * (kind == 0 ? 0.5f : 0.85f),
                                    .axis = {0.0f, size, 0.0f},
                                    .rgba = (uint32_t)cr | (uint32_t)cg << 8 | (uint32_t)cb << 16 | 0xffu << 24,
                                    .texture = (uint16_t)(r.d.texture0 + (kind < r.d.kinds ? kind : 0)),
                                    .flags = 0};
        }
    hz_billboard *shrunk = realloc(b, (n ? n : 1) * sizeof *b);
    *out = shrunk ? shrunk : b;
    *count = n;
    return HZ_OK;
}

void hz_forest_cover_map(const hz_heightmap *hm, float spacing, float zscale, const hz_scatter_desc *d, uint32_t side,
                         uint8_t *out)
{
    tree_rules r = rules(hm, spacing, zscale, d);
    for (uint32_t v = 0; v < side; v++)
        for (uint32_t u = 0; u < side; u++) {
            float x = ((float)u + 0.5f) / (float)side * r.extent, z = ((float)v + 0.5f) / (float)side * r.extent;
            float gx, gz, h = ground(hm, spacing, zscale, x, z, &gx, &gz);
            float p = hz_forest_density(&r.d, x, z) * suitability(&r, h, gx, gz);
            /* Clamped (NaN -> 0) before the conversion: an absurd relief can
             * make p NaN or out of [0, 1], and NaN -> uint8 is undefined. */
            p = p > 0.0f ? (p < 1.0f ? p : 1.0f) : 0.0f;
            out[(size_t)v * side + u] = (uint8_t)(p * 255.0f + 0.5f);
        }
}

float hz_water_level_auto(const hz_heightmap *hm, const uint8_t *valid, float zscale, float fraction, bool *is_sea)
{
    if (is_sea)
        *is_sea = false;
    if (!hm || !hm->h || hm->size < 2)
        return 0.0f;
    if (fraction <= 0.0f)
        fraction = 0.04f;
    fraction = fraction > 1.0f ? 1.0f : fraction;
    const uint32_t n = hm->size;
    /* every sample (a sea is often nodata, filled flat along its coast) and
     * the samples with data (lakes fill real ground only) */
    uint32_t *hist = calloc(2 * 65536, sizeof *hist), *hv = hist + 65536;
    if (!hist)
        return zscale * hm->offset;
    uint64_t nvalid = 0;
    for (uint32_t j = 0; j < n; j++)
        for (uint32_t i = 0; i < n; i++) {
            const uint16_t q = hz_heightmap_get16(hm, i, j);
            hist[q]++;
            if (!valid || valid[(size_t)j * n + i])
                hv[q]++, nvalid++;
        }
    const uint64_t total = (uint64_t)n * n;
    uint32_t lo = 0;
    while (lo < 65535 && hist[lo] == 0)
        lo++;
    const float step = hm->scale * zscale;
    /* A sea: a flat area (the most samples within 0.5 m) among the lowest
     * tenth of the heights, e.g. a DEM's sea at 0 m over some lower voids. */
    uint32_t hi10 = lo;
    for (uint64_t acc = 0; hi10 < 65535; hi10++) {
        acc += hist[hi10];
        if ((double)acc >= 0.1 * (double)total)
            break;
    }
    uint32_t win = step > 0.0f ? (uint32_t)(0.5f / step) : 0;
    win = win ? win : 1;
    uint64_t best = 0, run = 0;
    uint32_t best_top = lo;
    for (uint32_t v = lo; v <= hi10; v++) {
        run += hist[v];
        if (v >= lo + win)
            run -= hist[v - win];
        if (run > best)
            best = run, best_top = v;
    }
    float level;
    if ((double)best >= 0.005 * (double)total) {
        /* 0.1 m above the top of the flat band: never coplanar with it (the
         * reverse-Z depth resolves millimetres at tens of km), and no land
         * above the sea's own level is flooded (1 m drowned coastal flats). */
        level = zscale * hm->offset + step * (float)best_top + 0.1f;
        if (is_sea)
            *is_sea = true;
    } else {
        const uint64_t want = (uint64_t)((double)fraction * (double)(nvalid ? nvalid : total));
        const uint32_t *h = nvalid ? hv : hist;
        uint64_t acc = 0;
        uint32_t v = 0;
        for (; v < 65535; v++) {
            acc += h[v];
            if (acc >= want && acc > 0)
                break;
        }
        level = zscale * hm->offset + step * (float)v;
    }
    free(hist);
    return level;
}

bool hz_ground_clear(const float *tops, uint32_t size, float spacing, float x, float z, float radius)
{
    if (!tops || !size || !(spacing > 0.0f))
        return true;
    const float rad = fmaxf(radius, spacing);
    const float fi0 = floorf((x - rad) / spacing), fi1 = ceilf((x + rad) / spacing);
    const float fj0 = floorf((z - rad) / spacing), fj1 = ceilf((z + rad) / spacing);
    if (!(fi1 >= 0 && fj1 >= 0 && fi0 < (float)size && fj0 < (float)size))
        return true;
    const uint32_t i0 = (uint32_t)fmaxf(fi0, 0), i1 = (uint32_t)fminf(fi1, (float)(size - 1));
    const uint32_t j0 = (uint32_t)fmaxf(fj0, 0), j1 = (uint32_t)fminf(fj1, (float)(size - 1));
    for (uint32_t j = j0; j <= j1; j++)
        for (uint32_t i = i0; i <= i1; i++)
            if (tops[(size_t)j * size + i] > -INFINITY)
                return false;
    return true;
}

size_t hz_billboards_clear_of(hz_billboard *b, size_t n, const float *tops, uint32_t size, float spacing)
{
    if (!b || !tops)
        return n;
    size_t kept = 0;
    for (size_t k = 0; k < n; k++)
        if (hz_ground_clear(tops, size, spacing, b[k].pos[0], b[k].pos[2], 0.5f * b[k].width))
            b[kept++] = b[k];
    return kept;
}
