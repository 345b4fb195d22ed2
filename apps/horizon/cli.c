#include "cli.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "horizon/gl_limits.h"
#include "horizon/safety.h"

/* A macro's value as a string literal (for bounds in messages). */
#define STR_(x) #x
#define STR(x) STR_(x)

bool cli_parse_float(const char *s, double lo, double hi, float *out)
{
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    /* NOTE: compared in double: a float bound (0.8f = 0.800000012) would
     * refuse the documented value itself. ERANGE on an underflow (1e-400)
     * is a refusal too. */
    if (errno || end == s || *end || !isfinite(v) || v < lo || v > hi)
        return false;
    *out = (float)v;
    return true;
}

bool cli_parse_water_level(const char *s, int *mode, float *level)
{
    if (!strcmp(s, "auto"))
        *mode = 0;
    else if (!strcmp(s, "off"))
        *mode = 1;
    else if (cli_parse_float(s, -1e5, 1e5, level))
        *mode = 2;
    else
        return false;
    return true;
}

int cli_split(char *s, char **items, int cap)
{
    int n = 0;
    for (char *p = s;;) {
        char *comma = strchr(p, ',');
        if (comma)
            *comma = 0;
        if (!*p || n == cap)
            return -1;
        items[n++] = p;
        if (!comma)
            return n;
        p = comma + 1;
    }
}

bool cli_parse_u32(const char *s, uint32_t lo, uint32_t hi, uint32_t *out)
{
    char *end;
    errno = 0;
    unsigned long long v = strtoull(s, &end, 10);
    if (errno || end == s || *end || s[0] == '-' || v < lo || v > hi)
        return false;
    *out = (uint32_t)v;
    return true;
}

void cli_usage_terrain(void)
{
    fprintf(stderr,
            "terrain:\n"
            "  --dem PATH              any raster GDAL reads (GeoTIFF, SRTM .hgt/.hgt.zip, ENVI, ASCII grid,\n"
            "                          VRT), 16-bit/8-bit or Terrarium PNG, .r16, .r32 (also .gz); repeat it\n"
            "                          or give a folder to mosaic several files into one terrain\n"
            "  --crs EPSG:N            metric CRS for geographic DEMs (default: UTM zone of the centre)\n"
            "  --voids hole|fill       nodata inside the DEM: not drawn (default) or drawn filled\n"
            "  --format png|terrarium|hgt|r16|r32|gdal   override detection from the file name\n"
            "  --units m|ft|dm|raw     height units of PNG/raw values (default: from the name, else m)\n"
            "  --raw-size W[xH]        raw .r16/.r32 dimensions (default: square from the file size)\n"
            "  --generate perlin|diamond  generated terrain (default perlin when no --dem)\n"
            "  --size N                generated size, 2^n+1 (default 4097)\n"
            "  --seed S                generator seed (default 1)\n"
            "  --amplitude M           generated relief in metres (default 1800)\n"
            "  --fit auto|crop|pad|nearest|refuse  non-2^n+1 DEMs (default auto: every sample shown,\n"
            "                          padded to 2^n+1 and the padding not drawn)\n"
            "  --layout blocked|linear heightmap memory layout (default blocked 32x32)\n"
            "  --spacing M             metres between samples (default: the DEM's georeference, else from\n"
            "                          the name, SRTM 90/30, generated 10); georeferenced DEMs are resampled\n"
            "  --zscale Z              height multiplier (default 1)\n"
            "  --height-range MIN,MAX  normalised DEM: the sample type's range (0..65535 for 16-bit)\n"
            "                          becomes MIN..MAX metres\n"
            "  --height-offset M       metres added to every height (default 0)\n"
            "  --max-memory SIZE       refuse terrains needing more (e.g. 8G; default half the RAM)\n"
            "LOD:\n"
            "  --lod MODE              cdlod (default, 1 px), quadtree, remedy, bidirectional or roam\n"
            "  --pixel-error TAU       screen-space error bound in pixels (roam and cdlod: default 1;\n"
            "                          quadtree, remedy, bidirectional: replaces C and C2)\n"
            "  --near-pixel-error TAU  cdlod: a looser bound near the eye: TAU within --near-error-distance,\n"
            "                          falling as 1/sqrt(distance) to --pixel-error (default: off)\n"
            "  --near-error-distance M cdlod: where the near bound starts to tighten (default 500 m)\n"
            "  --lod-c C --lod-c2 C2   distance and roughness factors (default 25, 2.5)\n"
            "  --criterion clamped|unclamped  Roettger's clamped form (default) or the seed's\n"
            "  --no-cull               disable frustum culling (and horizon culling)\n"
            "  --horizon-cull          cdlod: drop the patches that nearer ground hides\n"
            "  --bidir-distance M      bidirectional: coarsen beyond M metres, split nearer (default far/4)\n"
            "  --roam-budget N         roam: at most N triangles (default: no budget)\n"
            "  --morph-start A         cdlod: morphing starts at this fraction of a range, " STR(HZ_LOD_MORPH_START_MIN)
            ".." STR(HZ_LOD_MORPH_START_MAX) " (" STR(HZ_LOD_MORPH_START_DEFAULT) ")\n"
            "  --patch-cells N         cdlod: grid cells per side of the patch each node draws (default 8)\n"
            "view:\n"
            "  --camera X,Y,Z,YAW,PITCH  metres and degrees (default: above the centre)\n"
            "  --fov DEG               vertical field of view (default 60)\n"
            "  --far M                 view distance in metres (default 1.5 x map side)\n"
            "  --near M                near clip plane in metres (default 0.25)\n"
            "  --curvature on|off|auto Earth curvature: the ground drops d^2/2R with the distance d\n"
            "                          (default auto: on for terrains wider than 50 km; R of the WGS84\n"
            "                          ellipsoid at a georeferenced DEM's centre, else 6371008.8 m)\n"
            "  --width W --height H    image size (default 1280x720)\n"
            "effects:\n"
            "  --effects LIST          sky, flare, shadows, detail, billboards, fog, water, weather,\n"
            "                          motionblur, bloom; all, none, default; -NAME removes one\n"
            "                          (default: all but weather and motionblur)\n"
            "  --lit-map on|off|vertex|pixel\n"
            "                          without terrain effects, read the terrain's colour from a map lit\n"
            "                          per sample (baked again when the sun changes; default on: per\n"
            "                          vertex where cdlod patches have one on every sample and the map\n"
            "                          is smooth, else per pixel), shade every pixel (off), read it per\n"
            "                          vertex of every patch (vertex: cheaper, less detail) or per pixel\n"
            "                          of every patch (pixel)\n"
            "  --sun AZ,EL             sun azimuth (clockwise from north) and elevation, degrees\n"
            "                          (default 245,30: west-south-west, afternoon)\n"
            "  --time S                effect time in seconds: clouds, waves, weather (default 0)\n"
            "  --clouds C              cloud cover 0..1 (default 0.45; 0 clear)\n"
            "  --wind SPEED,DIR        m/s and the direction it blows toward, degrees from north\n"
            "                          (default 6.7,63)\n"
            "  --weather rain|snow     kind of weather (with the weather effect; default rain)\n"
            "  --weather-intensity X   particles x X (default 1)\n"
            "  --water-level M|auto|off  water plane height in metres (default auto: a sea at the\n"
            "                          lowest flat ground of a DEM, else lakes over the lowest 4 %%)\n"
            "  --fog D|off             exponential fog density per metre (default 3 / view distance;\n"
            "                          without --far at most 1.3e-4: 30 km visibility)\n"
            "  --height-fog D          height fog density per metre at the lowest ground (default 3 x fog)\n"
            "  --blur F                motion blur feedback 0..0.98 (default 0.5)\n"
            "  --exposure E --gamma G  output = (colour x E)^(1/G) (default 1, 1)\n"
            "  --bloom S               bloom strength (default 0.35)\n"
            "  --trees N               trees per hectare in forests (default 12; 0 none)\n"
            "  --climate KIND          ground colours, trees and lakes: auto (default: from a georeferenced\n"
            "                          DEM's place, else temperate), temperate, arid, steppe, tropical, polar\n"
            "  --latitude DEG          where a DEM without a georeference lies (snow and tree lines; default 45)\n"
            "  --colormap FILE.png     ground colours from an image over the whole map\n"
            "  --imagery FILE          drape an orthophoto (any GDAL raster: GeoTIFF, PNG/JPEG + world\n"
            "                          file, VRT) by its georeference\n"
            "  --imagery-max N         imagery texels per side over the whole map at most (8192)\n"
            "  --textures DIR          PNGs replacing the procedural textures: grass, rock, snow,\n"
            "                          sand (.png, square, power of two) and conifer, broadleaf,\n"
            "                          rain, snowflake (.png, with alpha); missing ones stay procedural\n");
}

