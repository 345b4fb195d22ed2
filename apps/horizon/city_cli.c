/* --city: a CityJSON model on the terrain (its own TINRelief or a DEM),
 * culled, drawn from the sorted render queue, and picked. */
#include "city_cli.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cpl_conv.h>
#include <gdal.h>
#include <ogr_srs_api.h>

#include "cli.h"
#include "horizon/pick.h"

int city_cli_option(city_opts *c, const char *a, const char *v, const char *cmd, int *i)
{
    const bool takes = !strcmp(a, "--city") || !strcmp(a, "--scene") || !strcmp(a, "--pick") || !strcmp(a, "--cull") ||
                       !strcmp(a, "--draw") || !strcmp(a, "--tin-cell");
    if (!takes)
        return -1;
    if (!v) {
        fprintf(stderr, "horizon %s: option %s needs a value\n", cmd, a);
        return 2;
    }
    (*i)++;
    if (!strcmp(a, "--city")) {
        c->city = v;
    } else if (!strcmp(a, "--scene")) {
        c->scene = v;
    } else if (!strcmp(a, "--pick")) {
        char buf[64], *it[3];
        snprintf(buf, sizeof buf, "%s", v);
        if (cli_split(buf, it, 3) != 2 || !cli_parse_float(it[0], 0, 1e5, &c->pick[0]) ||
            !cli_parse_float(it[1], 0, 1e5, &c->pick[1])) {
            fprintf(stderr, "horizon %s: --pick wants X,Y (pixels from the top-left corner), not '%s'\n", cmd, v);
            return 2;
        }
        c->have_pick = true;
    } else if (!strcmp(a, "--cull")) {
        if (!strcmp(v, "none")) {
            c->no_frustum = c->no_occlusion = true;
        } else if (!strcmp(v, "frustum")) {
            c->no_occlusion = true;
        } else if (!strcmp(v, "occlusion")) {
            c->no_frustum = c->no_occlusion = false;
        } else {
            fprintf(stderr, "horizon %s: --cull wants none, frustum or occlusion, not '%s'\n", cmd, v);
            return 2;
        }
    } else if (!strcmp(a, "--draw")) {
        if (strcmp(v, "naive") && strcmp(v, "sorted")) {
            fprintf(stderr, "horizon %s: --draw wants naive or sorted, not '%s'\n", cmd, v);
            return 2;
        }
        c->naive = !strcmp(v, "naive");
    } else if (!cli_parse_float(v, 0.5, 1000, &c->tin_cell)) {
        fprintf(stderr, "horizon %s: --tin-cell wants metres in [0.5, 1000], not '%s'\n", cmd, v);
        return 2;
    }
    return 0;
}

void city_cli_usage(void)
{
    fprintf(stderr,
            "city models and scene objects:\n"
            "  --city FILE.city.json   CityJSON 2.0 buildings (LoD1/LoD2 solids and surfaces) on the terrain,\n"
            "                          placed through its CRS and clamped to the ground; without --dem or\n"
            "                          --generate the model's TINRelief is the terrain\n"
            "  --scene FILE.json       a scene file (docs/scene.md): terrain, sun, materials, models\n"
            "                          (box, glTF/OBJ/FBX... through assimp) and a node tree\n"
            "  --tin-cell M            grid cell of that TINRelief terrain (default 5)\n"
            "  --cull none|frustum|occlusion   object culling (default occlusion: frustum + occlusion)\n"
            "  --draw sorted|naive     render queue sorted by shader/material/mesh, multi-draw and\n"
            "                          instancing (default), or one draw per object in scene order\n"
            "  --pick X,Y              print what is under that pixel: node, attributes, world / CRS /\n"
            "                          lon-lat position of the hit\n");
}

