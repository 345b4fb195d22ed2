/* The effects' resources as the horizon commands set them up: light map for
 * the sun, trees and forest cover, water planes, a colour map; and per frame
 * the scene parameters and the reflection terrain. */
#include "cli.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <errno.h>
#include <sys/stat.h>

#include "horizon/lightmap.h"
#include "horizon/safety.h"

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wconversion"
#pragma GCC diagnostic ignored "-Wsign-conversion"
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#define STB_IMAGE_IMPLEMENTATION
#define STBI_ONLY_PNG
#include <stb_image.h>
#pragma GCC diagnostic pop

static int build_lightmap(app_fx *a, const hz_terrain *t, hz_renderer *r, const char *cmd)
{
    hz_err err = {0};
    if (!a->lightmap) {
        a->lightmap = malloc(hz_lightmap_bound(&t->hm));
        if (!a->lightmap) {
            fprintf(stderr, "horizon %s: out of memory for the light map\n", cmd);
            return 1;
        }
    }
    hz_lightmap_desc d = {.hm = &t->hm, .spacing = t->spacing, .zscale = t->zscale, .threads = 2,
                          .casters = a->casters};
    glm_vec3_copy(a->sun, d.sun_dir);
    /* The objects' shade: the sun heights around them. */
    if (a->sun_rect[2] && a->sun_rect[3]) {
        if (!a->sun_heights)
            a->sun_heights = malloc((size_t)a->sun_rect[2] * a->sun_rect[3] * sizeof *a->sun_heights);
        if (!a->sun_heights) {
            fprintf(stderr, "horizon %s: out of memory for the objects' sun heights\n", cmd);
            return 1;
        }
        d.sun_heights = a->sun_heights;
        memcpy(d.sun_rect, a->sun_rect, sizeof d.sun_rect);
    }
    hz_lightmap_stats st;
    if (hz_lightmap_build(&d, a->lightmap, &st, &err) != HZ_OK ||
        hz_renderer_set_lightmap(r, a->lightmap, t->hm.size, a->sun, &err) != HZ_OK ||
        (d.sun_heights && hz_renderer_set_sun_heights(r, d.sun_heights, d.sun_rect, a->sun, &err) != HZ_OK)) {
        fprintf(stderr, "horizon %s: light map: %s\n", cmd, err.msg);
        return 1;
    }
    a->lightmap_ms = st.ms;
    a->lightmap_threads = st.threads;
    glm_vec3_copy(a->sun, a->lightmap_sun);
    return 0;
}

/* The renderer spreads a colour map over the whole heightmap; a DEM that
 * covers only part of it (--fit auto pads non-square DEMs) gets its image
 * placed on a canvas so that the image spans exactly the DEM's samples
 * (nearest pixel; grey outside, which is not drawn). NULL if out of memory. */
static unsigned char *colormap_on_dem(const unsigned char *px, int w, int h, const hz_terrain *t, int *cw, int *ch)
{
    const double S = (double)(t->hm.size - 1);
    const double dw = t->data_w > 1 ? (double)(t->data_w - 1) : 1.0, dh = t->data_h > 1 ? (double)(t->data_h - 1) : 1.0;
    double fw = ceil((double)w * S / dw), fh = ceil((double)h * S / dh);
    int W = (int)(fw < 8192 ? fw : 8192), H = (int)(fh < 8192 ? fh : 8192);
    unsigned char *out = malloc((size_t)W * (size_t)H * 3);
    if (!out)
        return NULL;
    for (int Y = 0; Y < H; Y++) {
        double sj = ((Y + 0.5) / H * S - t->data_y) / dh; /* 0..1 across the DEM's rows */
        int py = (int)floor(sj * h);
        for (int X = 0; X < W; X++) {
            double si = ((X + 0.5) / W * S - t->data_x) / dw;
            int pxi = (int)floor(si * w);
            unsigned char *o = out + ((size_t)Y * (size_t)W + (size_t)X) * 3;
            if (pxi < 0 || py < 0 || pxi >= w || py >= h) {
                o[0] = o[1] = o[2] = 128;
                continue;
            }
            const unsigned char *p = px + ((size_t)py * (size_t)w + (size_t)pxi) * 3;
            o[0] = p[0];
            o[1] = p[1];
            o[2] = p[2];
        }
    }
    *cw = W;
    *ch = H;
    return out;
}

/* The decoded size an image's header asks for, against the memory budget,
 * before stb_image allocates it. 0, or 1 after the message. */
