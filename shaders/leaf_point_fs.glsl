#version 330 core
// Forest leaves drawn as points (leaf_point_vs.glsl): each pixel of the
// point is mapped back into the leaf's (u, v); outside the quad or the leaf
// outline it is discarded. Shading as leaf_fs.glsl, per leaf.
uniform vec3 u_color;
uniform vec3 u_sun_dir, u_sky_horizon, u_eye;
uniform float u_fog_density, u_ambient;
uniform vec2 u_dither;
flat in vec3 v_world;
flat in vec3 v_normal;
flat in float v_shade;
flat in vec2 v_center;
flat in vec4 v_inv;
out vec4 o_color;

float dither(vec2 p)
{
    return fract(52.9829189 * fract(dot(p, vec2(0.06711056, 0.00583715))));
}

void main()
{
    vec2 uv = mat2(v_inv.xy, v_inv.zw) * (gl_FragCoord.xy - v_center);
    if (abs(uv.x) > 1.0 || abs(uv.y) > 0.9 * (1.0 - uv.x * uv.x))
        discard;
    float dv = dither(gl_FragCoord.xy);
    if (dv < u_dither.x || dv >= u_dither.y)
        discard;
    vec3 n = v_normal;
    vec3 to_eye = u_eye - v_world;
    if (dot(n, to_eye) < 0.0)
        n = -n;
    float ndl = dot(n, u_sun_dir);
    float light = max(ndl, 0.0) + 0.35 * max(-ndl, 0.0);
    vec3 albedo = u_color * v_shade;
    vec3 c = albedo * (u_ambient + (1.0 - u_ambient) * light * vec3(1.0, 0.97, 0.90));
    float f = u_fog_density > 0.0 ? exp(-u_fog_density * length(to_eye)) : 1.0;
    o_color = vec4(mix(u_sky_horizon, c, f), 1.0);
}
