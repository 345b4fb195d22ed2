#version 330 core
#include "curvature.glsl"
// A water plane (R9): a rectangle at a fixed height, four vertices (strip).
uniform vec4 u_rect;     // x0, z0, x1, z1 world metres
uniform float u_level;   // world metres
uniform mat4 u_viewproj;
out vec3 v_world;

void main()
{
    vec2 c = vec2(float(gl_VertexID & 1), float(gl_VertexID >> 1));
    v_world = vec3(mix(u_rect.x, u_rect.z, c.x), u_level, mix(u_rect.y, u_rect.w, c.y));
    gl_Position = u_viewproj * vec4(hz_curve(v_world), 1.0);
}
