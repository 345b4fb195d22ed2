#version 450 core
#include "curvature.glsl"
// Scene objects (buildings, models): merged static vertices, one world
// matrix and material colour per instance (per-instance attributes;
// baseInstance picks them).
// Lit per vertex (Lambert from the sun plus a sky term): back faces are
// culled, and building faces are flat.
layout(location = 0) in vec3 a_pos;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in mat4 a_world;
layout(location = 6) in vec3 a_color; // the material's colour, per instance
uniform mat4 u_viewproj;
uniform vec4 u_clip_plane;
uniform vec3 u_sun_dir;
uniform float u_ambient;
uniform vec3 u_eye;
uniform float u_fog_density;
out vec3 v_world;
out vec3 v_normal;
flat out vec3 v_color;
out vec2 v_light; // the sky's share and the sun's (before shade); per vertex: exact on flat faces
out float v_fog;  // the exponential fog's factor, per vertex as the terrain's (object_fs.glsl)

void main()
{
    vec4 w = a_world * vec4(a_pos, 1.0);
    v_world = w.xyz;
    v_color = a_color;
    vec3 n = normalize(mat3(a_world) * a_normal);
    v_normal = n;
    v_light = vec2(u_ambient * (0.6 + 0.4 * (0.5 + 0.5 * n.y)), (1.0 - u_ambient) * max(dot(n, u_sun_dir), 0.0));
    v_fog = exp(-u_fog_density * length(w.xyz - u_eye));
    gl_ClipDistance[0] = dot(u_clip_plane, w);
    gl_Position = u_viewproj * hz_curve(w);
}
