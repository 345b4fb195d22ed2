#version 450 core
// Scene objects: the material's colour, Lambert from the sun plus a sky
// term, and the scene's fog (exponential, faded fully to the fog colour over
// the last stretch of the view distance, as the terrain). With the light
// map's sun heights, the sun term is shaded where the terrain or other
// objects hide the sun.
uniform vec3 u_color;
uniform vec3 u_sun_dir, u_sky_horizon, u_eye;
uniform float u_fog_density, u_ambient;
uniform vec2 u_fog_far;
uniform sampler2D u_sun_heights; // R32F: below it a point is in shade (hz_pass_info)
uniform vec4 u_sunh_map;         // world xz -> uv: xz * map.xy + map.zw
uniform vec4 u_sunh;             // x: 1 = on, y: lookup step (m), z: tan(sun elevation), w: soft edge (m)
uniform vec2 u_sun_h;            // the sun's horizontal unit direction
in vec3 v_world;
in vec3 v_normal;
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
    vec3 n = normalize(v_normal);
    if (!gl_FrontFacing)
        n = -n;
    float ndl = max(dot(n, u_sun_dir), 0.0);
    if (u_sunh.x > 0.0 && ndl > 0.0)
        ndl *= sun_lit(n);
    float sky = 0.5 + 0.5 * n.y;
    vec3 c = u_color * (u_ambient * (0.6 + 0.4 * sky) + (1.0 - u_ambient) * ndl * vec3(1.0, 0.97, 0.90));
    float dist = length(u_eye - v_world);
    float f = u_fog_density > 0.0 ? exp(-u_fog_density * dist) : 1.0;
    if (u_fog_far.y > u_fog_far.x)
        f *= 1.0 - smoothstep(u_fog_far.x, u_fog_far.y, dist);
    o_color = vec4(mix(u_sky_horizon, c, f), 1.0);
}
