// Earth curvature, shared by every shader that draws world geometry (inserted
// by src/render/embed_shaders.cmake where a shader says #include "curvature.glsl").
// A world point is drawn lowered by d^2 / 2R, d its horizontal distance from
// the eye (hz_curvature_drop in include/horizon/camera.h is the CPU twin that
// the LOD bounds, culling, picking and metrics use). Set per program by
// hz_gl_set_curvature; the default 0 is a flat world.
uniform vec3 hz_curv; // xy: eye world x, z (metres); z: 1 / (2 R) per metre, 0 = flat

vec3 hz_curve(vec3 p)
{
    vec2 d = p.xz - hz_curv.xy;
    return vec3(p.x, p.y - hz_curv.z * dot(d, d), p.z);
}

vec4 hz_curve(vec4 p) // homogeneous world points with w = 1
{
    return vec4(hz_curve(p.xyz), p.w);
}