/* The TIN as a GeoTIFF the terrain loader reads (nodata NaN). */
static int write_tin(city_app *a, struct cli_opts *o, const char *cmd)
{
    float *g = NULL;
    uint32_t w, h;
    double gt[6];
    hz_err err = {0};
    double cell = o->city.tin_cell > 0 ? o->city.tin_cell : 5.0;
    if (hz_city_tin_grid(a->city, cell, &g, &w, &h, gt, &err) != HZ_OK) {
        fprintf(stderr, "horizon %s: %s; give a terrain with --dem or --generate\n", cmd, err.msg);
        return 1;
    }
    const char *tmp = getenv("TMPDIR");
    snprintf(a->tin_path, sizeof a->tin_path, "%s/hz_tin_%d_XXXXXX", tmp && tmp[0] ? tmp : "/tmp", (int)getpid());
    int fd = mkstemp(a->tin_path);
    if (fd < 0) {
        fprintf(stderr, "horizon %s: cannot create a temporary file for the TIN grid in %s\n", cmd,
                tmp ? tmp : "/tmp");
        free(g);
        a->tin_path[0] = 0;
        return 1;
    }
    close(fd);
    unlink(a->tin_path);
    strncat(a->tin_path, ".tif", sizeof a->tin_path - strlen(a->tin_path) - 1);
    GDALAllRegister();
    GDALDriverH drv = GDALGetDriverByName("GTiff");
    GDALDatasetH ds = drv ? GDALCreate(drv, a->tin_path, (int)w, (int)h, 1, GDT_Float32, NULL) : NULL;
    int rc = 1;
    if (ds) {
        GDALSetGeoTransform(ds, gt);
        OGRSpatialReferenceH srs = OSRNewSpatialReference(NULL);
        char *wkt = NULL;
        if (srs && a->city->crs[0] && OSRSetFromUserInput(srs, a->city->crs) == OGRERR_NONE &&
            OSRExportToWkt(srs, &wkt) == OGRERR_NONE)
            GDALSetProjection(ds, wkt);
        CPLFree(wkt);
        if (srs)
            OSRDestroySpatialReference(srs);
        GDALRasterBandH b = GDALGetRasterBand(ds, 1);
        GDALSetRasterNoDataValue(b, NAN);
        if (GDALRasterIO(b, GF_Write, 0, 0, (int)w, (int)h, g, (int)w, (int)h, GDT_Float32, 0, 0) == CE_None)
            rc = 0;
        GDALClose(ds);
    }
    free(g);
    if (rc) {
        fprintf(stderr, "horizon %s: cannot write the TIN grid %s\n", cmd, a->tin_path);
        return 1;
    }
    o->terrain.dem_path = a->tin_path;
    /* The TIN has holes under the buildings' footprints: drawn filled. */
    o->terrain.fill_voids = true;
    if (o->terrain.format == 0)
        o->terrain.format = HZ_DEM_GDAL;
    return 0;
}

city_app *city_app_load(struct cli_opts *o, const char *cmd, int *rc)
{
    *rc = 0;
    if (!o->city.city && !o->city.scene)
        return NULL;
    *rc = 1;
    city_app *a = calloc(1, sizeof *a);
    if (!a) {
        fprintf(stderr, "horizon %s: out of memory\n", cmd);
        return NULL;
    }
    hz_err err = {0};
    if (o->city.scene) {
        a->file = hz_scene_file_open(o->city.scene, &a->file_info, &err);
        if (!a->file) {
            fprintf(stderr, "horizon %s: %s\n", cmd, err.msg);
            city_app_destroy(a);
            return NULL;
        }
    }
    if (o->city.city) {
        a->city = hz_city_load(o->city.city, NULL, &err);
        if (!a->city) {
            fprintf(stderr, "horizon %s: %s\n", cmd, err.msg);
            city_app_destroy(a);
            return NULL;
        }
        if (a->city->note[0] && !o->quiet)
            fprintf(stderr, "horizon %s: %s: %s\n", cmd, o->city.city, a->city->note);
    }
    const bool has_terrain = o->terrain.dem_path || o->dem_count || o->terrain.generate;
    const hz_scene_file_info *fi = &a->file_info;
    if (!has_terrain && a->file && fi->has_terrain) {
        /* The scene's terrain (the command line's wins). */
        if (fi->dem[0]) {
            o->terrain.dem_path = fi->dem;
        } else {
            o->terrain.generate = !strcmp(fi->generate, "diamond") ? HZ_GEN_DIAMOND : HZ_GEN_PERLIN;
            o->terrain.gen_size = fi->size;
            o->terrain.seed = fi->seed;
            o->terrain.amplitude = fi->amplitude;
        }
        if (fi->spacing > 0 && !(o->terrain.spacing > 0))
            o->terrain.spacing = fi->spacing;
    } else if (!has_terrain && a->city && write_tin(a, o, cmd)) {
        city_app_destroy(a);
        return NULL;
    }
    if (a->file && fi->has_sun && !o->have_sun) {
        o->have_sun = true;
        o->sun[0] = fi->sun[0];
        o->sun[1] = fi->sun[1];
    }
    *rc = 0;
    return a;
}

