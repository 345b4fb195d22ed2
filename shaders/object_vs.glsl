#version 450 core
#include "curvature.glsl"
// Scene objects (buildings, models): merged static vertices, one world
// matrix per instance (per-instance attributes; baseInstance picks them).
layout(location = 0) in vec3 a_pos;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in mat4 a_world;
uniform mat4 u_viewproj;
uniform vec4 u_clip_plane;
out vec3 v_world;
out vec3 v_normal;

void main()
{
    vec4 w = a_world * vec4(a_pos, 1.0);
    v_world = w.xyz;
    v_normal = mat3(a_world) * a_normal;
    gl_ClipDistance[0] = dot(u_clip_plane, w);
    gl_Position = u_viewproj * hz_curve(w);
}
