#version 330 core
#include "leaf_shade.glsl"
#include "leaf_dither.glsl"
// Forest leaves as quads: the leaf-shaped cut-out of the quad, lit and
// fogged (leaf_shade.glsl).
in vec3 v_world;
in vec3 v_normal;
in vec2 v_uv;
flat in float v_shade;
out vec4 o_color;

void main()
{
    if (abs(v_uv.y) > 0.9 * (1.0 - v_uv.x * v_uv.x) || leaf_dithered_out())
        discard;
    o_color = leaf_lit(normalize(v_normal), v_world, v_shade);
}
