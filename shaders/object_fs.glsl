#version 450 core
// Scene objects: the material's colour, Lambert from the sun plus a sky
// term (lit per vertex), and the scene's fog as hz_pass_info gives it:
// exponential (its factor per vertex, as the terrain's), plus with the fog
// effect the height fog (integrated along the ray) toward the sky's colour
// behind, faded fully to it over the last stretch of the view distance, as
// the terrain. With the light map's sun heights, the sun term is shaded
// where the terrain or other objects hide the sun.
// Variants (object_draw.c): OBJ_SUN_HEIGHTS, OBJ_HEIGHT_FOG and OBJ_FAR_FADE
// compile those paths in. A uniform switching them off would still cost
// every fragment on llvmpipe, which runs both sides of a branch.
#ifndef OBJ_SUN_HEIGHTS
#define OBJ_SUN_HEIGHTS 1
#endif
#ifndef OBJ_HEIGHT_FOG
#define OBJ_HEIGHT_FOG 1
#endif
#ifndef OBJ_FAR_FADE
#define OBJ_FAR_FADE 1
#endif
uniform vec3 u_sky_horizon, u_eye;
uniform float u_fog_density;
uniform vec2 u_fog_far;
uniform vec3 u_height_fog;       // density /m, base height, falloff (m); density 0: none
uniform vec3 u_zenith;
uniform sampler2D u_sun_heights; // R32F: below it a point is in shade (hz_pass_info)
uniform vec4 u_sunh_map;         // world xz -> uv: xz * map.xy + map.zw
uniform vec4 u_sunh;             // y: lookup step (m), z: tan(sun elevation), w: soft edge (m)
uniform vec2 u_sun_h;            // the sun's horizontal unit direction
in vec3 v_world;
in vec3 v_normal;
flat in vec3 v_color; // the material's, per instance
in vec2 v_light;
in float v_fog; // exp(-density * distance), per vertex
out vec4 o_color;

// 0 in the shade of the terrain or other objects, 1 in the sun. A face is
// looked up one sample outward along its normal, so that an object's own
// samples (which its roof raises) do not shade its walls; the height there
// is compared with the sun ray's rise over that step.
float sun_lit(vec3 n)
{
    vec2 off = n.xz * u_sunh.y;
    float y = v_world.y + dot(off, u_sun_h) * u_sunh.z;
    float top = texture(u_sun_heights, (v_world.xz + off) * u_sunh_map.xy + u_sunh_map.zw).r;
    return smoothstep(top - u_sunh.w, top, y);
}

void main()
{
    float direct = v_light.y;
#if OBJ_SUN_HEIGHTS
    if (direct > 0.0)
        direct *= sun_lit(normalize(v_normal));
#endif
    vec3 c = v_color * (v_light.x + direct * vec3(1.0, 0.97, 0.90));
#if OBJ_HEIGHT_FOG || OBJ_FAR_FADE
    vec3 d = v_world - u_eye;
    float dist = length(d);
    float f = v_fog;
    vec3 fog_c = u_sky_horizon;
#if OBJ_HEIGHT_FOG
    {
        // (exp(-ye) - exp(-yp)) / dy: the height fog's mean density along the ray
        float ye = max((u_eye.y - u_height_fog.y) / u_height_fog.z, -30.0);
        float yp = max((v_world.y - u_height_fog.y) / u_height_fog.z, -30.0);
        float dy = yp - ye;
        float k = abs(dy) > 1e-3 ? (exp(-ye) - exp(-yp)) / dy : exp(-ye) * (1.0 - 0.5 * dy);
        f *= exp(-u_height_fog.x * dist * k);
        float up = max(d.y / max(dist, 1e-6), 0.0);
        fog_c = mix(u_sky_horizon, u_zenith, (1.0 - exp(-3.0 * up)) / (1.0 - exp(-3.0)));
    }
#endif
#if OBJ_FAR_FADE
    f *= 1.0 - smoothstep(u_fog_far.x, u_fog_far.y, dist);
#endif
    o_color = vec4(mix(fog_c, c, f), 1.0);
#else
    // Only the exponential fog: its factor from the vertices (no distance
    // per pixel), as the terrain's.
    o_color = vec4(mix(u_sky_horizon, c, v_fog), 1.0);
#endif
}
