#version 330 core
#include "curvature.glsl"
// Vertex-less terrain for the index-list LOD modes (cdlod draws patches:
// terrain_patch_vs.glsl): gl_VertexID is the sample index into the row-major
// grid (index = j * size + i); the height comes from an R16 texture buffer.
uniform samplerBuffer u_heights; // GL_R16, normalised: value * 65535 = h16
uniform int u_size;              // samples per side
uniform float u_spacing;         // metres between samples
uniform float u_hscale;          // metres per h16 step, times zscale
uniform float u_hoffset;         // metres at h16 = 0, times zscale
uniform mat4 u_viewproj;         // reverse-Z projection * view
uniform float u_fog_density;     // per metre; 0 disables
uniform vec3 u_eye;              // world metres

out vec3 v_world;
out vec3 v_normal;
out float v_fog;   // the plain fog's factor (terrain_fs.glsl): per vertex, smooth enough

float height_at(int i, int j)
{
    float h16 = floor(texelFetch(u_heights, j * u_size + i).r * 65535.0 + 0.5);
    return u_hoffset + u_hscale * h16;
}

void main()
{
    int id = gl_VertexID;
    int i = id % u_size;
    int j = id / u_size;
    float y = height_at(i, j);
    // Central differences, one-sided at the borders (clamped neighbours).
    int il = max(i - 1, 0), ir = min(i + 1, u_size - 1);
    int jd = max(j - 1, 0), ju = min(j + 1, u_size - 1);
    float dx = (height_at(ir, j) - height_at(il, j)) / (float(ir - il) * u_spacing);
    float dz = (height_at(i, ju) - height_at(i, jd)) / (float(ju - jd) * u_spacing);
    v_normal = normalize(vec3(-dx, 1.0, -dz));

    v_world = vec3(float(i) * u_spacing, y, float(j) * u_spacing);
    v_fog = exp(-u_fog_density * length(v_world - u_eye));
    gl_Position = u_viewproj * vec4(hz_curve(v_world), 1.0);
}
