#version 330 core
// Tileable fractal Perlin noise computed on the GPU once (the seed found CPU
// Perlin noise too slow for large sky textures): R = 7 octaves from 4 cells,
// G = 5 octaves from 8 cells, both normalised to about [0, 1].
in vec2 v_uv;
out vec4 o_color;
uniform uint u_seed;

uint hash(uvec3 v)
{
    uint h = v.x * 0x8da6b343u ^ v.y * 0xd8163841u ^ v.z * 0xcb1ab31fu;
    h ^= h >> 15;
    h *= 0x2c1b3c6du;
    h ^= h >> 12;
    h *= 0x297a2d39u;
    h ^= h >> 15;
    return h;
}

float perlin(vec2 p, int period, uint seed)
{
    vec2 i = floor(p), f = p - i;
    float d[4];
    for (int k = 0; k < 4; k++) {
        ivec2 c = ivec2(i) + ivec2(k & 1, k >> 1);
        c = ((c % period) + period) % period;
        float a = float(hash(uvec3(uvec2(c), seed)) >> 8) * (6.2831853 / 16777216.0);
        d[k] = dot(vec2(cos(a), sin(a)), f - vec2(k & 1, k >> 1));
    }
    vec2 u = f * f * f * (f * (f * 6.0 - 15.0) + 10.0);
    return 1.41421356 * mix(mix(d[0], d[1], u.x), mix(d[2], d[3], u.x), u.y);
}

float fbm(vec2 uv, int cells, int octaves, uint seed)
{
    float s = 0.0, amp = 0.5, norm = 0.0;
    int period = cells;
    for (int o = 0; o < octaves; o++) {
        s += amp * perlin(uv * float(period), period, seed + uint(o) * 101u);
        norm += amp;
        amp *= 0.5;
        period *= 2;
    }
    return s / norm;
}

void main()
{
    float a = fbm(v_uv, 4, 7, u_seed);
    float b = fbm(v_uv, 8, 5, u_seed + 17u);
    o_color = vec4(0.5 + 0.75 * a, 0.5 + 0.75 * b, 0.0, 1.0);
}
