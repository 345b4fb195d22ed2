#version 330 core
#include "curvature.glsl"
// cdlod patches: one static grid of (P+1)^2 vertices (gl_VertexID = w (P+1) + u)
// drawn once per selected node (instanced). Heights, morph ranges and morph
// targets come from a buffer texture of tiles (one pyramid level per tile set),
// addressed per tile, never as one full-resolution buffer. hz_lod_morph_height
// computes the same on the CPU.
// Streamed: x0, z0 (samples), layer | shift << 16, ox | oz << 12 | coarse << 28.
// In memory (8 bytes a node): x0 | z0 << 16, shift | coarse << 4; the tile is
// found from them as the CPU's patch_upload validates it.
layout(location = 0) in uvec4 a_patch;
layout(location = 1) in uvec2 a_slide; // streamed tiles sliding in: the least morph (0..255) of this
                                       // level's vertices inside | W << 8 | E << 16 | N << 24; S
uniform usamplerBuffer u_tiles; // RGBA16UI: h16, morph q (65535 never), target2 lo, target2 hi;
                                // square tiles back to back (layer, row, column)
uniform int u_size;              // P: grid cells per side of a patch
uniform float u_spacing;         // metres between samples
uniform float u_hscale;          // metres per h16 step, times zscale
uniform float u_hoffset;         // metres at h16 = 0, times zscale
uniform mat4 u_viewproj;         // reverse-Z projection * view
uniform float u_fog_density;     // per metre; 0 disables
uniform vec3 u_eye;              // world metres
uniform float u_morph_scale;     // metres of range per q step; 0 = no morphing
uniform float u_morph_start;     // morphing starts at this fraction of the range
uniform float u_morph_near;      // the near bound (hz_lod_morph_range): tau / tau_near, 1 = none
uniform float u_morph_near_d0;   // and its distance, metres
uniform int u_map;               // samples per side of the map
uniform int u_tile;              // T: cells per tile side
uniform int u_tile_shift;        // log2 T (in memory T is a power of two). No integer division
                                 // here: llvmpipe has no vector one and runs it lane by lane
uniform int u_top;               // the coarsest tile level (one tile)
uniform int u_base[16];          // first layer of each tile level
// STREAM 1: a streamed pyramid; tiles are cache slots, neighbours come from
// the patch's own tile, normals from the heights. A compile-time constant
// (FX_VARIANT_STREAM, bit 22 of the variant), not a uniform: llvmpipe runs
// both sides of a branch under a mask, so the streamed path's texel fetches
// would cost every in-memory vertex too (about 20 % of the frame).
#if (FX_VARIANT & 4194304) != 0
const int STREAM = 1;
#else
const int STREAM = 0;
#endif
// MORPH false: a still patch (FX_VARIANT_STILL, bit 25): the CPU found that
// none of its vertices morphs for this eye, so the morph code, which llvmpipe
// would run for every vertex, is compiled out. The same positions.
#if (FX_VARIANT & 33554432) != 0
const bool MORPH = false;
#else
const bool MORPH = true;
#endif

// SIMPLE (FX_VARIANT_SIMPLE, bit 28): a patch none of whose even vertices
// morphs (hz_patch.simple): the two neighbours an odd vertex collapses
// between stand still, so its target is their stored midpoint (target_of),
// without reading and morphing them. The same positions.
#if (FX_VARIANT & 268435456) != 0
const bool SIMPLE = true;
#else
const bool SIMPLE = false;
#endif