static int check_image(const char *path, int channels, uint64_t budget, const char *cmd)
{
    int w, h, n;
    if (!stbi_info(path, &w, &h, &n))
        return 0; /* stbi_load reports why */
    char what[1200];
    snprintf(what, sizeof what, "image '%s' (%dx%d)", path, w, h);
    hz_err err = {0};
    if (hz_mem_check((uint64_t)w * (uint64_t)h * (uint64_t)channels, budget, what, &err) != HZ_OK) {
        fprintf(stderr, "horizon %s: %s\n", cmd, err.msg);
        return 1;
    }
    return 0;
}

static int load_colormap(const char *path, hz_renderer *r, const char *cmd, const hz_terrain *t, uint64_t budget)
{
    int w, h, n;
    if (check_image(path, 3, budget, cmd))
        return 1;
    unsigned char *px = stbi_load(path, &w, &h, &n, 3);
    if (!px) {
        fprintf(stderr, "horizon %s: cannot read colour map '%s': %s\n", cmd, path, stbi_failure_reason());
        return 1;
    }
    unsigned char *c = px; /* stbi memory, or ours once remapped onto the DEM */
    if (t->data_w && t->data_h &&
        (t->data_x || t->data_y || t->data_w != t->hm.size || t->data_h != t->hm.size)) {
        c = colormap_on_dem(px, w, h, t, &w, &h);
        stbi_image_free(px);
        px = NULL;
        if (!c) {
            fprintf(stderr, "horizon %s: out of memory for the colour map\n", cmd);
            return 1;
        }
    }
    hz_err err = {0};
    hz_result res = hz_renderer_set_colormap(r, c, (uint32_t)w, (uint32_t)h, &err);
    if (px)
        stbi_image_free(px);
    else
        free(c);
    if (res != HZ_OK) {
        fprintf(stderr, "horizon %s: colour map '%s': %s\n", cmd, path, err.msg);
        return 1;
    }
    return 0;
}

/* DIR/grass.png ... replace the procedural textures; at least one must be there. */
int app_load_imagery(app_fx *a, const cli_opts *o, const hz_georef *g, uint32_t samples, double spacing,
                     hz_renderer *r, const char *cmd)
{
    const double t0 = hz_time_ms();
    hz_imagery_desc d = {.path = o->imagery, .target = g, .samples = samples, .spacing = spacing,
                         .max_side = o->imagery_max, .max_bytes = o->terrain.max_memory,
                         .progress = o->quiet ? NULL : hz_progress_stderr};
    hz_imagery im;
    hz_err err = {0};
    if (hz_imagery_load(&d, &im, &err) != HZ_OK) {
        fprintf(stderr, "horizon %s: %s\n", cmd, err.msg);
        return 1;
    }
    if (im.note[0] && !o->quiet)
        fprintf(stderr, "horizon %s: imagery: %s\n", cmd, im.note);
    hz_result res = hz_renderer_set_imagery(r, &im, &err);
    a->imagery_side = im.side;
    a->imagery_tiles = im.tiles;
    a->imagery_native_m = im.native_m;
    a->imagery_coverage = im.coverage;
    hz_imagery_free(&im);
    if (res != HZ_OK) {
        fprintf(stderr, "horizon %s: imagery '%s': %s\n", cmd, o->imagery, err.msg);
        return 1;
    }
    a->imagery_ms = hz_time_ms() - t0;
    return 0;
}

