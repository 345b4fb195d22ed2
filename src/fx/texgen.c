/* Procedural textures: tileable ground detail per type and billboard
 * sprites, so the effects need no binary art. */
#include "horizon/fx.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "fx_noise.h"

static float clampf(float v, float lo, float hi)
{
    return v < lo ? lo : v > hi ? hi : v;
}

static float smooth(float e0, float e1, float x)
{
    float t = clampf((x - e0) / (e1 - e0), 0.0f, 1.0f);
    return t * t * (3 - 2 * t);
}

void hz_texgen_detail(hz_ground kind, uint32_t size, uint64_t seed64, uint8_t *rgba)
{
    const uint32_t S = size;
    const uint32_t seed = (uint32_t)(seed64 * 0x9e3779b9u) ^ (uint32_t)(kind + 1) * 0x1234567u;
    float *f = malloc((size_t)S * S * 4 * sizeof *f);
    if (!f) {
        /* Out of memory: a flat (neutral) texture still works. */
        memset(rgba, 128, (size_t)S * S * 4);
        return;
    }
    double mean[3] = {0, 0, 0};
    for (uint32_t y = 0; y < S; y++)
        for (uint32_t x = 0; x < S; x++) {
            /* Lattice coordinates: P cells across the texture, so every
             * octave (periods P, 2P, ...) tiles. */
            float u = (float)x / (float)S, v = (float)y / (float)S;
            float r = 1, g = 1, b = 1, a = 0;
            switch (kind) {
            case HZ_GROUND_GRASS: {
                float lo = fxn_fbm(u * 4, v * 4, 4, 4, seed);
                float blades = fxn_fbm(u * 32, v * 32, 3, 32, seed + 7);
                float fine = fxn_perlin(u * 96, v * 96, 96, seed + 9);
                float lum = 1.0f + 0.42f * lo + 0.34f * blades + 0.18f * fine;
                float dry = smooth(0.05f, 0.5f, fxn_fbm(u * 2, v * 2, 3, 2, seed + 3));
                r = lum * (1.0f + 0.16f * dry), g = lum * (1.0f + 0.03f * dry), b = lum * (1.0f - 0.12f * dry);
                a = 0.5f + 0.5f * lo;
                break;
            }
            case HZ_GROUND_ROCK: {
                float body = fxn_fbm(u * 4, v * 4, 6, 4, seed);
                float crack = smooth(0.0f, 0.07f, fabsf(fxn_perlin(u * 8, v * 8, 8, seed + 5)));
                float crack2 = smooth(0.0f, 0.05f, fabsf(fxn_perlin(u * 16 + 0.5f, v * 16, 16, seed + 6)));
                float lum = (1.0f + 0.35f * body) * (0.55f + 0.45f * crack) * (0.8f + 0.2f * crack2);
                float warm = fxn_fbm(u * 2, v * 2, 3, 2, seed + 11);
                r = lum * (1.0f + 0.06f * warm), g = lum, b = lum * (1.0f - 0.05f * warm);
                a = 0.5f + 0.5f * body;
                break;
            }
            case HZ_GROUND_SNOW: {
                float body = fxn_fbm(u * 4, v * 4, 5, 4, seed);
                float drift = fxn_perlin(u * 16, v * 16, 16, seed + 2);
                float lum = 1.0f + 0.2f * body + 0.06f * drift;
                float sparkle = fxn_u01(fxn_hash(x, y, seed + 1)) > 0.995f ? 0.08f : 0.0f;
                r = lum + sparkle, g = lum + sparkle, b = lum * (1.0f + 0.03f * (1.0f - body)) + sparkle;
                a = 0.5f + 0.5f * body;
                break;
            }
            case HZ_GROUND_SAND:
            default: {
                float warp = fxn_fbm(u * 2, v * 2, 3, 2, seed + 2);
                float ripple = sinf(6.2831853f * (10.0f * v + 1.5f * warp));
                float grain = fxn_u01(fxn_hash(x, y, seed + 4)) - 0.5f;
                float body = fxn_fbm(u * 4, v * 4, 4, 4, seed);
                float lum = 1.0f + 0.1f * ripple + 0.16f * grain + 0.16f * body;
                r = lum * 1.02f, g = lum, b = lum * 0.97f;
                a = 0.5f + 0.5f * body;
                break;
            }
            }
            float *p = f + 4 * ((size_t)y * S + x);
            p[0] = r, p[1] = g, p[2] = b, p[3] = a;
            mean[0] += r, mean[1] += g, mean[2] += b;
        }
    /* Each channel's mean to exactly 128: the modulation 2 x texel leaves the
     * ground colour's average alone. */
    float scale[3];
    for (int c = 0; c < 3; c++)
        scale[c] = (float)(128.0 * (double)S * (double)S / mean[c]);
    for (size_t k = 0; k < (size_t)S * S; k++) {
        for (int c = 0; c < 3; c++)
            rgba[4 * k + (size_t)c] = (uint8_t)clampf(f[4 * k + (size_t)c] * scale[c] + 0.5f, 0.0f, 255.0f);
        rgba[4 * k + 3] = (uint8_t)clampf(f[4 * k + 3] * 255.0f + 0.5f, 0.0f, 255.0f);
    }
    free(f);
}