// VLIT: the lit map is read per vertex (FX_VARIANT_VLIT, bit 26; --lit-map
// vertex) and interpolated over the triangles, as fixed-function lighting is:
// the fragment shader then only interpolates a colour.
// FINE (FX_VARIANT_FINE, bit 27, with VLIT): a patch of the finest level, a
// vertex on every sample, over smooth lit map (litmap_smooth_at). By default
// these read the lit map per vertex, the other patches per pixel: each
// vertex reads it filtered as the per-pixel read would there (trilinear, at
// its mip level), so that the two agree but for the interpolation inside the
// cells. A morphing vertex moves only in height: it reads its own sample,
// as the per-pixel read does at its place (no colour morph).
#if (FX_VARIANT & 134217728) != 0
const bool FINE = true;
#else
const bool FINE = false;
#endif
#if (FX_VARIANT & 67108864) != 0
uniform sampler2D u_lit;   // the lit colour per sample (terrain_litmap.c)
uniform float u_lit_lod;   // samples a pixel covers at one metre: the mip level is log2(d * this)
uniform int u_lit_top;     // the lit map's last mip level
out vec3 v_lit;
#endif

out vec3 v_world;
out vec3 v_normal;
out float v_fog;   // the plain fog's factor (terrain_fs.glsl): per vertex, smooth enough

// Texel c of tile layer: the tiles are squares of u_tile + 1 texels a side
// (+ 3 streamed: an apron of one texel around the shared border).
uvec4 tile_fetch(ivec2 c, int layer)
{
    int side = u_tile + (STREAM != 0 ? 3 : 1);
    return texelFetch(u_tiles, (layer * side + c.y) * side + c.x);
}

int low_bit(int v)
{
    return v == 0 ? (1 << 30) : (v & -v);
}

// The texel of sample (i, j) from tile level l (m tiles per side, the first
// layer base), where (i, j) lies on that level's grid. Every level stores a
// sample alike, so a morph neighbour is read from the level of the node that
// draws the vertex: it lies at least one vertex step away, on that level's
// grid. (Finding the finest level holding each neighbour instead, with a
// log2 and a per-lane index into u_base, cost llvmpipe 6 % more geometry time.)
uvec4 level_texel(ivec2 s, int l, int m, int base)
{
    ivec2 g = s >> l;
    ivec2 t = min(g >> u_tile_shift, ivec2(m - 1));
    return tile_fetch(g - (t << u_tile_shift), base + t.y * m + t.x);
}

float morph_factor(uvec4 t, vec3 p)
{
    if (t.g == 65535u)
        return 0.0;
    float R0 = u_morph_scale * float(t.g);
    float rn = u_morph_near * R0; // the near bound's range, as hz_lod_morph_range
    float R = min(R0, rn * max(1.0, rn / u_morph_near_d0));
    if (R <= 0.0)
        return 1.0;
    // a zone widened as the near bound's error grows (cd_morph_start_at; 0.8 is
    // HZ_LOD_MORPH_START_MIN)
    float q = R0 / R;
    float a = R < R0 ? max(0.8, 1.0 - (1.0 - u_morph_start) * q * q) : u_morph_start;
    return clamp((distance(hz_curve(p), u_eye) - a * R) / ((1.0 - a) * R), 0.0, 1.0);
}

// The morph target: half the 17-bit sum of the two neighbours' heights in b
// and bit 0 of a (bit 1 of a is the no-data flag, not a height).
float target_of(uvec4 t)
{
    return u_hoffset + u_hscale * 0.5 * (float(t.b) + 65536.0 * float(t.a & 1u));
}

// A neighbour moved one level toward its own target.
float morph1_texel(uvec4 t, int i, int j)
{
    float h = u_hoffset + u_hscale * float(t.r);
    float m = morph_factor(t, vec3(float(i) * u_spacing, h, float(j) * u_spacing));
    return mix(h, target_of(t), m);
}

// Streamed: the texel of sample (i, j) in the patch's tile (level shift), if it lies there.
bool tile_texel(int i, int j, ivec2 org, int shift, int layer, out uvec4 t)
{
    ivec2 l = (ivec2(i, j) - org) >> shift;
    bool ok = all(greaterThanEqual(l, ivec2(0))) && all(lessThanEqual(l, ivec2(u_tile))) &&
              ((ivec2(i, j) - org) & ((1 << shift) - 1)) == ivec2(0);
    t = ok ? tile_fetch(l + 1, layer) : uvec4(0u); // streamed tiles: a one-texel apron
    return ok;
}

