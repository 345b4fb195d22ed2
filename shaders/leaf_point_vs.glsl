#version 330 core
#include "curvature.glsl"
#include "leaf_shade.glsl"
// Forest leaves as points (the leaves of trees whose leaves are a few pixels
// across): one vertex per leaf instead of a quad, so a leaf costs one vertex
// and one point instead of four vertices and two triangles. The point covers
// the leaf's projected quad; the fragment shader maps each pixel back into
// the leaf's own (u, v) through the inverse of the quad's projected axes, so
// the leaf keeps its orientation, foreshortening and cut-out. The leaves are
// the same buffer leaf_vs.glsl reads, here as vertex attributes (vertex
// fetch is cheaper than buffer-texture fetches in software GL): interleaved
// by rank, a leaf beyond its node's kept count collapsed, F4 enlargement per
// node.
layout(location = 0) in vec4 a_c;  // centre, node
layout(location = 1) in vec4 a_u;  // half axis along, rank in node
layout(location = 2) in vec4 a_v;  // half axis across, shade
uniform usamplerBuffer u_kept;   // kept leaves per (tree, node), persistent
uniform samplerBuffer u_scales;  // F4 enlargement per (tree, node), persistent
uniform int u_kept_base;         // this tree's first node in u_kept; < 0: every leaf, no enlargement
uniform mat4 u_model, u_viewproj;
uniform mat4 u_mvp;              // u_viewproj * u_model
uniform vec4 u_clip_plane;
uniform vec2 u_viewport;         // pixels

flat out vec3 v_color;           // lit and fogged (leaf_shade.glsl): one colour per leaf
flat out vec2 v_center;          // window position of the leaf centre
flat out vec4 v_inv;             // pixels -> leaf (u, v): inverse of the projected axes

void collapse()
{
    v_color = vec3(0.0);
    v_center = vec2(0.0);
    v_inv = vec4(0.0);
    gl_ClipDistance[0] = -1.0;
    gl_PointSize = 1.0;
    gl_Position = vec4(2.0, 2.0, 2.0, 1.0);
}

void main()
{
    float s = 1.0;
    if (u_kept_base >= 0) {
        int node = u_kept_base + int(a_c.w);
        if (a_u.w >= float(texelFetch(u_kept, node).r)) {
            collapse();
            return;
        }
        s = texelFetch(u_scales, node).r;
    }
    vec4 w = u_model * vec4(a_c.xyz, 1.0);
    vec4 c = u_viewproj * hz_curve(w);
    vec4 du = u_mvp * vec4(s * a_u.xyz, 0.0);
    vec4 dv = u_mvp * vec4(s * a_v.xyz, 0.0);
    if (c.w <= 1e-3) {
        collapse();
        return;
    }
    // Projected half axes in pixels (the projection linearised at the centre).
    vec2 ndc = c.xy / c.w;
    vec2 hv = 0.5 * u_viewport;
    vec2 pu = hv * (du.xy - ndc * du.w) / c.w;
    vec2 pv = hv * (dv.xy - ndc * dv.w) / c.w;
    float det = pu.x * pv.y - pu.y * pv.x;
    if (abs(det) < 1e-4) { // edge on: covers no pixel
        collapse();
        return;
    }
    v_inv = vec4(pv.y, -pu.y, -pv.x, pu.x) / det; // column-major mat2 inverse
    vec2 ext = abs(pu) + abs(pv);
    gl_PointSize = 2.0 * max(ext.x, ext.y) + 1.0;
    v_center = (ndc * 0.5 + 0.5) * u_viewport;
    v_color = leaf_lit(normalize(mat3(u_model) * cross(a_u.xyz, a_v.xyz)), w.xyz, a_v.w).rgb;
    gl_ClipDistance[0] = dot(u_clip_plane, w);
    gl_Position = c;
}
