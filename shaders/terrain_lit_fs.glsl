#version 330 core
#include "ground_color.glsl"
// The lit map: per sample of the heightmap, the plain terrain's colour
// (terrain_fs.glsl without effects, fog aside) from the sample's height and
// its normal in the normal map. The plain terrain then reads it with one
// trilinear fetch per pixel instead of the normal, the colour and Lambert.
uniform samplerBuffer u_heights; // GL_R16, normalised: value * 65535 = h16
uniform sampler2D u_normals;     // per-sample normals (x, z)
uniform int u_size;              // samples per side
uniform float u_hscale;          // metres per h16 step, times zscale
uniform float u_hoffset;         // metres at h16 = 0, times zscale
out vec4 o_color;

void main()
{
    ivec2 s = ivec2(gl_FragCoord.xy); // sample (i, j): x along i, y along j
    float h16 = floor(texelFetch(u_heights, s.y * u_size + s.x).r * 65535.0 + 0.5);
    float y = u_hoffset + u_hscale * h16;
    vec3 n = ground_normal(texelFetch(u_normals, s, 0).rg);
    o_color = vec4(ground_lit(ground_color(y, 1.0 - n.y), n), 1.0);
}
