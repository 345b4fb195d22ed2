// The cross-fade between LOD states, shared by the leaf fragment shaders:
// the pixel is kept when its dither value lies in [x, y) of u_dither ((0, 1)
// keeps all).
uniform vec2 u_dither;

bool leaf_dithered_out()
{
    float dv = fract(52.9829189 * fract(dot(gl_FragCoord.xy, vec2(0.06711056, 0.00583715))));
    return dv < u_dither.x || dv >= u_dither.y;
}