static float ground(void *user, float x, float z)
{
    const hz_terrain *t = user;
    const float e = hz_terrain_extent(t);
    if (x < 0 || z < 0 || x > e || z > e)
        return NAN;
    return hz_terrain_surface_at(t, x, z);
}

/* Wall quads of a mesh: consecutive triangle pairs that share an edge (how
 * a planar 4-vertex face is triangulated). Appends to q (local coords). */
static size_t mesh_quads(const hz_scene *s, uint32_t mesh, float *q)
{
    const hz_mesh_range *m = hz_scene_mesh(s, mesh);
    uint32_t vc, ic;
    const hz_vertex *v = hz_scene_vertices(s, &vc);
    const uint32_t *ix = hz_scene_indices(s, &ic);
    size_t n = 0;
    for (uint32_t k = 0; k + 5 < m->index_count; k += 3) {
        const float *A[3], *B[3];
        for (int c = 0; c < 3; c++) {
            A[c] = v[m->first_vertex + ix[m->first_index + k + (uint32_t)c]].pos;
            B[c] = v[m->first_vertex + ix[m->first_index + k + 3 + (uint32_t)c]].pos;
        }
        /* The vertex of A not in B, and of B not in A. */
        int xa = -1, yb = -1, shared = 0;
        for (int c = 0; c < 3; c++) {
            bool in = false, inb = false;
            for (int d = 0; d < 3; d++) {
                in = in || !memcmp(A[c], B[d], 12);
                inb = inb || !memcmp(B[c], A[d], 12);
            }
            if (!in)
                xa = c;
            else
                shared++;
            if (!inb)
                yb = c;
        }
        if (shared != 2 || xa < 0 || yb < 0)
            continue;
        /* A = (x, p, q) in order; the quad is x, p, y, q. */
        const float *x = A[xa], *p = A[(xa + 1) % 3], *y = B[yb], *qq = A[(xa + 2) % 3];
        const float *quad[4] = {x, p, y, qq};
        for (int c = 0; c < 4; c++)
            memcpy(q + 12 * n + 3 * c, quad[c], 12);
        n++;
        k += 3; /* the pair is used */
    }
    return n;
}

/* Terrain occluder quads: a coarse grid over the valid data, each corner at
 * the lowest sample of the cells around it, so the quads lie under the
 * surface (inside the ground): anything behind them is behind ground. */
