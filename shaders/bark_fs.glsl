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

void main()
{
    vec3 n = normalize(v_normal);
    float light = max(dot(n, u_sun_dir), 0.0);
    vec3 albedo = u_color;
    if (u_hull != 0) {
        float m = hash(floor(v_local * 3.0));
        albedo *= 0.7 + 0.5 * m;
        light = 0.25 + 0.75 * light;
    }
    vec3 c = albedo * (u_ambient + (1.0 - u_ambient) * light * vec3(1.0, 0.97, 0.90));
    float f = u_fog_density > 0.0 ? exp(-u_fog_density * length(u_eye - v_world)) : 1.0;
    o_color = vec4(mix(u_sky_horizon, c, f), 1.0);
}
