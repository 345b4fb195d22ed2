#version 330 core
// Vertical sky gradient by view direction. At and below the horizon it is
// exactly the fog colour, so fogged terrain melts into it without a seam.
uniform vec3 u_sky_horizon; // = fog colour
uniform vec3 u_sky_zenith;  // deeper colour straight up
uniform vec3 u_sun_dir;     // unit, toward the sun

in vec3 v_dir;
out vec4 o_color;

void main()
{
    vec3 d = normalize(v_dir);
    float up = max(d.y, 0.0);
    // Finite slope at the horizon (pow(up, k < 1) would crease it visibly).
    float k = (1.0 - exp(-3.0 * up)) / (1.0 - exp(-3.0));
    vec3 c = mix(u_sky_horizon, u_sky_zenith, k);
    // A soft glow around the sun, only above the horizon: s^64 by six
    // squarings (pow is a log and an exp per pixel on llvmpipe; this pass
    // covers every sky pixel of every frame).
    float s = max(dot(d, u_sun_dir), 0.0);
    s *= s; s *= s; s *= s; s *= s; s *= s; s *= s;
    c += vec3(1.0, 0.9, 0.7) * 0.25 * s * smoothstep(0.0, 0.05, up);
    o_color = vec4(c, 0.0); // alpha 0: no ground (a sea shows over it)
}
