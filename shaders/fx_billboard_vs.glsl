#version 330 core
#include "curvature.glsl"
// Billboards (R3), pulled from a texture buffer: billboard b = u_first +
// gl_VertexID / 6 is three texels (pos.xyz, width), (axis.xyz, height),
// (rgba tint); gl_VertexID % 6 picks a corner of its two triangles. (One
// plain draw per batch: llvmpipe runs instanced draws per instance, which
// costs far more for thousands of small quads.) Axial billboards turn about
// their axis toward the eye (trees, rain streaks), facing ones turn fully
// toward the camera (snow).
uniform samplerBuffer u_bb;
uniform int u_first;
uniform int u_facing;               // 1: camera-facing batch
uniform int u_blend;                // 1: blended batch
uniform mat4 u_viewproj;
uniform vec3 u_cam_right, u_cam_up; // world-space camera axes (facing billboards)
uniform float u_px_per_m;           // pixels per metre at 1 m distance (viewport height / (2 tan(fov / 2)))
uniform sampler2D u_lightmap;

out vec2 v_uv;
out vec4 v_tint;
out vec3 v_world;
out float v_light;

void main()
{
    int b = u_first + gl_VertexID / 6;
    int k = gl_VertexID % 6;
    const vec2 corners[6] = vec2[6](vec2(0, 0), vec2(1, 0), vec2(0, 1), vec2(0, 1), vec2(1, 0), vec2(1, 1));
    vec2 c = corners[k];
    vec4 t0 = texelFetch(u_bb, 3 * b), t1 = texelFetch(u_bb, 3 * b + 1), t2 = texelFetch(u_bb, 3 * b + 2);
    vec3 pos = t0.xyz, axis = t1.xyz;
    float width = t0.w, height = t1.w;
    bool blend = u_blend != 0;
    vec3 eye = fx_eye.xyz;
    float alpha = 1.0;
    vec3 p;
    if (u_facing != 0) {
        float w = width, h = height;
        float px = w * u_px_per_m / max(length(pos - eye), 1e-3);
        if (blend && px < 1.5) { // thinner than a pixel and a half: wider and fainter, no shimmer
            alpha = px / 1.5;
            w *= 1.5 / px;
            h *= 1.5 / px;
        }
        p = pos + u_cam_right * (c.x - 0.5) * w + u_cam_up * (c.y - 0.5) * h;
    } else {
        float len = length(axis);
        vec3 u = axis / max(len, 1e-6);
        vec3 right = cross(u, eye - (pos + 0.5 * axis));
        float rl = length(right);
        right = rl > 1e-6 ? right / rl : u_cam_right;
        float w = width;
        if (blend) {
            float px = w * u_px_per_m / max(length(pos - eye), 1e-3);
            if (px < 1.2) {
                alpha = px / 1.2;
                w *= 1.2 / px;
            }
        }
        p = pos + right * (c.x - 0.5) * w + axis * c.y;
    }
    v_uv = vec2(c.x, 1.0 - c.y); // sprite rows are top first
    v_tint = vec4(t2.rgb, t2.a * alpha);
    v_world = p;
    float Ie = fx_sun_color.w;
    if (!blend && fx_on(FX_SHADOWS) && fx_lm.z > 0.0)
        v_light = textureLod(u_lightmap, fx_lightmap_uv(pos.xz), 0.0).r; // the ground's light at the foot
    else
        v_light = Ie + (1.0 - Ie) * clamp(fx_sun.y * 1.5, 0.0, 1.0) * 0.85;
    gl_Position = u_viewproj * vec4(hz_curve(p), 1.0);
}
