#version 330 core
// Bark (u_hull = 0) or crown hull (1): Lambert, fog. The hull gets a leafy
// mottle from value noise so that far crowns do not look like plastic.
uniform vec3 u_color;
uniform vec3 u_sun_dir, u_sky_horizon, u_eye;
uniform float u_fog_density, u_ambient;
uniform int u_hull;
in vec3 v_world;
in vec3 v_normal;
in vec3 v_local;
out vec4 o_color;

float hash(vec3 p)
{
    return fract(sin(dot(p, vec3(12.9898, 78.233, 37.719))) * 43758.5453);
}

// Smooth value noise in [0, 1].
float vnoise(vec3 p)
{
    vec3 i = floor(p), f = fract(p);
    f = f * f * (3.0 - 2.0 * f);
    float a = mix(hash(i), hash(i + vec3(1, 0, 0)), f.x);
    float b = mix(hash(i + vec3(0, 1, 0)), hash(i + vec3(1, 1, 0)), f.x);
    float c = mix(hash(i + vec3(0, 0, 1)), hash(i + vec3(1, 0, 1)), f.x);
    float d = mix(hash(i + vec3(0, 1, 1)), hash(i + vec3(1, 1, 1)), f.x);
    return mix(mix(a, b, f.y), mix(c, d, f.y), f.z);
}

void main()
{
    vec3 n = normalize(v_normal);
    float light = max(dot(n, u_sun_dir), 0.0);
    vec3 albedo = u_color;
    if (u_hull != 0) {
        // Clumps of foliage: two octaves of noise, darker underneath, light
        // wrapped round a little as through a crown's outer leaves.
        float m = 0.6 * vnoise(v_local * 1.8) + 0.4 * vnoise(v_local * 5.5);
        albedo *= (0.35 + 0.55 * m) * (0.8 + 0.2 * n.y);
        light = 0.2 + 0.8 * light;
    }
    vec3 c = albedo * (u_ambient + (1.0 - u_ambient) * light * vec3(1.0, 0.97, 0.90));
    float f = u_fog_density > 0.0 ? exp(-u_fog_density * length(u_eye - v_world)) : 1.0;
    o_color = vec4(mix(u_sky_horizon, c, f), 1.0);
}