static int bad(const char *cmd, const char *opt, const char *val, const char *want)
{
    fprintf(stderr, "horizon %s: invalid value '%s' for %s: expected %s\n", cmd, val ? val : "", opt, want);
    return 2;
}

int cli_unknown(const char *cmd, char **argv, int argc, int i)
{
    const char *a = argv[i];
    if (!strcmp(a, "--") && i + 1 < argc)
        fprintf(stderr, "horizon %s: unexpected argument '%s' after -- (see horizon %s --help)\n", cmd, argv[i + 1],
                cmd);
    else if (a[0] != '-')
        fprintf(stderr, "horizon %s: unexpected argument '%s': options start with -- (see horizon %s --help)\n", cmd,
                a, cmd);
    else
        fprintf(stderr, "horizon %s: unknown option '%s' (see horizon %s --help)\n", cmd, a, cmd);
    return 2;
}

int cli_parse(int argc, char **argv, int first, cli_opts *o, const char *cmd)
{
    memset(o, 0, sizeof *o);
    o->width = 1280;
    o->height = 720;
    o->repeat = 20;
    o->terrain.seed = 1;
    o->forest_seed = 1;
    o->forest = (hz_forest_params){.simplify = true, .hysteresis = true, .enlarge = true, .node_culling = true};
    o->effects = HZ_FX_DEFAULT;
    /* cdlod at 1 px is the best measured mode on every row of the bench;
     * the seed's modes stay one --lod away. */
    o->lod.mode = HZ_LOD_CDLOD;
    int city_rc;
    for (int i = first; i < argc; i++) {
        const char *a = argv[i];
        const char *v = i + 1 < argc ? argv[i + 1] : NULL;
#define NEEDV()                                                                         \
    do {                                                                                \
        if (!v) {                                                                       \
            fprintf(stderr, "horizon %s: option %s needs a value\n", cmd, a);           \
            return 2;                                                                   \
        }                                                                               \
        i++;                                                                            \
    } while (0)
        if (!strcmp(a, "--dem")) {
            NEEDV();
            if (o->dem_count >= CLI_MAX_DEMS) {
                fprintf(stderr, "horizon %s: more than %u --dem; pass their folder instead\n", cmd, CLI_MAX_DEMS);
                return 2;
            }
            o->dems[o->dem_count++] = v;
            o->terrain.dem_path = o->dems[0];
            o->terrain.dem_paths = o->dem_count > 1 ? o->dems : NULL;
            o->terrain.dem_path_count = o->dem_count > 1 ? o->dem_count : 0;
        } else if (!strcmp(a, "--voids")) {
            NEEDV();
            if (!strcmp(v, "hole")) o->terrain.fill_voids = false;
            else if (!strcmp(v, "fill")) o->terrain.fill_voids = true;
            else return bad(cmd, a, v, "hole or fill");
        } else if (!strcmp(a, "--crs")) {
            NEEDV();
            o->terrain.crs = v;
        } else if (!strcmp(a, "--max-memory")) {
            NEEDV();
            if (!hz_size_parse(v, (uint64_t)1 << 20, (uint64_t)1 << 50, &o->terrain.max_memory))
                return bad(cmd, a, v, "a size like 512M, 8G or 1.5T, in [1M, 1024T]");
        } else if (!strcmp(a, "--format")) {
            NEEDV();
            if (!hz_dem_format_parse(v, &o->terrain.format))
                return bad(cmd, a, v, "png, terrarium, hgt, r16, r32 or gdal");
        } else if (!strcmp(a, "--units")) {
            NEEDV();
            if (!strcmp(v, "m")) o->terrain.units = HZ_UNITS_M;
            else if (!strcmp(v, "ft")) o->terrain.units = HZ_UNITS_FT;
            else if (!strcmp(v, "dm")) o->terrain.units = HZ_UNITS_DM;
            else if (!strcmp(v, "raw")) o->terrain.units = HZ_UNITS_RAW;
            else return bad(cmd, a, v, "m, ft, dm or raw");
        } else if (!strcmp(a, "--raw-size")) {
            NEEDV();
            char buf[64];
            if (snprintf(buf, sizeof buf, "%s", v) >= (int)sizeof buf)
                return bad(cmd, a, v, "a shorter value");
            char *x = strchr(buf, 'x');
            if (x)
                *x = 0;
            if (!cli_parse_u32(buf, 2, 65537, &o->terrain.raw_width) ||
                (x && !cli_parse_u32(x + 1, 2, 65537, &o->terrain.raw_height)))
                return bad(cmd, a, v, "W or WxH, sides in [2, 65537]");
        } else if (!strcmp(a, "--generate")) {
            NEEDV();
            if (!hz_gen_kind_parse(v, &o->terrain.generate))
                return bad(cmd, a, v, "perlin or diamond");
        } else if (!strcmp(a, "--size")) {
            NEEDV();
            if (!cli_parse_u32(v, 3, 16385, &o->terrain.gen_size) || !hz_is_pow2_plus1(o->terrain.gen_size))
                return bad(cmd, a, v, "2^n+1 in [3, 16385] (e.g. 1025, 2049, 4097)");
        } else if (!strcmp(a, "--seed")) {
            NEEDV();
            char *end;
            errno = 0;
            o->terrain.seed = strtoull(v, &end, 10);
            if (errno || *end || end == v || v[0] == '-')
                return bad(cmd, a, v, "a non-negative integer");
        } else if (!strcmp(a, "--amplitude")) {
            NEEDV();
            if (!cli_parse_float(v, 0.001, 100000, &o->terrain.amplitude))
                return bad(cmd, a, v, "metres in [0.001, 100000]");
        } else if (!strcmp(a, "--fit")) {
            NEEDV();
            if (!strcmp(v, "auto")) o->terrain.fit = HZ_FIT_AUTO;
            else if (!strcmp(v, "crop")) o->terrain.fit = HZ_FIT_CROP;
            else if (!strcmp(v, "pad")) o->terrain.fit = HZ_FIT_PAD;
            else if (!strcmp(v, "refuse")) o->terrain.fit = HZ_FIT_REFUSE;
            else if (!strcmp(v, "nearest")) o->terrain.fit = HZ_FIT_NEAREST;
            else return bad(cmd, a, v, "auto, crop, pad, nearest or refuse");
        } else if (!strcmp(a, "--layout")) {
            NEEDV();
            if (!strcmp(v, "blocked")) o->terrain.layout = HZ_LAYOUT_BLOCKED;
            else if (!strcmp(v, "linear")) o->terrain.layout = HZ_LAYOUT_LINEAR;
            else return bad(cmd, a, v, "blocked or linear");
        } else if (!strcmp(a, "--spacing")) {
            NEEDV();
            if (!cli_parse_float(v, 0.001, 100000, &o->terrain.spacing))
                return bad(cmd, a, v, "metres in [0.001, 100000]");
        } else if (!strcmp(a, "--zscale")) {
            NEEDV();
            if (!cli_parse_float(v, 0.0001, 10000, &o->terrain.zscale))
                return bad(cmd, a, v, "a number in [0.0001, 10000]");
        } else if (!strcmp(a, "--height-range")) {
            NEEDV();
            char buf[128], *it[2];
            if (snprintf(buf, sizeof buf, "%s", v) >= (int)sizeof buf)
                return bad(cmd, a, v, "a shorter value");
            if (cli_split(buf, it, 2) != 2 || !cli_parse_float(it[0], -1e5, 1e5, &o->terrain.height_min) ||
                !cli_parse_float(it[1], -1e5, 1e5, &o->terrain.height_max) ||
                !(o->terrain.height_min < o->terrain.height_max))
                return bad(cmd, a, v, "MIN,MAX in metres, each in [-1e5, 1e5], MIN below MAX");
        } else if (!strcmp(a, "--height-offset")) {
            NEEDV();
            if (!cli_parse_float(v, -1e5, 1e5, &o->terrain.height_offset))
                return bad(cmd, a, v, "metres in [-1e5, 1e5]");
        } else if (!strcmp(a, "--lod-c")) {
            NEEDV();
            if (!cli_parse_float(v, 0.01, 100000, &o->lod.c))
                return bad(cmd, a, v, "a number in [0.01, 100000]");
        } else if (!strcmp(a, "--lod-c2")) {
            NEEDV();
            if (!cli_parse_float(v, 0.01, 100000, &o->lod.c2))
                return bad(cmd, a, v, "a number in [0.01, 100000]");
        } else if (!strcmp(a, "--criterion")) {
            NEEDV();
            if (!strcmp(v, "clamped")) o->lod.criterion = HZ_LOD_CLAMPED;
            else if (!strcmp(v, "unclamped")) o->lod.criterion = HZ_LOD_UNCLAMPED;
            else return bad(cmd, a, v, "clamped or unclamped");
        } else if (!strcmp(a, "--no-cull")) {
            o->lod.no_cull = true;
        } else if (!strcmp(a, "--horizon-cull")) {
            o->lod.horizon_cull = true;
        } else if (!strcmp(a, "--lod")) {
            NEEDV();
            if (!hz_lod_mode_from_name(v, &o->lod.mode))
                return bad(cmd, a, v, "quadtree, remedy, bidirectional, roam or cdlod");
        } else if (!strcmp(a, "--pixel-error")) {
            NEEDV();
            if (!cli_parse_float(v, 0.01, 1000, &o->lod.pixel_error))
                return bad(cmd, a, v, "pixels in [0.01, 1000]");
        } else if (!strcmp(a, "--near-pixel-error")) {
            NEEDV();
            if (!cli_parse_float(v, 0.01, 1000, &o->lod.near_pixel_error))
                return bad(cmd, a, v, "pixels in [0.01, 1000]");
        } else if (!strcmp(a, "--near-error-distance")) {
            NEEDV();
            if (!cli_parse_float(v, 0.001, 1e8, &o->lod.near_distance))
                return bad(cmd, a, v, "metres in [0.001, 1e8]");
        } else if (!strcmp(a, "--bidir-distance")) {
            NEEDV();
            if (!cli_parse_float(v, 0.001, 1e8, &o->lod.bidir_distance))
                return bad(cmd, a, v, "metres in [0.001, 1e8]");
        } else if (!strcmp(a, "--roam-budget")) {
            NEEDV();
            if (!cli_parse_u32(v, 16, 100000000, &o->lod.roam_budget))
                return bad(cmd, a, v, "triangles in [16, 100000000]");
        } else if (!strcmp(a, "--patch-cells")) {
            NEEDV();
            if (!cli_parse_u32(v, 2, 256, &o->terrain.patch_cells) ||
                (o->terrain.patch_cells & (o->terrain.patch_cells - 1)))
                return bad(cmd, a, v, "a power of two in [2, 256]");
        } else if (!strcmp(a, "--morph-start")) {
            NEEDV();
            if (!cli_parse_float(v, HZ_LOD_MORPH_START_MIN, HZ_LOD_MORPH_START_MAX, &o->lod.morph_start))
                return bad(cmd, a, v,
                           "a fraction in [" STR(HZ_LOD_MORPH_START_MIN) ", " STR(HZ_LOD_MORPH_START_MAX) "]");
        } else if (!strcmp(a, "--camera")) {
            NEEDV();
            char buf[256], *it[5];
            if (snprintf(buf, sizeof buf, "%s", v) >= (int)sizeof buf)
                return bad(cmd, a, v, "a shorter value");
            bool ok = cli_split(buf, it, 5) == 5;
            for (int k = 0; ok && k < 5; k++)
                ok = cli_parse_float(it[k], -1e7, 1e7, &o->camera[k]);
            if (!ok)
                return bad(cmd, a, v, "X,Y,Z,YAW,PITCH (metres and degrees, each in [-1e7, 1e7])");
            o->have_camera = true;
        } else if (!strcmp(a, "--fov")) {
            NEEDV();
            if (!cli_parse_float(v, 1, 170, &o->fov))
                return bad(cmd, a, v, "degrees in [1, 170]");
        } else if (!strcmp(a, "--near")) {
            NEEDV();
            if (!cli_parse_float(v, 0.001, 100000, &o->near))
                return bad(cmd, a, v, "metres in [0.001, 100000]");
        } else if (!strcmp(a, "--far")) {
            NEEDV();
            if (!cli_parse_float(v, 1, 1e8, &o->far))
                return bad(cmd, a, v, "metres in [1, 1e8]");
        } else if (!strcmp(a, "--width")) {
            NEEDV();
            if (!cli_parse_u32(v, 16, 8192, &o->width))
                return bad(cmd, a, v, "pixels in [16, 8192]");
        } else if (!strcmp(a, "--height")) {
            NEEDV();
            if (!cli_parse_u32(v, 16, 8192, &o->height))
                return bad(cmd, a, v, "pixels in [16, 8192]");
        } else if (!strcmp(a, "--out")) {
            NEEDV();
            o->out = v;
        } else if (!strcmp(a, "--dump-mesh")) {
            NEEDV();
            o->dump_mesh = v;
        } else if (!strcmp(a, "--repeat")) {
            NEEDV();
            if (!cli_parse_u32(v, 1, 100000, &o->repeat))
                return bad(cmd, a, v, "a count in [1, 100000]");
        } else if (!strcmp(a, "--forest")) {
            NEEDV();
            if (!cli_parse_u32(v, 1, 1000000, &o->forest_n))
                return bad(cmd, a, v, "a tree count in [1, 1000000]");
        } else if (!strcmp(a, "--forest-file")) {
            NEEDV();
            o->forest_file = v;
            if (!o->forest_n)
                o->forest_n = 1; /* the real count comes from the file */
        } else if (!strcmp(a, "--forest-save")) {
            NEEDV();
            o->forest_save = v;
        } else if (!strcmp(a, "--forest-trees")) {
            NEEDV();
            o->forest_trees = v;
        } else if (!strcmp(a, "--tree-cache")) {
            NEEDV();
            o->tree_cache = v;
        } else if (!strcmp(a, "--forest-leaves")) {
            NEEDV();
            if (!cli_parse_u32(v, 16, 2000000, &o->forest_leaves))
                return bad(cmd, a, v, "leaves per tree in [16, 2000000]");
        } else if (!strcmp(a, "--forest-density")) {
            NEEDV();
            if (!cli_parse_float(v, 1, 10000, &o->forest_density))
                return bad(cmd, a, v, "trees per hectare in [1, 10000]");
        } else if (!strcmp(a, "--forest-at")) {
            NEEDV();
            char buf[128], *it[2];
            if (snprintf(buf, sizeof buf, "%s", v) >= (int)sizeof buf)
                return bad(cmd, a, v, "a shorter value");
            if (cli_split(buf, it, 2) != 2 || !cli_parse_float(it[0], -1e7, 1e7, &o->forest_at[0]) ||
                !cli_parse_float(it[1], -1e7, 1e7, &o->forest_at[1]))
                return bad(cmd, a, v, "X,Z in metres, each in [-1e7, 1e7]");
            o->forest_at_set = true;
        } else if (!strcmp(a, "--forest-seed")) {
            NEEDV();
            char *end;
            errno = 0;
            o->forest_seed = strtoull(v, &end, 10);
            if (errno || *end || end == v || v[0] == '-')
                return bad(cmd, a, v, "a non-negative integer");
        } else if (!strcmp(a, "--no-simplify")) {
            o->forest.simplify = false;
        } else if (!strcmp(a, "--no-hysteresis")) {
            o->forest.hysteresis = false;
        } else if (!strcmp(a, "--no-enlarge")) {
            o->forest.enlarge = false;
        } else if (!strcmp(a, "--no-node-cull")) {
            o->forest.node_culling = false;
        } else if (!strcmp(a, "--tree-near")) {
            NEEDV();
            if (!cli_parse_float(v, 0.01, 100000, &o->forest.rate.near_m))
                return bad(cmd, a, v, "metres in [0.01, 100000]");
        } else if (!strcmp(a, "--tree-far")) {
            NEEDV();
            if (!cli_parse_float(v, 0.1, 1000000, &o->forest.rate.far_m))
                return bad(cmd, a, v, "metres in [0.1, 1000000]");
        } else if (!strcmp(a, "--hull-dist")) {
            NEEDV();
            if (!cli_parse_float(v, 0.1, 1000000, &o->forest.hull_dist))
                return bad(cmd, a, v, "metres in [0.1, 1000000]");
        } else if (!strcmp(a, "--rate-weights")) {
            NEEDV();
            char buf[256], *it[5];
            if (snprintf(buf, sizeof buf, "%s", v) >= (int)sizeof buf)
                return bad(cmd, a, v, "a shorter value");
            bool ok = cli_split(buf, it, 5) == 5;
            for (int k = 0; ok && k < 5; k++)
                ok = cli_parse_float(it[k], 0, 10, &o->forest.rate.w[k]);
            if (!ok)
                return bad(cmd, a, v, "five weights W1,..,W5 in [0, 10]");
        } else if (!strcmp(a, "--effects")) {
            NEEDV();
            hz_err e = {0};
            if (hz_fx_parse(v, &o->effects, &e) != HZ_OK) {
                fprintf(stderr, "horizon %s: %s\n", cmd, e.msg);
                return 2;
            }
        } else if (!strcmp(a, "--sun")) {
            NEEDV();
            char buf[128], *it[2];
            if (snprintf(buf, sizeof buf, "%s", v) >= (int)sizeof buf)
                return bad(cmd, a, v, "a shorter value");
            if (cli_split(buf, it, 2) != 2 || !cli_parse_float(it[0], -360, 720, &o->sun[0]) ||
                !cli_parse_float(it[1], -90, 90, &o->sun[1]))
                return bad(cmd, a, v, "AZIMUTH,ELEVATION in degrees (e.g. 245,30; azimuth in [-360, 720], elevation in [-90, 90])");
            o->have_sun = true;
        } else if (!strcmp(a, "--time")) {
            NEEDV();
            float t;
            if (!cli_parse_float(v, 0, 1e7, &t))
                return bad(cmd, a, v, "seconds in [0, 1e7]");
            o->time = t;
        } else if (!strcmp(a, "--clouds")) {
            NEEDV();
            if (!cli_parse_float(v, 0, 1, &o->fx.cloud_cover))
                return bad(cmd, a, v, "a cover in [0, 1]");
            if (o->fx.cloud_cover == 0.0f)
                o->fx.cloud_cover = -1.0f; /* clear sky (0 means default) */
        } else if (!strcmp(a, "--wind")) {
            NEEDV();
            char buf[128], *it[2];
            if (snprintf(buf, sizeof buf, "%s", v) >= (int)sizeof buf)
                return bad(cmd, a, v, "a shorter value");
            float speed, deg;
            if (cli_split(buf, it, 2) != 2 || !cli_parse_float(it[0], 0, 100, &speed) ||
                !cli_parse_float(it[1], -360, 720, &deg))
                return bad(cmd, a, v, "SPEED,DIRECTION (m/s in [0, 100], degrees in [-360, 720])");
            /* 0 means default: a calm wind is a tiny one. */
            speed = speed > 0.001f ? speed : 0.001f;
            o->fx.wind[0] = speed * sinf(glm_rad(deg));
            o->fx.wind[1] = -speed * cosf(glm_rad(deg));
        } else if (!strcmp(a, "--weather")) {
            NEEDV();
            if (!strcmp(v, "rain")) o->fx.weather = HZ_WEATHER_RAIN;
            else if (!strcmp(v, "snow")) o->fx.weather = HZ_WEATHER_SNOW;
            else return bad(cmd, a, v, "rain or snow");
        } else if (!strcmp(a, "--weather-intensity")) {
            NEEDV();
            if (!cli_parse_float(v, 0.01, 8, &o->fx.weather_intensity))
                return bad(cmd, a, v, "a factor in [0.01, 8]");
        } else if (!strcmp(a, "--water-level")) {
            NEEDV();
            if (!cli_parse_water_level(v, &o->water_mode, &o->water_level))
                return bad(cmd, a, v, "metres, auto or off");
        } else if (!strcmp(a, "--fog")) {
            NEEDV();
            if (!strcmp(v, "off")) o->fog = -1.0f;
            else if (!cli_parse_float(v, 0, 1, &o->fog)) return bad(cmd, a, v, "a density per metre in [0, 1] or off");
            else if (o->fog == 0.0f) o->fog = -1.0f;
        } else if (!strcmp(a, "--height-fog")) {
            NEEDV();
            if (!cli_parse_float(v, 0, 1, &o->fx.height_fog))
                return bad(cmd, a, v, "a density per metre in [0, 1]");
            if (o->fx.height_fog == 0.0f)
                o->fx.height_fog = -1.0f;
        } else if (!strcmp(a, "--blur")) {
            NEEDV();
            if (!cli_parse_float(v, 0.001, 0.98, &o->fx.blur))
                return bad(cmd, a, v, "a feedback factor in [0.001, 0.98]");
        } else if (!strcmp(a, "--exposure")) {
            NEEDV();
            if (!cli_parse_float(v, 0.01, 100, &o->fx.exposure))
                return bad(cmd, a, v, "a factor in [0.01, 100]");
        } else if (!strcmp(a, "--gamma")) {
            NEEDV();
            if (!cli_parse_float(v, 0.1, 10, &o->fx.gamma))
                return bad(cmd, a, v, "a gamma in [0.1, 10]");
        } else if (!strcmp(a, "--bloom")) {
            NEEDV();
            if (!cli_parse_float(v, 0.001, 10, &o->fx.bloom_strength))
                return bad(cmd, a, v, "a strength in [0.001, 10]");
        } else if (!strcmp(a, "--trees")) {
            NEEDV();
            if (!cli_parse_float(v, 0, 1000, &o->trees))
                return bad(cmd, a, v, "trees per hectare in [0, 1000]");
            if (o->trees == 0.0f)
                o->trees = -1.0f;
        } else if (!strcmp(a, "--climate")) {
            NEEDV();
            if (!hz_climate_parse(v, &o->climate))
                return bad(cmd, a, v, "auto, temperate, arid, steppe, tropical or polar");
        } else if (!strcmp(a, "--latitude")) {
            NEEDV();
            if (!cli_parse_float(v, -90, 90, &o->latitude))
                return bad(cmd, a, v, "degrees in [-90, 90]");
            o->have_latitude = true;
        } else if (!strcmp(a, "--curvature")) {
            NEEDV();
            if (!curv_cli_parse(v, &o->curv.mode))
                return bad(cmd, a, v, "on, off or auto");
        } else if (!strcmp(a, "--colormap")) {
            NEEDV();
            o->colormap = v;
        } else if (!strcmp(a, "--imagery")) {
            NEEDV();
            o->imagery = v;
        } else if (!strcmp(a, "--imagery-max")) {
            NEEDV();
            if (!cli_parse_u32(v, 64, HZ_IMAGERY_MAX_SIDE, &o->imagery_max))
                return bad(cmd, a, v, "texels per side in [64, 32768]");
        } else if (!strcmp(a, "--textures")) {
            NEEDV();
            o->textures = v;
        } else if (!strcmp(a, "--json")) {
            o->json = true;
        } else if (!strcmp(a, "--wireframe")) {
            o->wireframe = true;
        } else if (!strcmp(a, "--lit-map")) {
            NEEDV();
            if (strcmp(v, "on") && strcmp(v, "off") && strcmp(v, "vertex") && strcmp(v, "pixel"))
                return bad(cmd, a, v, "on, off, vertex or pixel");
            o->no_lit_map = !strcmp(v, "off");
            o->lit_per_vertex = !strcmp(v, "vertex");
            o->lit_pixel = !strcmp(v, "pixel");
        } else if (!strcmp(a, "--quiet") || !strcmp(a, "-q")) {
            o->quiet = true;
        } else if ((city_rc = city_cli_option(&o->city, a, v, cmd, &i)) >= 0) {
            if (city_rc)
                return city_rc;
        } else {
            return cli_unknown(cmd, argv, argc, i);
        }
#undef NEEDV
    }
    if (o->forest.rate.near_m > 0 && o->forest.rate.far_m > 0 && o->forest.rate.far_m <= o->forest.rate.near_m) {
        fprintf(stderr, "horizon %s: --tree-far must be larger than --tree-near\n", cmd);
        return 2;
    }
    if (o->dem_count > 1) {
        o->terrain.dem_paths = o->dems;
        o->terrain.dem_path_count = o->dem_count;
    }
    if (o->forest_save && !o->forest_n) {
        fprintf(stderr, "horizon %s: --forest-save needs a forest (--forest N or --forest-file)\n", cmd);
        return 2;
    }
    if (o->terrain.dem_path && o->terrain.generate) {
        fprintf(stderr, "horizon %s: give either --dem or --generate, not both\n", cmd);
        return 2;
    }
    o->lod.viewport_height = o->height; /* pixel errors are measured at the target's height */
    return 0;
}

