#version 330 core
#include "leaf_shade.glsl"
// Forest leaves drawn as points (leaf_point_vs.glsl): each pixel of the
// point is mapped back into the leaf's (u, v); outside the quad or the leaf
// outline it is discarded. Lit and fogged as the quads (leaf_shade.glsl),
// per leaf.
flat in vec3 v_world;
flat in vec3 v_normal;
flat in float v_shade;
flat in vec2 v_center;
flat in vec4 v_inv;
out vec4 o_color;

void main()
{
    vec2 uv = mat2(v_inv.xy, v_inv.zw) * (gl_FragCoord.xy - v_center);
    if (abs(uv.x) > 1.0 || abs(uv.y) > 0.9 * (1.0 - uv.x * uv.x) || leaf_dithered_out())
        discard;
    o_color = leaf_lit(v_normal, v_world, v_shade);
}