static int terrain_quads(city_app *a, const hz_terrain *t)
{
    const uint32_t n = t->hm.size, step = 4;
    const uint32_t cn = (n - 1) / step; /* coarse cells per side */
    float *cmin = malloc((size_t)(cn + 1) * (cn + 1) * sizeof *cmin);
    a->terrain_quads = malloc((size_t)cn * cn * 12 * sizeof *a->terrain_quads);
    if (!cmin || !a->terrain_quads) {
        free(cmin);
        return 1;
    }
    /* Corner heights: min over the samples of the (up to 4) coarse cells touching the corner. */
    for (uint32_t cj = 0; cj <= cn; cj++)
        for (uint32_t ci = 0; ci <= cn; ci++) {
            float m = INFINITY;
            uint32_t i0 = ci ? (ci - 1) * step : 0, i1 = ci < cn ? (ci + 1) * step : ci * step;
            uint32_t j0 = cj ? (cj - 1) * step : 0, j1 = cj < cn ? (cj + 1) * step : cj * step;
            for (uint32_t j = j0; j <= j1 && j < n; j++)
                for (uint32_t i = i0; i <= i1 && i < n; i++)
                    m = fminf(m, hz_heightmap_get(&t->hm, i, j) * t->zscale);
            cmin[(size_t)cj * (cn + 1) + ci] = m - 1.0f; /* a metre of margin for the LOD's error */
        }
    size_t q = 0;
    for (uint32_t cj = 0; cj < cn; cj++)
        for (uint32_t ci = 0; ci < cn; ci++) {
            /* Only over real data: a cell touching a masked sample is no occluder. */
            bool ok = true;
            if (t->valid)
                for (uint32_t j = cj * step; j <= (cj + 1) * step && ok; j++)
                    for (uint32_t i = ci * step; i <= (ci + 1) * step && ok; i++)
                        ok = t->valid[(size_t)j * n + i];
            if (!ok)
                continue;
            const uint32_t cc[4][2] = {{ci, cj}, {ci, cj + 1}, {ci + 1, cj + 1}, {ci + 1, cj}};
            for (int k = 0; k < 4; k++) {
                float *p = a->terrain_quads + 12 * q + 3 * k;
                p[0] = (float)(cc[k][0] * step) * t->spacing;
                p[1] = cmin[(size_t)cc[k][1] * (cn + 1) + cc[k][0]];
                p[2] = (float)(cc[k][1] * step) * t->spacing;
            }
            q++;
        }
    a->terrain_quad_count = q;
    free(cmin);
    return 0;
}

int city_app_place(city_app *a, const hz_terrain *t, const char *cmd)
{
    double t0 = hz_time_ms();
    hz_err err = {0};
    a->scene = hz_scene_create(&(hz_scene_desc){.node_capacity = (a->city ? a->city->obj_count * 2 : 0) +
                                                                 a->file_info.nodes + 64});
    if (!a->scene) {
        fprintf(stderr, "horizon %s: out of memory\n", cmd);
        return 1;
    }
    if (a->city) {
        hz_city_place p = {.georef = t->georef, .ground = ground, .ground_user = (void *)t};
        if (!t->georef) {
            /* A terrain without a place on Earth: the city's centre at the map's centre. */
            const float e = hz_terrain_extent(t);
            p.origin[0] = 0.5 * (a->city->extent[0] + a->city->extent[3]) - 0.5 * e;
            p.origin[1] = 0.5 * (a->city->extent[1] + a->city->extent[4]) + 0.5 * e;
        }
        if (hz_city_to_scene(a->city, a->scene, &p, &a->placed, &err) != HZ_OK) {
            fprintf(stderr, "horizon %s: %s\n", cmd, err.msg);
            return 1;
        }
    }
    if (a->file) {
        hz_scene_file_place p = {.georef = t->georef, .ground = ground, .ground_user = (void *)t};
        if (hz_scene_file_build(a->file, a->scene, &p, &a->file_stats, &err) != HZ_OK) {
            fprintf(stderr, "horizon %s: %s\n", cmd, err.msg);
            return 1;
        }
    }
    hz_scene_update(a->scene);
    /* Occluders: every mesh's face quads once; the nodes drawing a mesh
     * with quads occlude with it. */
    const uint32_t nn = hz_scene_node_count(a->scene), nm = hz_scene_mesh_count(a->scene);
    uint32_t ic;
    hz_scene_indices(a->scene, &ic);
    a->mesh_first = malloc(((size_t)nm + 1) * sizeof *a->mesh_first);
    a->mesh_quads = malloc(((size_t)nm + 1) * sizeof *a->mesh_quads);
    a->occ_node = malloc(((size_t)nn + 1) * sizeof *a->occ_node);
    a->quads = malloc(((size_t)ic / 6 + 1) * 12 * sizeof *a->quads);
    if (!a->mesh_first || !a->mesh_quads || !a->occ_node || !a->quads || terrain_quads(a, t) ||
        !hz_occlusion_init(&a->occ, 0, 0)) {
        fprintf(stderr, "horizon %s: out of memory for the occluders\n", cmd);
        return 1;
    }
    size_t q = 0;
    for (uint32_t m = 0; m < nm; m++) {
        a->mesh_first[m] = (uint32_t)q;
        a->mesh_quads[m] = (uint32_t)mesh_quads(a->scene, m, a->quads + 12 * q);
        q += a->mesh_quads[m];
    }
    for (uint32_t id = 1; id <= nn; id++) {
        uint32_t m = hz_scene_node_mesh(a->scene, id);
        if (m != HZ_MESH_NONE && a->mesh_quads[m])
            a->occ_node[a->occ_nodes++] = id;
    }
    a->place_ms = hz_time_ms() - t0;
    return 0;
}