size_t cli_opts_inputs(const cli_opts *o, cli_file *ins, size_t n, size_t cap)
{
    const cli_file all[] = {{o->terrain.dem_path, "--dem", CLI_FILE},
                            {o->colormap, "--colormap", CLI_FILE},
                            {o->imagery, "--imagery", CLI_FILE},
                            {o->forest_file, "--forest-file", CLI_FILE},
                            {o->forest_trees, "--forest-trees", CLI_LIST},
                            {o->textures, "--textures", CLI_TEXTURES}};
    for (size_t k = 0; k < sizeof all / sizeof *all && n < cap; k++)
        if (all[k].path)
            ins[n++] = all[k];
    return n;
}

/* Calls fn on every file f names; stops at the first true. */
static bool each_file(const cli_file *f, bool (*fn)(const char *path, const void *user), const void *user,
                      const char **hit)
{
    if (!f->path)
        return false;
    if (f->kind == CLI_FILE) {
        *hit = f->path;
        return fn(f->path, user);
    }
    static char name[4200];
    if (f->kind == CLI_TEXTURES) {
        static const char *const tex[] = {"grass", "rock", "snow", "sand", "conifer", "broadleaf", "rain", "snowflake"};
        for (size_t k = 0; k < sizeof tex / sizeof *tex; k++) {
            snprintf(name, sizeof name, "%s/%s.png", f->path, tex[k]);
            *hit = name;
            if (fn(name, user))
                return true;
        }
        return false;
    }
    const char *p = f->path;
    while (*p) {
        const char *c = strchr(p, ',');
        size_t len = c ? (size_t)(c - p) : strlen(p);
        snprintf(name, sizeof name, "%.*s", (int)(len < sizeof name ? len : sizeof name - 1), p);
        *hit = name;
        if (len && fn(name, user))
            return true;
        p += len + (c != NULL);
    }
    return false;
}