/* ---- sprites ------------------------------------------------------------------ */

static void put(uint8_t *rgba, uint32_t w, uint32_t x, uint32_t y, float r, float g, float b, float a)
{
    uint8_t *p = rgba + 4 * ((size_t)y * w + x);
    p[0] = (uint8_t)clampf(r * 255.0f + 0.5f, 0, 255);
    p[1] = (uint8_t)clampf(g * 255.0f + 0.5f, 0, 255);
    p[2] = (uint8_t)clampf(b * 255.0f + 0.5f, 0, 255);
    p[3] = (uint8_t)clampf(a * 255.0f + 0.5f, 0, 255);
}

/* Trees: (u, v) in [0, 1], v = 0 at the top. Returns coverage in [0, 1] and
 * the colour. */
static float conifer(float u, float v, uint32_t seed, float *r, float *g, float *b)
{
    float dx = u - 0.5f;
    /* Trunk. */
    if (v > 0.86f && fabsf(dx) < 0.045f) {
        *r = 0.25f, *g = 0.17f, *b = 0.10f;
        return 1.0f;
    }
    if (v < 0.02f || v > 0.9f)
        return 0.0f;
    float t = (v - 0.02f) / 0.88f;                 /* 0 at the tip, 1 at the lowest branches */
    float tier = 0.72f + 0.28f * (t * 7.0f - floorf(t * 7.0f)); /* whorls of branches */
    float jag = 0.08f * fxn_perlin(u * 24.0f, v * 24.0f, 0, seed);
    float hw = 0.46f * powf(t, 0.9f) * tier + jag * t;
    float cov = smooth(hw + 0.02f, hw - 0.02f, fabsf(dx));
    float light = 0.75f + 0.35f * (0.5f - dx) - 0.25f * t + 0.15f * fxn_perlin(u * 40, v * 40, 0, seed + 1);
    *r = 0.09f * light, *g = 0.22f * light, *b = 0.10f * light;
    return cov;
}

static float broadleaf(float u, float v, uint32_t seed, float *r, float *g, float *b)
{
    float dx = u - 0.5f;
    if (v > 0.62f && fabsf(dx) < 0.05f + 0.03f * (v - 0.62f)) {
        *r = 0.28f, *g = 0.20f, *b = 0.12f;
        return v < 0.985f ? 1.0f : 0.0f;
    }
    /* Crown: a union of lumps, ragged by noise. */
    static const float lumps[7][3] = {{0.5f, 0.40f, 0.30f},  {0.32f, 0.48f, 0.2f}, {0.68f, 0.47f, 0.2f},
                                      {0.42f, 0.22f, 0.2f},  {0.6f, 0.24f, 0.19f}, {0.5f, 0.58f, 0.2f},
                                      {0.25f, 0.35f, 0.14f}};
    float d = 1e9f;
    for (int k = 0; k < 7; k++) {
        float ex = (u - lumps[k][0]) / lumps[k][2], ey = (v - lumps[k][1]) / lumps[k][2];
        d = fminf(d, sqrtf(ex * ex + ey * ey));
    }
    d += 0.22f * fxn_fbm(u * 10.0f, v * 10.0f, 3, 0, seed);
    float cov = smooth(1.02f, 0.94f, d);
    float light = 0.8f + 0.45f * (0.45f - v) + 0.25f * (0.5f - dx) + 0.18f * fxn_perlin(u * 30, v * 30, 0, seed + 3);
    *r = 0.15f * light, *g = 0.27f * light, *b = 0.09f * light;
    return cov;
}