// Height of sample (i, j) next to the patch's tile: the tile or its apron
// (one sample around it), which both tiles of an edge share.
float stream_h(int i, int j, ivec2 org, int shift, int layer)
{
    ivec2 l = clamp((ivec2(i, j) - org) >> shift, ivec2(-1), ivec2(u_tile + 1));
    return u_hoffset + u_hscale * float(tile_fetch(l + 1, layer).r);
}

// The normal of the next coarser level at sample (i, j) of the patch's tile
// (central differences two steps wide).
vec3 coarse_normal(int i, int j, ivec2 org, int shift, int layer)
{
    int st2 = 2 << shift;
    float hw = stream_h(i - st2, j, org, shift, layer), he = stream_h(i + st2, j, org, shift, layer);
    float hn = stream_h(i, j - st2, org, shift, layer), hs = stream_h(i, j + st2, org, shift, layer);
    return normalize(vec3(-(he - hw) / (2.0 * float(st2) * u_spacing), 1.0, -(hs - hn) / (2.0 * float(st2) * u_spacing)));
}

#if (FX_VARIANT & 67108864) != 0
// The mip level the per-pixel read takes at sample s, dv from the eye: a
// pixel's footprint on the surface (the sample's normal, from the normal
// map), projected onto the map, along its longer screen axis (the texture
// unit's level follows the larger derivative). Seen at a low angle the
// footprint stretches along the view: the distance alone would read too
// fine a level there.
uniform sampler2D u_normals; // per-sample normals (x, z)
float lit_lod(ivec2 s, vec3 dv)
{
    vec2 nxz = texelFetch(u_normals, s, 0).rg;
    vec3 n = vec3(nxz.x, sqrt(max(1.0 - dot(nxz, nxz), 0.0)), nxz.y);
    float d = length(dv);
    vec3 r = dv / max(d, 1e-6);
    vec3 side = cross(r, vec3(0.0, 1.0, 0.0));
    side = dot(side, side) > 1e-8 ? normalize(side) : vec3(1.0, 0.0, 0.0);
    vec3 up = cross(side, r);
    // a screen step along t lands on the surface moved by t - r (n.t) / (n.r);
    // its map part is the xz of that (at most 64 times the step)
    float nr = dot(n, r);
    nr = abs(nr) > 1.0 / 64.0 ? nr : (nr < 0.0 ? -1.0 : 1.0) / 64.0;
    vec2 fs = side.xz - r.xz * dot(n, side) / nr, fu = up.xz - r.xz * dot(n, up) / nr;
    float f = sqrt(max(dot(fs, fs), dot(fu, fu)));
    return log2(max(d * u_lit_lod * f, 1.0));
}

// The lit colour of sample s, averaged over what a pixel covers at the
// vertex's distance (mip level lod): a function of the vertex alone, so every
// patch that draws it gives it the same colour (no seam between levels), and
// continuous in the distance. Two texel fetches blended by hand: textureLod
// with a level per vertex costs llvmpipe several times more.
vec3 lit_at(ivec2 s, float lod)
{
    int k = int(lod), top = u_lit_top;
    int k0 = min(k, top), k1 = min(k + 1, top);
    ivec2 s0 = min(s >> k0, ivec2((u_map >> k0) - 1)), s1 = min(s >> k1, ivec2((u_map >> k1) - 1));
    return mix(texelFetch(u_lit, s0, k0).rgb, texelFetch(u_lit, s1, k1).rgb, lod - float(k));
}
#endif

