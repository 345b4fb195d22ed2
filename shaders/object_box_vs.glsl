#version 450 core
#include "curvature.glsl"
// Occlusion query proxies: an object's world box (unit cube corners mixed
// between u_min and u_max), drawn with colour and depth writes off.
layout(location = 0) in vec3 a_pos;
uniform mat4 u_viewproj;
uniform vec3 u_min, u_max;

void main()
{
    gl_Position = u_viewproj * vec4(hz_curve(mix(u_min, u_max, a_pos)), 1.0);
}
