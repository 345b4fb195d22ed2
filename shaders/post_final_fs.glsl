#version 330 core
// Last pass of the chain: adds bloom, then exposure and gamma (R8):
// out = (c x exposure)^(1 / gamma), clamped to [0, 1].
uniform sampler2D u_scene, u_bloom;
uniform sampler2D u_depth;      // the scene's depth, copied to the output's
uniform int u_has_bloom;
uniform float u_bloom_strength, u_exposure, u_gamma;
in vec2 v_uv;
out vec4 o_color;

void main()
{
    vec3 c = texture(u_scene, v_uv).rgb;
    if (u_has_bloom != 0)
        c += u_bloom_strength * texture(u_bloom, v_uv).rgb;
    c = pow(max(c * u_exposure, vec3(0.0)), vec3(1.0 / u_gamma));
    o_color = vec4(clamp(c, 0.0, 1.0), 1.0);
#if defined(FX_VARIANT) && FX_VARIANT == 1
    gl_FragDepth = texture(u_depth, v_uv).r; // into a window's depth buffer
#endif
}
