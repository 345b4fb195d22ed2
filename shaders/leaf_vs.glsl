#version 330 core
#include "curvature.glsl"
// Forest leaves: vertex-less. The model's leaves are stored interleaved by
// rank (every node's kept leaves lie in one prefix); a static quad index
// buffer gives 4 vertices per leaf (gl_VertexID / 4 = leaf). A leaf beyond
// its node's kept count this frame is collapsed outside the clip volume, so
// an unchanged node costs neither CPU nor upload. F4 enlargement about the
// leaf centre, by the coverage the node's prefix lost (set on the CPU).
uniform samplerBuffer u_leaves;  // 3 texels per leaf: (c, node), (u, rank in node), (v, shade)
uniform usamplerBuffer u_kept;   // kept leaves per (tree, node), persistent
uniform samplerBuffer u_scales;  // F4 enlargement per (tree, node), persistent
uniform int u_kept_base;         // this tree's first node in u_kept; < 0: every leaf, no enlargement
uniform mat4 u_model, u_viewproj;
uniform vec4 u_clip_plane;

out vec3 v_world;
out vec3 v_normal;
out vec2 v_uv;
flat out float v_shade;

const vec2 corners[4] = vec2[4](vec2(-1, -1), vec2(1, -1), vec2(1, 1), vec2(-1, 1));

void main()
{
    int leaf = gl_VertexID >> 2;
    vec2 k = corners[gl_VertexID & 3];
    vec4 t0 = texelFetch(u_leaves, leaf * 3);
    vec4 t1 = texelFetch(u_leaves, leaf * 3 + 1);
    float s = 1.0;
    if (u_kept_base >= 0) {
        float kept = float(texelFetch(u_kept, u_kept_base + int(t0.w)).r);
        if (t1.w >= kept) {
            v_world = vec3(0.0);
            v_normal = vec3(0.0, 1.0, 0.0);
            v_uv = vec2(0.0);
            v_shade = 0.0;
            gl_ClipDistance[0] = -1.0;
            gl_Position = vec4(2.0, 2.0, 2.0, 1.0);
            return;
        }
        s = texelFetch(u_scales, u_kept_base + int(t0.w)).r;
    }
    vec4 t2 = texelFetch(u_leaves, leaf * 3 + 2);
    vec3 u = t1.xyz, v = t2.xyz;
    vec3 p = t0.xyz + s * (k.x * u + k.y * v);
    vec4 w = u_model * vec4(p, 1.0);
    v_world = w.xyz;
    v_normal = normalize(mat3(u_model) * cross(u, v));
    v_uv = k;
    // Per leaf, set at upload: its tint times the crown occlusion.
    v_shade = t2.w;
    gl_ClipDistance[0] = dot(u_clip_plane, w);
    gl_Position = u_viewproj * hz_curve(w);
}
