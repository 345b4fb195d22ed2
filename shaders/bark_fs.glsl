#version 330 core
// Bark (BARK_HULL 0) or crown hull (1), Lambert and fog (per vertex). The hull is shaded
// from the tree's own impostor: each fragment looks up the baked view
// nearest the eye (albedo with alpha, model-space normal) where it projects,
// so the hull reads as the same foliage as the impostor and the leaves, with
// the hull's depth; transparent texels are holes. Two programs, not a
// uniform: llvmpipe runs both sides of a branch under a mask, and every bark
// fragment would pay the hull's two filtered fetches.
#ifndef BARK_HULL
#define BARK_HULL 0
#endif
uniform vec3 u_color;
uniform vec3 u_sun_dir, u_sky_horizon;
uniform float u_ambient;
uniform vec3 u_tree_eye;         // hulls: unit, from the tree toward the eye, model space
uniform vec3 u_sun_model;        // hulls: the sun, model space
uniform vec2 u_dither;           // keep pixels whose dither value is in [x, y)
uniform sampler2DArray u_albedo, u_normals;
uniform float u_layer;           // the model's atlas layer
uniform vec4 u_tile;             // atlas uv of the view's tile: offset xy, size zw
uniform int u_lod;               // atlas level for the hull's size on screen
uniform vec2 u_size;             // atlas size in texels at that level
in vec3 v_normal;
in vec2 v_q;
in float v_fog;
out vec4 o_color;

float dither(vec2 p)
{
    return fract(52.9829189 * fract(dot(p, vec2(0.06711056, 0.00583715))));
}

void main()
{
    float dv = dither(gl_FragCoord.xy);
    if (dv < u_dither.x || dv >= u_dither.y)
        discard;
    vec3 albedo = u_color;
    float light;
#if BARK_HULL
    {
        // Filtered: a hull is seen nearer than its bounding centre, often
        // with several pixels per texel, where single texels show as blocks.
        vec3 uv = vec3(u_tile.xy + clamp(v_q, 0.0, 1.0) * u_tile.zw, u_layer);
        vec4 a = textureLod(u_albedo, uv, float(u_lod));
        if (a.a < 0.5)
            discard;
        vec4 nn = textureLod(u_normals, uv, float(u_lod));
        albedo = a.rgb / a.a;
        vec3 n = normalize(nn.rgb / max(nn.a, 1e-3) * 2.0 - 1.0); // model space, as u_tree_eye, u_sun_model
        if (dot(n, u_tree_eye) < 0.0)
            n = -n;
        float ndl = dot(n, u_sun_model);
        light = max(ndl, 0.0) + 0.35 * max(-ndl, 0.0);
    }
#else
    light = max(dot(normalize(v_normal), u_sun_dir), 0.0);
#endif
    vec3 c = albedo * (u_ambient + (1.0 - u_ambient) * light * vec3(1.0, 0.97, 0.90));
    o_color = vec4(mix(u_sky_horizon, c, v_fog), 1.0);
}