static bool same_as(const char *path, const void *user)
{
    return hz_same_file(path, user);
}

int cli_check_outputs(const char *cmd, const cli_file *outs, size_t nout, const cli_file *ins, size_t nin)
{
    for (size_t a = 0; a < nout; a++) {
        if (!outs[a].path)
            continue;
        const char *hit = NULL;
        for (size_t b = 0; b < nin; b++)
            if (each_file(&ins[b], same_as, outs[a].path, &hit)) {
                fprintf(stderr,
                        "horizon %s: the output '%s' (%s) is the input '%s' (%s): refusing to overwrite it; "
                        "choose another output file\n",
                        cmd, outs[a].path, outs[a].opt, hit, ins[b].opt);
                return 2;
            }
        for (size_t b = 0; b < a; b++)
            if (outs[b].path && hz_same_file(outs[a].path, outs[b].path)) {
                fprintf(stderr, "horizon %s: %s and %s both write '%s': give them different files\n", cmd,
                        outs[b].opt, outs[a].opt, outs[a].path);
                return 2;
            }
    }
    return 0;
}

int cli_check_dir(const char *cmd, const char *opt, const char *dir)
{
    struct stat st;
    const char *why = stat(dir, &st) != 0          ? strerror(errno)
                      : !S_ISDIR(st.st_mode)       ? "not a folder"
                      : access(dir, W_OK | X_OK) ? strerror(errno)
                                                   : NULL;
    if (!why)
        return 0;
    fprintf(stderr, "horizon %s: cannot write into %s '%s': %s\n", cmd, opt, dir, why);
    return 1;
}

