#version 330 core
// Leaf item buffer: leaf ids for VMI ranking (tile mode), and of the whole
// tree for its visibility and precision / recall (camera mode 2).
// Vertex-less: 6 vertices per leaf, gl_VertexID / 6 = leaf.
uniform samplerBuffer u_leaves; // 3 texels per leaf: (c, node), (u, 0), (v, 0)
uniform samplerBuffer u_nodes;  // tile mode, 2 texels per node slot: (centre, radius), (tile x, y, first leaf, 0)
uniform samplerBuffer u_scales; // camera mode: F4 enlargement per node
uniform int u_mode;             // 0 tiles, 2 camera
uniform int u_slot_base;        // tile mode: node index of slot 0
uniform mat4 u_viewproj;        // camera mode
uniform vec3 u_right, u_up, u_fwd; // tile mode view basis (fwd: away from the viewer)
uniform vec2 u_atlas;           // atlas size, pixels
uniform float u_tile;           // tile size, pixels

flat out uint v_id;
out vec2 v_uv;

const vec2 corners[6] = vec2[6](vec2(-1, -1), vec2(1, -1), vec2(1, 1), vec2(-1, -1), vec2(1, 1), vec2(-1, 1));

void main()
{
    int leaf = gl_VertexID / 6;
    vec2 k = corners[gl_VertexID % 6];
    vec4 t0 = texelFetch(u_leaves, leaf * 3);
    vec3 u = texelFetch(u_leaves, leaf * 3 + 1).xyz;
    vec3 v = texelFetch(u_leaves, leaf * 3 + 2).xyz;
    int node = int(t0.w);
    v_uv = k;
    if (u_mode == 0) {
        int slot = node - u_slot_base;
        vec4 n0 = texelFetch(u_nodes, slot * 2);
        vec4 n1 = texelFetch(u_nodes, slot * 2 + 1);
        vec3 q = (t0.xyz + k.x * u + k.y * v - n0.xyz) / n0.w;
        vec2 xy = vec2(dot(q, u_right), dot(q, u_up)) * 0.5 + 0.5;
        vec2 px = n1.xy + xy * u_tile;
        gl_Position = vec4(px / u_atlas * 2.0 - 1.0, dot(q, u_fwd) * 0.999, 1.0);
        v_id = uint(leaf - int(n1.z)) + 1u;
    } else {
        float s = texelFetch(u_scales, node).r;
        gl_Position = u_viewproj * vec4(t0.xyz + s * (k.x * u + k.y * v), 1.0);
        v_id = uint(leaf) + 1u;
    }
}
