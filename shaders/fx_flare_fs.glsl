#version 330 core
uniform vec4 u_color[8];     // rgb, a = kind: 0 glow with streaks, 1 ring, 2 soft disc
uniform float u_intensity;   // visibility x strength
in vec2 v_q;
flat in int v_k;
out vec4 o_color;

void main()
{
    vec4 col = u_color[v_k];
    float r = length(v_q);
    float v;
    if (col.a < 0.5) {
        v = exp(-r * r * 9.0) + 0.35 * exp(-r * 3.0);
        v += 0.5 * exp(-abs(v_q.y) * 60.0) * exp(-abs(v_q.x) * 2.2); // horizontal streak
        v += 0.25 * exp(-abs(v_q.x) * 60.0) * exp(-abs(v_q.y) * 3.0);
    } else if (col.a < 1.5) {
        v = smoothstep(0.72, 0.85, r) * (1.0 - smoothstep(0.88, 1.0, r));
    } else {
        v = (1.0 - smoothstep(0.55, 1.0, r)) * (0.55 + 0.45 * r);
    }
    o_color = vec4(col.rgb * v * u_intensity, 1.0);
}
