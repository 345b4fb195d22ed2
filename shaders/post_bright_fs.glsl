#version 330 core
// Bloom, step 1: what is brighter than the threshold, at half resolution
// (4 taps, so no bright pixel is skipped).
uniform sampler2D u_src;
uniform vec2 u_texel;     // source texel size
uniform float u_threshold;
in vec2 v_uv;
out vec4 o_color;

void main()
{
    vec3 c = vec3(0.0);
    for (int k = 0; k < 4; k++) {
        vec3 s = texture(u_src, v_uv + (vec2(k & 1, k >> 1) - 0.5) * u_texel).rgb;
        // The chain is 8-bit: what passes the threshold counts up to white.
        float m = max(max(s.r, s.g), s.b);
        c += s * smoothstep(u_threshold, 1.0, m);
    }
    o_color = vec4(c * 0.25, 1.0);
}
