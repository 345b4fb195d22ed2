#version 330 core
#include "curvature.glsl"
// Bark and crown hulls: a mesh with positions and normals, one tree per draw.
layout(location = 0) in vec3 a_pos;
layout(location = 1) in vec3 a_normal;
uniform mat4 u_model, u_viewproj;
uniform vec4 u_clip_plane;
out vec3 v_world;
out vec3 v_normal;
out vec3 v_local;

void main()
{
    vec4 w = u_model * vec4(a_pos, 1.0);
    v_world = w.xyz;
    v_local = a_pos;
    v_normal = normalize(mat3(u_model) * a_normal);
    gl_ClipDistance[0] = dot(u_clip_plane, w);
    gl_Position = u_viewproj * hz_curve(w);
}
