#version 330 core
// Terrain shading: colour by absolute height (the climate's snow and tree
// lines), aridity and slope, sun Lambert + ambient,
// exponential fog to the sky's horizon colour. With effects (fx_bits.x):
// ground detail splatting (R4), the light map with shadows (R5), height fog
// and the far fade (R6), water-plane clipping for reflections (R9).
// Without effects, colour map or imagery (FX_LIT) the colour comes lit
// from the lit map, baked from the same shading (terrain_lit_fs.glsl).
#include "ground_color.glsl"
uniform vec3 u_sky_horizon;
uniform vec3 u_eye;       // world metres
uniform vec2 u_hrange;    // min, max world height of the heightmap
uniform int u_wire;       // 1: wireframe overlay pass
uniform float u_water_mask; // alpha 0 below this world height (under the water), 1 above (-1e30: none)
uniform sampler2D u_normals; // per-sample normals (x, z), bilinear: full-resolution shading
uniform int u_normal_tex;    // 1: use u_normals, 0: the interpolated vertex normal
uniform vec2 u_nrm_scale;    // uv = world.xz * x + y
uniform sampler2D u_lit;     // FX_LIT: the lit colour per sample, as u_normals (src/render/terrain_litmap.c)

uniform sampler2D u_lightmap;       // R8: I = cos(r)(1 - Ie) + Ie, or Ie in shadow
uniform sampler2D u_detail;         // luminance detail per type, mean 0.5: R grass, G rock, B snow, A sand
uniform sampler2D u_colormap;       // optional user colour map over the whole terrain
uniform sampler2D u_cover;          // forest cover (R), 1 = forest
uniform sampler2D u_img_ov;         // draped imagery: the overview of the whole footprint (RGBA)
uniform sampler2DArray u_img_tiles; // draped imagery: tiles with a border of their neighbours' texels
uniform vec4 u_img_map;             // uv = (world.xz - xy) * z over the footprint; w = tiles per side (0: none)
uniform vec2 u_img_tile;            // texels per tile (border excluded), border texels

in vec3 v_world;
in vec3 v_normal;
in float v_fog;
#ifdef FX_VLIT
in vec3 v_lit; // --lit-map vertex: the lit colour interpolated from the vertices
#endif
out vec4 o_color;

// Desert sand (not the shore's) by aridity.
float desert_weight(float slope)
{
    return smoothstep(0.6, 0.95, u_climate.z) * (1.0 - smoothstep(0.16, 0.32, slope));
}

// Splatting: per-type weights from height and slope (the same classes as the
// colour). The detail of all four types comes from one packed texture at two
// rotated scales 4.37 apart, mixed by a slow noise, so no repeat shows; the
// types blend by weight plus their detail as a height, so they interlock.
// Three texture fetches in all.
vec3 splat(vec3 albedo, float slope, float dist)
{
    vec2 xz = v_world.xz;
    float s = fx_map.z;
    const mat2 r1 = mat2(0.8660, 0.5, -0.5, 0.8660), r2 = mat2(0.2588, -0.9659, 0.9659, 0.2588);
    float macro = texture(u_detail, xz / (s * 97.3)).r;
    // A very slow brightness variation breaks uniform far colour.
    float far_var = 0.92 + 0.16 * macro;
    float w_snow = snow_weight(v_world.y, slope);
    float w_sand = fx_on(FX_WATER) ? 1.0 - smoothstep(fx_map.y + 1.0, fx_map.y + 5.0, v_world.y) : 0.0;
    float w_desert = desert_weight(slope);
    if (FX_DETAIL_FAR) {
        // Patches entirely beyond the fade (the renderer picks them): the
        // same colour without the detail's fetches, which llvmpipe would
        // run for every pixel even behind a branch.
        albedo = mix(albedo, sand, w_sand * (1.0 - w_snow) * (1.0 - w_desert));
        return albedo * far_var;
    }
    vec4 d = mix(texture(u_detail, r1 * xz / s), texture(u_detail, r2 * xz / (s * 4.37)), 0.35 + 0.3 * macro) * 2.0;
    float w_rock = smoothstep(0.16, 0.32, slope);
    vec4 w = vec4((1.0 - w_rock) * (1.0 - w_snow), w_rock * (1.0 - w_snow), w_snow, 0.0);
    w = mix(w, vec4(0.0, 0.0, 0.0, 1.0), max(w_sand, w_desert) * (1.0 - w_snow));
    vec4 present = step(vec4(0.01), w);
    vec4 b = (w + 0.5 * (d - 1.0)) * present;
    float best = max(max(b.x, b.y), max(b.z, b.w));
    vec4 a = max(b - best + 0.25, 0.0) * present;
    float m = dot(a, d) / max(dot(a, vec4(1.0)), 1e-4);
    // Sand is a colour of its own, the others modulate the class colour.
    albedo = mix(albedo, sand, w_sand * (1.0 - w_snow) * (1.0 - w_desert));
    // Fade the detail with distance (its mean is 1): no shimmer far away.
    // (FX_DETAIL_FADE_NEAR and _FAR in render_internal.h.)
    float k = 1.0 - smoothstep(s * 150.0, s * 900.0, dist);
    return albedo * mix(1.0, m, k) * far_var;
}

