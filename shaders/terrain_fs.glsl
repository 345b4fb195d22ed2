#version 330 core
// Terrain shading: colour by relative height and slope, sun Lambert + ambient,
// exponential fog to the sky's horizon colour. With effects (fx_bits.x):
// ground detail splatting (R4), the light map with shadows (R5), height fog
// and the far fade (R6), water-plane clipping for reflections (R9).
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

uniform sampler2D u_lightmap;       // R8: I = cos(r)(1 - Ie) + Ie, or Ie in shadow
uniform sampler2D u_detail;         // luminance detail per type, mean 0.5: R grass, G rock, B snow, A sand
uniform sampler2D u_colormap;       // optional user colour map over the whole terrain
uniform sampler2D u_cover;          // forest cover (R), 1 = forest

in vec3 v_world;
in vec3 v_normal;
in float v_valid;
out vec4 o_color;

const vec3 lowland = vec3(0.26, 0.40, 0.16);
const vec3 meadow  = vec3(0.42, 0.45, 0.22);
const vec3 dirt    = vec3(0.45, 0.37, 0.26);
const vec3 rock    = vec3(0.44, 0.41, 0.38);
const vec3 snow    = vec3(0.93, 0.94, 0.97);
const vec3 sand    = vec3(0.62, 0.56, 0.42);

vec3 ground_color(float t, float slope)
{
    vec3 grass = mix(lowland, meadow, smoothstep(0.05, 0.55, t));
    vec3 stone = mix(dirt, rock, smoothstep(0.2, 0.7, t));
    // slope = 1 - n.y: 0.16 ~ 33 deg, 0.32 ~ 47 deg
    vec3 c = mix(grass, stone, smoothstep(0.16, 0.32, slope));
    float snow_amt = smoothstep(0.68, 0.80, t) * (1.0 - smoothstep(0.18, 0.34, slope));
    return mix(c, snow, snow_amt);
}

// Splatting: per-type weights from height and slope (the same classes as the
// colour). The detail of all four types comes from one packed texture at two
// rotated scales 4.37 apart, mixed by a slow noise, so no repeat shows; the
// types blend by weight plus their detail as a height, so they interlock.
// Three texture fetches in all.
vec3 splat(vec3 albedo, float t, float slope, float dist)
{
    vec2 xz = v_world.xz;
    float s = fx_map.z;
    const mat2 r1 = mat2(0.8660, 0.5, -0.5, 0.8660), r2 = mat2(0.2588, -0.9659, 0.9659, 0.2588);
    float macro = texture(u_detail, xz / (s * 97.3)).r;
    vec4 d = mix(texture(u_detail, r1 * xz / s), texture(u_detail, r2 * xz / (s * 4.37)), 0.35 + 0.3 * macro) * 2.0;
    float w_rock = smoothstep(0.16, 0.32, slope);
    float w_snow = smoothstep(0.68, 0.80, t) * (1.0 - smoothstep(0.18, 0.34, slope));
    float w_sand = fx_on(FX_WATER) ? 1.0 - smoothstep(fx_map.y + 1.0, fx_map.y + 5.0, v_world.y) : 0.0;
    vec4 w = vec4((1.0 - w_rock) * (1.0 - w_snow), w_rock * (1.0 - w_snow), w_snow, 0.0);
    w = mix(w, vec4(0.0, 0.0, 0.0, 1.0), w_sand * (1.0 - w_snow));
    vec4 present = step(vec4(0.01), w);
    vec4 b = (w + 0.5 * (d - 1.0)) * present;
    float best = max(max(b.x, b.y), max(b.z, b.w));
    vec4 a = max(b - best + 0.25, 0.0) * present;
    float m = dot(a, d) / max(dot(a, vec4(1.0)), 1e-4);
    // Sand is a colour of its own, the others modulate the class colour.
    albedo = mix(albedo, sand, w_sand * (1.0 - w_snow));
    // Fade the detail with distance (its mean is 1): no shimmer far away.
    float k = 1.0 - smoothstep(s * 150.0, s * 900.0, dist);
    // A very slow brightness variation breaks uniform far colour.
    float far_var = 0.92 + 0.16 * macro;
    return albedo * mix(1.0, m, k) * far_var;
}

void main()
{
    // Below a water plane in its reflection pass. Only that variant may
    // discard: a shader that can discard loses llvmpipe's early depth test.
    if (FX_CLIP_PASS && fx_bits.y != 0 && dot(fx_clip, vec4(v_world, 1.0)) < 0.0)
        discard;
    // cdlod over missing data (only that variant discards): a triangle with a
    // vertex without data interpolates below 1 everywhere but at its corners.
    if (FX_MASKED && v_valid < 0.999)
        discard;
    vec3 n;
    if (u_normal_tex != 0) {
        vec2 nxz = texture(u_normals, v_world.xz * u_nrm_scale.x + u_nrm_scale.y).rg;
        n = normalize(vec3(nxz.x, sqrt(max(1.0 - dot(nxz, nxz), 0.0)), nxz.y));
    } else {
        n = normalize(v_normal);
    }
    float range = max(u_hrange.y - u_hrange.x, 1e-6);
    float t = clamp((v_world.y - u_hrange.x) / range, 0.0, 1.0);
    float dist = length(v_world - u_eye);
    vec3 albedo = ground_color(t, 1.0 - n.y);
    vec2 uv = v_world.xz / max(fx_map.x, 1e-6);
    if (FX_HAS_COLORMAP)
        albedo = texture(u_colormap, uv).rgb;
    if (FX_ENABLED != 0) {
        if (fx_on(FX_DETAIL))
            albedo = splat(albedo, t, 1.0 - n.y, dist);
        if (fx_on(FX_BILLBOARDS) && FX_HAS_COVER) {
            // Forest floor and canopy seen from afar: darker, bluer green.
            float cover = texture(u_cover, uv).r;
            albedo = mix(albedo, vec3(0.10, 0.17, 0.08), 0.7 * cover);
        }
    }

    vec3 c;
    if (fx_on(FX_SHADOWS) && fx_lm.z > 0.0) {
        // The seed's light map, multiplied into the ground colour.
        c = albedo * texture(u_lightmap, fx_lightmap_uv(v_world.xz)).r;
    } else {
        float lambert = max(dot(n, u_sun_dir), 0.0);
        c = albedo * (u_ambient + (1.0 - u_ambient) * lambert * vec3(1.0, 0.97, 0.90));
    }
    if (u_wire != 0)
        c = mix(c, vec3(0.05, 0.05, 0.05), 0.7);

    if (FX_ENABLED != 0) {
        o_color = vec4(fx_fogged(c, v_world), 1.0);
        return;
    }
    float f = u_fog_density > 0.0 ? exp(-u_fog_density * dist) : 1.0;
    o_color = vec4(mix(u_sky_horizon, c, f), 1.0);
}
