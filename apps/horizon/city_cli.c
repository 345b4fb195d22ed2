/* --city: a CityJSON model on the terrain (its own TINRelief or a DEM),
 * culled, drawn from the sorted render queue, and picked. */
#include "city_cli.h"

#include <float.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cpl_conv.h>
#include <gdal.h>
#include <ogr_srs_api.h>

#include "cli.h"
#include "horizon/pick.h"
#include "horizon/safety.h"

#include <jansson.h>

int city_cli_option(city_opts *c, const char *a, const char *v, const char *cmd, int *i)
{
    const bool takes = !strcmp(a, "--city") || !strcmp(a, "--scene") || !strcmp(a, "--footprints") ||
                       !strcmp(a, "--height-field") || !strcmp(a, "--levels-field") || !strcmp(a, "--pick") || !strcmp(a, "--cull") ||
                       !strcmp(a, "--draw") || !strcmp(a, "--tin-cell") || !strcmp(a, "--city-bench") ||
                       !strcmp(a, "--city-bench-frames");
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
    } else if (!strcmp(a, "--footprints")) {
        c->footprints = v;
    } else if (!strcmp(a, "--height-field") || !strcmp(a, "--levels-field")) {
        if (!v[0] || strlen(v) > 64) {
            fprintf(stderr, "horizon %s: %s wants a field name of 1 to 64 characters, not '%s'\n", cmd, a, v);
            return 2;
        }
        *(!strcmp(a, "--height-field") ? &c->height_field : &c->levels_field) = v;
    } else if (!strcmp(a, "--city-bench")) {
        if (strcmp(v, "street") && strcmp(v, "overview")) {
            fprintf(stderr, "horizon %s: --city-bench wants street or overview, not '%s'\n", cmd, v);
            return 2;
        }
        c->bench = v;
    } else if (!strcmp(a, "--city-bench-frames")) {
        if (!cli_parse_u32(v, 1, 10000, &c->bench_frames)) {
            fprintf(stderr, "horizon %s: --city-bench-frames wants a count in [1, 10000], not '%s'\n", cmd, v);
            return 2;
        }
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
        c->gpu_queries = false;
        if (!strcmp(v, "none")) {
            c->no_frustum = c->no_occlusion = true;
        } else if (!strcmp(v, "frustum")) {
            c->no_frustum = false;
            c->no_occlusion = true;
        } else if (!strcmp(v, "occlusion")) {
            c->no_frustum = c->no_occlusion = false;
        } else if (!strcmp(v, "gpu")) {
            c->no_frustum = false;
            c->no_occlusion = c->gpu_queries = true;
        } else {
            fprintf(stderr, "horizon %s: --cull wants none, frustum, occlusion or gpu, not '%s'\n", cmd, v);
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
            "                          --generate the model's TINRelief is the terrain; a CityJSON Text\n"
            "                          Sequence (.city.jsonl: header line, then CityJSONFeatures) too\n"
            "  --scene FILE.json       a scene file (docs/scene.md): terrain, sun, materials, models\n"
            "                          (box, glTF/OBJ/FBX... through assimp) and a node tree\n"
            "  --footprints FILE       building footprints GDAL/OGR reads (GeoJSON, GeoPackage, Shapefile,\n"
            "                          OSM PBF ...) extruded by their height, else their levels x 3 m,\n"
            "                          else 10 m, and clamped to the ground\n"
            "  --height-field NAME     the footprints' height field (default: the first of height,\n"
            "                          building:height, measuredHeight)\n"
            "  --levels-field NAME     their levels field (default: the first of building:levels,\n"
            "                          num_floors, building_l, levels)\n"
            "  --tin-cell M            grid cell of that TINRelief terrain (default 5)\n"
            "  --cull none|frustum|occlusion|gpu   object culling (default occlusion: frustum + the CPU\n"
            "                          occlusion buffer; gpu: frustum + GPU occlusion queries)\n"
            "  --draw sorted|naive     render queue sorted by shader/material/mesh, multi-draw and\n"
            "                          instancing (default), or one draw per object in scene order\n"
            "  --city-bench street|overview   (render) draw a path's frames (12, --city-bench-frames N)\n"
            "                          with every culling/queue configuration; street: 2 m above the\n"
            "                          ground from the scene's centre (or --camera's x, z, yaw) 400 m on\n"
            "  --pick X,Y              print what is under pixel (X, Y) from the top-left (the ray\n"
            "                          through its centre): node, attributes, world / CRS / lon-lat\n"
            "                          position of the hit\n");
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
    if (!o->city.city && !o->city.scene && !o->city.footprints) {
        if (o->city.bench || o->city.naive || o->city.no_frustum || o->city.no_occlusion) {
            fprintf(stderr, "horizon %s: --city-bench, --cull and --draw need --city or --scene\n", cmd);
            *rc = 2;
        }
        return NULL;
    }
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
    if (o->city.footprints) {
        const hz_footprint_desc fd = {.height_field = o->city.height_field, .levels_field = o->city.levels_field};
        a->fp = hz_city_load_footprints(o->city.footprints, &fd, &err);
        if (!a->fp) {
            fprintf(stderr, "horizon %s: %s\n", cmd, err.msg);
            city_app_destroy(a);
            return NULL;
        }
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

typedef struct edge_key {
    float a[3], b[3];
} edge_key;

static int cmp_edge(const void *x, const void *y)
{
    return memcmp(x, y, sizeof(edge_key));
}

/* Appends the directed edges of a mesh's triangles (by vertex position,
 * through m when not NULL) to e, and each reversed to r. */
static size_t add_edges(const hz_scene *s, uint32_t mesh, const mat4 m, edge_key *e, edge_key *r)
{
    const hz_mesh_range *mr = hz_scene_mesh(s, mesh);
    uint32_t vc, ic;
    const hz_vertex *v = hz_scene_vertices(s, &vc);
    const uint32_t *ix = hz_scene_indices(s, &ic);
    const size_t n = mr->index_count / 3 * 3;
    for (size_t k = 0; k < n; k++) {
        const size_t k2 = k - k % 3 + (k + 1) % 3;
        const float *p[2] = {v[mr->first_vertex + ix[mr->first_index + k]].pos,
                             v[mr->first_vertex + ix[mr->first_index + k2]].pos};
        float w[2][3];
        for (int a = 0; a < 2; a++) {
            vec4 q = {p[a][0], p[a][1], p[a][2], 1};
            if (m)
                glm_mat4_mulv((vec4 *)m, (vec4){p[a][0], p[a][1], p[a][2], 1}, q);
            for (int c = 0; c < 3; c++)
                w[a][c] = q[c] + 0.0f; /* + 0.0f: -0 and +0 are one position */
        }
        memcpy(e[k].a, w[0], sizeof w[0]);
        memcpy(e[k].b, w[1], sizeof w[1]);
        memcpy(r[k].a, w[1], sizeof w[1]);
        memcpy(r[k].b, w[0], sizeof w[0]);
    }
    return n;
}

/* Whether an object is a closed, consistently wound surface: every
 * directed edge (by vertex position) is matched by the same edge the other
 * way round. Then a face turned away from the camera lies behind one
 * turned toward it, so its back faces may occlude too. The object is the
 * node's mesh with those of its children (kid[], through their local
 * transforms): a CityJSON building's roof is a child node of its walls.
 * 1 closed, 0 open, -1 out of memory. */
static int object_closed(const hz_scene *s, uint32_t node, const uint32_t *kid, uint32_t kids)
{
    size_t n = 0;
    const uint32_t mesh = hz_scene_node_mesh(s, node);
    n += hz_scene_mesh(s, mesh)->index_count / 3 * 3;
    for (uint32_t k = 0; k < kids; k++)
        n += hz_scene_mesh(s, hz_scene_node_mesh(s, kid[k]))->index_count / 3 * 3;
    if (!n)
        return 0;
    edge_key *e = malloc(2 * n * sizeof *e);
    if (!e)
        return -1;
    size_t at = add_edges(s, mesh, NULL, e, e + n);
    for (uint32_t k = 0; k < kids; k++) {
        mat4 m;
        hz_scene_local_matrix(s, kid[k], m);
        at += add_edges(s, hz_scene_node_mesh(s, kid[k]), m, e + at, e + n + at);
    }
    qsort(e, n, sizeof *e, cmp_edge);
    qsort(e + n, n, sizeof *e, cmp_edge);
    const int closed = !memcmp(e, e + n, n * sizeof *e);
    free(e);
    return closed;
}

/* Per node with a mesh: whether it is (a part of) a closed object
 * (object_closed): of the node with the mesh children under it; a mesh
 * child takes its parent's answer. A node alone is answered per mesh.
 * 0, or -1 out of memory. */
static int nodes_closed(const hz_scene *s, uint8_t *closed)
{
    const uint32_t nn = hz_scene_node_count(s), nm = hz_scene_mesh_count(s);
    uint32_t *first = calloc((size_t)nn + 1, sizeof *first), *next = calloc((size_t)nn + 1, sizeof *next),
             *kid = malloc(((size_t)nn + 1) * sizeof *kid);
    int8_t *mesh_closed = malloc((size_t)nm + 1);
    int rc = -1;
    if (!first || !next || !kid || !mesh_closed)
        goto out;
    memset(mesh_closed, -2, (size_t)nm + 1); /* not asked yet */
    /* The mesh children of each node with a mesh. */
    for (uint32_t id = nn; id >= 1; id--) {
        const uint32_t p = hz_scene_parent(s, id);
        if (p != HZ_NODE_NONE && p >= 1 && p <= nn && hz_scene_node_mesh(s, p) != HZ_MESH_NONE &&
            hz_scene_node_mesh(s, id) != HZ_MESH_NONE) {
            next[id] = first[p];
            first[p] = id;
        }
    }
    for (uint32_t id = 1; id <= nn; id++) {
        const uint32_t mesh = hz_scene_node_mesh(s, id);
        closed[id] = 0;
        if (mesh == HZ_MESH_NONE)
            continue;
        const uint32_t p = hz_scene_parent(s, id);
        if (p != HZ_NODE_NONE && p >= 1 && p < id && hz_scene_node_mesh(s, p) != HZ_MESH_NONE) {
            closed[id] = closed[p]; /* a part of its parent's object */
            continue;
        }
        int c;
        if (!first[id]) {
            if (mesh_closed[mesh] == -2)
                mesh_closed[mesh] = (int8_t)object_closed(s, id, NULL, 0);
            c = mesh_closed[mesh];
        } else {
            uint32_t kids = 0;
            for (uint32_t k = first[id]; k; k = next[k])
                kid[kids++] = k;
            c = object_closed(s, id, kid, kids);
        }
        if (c < 0)
            goto out;
        closed[id] = (uint8_t)c;
    }
    rc = 0;
out:
    free(first);
    free(next);
    free(kid);
    free(mesh_closed);
    return rc;
}

/* Terrain occluders: a coarse grid over the valid data, each corner at the
 * lowest sample of the cells around it, so the quads lie under the surface
 * (inside the ground): anything behind them is behind ground. Kept as
 * corner heights and a flag per cell; the quads within reach of the camera
 * are made per frame (terrain_occlude). A cell spans 4 samples, and at
 * least TER_CELL_M metres: on a fine DEM (a 1 m lidar grid) 4-sample cells
 * would put a million quads within reach, and the buffer would take a
 * third of a second per frame. */
#define TER_REACH_M 3000.0f /* the terrain occludes within this distance along x and z */
#define TER_CELL_M 60.0f    /* at most (2 * 3000 / 60)^2 = 10 000 cells within reach */
static int terrain_grid(city_app *a, const hz_terrain *t)
{
    const uint32_t n = t->hm.size;
    const float fs = ceilf(TER_CELL_M / t->spacing);
    const uint32_t step = !(fs > 4.0f) ? 4u : fs < (float)n ? (uint32_t)fs : n;
    const uint32_t cn = (n - 1) / step; /* coarse cells per side */
    a->ter_cn = cn;
    a->ter_cell = (float)step * t->spacing;
    a->ter_cmin = malloc((size_t)(cn + 1) * (cn + 1) * sizeof *a->ter_cmin);
    a->ter_cell_ok = malloc((size_t)cn * cn + 1);
    /* A window spans at most ceil(2 * reach / cell) + 2 cells per side
     * (terrain_window's floor and ceil; one more against rounding). */
    const size_t side = (size_t)fminf((float)cn, ceilf(2.0f * TER_REACH_M / a->ter_cell) + 3.0f);
    a->ter_quads_cap = side * side;
    a->ter_quads = malloc((side * side + 1) * 12 * sizeof *a->ter_quads);
    if (!a->ter_cmin || !a->ter_cell_ok || !a->ter_quads)
        return 1;
    /* Corner heights: min over the samples of the (up to 4) coarse cells touching the corner. */
    for (uint32_t cj = 0; cj <= cn; cj++)
        for (uint32_t ci = 0; ci <= cn; ci++) {
            float m = INFINITY;
            uint32_t i0 = ci ? (ci - 1) * step : 0, i1 = ci < cn ? (ci + 1) * step : ci * step;
            uint32_t j0 = cj ? (cj - 1) * step : 0, j1 = cj < cn ? (cj + 1) * step : cj * step;
            for (uint32_t j = j0; j <= j1 && j < n; j++)
                for (uint32_t i = i0; i <= i1 && i < n; i++)
                    m = fminf(m, hz_heightmap_get(&t->hm, i, j) * t->zscale);
            a->ter_cmin[(size_t)cj * (cn + 1) + ci] = m - 1.0f; /* a metre of margin for the LOD's error */
        }
    /* Only over real data: a cell touching a masked sample is no occluder. */
    for (uint32_t cj = 0; cj < cn; cj++)
        for (uint32_t ci = 0; ci < cn; ci++) {
            bool ok = true;
            if (t->valid)
                for (uint32_t j = cj * step; j <= (cj + 1) * step && ok; j++)
                    for (uint32_t i = ci * step; i <= (ci + 1) * step && ok; i++)
                        ok = t->valid[(size_t)j * n + i];
            a->ter_cell_ok[(size_t)cj * cn + ci] = ok;
        }
    return 0;
}

/* The window of coarse cells within reach of the camera along x and z,
 * clipped to the grid: {i0, i1, j0, j1}, inclusive. A rectangle, so convex:
 * the segment from the eye to any point of it stays inside it (the back
 * faces' rule in ter_occlude rests on that). False when it is empty. */
static bool terrain_window(const city_app *a, const hz_camera *cam, float reach, uint32_t win[4])
{
    const uint32_t cn = a->ter_cn;
    if (!cn)
        return false;
    const float cell = a->ter_cell;
    const float fi0 = floorf((cam->pos[0] - reach) / cell), fi1 = ceilf((cam->pos[0] + reach) / cell);
    const float fj0 = floorf((cam->pos[2] - reach) / cell), fj1 = ceilf((cam->pos[2] + reach) / cell);
    if (!(fi1 >= 0 && fj1 >= 0 && fi0 < (float)cn && fj0 < (float)cn))
        return false;
    win[0] = (uint32_t)fmaxf(fi0, 0);
    win[1] = (uint32_t)fminf(fi1, (float)(cn - 1));
    win[2] = (uint32_t)fmaxf(fj0, 0);
    win[3] = (uint32_t)fminf(fj1, (float)(cn - 1));
    return true;
}

/* The cells of the window with data. Fewer than the window's cells: a cell
 * without data is no occluder, and the window's occluder surface has a hole
 * there. */
static uint32_t terrain_window_cells(const city_app *a, const uint32_t win[4])
{
    uint32_t n = 0;
    for (uint32_t cj = win[2]; cj <= win[3]; cj++)
        for (uint32_t ci = win[0]; ci <= win[1]; ci++)
            n += a->ter_cell_ok[(size_t)cj * a->ter_cn + ci] != 0;
    return n;
}

/* Appends coarse cell (ci, cj)'s occluder quad to a->ter_quads (at *nq)
 * when the cell has data. */
static void ter_quad(city_app *a, long ci, long cj, size_t *nq)
{
    const uint32_t cn = a->ter_cn;
    const float cell = a->ter_cell;
    if (!a->ter_cell_ok[(size_t)cj * cn + (size_t)ci])
        return;
    const long cc[4][2] = {{ci, cj}, {ci, cj + 1}, {ci + 1, cj + 1}, {ci + 1, cj}};
    float *q = a->ter_quads + 12 * (*nq)++;
    for (int k = 0; k < 4; k++) {
        q[3 * k] = (float)cc[k][0] * cell;
        q[3 * k + 1] = a->ter_cmin[(size_t)cc[k][1] * (cn + 1) + (size_t)cc[k][0]];
        q[3 * k + 2] = (float)cc[k][1] * cell;
    }
}

/* Rasterises into a->occ_ter the valid cells of the window (far ground
 * hides little and costs the most): only the cells of that window are
 * visited, whatever the map's size. Nearest first, ring by ring around the
 * camera's cell: a far quad then finds the cells it would cover already
 * nearer and costs little, and the cells' partial layers (pixel samples)
 * take the near depths first (a layer keeps the farthest depth of what it
 * holds, and leaves out occluders more than twice as far). In rows order
 * the street bench drew 263 objects and 73 patches, in rings 231 and 66. */
static void terrain_occlude(city_app *a, const hz_camera *cam, const uint32_t win[4])
{
    if ((size_t)(win[1] - win[0] + 1) * (win[3] - win[2] + 1) > a->ter_quads_cap)
        return; /* cannot happen (terrain_grid's bound); no occluders is conservative */
    const long i0 = win[0], i1 = win[1], j0 = win[2], j1 = win[3];
    /* the camera's cell, clamped into the window */
    const float fi = floorf(cam->pos[0] / a->ter_cell), fj = floorf(cam->pos[2] / a->ter_cell);
    const long ic = (long)fminf(fmaxf(fi, (float)i0), (float)i1), jc = (long)fminf(fmaxf(fj, (float)j0), (float)j1);
    long rings = ic - i0;
    rings = i1 - ic > rings ? i1 - ic : rings;
    rings = jc - j0 > rings ? jc - j0 : rings;
    rings = j1 - jc > rings ? j1 - jc : rings;
    size_t nq = 0;
    for (long r = 0; r <= rings; r++) {
        /* ring r: the cells r cells from (ic, jc) along x or z, the rest less */
        const long ja = jc - r > j0 ? jc - r : j0, jb = jc + r < j1 ? jc + r : j1;
        const long ia = ic - r > i0 ? ic - r : i0, ib = ic + r < i1 ? ic + r : i1;
        for (long j = ja; j <= jb; j++) {
            if (j == jc - r || j == jc + r) {
                for (long i = ia; i <= ib; i++)
                    ter_quad(a, i, j, &nq);
            } else {
                if (ic - r >= i0)
                    ter_quad(a, ic - r, j, &nq);
                if (r && ic + r <= i1)
                    ter_quad(a, ic + r, j, &nq);
            }
        }
    }
    a->ter_occluders = (uint32_t)nq; /* (one per cell with data: --json, against ter_window_cells) */
    hz_occlusion_rasterize_quads(&a->occ_ter, a->ter_quads, nq, NULL);
}

/* The objects as the light map's shadow casters: the highest point of their
 * triangles over each terrain sample (hz_scene_heights). Skipped (no object
 * shadows) beyond 64 M samples, where the grid would cost more than 256 MB. */
static void shadow_casters(city_app *a, const hz_terrain *t)
{
    const uint32_t n = t->hm.size;
    if (!hz_scene_mesh_count(a->scene) || (uint64_t)n * n > (64u << 20))
        return;
    a->casters = malloc((size_t)n * n * sizeof *a->casters);
    if (!a->casters)
        return;
    for (size_t k = 0; k < (size_t)n * n; k++)
        a->casters[k] = -INFINITY;
    const float sp = t->spacing;
    a->caster_samples = hz_scene_heights(a->scene, n, sp, a->casters);
    hz_box all;
    hz_scene_bounds(a->scene, &all);
    /* The objects' faces are shaded by the sun heights over their samples
     * and two more around (a face looks one sample outward); at most 16 M
     * samples (64 MB) and 16 384 per side. */
    if (hz_box_is_empty(&all))
        return;
    const float i0 = fmaxf(floorf(all.min[0] / sp) - 2, 0), i1 = fminf(ceilf(all.max[0] / sp) + 2, (float)(n - 1));
    const float j0 = fmaxf(floorf(all.min[2] / sp) - 2, 0), j1 = fminf(ceilf(all.max[2] / sp) + 2, (float)(n - 1));
    if (!(i1 >= i0 && j1 >= j0))
        return;
    const uint32_t w = (uint32_t)(i1 - i0) + 1, h = (uint32_t)(j1 - j0) + 1;
    if ((uint64_t)w * h > (16u << 20) || w > 16384 || h > 16384)
        return;
    a->sun_rect[0] = (uint32_t)i0;
    a->sun_rect[1] = (uint32_t)j0;
    a->sun_rect[2] = w;
    a->sun_rect[3] = h;
}

int city_app_place(city_app *a, const hz_terrain *t, const char *cmd)
{
    double t0 = hz_time_ms();
    a->lod = t->lod;
    a->ter = t;
    hz_err err = {0};
    a->scene = hz_scene_create(&(hz_scene_desc){.node_capacity = (a->city ? a->city->obj_count * 2 : 0) +
                                                                 a->file_info.nodes + 64});
    if (!a->scene) {
        fprintf(stderr, "horizon %s: out of memory\n", cmd);
        return 1;
    }
    hz_city *cities[2] = {a->city, a->fp};
    hz_city_placed *placed[2] = {&a->placed, &a->fp_placed};
    for (int k = 0; k < 2; k++) {
        if (!cities[k])
            continue;
        hz_city_place p = {.georef = t->georef, .ground = ground, .ground_user = (void *)t};
        if (!t->georef) {
            /* A terrain without a place on Earth: the model's centre at the map's centre. */
            const float e = hz_terrain_extent(t);
            p.origin[0] = 0.5 * (cities[k]->extent[0] + cities[k]->extent[3]) - 0.5 * e;
            p.origin[1] = 0.5 * (cities[k]->extent[1] + cities[k]->extent[4]) + 0.5 * e;
        }
        if (hz_city_to_scene(cities[k], a->scene, &p, placed[k], &err) != HZ_OK) {
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
    a->node_closed = malloc((size_t)nn + 1);
    a->occ_node = malloc(((size_t)nn + 1) * sizeof *a->occ_node);
    a->occ_cand = malloc(((size_t)nn + 1) * 4 * sizeof *a->occ_cand); /* the nodes, the sort's scratch */
    a->occ_cand_cap = nn + 1;
    a->quads = malloc(((size_t)ic / 6 + 1) * 12 * sizeof *a->quads);
    if (!a->mesh_first || !a->mesh_quads || !a->node_closed || !a->occ_node || !a->occ_cand || !a->quads ||
        terrain_grid(a, t) || !hz_occlusion_init(&a->occ, 0, 0) || !hz_occlusion_init(&a->occ_ter, 0, 0)) {
        fprintf(stderr, "horizon %s: out of memory for the occluders\n", cmd);
        return 1;
    }
    size_t q = 0;
    for (uint32_t m = 0; m < nm; m++) {
        a->mesh_first[m] = (uint32_t)q;
        a->mesh_quads[m] = (uint32_t)mesh_quads(a->scene, m, a->quads + 12 * q);
        q += a->mesh_quads[m];
    }
    if (nodes_closed(a->scene, a->node_closed)) {
        fprintf(stderr, "horizon %s: out of memory for the occluders\n", cmd);
        return 1;
    }
    for (uint32_t id = 1; id <= nn; id++) {
        uint32_t m = hz_scene_node_mesh(a->scene, id);
        if (m != HZ_MESH_NONE && a->mesh_quads[m])
            a->occ_node[a->occ_nodes++] = id;
    }
    shadow_casters(a, t);
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
    /* Over rough ground a hill may stand between: raise the camera until the
     * line to the middle of the city's box clears the terrain by 5 m. The
     * line is linear in the camera's height, so one pass finds the rise. */
    const float ty = fmaxf(0.5f * (b.min[1] + b.max[1]), gy);
    float rise = 0;
    for (int k = 1; k < 64; k++) {
        const float f = (float)k / 64.0f;
        const float x = c.pos[0] + f * (cx - c.pos[0]), z = c.pos[2] + f * (cz - c.pos[2]);
        const float h = hz_terrain_surface_at(t, x, z), line = c.pos[1] + f * (ty - c.pos[1]);
        if (isfinite(h) && h + 5.0f > line)
            rise = fmaxf(rise, (h + 5.0f - line) / (1.0f - f));
    }
    c.pos[1] += rise;
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

/* Whether the occlusion buffer hides a terrain box (hz_lod_patch_box). */
static bool ter_box_hidden(const city_app *a, vec3 box[2])
{
    const hz_box b = {{box[0][0], box[0][1], box[0][2]}, {box[1][0], box[1][1], box[1][2]}};
    return hz_occlusion_box_hidden(&a->occ, &b);
}

/* hz_patch.hidden bits of the blocks of p that block (bx, bz) of the cut
 * into per_side x per_side holds and the occlusion buffer hides; a block
 * shown is tested by its quarters down to the finest cut
 * (hz_lod_patch_blocks), whose boxes lie within its own. */
static uint16_t hidden_blocks(city_app *a, const hz_patch *p, const hz_camera *cam, const hz_lod_stats *st,
                              uint32_t per_side, uint32_t bx, uint32_t bz)
{
    const uint32_t B = hz_lod_patch_blocks(hz_lod_patch_cells(a->lod));
    vec3 box[2];
    if (per_side > 1 && hz_lod_patch_block_box(a->lod, p, per_side, bx, bz, cam, st, box)) {
        if (ter_box_hidden(a, box)) {
            /* every finest block inside it */
            const uint32_t k = B / per_side;
            uint16_t bits = 0;
            for (uint32_t z = bz * k; z < (bz + 1) * k; z++)
                for (uint32_t x = bx * k; x < (bx + 1) * k; x++)
                    bits |= (uint16_t)(1u << (z * B + x));
            return bits;
        }
    }
    if (per_side >= B)
        return 0;
    uint16_t bits = 0;
    for (uint32_t q = 0; q < 4; q++)
        bits |= hidden_blocks(a, p, cam, st, 2 * per_side, 2 * bx + (q & 1), 2 * bz + (q >> 1));
    return bits;
}

/* What hides of patches [first, count) of sp, every second one: vis[k]
 * gets 0x10000 when patch k is behind the buffer, else its hidden blocks. */
typedef struct hide_job {
    city_app *a;
    const hz_camera *cam;
    const hz_scene_params *sp;
    const hz_lod_stats *st;
    uint32_t first;
} hide_job;

static void *hide_run(void *arg)
{
    const hide_job *j = arg;
    city_app *a = j->a;
    for (uint32_t k = j->first; k < j->sp->patch_count; k += 2) {
        const hz_patch *p = &j->sp->patches[k];
        uint32_t v = 0;
        vec3 box[2];
        if (p->layer1 == 0 && hz_lod_patch_box(a->lod, p, j->cam, j->st, box))
            v = ter_box_hidden(a, box) ? 0x10000u : hidden_blocks(a, p, j->cam, j->st, 1, 0, 0);
        a->patch_vis[k] = v;
    }
    return NULL;
}

/* The seed's occlusion culling for the terrain too: at street level the
 * buildings hide most of it. sp's in-memory cdlod patches whose box (as
 * drawn, morphing included: hz_lod_patch_box) is behind the occlusion
 * buffer are dropped; the rest keep their order (nearest first), and of
 * those the blocks (hz_lod_patch_block_box) behind it are marked hidden
 * (hz_patch.hidden), which the renderer leaves out. Holes appear only
 * where nothing shows through. The patches are tested on two threads
 * (llvmpipe's rasteriser threads have nothing to do yet), every second
 * one each. */
static void hide_patches(city_app *a, const hz_camera *cam, hz_scene_params *sp)
{
    a->patches_in = a->patches_drawn = sp->patch_count;
    a->blocks_hidden = 0;
    if (!sp->patches || !sp->patch_count || !a->lod)
        return;
    /* the selection's morphing, as the renderer draws it */
    const hz_lod_stats st = {.morph_scale = sp->morph_scale,
                             .morph_start = sp->morph_start,
                             .morph_near = sp->morph_near,
                             .morph_near_distance = sp->morph_near_distance};
    if (sp->patch_count > a->patch_keep_cap) {
        hz_patch *k = realloc(a->patch_keep, sp->patch_count * sizeof *k);
        if (k)
            a->patch_keep = k;
        uint32_t *v = realloc(a->patch_vis, sp->patch_count * sizeof *v);
        if (v)
            a->patch_vis = v;
        if (!k || !v)
            return; /* all drawn */
        a->patch_keep_cap = sp->patch_count;
    }
    hide_job jobs[2] = {{a, cam, sp, &st, 0}, {a, cam, sp, &st, 1}};
    pthread_t th;
    const bool threaded = sp->patch_count > 1 && pthread_create(&th, NULL, hide_run, &jobs[1]) == 0;
    hide_run(&jobs[0]);
    if (threaded)
        pthread_join(th, NULL);
    else
        hide_run(&jobs[1]);
    uint32_t kept = 0;
    for (uint32_t k = 0; k < sp->patch_count; k++) {
        const uint32_t v = a->patch_vis[k];
        if (v & 0x10000u)
            continue;
        hz_patch *q = &a->patch_keep[kept++];
        *q = sp->patches[k];
        q->hidden |= (uint16_t)v;
        for (uint16_t h = q->hidden; h; h &= (uint16_t)(h - 1))
            a->blocks_hidden++;
    }
    sp->patches = a->patch_keep;
    sp->patch_count = kept;
    a->patches_drawn = kept;
}

/* Whether the terrain's occluder quads may occlude with their back faces
 * too: the eye stands above the occluder surface of the valid cell under
 * it. Then a ray that meets a back face has passed under the surface since
 * the eye, so it crossed a front face first, over the ground between: the
 * back face lies behind ground, if the occluder surface has no hole on the
 * way (ter_occlude checks the window). Under the surface, over a cell
 * without data or off the grid, the eye may look through the terrain from
 * below, where the renderer culls it. */
static bool eye_over_ground(const city_app *a, const hz_camera *cam)
{
    const uint32_t cn = a->ter_cn;
    const float cell = a->ter_cell;
    const float fi = floorf(cam->pos[0] / cell), fj = floorf(cam->pos[2] / cell);
    if (!cn || !(fi >= 0 && fj >= 0 && fi < (float)cn && fj < (float)cn))
        return false;
    const uint32_t ci = (uint32_t)fi, cj = (uint32_t)fj;
    if (!a->ter_cell_ok[(size_t)cj * cn + ci])
        return false;
    float top = -INFINITY;
    for (uint32_t dj = 0; dj < 2; dj++)
        for (uint32_t di = 0; di < 2; di++)
            top = fmaxf(top, a->ter_cmin[(size_t)(cj + dj) * (cn + 1) + ci + di]);
    return cam->pos[1] > top;
}

/* The terrain's occluders into their own buffer (a->occ_ter), on a thread
 * of its own while the objects' go into a->occ. */
typedef struct ter_job {
    city_app *a;
    const hz_camera *cam;
    bool under; /* the eye is under the ground */
} ter_job;

static void *ter_occlude(void *arg)
{
    ter_job *j = arg;
    j->a->ter_window_cells = j->a->ter_occluders = 0;
    hz_occlusion_begin(&j->a->occ_ter, j->cam);
    uint32_t win[4];
    /* Under the ground the eye looks through it (the renderer culls the
     * ground seen from below), even where it is above the occluder quads
     * (which lie under the surface): those would hide what shows. */
    if (!j->under && terrain_window(j->a, j->cam, TER_REACH_M, win)) {
        /* Through a hole in the window (a cell without data, where the
         * renderer draws no ground) the eye may see the underside of the
         * ground beyond it, which the renderer culls: no back faces then. */
        const uint32_t cells = terrain_window_cells(j->a, win);
        j->a->ter_window_cells = cells; /* (counted apart from the rings of terrain_occlude: --json) */
        j->a->occ_ter.cull_back =
            !eye_over_ground(j->a, j->cam) || cells < (win[1] - win[0] + 1) * (win[3] - win[2] + 1);
        terrain_occlude(j->a, j->cam, win);
    }
    return NULL;
}

void city_app_frame(city_app *a, const struct cli_opts *o, const hz_camera *cam, uint32_t fb_w, uint32_t fb_h,
                    hz_scene_params *sp)
{
    a->hook.gpu = a->gpu;
    a->hook.scene = a->scene;
    a->hook.opts = (hz_scene_draw_opts){.no_frustum = o->city.no_frustum, .naive = o->city.naive,
                                        .gpu_queries = o->city.gpu_queries};
    a->occ_ms = 0;
    /* Adaptive: when the last buffer hid under 5 % of the objects in the
     * frustum (a view from above), the next 7 frames with occlusion culling
     * go without one (only frustum culling: still conservative), then it is
     * tried again. Frames drawn with occlusion culling off (--city-bench
     * interleaves them) do not count. */
    if (a->occ_built) {
        const hz_scene_draw_stats *ls = &a->hook.stats;
        if (ls->after_frustum && (double)ls->after_occlusion > 0.95 * (double)ls->after_frustum)
            a->occ_rest = 8;
    }
    a->occ_built = false;
    if (!o->city.no_occlusion && a->occ_rest)
        a->occ_rest--;
    if (!o->city.no_occlusion && !a->occ_rest) {
        a->occ_built = true;
        double t0 = hz_time_ms();
        /* The ground's occluders with pixel samples at the frame's size:
         * its quads side by side cover the cells along their common edges
         * together (the buildings' quads stand apart, and their samples
         * cost more than they hide). */
        hz_occlusion_set_viewport(&a->occ_ter, fb_w, fb_h);
        hz_occlusion_begin(&a->occ, cam);
        /* The ground within 3 km on a second thread (llvmpipe's rasteriser
         * threads have nothing to do yet: the core is free), the objects'
         * faces on this one, each into its own buffer; then the nearer of
         * the two per cell. (The objects' skipping of hidden occluders sees
         * only the objects: at street level the buildings hide them.) */
        ter_job job = {a, cam, !(cam->pos[1] > hz_terrain_surface_at(a->ter, cam->pos[0], cam->pos[2]))};
        pthread_t th;
        const bool threaded = pthread_create(&th, NULL, ter_occlude, &job) == 0;
        if (!threaded)
            ter_occlude(&job);
        /* The objects in view within 1.5 km (big near occluders; far walls
         * hide little), nearest first: an occluder whose box is already
         * hidden cannot bring any cell nearer, so it is skipped. At street
         * level the first rows of buildings hide most of the rest. */
        vec4 planes[6];
        hz_camera_frustum(cam, planes);
        const float reach_obj = 1500.0f;
        /* The scene's hierarchical frustum culling: whole blocks out of
         * view cost one test. */
        uint32_t nv = hz_scene_cull_curved(a->scene, cam, planes, a->occ_cand, a->occ_cand_cap, NULL), nc = 0;
        if (nv > a->occ_cand_cap)
            nv = a->occ_cand_cap; /* (nodes added after placing are not occluders) */
        for (uint32_t k = 0; k < nv; k++) {
            const uint32_t id = a->occ_cand[k], mesh = hz_scene_node_mesh(a->scene, id);
            if (mesh == HZ_MESH_NONE || !a->mesh_quads[mesh])
                continue;
            hz_box b;
            hz_scene_node_bounds(a->scene, id, &b);
            float d2 = 0;
            for (int c = 0; c < 3; c += 2) {
                float v = fmaxf(fmaxf(b.min[c] - cam->pos[c], cam->pos[c] - b.max[c]), 0.0f);
                d2 += v * v;
            }
            if (d2 <= reach_obj * reach_obj)
                a->occ_cand[nc++] = id;
        }
        hz_scene_sort_near_first(a->scene, cam->pos, a->occ_cand, nc, a->occ_cand + nc);
        for (uint32_t k = 0; k < nc; k++) {
            const uint32_t id = a->occ_cand[k];
            hz_box b;
            hz_scene_node_bounds(a->scene, id, &b);
            if (hz_occlusion_box_hidden(&a->occ, &b))
                continue;
            mat4 m;
            hz_scene_world_matrix(a->scene, id, m);
            const uint32_t mesh = hz_scene_node_mesh(a->scene, id);
            /* The objects are drawn with back faces culled: an open mesh's
             * face turned away is not drawn, so it must not hide anything. A
             * closed one's lies behind its front faces, seen from outside
             * its box (inside it, or nearer than the near plane's clipping,
             * the eye may see through the back faces): kept, it fills the
             * cells along the edges between them. */
            a->occ.cull_back = hz_box_around_eye(&b, cam) || !a->node_closed[id];
            hz_occlusion_rasterize_quads(&a->occ, a->quads + 12 * (size_t)a->mesh_first[mesh], a->mesh_quads[mesh], m);
        }
        if (threaded)
            pthread_join(th, NULL);
        hz_occlusion_merge(&a->occ, &a->occ_ter); /* both 256 x 144 (city_app_place) */
        a->hook.opts.occlusion = &a->occ;
        hide_patches(a, cam, sp);
        sp->sky_occluders = &a->occ; /* and the sky behind them */
        a->occ_ms = hz_time_ms() - t0;
    } else {
        a->patches_in = a->patches_drawn = sp->patch_count;
        a->blocks_hidden = 0;
        a->ter_window_cells = a->ter_occluders = 0;
    }
    a->hook.next = sp->draw_objects;
    a->hook.next_user = sp->draw_objects_user;
    sp->draw_objects = hz_scene_draw_hook;
    sp->draw_objects_user = &a->hook;
    /* Buildings are opaque occluders: drawn before the terrain (a chained
     * hook runs with them), except for GPU queries, which test the boxes
     * against the depth the terrain has already drawn. */
    sp->objects_first = !o->city.gpu_queries;
}

/* The node a user means: the nearest ancestor with a name (roofs are unnamed
 * children of their building). */
static uint32_t named(const hz_scene *s, uint32_t n)
{
    while (n && !hz_scene_name(s, n)[0])
        n = hz_scene_parent(s, n);
    return n;
}

void city_app_pick_line(const city_app *a, const hz_terrain *t, const hz_camera *cam, float x, float y, uint32_t w,
                        uint32_t h, char *buf, size_t n)
{
    hz_pick_result r = hz_pick(t, a ? a->scene : NULL, cam, x, y, w, h);
    uint32_t nd = r.node ? named(a->scene, r.node) : 0;
    if (!r.hit) {
        snprintf(buf, n, "nothing under %.0f,%.0f (sky)", (double)x, (double)y);
        return;
    }
    int k = snprintf(buf, n, "%s at %.1f, %.1f, %.1f", nd ? hz_scene_name(a->scene, nd) : "terrain", (double)r.pos[0],
                     (double)r.pos[1], (double)r.pos[2]);
    double cx, cy, lon, lat;
    if (t->georef && k > 0 && (size_t)k < n) {
        hz_georef_local_to_crs(t->georef, r.pos[0], r.pos[2], &cx, &cy);
        if (hz_georef_crs_to_lonlat(t->georef, cx, cy, &lon, &lat, NULL) == HZ_OK)
            snprintf(buf + k, n - (size_t)k, "  %s %.1f, %.1f  lon/lat %.6f, %.6f", hz_georef_label(t->georef), cx, cy,
                     lon, lat);
    }
}

void city_app_pick(const city_app *a, const hz_terrain *t, const hz_camera *cam, float x, float y, uint32_t w,
                   uint32_t h, json_t *json)
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
        json_t *pk = json_object();
        jx_set(pk, "pixel", json_pack("[ii]", (int)floorf(x), (int)floorf(y)));
        jx_set(pk, "hit", jx_bool(r.hit));
        if (r.hit) {
            jx_set(pk, "what", jx_str(r.terrain ? "terrain" : "node"));
            jx_set(pk, "world", json_pack("[fff]", (double)r.pos[0], (double)r.pos[1], (double)r.pos[2]));
            jx_set(pk, "distance", jx_fix(r.distance, 3));
            if (n) {
                jx_set(pk, "node", jx_str(name));
                json_t *at = attrs[0] ? json_loads(attrs, 0, NULL) : NULL;
                jx_set(pk, "attributes", at ? at : json_object());
            }
            if (crs) {
                jx_set(pk, "crs", jx_str(hz_georef_label(t->georef)));
                jx_set(pk, "crs_xy", json_pack("[ff]", cx, cy));
            }
            if (ll)
                jx_set(pk, "lonlat", json_pack("[ff]", lon, lat));
        }
        jx_set(json, "pick", pk);
        return;
    }
    if (!r.hit) {
        printf("pick          %.0f,%.0f: nothing (sky)\n", (double)floorf(x), (double)floorf(y));
        return;
    }
    if (n)
        printf("pick          %.0f,%.0f: %s %s\n", (double)floorf(x), (double)floorf(y), name, attrs);
    else
        printf("pick          %.0f,%.0f: terrain\n", (double)floorf(x), (double)floorf(y));
    printf("pick world    %.2f, %.2f, %.2f (%.1f m away)\n", (double)r.pos[0], (double)r.pos[1], (double)r.pos[2],
           (double)r.distance);
    if (crs)
        printf("pick CRS      %s: %.3f, %.3f, height %.2f\n", hz_georef_label(t->georef), cx, cy, (double)r.pos[1]);
    if (ll)
        printf("pick lon/lat  %.7f, %.7f\n", lon, lat);
}

void city_app_print(const city_app *a, json_t *json)
{
    const hz_scene_draw_stats *s = &a->hook.stats;
    const hz_city *c = a->city;
    const hz_scene_file_stats *fs = &a->file_stats;
    if (json) {
        json_t *o = json_object();
        jx_set(o, "scene_objects", jx_int(s->objects));
        jx_set(o, "after_frustum", jx_int(s->after_frustum));
        jx_set(o, "after_occlusion", jx_int(s->after_occlusion));
        jx_set(o, "draw_calls", jx_int(s->draw_calls));
        jx_set(o, "state_changes", jx_int(s->state_changes));
        jx_set(o, "queue_items", jx_int(s->items));
        jx_set(o, "triangles_drawn", jx_int((long long)s->triangles));
        jx_set(o, "cull_ms", jx_fix(s->cull_ms, 3));
        jx_set(o, "occlusion_tests", jx_int(s->occlusion_tests));
        jx_set(o, "occlusion_ms", jx_fix(a->occ_ms, 3));
        jx_set(o, "draw_ms", jx_fix(s->draw_ms, 3));
        jx_set(o, "occluder_quads", jx_int((long long)a->occ.triangles));
        jx_set(o, "shadow_caster_samples", jx_int((long long)a->caster_samples));
        jx_set(o, "terrain_patches", jx_int(a->patches_in));
        jx_set(o, "terrain_patches_drawn", jx_int(a->patches_drawn));
        jx_set(o, "terrain_blocks_hidden", jx_int(a->blocks_hidden));
        jx_set(o, "terrain_window_cells", jx_int(a->ter_window_cells));
        jx_set(o, "terrain_occluders", jx_int(a->ter_occluders));
        jx_set(o, "place_ms", jx_fix(a->place_ms, 1));
        jx_set(o, "meshes", jx_int(hz_scene_mesh_count(a->scene)));
        if (c) {
            jx_set(o, "file_crs", jx_str(c->crs));
            jx_set(o, "buildings", jx_int(c->buildings));
            jx_set(o, "objects", jx_int(c->obj_count));
            jx_set(o, "geometry_instances", jx_int(c->instances));
            jx_set(o, "features", jx_int(c->features));
            jx_set(o, "appearance_materials", jx_int(c->material_count));
            jx_set(o, "material_theme", jx_str(c->material_theme));
            jx_set(o, "faces", jx_int((long long)c->faces));
            jx_set(o, "triangles", jx_int((long long)a->placed.triangles));
            jx_set(o, "load_ms", jx_fix(c->load_ms, 1));
            jx_set(o, "clamp_mean_m", jx_fix(a->placed.mean_shift, 3));
            jx_set(o, "clamp_max_m", jx_fix(a->placed.max_shift, 3));
            jx_set(o, "clamped", jx_int(a->placed.clamped));
            jx_set(o, "without_ground", jx_int(a->placed.outside));
        }
        if (a->fp) {
            json_t *f = json_object();
            jx_set(f, "buildings", jx_int(a->fp->buildings));
            jx_set(f, "crs", jx_str(a->fp->crs));
            jx_set(f, "clamped", jx_int(a->fp_placed.clamped));
            jx_set(f, "without_ground", jx_int(a->fp_placed.outside));
            jx_set(f, "load_ms", jx_fix(a->fp->load_ms, 1));
            jx_set(f, "height_from_field", jx_int(a->fp->height_from_field));
            jx_set(f, "height_field", jx_str(a->fp->height_field));
            jx_set(f, "height_from_levels", jx_int(a->fp->height_from_levels));
            jx_set(f, "levels_field", jx_str(a->fp->levels_field));
            jx_set(f, "height_default", jx_int(a->fp->height_default));
            jx_set(o, "footprints", f);
        }
        if (a->file) {
            json_t *f = json_object();
            jx_set(f, "nodes", jx_int(fs->nodes));
            jx_set(f, "objects", jx_int(fs->objects));
            jx_set(f, "clamped", jx_int(fs->clamped));
            jx_set(f, "meshes", jx_int(fs->meshes));
            jx_set(f, "build_ms", jx_fix(fs->ms, 1));
            jx_set(o, "scene_file", f);
        }
        jx_set(json, "city", o);
        return;
    }
    if (c) {
        printf("city          %u buildings (%s, %llu faces -> %llu triangles", c->buildings,
               c->crs[0] ? c->crs : "no CRS", (unsigned long long)c->faces, (unsigned long long)a->placed.triangles);
        if (c->instances)
            printf(", %u geometry instances", c->instances);
        if (c->features)
            printf(", %u features of a sequence", c->features);
        if (c->material_count)
            printf(", %u materials (theme %s)", c->material_count, c->material_theme[0] ? c->material_theme : "none used");
        printf("), loaded in %.0f ms\n", c->load_ms);
        printf("city ground   %u clamped (mean move %.2f m, max %.2f m), %u without ground under them\n",
               a->placed.clamped, a->placed.mean_shift, a->placed.max_shift, a->placed.outside);
    }
    if (a->fp) {
        const hz_city *f = a->fp;
        printf("footprints    %u buildings extruded (%s), %u clamped (mean move %.2f m), %u without ground\n",
               f->buildings, f->crs, a->fp_placed.clamped, a->fp_placed.mean_shift, a->fp_placed.outside);
        printf("heights       %u from %s, %u from %s x 3 m, %u the default 10 m\n", f->height_from_field,
               f->height_field[0] ? f->height_field : "a height field", f->height_from_levels,
               f->levels_field[0] ? f->levels_field : "a levels field", f->height_default);
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
    hz_city_destroy(a->fp);
    hz_occlusion_free(&a->occ);
    hz_occlusion_free(&a->occ_ter);
    free(a->patch_keep);
    free(a->patch_vis);
    free(a->casters);
    free(a->ter_cmin);
    free(a->ter_quads);
    free(a->ter_cell_ok);
    free(a->occ_node);
    free(a->occ_cand);
    free(a->mesh_first);
    free(a->mesh_quads);
    free(a->node_closed);
    free(a->quads);
    hz_scene_file_destroy(a->file);
    if (a->tin_path[0])
        unlink(a->tin_path);
    free(a);
}

/* ---- horizon city: a procedural city as a scene file ---------------------- */

static uint64_t rng_next(uint64_t *s)
{
    uint64_t z = (*s += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

static double rng_unit(uint64_t *s)
{
    return (double)(rng_next(s) >> 11) * (1.0 / 9007199254740992.0);
}

/* Where lots may be built: the terrain, the city's centre (world x, z) and
 * the steepest ground a building may stand on (tangent). */
typedef struct lot_ground {
    const hz_terrain *t;
    double cx, cz;
    double max_tan;
    uint32_t steep; /* lots left empty */
} lot_ground;

/* True when the ground under a lot (centre x, z relative to the city,
 * w x d metres, any turn) rises no more than max_tan across it: sampled at
 * the corners and the centre of the square that holds it. */
static bool lot_flat_enough(lot_ground *g, double x, double z, double w, double d)
{
    if (!(g->max_tan < 1e6))
        return true;
    const double r = 0.5 * fmax(w, d);
    float lo = INFINITY, hi = -INFINITY;
    static const double k[5][2] = {{0, 0}, {-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
    for (int q = 0; q < 5; q++) {
        const float h = hz_terrain_surface_at(g->t, (float)(g->cx + x + k[q][0] * r), (float)(g->cz + z + k[q][1] * r));
        if (isfinite(h))
            lo = fminf(lo, h), hi = fmaxf(hi, h);
    }
    if (!(hi >= lo) || (double)(hi - lo) <= g->max_tan * 2.0 * r)
        return true;
    g->steep++;
    return false;
}

/* One block of buildings along its four edges (lots of 12-24 m, 10-18 m deep,
 * facing the street), heights rising toward the city centre; lots on ground
 * steeper than allowed stay empty (the same random draws, so the rest of
 * the city does not change). */
static bool add_block(json_t *children, uint64_t *rng, double bx, double bz, double side, double r_norm,
                      uint32_t bi, uint32_t bj, uint32_t *count, lot_ground *ground)
{
    static const char *const mats[4] = {"concrete", "brick", "plaster", "glass"};
    for (int e = 0; e < 4; e++) {
        /* Edge e: along x (north, south) or z (west, east); yaw faces the street. */
        double along = -0.5 * side + 2.0;
        while (along < 0.5 * side - 14.0) {
            double w = 12.0 + 12.0 * rng_unit(rng), d = 10.0 + 8.0 * rng_unit(rng);
            if (along + w > 0.5 * side - 2.0)
                w = 0.5 * side - 2.0 - along;
            double tall = exp(-3.0 * r_norm * r_norm);
            double h = 6.0 + (8.0 + 70.0 * tall * rng_unit(rng)) * rng_unit(rng) + 30.0 * tall;
            double c = along + 0.5 * w, off = 0.5 * side - 0.5 * d - 1.0;
            double x, z, yaw;
            switch (e) {
            case 0: x = c, z = -off, yaw = 0; break;   /* north edge */
            case 1: x = off, z = c, yaw = 90; break;   /* east */
            case 2: x = -c, z = off, yaw = 180; break; /* south */
            default: x = -off, z = -c, yaw = 270; break;
            }
            char name[64];
            snprintf(name, sizeof name, "b_%u_%u_%u", bi, bj, *count);
            const char *mat = mats[rng_next(rng) % (tall > 0.5 ? 4u : 3u)];
            if (!lot_flat_enough(ground, bx + x, bz + z, w, d)) {
                along += w + 1.0 + 3.0 * rng_unit(rng);
                continue;
            }
            json_t *n = json_pack("{s:s, s:s, s:s, s:[f,f,f], s:f, s:[f,f,f], s:s, s:{s:[i,i], s:f, s:i}}", "name",
                                  name, "model", "box", "material", mat, "position", bx + x, 0.0, bz + z, "yaw", yaw,
                                  "scale", w, h, d, "clamp", "ground", "attributes", "block", (int)bi, (int)bj,
                                  "height", floor(h * 10) / 10, "levels", (int)(h / 3.2));
            if (!n || json_array_append_new(children, n))
                return false;
            (*count)++;
            along += w + 1.0 + 3.0 * rng_unit(rng);
        }
    }
    return true;
}

int cmd_city(int argc, char **argv)
{
    uint32_t blocks = 0;
    float block = 120, street = 20, max_slope = 45;
    char **rest = calloc((size_t)argc + 1, sizeof *rest);
    if (!rest)
        return 1;
    int nr = 0;
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (i >= 2 && (!strcmp(a, "--help") || !strcmp(a, "-h"))) {
            fprintf(stderr, "usage: horizon city --blocks N --out FILE.json [terrain options] [--block M] [--street M]\n"
                            "       [--max-slope DEG]\n"
                            "Writes a scene file (docs/scene.md) of a procedural city: N x N blocks of --block metres\n"
                            "(default 120) between streets of --street metres (default 20), buildings along each\n"
                            "block's edges (about 24 per block), taller toward the centre, four materials, one box\n"
                            "model instanced, every building clamped to the ground; centred on the terrain given\n"
                            "(default: a generated one), which the scene names. --seed also seeds the city.\n"
                            "Lots on ground steeper than --max-slope degrees (default 45; 90: any) stay empty.\n");
            cli_usage_terrain();
            free(rest);
            return 0;
        }
        if (i >= 2 && (!strcmp(a, "--blocks") || !strcmp(a, "--block") || !strcmp(a, "--street") ||
                       !strcmp(a, "--max-slope"))) {
            bool ok = v && (!strcmp(a, "--blocks")    ? cli_parse_u32(v, 1, 400, &blocks)
                            : !strcmp(a, "--block")   ? cli_parse_float(v, 40, 2000, &block)
                            : !strcmp(a, "--street")  ? cli_parse_float(v, 4, 500, &street)
                                                      : cli_parse_float(v, 0, 90, &max_slope));
            if (!ok) {
                fprintf(stderr, "horizon city: %s wants %s, not '%s'\n", a,
                        !strcmp(a, "--blocks")   ? "a count in [1, 400]"
                        : !strcmp(a, "--block")  ? "metres in [40, 2000]"
                        : !strcmp(a, "--street") ? "metres in [4, 500]"
                                                 : "degrees in [0, 90]",
                        v ? v : "(nothing)");
                free(rest);
                return 2;
            }
            i++;
            continue;
        }
        rest[nr++] = argv[i];
    }
    cli_opts o;
    int rc = cli_parse(nr, rest, 2, &o, "city");
    free(rest);
    if (rc)
        return rc;
    if (!blocks || !o.out) {
        fprintf(stderr, "horizon city: give --blocks N and --out FILE.json (see horizon city --help)\n");
        return 2;
    }
    cli_file ins[8];
    const size_t nin = cli_opts_inputs(&o, ins, 0, 8);
    const cli_file outs[] = {{o.out, "--out", CLI_FILE}};
    if ((rc = cli_check_outputs("city", outs, 1, ins, nin)))
        return rc;
    hz_terrain *t = cli_load_terrain(&o);
    if (!t)
        return 1;
    /* Centre on the DEM's data (not its padding). */
    const uint32_t dw = t->data_w ? t->data_w : t->hm.size, dh = t->data_h ? t->data_h : t->hm.size;
    const double cx = ((double)t->data_x + 0.5 * (dw - 1)) * t->spacing;
    const double cz = ((double)t->data_y + 0.5 * (dh - 1)) * t->spacing;
    const double pitch = (double)block + (double)street;
    const double half = 0.5 * pitch * blocks;
    if (half > 0.5 * (double)(dw < dh ? dw : dh) * t->spacing && !o.quiet)
        fprintf(stderr, "horizon city: the city (%.0f m across) is larger than the terrain's data (%.0f m)\n",
                2 * half, (double)(dw < dh ? dw : dh) * t->spacing);
    json_t *root = json_object(), *nodes = json_array(), *children = json_array();
    /* The DEM by its absolute path: the scene resolves relative names against its own folder. */
    char *dem_abs = o.terrain.dem_path ? realpath(o.terrain.dem_path, NULL) : NULL;
    json_t *terrain = o.terrain.dem_path ? json_pack("{s:s}", "dem", dem_abs ? dem_abs : o.terrain.dem_path)
                                         : json_pack("{s:s, s:i, s:I}", "generate",
                                                     o.terrain.generate == HZ_GEN_DIAMOND ? "diamond" : "perlin",
                                                     "size", (int)(o.terrain.gen_size ? o.terrain.gen_size : 4097),
                                                     "seed", (json_int_t)o.terrain.seed);
    free(dem_abs);
    if (terrain && o.terrain.spacing > 0)
        json_object_set_new(terrain, "spacing", json_real(o.terrain.spacing));
    json_t *mats = json_pack("{s:{s:[f,f,f]}, s:{s:[f,f,f]}, s:{s:[f,f,f]}, s:{s:[f,f,f]}}", "concrete", "color",
                             0.62, 0.62, 0.60, "brick", "color", 0.58, 0.32, 0.24, "plaster", "color", 0.82, 0.76,
                             0.62, "glass", "color", 0.36, 0.47, 0.55);
    json_t *models = json_pack("{s:{s:[f,f,f]}}", "box", "box", 1.0, 1.0, 1.0);
    uint64_t rng = o.terrain.seed * 0x2545f4914f6cdd1dull + blocks;
    uint32_t count = 0;
    lot_ground ground = {.t = t, .cx = cx, .cz = cz,
                         .max_tan = max_slope >= 90.0f ? INFINITY : tan(glm_rad(max_slope))};
    bool ok = root && nodes && children && terrain && mats && models;
    for (uint32_t bj = 0; ok && bj < blocks; bj++)
        for (uint32_t bi = 0; ok && bi < blocks; bi++) {
            double bx = ((double)bi + 0.5) * pitch - half, bz = ((double)bj + 0.5) * pitch - half;
            double r = sqrt(bx * bx + bz * bz) / (half > 0 ? half : 1);
            json_t *bl = json_array();
            char name[32];
            snprintf(name, sizeof name, "block_%u_%u", bi, bj);
            ok = bl && add_block(bl, &rng, bx, bz, block, r, bi, bj, &count, &ground);
            json_t *node = ok ? json_pack("{s:s, s:o}", "name", name, "children", bl) : NULL;
            ok = node && !json_array_append_new(children, node);
        }
    json_t *city = ok ? json_pack("{s:s, s:[f,f,f], s:o}", "name", "city", "position", cx, 0.0, cz, "children",
                                  children)
                      : NULL;
    ok = city && !json_array_append_new(nodes, city);
    if (ok) {
        json_object_set_new(root, "horizon_scene", json_integer(1));
        json_object_set_new(root, "terrain", terrain);
        json_object_set_new(root, "lights", json_pack("{s:[f,f]}", "sun", 235.0, 35.0));
        json_object_set_new(root, "materials", mats);
        json_object_set_new(root, "models", models);
        json_object_set_new(root, "nodes", nodes);
    }
    hz_outfile of;
    hz_err err = {0};
    rc = 1;
    if (!ok) {
        fprintf(stderr, "horizon city: out of memory\n");
    } else if (hz_outfile_begin(&of, o.out, &err) != HZ_OK) {
        fprintf(stderr, "horizon city: %s\n", err.msg);
    } else if (json_dump_file(root, of.tmp, JSON_COMPACT) != 0) {
        hz_outfile_discard(&of);
        fprintf(stderr, "horizon city: cannot write %s\n", o.out);
    } else if (hz_outfile_commit(&of, &err) != HZ_OK) {
        fprintf(stderr, "horizon city: %s\n", err.msg);
    } else {
        printf("city          %u x %u blocks, %u buildings, %.0f m across, centred at %.0f, %.0f on %s\n", blocks,
               blocks, count, 2 * half, cx, cz, t->source);
        if (ground.steep)
            printf("steep ground  %u lots left empty (steeper than %.0f degrees)\n", ground.steep, max_slope);
        printf("scene         %s\n", o.out);
        rc = 0;
    }
    if (!ok) {
        json_decref(terrain);
        json_decref(mats);
        json_decref(models);
        json_decref(children);
        json_decref(nodes);
    }
    json_decref(root);
    hz_terrain_destroy(t);
    return rc;
}

/* ---- --city-bench: every culling / queue stage on and off on the same frames -- */

typedef struct bench_cfg {
    const char *name;
    bool no_frustum, no_occlusion, naive, gpu;
} bench_cfg;

static const bench_cfg bench_cfgs[] = {
    {"none_naive", true, true, true, false},        /* the reference: everything, one draw per object */
    {"none_sorted", true, true, false, false},
    {"frustum_naive", false, true, true, false},
    {"frustum_sorted", false, true, false, false},
    {"occlusion_naive", false, false, true, false},
    {"occlusion_sorted", false, false, false, false}, /* everything on (the default) */
    {"gpuquery_sorted", false, true, false, true}, /* GPU occlusion queries instead of the CPU buffer */
};
#define BENCH_CFGS (sizeof bench_cfgs / sizeof *bench_cfgs)

static int cmp_d(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* The path's cameras: "street" walks 2 m above the ground from the scene's
 * centre (or --camera's x, z, yaw) 400 m ahead; "overview" circles the
 * scene 600 m up, looking at its centre. */
static void bench_camera(const city_app *a, const struct cli_opts *o, const hz_terrain *t, const char *kind,
                         uint32_t k, uint32_t n, hz_camera *c)
{
    *c = cli_camera(o, t);
    hz_box b;
    hz_scene_bounds(a->scene, &b);
    float cx = 0.5f * (b.min[0] + b.max[0]), cz = 0.5f * (b.min[2] + b.max[2]);
    float ext = fmaxf(b.max[0] - b.min[0], b.max[2] - b.min[2]);
    const float u = n > 1 ? (float)k / (float)(n - 1) : 0;
    if (!strcmp(kind, "street")) {
        float x0 = o->have_camera ? o->camera[0] : cx, z0 = o->have_camera ? o->camera[2] : cz;
        float yaw = o->have_camera ? o->camera[3] : 0;
        float d = 400.0f * u;
        c->pos[0] = x0 + d * sinf(glm_rad(yaw));
        c->pos[2] = z0 - d * cosf(glm_rad(yaw));
        c->pos[1] = hz_terrain_surface_at(t, c->pos[0], c->pos[2]) + 2.0f;
        c->yaw = yaw;
        c->pitch = 2;
    } else {
        float ang = glm_rad(360.0f * u), r = 0.6f * ext + 100.0f;
        c->pos[0] = cx + r * sinf(ang);
        c->pos[2] = cz + r * cosf(ang);
        float g = hz_terrain_surface_at(t, cx, cz);
        c->pos[1] = fmaxf(g, hz_terrain_surface_at(t, c->pos[0], c->pos[2])) + 600.0f;
        c->yaw = glm_deg(atan2f(cx - c->pos[0], -(cz - c->pos[2])));
        c->pitch = -glm_deg(atan2f(c->pos[1] - g, r));
    }
}

int city_app_bench(city_app *a, struct cli_opts *o, hz_terrain *t, hz_renderer *ren, app_fx *afx, bool json)
{
    const char *kind = o->city.bench;
    const uint32_t frames = o->city.bench_frames ? o->city.bench_frames : 12;
    const size_t px = (size_t)o->width * o->height * 3;
    double *ms = calloc((size_t)frames * BENCH_CFGS, sizeof *ms);
    double sum_obj[BENCH_CFGS][10] = {{0}}; /* after frustum, after occlusion, draw calls, state changes, occ ms,
                                              query ms, terrain patches in view, drawn, sky cells drawn,
                                              blocks of the drawn patches hidden */
    uint64_t diff[BENCH_CFGS] = {0}, diff_frames[BENCH_CFGS] = {0};
    struct {
        bool built;
        uint32_t rest;
        hz_scene_draw_stats stats;
    } adapt[BENCH_CFGS] = {{0}};
    uint8_t *img = malloc(px * BENCH_CFGS);
    uint32_t objects = 0;
    cli_lod_frame lf = {0};
    hz_err err = {0};
    int rc = 1;
    if (!ms || !img) {
        fprintf(stderr, "horizon render: out of memory\n");
        goto out;
    }
    for (uint32_t k = 0; k < frames; k++) {
        hz_camera cam;
        bench_camera(a, o, t, kind, k, frames, &cam);
        if (cli_lod_select(t, &cam, &o->lod, &lf) != HZ_OK) {
            fprintf(stderr, "horizon render: out of memory in LOD selection\n");
            goto out;
        }
        /* A warm-up draw, then every configuration in an order rotating per frame. */
        for (uint32_t r = 0; r <= BENCH_CFGS; r++) {
            const uint32_t ci = r == 0 ? 0 : (r - 1 + k) % BENCH_CFGS;
            const bench_cfg *bc = &bench_cfgs[ci];
            city_opts keep = o->city;
            o->city.no_frustum = bc->no_frustum;
            o->city.no_occlusion = bc->no_occlusion;
            o->city.naive = bc->naive;
            o->city.gpu_queries = bc->gpu;
            hz_scene_params sp = {0};
            app_fx_params(afx, t, &cam, &o->lod, o->time, &sp);
            const uint32_t *idx;
            uint32_t count;
            cli_lod_scene(&lf, &sp, &idx, &count);
            /* Each configuration blurs motion with its own frames (and the
             * warm-up draws with none of theirs), as if it ran alone. */
            _Static_assert(BENCH_CFGS < HZ_MAX_HISTORY, "a motion blur slot per configuration");
            sp.history = r == 0 ? (uint32_t)BENCH_CFGS : ci;
            sp.reset_history = k == 0;
            /* Each configuration keeps its own adaptive occlusion state, as
             * if it ran alone. */
            a->occ_built = adapt[ci].built;
            a->occ_rest = adapt[ci].rest;
            a->hook.stats = adapt[ci].stats;
            city_app_frame(a, o, &cam, o->width, o->height, &sp);
            o->city = keep;
            hz_draw_stats ds = {0};
            if (hz_renderer_draw(ren, &cam, &sp, idx, count, &ds, &err) != HZ_OK || a->hook.failed) {
                fprintf(stderr, "horizon render: %s\n", a->hook.failed ? a->hook.err.msg : err.msg);
                goto out;
            }
            adapt[ci].built = a->occ_built;
            adapt[ci].rest = a->occ_rest;
            adapt[ci].stats = a->hook.stats;
            if (r == 0)
                continue;
            const hz_scene_draw_stats *s = &a->hook.stats;
            objects = s->objects;
            ms[ci * frames + k] = ds.draw_ms + a->occ_ms;
            sum_obj[ci][0] += s->after_frustum;
            sum_obj[ci][1] += s->after_occlusion;
            sum_obj[ci][2] += s->draw_calls;
            sum_obj[ci][3] += s->state_changes;
            sum_obj[ci][4] += a->occ_ms;
            sum_obj[ci][5] += s->query_ms;
            sum_obj[ci][6] += a->patches_in;
            sum_obj[ci][7] += a->patches_drawn;
            sum_obj[ci][8] += ds.sky_cells;
            sum_obj[ci][9] += a->blocks_hidden;
            if (hz_renderer_read_rgb(ren, img + px * ci, &err) != HZ_OK) {
                fprintf(stderr, "horizon render: %s\n", err.msg);
                goto out;
            }
        }
        /* Pixels that differ from the unculled frame drawn in the same queue
         * order (none_naive or none_sorted): what culling changed. (Between
         * the two orders, coplanar faces of touching buildings may resolve
         * differently at equal depth.) */
        for (uint32_t ci = 2; ci < BENCH_CFGS; ci++) {
            const uint8_t *ref = img + px * (bench_cfgs[ci].naive ? 0 : 1);
            uint64_t d = 0;
            for (size_t p = 0; p < px; p += 3)
                d += memcmp(ref + p, img + px * ci + p, 3) != 0;
            diff[ci] = d > diff[ci] ? d : diff[ci];
            diff_frames[ci] += d > 0;
        }
    }
    if (json)
        printf("{\"bench\":\"%s\",\"frames\":%u,\"objects\":%u,\"width\":%u,\"height\":%u,\"configs\":[", kind,
               frames, objects, o->width, o->height);
    else
        printf("city bench    %s path, %u frames, %u objects, %ux%u (frame ms: median over frames, all passes + "
               "occlusion buffer)\n%-18s %9s %9s %9s %9s %9s %9s %9s %9s %12s\n",
               kind, frames, objects, o->width, o->height, "config", "frame_ms", "frustum", "occlusion", "draws",
               "states", "occ_ms", "terrain", "sky", "diff_px_max");
    for (uint32_t ci = 0; ci < BENCH_CFGS; ci++) {
        double *v = ms + ci * frames;
        qsort(v, frames, sizeof *v, cmp_d);
        double med = frames % 2 ? v[frames / 2] : 0.5 * (v[frames / 2 - 1] + v[frames / 2]);
        const double f = frames;
        if (json)
            printf("%s{\"config\":\"%s\",\"frame_ms\":%.3f,\"after_frustum\":%.1f,\"after_occlusion\":%.1f,"
                   "\"draw_calls\":%.1f,\"state_changes\":%.1f,\"occlusion_ms\":%.3f,\"query_ms\":%.3f,"
                   "\"terrain_patches\":%.1f,\"terrain_patches_drawn\":%.1f,\"terrain_blocks_hidden\":%.1f,"
                   "\"sky_cells\":%.1f,"
                   "\"diff_pixels_max\":%llu,\"diff_frames\":%llu}",
                   ci ? "," : "", bench_cfgs[ci].name, med, sum_obj[ci][0] / f, sum_obj[ci][1] / f,
                   sum_obj[ci][2] / f, sum_obj[ci][3] / f, sum_obj[ci][4] / f, sum_obj[ci][5] / f,
                   sum_obj[ci][6] / f, sum_obj[ci][7] / f, sum_obj[ci][9] / f, sum_obj[ci][8] / f,
                   (unsigned long long)diff[ci],
                   (unsigned long long)diff_frames[ci]);
        else
            printf("%-18s %9.1f %9.0f %9.0f %9.0f %9.0f %9.2f %9.0f %9.0f %12llu\n", bench_cfgs[ci].name, med,
                   sum_obj[ci][0] / f, sum_obj[ci][1] / f, sum_obj[ci][2] / f, sum_obj[ci][3] / f,
                   sum_obj[ci][4] / f + sum_obj[ci][5] / f, sum_obj[ci][7] / f, sum_obj[ci][8] / f,
                   (unsigned long long)diff[ci]);
    }
    if (json)
        printf("]}\n");
    /* --out: the path's last frame with every stage on (the default). */
    if (o->out) {
        hz_outfile of;
        uint32_t def = 0;
        while (strcmp(bench_cfgs[def].name, "occlusion_sorted"))
            def++;
        const uint8_t *last = img + px * def;
        if (hz_outfile_begin(&of, o->out, &err) != HZ_OK)
            goto fail;
        if (hz_image_write_png(of.tmp, last, o->width, o->height, &err) != HZ_OK ||
            hz_outfile_commit(&of, &err) != HZ_OK) {
            hz_outfile_discard(&of);
            goto fail;
        }
    }
    rc = 0;
    goto out;
fail:
    fprintf(stderr, "horizon render: %s\n", err.msg);
out:
    cli_lod_frame_free(&lf);
    free(ms);
    free(img);
    return rc;
}
