#version 330 core
#include "curvature.glsl"
// A water plane (R9): a rectangle at a fixed height, four vertices (strip).
uniform vec4 u_rect;     // x0, z0, x1, z1 world metres
uniform float u_level;   // world metres
uniform mat4 u_viewproj;
uniform int u_grid;      // 0: one quad (a strip of 4 vertices); N: N x N cells of 6 vertices
                         // (Earth curvature), spaced quadratically out from the eye so that
                         // the flat cells follow the sphere within the same angle everywhere
out vec3 v_world;

// Grid line t in [0, 1] of the axis [a, b], dense at e (the eye, clamped).
float grid_at(float t, float a, float b, float e)
{
    float s = 2.0 * t - 1.0;
    return e + (s < 0.0 ? a - e : b - e) * s * s;
}

// Size of the larger of the two cells along an axis at grid line g.
float cell_at(int g, float a, float b, float e)
{
    float n = float(u_grid), x = grid_at(float(g) / n, a, b, e);
    float lo = grid_at(float(max(g - 1, 0)) / n, a, b, e), hi = grid_at(float(min(g + 1, u_grid)) / n, a, b, e);
    return max(x - lo, hi - x);
}

void main()
{
    vec2 c;
    float lift = 0.0;
    if (u_grid == 0) {
        c = vec2(float(gl_VertexID & 1), float(gl_VertexID >> 1));
        v_world = vec3(mix(u_rect.x, u_rect.z, c.x), u_level, mix(u_rect.y, u_rect.w, c.y));
    } else {
        const ivec2 corner[6] = ivec2[6](ivec2(0, 0), ivec2(1, 0), ivec2(0, 1), ivec2(0, 1), ivec2(1, 0), ivec2(1, 1));
        int cell = gl_VertexID / 6;
        ivec2 g = ivec2(cell % u_grid, cell / u_grid) + corner[gl_VertexID % 6];
        vec2 e = clamp(hz_curv.xy, u_rect.xy, u_rect.zw);
        vec2 t = vec2(g) / float(u_grid);
        v_world = vec3(grid_at(t.x, u_rect.x, u_rect.z, e.x), u_level, grid_at(t.y, u_rect.y, u_rect.w, e.y));
        // A flat cell is a chord under the curved surface, by up to k (its
        // half-diagonal)^2: lifted by that, the water never dips under ground
        // drawn at the level (a DEM's sea is flat fill 0.1 m below it).
        float lx = cell_at(g.x, u_rect.x, u_rect.z, e.x), lz = cell_at(g.y, u_rect.y, u_rect.w, e.y);
        lift = hz_curv.z * 0.25 * (lx * lx + lz * lz);
    }
    gl_Position = u_viewproj * vec4(hz_curve(v_world) + vec3(0.0, lift, 0.0), 1.0);
}
