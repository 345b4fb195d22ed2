#version 330 core
#include "leaf_dither.glsl"
// Forest leaves drawn as points (leaf_point_vs.glsl): each pixel of the
// point is mapped back into the leaf's (u, v); outside the quad or the leaf
// outline it is discarded. The colour is the leaf's, lit in the vertex
// shader.
flat in vec3 v_color;
flat in vec2 v_center;
flat in vec4 v_inv;
out vec4 o_color;

void main()
{
    vec2 uv = mat2(v_inv.xy, v_inv.zw) * (gl_FragCoord.xy - v_center);
    if (abs(uv.x) > 1.0 || abs(uv.y) > 0.9 * (1.0 - uv.x * uv.x) || leaf_dithered_out())
        discard;
    o_color = vec4(v_color, 1.0);
}
