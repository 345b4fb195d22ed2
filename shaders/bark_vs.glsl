#version 330 core
#include "curvature.glsl"
// Bark and crown hulls (bark_fs.glsl). Per vertex: the world normal (bark),
// where the point projects in the impostor view the hull is shaded from
// (linear in the position, so interpolating it is exact) and the fog.
layout(location = 0) in vec3 a_pos;
layout(location = 1) in vec3 a_normal;
uniform mat4 u_model, u_viewproj;
uniform vec4 u_clip_plane;
uniform vec3 u_eye;
uniform float u_fog_density;
uniform vec3 u_right, u_up;      // hulls: the view's image axes, model space
uniform vec4 u_bound;            // hulls: model-space bounding sphere (image frame)
out vec3 v_normal;
out vec2 v_q;                    // hulls: [0, 1]^2 across the view's image
out float v_fog;

void main()
{
    vec4 w = u_model * vec4(a_pos, 1.0);
    v_normal = normalize(mat3(u_model) * a_normal);
    vec3 d = a_pos - u_bound.xyz;
    v_q = vec2(dot(d, u_right), dot(d, u_up)) / max(u_bound.w, 1e-6) * 0.5 + 0.5;
    v_fog = u_fog_density > 0.0 ? exp(-u_fog_density * length(u_eye - w.xyz)) : 1.0;
    gl_ClipDistance[0] = dot(u_clip_plane, w);
    gl_Position = u_viewproj * hz_curve(w);
}