static int load_textures(const char *dir, hz_renderer *r, const char *cmd, uint64_t budget)
{
    static const char *const ground[HZ_GROUND_COUNT] = {"grass", "rock", "snow", "sand"};
    static const char *const sprite[HZ_SPRITE_COUNT] = {"conifer", "broadleaf", "rain", "snowflake"};
    struct stat st;
    if (stat(dir, &st) != 0) {
        fprintf(stderr, "horizon %s: cannot open the textures folder '%s': %s\n", cmd, dir, strerror(errno));
        return 1;
    }
    if (!S_ISDIR(st.st_mode)) {
        fprintf(stderr, "horizon %s: --textures takes a folder of PNGs, and '%s' is not a folder\n", cmd, dir);
        return 1;
    }
    int found = 0;
    for (int k = 0; k < HZ_GROUND_COUNT + HZ_SPRITE_COUNT; k++) {
        const bool is_ground = k < HZ_GROUND_COUNT;
        char path[1024];
        snprintf(path, sizeof path, "%s/%s.png", dir, is_ground ? ground[k] : sprite[k - HZ_GROUND_COUNT]);
        FILE *f = fopen(path, "rb");
        if (!f)
            continue;
        fclose(f);
        int w, h, n;
        if (check_image(path, 4, budget, cmd))
            return 1;
        unsigned char *px = stbi_load(path, &w, &h, &n, 4);
        if (!px) {
            fprintf(stderr, "horizon %s: cannot read texture '%s': %s\n", cmd, path, stbi_failure_reason());
            return 1;
        }
        hz_err err = {0};
        hz_result res;
        if (is_ground) {
            /* The renderer's limits, stated. */
            const bool pow2 = w >= 4 && w <= 8192 && (w & (w - 1)) == 0;
            res = w == h && pow2 ? hz_renderer_set_detail_texture(r, (hz_ground)k, px, (uint32_t)w, &err)
                                 : hz_err_set(&err, HZ_ERR_VALUE,
                                              "a ground texture must be square with a power-of-two side from 4 to "
                                              "8192 pixels (4, 8, ..., 8192); got %dx%d",
                                              w, h);
        } else {
            res = w >= 1 && h >= 1 && w <= 4096 && h <= 4096
                      ? hz_renderer_set_billboard_texture(r, (uint32_t)(k - HZ_GROUND_COUNT), px, (uint32_t)w,
                                                          (uint32_t)h, &err)
                      : hz_err_set(&err, HZ_ERR_VALUE, "a sprite may be at most 4096x4096 pixels; got %dx%d", w, h);
        }
        stbi_image_free(px);
        if (res != HZ_OK) {
            fprintf(stderr, "horizon %s: texture '%s': %s\n", cmd, path, err.msg);
            return 1;
        }
        found++;
    }
    if (!found) {
        fprintf(stderr, "horizon %s: no textures in '%s' (grass.png, rock.png, snow.png, sand.png, conifer.png, "
                        "broadleaf.png, rain.png or snowflake.png)\n", cmd, dir);
        return 1;
    }
    return 0;
}

/* The climate the ground follows: a georeferenced DEM's own (the lon/lat of
 * its centre), else --latitude or 45 degrees; --climate picks the kind. */
static hz_climate app_climate(const cli_opts *o, const hz_terrain *t, bool *known)
{
    double lon = 0, lat = o->have_latitude ? o->latitude : 45.0;
    *known = false;
    if (t->georef) {
        float cx, cz;
        hz_terrain_data_centre(t, &cx, &cz);
        if (hz_georef_local_to_lonlat(t->georef, cx, cz, &lon, &lat, NULL) == HZ_OK)
            *known = true;
    }
    if (o->climate == HZ_CLIMATE_AUTO && *known)
        return hz_climate_at(lon, lat);
    if (o->climate == HZ_CLIMATE_AUTO) {
        const double a = fabs(lat);
        return hz_climate_of_kind(a < 23.5 ? HZ_CLIMATE_TROPICAL : a > 66.5 ? HZ_CLIMATE_POLAR : HZ_CLIMATE_TEMPERATE,
                                  lat);
    }
    return hz_climate_of_kind(o->climate, lat);
}

void app_fx_objects(app_fx *a, const city_app *ca)
{
    a->casters = ca ? ca->casters : NULL;
    if (ca)
        memcpy(a->sun_rect, ca->sun_rect, sizeof a->sun_rect);
    else
        memset(a->sun_rect, 0, sizeof a->sun_rect);
}