uint64_t cli_gpu_max_samples(void)
{
    hz_err err = {0};
    hz_gl *gl = hz_gl_create_headless(&err);
    if (!gl)
        return 0; /* reported when the renderer is created */
    uint64_t n = hz_gl_query_max_heightmap_samples();
    hz_gl_destroy(gl);
    return n;
}

hz_terrain *cli_load_terrain(const cli_opts *o)
{
    hz_err err = {0};
    hz_terrain_desc d = o->terrain;
    if (o->dem_count > 1)
        d.dem_paths = o->dems;
    /* The GPU's heightmap limit, checked before reading and preparing (a
     * 16385^2 terrain takes a minute and gigabytes before the upload would
     * refuse it). */
    if (!d.max_samples)
        d.max_samples = cli_gpu_max_samples();
    d.progress = o->quiet ? NULL : hz_progress_stderr;
    hz_terrain *t = hz_terrain_create(&d, &err);
    if (!t) {
        fprintf(stderr, "horizon: %s\n", err.msg);
        return NULL;
    }
    if (t->note[0] && !o->quiet)
        fprintf(stderr, "horizon: %s\n", t->note);
    if (t->voids_filled && !o->quiet)
        fprintf(stderr, "horizon: %llu nodata samples masked (not drawn; filled for the LOD bounds)\n",
                (unsigned long long)t->voids_filled);
    if (hz_lod_prepare(t->lod, o->lod.mode) != HZ_OK) {
        fprintf(stderr, "horizon: out of memory preparing the %s LOD data\n", hz_lod_mode_name(o->lod.mode));
        hz_terrain_destroy(t);
        return NULL;
    }
    return t;
}

