/* Light map with terrain shadows (SPEC R5), by a horizon sweep.
 *
 * The ray from a sample toward the sun is followed one grid line at a time
 * along the sun's dominant horizontal axis ("major"): each step moves one
 * sample along the major axis, r = s_minor / |s_major| samples (|r| <= 1)
 * along the minor axis, and rises rise = spacing * s_y / |s_major| metres.
 * The lines are processed from the sun side inwards. For each line we keep
 * the "shadow surface"
 *     S(line, q) = max(h(line, q), S(previous line, q + r) - rise),
 * the highest sun ray that passes over the sample (the previous line's value
 * is linearly interpolated between its two neighbouring samples). A sample is
 * in shadow when S(previous, q + r) - rise > h(line, q). This makes the whole
 * map O(samples) instead of O(samples x ray length) for a ray march.
 *
 * NOTE: for a sun along an axis or a diagonal (r integer) the sweep equals a
 * ray march with linear interpolation between samples exactly; for other
 * azimuths interpolating S (a max of rays) instead of the terrain widens
 * shadows slightly near their edges (tests/terrain/test_lightmap.c measures
 * the agreement with a brute-force ray march).
 *
 * Threads: each line is split into bands along the minor axis. A sample only
 * reads the previous line at q - 1 .. q + 1, so a thread may start line k once
 * its two neighbour bands have finished line k - 1 (atomic line counters, no
 * global barrier); two line buffers are then enough. */
#include "horizon/lightmap.h"

#include <math.h>
#include <pthread.h>
#include <sched.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#define MAX_THREADS 16
#define TILE 64u /* lines gathered before a transposed write */

typedef struct sweep {
    const hz_heightmap *hm;
    uint8_t *out;
    uint32_t n;
    float hscale, hoffset; /* metres = hoffset + hscale * h16 (zscale applied) */
    float spacing;
    vec3 s;                /* unit, toward the sun */
    float ambient;
    bool shadows;
    const float *casters;  /* hz_lightmap_desc.casters */
    float *sun_heights;    /* hz_lightmap_desc.sun_heights over sun_rect, or NULL */
    uint32_t rect[4];
    bool major_x;          /* lines are columns (i const) when the sun is mostly along x */
    int dir;               /* +1: the sun is toward increasing major coordinate */
    float r, rise;
    int32_t ri;            /* floor(r) */
    float rf;              /* r - ri, in [0, 1) */
    float *line[2];        /* shadow surface of the current and previous line */
    uint32_t threads;
    _Atomic int gate;      /* 0: wait, 1: go, 2: leave (a thread failed to start) */
    _Atomic uint32_t done[MAX_THREADS]; /* lines finished per band */
    uint64_t shadowed[MAX_THREADS], away[MAX_THREADS];
} sweep;

typedef struct worker {
    sweep *sw;
    uint32_t t, q0, q1;    /* band [q0, q1) of the minor axis */
    bool failed;           /* out of memory */
} worker;

static inline uint8_t quantise(float I)
{
    float v = I * 255.0f + 0.5f;
    return (uint8_t)(v < 0.0f ? 0.0f : v > 255.0f ? 255.0f : v);
}

static void wait_for(const sweep *sw, uint32_t t, uint32_t lines)
{
    for (unsigned spins = 0; atomic_load_explicit(&sw->done[t], memory_order_acquire) < lines; spins++)
        if (spins > 64)
            sched_yield(); /* two cores shared with others: do not burn the neighbour's core */
}

/* Heights (metres) of major line m, minor samples [a, b), into dst[a..b). */
static void load_line(const sweep *sw, uint32_t m, uint32_t a, uint32_t b, float *dst)
{
    for (uint32_t q = a; q < b; q++) {
        uint16_t v = sw->major_x ? hz_heightmap_get16(sw->hm, m, q) : hz_heightmap_get16(sw->hm, q, m);
        dst[q] = sw->hoffset + sw->hscale * (float)v;
    }
}

