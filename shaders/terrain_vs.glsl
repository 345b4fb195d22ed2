#version 330 core
// Vertex-less terrain: gl_VertexID is the sample index into the row-major
// grid (index = j * size + i); the height comes from an R16 texture buffer.
uniform samplerBuffer u_heights; // GL_R16, normalised: value * 65535 = h16
uniform int u_size;              // samples per side
uniform float u_spacing;         // metres between samples
uniform float u_hscale;          // metres per h16 step, times zscale
uniform float u_hoffset;         // metres at h16 = 0, times zscale
uniform mat4 u_viewproj;         // reverse-Z projection * view
uniform vec3 u_eye;              // world metres
// cdlod geomorphing (hz_lod_morph_height does the same on the CPU):
uniform samplerBuffer u_morph;   // GL_R16: per-sample morph error in h16 steps, 65535 = never
uniform float u_morph_scale;     // metres of range per step; 0 = no morphing
uniform float u_morph_start;     // morphing starts at this fraction of the range

out vec3 v_world;
out vec3 v_normal;

float height_at(int i, int j)
{
    float h16 = floor(texelFetch(u_heights, j * u_size + i).r * 65535.0 + 0.5);
    return u_hoffset + u_hscale * h16;
}

// Lowest set bit; "infinite" for 0 (a map edge row/column at index 0).
int low_bit(int v)
{
    return v == 0 ? (1 << 30) : (v & -v);
}

// The height this vertex collapses to on the coarser level: the midpoint of
// its two neighbours at its own level's spacing.
float morph_target(int i, int j)
{
    int bi = low_bit(i), bj = low_bit(j);
    if (bi == bj) {
        // a child's centre: on the parent's diagonal (parent centre <-> corner)
        int s = bi, ps = 2 * s;
        int pcx = (i / (2 * ps)) * (2 * ps) + ps, pcz = (j / (2 * ps)) * (2 * ps) + ps;
        int dx = pcx > i ? 1 : -1, dz = pcz > j ? 1 : -1;
        return 0.5 * (height_at(i + dx * s, j + dz * s) + height_at(i - dx * s, j - dz * s));
    }
    if (bi < bj)
        return 0.5 * (height_at(i - bi, j) + height_at(i + bi, j));
    return 0.5 * (height_at(i, j - bj) + height_at(i, j + bj));
}

void main()
{
    int id = gl_VertexID;
    int i = id % u_size;
    int j = id / u_size;
    float y = height_at(i, j);
    vec3 true_pos = vec3(float(i) * u_spacing, y, float(j) * u_spacing);
    if (u_morph_scale > 0.0) {
        float q = floor(texelFetch(u_morph, id).r * 65535.0 + 0.5);
        if (q < 65535.0) {
            float R = u_morph_scale * q;
            float m = 1.0;
            if (R > 0.0)
                m = clamp((distance(true_pos, u_eye) - u_morph_start * R) / ((1.0 - u_morph_start) * R), 0.0, 1.0);
            if (m > 0.0)
                y = mix(y, morph_target(i, j), m);
        }
    }

    // Central differences, one-sided at the borders (clamped neighbours).
    int il = max(i - 1, 0), ir = min(i + 1, u_size - 1);
    int jd = max(j - 1, 0), ju = min(j + 1, u_size - 1);
    float dx = (height_at(ir, j) - height_at(il, j)) / (float(ir - il) * u_spacing);
    float dz = (height_at(i, ju) - height_at(i, jd)) / (float(ju - jd) * u_spacing);
    v_normal = normalize(vec3(-dx, 1.0, -dz));

    v_world = vec3(float(i) * u_spacing, y, float(j) * u_spacing);
    gl_Position = u_viewproj * vec4(v_world, 1.0);
}