hz_camera city_app_camera(const city_app *a, const struct cli_opts *o, const hz_terrain *t)
{
    hz_camera c = cli_camera(o, t);
    if (o->have_camera)
        return c;
    hz_box b;
    hz_scene_bounds(a->scene, &b);
    if (hz_box_is_empty(&b))
        return c;
    float cx = 0.5f * (b.min[0] + b.max[0]), cz = 0.5f * (b.min[2] + b.max[2]);
    float ext = fmaxf(b.max[0] - b.min[0], b.max[2] - b.min[2]);
    /* From the south-east, 30 degrees down, far enough to frame the city. */
    float d = 0.75f * ext + 50.0f;
    c.pos[0] = cx + d * 0.5f;
    c.pos[2] = cz + d * 0.866f;
    float gy = hz_terrain_surface_at(t, cx, cz);
    c.pos[1] = fmaxf(gy, hz_terrain_surface_at(t, c.pos[0], c.pos[2])) + d * 0.55f;
    c.yaw = glm_deg(atan2f(cx - c.pos[0], -(cz - c.pos[2])));
    c.pitch = -glm_deg(atan2f(c.pos[1] - gy, d));
    return c;
}

int city_app_gpu(city_app *a, const char *cmd)
{
    hz_err err = {0};
    a->gpu = hz_scene_gpu_create(a->scene, &err);
    if (!a->gpu) {
        fprintf(stderr, "horizon %s: %s\n", cmd, err.msg);
        return 1;
    }
    return 0;
}

