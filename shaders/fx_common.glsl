// Shared by every effect shader (prepended after the #version line, after the
// variant's constants FX_ENABLED (HZ_FX_* bits compiled in), FX_HAS_COLORMAP,
// FX_HAS_COVER: each effect set gets its own program, because llvmpipe runs
// both sides of a branch and a runtime switch would cost as much as the
// effect itself). The
// frame's common parameters and the functions that must agree everywhere -
// the horizon/fog colour, fog along a ray, the cloud layer. Mirrored in C by
// fx_common_ubo (src/render/render_internal.h).
layout(std140) uniform FxCommon {
    vec4 fx_sun;        // xyz: unit toward the sun; w: sun disc angular radius (radians)
    vec4 fx_sun_color;  // rgb: sunlight colour; w: ambient Ie
    vec4 fx_horizon;    // rgb: horizon = fog colour; w: warm glow toward a low sun (0..1)
    vec4 fx_zenith;     // rgb: zenith colour; w: unused
    vec4 fx_eye;        // xyz: eye of this pass (mirrored in reflections); w: time (s)
    vec4 fx_fog;        // x: exponential density /m; y: height fog density /m at z: base height (world y); w: falloff (m)
    vec4 fx_fog_far;    // x, y: distances where everything fades fully to fog (y <= 0: none)
    vec4 fx_clip;       // world plane: keep dot(fx_clip, vec4(p, 1)) >= 0 when fx_bits.y != 0
    vec4 fx_cloud;      // x: cover 0..1; y: world height of the cloud layer; zw: wind (m/s, world x and z)
    vec4 fx_cloud_off;  // xy, zw: wind offsets (m) of the two cloud layers
    vec4 fx_map;        // x: map side (m); y: water level (world y); z: detail scale (m); w: unused
    vec4 fx_lm;         // light map texel of world xz: xz * x + y; z: 1 when valid; w: unused
    ivec4 fx_bits;      // x: HZ_FX_* bits of the frame; y: clip plane on; z: 1 in a reflection pass; w: unused
};

uniform sampler2D u_cloud_noise; // tileable fBm (R: large, G: small shapes), generated on the GPU

const int FX_SKY = 1, FX_FLARE = 2, FX_SHADOWS = 4, FX_DETAIL = 8, FX_BILLBOARDS = 16, FX_FOG = 32,
          FX_WATER = 64, FX_WEATHER = 128, FX_MOTIONBLUR = 256, FX_BLOOM = 512;

bool fx_on(int bit) { return (FX_ENABLED & bit) != 0; }

vec2 fx_lightmap_uv(vec2 xz) { return xz * fx_lm.x + fx_lm.y; }

// The colour the fog fades to when looking along d: the horizon colour, warmer
// toward a low sun when the sky effect is on. The sky at the horizon is exactly
// this, so fogged terrain, water and billboards melt into it without a seam.
vec3 fx_horizon_color(vec3 d)
{
    vec3 c = fx_horizon.rgb;
    if (fx_on(FX_SKY)) {
        vec2 h = normalize(d.xz + vec2(1e-6, 0.0)), s = normalize(fx_sun.xz + vec2(1e-6, 0.0));
        float toward = max(dot(h, s), 0.0);
        toward *= toward * toward;
        c = mix(c, vec3(1.0, 0.72, 0.48) * (0.6 + 0.4 * dot(c, vec3(0.333))), fx_horizon.w * toward * 0.6);
        // Haze lit by the sun: the aureole, wider when the sun is low.
        // Powers by squaring: pow() is a log and an exp per pixel on llvmpipe,
        // and the fog colour is worked out for every fogged pixel.
        float a = max(dot(d, fx_sun.xyz), 0.0), a2 = a * a, a6 = a2 * a2 * a2, a64 = a2;
        a64 *= a64; a64 *= a64; a64 *= a64; a64 *= a64; a64 *= a64; // a^64
        c += fx_sun_color.rgb * (0.25 * a64 + 0.12 * fx_horizon.w * a6);
    }
    return c;
}

// Sky gradient factor toward the zenith for a direction d.y (the plain sky's).
float fx_zenith_k(float up)
{
    return (1.0 - exp(-3.0 * max(up, 0.0))) / (1.0 - exp(-3.0));
}

// The fog colour along d. With the fog effect it is the sky behind: the
// gradient toward the zenith above the horizon (aerial perspective), so
// anything fading out at the view distance becomes exactly the sky it
// covers and far culling cannot pop. Without it, the horizon colour.
vec3 fx_fog_color(vec3 d)
{
    vec3 c = fx_horizon_color(d);
    if (fx_on(FX_FOG) && d.y > 0.0) {
        c = mix(c, fx_zenith.rgb, fx_zenith_k(d.y));
        if (!fx_on(FX_SKY)) { // the plain sky's sun glow (sky_fs.glsl)
            float g = max(dot(d, fx_sun.xyz), 0.0);
            g *= g; g *= g; g *= g; g *= g; g *= g; g *= g; // ^64
            c += vec3(1.0, 0.9, 0.7) * 0.25 * g * smoothstep(0.0, 0.05, d.y);
        }
    }
    return c;
}

