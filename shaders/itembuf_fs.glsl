#version 330 core
// Leaf item buffer: writes the leaf's id (0 = nothing). Layers after the
// first peel away everything at or in front of the previous layer's depth.
uniform sampler2D u_prev_depth;
uniform int u_layer;
flat in uint v_id;
in vec2 v_uv;
out uint o_id;

void main()
{
    // The leaf blade: pointed at both ends, widest in the middle (60% of the quad).
    if (abs(v_uv.y) > 0.9 * (1.0 - v_uv.x * v_uv.x))
        discard;
    if (u_layer > 0 && gl_FragCoord.z <= texelFetch(u_prev_depth, ivec2(gl_FragCoord.xy), 0).r)
        discard;
    o_id = v_id;
}
