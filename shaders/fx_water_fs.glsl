#version 330 core
// Water (R9): planar reflection (a mirrored render of sky, terrain, trees and
// objects), transparency by the depth of water along the view (terrain
// heights from the height buffer), animated wave normals that distort the
// reflection, Fresnel, the sun's glitter, and the common fog. Blended over the
// terrain below with (ONE, SRC_ALPHA): out = src + alpha * underwater.
uniform sampler2D u_reflection;
uniform int u_has_reflection;
uniform vec2 u_viewport;       // pixels
uniform samplerBuffer u_heights;
uniform samplerBuffer u_valid; // a byte per sample: has data (bound when u_has_valid)
uniform int u_has_valid;
uniform int u_sea;             // a DEM's sea: the ground below the level is flat fill, not a floor
uniform samplerBuffer u_coast; // a byte per sample along each edge of the data: 1 = sea (hz_coast)
uniform ivec4 u_coast_rect;    // the data's rectangle in samples; z < x: no coast
uniform float u_coast_spacing; // metres between those samples
uniform int u_size;
uniform float u_spacing, u_hscale, u_hoffset;
uniform float u_level;
uniform vec3 u_deep;
uniform float u_clarity, u_waves, u_reflectivity;

in vec3 v_world;
out vec4 o_color;

float h_at(int i, int j)
{
    float h16 = floor(texelFetch(u_heights, j * u_size + i).r * 65535.0 + 0.5);
    return u_hoffset + u_hscale * h16;
}

// Bilinear ground height; far below everything outside the map and where
// there is no data (open sea).
float ground(vec2 xz)
{
    vec2 g = xz / u_spacing;
    float n1 = float(u_size - 1);
    if (g.x < 0.0 || g.y < 0.0 || g.x > n1 || g.y > n1)
        return -1e6;
    ivec2 i = min(ivec2(floor(g)), ivec2(u_size - 2));
    vec2 f = g - vec2(i);
    float a = h_at(i.x, i.y), b = h_at(i.x + 1, i.y), c = h_at(i.x, i.y + 1), d = h_at(i.x + 1, i.y + 1);
    // A sample without data (an SRTM sea is nodata) is as deep as the open
    // sea: its filled height is no sea floor, nor is it beside one.
    if (u_has_valid != 0) {
        int k = i.y * u_size + i.x;
        a = texelFetch(u_valid, k).r == 0.0 ? -1e6 : a; // GL_R8: 1 reads 1/255
        b = texelFetch(u_valid, k + 1).r == 0.0 ? -1e6 : b;
        c = texelFetch(u_valid, k + u_size).r == 0.0 ? -1e6 : c;
        d = texelFetch(u_valid, k + u_size + 1).r == 0.0 ? -1e6 : d;
    }
    float h = mix(mix(a, b, f.x), mix(c, d, f.x), f.y);
    // A DEM's sea is flat fill just under the plane: as deep as the open sea.
    return u_sea != 0 && h < u_level ? -1e6 : h;
}

bool coast_sea(int k)
{
    return texelFetch(u_coast, k).r > 0.0;
}

// Beyond the data's rectangle a sea goes on only off the edge's sea samples
// (the coast runs straight out); inside it, everywhere.
bool sea_here(vec2 xz)
{
    ivec4 r = u_coast_rect;
    if (u_sea == 0 || r.z < r.x)
        return true;
    vec2 g = xz / u_coast_spacing;
    int rows = r.w - r.y + 1, cols = r.z - r.x + 1;
    ivec2 c = clamp(ivec2(floor(g + 0.5)), r.xy, r.zw);
    bool sea = true;
    if (g.x < float(r.x) - 0.5)
        sea = sea && coast_sea(c.y - r.y);
    else if (g.x > float(r.z) + 0.5)
        sea = sea && coast_sea(rows + c.y - r.y);
    if (g.y < float(r.y) - 0.5)
        sea = sea && coast_sea(2 * rows + c.x - r.x);
    else if (g.y > float(r.w) + 0.5)
        sea = sea && coast_sea(2 * rows + cols + c.x - r.x);
    return sea;
}

// Sum of wind-driven directional waves (deep-water speeds), as a slope.
vec2 wave_slope(vec2 xz, float t, float fade)
{
    vec2 w = fx_cloud.zw;
    float wl = length(w);
    vec2 dir0 = wl > 1e-3 ? w / wl : vec2(1.0, 0.0);
    const float lambda[6] = float[6](21.0, 12.7, 7.9, 4.3, 2.6, 1.4);
    const float turn[6] = float[6](0.0, 0.55, -0.4, 0.9, -0.8, 0.25);
    vec2 g = vec2(0.0);
    for (int k = 0; k < 6; k++) {
        float a = turn[k];
        vec2 d = vec2(dir0.x * cos(a) - dir0.y * sin(a), dir0.x * sin(a) + dir0.y * cos(a));
        float kf = 6.2831853 / lambda[k];
        float c = sqrt(9.81 / kf);
        float amp = 0.035 * lambda[k] / 6.2831853 * (0.6 + 0.4 * min(wl / 6.0, 2.0));
        // Small waves vanish first with distance (they would only alias).
        float damp = k >= 2 ? fade * fade : fade;
        g += damp * amp * kf * cos(kf * (dot(d, xz) - c * t) + float(k) * 1.7) * d;
    }
    return g;
}

void main()
{
    if (!sea_here(v_world.xz))
        discard;
    vec3 e = fx_eye.xyz;
    vec3 to_eye = e - v_world;
    float dist = length(to_eye);
    vec3 v = to_eye / max(dist, 1e-4);
    float fade = 1.0 / (1.0 + dist / 400.0);
    vec2 g = wave_slope(v_world.xz, fx_eye.w, fade) * u_waves;
    vec3 n = normalize(vec3(-g.x, 1.0, -g.y));

    float cosv = max(dot(n, v), 0.0);
    float F = clamp((0.02 + 0.98 * pow(1.0 - cosv, 5.0)) * u_reflectivity, 0.0, 1.0);
    vec3 refl;
    if (u_has_reflection != 0) {
        vec2 uv = gl_FragCoord.xy / u_viewport + n.xz * 0.05 * fade;
        refl = texture(u_reflection, clamp(uv, vec2(0.001), vec2(0.999))).rgb;
    } else {
        refl = fx_horizon_color(reflect(-v, n));
    }
    // Light through the water: the path below the surface along the view.
    float depth = max(u_level - ground(v_world.xz), 0.0);
    float path = depth / max(v.y, 0.08);
    float T = exp(-path / max(u_clarity, 1e-3));
    float Ie = fx_sun_color.w;
    vec3 deep = u_deep * (Ie + (1.0 - Ie) * max(fx_sun.y, 0.0)) * fx_sun_color.rgb;
    float spec = fx_sun.y > 0.0 ? pow(max(dot(reflect(-v, n), fx_sun.xyz), 0.0), 600.0) * 5.0 : 0.0;
    vec3 src = (1.0 - F) * (1.0 - T) * deep + F * refl + spec * fx_sun_color.rgb;
    float a = (1.0 - F) * T;
    // Fog over the whole (the underwater part is fogged already).
    float keep = fx_fog_keep(e, v_world);
    vec3 fogc = fx_fog_color(-v);
    o_color = vec4(keep * src + (1.0 - keep) * (1.0 - a) * fogc, a);
}
