#version 330 core
// Terrain shading: colour by relative height and slope, sun Lambert + ambient,
// exponential fog to the sky's horizon colour.
uniform vec3 u_sun_dir;   // unit, toward the sun
uniform vec3 u_sky_horizon;
uniform vec3 u_eye;       // world metres
uniform float u_fog_density; // per metre; 0 disables
uniform float u_ambient;
uniform vec2 u_hrange;    // min, max world height of the heightmap
uniform int u_wire;       // 1: wireframe overlay pass
uniform sampler2D u_normals; // per-sample normals (x, z), bilinear: full-resolution shading
uniform int u_normal_tex;    // 1: use u_normals, 0: the interpolated vertex normal
uniform vec2 u_nrm_scale;    // uv = world.xz * x + y

in vec3 v_world;
in vec3 v_normal;
out vec4 o_color;

vec3 ground_color(float t, float slope)
{
    const vec3 lowland = vec3(0.26, 0.40, 0.16);
    const vec3 meadow  = vec3(0.42, 0.45, 0.22);
    const vec3 dirt    = vec3(0.45, 0.37, 0.26);
    const vec3 rock    = vec3(0.44, 0.41, 0.38);
    const vec3 snow    = vec3(0.93, 0.94, 0.97);

    vec3 grass = mix(lowland, meadow, smoothstep(0.05, 0.55, t));
    vec3 stone = mix(dirt, rock, smoothstep(0.2, 0.7, t));
    // slope = 1 - n.y: 0.16 ~ 33 deg, 0.32 ~ 47 deg
    vec3 c = mix(grass, stone, smoothstep(0.16, 0.32, slope));
    float snow_amt = smoothstep(0.68, 0.80, t) * (1.0 - smoothstep(0.18, 0.34, slope));
    return mix(c, snow, snow_amt);
}

void main()
{
    vec3 n;
    if (u_normal_tex != 0) {
        vec2 nxz = texture(u_normals, v_world.xz * u_nrm_scale.x + u_nrm_scale.y).rg;
        n = normalize(vec3(nxz.x, sqrt(max(1.0 - dot(nxz, nxz), 0.0)), nxz.y));
    } else {
        n = normalize(v_normal);
    }
    float range = max(u_hrange.y - u_hrange.x, 1e-6);
    float t = clamp((v_world.y - u_hrange.x) / range, 0.0, 1.0);
    vec3 albedo = ground_color(t, 1.0 - n.y);

    float lambert = max(dot(n, u_sun_dir), 0.0);
    vec3 c = albedo * (u_ambient + (1.0 - u_ambient) * lambert * vec3(1.0, 0.97, 0.90));
    if (u_wire != 0)
        c = mix(c, vec3(0.05, 0.05, 0.05), 0.7);

    float dist = length(v_world - u_eye);
    float f = u_fog_density > 0.0 ? exp(-u_fog_density * dist) : 1.0;
    o_color = vec4(mix(u_sky_horizon, c, f), 1.0);
}