int app_fx_setup(app_fx *a, const cli_opts *o, const hz_terrain *t, hz_renderer *r, const char *cmd)
{
    double t0 = hz_time_ms();
    const float *casters = a->casters; /* set by the caller */
    uint32_t sun_rect[4];
    memcpy(sun_rect, a->sun_rect, sizeof sun_rect);
    memset(a, 0, sizeof *a);
    a->casters = casters;
    memcpy(a->sun_rect, sun_rect, sizeof sun_rect);
    a->effects = o->effects;
    a->fx = o->fx;
    a->fog = o->fog;
    a->fog_capped = o->fog == 0.0f && !(o->far > 0);
    a->no_lit_map = o->no_lit_map;
    a->lit_per_vertex = o->lit_per_vertex;
    a->lit_pixel = o->lit_pixel;
    if (o->have_sun)
        hz_sun_direction(o->sun[0], o->sun[1], a->sun);
    else
        hz_sun_direction(245.2f, 30.2f, a->sun); /* the renderer's default afternoon sun */
    const bool all = !strcmp(cmd, "view"); /* the viewer may switch any effect on later */
    const uint32_t fx = all ? HZ_FX_ALL : a->effects;
    hz_err err = {0};
    a->climate = app_climate(o, t, &a->climate_known);
    hz_renderer_set_climate(r, &a->climate);
    const bool dry = a->climate.aridity >= 0.6f; /* no forests, no lakes */

    if (o->water_mode != 1) {
        bool sea = false;
        a->water_level =
            o->water_mode == 2 ? o->water_level : hz_water_level_auto(&t->hm, t->valid, t->zscale, 0, &sea);
        a->water = true;
        if (o->water_mode == 0) {
            /* A georeferenced DEM's sea is at 0 m: a flat plain higher up
             * is land, not a sea. A real place gets no invented lakes (its
             * lowest 4 % is a valley or a plain people live on: Heidelberg's
             * Rhine plain), nor do deserts and steppes. */
            if (sea && a->climate_known && fabsf(a->water_level / t->zscale) > 10.0f)
                a->water = false;
            else if (!sea && (dry || a->climate_known))
                a->water = false;
        }
        if (a->water && (fx & HZ_FX_WATER)) {
            /* A sea reaches the horizon; lakes (and a given level) stay on the map. */
            const float ext = hz_terrain_extent(t);
            hz_water_plane plane = {.height = a->water_level, .rect = {0, 0, ext, ext}, .sea = sea};
            if (sea)
                memset(plane.rect, 0, sizeof plane.rect);
            if (t->valid && !sea) {
                /* A masked DEM (nodata, padding): lakes only over the DEM's own
                 * rectangle; the level may come from the smooth fill of the
                 * padding, which is not ground anyone sees. */
                plane.rect[0] = (float)t->data_x * t->spacing;
                plane.rect[1] = (float)t->data_y * t->spacing;
                plane.rect[2] = (float)(t->data_x + t->data_w - 1) * t->spacing;
                plane.rect[3] = (float)(t->data_y + t->data_h - 1) * t->spacing;
            }
            /* A real place's sea goes on beyond its data where the coast does,
             * not over the land the DEM stops short of (a generated one is an
             * island in an open sea). Its sea has no bathymetry (flat just
             * under the plane): the plane's .sea draws it deep. */
            hz_coast coast = {0};
            if (sea && (t->valid || t->georef)) {
                const uint32_t dr[4] = {t->data_x, t->data_y, t->data_x + t->data_w - 1, t->data_y + t->data_h - 1};
                if (hz_coast_make(&t->hm, t->valid, t->spacing, t->zscale, a->water_level, t->data_w ? dr : NULL,
                                  &coast, &err) != HZ_OK ||
                    hz_renderer_set_coast(r, &coast, &err) != HZ_OK) {
                    hz_coast_free(&coast);
                    fprintf(stderr, "horizon %s: water: %s\n", cmd, err.msg);
                    return 1;
                }
                hz_coast_free(&coast);
            }
            hz_water_material mat = {.clarity = sea ? 0.3f : 0.0f};
            if (hz_renderer_set_water(r, &plane, 1, &mat, 1, &err) != HZ_OK) {
                fprintf(stderr, "horizon %s: water: %s\n", cmd, err.msg);
                return 1;
            }
        }
    }
    if ((fx & HZ_FX_SHADOWS) && build_lightmap(a, t, r, cmd))
        return 1;
    /* Trees below the climate's tree line (absolute metres, as a fraction of
     * the heightmap's range for the scatter), none in deserts and steppes. */
    const float lo = t->min_h * t->zscale, hi = t->max_h * t->zscale;
    const float tree_frac = hi > lo ? (a->climate.tree_line * t->zscale - lo) / (hi - lo) : 1.0f;
    if ((fx & HZ_FX_BILLBOARDS) && o->trees >= 0.0f && !dry && tree_frac > 0.02f) {
        hz_scatter_desc td = {.density = o->trees, .water_level = a->water ? a->water_level : -INFINITY,
                           .tree_line = fminf(tree_frac, 1.5f), .seed = t->hm.size ^ 0x7715u};
        hz_billboard *trees = NULL;
        if (hz_trees_scatter(&t->hm, t->spacing, t->zscale, &td, &trees, &a->trees, &err) == HZ_OK && t->valid) {
            /* No trees on nodata or padding (not drawn): keep those whose
             * nearest sample is valid. */
            size_t kept = 0;
            for (size_t k = 0; k < a->trees; k++)
                if (hz_terrain_valid_at(t, trees[k].pos[0], trees[k].pos[2]))
                    trees[kept++] = trees[k];
            a->trees = kept;
        }
        /* None inside the buildings. */
        if (!err.msg[0] && a->casters)
            a->trees = hz_billboards_clear_of(trees, a->trees, a->casters, t->hm.size, t->spacing);
        if (err.msg[0] || hz_renderer_set_billboards(r, trees, a->trees, &err) != HZ_OK) {
            free(trees);
            fprintf(stderr, "horizon %s: trees: %s\n", cmd, err.msg);
            return 1;
        }
        free(trees);
        uint32_t side = t->hm.size < 1024 ? t->hm.size : 1024;
        uint8_t *cover = malloc((size_t)side * side);
        if (!cover) {
            fprintf(stderr, "horizon %s: out of memory for the forest cover\n", cmd);
            return 1;
        }
        hz_forest_cover_map(&t->hm, t->spacing, t->zscale, &td, side, cover);
        hz_result res = hz_renderer_set_forest_cover(r, cover, side, &err);
        free(cover);
        if (res != HZ_OK) {
            fprintf(stderr, "horizon %s: forest cover: %s\n", cmd, err.msg);
            return 1;
        }
    }
    if (o->colormap && load_colormap(o->colormap, r, cmd, t, o->terrain.max_memory))
        return 1;
    if (o->imagery && app_load_imagery(a, o, t->georef, t->hm.size, t->spacing, r, cmd))
        return 1;
    if (o->textures && load_textures(o->textures, r, cmd, o->terrain.max_memory))
        return 1;
    a->setup_ms = hz_time_ms() - t0;
    return 0;
}