void cli_georef_json(json_t *obj, const hz_terrain *t, const hz_camera *cam)
{
    if (!t->georef) {
        jx_set(obj, "crs", json_null());
        return;
    }
    const hz_georef *g = t->georef;
    double cx, cy, lon = 0, lat = 0;
    hz_georef_local_to_crs(g, cam->pos[0], cam->pos[2], &cx, &cy);
    bool ok = hz_georef_crs_to_lonlat(g, cx, cy, &lon, &lat, NULL) == HZ_OK;
    double o_lon = 0, o_lat = 0;
    bool ook = hz_georef_local_to_lonlat(g, 0, 0, &o_lon, &o_lat, NULL) == HZ_OK;
    jx_set(obj, "crs", jx_str(hz_georef_label(g)));
    jx_set(obj, "crs_name", jx_str(hz_georef_name(g)));
    jx_set(obj, "epsg", jx_int(hz_georef_epsg(g)));
    jx_set(obj, "camera_crs", json_pack("[ooo]", jx_fix(cx, 3), jx_fix(cy, 3), jx_fix(cam->pos[1], 3)));
    jx_set(obj, "camera_lonlat", ok ? json_pack("[oo]", jx_fix(lon, 8), jx_fix(lat, 8)) : json_null());
    double ox, oy;
    hz_georef_local_to_crs(g, 0, 0, &ox, &oy);
    jx_set(obj, "origin_crs", json_pack("[oo]", jx_fix(ox, 3), jx_fix(oy, 3)));
    if (ook)
        jx_set(obj, "origin_lonlat", json_pack("[oo]", jx_fix(o_lon, 8), jx_fix(o_lat, 8)));
}

