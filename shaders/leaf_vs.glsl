#version 330 core
// Forest leaves: vertex-less, gl_VertexID / 6 = leaf (the per-frame index list
// holds the kept prefix of every node), F4 enlargement about the leaf centre.
uniform samplerBuffer u_leaves;  // 3 texels per leaf: (c, node), (u, 0), (v, 0)
uniform samplerBuffer u_scales;  // per (tree, node) enlargement, this frame
uniform int u_scale_base;
uniform mat4 u_model, u_viewproj;
uniform vec4 u_clip_plane;
uniform vec4 u_crown;            // model-space crown centre, radius

out vec3 v_world;
out vec3 v_normal;
out vec2 v_uv;
out float v_ao;
flat out float v_tint;

const vec2 corners[6] = vec2[6](vec2(-1, -1), vec2(1, -1), vec2(1, 1), vec2(-1, -1), vec2(1, 1), vec2(-1, 1));

void main()
{
    int leaf = gl_VertexID / 6;
    vec2 k = corners[gl_VertexID % 6];
    vec4 t0 = texelFetch(u_leaves, leaf * 3);
    vec3 u = texelFetch(u_leaves, leaf * 3 + 1).xyz;
    vec3 v = texelFetch(u_leaves, leaf * 3 + 2).xyz;
    float s = texelFetch(u_scales, u_scale_base + int(t0.w)).r;
    vec3 p = t0.xyz + s * (k.x * u + k.y * v);
    vec4 w = u_model * vec4(p, 1.0);
    v_world = w.xyz;
    v_normal = normalize(mat3(u_model) * cross(u, v));
    v_uv = k;
    // Darker toward the inside of the crown: a cheap stand-in for occlusion.
    v_ao = 0.45 + 0.55 * clamp(length(t0.xyz - u_crown.xyz) / u_crown.w, 0.0, 1.0);
    v_tint = fract(sin(float(leaf) * 12.9898) * 43758.5453);
    gl_ClipDistance[0] = dot(u_clip_plane, w);
    gl_Position = u_viewproj * w;
}
