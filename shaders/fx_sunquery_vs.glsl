#version 330 core
// A small disc around the sun's screen position on the far plane, counted by
// an occlusion query: only where the depth buffer still holds the cleared
// far value (sky) do its fragments pass.
uniform vec2 u_center;  // NDC
uniform vec2 u_half;    // NDC half size
uniform float u_z;      // NDC z of the far plane
out vec2 v_q;

void main()
{
    vec2 c = vec2(float(gl_VertexID & 1), float(gl_VertexID >> 1)) * 2.0 - 1.0;
    v_q = c;
    gl_Position = vec4(u_center + c * u_half, u_z, 1.0);
}