void city_app_frame(city_app *a, const struct cli_opts *o, const hz_camera *cam, hz_scene_params *sp)
{
    a->hook.gpu = a->gpu;
    a->hook.scene = a->scene;
    a->hook.opts = (hz_scene_draw_opts){.no_frustum = o->city.no_frustum, .naive = o->city.naive};
    a->occ_ms = 0;
    if (!o->city.no_occlusion) {
        double t0 = hz_time_ms();
        hz_occlusion_begin(&a->occ, cam);
        /* The ground, then the faces of the objects in view within 1.5 km
         * (big near occluders; far walls hide little). */
        hz_occlusion_rasterize_quads(&a->occ, a->terrain_quads, a->terrain_quad_count, NULL);
        vec4 planes[6];
        hz_camera_frustum(cam, planes);
        for (uint32_t k = 0; k < a->occ_nodes; k++) {
            hz_box b;
            hz_scene_node_bounds(a->scene, a->occ_node[k], &b);
            if (hz_box_vs_planes(&b, planes, 6) < 0)
                continue;
            float dx = 0.5f * (b.min[0] + b.max[0]) - cam->pos[0], dz = 0.5f * (b.min[2] + b.max[2]) - cam->pos[2];
            if (dx * dx + dz * dz > 1500.0f * 1500.0f)
                continue;
            mat4 m;
            hz_scene_world_matrix(a->scene, a->occ_node[k], m);
            const uint32_t mesh = hz_scene_node_mesh(a->scene, a->occ_node[k]);
            hz_occlusion_rasterize_quads(&a->occ, a->quads + 12 * (size_t)a->mesh_first[mesh], a->mesh_quads[mesh], m);
        }
        a->hook.opts.occlusion = &a->occ;
        a->occ_ms = hz_time_ms() - t0;
    }
    a->hook.next = sp->draw_objects;
    a->hook.next_user = sp->draw_objects_user;
    sp->draw_objects = hz_scene_draw_hook;
    sp->draw_objects_user = &a->hook;
}

/* The node a user means: the nearest ancestor with a name (roofs are unnamed
 * children of their building). */
static uint32_t named(const hz_scene *s, uint32_t n)
{
    while (n && !hz_scene_name(s, n)[0])
        n = hz_scene_parent(s, n);
    return n;
}

void city_app_pick(const city_app *a, const hz_terrain *t, const hz_camera *cam, float x, float y, uint32_t w,
                   uint32_t h, bool json)
{
    hz_pick_result r = hz_pick(t, a ? a->scene : NULL, cam, x, y, w, h);
    double cx = 0, cy = 0, lon = 0, lat = 0;
    bool crs = r.hit && t->georef, ll = false;
    if (crs) {
        hz_georef_local_to_crs(t->georef, r.pos[0], r.pos[2], &cx, &cy);
        ll = hz_georef_crs_to_lonlat(t->georef, cx, cy, &lon, &lat, NULL) == HZ_OK;
    }
    uint32_t n = r.node ? named(a->scene, r.node) : 0;
    const char *name = n ? hz_scene_name(a->scene, n) : "";
    const char *attrs = n ? hz_scene_attributes(a->scene, n) : "";
    if (json) {
        printf(",\"pick\":{\"pixel\":[%g,%g],\"hit\":%s", (double)x, (double)y, r.hit ? "true" : "false");
        if (r.hit) {
            printf(",\"what\":\"%s\",\"world\":[%.3f,%.3f,%.3f],\"distance\":%.3f", r.terrain ? "terrain" : "node",
                   (double)r.pos[0], (double)r.pos[1], (double)r.pos[2], (double)r.distance);
            if (n) {
                printf(",\"node\":\"");
                for (const char *p = name; *p; p++)
                    printf(*p == '"' || *p == '\\' ? "\\%c" : "%c", *p);
                printf("\",\"attributes\":%s", attrs[0] ? attrs : "{}");
            }
            if (crs)
                printf(",\"crs\":\"%s\",\"crs_xy\":[%.3f,%.3f]", hz_georef_label(t->georef), cx, cy);
            if (ll)
                printf(",\"lonlat\":[%.8f,%.8f]", lon, lat);
        }
        printf("}");
        return;
    }
    if (!r.hit) {
        printf("pick          %g,%g: nothing (sky)\n", (double)x, (double)y);
        return;
    }
    if (n)
        printf("pick          %g,%g: %s %s\n", (double)x, (double)y, name, attrs);
    else
        printf("pick          %g,%g: terrain\n", (double)x, (double)y);
    printf("pick world    %.2f, %.2f, %.2f (%.1f m away)\n", (double)r.pos[0], (double)r.pos[1], (double)r.pos[2],
           (double)r.distance);
    if (crs)
        printf("pick CRS      %s: %.3f, %.3f, height %.2f\n", hz_georef_label(t->georef), cx, cy, (double)r.pos[1]);
    if (ll)
        printf("pick lon/lat  %.7f, %.7f\n", lon, lat);
}

