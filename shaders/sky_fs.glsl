#version 330 core
// Vertical sky gradient by view direction, shaded per vertex (sky_grid_vs.glsl).
// At and below the horizon it is exactly the fog colour, so fogged terrain
// melts into it without a seam.
in vec3 v_color;
out vec4 o_color;

void main()
{
    o_color = vec4(v_color, 0.0); // alpha 0: no ground (a sea shows over it)
}
