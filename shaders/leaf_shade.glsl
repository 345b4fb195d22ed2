// A leaf's lighting, shared by the leaf shaders: per fragment for quads
// (leaf_fs.glsl), per leaf in the vertex shader for points (whose normal
// and position are the leaf's).
uniform vec3 u_color;
uniform vec3 u_sun_dir, u_sky_horizon, u_eye;
uniform float u_fog_density, u_ambient;

// Two-sided Lambert with some light through the leaf, the leaf's tint and
// crown occlusion (shade), exponential fog.
vec4 leaf_lit(vec3 n, vec3 world, float shade)
{
    vec3 to_eye = u_eye - world;
    if (dot(n, to_eye) < 0.0)
        n = -n;
    float ndl = dot(n, u_sun_dir);
    float light = max(ndl, 0.0) + 0.35 * max(-ndl, 0.0);
    vec3 c = u_color * shade * (u_ambient + (1.0 - u_ambient) * light * vec3(1.0, 0.97, 0.90));
    float f = u_fog_density > 0.0 ? exp(-u_fog_density * length(to_eye)) : 1.0;
    return vec4(mix(u_sky_horizon, c, f), 1.0);
}
