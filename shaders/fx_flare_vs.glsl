#version 330 core
// Lens flare (R2): elements on the line from the sun to the screen centre,
// one instance each, additive.
uniform vec2 u_sun;          // NDC of the sun
uniform float u_aspect;      // width / height
uniform float u_t[8];        // position along sun -> centre (0 = sun, 1 = centre, 2 = mirrored)
uniform float u_size[8];     // radius, fraction of the screen height
out vec2 v_q;
flat out int v_k;

void main()
{
    int k = gl_InstanceID;
    vec2 c = vec2(float(gl_VertexID & 1), float(gl_VertexID >> 1)) * 2.0 - 1.0;
    vec2 pos = u_sun + (vec2(0.0) - u_sun) * u_t[k];
    v_q = c;
    v_k = k;
    gl_Position = vec4(pos + c * vec2(u_size[k] * 2.0 / u_aspect, u_size[k] * 2.0), 0.0, 1.0);
}
