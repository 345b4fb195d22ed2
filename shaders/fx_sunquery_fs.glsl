#version 330 core
uniform int u_clouds;   // 1: thin out by the cloud cover along the sun (dithered)
in vec2 v_q;
out vec4 o_color;

void main()
{
    if (dot(v_q, v_q) > 1.0)
        discard;
    if (u_clouds != 0) {
        float a = fx_clouds(fx_eye.xyz, fx_sun.xyz).a;
        // Ordered dither: the passing fraction is 1 - a, the same every frame.
        ivec2 p = ivec2(gl_FragCoord.xy) & 3;
        const float bayer[16] = float[16](0.0, 8.0, 2.0, 10.0, 12.0, 4.0, 14.0, 6.0, 3.0, 11.0, 1.0, 9.0, 15.0, 7.0,
                                          13.0, 5.0);
        if (a > (bayer[p.y * 4 + p.x] + 0.5) / 16.0)
            discard;
    }
    o_color = vec4(1.0);
}