// Optical depth from e to p: exponential fog plus (with the fog effect)
// height fog that thins exponentially with height, integrated exactly along
// the segment.
float fx_fog_depth(vec3 e, vec3 p)
{
    vec3 d = p - e;
    float L = length(d);
    float tau = fx_fog.x * L;
    if (fx_on(FX_FOG) && fx_fog.y > 0.0) {
        float H = fx_fog.w;
        float ye = max((e.y - fx_fog.z) / H, -30.0);
        float yp = max((p.y - fx_fog.z) / H, -30.0);
        float dy = yp - ye;
        // (exp(-ye) - exp(-yp)) / dy, not exp(-ye) (1 - exp(-dy)) / dy: an
        // eye far above the fog (ye ~ 100) would overflow exp(-dy) to inf and
        // multiply it by 0, a NaN that drew the terrain black.
        float k = abs(dy) > 1e-3 ? (exp(-ye) - exp(-yp)) / dy : exp(-ye) * (1.0 - 0.5 * dy);
        tau += fx_fog.y * L * k;
    }
    return tau;
}

// Fraction of an object's own colour left at p seen from e.
float fx_fog_keep(vec3 e, vec3 p)
{
    float T = exp(-fx_fog_depth(e, p));
    if (fx_on(FX_FOG) && fx_fog_far.y > 0.0)
        T *= 1.0 - smoothstep(fx_fog_far.x, fx_fog_far.y, length(p - e));
    return T;
}

// Applies fog to colour c of a surface at p seen from the pass's eye.
vec3 fx_fogged(vec3 c, vec3 p)
{
    vec3 e = fx_eye.xyz;
    return mix(fx_fog_color(normalize(p - e)), c, fx_fog_keep(e, p));
}

// Cloud layer: a plane at world height fx_cloud.y, two fBm layers drifting
// with the wind. Returns the coverage in [0, 1] at world (x, z) and, in y,
// how thick the cloud is there (how far the noise passed the threshold).
vec2 fx_cloud_density(vec2 xz)
{
    vec2 a = (xz + fx_cloud_off.xy) / 14000.0, b = (xz + fx_cloud_off.zw) / 3100.0;
    float n = 0.68 * texture(u_cloud_noise, a).r + 0.32 * texture(u_cloud_noise, b).g;
    float cover = fx_cloud.x;
    // cover 0: none; 1: overcast. n is about normal around 0.5.
    float lo = mix(0.74, 0.2, cover);
    return vec2(smoothstep(lo, lo + 0.12, n), clamp((n - lo - 0.06) / 0.22, 0.0, 1.0));
}

// The cloud layer seen along unit direction d from e: rgb colour and coverage
// (already faded toward the horizon by distance).
vec4 fx_clouds(vec3 e, vec3 d)
{
    if (!fx_on(FX_SKY) || fx_cloud.x <= 0.0)
        return vec4(0.0);
    float above = fx_cloud.y - e.y;
    if (above <= 0.0 || d.y <= 0.01)
        return vec4(0.0);
    float t = above / d.y;
    vec2 p = e.xz + d.xz * t;
    vec2 cd = fx_cloud_density(p);
    float dens = cd.x;
    if (dens <= 0.0)
        return vec4(0.0);
    // Light: thick parts have grey bases, thin edges are sunlit (no second
    // lookup toward the sun: texture fetches are the cost in software);
    // looking toward the sun the thin edges glow (forward scattering).
    float sun_up = clamp(fx_sun.y * 3.0, 0.0, 1.0);
    vec3 lit = fx_sun_color.rgb * (0.75 + 0.25 * sun_up) * 1.03;
    vec3 shade = mix(vec3(0.58, 0.61, 0.68), fx_zenith.rgb, 0.2) * (0.65 + 0.35 * sun_up);
    vec3 c = mix(lit, shade, 0.8 * cd.y);
    float x = max(dot(d, fx_sun.xyz), 0.0), x2 = x * x, x4 = x2 * x2;
    float fwd = x4 * x4 * x2; // x^10
    c += fx_sun_color.rgb * fwd * (1.0 - cd.y) * 1.2;
    // Far clouds fade into the horizon haze.
    float fade = exp(-t / 45000.0) * smoothstep(0.01, 0.12, d.y);
    return vec4(c, dens * fade);
}
