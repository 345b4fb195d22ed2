// The plain terrain shading, shared by terrain_fs.glsl and the lit map's
// bake (terrain_lit_fs.glsl; included through src/render/embed_shaders.cmake):
// colour by absolute height (the climate's snow and tree lines), aridity and
// slope, lit by the sun (Lambert) and the ambient term.
uniform vec4 u_climate;   // snow line, tree line (world metres: zscale applied), aridity 0..1, zscale
uniform vec3 u_sun_dir;   // unit, toward the sun
uniform float u_ambient;

const vec3 lowland = vec3(0.26, 0.40, 0.16);
const vec3 meadow  = vec3(0.42, 0.45, 0.22);
const vec3 dirt    = vec3(0.45, 0.37, 0.26);
const vec3 rock    = vec3(0.44, 0.41, 0.38);
const vec3 snow    = vec3(0.93, 0.94, 0.97);
const vec3 sand    = vec3(0.62, 0.56, 0.42);
const vec3 alpine  = vec3(0.46, 0.47, 0.30);  // grass above the tree line
const vec3 scree   = vec3(0.50, 0.48, 0.45);
const vec3 steppe  = vec3(0.60, 0.54, 0.36);  // dry grass
const vec3 desert  = vec3(0.80, 0.64, 0.44);  // sand and gravel plains
const vec3 redrock = vec3(0.56, 0.42, 0.31);  // desert rock

// Permanent snow (flat enough to hold it) above the climate's snow line.
float snow_weight(float y, float slope)
{
    float zs = u_climate.w;
    return smoothstep(u_climate.x - 150.0 * zs, u_climate.x + 150.0 * zs, y) * (1.0 - smoothstep(0.18, 0.34, slope));
}

// Colour by absolute height y (world metres) and slope (1 - n.y): lush
// lowland to meadow up to the tree line, alpine grass to scree above it;
// dry grass and desert by aridity; rock on steep slopes; snow above the
// snow line.
vec3 ground_color(float y, float slope)
{
    float zs = u_climate.w, tree = u_climate.y, arid = u_climate.z;
    float top = tree + 600.0 * zs; // the highest grass
    vec3 green = mix(lowland, meadow, smoothstep(tree - 1500.0 * zs, tree, y));
    green = mix(green, alpine, smoothstep(tree - 100.0 * zs, tree + 100.0 * zs, y));
    green = mix(green, scree, smoothstep(tree + 100.0 * zs, top, y));
    vec3 dry = mix(steppe, desert, smoothstep(0.75, 1.0, arid));
    vec3 c = mix(green, dry, smoothstep(0.0, 0.7, arid));
    vec3 stone = mix(mix(dirt, rock, smoothstep(tree - 1000.0 * zs, top, y)), redrock, smoothstep(0.6, 1.0, arid));
    // slope = 1 - n.y: 0.16 ~ 33 deg, 0.32 ~ 47 deg
    c = mix(c, stone, smoothstep(0.16, 0.32, slope));
    return mix(c, snow, snow_weight(y, slope));
}

// Sun Lambert (warm white light) plus the ambient term.
vec3 ground_lit(vec3 albedo, vec3 n)
{
    float lambert = max(dot(n, u_sun_dir), 0.0);
    return albedo * (u_ambient + (1.0 - u_ambient) * lambert * vec3(1.0, 0.97, 0.90));
}

// The unit normal from the normal map's (x, z).
vec3 ground_normal(vec2 nxz)
{
    return normalize(vec3(nxz.x, sqrt(max(1.0 - dot(nxz, nxz), 0.0)), nxz.y));
}
