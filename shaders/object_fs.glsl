#version 450 core
// Scene objects: the material's colour, Lambert from the sun plus a sky
// term (lit per vertex), and the scene's fog as hz_pass_info gives it:
// exponential, plus with the fog effect the height fog (integrated along the ray) toward the
// sky's colour behind, faded fully to it over the last stretch of the view
// distance, as the terrain. With the light
// map's sun heights, the sun term is shaded where the terrain or other
// objects hide the sun.
uniform vec3 u_color;
uniform vec3 u_sky_horizon, u_eye;
uniform float u_fog_density;
uniform vec2 u_fog_far;
uniform vec3 u_height_fog;       // density /m, base height, falloff (m); density 0: none
uniform vec3 u_zenith;
uniform sampler2D u_sun_heights; // R32F: below it a point is in shade (hz_pass_info)
uniform vec4 u_sunh_map;         // world xz -> uv: xz * map.xy + map.zw
uniform vec4 u_sunh;             // x: 1 = on, y: lookup step (m), z: tan(sun elevation), w: soft edge (m)
uniform vec2 u_sun_h;            // the sun's horizontal unit direction
in vec3 v_world;
in vec3 v_normal;
in vec2 v_light;
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
    if (u_sunh.x > 0.0 && direct > 0.0)
        direct *= sun_lit(normalize(v_normal));
    vec3 c = u_color * (v_light.x + direct * vec3(1.0, 0.97, 0.90));
    vec3 d = v_world - u_eye;
    float dist = length(d);
    float tau = u_fog_density * dist;
    vec3 fog_c = u_sky_horizon;
    if (u_height_fog.x > 0.0) {
        // (exp(-ye) - exp(-yp)) / dy: the height fog's mean density along the ray
        float ye = max((u_eye.y - u_height_fog.y) / u_height_fog.z, -30.0);
        float yp = max((v_world.y - u_height_fog.y) / u_height_fog.z, -30.0);
        float dy = yp - ye;
        float k = abs(dy) > 1e-3 ? (exp(-ye) - exp(-yp)) / dy : exp(-ye) * (1.0 - 0.5 * dy);
        tau += u_height_fog.x * dist * k;
        float up = max(d.y / max(dist, 1e-6), 0.0);
        fog_c = mix(u_sky_horizon, u_zenith, (1.0 - exp(-3.0 * up)) / (1.0 - exp(-3.0)));
    }
    float f = exp(-tau);
    if (u_fog_far.y > u_fog_far.x)
        f *= 1.0 - smoothstep(u_fog_far.x, u_fog_far.y, dist);
    o_color = vec4(mix(fog_c, c, f), 1.0);
}
