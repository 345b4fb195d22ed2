/* Procedural terrain: seeded gradient-noise fBm (Perlin) with ridges and a
 * domain warp, and diamond-square. Bit-for-bit repeatable: our own RNG and
 * permutation table, only +,-,*,/ and integer ops in the hot paths (no libm
 * transcendental whose last bit differs between libms), and this file is
 * compiled with -ffp-contract=off so no FMA changes rounding on some CPUs. */
#define _POSIX_C_SOURCE 200809L
#include "io_internal.h"

#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

bool hz_gen_kind_parse(const char *s, hz_gen_kind *out)
{
    hz_gen_kind k;
    if (!s)
        return false;
    if (!strcmp(s, "perlin"))
        k = HZ_GEN_PERLIN;
    else if (!strcmp(s, "diamond") || !strcmp(s, "diamond-square"))
        k = HZ_GEN_DIAMOND;
    else
        return false;
    if (out)
        *out = k;
    return true;
}

static uint64_t splitmix64(uint64_t *s)
{
    uint64_t z = (*s += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

/* Uniform in [0, 1) with 24 bits. */
static float rnd01(uint64_t *s)
{
    return (float)(splitmix64(s) >> 40) * (1.0f / 16777216.0f);
}

/* ---- gradient noise ---- */

enum { PERM_N = 4096 }; /* lattice period in cells: no visible repetition */

typedef struct noise2 {
    uint16_t perm[2 * PERM_N];
} noise2;

static void noise_init(noise2 *n, uint64_t *s)
{
    for (int i = 0; i < PERM_N; i++)
        n->perm[i] = (uint16_t)i;
    for (int i = PERM_N - 1; i > 0; i--) {
        int j = (int)(splitmix64(s) % (uint64_t)(i + 1));
        uint16_t t = n->perm[i];
        n->perm[i] = n->perm[j];
        n->perm[j] = t;
    }
    memcpy(n->perm + PERM_N, n->perm, PERM_N * sizeof *n->perm);
}

/* Eight unit gradients. */
static const float GX[8] = {1.0f, -1.0f, 0.0f, 0.0f, 0.70710678f, -0.70710678f, 0.70710678f, -0.70710678f};
static const float GY[8] = {0.0f, 0.0f, 1.0f, -1.0f, 0.70710678f, 0.70710678f, -0.70710678f, -0.70710678f};

static inline float fade(float t)
{
    return t * t * t * (t * (t * 6.0f - 15.0f) + 10.0f);
}

/* Gradient noise at (x, y) >= 0, roughly in [-1, 1]; *dx, *dy receive its
 * derivatives in lattice units. */
static inline float noise_dm(const noise2 *n, int mask, double x, double y, float *dx, float *dy)
{
    int xi = (int)x, yi = (int)y;
    float fx = (float)(x - (double)xi), fy = (float)(y - (double)yi);
    /* mask + 1: the lattice period (PERM_N, or a power of two dividing it
     * for a terrain that repeats) */
    int X = xi & mask, Y = yi & mask, X1 = (xi + 1) & mask, Y1 = (yi + 1) & mask;
    const uint16_t *p = n->perm;
    int a = p[X], b = p[X1];
    int h00 = p[a + Y] & 7, h01 = p[a + Y1] & 7, h10 = p[b + Y] & 7, h11 = p[b + Y1] & 7;
    float n00 = GX[h00] * fx + GY[h00] * fy;
    float n10 = GX[h10] * (fx - 1.0f) + GY[h10] * fy;
    float n01 = GX[h01] * fx + GY[h01] * (fy - 1.0f);
    float n11 = GX[h11] * (fx - 1.0f) + GY[h11] * (fy - 1.0f);
    float u = fade(fx), v = fade(fy);
    float du = 30.0f * fx * fx * (fx - 1.0f) * (fx - 1.0f), dv = 30.0f * fy * fy * (fy - 1.0f) * (fy - 1.0f);
    float nx0 = n00 + u * (n10 - n00), nx1 = n01 + u * (n11 - n01);
    float gx0 = GX[h00] + u * (GX[h10] - GX[h00]) + du * (n10 - n00);
    float gx1 = GX[h01] + u * (GX[h11] - GX[h01]) + du * (n11 - n01);
    float gy0 = GY[h00] + u * (GY[h10] - GY[h00]);
    float gy1 = GY[h01] + u * (GY[h11] - GY[h01]);
    *dx = 1.41421356f * (gx0 + v * (gx1 - gx0));
    *dy = 1.41421356f * (gy0 + v * (gy1 - gy0) + dv * (nx1 - nx0));
    return 1.41421356f * (nx0 + v * (nx1 - nx0));
}

static inline float noise_d(const noise2 *n, double x, double y, float *dx, float *dy)
{
    return noise_dm(n, PERM_N - 1, x, y, dx, dy);
}

static inline float noise(const noise2 *n, double x, double y)
{
    float dx, dy;
    return noise_d(n, x, y, &dx, &dy);
}

static float clamp01(float x)
{
    return x < 0.0f ? 0.0f : x > 1.0f ? 1.0f : x;
}

static float smooth01(float e0, float e1, float x)
{
    float t = clamp01((x - e0) / (e1 - e0));
    return t * t * (3.0f - 2.0f * t);
}

enum { MAX_OCTAVES = 24, WARP_STEP = 8, ROW_CHUNK = 16, MAX_THREADS = 8 };

typedef struct perlin_params {
    noise2 nz;
    int octaves;
    double freq0;                 /* cycles per sample of octave 0 */
    float persistence;
    double offx[MAX_OCTAVES + 4], offy[MAX_OCTAVES + 4]; /* per-octave lattice offsets */
    double warp_freq, warp_amp;   /* warp noise frequency, displacement in samples */
    int mask[MAX_OCTAVES + 4];    /* lattice period - 1 per octave (warp octaves at MAX_OCTAVES..) */
} perlin_params;

/* Look of the terrain (tuned by eye on hillshades against real DEMs):
 * octaves after the 4th fade 15% faster than the persistence says, since
 * real terrain has less fine relief than plain fBm; slope damping strength;
 * softness of ridge crests; mountain mask over the two lowest octaves. */
#define HIGH_OCTAVE 3
#define HIGH_DECAY 0.85f
#define SLOPE_DAMP 1.5f
#define CREST_SOFT 0.003f
#define MASK_LO -0.6f
#define MASK_HI 0.5f

/* Domain-warp displacement at (x, y), in samples. Two octaves of noise bend
 * ridges and valleys so they meander instead of following the lattice. */
static void warp_at(const perlin_params *pp, double x, double y, float *dx, float *dy)
{
    const noise2 *nz = &pp->nz;
    double wf = pp->warp_freq;
    int W = MAX_OCTAVES;
    float d0, d1;
    float wx = noise_dm(nz, pp->mask[W], x * wf + pp->offx[W], y * wf + pp->offy[W], &d0, &d1) +
               0.5f * noise_dm(nz, pp->mask[W + 1], x * 2 * wf + pp->offx[W + 1], y * 2 * wf + pp->offy[W + 1], &d0, &d1);
    float wy = noise_dm(nz, pp->mask[W], x * wf + pp->offx[W + 2], y * wf + pp->offy[W + 2], &d0, &d1) +
               0.5f * noise_dm(nz, pp->mask[W + 1], x * 2 * wf + pp->offx[W + 3], y * 2 * wf + pp->offy[W + 3], &d0, &d1);
    *dx = (float)pp->warp_amp * wx;
    *dy = (float)pp->warp_amp * wy;
}

/* Height at (already warped) (x, y), not normalised. */
static float perlin_height(const perlin_params *pp, double x, double y)
{
    const noise2 *nz = &pp->nz;
    float fbm = 0.0f, ridge = 0.0f, amp = 1.0f, norm = 0.0f, weight = 1.0f, base = 0.0f;
    float sdx = 0.0f, sdy = 0.0f;
    double f = pp->freq0;
    for (int o = 0; o < pp->octaves; o++) {
        float dx, dy;
        float n = noise_dm(nz, pp->mask[o], x * f + pp->offx[o], y * f + pp->offy[o], &dx, &dy);
        if (o < 2)
            base += amp * n;
        /* Slope-damped fBm: detail fades where the coarser octaves are steep,
         * which looks like erosion (smooth flanks, rough tops). */
        sdx += dx;
        sdy += dy;
        fbm += amp * n / (1.0f + SLOPE_DAMP * (sdx * sdx + sdy * sdy));
        /* Ridged multifractal (Musgrave): crests where the noise crosses 0;
         * each octave is weighted by the previous ridge signal, so detail
         * gathers on the ridges. */
        float r = 1.0f - sqrtf(n * n + CREST_SOFT);
        r = r * r * weight;
        weight = clamp01(r * 2.0f);
        if (o > 0)
            ridge += amp * r;
        norm += amp;
        amp *= o >= HIGH_OCTAVE ? pp->persistence * HIGH_DECAY : pp->persistence;
        f *= 2.0;
    }
    fbm /= norm;   /* ~[-1, 1] */
    ridge /= norm; /* [0, 1] */
    /* Mountain ranges (ridged) where the two lowest octaves are high;
     * elsewhere rolling hills and plains. */
    float m = smooth01(MASK_LO, MASK_HI, base);
    return 0.5f * (0.5f + 0.5f * fbm) + m * m * ridge;
}

typedef struct perlin_job {
    const perlin_params *pp;
    hz_grid *g;
    const float *warp; /* (cw x ch) x 2 displacements every WARP_STEP samples */
    uint32_t cw;
    atomic_uint next_chunk;
    atomic_uint rows_done;
} perlin_job;

static void perlin_rows(perlin_job *job, hz_io_progress *prog)
{
    const uint32_t n = job->g->width, cw = job->cw;
    const float inv = 1.0f / (float)WARP_STEP;
    for (;;) {
        uint32_t j0 = atomic_fetch_add(&job->next_chunk, 1u) * ROW_CHUNK;
        if (j0 >= n)
            break;
        uint32_t j1 = j0 + ROW_CHUNK < n ? j0 + ROW_CHUNK : n;
        for (uint32_t j = j0; j < j1; j++) {
            float *row = job->g->z + (size_t)j * n;
            uint32_t J = j / WARP_STEP;
            float v = (float)(j % WARP_STEP) * inv;
            const float *w0 = job->warp + (size_t)J * cw * 2, *w1 = w0 + (size_t)cw * 2;
            for (uint32_t i = 0; i < n; i++) {
                /* The warp is smooth on a scale of hundreds of samples:
                 * bilinear from a coarse grid is exact enough and 4x cheaper. */
                uint32_t I = i / WARP_STEP;
                float u = (float)(i % WARP_STEP) * inv;
                const float *a = w0 + 2 * I, *b = w1 + 2 * I;
                float dx0 = a[0] + u * (a[2] - a[0]), dx1 = b[0] + u * (b[2] - b[0]);
                float dy0 = a[1] + u * (a[3] - a[1]), dy1 = b[1] + u * (b[3] - b[1]);
                double x = (double)i + (double)(dx0 + v * (dx1 - dx0));
                double y = (double)j + (double)(dy0 + v * (dy1 - dy0));
                row[i] = perlin_height(job->pp, x, y);
            }
        }
        unsigned done = atomic_fetch_add(&job->rows_done, j1 - j0) + (j1 - j0);
        if (prog)
            hz_io_progress_step(prog, done);
    }
}

static void *perlin_worker(void *arg)
{
    perlin_rows(arg, NULL);
    return NULL;
}

static int worker_count(uint32_t n)
{
    long cpus = sysconf(_SC_NPROCESSORS_ONLN);
    int t = cpus < 1 ? 1 : cpus > MAX_THREADS ? MAX_THREADS : (int)cpus;
    return n < 257 ? 1 : t;
}

static void perlin_setup(const hz_gen_desc *d, float persistence, uint32_t n, perlin_params *pp);

static hz_result gen_perlin(const hz_gen_desc *d, float persistence, hz_grid *g, hz_err *err)
{
    const uint32_t n = d->size;
    const uint32_t cw = (n - 1) / WARP_STEP + 2; /* one spare column/row for the bilinear */
    perlin_params *pp = malloc(sizeof *pp);
    float *warp = malloc((size_t)cw * cw * 2 * sizeof *warp);
    if (!pp || !warp) {
        free(pp);
        free(warp);
        return hz_err_set(err, HZ_ERR_MEMORY, "generate: out of memory");
    }
    hz_gen_desc whole = *d;
    whole.periodic = false; /* repeating terrains are made window by window (hz_gen_window) */
    perlin_setup(&whole, persistence, n, pp);
    for (uint32_t J = 0; J < cw; J++)
        for (uint32_t I = 0; I < cw; I++) {
            float *w = warp + ((size_t)J * cw + I) * 2;
            warp_at(pp, (double)(I * WARP_STEP), (double)(J * WARP_STEP), &w[0], &w[1]);
        }

    perlin_job job = {.pp = pp, .g = g, .warp = warp, .cw = cw};
    atomic_init(&job.next_chunk, 0u);
    atomic_init(&job.rows_done, 0u);
    hz_io_progress prog = {d->progress, d->progress_user, "generate perlin", n, -1};
    /* Rows are independent, so threads change nothing in the result. */
    pthread_t th[MAX_THREADS];
    int nt = worker_count(n), started = 0;
    for (int t = 1; t < nt; t++) {
        if (pthread_create(&th[started], NULL, perlin_worker, &job) != 0)
            break; /* fewer threads: same result, just slower */
        started++;
    }
    perlin_rows(&job, &prog);
    for (int t = 0; t < started; t++)
        pthread_join(th[t], NULL);
    hz_io_progress_step(&prog, n);
    free(warp);
    free(pp);
    return HZ_OK;
}

/* Normalises to [0, 1], applies the height curve and scales to [0, amp]. The
 * curve h * (0.3 + 0.7 h) flattens lowlands (slope 0.3 at 0) and steepens
 * peaks (slope 1.7 at 1). */
static void finish(hz_grid *g, float amplitude)
{
    size_t n = (size_t)g->width * g->height;
    float lo = g->z[0], hi = g->z[0];
    for (size_t k = 1; k < n; k++) {
        lo = g->z[k] < lo ? g->z[k] : lo;
        hi = g->z[k] > hi ? g->z[k] : hi;
    }
    float range = hi > lo ? hi - lo : 1.0f;
    for (size_t k = 0; k < n; k++) {
        float t = clamp01((g->z[k] - lo) / range); /* division: exactly 1 at the top */
        float h = amplitude * (t * (0.3f + 0.7f * t));
        g->z[k] = h > amplitude ? amplitude : h;
    }
}

/* ---- diamond-square ---- */

static hz_result gen_diamond(const hz_gen_desc *d, float decay, hz_grid *g)
{
    const uint32_t n = d->size;
    float *z = g->z;
    uint64_t s = d->seed ^ 0xd1a30d5a3e7ULL;
    float scale = 1.0f;
    hz_io_progress prog = {d->progress, d->progress_user, "generate diamond", (uint64_t)n * n, -1};
    uint64_t done = 4;
#define Z(i, j) z[(size_t)(j) * n + (i)]
    Z(0, 0) = rnd01(&s);
    Z(n - 1, 0) = rnd01(&s);
    Z(0, n - 1) = rnd01(&s);
    Z(n - 1, n - 1) = rnd01(&s);
    for (uint32_t step = n - 1; step > 1; step /= 2) {
        uint32_t half = step / 2;
        /* Diamond: centres of squares. */
        for (uint32_t j = half; j < n; j += step) {
            for (uint32_t i = half; i < n; i += step) {
                float a = Z(i - half, j - half) + Z(i + half, j - half) + Z(i - half, j + half) +
                          Z(i + half, j + half);
                Z(i, j) = 0.25f * a + scale * (2.0f * rnd01(&s) - 1.0f);
            }
            done += (n - 1) / step;
        }
        /* Square: edge midpoints, from up to four diamond neighbours. */
        for (uint32_t j = 0; j < n; j += half) {
            for (uint32_t i = (j / half) % 2 ? 0 : half; i < n; i += step) {
                float a = 0.0f;
                int c = 0;
                if (i >= half) { a += Z(i - half, j); c++; }
                if (i + half < n) { a += Z(i + half, j); c++; }
                if (j >= half) { a += Z(i, j - half); c++; }
                if (j + half < n) { a += Z(i, j + half); c++; }
                Z(i, j) = a / (float)c + scale * (2.0f * rnd01(&s) - 1.0f);
                done++;
            }
            hz_io_progress_step(&prog, done);
        }
        /* Displacement shrinks by decay (= 2^-H) per level, except that the
         * four coarsest levels keep most of theirs (several mountains, not
         * one tilted plane) and, like the Perlin octaves, the fine levels
         * fade faster (less small-scale roughness, as in real terrain). */
        scale *= step > (n - 1) / 16 ? 0.9f : step <= (n - 1) / 32 ? decay * 0.8f : decay;
    }
#undef Z
    hz_io_progress_step(&prog, (uint64_t)n * n);
    return HZ_OK;
}

hz_result hz_generate(const hz_gen_desc *desc, hz_grid *out, hz_err *err)
{
    HZ_ASSERT(desc && out);
    out->z = NULL;
    out->width = out->height = 0;
    if (desc->kind != HZ_GEN_PERLIN && desc->kind != HZ_GEN_DIAMOND)
        return hz_err_set(err, HZ_ERR_VALUE, "generate: unknown kind %d (use perlin or diamond)", (int)desc->kind);
    if (!hz_is_pow2_plus1(desc->size) || desc->size > 16385)
        return hz_err_set(err, HZ_ERR_VALUE,
                          "generate: size %u must be 2^n+1 between 3 and 16385 (e.g. 1025, 2049, 4097)",
                          desc->size);
    float amp = desc->amplitude == 0.0f ? 1800.0f : desc->amplitude;
    if (!(amp > 0.0f) || !(amp <= 100000.0f))
        return hz_err_set(err, HZ_ERR_VALUE, "generate: amplitude %g m must be in (0, 100000]",
                          (double)desc->amplitude);
    float rough = desc->roughness == 0.0f ? 0.5f : desc->roughness;
    if (!(rough > 0.0f) || !(rough <= 1.0f))
        return hz_err_set(err, HZ_ERR_VALUE, "generate: roughness %g must be in (0, 1]", (double)desc->roughness);
    if (!(desc->feature_size >= 0.0f) || desc->feature_size > 1e6f ||
        (desc->feature_size > 0.0f && desc->feature_size < 2.0f))
        return hz_err_set(err, HZ_ERR_VALUE, "generate: feature_size %g must be 0 (auto) or 2..1e6 samples",
                          (double)desc->feature_size);
    if (desc->octaves > MAX_OCTAVES)
        return hz_err_set(err, HZ_ERR_VALUE, "generate: %u octaves is more than the maximum %d", desc->octaves,
                          MAX_OCTAVES);
    hz_result r = hz_grid_alloc(out, desc->size, desc->size, err);
    if (r != HZ_OK)
        return r;
    r = desc->kind == HZ_GEN_PERLIN ? gen_perlin(desc, rough, out, err) : gen_diamond(desc, rough, out);
    if (r != HZ_OK) {
        hz_grid_free(out);
        return r;
    }
    finish(out, amp);
    return HZ_OK;
}

/* ---- windowed Perlin (pyramid import): any window of a map of any size ---- */

struct hz_gen_window {
    perlin_params pp;
    float amplitude;
};

/* The Perlin parameters of d for a map of n samples a side (gen_perlin and
 * the windows). */
static void perlin_setup(const hz_gen_desc *d, float persistence, uint32_t n, perlin_params *pp)
{
    uint64_t s = d->seed ^ 0x5eed5eed5eed5eedULL;
    noise_init(&pp->nz, &s);
    double feature = d->feature_size > 0 ? (double)d->feature_size : (double)(n / 2);
    if (feature < 2.0)
        feature = 2.0;
    int oct = (int)d->octaves;
    if (oct == 0) {
        oct = 1;
        for (double w = feature; w >= 4.0 && oct < MAX_OCTAVES; w *= 0.5)
            oct++;
    }
    pp->octaves = oct;
    pp->freq0 = 1.0 / feature;
    pp->persistence = persistence;
    for (int o = 0; o < MAX_OCTAVES + 4; o++) {
        pp->offx[o] = 64.0 + (double)(splitmix64(&s) % 1024u) + (double)rnd01(&s);
        pp->offy[o] = 64.0 + (double)(splitmix64(&s) % 1024u) + (double)rnd01(&s);
    }
    pp->warp_freq = 1.5 / feature;
    pp->warp_amp = 0.12 * feature;
    for (int o = 0; o < MAX_OCTAVES + 4; o++)
        pp->mask[o] = PERM_N - 1;
    if (d->periodic) {
        /* Every octave a whole number of lattice cells across the map
         * (n - 1 samples), and the lattice wrapped at that count: the
         * terrain repeats seamlessly. The warp's frequency is rounded to
         * a power of two cells across. */
        const double cells0 = (double)(n - 1) / feature;
        pp->warp_freq = 2.0 / feature;
        for (int o = 0; o < MAX_OCTAVES + 4; o++) {
            const double c = o < MAX_OCTAVES ? cells0 * (double)(1u << (o < 30 ? o : 30))
                                             : 2.0 * cells0 * (double)(((o - MAX_OCTAVES) & 1) ? 2 : 1);
            const double m = c < (double)PERM_N ? c : (double)PERM_N;
            pp->mask[o] = (int)m - 1;
        }
    }
}

hz_result hz_gen_window_open(const hz_gen_desc *d, hz_gen_window **out, hz_err *err)
{
    *out = NULL;
    if (d->kind != HZ_GEN_PERLIN)
        return hz_err_set(err, HZ_ERR_UNSUPPORTED,
                          "generate: only perlin can be generated window by window (diamond-square's every "
                          "sample depends on the whole coarser map: use --size <= 16385 and a DEM file)");
    if (!hz_is_pow2_plus1(d->size) || d->size > 1048577u)
        return hz_err_set(err, HZ_ERR_VALUE, "generate: size %u must be 2^n+1 between 3 and 1048577", d->size);
    float amp = d->amplitude == 0.0f ? 1800.0f : d->amplitude;
    float rough = d->roughness == 0.0f ? 0.5f : d->roughness;
    if (!(amp > 0.0f) || !(amp <= 100000.0f) || !(rough > 0.0f) || !(rough <= 1.0f) || d->octaves > MAX_OCTAVES ||
        !(d->feature_size >= 0.0f) || d->feature_size > 1e7f)
        return hz_err_set(err, HZ_ERR_VALUE, "generate: amplitude, roughness, octaves or feature size out of range");
    if (d->periodic) {
        const double feature = d->feature_size > 0 ? (double)d->feature_size : (double)(d->size / 2);
        const double cells = (double)(d->size - 1) / feature;
        if (cells != floor(cells) || ((uint64_t)cells & ((uint64_t)cells - 1)))
            return hz_err_set(err, HZ_ERR_VALUE,
                              "generate: a repeating terrain needs a feature size of (size - 1) / 2^k samples "
                              "(%g does not divide %u)", feature, d->size - 1);
    }
    hz_gen_window *w = calloc(1, sizeof *w);
    if (!w)
        return hz_err_set(err, HZ_ERR_MEMORY, "generate: out of memory");
    perlin_setup(d, rough, d->size, &w->pp);
    w->amplitude = amp;
    *out = w;
    return HZ_OK;
}

void hz_gen_window_close(hz_gen_window *w)
{
    free(w);
}

float hz_gen_window_amplitude(const hz_gen_window *w)
{
    return w->amplitude;
}

/* Raw Perlin heights lie in [0, 1.5]; a window cannot see the map's own
 * range, so the curve of finish() is applied to the fixed range [0.05, 1.05]. */
#define WIN_LO 0.05f
#define WIN_HI 1.05f

void hz_gen_window_read(const hz_gen_window *gw, uint32_t x0, uint32_t y0, uint32_t w, uint32_t h, float *out)
{
    const perlin_params *pp = &gw->pp;
    const float inv = 1.0f / (float)WARP_STEP;
    const float amp = gw->amplitude;
    for (uint32_t y = 0; y < h; y++) {
        const uint32_t j = y0 + y, J = j / WARP_STEP;
        const float v = (float)(j % WARP_STEP) * inv;
        uint32_t Ic = UINT32_MAX;
        float a[4] = {0}, b[4] = {0};
        for (uint32_t x = 0; x < w; x++) {
            const uint32_t i = x0 + x, I = i / WARP_STEP;
            if (I != Ic) { /* the warp grid's corners, as gen_perlin samples them */
                warp_at(pp, (double)(I * WARP_STEP), (double)(J * WARP_STEP), &a[0], &a[1]);
                warp_at(pp, (double)((I + 1) * WARP_STEP), (double)(J * WARP_STEP), &a[2], &a[3]);
                warp_at(pp, (double)(I * WARP_STEP), (double)((J + 1) * WARP_STEP), &b[0], &b[1]);
                warp_at(pp, (double)((I + 1) * WARP_STEP), (double)((J + 1) * WARP_STEP), &b[2], &b[3]);
                Ic = I;
            }
            const float u = (float)(i % WARP_STEP) * inv;
            float dx0 = a[0] + u * (a[2] - a[0]), dx1 = b[0] + u * (b[2] - b[0]);
            float dy0 = a[1] + u * (a[3] - a[1]), dy1 = b[1] + u * (b[3] - b[1]);
            double px = (double)i + (double)(dx0 + v * (dx1 - dx0));
            double py = (double)j + (double)(dy0 + v * (dy1 - dy0));
            float t = clamp01((perlin_height(pp, px, py) - WIN_LO) / (WIN_HI - WIN_LO));
            float hh = amp * (t * (0.3f + 0.7f * t));
            out[(size_t)y * w + x] = hh > amp ? amp : hh;
        }
    }
}