void main()
{
    int c1 = u_size + 1;
    int w = int((float(gl_VertexID) + 0.5) / float(c1)); // exact: gl_VertexID < 2^20
    int u = gl_VertexID - w * c1;
    uint x0, z0, coarse;
    int shift, layer, ox, oz, ts;
    int lv = 0, lm = 1, lbase = 0; // in memory: the node's tile level, its tiles per side, first layer
    if (STREAM != 0) {
        x0 = a_patch.x;
        z0 = a_patch.y;
        shift = int(a_patch.z >> 16);
        layer = int(a_patch.z & 0xffffu);
        ox = int(a_patch.w & 0xfffu);
        oz = int((a_patch.w >> 12) & 0xfffu);
        ts = 0;
        coarse = a_patch.w >> 28;
    } else {
        x0 = a_patch.x & 0xffffu;
        z0 = a_patch.x >> 16;
        shift = int(a_patch.y & 15u);
        coarse = (a_patch.y >> 4) & 15u;
        // The finest tile level holding the node's grid; above the top level
        // the vertices are every (1 << ts)-th texel of the top tile.
        int l = min(shift, u_top);
        ts = shift - l;
        int gi = int(x0) >> l, gj = int(z0) >> l;
        int tx = gi >> u_tile_shift, tz = gj >> u_tile_shift;
        int m = ((u_map - 1) >> l) >> u_tile_shift; // tiles per side at level l
        lv = l;
        lm = m;
        lbase = u_base[l];
        layer = lbase + tz * m + tx;
        ox = gi - (tx << u_tile_shift);
        oz = gj - (tz << u_tile_shift);
    }
    uvec2 slide = STREAM != 0 ? a_slide : uvec2(0u); // in memory no tile arrives late
    // Stitching: odd vertices of an edge toward a coarser neighbour collapse
    // onto the even vertex before them (hz_lod_patches_to_indices does the same).
    if ((u & 1) == 1 && ((w == 0 && (coarse & 4u) != 0u) || (w == u_size && (coarse & 8u) != 0u)))
        u -= 1;
    if ((w & 1) == 1 && ((u == 0 && (coarse & 1u) != 0u) || (u == u_size && (coarse & 2u) != 0u)))
        w -= 1;
    uvec4 t = tile_fetch(ivec2(ox + (u << ts) + STREAM, oz + (w << ts) + STREAM), layer);
    int i = int(x0) + (u << shift), j = int(z0) + (w << shift);
    float h = u_hoffset + u_hscale * float(t.r);
    vec3 p = vec3(float(i) * u_spacing, h, float(j) * u_spacing);
    ivec2 org = ivec2(int(x0), int(z0)) - (ivec2(ox, oz) << shift);
    float nm = float(slide.x & 255u) / 255.0; // how far the normal leans to the parent level's
    bool odd = ((u | w) & 1) == 1;
    ivec2 a = ivec2(i, j), b = ivec2(i, j); // an odd vertex: the two it collapses between
    float mc = 0.0; // the colour's morph (VLIT)
    if (MORPH && u_morph_scale > 0.0) {
        float m = morph_factor(t, p);
        // A tile that just arrived slides in: the vertices this level adds
        // (odd u or w) start at their parent's shape. Along an edge the value
        // both patches of this level share, so the edge never opens.
        if (((u | w) & 1) == 1 && (slide.x | slide.y) != 0u) {
            uint s = slide.x & 255u;
            if (u == 0)
                s = (slide.x >> 8) & 255u;
            else if (u == u_size)
                s = (slide.x >> 16) & 255u;
            else if (w == 0)
                s = slide.x >> 24;
            else if (w == u_size)
                s = slide.y & 255u;
            m = max(m, float(s) / 255.0);
        }
        if (odd)
            nm = m;
        mc = m;
        if (m > 0.0) {
            // Toward the midpoint of the two neighbours it collapses between,
            // each as drawn (morphed one level itself).
            int bi = low_bit(i), bj = low_bit(j);
            if (bi == bj) {
                int s = bi;
                // i - s and j - s are multiples of 2s: the parities of their
                // quotients by 2s are their bits 2s
                bool main_diag = (((i - s) ^ (j - s)) & (2 * s)) == 0;
                a = ivec2(i - s, main_diag ? j - s : j + s);
                b = ivec2(i + s, main_diag ? j + s : j - s);
            } else if (bi < bj) {
                a = ivec2(i - bi, j);
                b = ivec2(i + bi, j);
            } else {
                a = ivec2(i, j - bj);
                b = ivec2(i, j + bj);
            }
            if (STREAM == 0 && SIMPLE) {
                p.y = mix(h, target_of(t), m);
            } else if (STREAM == 0) {
                p.y = mix(h, 0.5 * (morph1_texel(level_texel(a, lv, lm, lbase), a.x, a.y) +
                                    morph1_texel(level_texel(b, lv, lm, lbase), b.x, b.y)), m);
            } else {
                uvec4 ta, tb;
                // A tile's corners have their neighbours outside it: there the
                // target is the midpoint of the unmorphed neighbours.
                // Next to a sample without data the target is the vertex itself
                // (the CPU wrote it so): the fill height is no shape.
                if (tile_texel(a.x, a.y, org, shift, layer, ta) && tile_texel(b.x, b.y, org, shift, layer, tb) &&
                    ((ta.a | tb.a) & 2u) == 0u)
                    p.y = mix(h, 0.5 * (morph1_texel(ta, a.x, a.y) + morph1_texel(tb, b.x, b.y)), m);
                else
                    p.y = mix(h, target_of(t), m);
            }
        }
    }
    if (STREAM != 0) {
        // No full-resolution normal map: the normal of the heights at this level.
        int st = 1 << shift;
        float hw = stream_h(i - st, j, org, shift, layer), he = stream_h(i + st, j, org, shift, layer);
        float hn = stream_h(i, j - st, org, shift, layer), hs = stream_h(i, j + st, org, shift, layer);
        v_normal = normalize(vec3(-(he - hw) / (2.0 * float(st) * u_spacing), 1.0,
                                  -(hs - hn) / (2.0 * float(st) * u_spacing)));
        if (nm > 0.0) { // morphing or sliding in: toward the parent level's normal, as it draws it
            vec3 n2 = odd ? normalize(coarse_normal(a.x, a.y, org, shift, layer) + coarse_normal(b.x, b.y, org, shift, layer))
                          : coarse_normal(i, j, org, shift, layer);
            v_normal = normalize(mix(v_normal, n2, nm));
        }
    } else {
        v_normal = vec3(0.0, 1.0, 0.0); // the fragment shader takes normals from the normal map
    }
    // Over missing data (FX_VARIANT_MASK, bit 20): a triangle with a vertex
    // without data is clipped away where its data share falls below 0.999,
    // which leaves nothing of it but slivers under a thousandth of its
    // height. Clipped here, not discarded per fragment: a shader that may
    // discard loses llvmpipe's early depth test for every patch.
#if (FX_VARIANT & 1048576) != 0
    gl_ClipDistance[0] = ((t.a & 2u) != 0u ? 0.0 : 1.0) - 0.999;
#endif
#if (FX_VARIANT & 67108864) != 0
    vec3 dv = hz_curve(vec3(p.x, h, p.z)) - u_eye;
    if (FINE) {
        v_lit = textureLod(u_lit, (vec2(i, j) + 0.5) / float(u_map), lit_lod(ivec2(i, j), dv)).rgb;
    } else {
        // Morphing, the colour moves as the height does: toward the midpoint
        // of the two samples the vertex collapses between (a = b = the vertex
        // when it does not morph).
        float lod = log2(max(length(dv) * u_lit_lod, 1.0));
        v_lit = lit_at(ivec2(i, j), lod);
        if (MORPH && mc > 0.0)
            v_lit = mix(v_lit, 0.5 * (lit_at(a, lod) + lit_at(b, lod)), mc);
    }
#endif
    v_world = p;
    v_fog = exp(-u_fog_density * length(p - u_eye));
    gl_Position = u_viewproj * vec4(hz_curve(p), 1.0);
}