static void *run_band(void *arg)
{
    worker *w = arg;
    sweep *sw = w->sw;
    const uint32_t n = sw->n;
    const float Ie = sw->ambient, eps = 1e-3f;
    uint64_t shadowed = 0, away = 0;
    int g;
    while ((g = atomic_load(&sw->gate)) == 0)
        sched_yield();
    if (g == 2)
        return NULL;
    /* Heights of the band (with one sample of margin) for three consecutive
     * major lines, indexed by the full minor coordinate. */
    const uint32_t a = w->q0 ? w->q0 - 1 : 0, b = w->q1 < n ? w->q1 + 1 : n;
    float *win = malloc(3 * (size_t)n * sizeof *win);
    uint8_t *shade = malloc((size_t)n), *ob = malloc((size_t)n);
    uint8_t *tile = sw->major_x ? malloc((size_t)TILE * (w->q1 - w->q0)) : NULL;
    if (!win || !shade || !ob || (sw->major_x && !tile)) {
        free(win);
        free(shade);
        free(ob);
        free(tile);
        w->failed = true;
        /* Still publish progress so neighbours do not wait forever. */
        for (uint32_t k = 0; k < n; k++)
            atomic_store_explicit(&sw->done[w->t], k + 1, memory_order_release);
        return NULL;
    }
    float *lo = win, *mid = win + n, *hi = win + 2 * (size_t)n; /* lines m - 1, m, m + 1 (clamped) */
    const float inv_min = 1.0f / sw->spacing;
    const float s_maj = sw->major_x ? sw->s[0] : sw->s[2], s_min = sw->major_x ? sw->s[2] : sw->s[0];
    uint32_t m = sw->dir > 0 ? n - 1 : 0;
    load_line(sw, m, a, b, mid);
    load_line(sw, m ? m - 1 : 0, a, b, lo);
    load_line(sw, m + 1 < n ? m + 1 : m, a, b, hi);
    for (uint32_t k = 0; k < n; k++) {
        m = sw->dir > 0 ? n - 1 - k : k;
        if (k > 0) {
            /* Slide the window one line away from the sun. */
            if (sw->dir > 0) { /* m decreased: hi <- mid, mid <- lo, lo <- line m - 1 */
                float *t = hi;
                hi = mid, mid = lo, lo = t;
                load_line(sw, m ? m - 1 : 0, a, b, lo);
            } else {
                float *t = lo;
                lo = mid, mid = hi, hi = t;
                load_line(sw, m + 1 < n ? m + 1 : m, a, b, hi);
            }
        }
        float *cur = sw->line[k & 1];
        const float *prev = sw->line[(k + 1) & 1];
        if (k > 0) {
            if (w->t > 0)
                wait_for(sw, w->t - 1, k);
            if (w->t + 1 < sw->threads)
                wait_for(sw, w->t + 1, k);
        }
        const float inv_maj = inv_min / (float)((m + 1 < n ? m + 1 : m) - (m ? m - 1 : 0));
        const uint32_t q0 = w->q0, q1 = w->q1;
        /* 1. The shadow surface. The ray from sample q meets the previous
         * line at q + r: samples q + ri and q + ri + 1 with the same weight f
         * for every q, a constant stencil (vectorises). Outside [qa, qb) the
         * ray leaves the map: no occluder. */
        uint32_t qa = q0, qb = q0;
        if (k > 0 && sw->shadows) {
            const int64_t ri = sw->ri;
            const int64_t lo_q = -ri, hi_q = (int64_t)n - 1 - ri - (sw->rf > 0.0f ? 1 : 0); /* inclusive */
            qa = (uint32_t)(lo_q > (int64_t)q0 ? (lo_q < (int64_t)q1 ? lo_q : q1) : q0);
            qb = (uint32_t)(hi_q + 1 < (int64_t)q1 ? (hi_q + 1 > (int64_t)qa ? hi_q + 1 : qa) : q1);
        }
        for (uint32_t q = q0; q < qa; q++)
            cur[q] = mid[q], shade[q] = 0;
        if (qb > qa) {
            const float f = sw->rf, f0 = 1.0f - f, rise = sw->rise;
            const float *p0 = prev + sw->ri, *p1 = p0 + (f > 0.0f ? 1 : 0);
            for (uint32_t q = qa; q < qb; q++) {
                float h = mid[q], occ = p0[q] * f0 + p1[q] * f - rise;
                shade[q] = occ > h + eps;
                cur[q] = occ > h ? occ : h;
            }
        }
        for (uint32_t q = qb > qa ? qb : qa; q < q1; q++)
            cur[q] = mid[q], shade[q] = 0;
        /* The sun heights are the shadow surface before this line's own
         * casters raise it. */
        if (sw->sun_heights) {
            const uint32_t *R = sw->rect;
            const uint32_t m0 = sw->major_x ? R[0] : R[1], mn = sw->major_x ? R[2] : R[3];
            const uint32_t n0 = sw->major_x ? R[1] : R[0], nn = sw->major_x ? R[3] : R[2];
            if (m >= m0 && m < m0 + mn) {
                const uint32_t a0 = q0 > n0 ? q0 : n0, a1 = q1 < n0 + nn ? q1 : n0 + nn;
                for (uint32_t q = a0; q < a1; q++) {
                    const size_t at = sw->major_x ? (size_t)(q - n0) * R[2] + (m - m0)
                                                  : (size_t)(m - m0) * R[2] + (q - n0);
                    sw->sun_heights[at] = cur[q];
                }
            }
        }
        /* Objects standing on a sample raise the shadow surface the next
         * lines see (not the sample's own shading). */
        if (sw->casters && sw->shadows)
            for (uint32_t q = q0; q < q1; q++) {
                const float top = sw->casters[sw->major_x ? (size_t)q * n + m : (size_t)m * n + q];
                if (top > cur[q])
                    cur[q] = top;
            }
        /* 2. cos(r) from central differences (one-sided at the borders), the
         * seed's formula, quantised into the line's bytes. */
        for (uint32_t q = q0; q < q1; q++) {
            uint32_t ql = q ? q - 1 : 0, qr = q + 1 < n ? q + 1 : n - 1;
            float dmaj = (hi[q] - lo[q]) * inv_maj;
            float dmin = (mid[qr] - mid[ql]) * inv_min * (qr - ql == 2 ? 0.5f : 1.0f);
            float c = (-dmaj * s_maj + sw->s[1] - dmin * s_min) / sqrtf(dmaj * dmaj + 1.0f + dmin * dmin);
            bool facing = c > 0.0f;
            away += !facing;
            shadowed += facing && shade[q];
            ob[q] = quantise(facing && !shade[q] ? c * (1.0f - Ie) + Ie : Ie);
        }
        /* 3. Into the map: a row; or, when the lines run along x, a column,
         * gathered TILE lines at a time so each row gets TILE bytes at once
         * (a byte per row and line would miss the cache every time). */
        if (!sw->major_x) {
            memcpy(sw->out + (size_t)m * n + q0, ob + q0, q1 - q0);
        } else {
            const uint32_t len = q1 - q0, t = k % TILE;
            memcpy(tile + (size_t)t * len, ob + q0, len);
            if (t == TILE - 1 || k == n - 1) {
                const uint32_t k0 = k - t;
                for (uint32_t q = 0; q < len; q++) {
                    uint8_t *row = sw->out + (size_t)(q0 + q) * n;
                    for (uint32_t u = 0; u <= t; u++) {
                        uint32_t mm = sw->dir > 0 ? n - 1 - (k0 + u) : k0 + u;
                        row[mm] = tile[(size_t)u * len + q];
                    }
                }
            }
        }
        atomic_store_explicit(&sw->done[w->t], k + 1, memory_order_release);
    }
    free(win);
    free(shade);
    free(ob);
    free(tile);
    sw->shadowed[w->t] = shadowed;
    sw->away[w->t] = away;
    return NULL;
}