void cli_print_georef_text(const hz_terrain *t, const hz_camera *cam)
{
    if (!t->georef)
        return;
    const hz_georef *g = t->georef;
    double cx, cy, lon = 0, lat = 0;
    hz_georef_local_to_crs(g, cam->pos[0], cam->pos[2], &cx, &cy);
    printf("camera CRS    %s (%s): %.1f, %.1f", hz_georef_label(g), hz_georef_name(g), cx, cy);
    if (hz_georef_crs_to_lonlat(g, cx, cy, &lon, &lat, NULL) == HZ_OK)
        printf("; lon %.6f, lat %.6f", lon, lat);
    printf("\n");
}

hz_result cli_renderer_morph(hz_renderer *r, hz_terrain *t, hz_lod_mode mode, hz_err *err)
{
    if (mode != HZ_LOD_CDLOD)
        return HZ_OK;
    return hz_renderer_set_cdlod(r, t->lod, t->valid, err);
}

/* Drops the frame's triangles touching nodata or padding (not drawn). */
static void mask_triangles(const hz_terrain *t, cli_lod_frame *f)
{
    if (!t->valid)
        return;
    const size_t before = f->il.count;
    f->il.count = hz_terrain_filter_triangles(t, f->il.data, f->il.count);
    f->masked = (before - f->il.count) / 3;
}

/* The late cull (on f->job). */
static void late_cull(void *arg)
{
    cli_lod_frame *f = arg;
    f->late_res = hz_lod_horizon_hide(f->lod, &f->cam, &f->params, &f->sel, f->pl.data, f->pl.count, f->from,
                                      f->hidden, f->blocks, &f->hs);
}

hz_result cli_lod_finish(cli_lod_frame *f)
{
    if (!f->late)
        return HZ_OK;
    hz_job_wait(&f->job);
    f->late = false;
    size_t w = 0; /* the patches as drawn */
    for (size_t k = 0; k < f->pl.count; k++) {
        if (f->hidden[k])
            continue;
        f->pl.data[w] = f->pl.data[k];
        f->pl.data[w++].hidden |= f->blocks[k];
    }
    f->pl.count = w;
    hz_lod_stats_hide(&f->st, &f->hs);
    f->cull_ms = f->hs.ms;
    return f->late_res;
}