void hz_texgen_sprite(hz_sprite kind, uint32_t w, uint32_t h, uint64_t seed64, uint8_t *rgba)
{
    const uint32_t seed = (uint32_t)(seed64 * 0x85ebca6bu) ^ (uint32_t)(kind + 1) * 0x27d4eb2du;
    double acc[3] = {0, 0, 0}, wsum = 0;
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            float u = ((float)x + 0.5f) / (float)w, v = ((float)y + 0.5f) / (float)h;
            float r = 1, g = 1, b = 1, a = 0;
            switch (kind) {
            case HZ_SPRITE_CONIFER: a = conifer(u, v, seed, &r, &g, &b); break;
            case HZ_SPRITE_BROADLEAF: a = broadleaf(u, v, seed, &r, &g, &b); break;
            case HZ_SPRITE_RAIN: {
                float dx = (u - 0.5f) / 0.22f;
                a = expf(-dx * dx) * sinf(3.14159265f * v);
                r = g = b = 1.0f;
                break;
            }
            case HZ_SPRITE_SNOW:
            default: {
                float dx = u - 0.5f, dy = v - 0.5f, d = sqrtf(dx * dx + dy * dy);
                a = smooth(0.5f, 0.15f, d);
                r = g = b = 1.0f;
                break;
            }
            }
            put(rgba, w, x, y, r, g, b, a);
            if (a > 0.5f) {
                acc[0] += r, acc[1] += g, acc[2] += b;
                wsum += 1;
            }
        }
    /* Transparent texels take the mean visible colour: filtering at the
     * cut-out edges then does not darken the silhouette. */
    if ((kind == HZ_SPRITE_CONIFER || kind == HZ_SPRITE_BROADLEAF) && wsum > 0)
        for (size_t k = 0; k < (size_t)w * h; k++)
            if (rgba[4 * k + 3] == 0)
                for (int c = 0; c < 3; c++)
                    rgba[4 * k + (size_t)c] = (uint8_t)clampf((float)(acc[c] / wsum) * 255.0f + 0.5f, 0, 255);
}

/* Share of texels an alpha test at 0.5 keeps with alpha scaled by k. */
static double coverage_scaled(const uint8_t *rgba, size_t n, double k)
{
    size_t kept = 0;
    for (size_t i = 0; i < n; i++)
        kept += (double)rgba[i * 4 + 3] * k >= 127.5;
    return n ? (double)kept / (double)n : 0.0;
}

double hz_sprite_coverage(const uint8_t *rgba, size_t n)
{
    return coverage_scaled(rgba, n, 1.0);
}

void hz_sprite_mip_next(const uint8_t *in, uint32_t w, uint32_t h, double cover0, uint8_t *out, uint32_t *ow,
                        uint32_t *oh)
{
    uint32_t nw = w > 1 ? w / 2 : 1, nh = h > 1 ? h / 2 : 1;
    for (uint32_t y = 0; y < nh; y++)
        for (uint32_t x = 0; x < nw; x++) {
            double acc[4] = {0, 0, 0, 0};
            int cnt = 0;
            for (uint32_t dy = 0; dy < 2; dy++)
                for (uint32_t dx = 0; dx < 2; dx++) {
                    uint32_t sx = x * 2 + dx, sy = y * 2 + dy;
                    if (sx >= w || sy >= h)
                        continue;
                    const uint8_t *p = in + ((size_t)sy * w + sx) * 4;
                    for (int c = 0; c < 3; c++)
                        acc[c] += (double)p[c] * p[3];
                    acc[3] += p[3];
                    cnt++;
                }
            uint8_t *o = out + ((size_t)y * nw + x) * 4;
            for (int c = 0; c < 3; c++)
                o[c] = (uint8_t)(acc[3] > 0 ? acc[c] / acc[3] + 0.5 : 0);
            o[3] = (uint8_t)(acc[3] / cnt + 0.5);
        }
    /* The alpha scale whose coverage comes nearest cover0: bisection for the
     * step where it crosses, then the nearer side (alpha takes few values
     * in the first levels, so coverage moves in steps). */
    const size_t n = (size_t)nw * nh;
    double lo = 0.0, hi = 1.0;
    while (hi < 256.0 && coverage_scaled(out, n, hi) < cover0)
        hi *= 2.0;
    for (int it = 0; it < 24; it++) {
        double mid = 0.5 * (lo + hi);
        if (coverage_scaled(out, n, mid) < cover0)
            lo = mid;
        else
            hi = mid;
    }
    double k = fabs(coverage_scaled(out, n, lo) - cover0) < fabs(coverage_scaled(out, n, hi) - cover0) ? lo : hi;
    for (size_t i = 0; i < n; i++)
        out[i * 4 + 3] = (uint8_t)fmin(255.0, out[i * 4 + 3] * k + 0.5);
    *ow = nw, *oh = nh;
}
