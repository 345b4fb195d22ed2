#version 330 core
// Sky: a grid of SKY_COLS x SKY_ROWS screen cells above the horizon (no
// vertex buffer; six vertices a cell). Each vertex shades the sky in its
// view ray's direction (world space, linear in screen space); the cells
// interpolate it. The colour is smooth in the direction (the narrowest
// feature, the sun's glow, is about 8 degrees wide at half height, against
// cells of 1-2 degrees), so llvmpipe shades a few thousand vertices instead
// of every sky pixel.
uniform mat4 u_inv_viewproj_rot; // inverse(proj * view-without-translation)
uniform float u_sky_z;           // NDC z: 0 (unset) = the far plane with glClipControl's [0, 1] depth
uniform vec3 u_sky_horizon;      // = fog colour
uniform vec3 u_sky_zenith;       // deeper colour straight up
uniform vec3 u_sun_dir;          // unit, toward the sun

const int SKY_COLS = 48, SKY_ROWS = 27; // the renderer draws 6 SKY_COLS SKY_ROWS vertices

out vec3 v_color;

vec3 sky_color(vec3 dir)
{
    vec3 d = normalize(dir);
    float up = max(d.y, 0.0);
    // Finite slope at the horizon (pow(up, k < 1) would crease it visibly).
    float k = (1.0 - exp(-3.0 * up)) / (1.0 - exp(-3.0));
    vec3 c = mix(u_sky_horizon, u_sky_zenith, k);
    // A soft glow around the sun, only above the horizon: s^64.
    float s = max(dot(d, u_sun_dir), 0.0);
    s *= s; s *= s; s *= s; s *= s; s *= s; s *= s;
    return c + vec3(1.0, 0.9, 0.7) * 0.25 * s * smoothstep(0.0, 0.05, up);
}

// The world-space view ray through NDC point p (linear in p).
vec3 ray(vec2 p)
{
    vec4 w = u_inv_viewproj_rot * vec4(p, 0.5, 1.0);
    return w.xyz / w.w;
}

void main()
{
    int cell = gl_VertexID / 6, corner = gl_VertexID - 6 * cell;
    // Two triangles a cell: corners (0,0) (1,0) (1,1), (0,0) (1,1) (0,1).
    ivec2 o = ivec2(corner == 1 || corner == 2 || corner == 4 ? 1 : 0, corner == 2 || corner == 4 || corner == 5 ? 1 : 0);
    vec2 g = vec2(ivec2(cell % SKY_COLS, cell / SKY_COLS) + o) / vec2(SKY_COLS, SKY_ROWS);
    // A camera without roll sees the horizon (rays with y = 0) as a screen
    // row. The rows then span the screen on the sky's side of it only: the
    // horizon, where the gradient has a kink, falls on a row's edge, and
    // below it the sky is exactly the horizon colour, the clear colour.
    float a = ray(vec2(0.0)).y, b = ray(vec2(1.0, 0.0)).y - a, c = ray(vec2(0.0, 1.0)).y - a;
    vec2 span = vec2(-1.0, 1.0);
    if (abs(b) <= 1e-4 * abs(c)) {
        float yh = clamp(-a / c, -1.0, 1.0);
        span = c > 0.0 ? vec2(yh, 1.0) : vec2(-1.0, yh);
    }
    vec2 p = vec2(g.x * 2.0 - 1.0, mix(span.x, span.y, g.y));
    v_color = sky_color(ray(p));
    // The far plane in reverse-Z: the sky is drawn after the terrain, where
    // the depth is still far.
    gl_Position = vec4(p, u_sky_z, 1.0);
}
