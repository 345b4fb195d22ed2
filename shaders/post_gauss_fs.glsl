#version 330 core
// Bloom, step 2: separable Gaussian (9 taps in 5 linear fetches).
uniform sampler2D u_src;
uniform vec2 u_step;      // one texel along the blur direction
in vec2 v_uv;
out vec4 o_color;

void main()
{
    const float w0 = 0.2270270270, w1 = 0.3162162162, w2 = 0.0702702703;
    const float o1 = 1.3846153846, o2 = 3.2307692308;
    vec3 c = texture(u_src, v_uv).rgb * w0;
    c += (texture(u_src, v_uv + u_step * o1).rgb + texture(u_src, v_uv - u_step * o1).rgb) * w1;
    c += (texture(u_src, v_uv + u_step * o2).rgb + texture(u_src, v_uv - u_step * o2).rgb) * w2;
    o_color = vec4(c, 1.0);
}
