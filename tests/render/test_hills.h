/* The test terrain the render tests share: one big mountain at (2900, 2000),
 * ridged value-noise foothills and a tilt, in metres. Header-only (static):
 * each test executable compiles its own copy. */
#ifndef HZ_TEST_HILLS_H
#define HZ_TEST_HILLS_H

#include <math.h>
#include <stdint.h>

/* Deterministic value noise in [-1, 1] on a unit lattice. */
static float test_lattice(int x, int z)
{
    uint32_t h = (uint32_t)x * 374761393u + (uint32_t)z * 668265263u;
    h = (h ^ (h >> 13)) * 1274126177u;
    h ^= h >> 16;
    return (float)(h & 0xffffu) / 32767.5f - 1.0f;
}

static float test_value_noise(float x, float z)
{
    float fx = floorf(x), fz = floorf(z);
    int ix = (int)fx, iz = (int)fz;
    float tx = x - fx, tz = z - fz;
    tx = tx * tx * (3.0f - 2.0f * tx);
    tz = tz * tz * (3.0f - 2.0f * tz);
    float a = test_lattice(ix, iz), b = test_lattice(ix + 1, iz), c = test_lattice(ix, iz + 1),
          d = test_lattice(ix + 1, iz + 1);
    return (a + (b - a) * tx) + ((c + (d - c) * tx) - (a + (b - a) * tx)) * tz;
}

/* Height in metres at world (x, z). */
static float test_hills(float x, float z)
{
    const float cx = 2900.0f, cz = 2000.0f;
    float d2 = (x - cx) * (x - cx) + (z - cz) * (z - cz);
    float h = 1000.0f * expf(-d2 / (2.0f * 850.0f * 850.0f));
    float amp = 230.0f, freq = 1.0f / 900.0f;
    for (int o = 0; o < 6; o++) {
        float n = 1.0f - fabsf(test_value_noise(x * freq + 17.0f * (float)o, z * freq));
        h += amp * (n * n - 0.4f);
        amp *= 0.44f;
        freq *= 2.05f;
    }
    h -= 0.06f * z; /* land rises toward the north (away from the viewer) */
    return h + 600.0f;
}

#endif