bool hz_sample_rect_inside(const uint32_t rect[4], uint32_t size)
{
    return rect && rect[2] && rect[3] && rect[0] < size && rect[1] < size && rect[2] <= size - rect[0] &&
           rect[3] <= size - rect[1];
}

size_t hz_lightmap_bound(const hz_heightmap *hm)
{
    return hm ? (size_t)hm->size * hm->size : 0;
}

void hz_sun_direction(float azimuth_deg, float elevation_deg, vec3 dest)
{
    float az = glm_rad(azimuth_deg), el = glm_rad(elevation_deg);
    dest[0] = sinf(az) * cosf(el);
    dest[1] = sinf(el);
    dest[2] = -cosf(az) * cosf(el);
    /* sin/cos of 90-degree multiples are not exact in float: snap the
     * residue so an east sun is exactly (x, y, 0). */
    for (int k = 0; k < 3; k++)
        if (fabsf(dest[k]) < 1e-6f)
            dest[k] = 0.0f;
}

hz_result hz_lightmap_build(const hz_lightmap_desc *d, uint8_t *out, hz_lightmap_stats *stats, hz_err *err)
{
    double t0 = hz_time_ms();
    if (stats)
        *stats = (hz_lightmap_stats){0};
    if (!d || !d->hm || !d->hm->h || d->hm->size < 2 || !out)
        return hz_err_set(err, HZ_ERR_VALUE, "lightmap: no heightmap or no output buffer");
    const float zscale = d->zscale == 0.0f ? 1.0f : d->zscale;
    const float ambient = d->ambient == 0.0f ? 0.3f : d->ambient;
    if (!(d->spacing > 0.0f) || !isfinite(d->spacing) || !isfinite(zscale) || !(zscale > 0.0f))
        return hz_err_set(err, HZ_ERR_VALUE, "lightmap: bad spacing %g or zscale %g", (double)d->spacing,
                          (double)zscale);
    if (!(ambient >= 0.0f && ambient < 1.0f))
        return hz_err_set(err, HZ_ERR_VALUE, "lightmap: ambient Ie must be in [0, 1), got %g", (double)ambient);
    float len = sqrtf(d->sun_dir[0] * d->sun_dir[0] + d->sun_dir[1] * d->sun_dir[1] + d->sun_dir[2] * d->sun_dir[2]);
    if (!(len > 1e-12f) || !isfinite(len))
        return hz_err_set(err, HZ_ERR_VALUE, "lightmap: sun direction (%g, %g, %g) is zero or not finite",
                          (double)d->sun_dir[0], (double)d->sun_dir[1], (double)d->sun_dir[2]);

    sweep *sw = calloc(1, sizeof *sw);
    if (!sw)
        return hz_err_set(err, HZ_ERR_MEMORY, "lightmap: out of memory");
    const uint32_t n = d->hm->size;
    sw->hm = d->hm;
    sw->out = out;
    sw->n = n;
    sw->hscale = d->hm->scale * zscale;
    sw->hoffset = d->hm->offset * zscale;
    sw->spacing = d->spacing;
    for (int k = 0; k < 3; k++)
        sw->s[k] = d->sun_dir[k] / len;
    sw->ambient = ambient;
    const float sx = sw->s[0], sy = sw->s[1], sz = sw->s[2];
    const float horiz = fmaxf(fabsf(sx), fabsf(sz));
    sw->shadows = !d->no_shadows && sy > 0.0f && horiz > 1e-6f;
    sw->casters = d->casters;
    if (d->sun_heights) {
        const uint32_t *R = d->sun_rect;
        if (!hz_sample_rect_inside(R, n)) {
            free(sw);
            return hz_err_set(err, HZ_ERR_VALUE, "lightmap: sun height rectangle %u,%u %ux%u is empty or leaves "
                              "the %u x %u map", R[0], R[1], R[2], R[3], n, n);
        }
        sw->sun_heights = d->sun_heights;
        memcpy(sw->rect, R, sizeof sw->rect);
    }
    sw->major_x = fabsf(sx) >= fabsf(sz);
    const float smaj = sw->major_x ? sx : sz, smin = sw->major_x ? sz : sx;
    sw->dir = smaj > 0.0f ? 1 : -1;
    if (sw->shadows) {
        /* Stepping toward the sun moves the major coordinate by dir and the
         * minor one by smin / |smaj|. */
        sw->r = smin / fabsf(smaj);
        sw->rise = d->spacing * sy / fabsf(smaj);
        sw->ri = (int32_t)floorf(sw->r);
        sw->rf = sw->r - (float)sw->ri;
    }

    uint32_t T = d->threads ? d->threads : 2;
    if (T > MAX_THREADS)
        T = MAX_THREADS;
    if (T > n / 64)
        T = n / 64 ? n / 64 : 1; /* bands narrower than 64 samples cost more in waiting than they gain */
    sw->threads = T;
    sw->line[0] = malloc((size_t)n * sizeof(float));
    sw->line[1] = malloc((size_t)n * sizeof(float));
    if (!sw->line[0] || !sw->line[1]) {
        free(sw->line[0]);
        free(sw->line[1]);
        free(sw);
        return hz_err_set(err, HZ_ERR_MEMORY, "lightmap: out of memory");
    }
    for (uint32_t t = 0; t < MAX_THREADS; t++)
        atomic_init(&sw->done[t], 0);
    atomic_init(&sw->gate, 0);

    worker w[MAX_THREADS];
    pthread_t tid[MAX_THREADS];
    bool started[MAX_THREADS] = {false};
    for (uint32_t t = 0; t < T; t++)
        w[t] = (worker){.sw = sw, .t = t, .q0 = (uint32_t)((uint64_t)n * t / T),
                        .q1 = (uint32_t)((uint64_t)n * (t + 1) / T)};
    /* Thread 0 runs on the calling thread. The others wait at a gate until
     * all of them exist: if one cannot be started, the started ones leave
     * and a single band does the whole map (a band must never wait for a
     * neighbour that does not run). */
    uint32_t got = 1;
    for (uint32_t t = 1; t < T; t++) {
        if (pthread_create(&tid[t], NULL, run_band, &w[t]) != 0)
            break;
        started[t] = true;
        got++;
    }
    if (got < T) {
        atomic_store(&sw->gate, 2);
        for (uint32_t t = 1; t < T; t++)
            if (started[t])
                pthread_join(tid[t], NULL);
        T = sw->threads = 1;
        w[0].q1 = n;
        memset(started, 0, sizeof started);
    }
    atomic_store(&sw->gate, 1);
    run_band(&w[0]);
    for (uint32_t t = 1; t < T; t++)
        if (started[t])
            pthread_join(tid[t], NULL);

    bool failed = false;
    for (uint32_t t = 0; t < T; t++)
        failed |= w[t].failed;
    if (failed) {
        free(sw->line[0]);
        free(sw->line[1]);
        free(sw);
        return hz_err_set(err, HZ_ERR_MEMORY, "lightmap: out of memory");
    }
    if (stats) {
        stats->threads = T;
        for (uint32_t t = 0; t < T; t++) {
            stats->shadowed += sw->shadowed[t];
            stats->facing_away += sw->away[t];
        }
    }
    free(sw->line[0]);
    free(sw->line[1]);
    free(sw);
    if (stats)
        stats->ms = hz_time_ms() - t0;
    return HZ_OK;
}
