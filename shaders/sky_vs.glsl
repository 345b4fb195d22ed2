#version 330 core
// Sky: one full-screen triangle (no vertex buffer). Each corner carries the
// world-space view ray, which is linear in screen space, so the fragment
// shader gets the exact per-pixel direction.
uniform mat4 u_inv_viewproj_rot; // inverse(proj * view-without-translation)
uniform float u_sky_z;           // NDC z: 0 (unset) = the far plane with glClipControl's [0, 1] depth

out vec3 v_dir;

void main()
{
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2)) * 2.0 - 1.0;
    vec4 w = u_inv_viewproj_rot * vec4(p, 0.5, 1.0);
    v_dir = w.xyz / w.w;
    // The far plane in reverse-Z: the sky is drawn after the terrain, where
    // the depth is still far.
    gl_Position = vec4(p, u_sky_z, 1.0);
}
