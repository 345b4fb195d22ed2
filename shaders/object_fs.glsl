#version 450 core
// Scene objects: the material's colour, Lambert from the sun plus a sky
// term, and the scene's fog (exponential, faded fully to the fog colour over
// the last stretch of the view distance, as the terrain).
uniform vec3 u_color;
uniform vec3 u_sun_dir, u_sky_horizon, u_eye;
uniform float u_fog_density, u_ambient;
uniform vec2 u_fog_far;
in vec3 v_world;
in vec3 v_normal;
out vec4 o_color;

void main()
{
    vec3 n = normalize(v_normal);
    if (!gl_FrontFacing)
        n = -n;
    float ndl = max(dot(n, u_sun_dir), 0.0);
    float sky = 0.5 + 0.5 * n.y;
    vec3 c = u_color * (u_ambient * (0.6 + 0.4 * sky) + (1.0 - u_ambient) * ndl * vec3(1.0, 0.97, 0.90));
    float dist = length(u_eye - v_world);
    float f = u_fog_density > 0.0 ? exp(-u_fog_density * dist) : 1.0;
    if (u_fog_far.y > u_fog_far.x)
        f *= 1.0 - smoothstep(u_fog_far.x, u_fog_far.y, dist);
    o_color = vec4(mix(u_sky_horizon, c, f), 1.0);
}
