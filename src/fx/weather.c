/* Rain and snow particles: a closed-form particle field around the eye. */
#include "horizon/fx.h"

#include <math.h>

#include "fx_noise.h"

static float radius_of(const hz_weather_desc *d)
{
    return d->radius > 0.0f ? d->radius : 35.0f;
}

size_t hz_weather_bound(const hz_weather_desc *d)
{
    if (!d)
        return 0;
    float in = d->intensity > 0.0f ? d->intensity : 1.0f;
    in = in > 8.0f ? 8.0f : in;
    float base = d->kind == HZ_WEATHER_SNOW ? 5000.0f : 6000.0f;
    float r = radius_of(d) / 35.0f;
    return (size_t)(base * in * r * r * r);
}

static double wrap(double v, double period)
{
    double m = fmod(v, period);
    return m < 0 ? m + period : m;
}

size_t hz_weather_build(const hz_weather_desc *d, const vec3 eye, double t, hz_billboard *out, size_t cap)
{
    size_t n = hz_weather_bound(d);
    n = n < cap ? n : cap;
    const bool snow = d->kind == HZ_WEATHER_SNOW;
    const double R = radius_of(d), box_h = snow ? R : 1.2 * R;
    /* Box origin: the eye at the centre of the box. */
    const double ox = eye[0] - R, oy = eye[1] - 0.5 * box_h, oz = eye[2] - R;
    const uint32_t seed = (uint32_t)(d->seed * 0x9e3779b9u) ^ (snow ? 0x5a0du : 0x4a1du);
    for (size_t k = 0; k < n; k++) {
        uint32_t h0 = fxn_hash((uint32_t)k, 0, seed), h1 = fxn_hash((uint32_t)k, 1, seed);
        uint32_t h2 = fxn_hash((uint32_t)k, 2, seed), h3 = fxn_hash((uint32_t)k, 3, seed);
        double fall = snow ? 0.7 + 0.6 * fxn_u01(h3) : 6.5 + 2.5 * fxn_u01(h3);
        double vx = d->wind[0], vz = d->wind[1];
        /* World-space position on its line; the box around the eye wraps it. */
        double px = fxn_u01(h0) * 2 * R + vx * t, py = fxn_u01(h1) * box_h - fall * t, pz = fxn_u01(h2) * 2 * R + vz * t;
        if (snow) {
            double ph = 6.2831853 * fxn_u01(h3 ^ 0x9u), w = 0.8 + 0.6 * fxn_u01(h0 ^ 0x3u);
            px += 0.35 * sin(w * t + ph);
            pz += 0.35 * cos(0.9 * w * t + 1.7 * ph);
        }
        /* Fixed world lattice of boxes, so particles do not move with the eye:
         * a particle's copy nearest the eye is the one in the box. */
        double x = ox + wrap(px - ox, 2 * R), y = oy + wrap(py - oy, box_h), z = oz + wrap(pz - oz, 2 * R);
        hz_billboard *b = &out[k];
        b->pos[0] = (float)x, b->pos[1] = (float)y, b->pos[2] = (float)z;
        b->texture = d->texture;
        b->flags = HZ_BB_BLEND;
        if (snow) {
            float s = 0.025f + 0.03f * fxn_u01(h1 ^ 0x77u);
            b->width = b->height = s;
            b->axis[0] = b->axis[1] = b->axis[2] = 0.0f;
            b->flags |= HZ_BB_FACING;
            b->rgba = 0xe6ffffffu; /* white, alpha 0.9 */
        } else {
            /* A streak: how far the drop moves while the shutter is open. */
            const float shutter = 0.045f;
            b->axis[0] = (float)(-vx) * shutter;
            b->axis[1] = (float)fall * shutter;
            b->axis[2] = (float)(-vz) * shutter;
            b->width = 0.012f;
            b->height = 0.0f;
            b->rgba = 0x78e6dcd2u; /* pale blue-grey, alpha 0.47 */
        }
    }
    return n;
}
