#version 330 core
#include "curvature.glsl"
// Far trees: one draw, 6 vertices per tree of the frame's list (nearest
// first, so the early depth test spares hidden ones); a tree short of the
// impostor distance band is collapsed outside the clip volume. The quad faces the eye at the tree's
// bounding centre and shows the baked view nearest the direction it is seen
// from (azimuth ring x elevation rows of the model's atlas layer).
uniform samplerBuffer u_trees;   // 2 texels per tree: (pos, yaw), (scale, model, 0, 0)
uniform samplerBuffer u_models;  // 1 texel per model: bounding centre (model space), radius
uniform usamplerBuffer u_order;  // this frame's impostor trees, nearest first
uniform mat4 u_viewproj;
uniform vec4 u_clip_plane;
uniform vec3 u_eye;
uniform vec3 u_sun_dir;
uniform float u_fog_density;
uniform vec2 u_band;             // distance band over which impostors fade in
uniform float u_max_dist;
uniform ivec2 u_views;           // azimuths, elevations
uniform float u_el_step;         // radians between elevation rows
uniform samplerBuffer u_rects;   // per (model, view): the image's extent in the tile, [-1, 1]^2
uniform float u_px_scale;        // pixels per unit of (size / distance) on screen
uniform int u_tile_px;           // texels across a tile at level 0
uniform int u_max_lod;

flat out vec3 v_to_eye;          // unit, from the tree toward the eye, model space
flat out float v_fog;            // exponential fog at the tree's distance
out vec2 v_uv;
flat out float v_layer;
flat out float v_fade;
flat out vec3 v_sun_m;           // the sun, in the tree's model space (where the normals are)
flat out int v_lod;              // atlas level: about one texel per pixel
flat out vec2 v_size;            // atlas size in texels at that level

const vec2 corners[6] = vec2[6](vec2(-1, -1), vec2(1, -1), vec2(1, 1), vec2(-1, -1), vec2(1, 1), vec2(-1, 1));

void main()
{
    int tree = int(texelFetch(u_order, gl_VertexID / 6).r);
    vec2 k = corners[gl_VertexID % 6];
    vec4 a = texelFetch(u_trees, tree * 2);
    vec4 b = texelFetch(u_trees, tree * 2 + 1);
    vec4 bs = texelFetch(u_models, int(b.y));
    float c = cos(a.w), s = sin(a.w), sc = b.x;
    // world = pos + sc * R(yaw) * p, R columns (c,0,-s), (0,1,0), (s,0,c)
    vec3 ctr = a.xyz + sc * vec3(c * bs.x + s * bs.z, bs.y, -s * bs.x + c * bs.z);
    vec3 to_eye = u_eye - ctr;
    float dist = length(to_eye);
    float fade = clamp((dist - u_band.x) / max(u_band.y - u_band.x, 1e-3), 0.0, 1.0);
    v_sun_m = vec3(c * u_sun_dir.x - s * u_sun_dir.z, u_sun_dir.y, s * u_sun_dir.x + c * u_sun_dir.z);
    v_lod = 0;
    v_size = vec2(1.0);
    v_fade = fade;
    v_layer = b.y;
    if (fade <= 0.0 || dist > u_max_dist) {
        v_to_eye = vec3(0.0, 1.0, 0.0);
        v_fog = 1.0;
        v_uv = vec2(0.0);
        gl_ClipDistance[0] = -1.0;
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);
        return;
    }
    vec3 dm = to_eye / dist;
    dm = vec3(c * dm.x - s * dm.z, dm.y, s * dm.x + c * dm.z); // to model space
    float az = atan(dm.x, dm.z), el = asin(clamp(dm.y, -1.0, 1.0));
    int ia = int(floor(az / 6.2831853 * float(u_views.x) + 0.5));
    ia = ((ia % u_views.x) + u_views.x) % u_views.x;
    int ie = clamp(int(floor(el / u_el_step + 0.5)), 0, u_views.y - 1);
    vec3 fwd = -to_eye / dist;
    vec3 right = normalize(cross(fwd, vec3(0.0, 1.0, 0.0)));
    vec3 up = cross(right, fwd);
    vec4 r = texelFetch(u_rects, int(b.y) * u_views.x * u_views.y + ie * u_views.x + ia);
    vec2 q = vec2(k.x < 0.0 ? r.x : r.z, k.y < 0.0 ? r.y : r.w);
    vec3 w = ctr + sc * bs.w * (q.x * right + q.y * up);
    v_to_eye = dm;
    v_fog = u_fog_density > 0.0 ? exp(-u_fog_density * dist) : 1.0;
    v_uv = (vec2(float(ia), float(ie)) + (q * 0.5 + 0.5)) / vec2(u_views);
    float px = 2.0 * sc * bs.w / dist * u_px_scale; // pixels across the tile on screen
    v_lod = clamp(int(floor(log2(max(float(u_tile_px) / max(px, 1e-3), 1.0)) + 0.5)), 0, u_max_lod);
    v_size = vec2(u_views * (u_tile_px >> v_lod));
    gl_ClipDistance[0] = dot(u_clip_plane, vec4(w, 1.0));
    gl_Position = u_viewproj * vec4(hz_curve(w), 1.0);
}
