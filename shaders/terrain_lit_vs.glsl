#version 330 core
// The lit map's bake: one triangle over the whole target, a fragment per
// sample (no vertex buffer).
void main()
{
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2)) * 2.0 - 1.0;
    gl_Position = vec4(p, 0.0, 1.0);
}
