/* Small deterministic noise for the effects' CPU parts (private). */
#ifndef HZ_FX_NOISE_H
#define HZ_FX_NOISE_H

#include <math.h>
#include <stdint.h>

static inline uint32_t fxn_hash(uint32_t x, uint32_t y, uint32_t s)
{
    uint32_t h = x * 0x8da6b343u ^ y * 0xd8163841u ^ s * 0xcb1ab31fu;
    h ^= h >> 15;
    h *= 0x2c1b3c6du;
    h ^= h >> 12;
    h *= 0x297a2d39u;
    h ^= h >> 15;
    return h;
}

/* Uniform in [0, 1). */
static inline float fxn_u01(uint32_t h)
{
    return (float)(h >> 8) * (1.0f / 16777216.0f);
}

static inline int fxn_wrap(int v, int period)
{
    if (period <= 0)
        return v;
    v %= period;
    return v < 0 ? v + period : v;
}

/* 2D gradient (Perlin) noise in about [-1, 1]; tileable with the given
 * integer period on the lattice (0: none). */
static inline float fxn_perlin(float x, float y, int period, uint32_t seed)
{
    float fx = floorf(x), fy = floorf(y);
    int ix = (int)fx, iy = (int)fy;
    float tx = x - fx, ty = y - fy;
    float d[4];
    for (int k = 0; k < 4; k++) {
        int cx = ix + (k & 1), cy = iy + (k >> 1);
        uint32_t h = fxn_hash((uint32_t)fxn_wrap(cx, period), (uint32_t)fxn_wrap(cy, period), seed);
        float a = fxn_u01(h) * 6.2831853f;
        d[k] = cosf(a) * (tx - (float)(k & 1)) + sinf(a) * (ty - (float)(k >> 1));
    }
    float ux = tx * tx * tx * (tx * (tx * 6 - 15) + 10), uy = ty * ty * ty * (ty * (ty * 6 - 15) + 10);
    float a = d[0] + (d[1] - d[0]) * ux, b = d[2] + (d[3] - d[2]) * ux;
    return 1.41421356f * (a + (b - a) * uy);
}

/* Fractal sum of `oct` octaves; each octave doubles the frequency (and the period). */
static inline float fxn_fbm(float x, float y, int oct, int period, uint32_t seed)
{
    float s = 0, amp = 0.5f, norm = 0;
    for (int o = 0; o < oct; o++) {
        s += amp * fxn_perlin(x, y, period, seed + (uint32_t)o * 101u);
        norm += amp;
        x *= 2, y *= 2;
        period *= 2;
        amp *= 0.5f;
    }
    return s / norm;
}

#endif