void city_app_print(const city_app *a, bool json)
{
    const hz_scene_draw_stats *s = &a->hook.stats;
    const hz_city *c = a->city;
    const hz_scene_file_stats *fs = &a->file_stats;
    if (json) {
        printf(",\"city\":{\"scene_objects\":%u,\"after_frustum\":%u,\"after_occlusion\":%u,\"draw_calls\":%u,"
               "\"state_changes\":%u,\"queue_items\":%u,\"triangles_drawn\":%llu,\"cull_ms\":%.3f,"
               "\"occlusion_ms\":%.3f,\"draw_ms\":%.3f,\"occluder_quads\":%llu,\"place_ms\":%.1f,\"meshes\":%u",
               s->objects, s->after_frustum, s->after_occlusion, s->draw_calls, s->state_changes, s->items,
               (unsigned long long)s->triangles, s->cull_ms, a->occ_ms, s->draw_ms,
               (unsigned long long)a->occ.triangles, a->place_ms, hz_scene_mesh_count(a->scene));
        if (c)
            printf(",\"file_crs\":\"%s\",\"buildings\":%u,\"objects\":%u,\"faces\":%llu,\"triangles\":%llu,"
                   "\"load_ms\":%.1f,\"clamp_mean_m\":%.3f,\"clamp_max_m\":%.3f,\"clamped\":%u,\"without_ground\":%u",
                   c->crs, c->buildings, c->obj_count, (unsigned long long)c->faces,
                   (unsigned long long)a->placed.triangles, c->load_ms, a->placed.mean_shift, a->placed.max_shift,
                   a->placed.clamped, a->placed.outside);
        if (a->file)
            printf(",\"scene_file\":{\"nodes\":%u,\"objects\":%u,\"clamped\":%u,\"meshes\":%u,\"build_ms\":%.1f}",
                   fs->nodes, fs->objects, fs->clamped, fs->meshes, fs->ms);
        printf("}");
        return;
    }
    if (c) {
        printf("city          %u buildings (%s, %llu faces -> %llu triangles), loaded in %.0f ms\n", c->buildings,
               c->crs[0] ? c->crs : "no CRS", (unsigned long long)c->faces, (unsigned long long)a->placed.triangles,
               c->load_ms);
        printf("city ground   %u clamped (mean move %.2f m, max %.2f m), %u without ground under them\n",
               a->placed.clamped, a->placed.mean_shift, a->placed.max_shift, a->placed.outside);
    }
    if (a->file)
        printf("scene file    %u nodes, %u objects (%u meshes), %u clamped to the ground, built in %.0f ms\n",
               fs->nodes, fs->objects, fs->meshes, fs->clamped, fs->ms);
    printf("objects       %u in scene, %u after frustum culling, %u after occlusion culling\n", s->objects,
           s->after_frustum, s->after_occlusion);
    printf("objects draw  %u draw calls, %u state changes, %u queue items, %llu triangles, %.1f ms draw, "
           "%.2f ms cull, %.2f ms occlusion buffer\n",
           s->draw_calls, s->state_changes, s->items, (unsigned long long)s->triangles, s->draw_ms, s->cull_ms,
           a->occ_ms);
}

void city_app_destroy(city_app *a)
{
    if (!a)
        return;
    hz_scene_gpu_destroy(a->gpu);
    hz_scene_destroy(a->scene);
    hz_city_destroy(a->city);
    hz_occlusion_free(&a->occ);
    free(a->terrain_quads);
    free(a->occ_node);
    free(a->mesh_first);
    free(a->mesh_quads);
    free(a->quads);
    hz_scene_file_destroy(a->file);
    if (a->tin_path[0])
        unlink(a->tin_path);
    free(a);
}
