#version 330 core
// Far trees: the baked albedo (premultiplied by coverage through the mips)
// and model-space normal, lit like the leaves and fogged at the tree's
// distance (one value per tree, set in the vertex shader); dithered in over
// the fade band.
uniform sampler2DArray u_albedo, u_normals;
uniform vec3 u_sky_horizon;
uniform float u_ambient;
flat in vec3 v_to_eye;
flat in float v_fog;
in vec2 v_uv;
flat in float v_layer;
flat in float v_fade;
flat in vec3 v_sun_m;
flat in int v_lod;
flat in vec2 v_size;
out vec4 o_color;

float dither(vec2 p)
{
    return fract(52.9829189 * fract(dot(p, vec2(0.06711056, 0.00583715))));
}

void main()
{
    // One texel of the level that matches the screen size (no filtering:
    // software GL pays per texel).
    ivec3 uv = ivec3(ivec2(min(v_uv * v_size, v_size - 1.0)), int(v_layer));
    vec4 a = texelFetch(u_albedo, uv, v_lod);
    if (a.a < 0.5 || dither(gl_FragCoord.xy) >= v_fade)
        discard;
    vec4 nn = texelFetch(u_normals, uv, v_lod);
    vec3 n = normalize(nn.rgb / max(nn.a, 1e-3) * 2.0 - 1.0); // model space, as the sun and eye
    if (dot(n, v_to_eye) < 0.0)
        n = -n;
    float ndl = dot(n, v_sun_m);
    float light = max(ndl, 0.0) + 0.35 * max(-ndl, 0.0);
    vec3 col = a.rgb / a.a * (u_ambient + (1.0 - u_ambient) * light * vec3(1.0, 0.97, 0.90));
    o_color = vec4(mix(u_sky_horizon, col, v_fog), 1.0);
}
