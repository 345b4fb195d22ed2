/* Private helpers of the foliage module. */
#ifndef HZ_FOLIAGE_INTERNAL_H
#define HZ_FOLIAGE_INTERNAL_H

#include <math.h>
#include <stdint.h>

/* splitmix64: small, seeded, repeatable. */
typedef struct hz_rng {
    uint64_t s;
} hz_rng;

static inline uint64_t rng_next(hz_rng *r)
{
    uint64_t z = (r->s += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

/* Uniform in [0, 1). */
static inline float rng_unit(hz_rng *r)
{
    return (float)(rng_next(r) >> 40) / 16777216.0f;
}

/* Uniform in [-1, 1). */
static inline float rng_sym(hz_rng *r)
{
    return 2.0f * rng_unit(r) - 1.0f;
}

static inline void v3_set(float *d, float x, float y, float z)
{
    d[0] = x, d[1] = y, d[2] = z;
}
static inline void v3_copy(float *d, const float *a)
{
    d[0] = a[0], d[1] = a[1], d[2] = a[2];
}
static inline void v3_add(float *d, const float *a, const float *b)
{
    d[0] = a[0] + b[0], d[1] = a[1] + b[1], d[2] = a[2] + b[2];
}
static inline void v3_sub(float *d, const float *a, const float *b)
{
    d[0] = a[0] - b[0], d[1] = a[1] - b[1], d[2] = a[2] - b[2];
}
static inline void v3_scale(float *d, const float *a, float s)
{
    d[0] = a[0] * s, d[1] = a[1] * s, d[2] = a[2] * s;
}
static inline void v3_madd(float *d, const float *a, const float *b, float s)
{
    d[0] = a[0] + b[0] * s, d[1] = a[1] + b[1] * s, d[2] = a[2] + b[2] * s;
}
static inline float v3_dot(const float *a, const float *b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
static inline void v3_cross(float *d, const float *a, const float *b)
{
    float x = a[1] * b[2] - a[2] * b[1], y = a[2] * b[0] - a[0] * b[2], z = a[0] * b[1] - a[1] * b[0];
    d[0] = x, d[1] = y, d[2] = z;
}
static inline float v3_len(const float *a)
{
    return sqrtf(v3_dot(a, a));
}
static inline void v3_norm(float *d)
{
    float l = v3_len(d);
    if (l > 0.0f)
        v3_scale(d, d, 1.0f / l);
}
static inline float v3_dist(const float *a, const float *b)
{
    float d[3];
    v3_sub(d, a, b);
    return v3_len(d);
}
/* Rotates v about unit axis k by angle a (radians), Rodrigues. */
static inline void v3_rotate(float *d, const float *v, const float *k, float a)
{
    float c = cosf(a), s = sinf(a), kxv[3], kv = v3_dot(k, v), r[3];
    v3_cross(kxv, k, v);
    for (int i = 0; i < 3; i++)
        r[i] = v[i] * c + kxv[i] * s + k[i] * kv * (1.0f - c);
    v3_copy(d, r);
}
/* Some unit vector perpendicular to unit a. */
static inline void v3_perp(float *d, const float *a)
{
    float t[3] = {0, 1, 0};
    if (fabsf(a[1]) > 0.9f)
        v3_set(t, 1, 0, 0);
    v3_cross(d, a, t);
    v3_norm(d);
}

#endif