// Draped imagery (alpha 0 where the image has no data). Near: the tile
// under the point, filtered with its own first mip levels (its border makes
// them seamless); from where those run out (a texel under 1/4 pixel), the
// overview, a quarter the resolution with all its levels. Derivatives are
// taken before any branch.
vec4 imagery(vec2 xz)
{
    vec2 uv = (xz - u_img_map.xy) * u_img_map.z;
    vec2 duvx = dFdx(uv), duvy = dFdy(uv);
    vec4 ov = textureGrad(u_img_ov, uv, duvx, duvy);
    float n = u_img_map.w;
    if (n > 0.0) {
        float C = u_img_tile.x, B = u_img_tile.y, L = C + 2.0 * B;
        vec2 t = uv * n * C; // texels over the whole image
        vec2 dx = duvx * n * C, dy = duvy * n * C;
        float lod = 0.5 * log2(max(max(dot(dx, dx), dot(dy, dy)), 1e-12));
        if (lod < 2.0) {
            vec2 ti = clamp(floor(t / C), vec2(0.0), vec2(n - 1.0));
            vec2 local = (t - ti * C + B) / L;
            vec4 fine = textureGrad(u_img_tiles, vec3(local, ti.y * n + ti.x), dx / L, dy / L);
            ov = mix(fine, ov, smoothstep(1.5, 2.0, lod));
        }
    }
    bool inside = all(greaterThanEqual(uv, vec2(0.0))) && all(lessThanEqual(uv, vec2(1.0)));
    return inside ? ov : vec4(0.0);
}

// The wireframe overlay pass darkens the shaded colour.
vec3 wired(vec3 c)
{
    return u_wire != 0 ? mix(c, vec3(0.05, 0.05, 0.05), 0.7) : c;
}

// Without effects: exponential fog to the sky's horizon colour, its factor
// from the vertices (it varies slowly over a triangle).
vec3 plain_fog(vec3 c)
{
    return mix(u_sky_horizon, c, v_fog);
}

void main()
{
    // Below a water plane in its reflection pass. Only that variant may
    // discard: a shader that can discard loses llvmpipe's early depth test.
    if (FX_CLIP_PASS && fx_bits.y != 0 && dot(fx_clip, vec4(v_world, 1.0)) < 0.0)
        discard;
    // Alpha: whether this ground stands above the water (a sea shows where
    // it does not: fx_water_draw). Only the water effect sets a mask: the
    // other variants compile the test out (llvmpipe would run it per pixel).
    float above = fx_on(FX_WATER) && v_world.y < u_water_mask ? 0.0 : 1.0;
    if (FX_LIT) {
        // Trilinear like the normal map: far pixels read the lit colour
        // averaged over what they cover.
#ifdef FX_VLIT
        vec3 lit = v_lit;
#else
        vec3 lit = texture(u_lit, v_world.xz * u_nrm_scale.x + u_nrm_scale.y).rgb;
#endif
        o_color = vec4(plain_fog(wired(lit)), above);
        return;
    }
    vec3 n;
    if (u_normal_tex != 0) {
        n = ground_normal(texture(u_normals, v_world.xz * u_nrm_scale.x + u_nrm_scale.y).rg);
    } else {
        n = normalize(v_normal);
    }
    float dist = length(v_world - u_eye);
    vec3 albedo = ground_color(v_world.y, 1.0 - n.y);
    vec2 uv = v_world.xz / max(fx_map.x, 1e-6);
    if (FX_HAS_COLORMAP)
        albedo = texture(u_colormap, uv).rgb;
    float photo = 0.0; // how much of the colour is draped imagery
    if (FX_HAS_IMAGERY) {
        vec4 img = imagery(v_world.xz);
        photo = img.a;
        albedo = mix(albedo, img.rgb, photo);
    }
    if (FX_ENABLED != 0 && photo < 1.0) {
        if (fx_on(FX_DETAIL))
            albedo = splat(albedo, 1.0 - n.y, dist);
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
        c = ground_lit(albedo, n);
    }
    // A photo carries its own light: relight it relative to flat ground, so
    // the relief still reads but a level field keeps the photo's colour.
    if (photo > 0.0) {
        float flat_light = u_ambient + (1.0 - u_ambient) * max(u_sun_dir.y, 0.0);
        float lambert = max(dot(n, u_sun_dir), 0.0);
        float rel = (u_ambient + (1.0 - u_ambient) * lambert) / max(flat_light, 0.05);
        c = mix(c, albedo * mix(1.0, rel, 0.6), photo);
    }
    c = wired(c);
    if (FX_ENABLED != 0) {
        o_color = vec4(fx_fogged(c, v_world), above);
        return;
    }
    o_color = vec4(plain_fog(c), above);
}