hz_result cli_lod_select(hz_terrain *t, const hz_camera *cam, const hz_lod_params *p, cli_lod_frame *f)
{
    cli_lod_finish(f); /* (a frame drawn without it) */
    f->patches = p->mode == HZ_LOD_CDLOD;
    f->il.count = 0;
    f->pl.count = 0;
    f->masked = 0;
    f->cull_ms = 0.0;
    if (f->patches && f->late_ok && p->horizon_cull) {
        f->params = *p;
        f->params.horizon_cull = false;
        hz_result r = hz_lod_select_patches(t->lod, cam, &f->params, &f->pl, &f->st);
        if (r != HZ_OK)
            return r;
        if (f->pl.count > f->hidden_cap) {
            uint8_t *h = realloc(f->hidden, f->pl.count);
            if (h)
                f->hidden = h;
            uint16_t *b = realloc(f->blocks, f->pl.count * sizeof *b);
            if (b)
                f->blocks = b;
            if (!h || !b)
                return HZ_ERR_MEMORY;
            f->hidden_cap = f->pl.count;
        }
        f->lod = t->lod;
        f->cam = *cam;
        f->sel = f->st;
        f->from = hz_renderer_patch_lead((uint32_t)f->pl.count);
        f->hs = (hz_horizon_stats){0};
        f->late = true;
        hz_job_start(&f->job, late_cull, f);
        return HZ_OK;
    }
    if (f->patches)
        return hz_lod_select_patches(t->lod, cam, p, &f->pl, &f->st);
    hz_result r = hz_lod_select(t->lod, cam, p, &f->il, NULL, NULL, &f->st);
    if (r == HZ_OK)
        mask_triangles(t, f);
    return r;
}

void cli_lod_scene(cli_lod_frame *f, hz_scene_params *sp, const uint32_t **idx, uint32_t *count)
{
    cli_scene_lod(sp, &f->st);
    sp->patch_late_job = NULL;
    sp->patch_late_hidden = NULL;
    sp->patch_late_blocks = NULL;
    if (f->patches) {
        sp->patches = f->pl.data;
        sp->patch_count = (uint32_t)f->pl.count;
        if (f->late) {
            sp->patch_late_job = &f->job;
            sp->patch_late_hidden = f->hidden;
            sp->patch_late_blocks = f->blocks;
        }
        *idx = NULL;
        *count = 0;
    } else {
        sp->patches = NULL;
        sp->patch_count = 0;
        *idx = f->il.data;
        *count = (uint32_t)f->il.count;
    }
}

hz_result cli_lod_indices(hz_terrain *t, cli_lod_frame *f)
{
    if (!f->patches)
        return HZ_OK;
    f->il.count = 0;
    hz_result r = hz_lod_patches_to_indices(t->lod, f->pl.data, f->pl.count, &f->il);
    if (r == HZ_OK)
        mask_triangles(t, f); /* what the patch shader does not draw */
    return r;
}

void cli_lod_frame_free(cli_lod_frame *f)
{
    cli_lod_finish(f);
    free(f->hidden);
    free(f->blocks);
    free(f->il.data);
    free(f->pl.data);
    memset(f, 0, sizeof *f);
}

hz_result cli_renderer_setup(hz_renderer *r, hz_terrain *t, const cli_opts *o, hz_err *err)
{
    hz_result res = hz_renderer_set_heightmap(r, &t->hm, t->spacing, t->zscale, err);
    if (res == HZ_OK)
        res = hz_renderer_set_valid(r, t->valid, err);
    return res != HZ_OK ? res : cli_renderer_morph(r, t, o->lod.mode, err);
}

void cli_scene_lod(hz_scene_params *sp, const hz_lod_stats *st)
{
    sp->morph_scale = st->morph_scale;
    sp->morph_start = st->morph_start;
    sp->morph_near = st->morph_near;
    sp->morph_near_distance = st->morph_near_distance;
}

float cli_pixel_error(const hz_lod_params *p)
{
    if (p->pixel_error > 0 || (p->mode != HZ_LOD_CDLOD && p->mode != HZ_LOD_ROAM))
        return p->pixel_error;
    return 1.0f;
}

void cli_near_json(json_t *j, const hz_lod_params *p)
{
    const bool on = p->mode == HZ_LOD_CDLOD && p->near_pixel_error > cli_pixel_error(p);
    jx_set(j, "near_pixel_error", on ? jx_num(p->near_pixel_error) : json_null());
    jx_set(j, "near_error_distance", on ? jx_num(p->near_distance > 0 ? p->near_distance : HZ_LOD_NEAR_DISTANCE_DEFAULT)
                                        : json_null());
}

hz_camera cli_camera(const cli_opts *o, const hz_terrain *t)
{
    hz_camera c = hz_terrain_default_camera(t, o->width, o->height);
    if (o->have_camera) {
        c.pos[0] = o->camera[0];
        c.pos[1] = o->camera[1];
        c.pos[2] = o->camera[2];
        c.yaw = o->camera[3];
        c.pitch = o->camera[4];
    }
    if (o->fov > 0)
        c.fov_y = o->fov;
    if (o->far > 0) {
        c.zfar = o->far;
    } else {
        /* The default view distance follows the camera's height: from high
         * above, the map is farther than 1.5 map sides. */
        const float above = c.pos[1] - t->min_h * t->zscale;
        if (above > 0.0f)
            c.zfar += above;
    }
    if (o->near > 0)
        c.znear = o->near;
    c.earth_radius = o->curv.radius;
    return c;
}

void cli_curvature(cli_opts *o, const hz_terrain *t)
{
    float cx, cz;
    hz_terrain_data_centre(t, &cx, &cz);
    /* The data's longer side (a padded map's padding is not terrain). */
    const uint32_t dw = t->data_w ? t->data_w : t->hm.size, dh = t->data_h ? t->data_h : t->hm.size;
    const float ext = (float)((dw > dh ? dw : dh) - 1) * t->spacing;
    curv_cli_resolve(&o->curv, ext, t->georef, cx, cz);
}
