#version 330 core
// Sky dome with effects (R1): a gradient that follows the sun (darker and
// warmer toward the horizon as the sun sinks), the sun disc, and the cloud
// layer. Shares fx_horizon_color with the fog, so the horizon matches it.
in vec3 v_dir;
out vec4 o_color;

void main()
{
    vec3 d = normalize(v_dir);
    vec3 horizon = fx_horizon_color(d);
    if (d.y <= 0.0) {
        // At and below the horizon: exactly the fog colour.
        o_color = vec4(horizon, 0.0); // alpha 0: no ground (a sea shows over it)
        return;
    }
    vec3 c = mix(horizon, fx_zenith.rgb, fx_zenith_k(d.y)); // = fx_fog_color(d) with the fog effect
    float s = max(dot(d, fx_sun.xyz), 0.0); // (the aureole is part of the horizon colour)
    // The sun disc (HDR: brighter than white, for bloom), with a soft rim.
    float cos_r = cos(fx_sun.w);
    float disc = smoothstep(cos_r - 2e-5, cos_r + 2e-5, s) * smoothstep(-0.01, 0.01, fx_sun.y);
    c = mix(c, fx_sun_color.rgb * 6.0, disc);
    // Clouds in front of all that.
    vec4 cl = fx_clouds(fx_eye.xyz, d);
    c = mix(c, cl.rgb, cl.a);
    o_color = vec4(c, 0.0);
}
