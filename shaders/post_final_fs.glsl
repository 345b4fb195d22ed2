#version 330 core
// Last pass of the chain: adds bloom, then exposure and gamma (R8):
// out = (c x exposure)^(1 / gamma), clamped to [0, 1].
// Variants (FX_VARIANT, fx_post.c): 1 copies the scene depth (windows),
// 2 adds bloom, 4 applies a gamma other than 1. Compiled in, not switched by
// uniforms: llvmpipe runs both sides of a branch, and a pow per channel of
// every pixel costs 1-2 ms at 1280x720.
#ifndef FX_VARIANT
#define FX_VARIANT 0
#endif
uniform sampler2D u_scene, u_bloom;
uniform sampler2D u_depth;      // the scene's depth, copied to the output's
uniform float u_bloom_strength, u_exposure, u_gamma;
in vec2 v_uv;
out vec4 o_color;

void main()
{
    vec3 c = texture(u_scene, v_uv).rgb;
#if (FX_VARIANT & 2) != 0
    c += u_bloom_strength * texture(u_bloom, v_uv).rgb;
#endif
    c = max(c * u_exposure, vec3(0.0));
#if (FX_VARIANT & 4) != 0
    c = pow(c, vec3(1.0 / u_gamma));
#endif
    o_color = vec4(clamp(c, 0.0, 1.0), 1.0);
#if (FX_VARIANT & 1) != 0
    gl_FragDepth = texture(u_depth, v_uv).r; // into a window's depth buffer
#endif
}
