#version 330 core
uniform sampler2D u_tex;
uniform int u_blend; // 0: alpha test (cut-outs), 1: alpha blend (particles)

in vec2 v_uv;
in vec4 v_tint;
in vec3 v_world;
in float v_light;
out vec4 o_color;

void main()
{
    if (fx_bits.y != 0 && dot(fx_clip, vec4(v_world, 1.0)) < 0.0)
        discard;
    vec4 t = texture(u_tex, v_uv) * v_tint;
    if (u_blend == 0 && t.a < 0.5)
        discard;
    vec3 c = t.rgb * v_light * mix(vec3(1.0), fx_sun_color.rgb, 0.5);
    c = fx_fogged(c, v_world);
    o_color = vec4(c, u_blend != 0 ? t.a : 1.0);
}
