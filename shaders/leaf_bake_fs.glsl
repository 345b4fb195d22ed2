#version 330 core
// Impostor bake of the leaves: albedo (the leaf colour with its tint and
// crown occlusion, unlit) and the model-space normal facing the viewer.
uniform vec3 u_color;
uniform vec3 u_eye;              // model space, far along the view direction
in vec3 v_world;
in vec3 v_normal;
in vec2 v_uv;
flat in float v_shade;
layout(location = 0) out vec4 o_albedo;
layout(location = 1) out vec4 o_normal;

void main()
{
    if (abs(v_uv.y) > 0.9 * (1.0 - v_uv.x * v_uv.x))
        discard;
    vec3 n = normalize(v_normal);
    if (dot(n, u_eye - v_world) < 0.0)
        n = -n;
    o_albedo = vec4(u_color * v_shade, 1.0);
    o_normal = vec4(n * 0.5 + 0.5, 1.0);
}
