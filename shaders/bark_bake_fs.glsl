#version 330 core
// Impostor bake of the bark: albedo and the model-space normal.
uniform vec3 u_color;
in vec3 v_world;
in vec3 v_normal;
in vec3 v_local;
layout(location = 0) out vec4 o_albedo;
layout(location = 1) out vec4 o_normal;

void main()
{
    o_albedo = vec4(u_color, 1.0);
    o_normal = vec4(normalize(v_normal) * 0.5 + 0.5, 1.0);
}
