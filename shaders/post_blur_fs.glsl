#version 330 core
// Motion blur by frame feedback (R7, seed 000 ch. 11): P = (1 - f) P_now + f P_prev,
// P_prev being the previous result of this pass.
uniform sampler2D u_now, u_prev;
uniform float u_f;
in vec2 v_uv;
out vec4 o_color;

void main()
{
    vec3 now = texture(u_now, v_uv).rgb;
    vec3 prev = texture(u_prev, v_uv).rgb;
    o_color = vec4((1.0 - u_f) * now + u_f * prev, 1.0);
}