void app_fx_params(app_fx *a, const hz_terrain *t, const hz_camera *cam, const hz_lod_params *lod, double time,
                   hz_scene_params *sp)
{
    sp->effects = a->effects;
    sp->fx = &a->fx;
    sp->no_lit_map = a->no_lit_map;
    sp->lit_per_vertex = a->lit_per_vertex;
    sp->lit_pixel = a->lit_pixel;
    glm_vec3_copy(a->sun, sp->sun_dir);
    sp->fog_density = a->fog_capped ? cli_fog_default(cam->zfar) : a->fog;
    sp->time = time;
    sp->reflection_indices = NULL;
    sp->reflection_count = 0;
    if ((a->effects & HZ_FX_WATER) && a->water && cam->pos[1] > a->water_level) {
        /* The mirrored camera sees other terrain than the main one (hill tops
         * above the screen); a coarser selection is enough at half resolution. */
        hz_camera mc;
        hz_camera_mirror_y(cam, a->water_level, &mc);
        hz_lod_params p = lod ? *lod : (hz_lod_params){0};
        /* Always the plain quadtree: roam keeps its mesh from frame to frame
         * in the hz_lod, and a second camera would spoil its coherence. */
        p.mode = HZ_LOD_QUADTREE;
        p.pixel_error = 0.0f;
        p.c = 0.6f * (p.c > 0 ? p.c : 25.0f);
        if (hz_lod_select(t->lod, &mc, &p, &a->refl, NULL, NULL, NULL) == HZ_OK) {
            a->refl.count = hz_terrain_filter_triangles(t, a->refl.data, a->refl.count);
            sp->reflection_indices = a->refl.data;
            sp->reflection_count = (uint32_t)a->refl.count;
        }
    }
}

int app_fx_set_sun(app_fx *a, const hz_terrain *t, hz_renderer *r, float azimuth, float elevation)
{
    hz_sun_direction(azimuth, elevation, a->sun);
    return build_lightmap(a, t, r, "view");
}

void app_fx_sun_angles(const app_fx *a, float *azimuth, float *elevation)
{
    float az = glm_deg(atan2f(a->sun[0], -a->sun[2]));
    *azimuth = az < 0 ? az + 360.0f : az;
    *elevation = glm_deg(asinf(glm_clamp(a->sun[1], -1.0f, 1.0f)));
}

void app_fx_free(app_fx *a)
{
    free(a->lightmap);
    free(a->sun_heights);
    free(a->refl.data);
    memset(a, 0, sizeof *a);
}
