/* --forest for render, bench and view: models (loaded, or grown, ranked and
 * cached), placement on the terrain, per-frame selection, the draw hook. */
#include "cli.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

#include "horizon/blob.h"
#include "horizon/safety.h"

void cli_usage_forest(void)
{
    fprintf(stderr,
            "forest:\n"
            "  --forest N              place N trees around --forest-at (default: the most plantable\n"
            "                          ground, real data clear of buildings, near the map's middle)\n"
            "  --forest-trees A,B,...  tree models to use: .hzt files, or models assimp reads (OBJ,\n"
            "                          glTF...; imported, ranked and cached); default: oak, maple,\n"
            "                          birch, conifer, grown, VMI-ranked and cached on first use\n"
            "  --forest-leaves N       leaves per generated tree (default: each species' own)\n"
            "  --tree-cache DIR        cache of generated trees (default ~/.cache/horizon/trees)\n"
            "  --forest-density D      trees per hectare (default 400)\n"
            "  --forest-at X,Z         forest centre, metres\n"
            "  --forest-file F.csv     trees from a file instead: x,z,model,scale,yaw_degrees per line\n"
            "                          (model: 0-based index into the models; y from the terrain)\n"
            "  --forest-save F.csv     write the placed trees there, in --forest-file's format\n"
            "  --forest-seed S         placement seed (default 1)\n"
            "  --no-simplify           every tree in the frustum at full detail (reference)\n"
            "  --no-hysteresis         update every node's rate every frame (no F6)\n"
            "  --no-enlarge            no leaf enlargement (F4)\n"
            "  --no-node-cull          no per-node frustum culling\n"
            "  --tree-near M --tree-far M  F3 distances near/far (default 5, 80)\n"
            "  --hull-dist M           trees beyond are crown hulls (default: a quarter of --tree-far),\n"
            "                          beyond max(half of --tree-far, 2 x M) impostors\n"
            "  --rate-weights W1,..,W5 F3 weights (default 0.2,0.1,0.2,0.3,0.2)\n");
}

static const char *const SPECIES[] = {"oak", "maple", "birch", "conifer"};

/* Progress of growing and ranking: a bar on a terminal, otherwise a line
 * every 10 % or 10 s (logs, CI), so a long first run never looks hung. */
typedef struct line_progress {
    const char *what;
    int last_pct;
    double last_ms;
} line_progress;

void cli_pr_json(json_t *obj, const char *prefix, const hz_pr_result *r)
{
    const struct {
        const char *measure;
        double p, r, f;
    } m[2] = {{"", r->precision, r->recall, r->f_measure},
              {"_leaf", r->leaf_precision, r->leaf_recall, r->leaf_f_measure}};
    char key[96];
    for (int k = 0; k < 2; k++) {
        snprintf(key, sizeof key, "%s%s_precision", prefix, m[k].measure);
        jx_set(obj, key, jx_fix(m[k].p, 4));
        snprintf(key, sizeof key, "%s%s_recall", prefix, m[k].measure);
        jx_set(obj, key, jx_fix(m[k].r, 4));
        snprintf(key, sizeof key, "%s%s_f", prefix, m[k].measure);
        jx_set(obj, key, jx_fix(m[k].f, 4));
    }
}

void cli_tree_progress(void *user, const char *label, uint64_t done, uint64_t total)
{
    static line_progress shared = {.last_pct = -100};
    line_progress *lp = user ? user : &shared;
    if (done == 0 || (lp == &shared && lp->last_pct > (total ? (int)(done * 100 / total) : 100))) {
        lp->last_pct = -100; /* a new run */
        lp->last_ms = hz_time_ms();
    }
    if (isatty(STDERR_FILENO)) {
        hz_progress_stderr(NULL, label, done, total);
        return;
    }
    int pct = total ? (int)(done * 100 / total) : 100;
    double now = hz_time_ms();
    if (pct >= lp->last_pct + 10 || now - lp->last_ms > 10000.0 || done >= total) {
        fprintf(stderr, "horizon: %s%s%s: %d%% (%llu/%llu)\n", lp->what ? lp->what : "", lp->what ? ": " : "",
                label ? label : "", pct, (unsigned long long)done, (unsigned long long)total);
        fflush(stderr);
        lp->last_pct = pct;
        lp->last_ms = now;
    }
}
static const float SPECIES_HIGH[] = {0.0f, 0.3f, 0.55f, 1.0f};

static bool mkdir_p(const char *dir)
{
    char buf[1024];
    snprintf(buf, sizeof buf, "%s", dir);
    for (char *p = buf + 1; *p; p++)
        if (*p == '/') {
            *p = 0;
            if (mkdir(buf, 0755) != 0 && errno != EEXIST)
                return false;
            *p = '/';
        }
    return mkdir(buf, 0755) == 0 || errno == EEXIST;
}

/* The tree cache directory (--tree-cache, XDG, ~/.cache); false: none. */
static bool cache_dir(const cli_opts *o, char *dir, size_t cap)
{
    if (o->tree_cache && !strcmp(o->tree_cache, "none"))
        return false;
    if (o->tree_cache) {
        snprintf(dir, cap, "%s", o->tree_cache);
        return true;
    }
    const char *xdg = getenv("XDG_CACHE_HOME"), *home = getenv("HOME");
    if (xdg && *xdg)
        snprintf(dir, cap, "%s/horizon/trees", xdg);
    else if (home && *home)
        snprintf(dir, cap, "%s/.cache/horizon/trees", home);
    else
        return false;
    return true;
}

/* A tree from the cache, or made (grown from a species or imported from a
 * model file), VMI-ranked, hulled and cached. The cache file is keyed by
 * everything that makes the tree: the species and seed or the model file
 * (name, size, time), the leaves asked, the ranking (views, their least
 * elevation, resolution, layers) and hull parameters, and the generator's version. */
static hz_tree *cached_model(const cli_opts *o, const char *species, const char *import, hz_err *err)
{
    const hz_rank_desc rank = {.views = 162, .res = 32, .layers = 4, .min_elevation = 0, .tree_res = HZ_RANK_TREE_RES};
    const hz_hull_desc hull = {.grid = 40, .triangles = 3000};
    const uint64_t seed = 1;
    char dir[700], file[1100], key[300];
    if (import) {
        struct stat ms;
        if (stat(import, &ms) != 0) {
            hz_err_set(err, HZ_ERR_IO, "cannot open '%s': %s", import, strerror(errno));
            return NULL;
        }
        const char *base = strrchr(import, '/');
        base = base ? base + 1 : import;
        snprintf(key, sizeof key, "import-%.120s-%lld-%lld", base, (long long)ms.st_size, (long long)ms.st_mtime);
        for (char *p = key; *p; p++)
            if (*p == '/' || *p == ' ')
                *p = '_';
    } else {
        snprintf(key, sizeof key, "%s-s%llu-l%u", species, (unsigned long long)seed, o->forest_leaves);
    }
    bool cache = cache_dir(o, dir, sizeof dir);
    if (cache) {
        snprintf(file, sizeof file, "%s/%s-v%ue%dr%uk%u-h%ut%u-g3.hzt", dir, key, rank.views,
                 (int)rank.min_elevation, rank.tree_res ? rank.tree_res : rank.res, rank.layers,
                 hull.grid, hull.triangles);
        struct stat sb;
        if (stat(file, &sb) == 0) {
            hz_tree *t = hz_tree_load(file, err);
            if (t && t->ranked && t->hull.index_count)
                return t;
            hz_tree_destroy(t);
            if (!o->quiet)
                fprintf(stderr, "horizon: regenerating %s (%s)\n", file, err->msg);
        }
    }
    const char *name = import ? import : species;
    hz_tree *t;
    if (import) {
        if (!o->quiet)
            fprintf(stderr, "horizon: importing and ranking %s (cached for next time)\n", import);
        t = hz_tree_import(&(hz_tree_import_desc){.path = import}, err);
    } else {
        if (!o->quiet)
            fprintf(stderr, "horizon: growing and ranking a %s tree (cached for next time)\n", species);
        t = hz_tree_grow(&(hz_tree_desc){.species = species, .seed = seed, .leaves = o->forest_leaves}, err);
    }
    if (!t)
        return NULL;
    line_progress lp = {.what = name, .last_pct = -100, .last_ms = hz_time_ms()};
    hz_rank_desc rd = rank;
    rd.progress = o->quiet ? NULL : cli_tree_progress;
    rd.progress_user = &lp;
    if (hz_tree_rank(t, &rd, NULL, err) != HZ_OK) {
        hz_tree_destroy(t);
        return NULL;
    }
    if (!o->quiet)
        fprintf(stderr, "horizon: %s: crown hull\n", name);
    if (hz_hull_build(t, &hull, NULL, err) != HZ_OK) {
        hz_tree_destroy(t);
        return NULL;
    }
    if (cache) {
        hz_err e2 = {0};
        hz_outfile of = {0};
        /* Through a temporary file: a run reading the cache meanwhile never
         * sees half a tree. */
        bool saved = mkdir_p(dir) && hz_outfile_begin(&of, file, &e2) == HZ_OK &&
                     hz_tree_save(t, of.tmp, &e2) == HZ_OK && hz_outfile_commit(&of, &e2) == HZ_OK;
        hz_outfile_discard(&of);
        if (!saved) {
            if (!o->quiet)
                fprintf(stderr, "horizon: cannot cache the tree in %s (%s)\n", dir, e2.msg[0] ? e2.msg : strerror(errno));
        }
    }
    return t;
}

/* A model named in --forest-trees: a .hzt file, or any model assimp reads
 * (OBJ, glTF, FBX...), imported, ranked and cached like the species. */
static hz_tree *model_file(const cli_opts *o, const char *path, hz_err *err)
{
    size_t n = strlen(path);
    if (n >= 4 && !strcasecmp(path + n - 4, ".hzt")) {
        hz_tree *m = hz_tree_load(path, err);
        if (!m)
            return NULL;
        if (!m->hull.index_count && hz_hull_build(m, NULL, NULL, err) != HZ_OK) {
            hz_tree_destroy(m);
            return NULL;
        }
        if (!m->ranked && !o->quiet)
            fprintf(stderr, "horizon: note: %s is not VMI-ranked; leaves are pruned in file order\n", path);
        return m;
    }
    return cached_model(o, NULL, path, err);
}

/* x,z,model,scale,yaw lines ('#' comments, blank lines skipped). */
bool cli_read_forest_file(const char *file, const hz_terrain *t, uint32_t models, hz_forest_tree **out,
                             uint32_t *n, hz_err *err)
{
    FILE *f = fopen(file, "r");
    if (!f) {
        hz_err_set(err, HZ_ERR_IO, "cannot open forest file '%s': %s", file, strerror(errno));
        return false;
    }
    char line[512];
    uint32_t cap = 0, ln = 0;
    *out = NULL;
    *n = 0;
    while (fgets(line, sizeof line, f)) {
        ln++;
        if (!strchr(line, '\n') && !feof(f)) {
            hz_err_set(err, HZ_ERR_FORMAT, "%s:%u: line too long (over %zu bytes)", file, ln, sizeof line - 2);
            fclose(f);
            free(*out);
            *out = NULL;
            return false;
        }
        char *p = line;
        while (*p == ' ' || *p == '\t')
            p++;
        if (*p == '#' || *p == '\n' || *p == '\r' || !*p)
            continue;
        double x, z, sc, yaw;
        unsigned m;
        char extra;
        /* Positions and angles in the range of --camera (also keeps the
         * float conversions below defined). */
        if (sscanf(p, "%lf,%lf,%u,%lf,%lf %c", &x, &z, &m, &sc, &yaw, &extra) != 5 || !(fabs(x) <= 1e7) ||
            !(fabs(z) <= 1e7) || !(fabs(yaw) <= 1e7) || !(sc >= 1e-3 && sc <= 100) || m >= models) {
            hz_err_set(err, HZ_ERR_FORMAT,
                       "%s:%u: expected x,z,model,scale,yaw with x, z in [-1e7, 1e7] m, model < %u, scale in "
                       "[0.001, 100] and yaw in [-1e7, 1e7] degrees",
                       file, ln, models);
            fclose(f);
            free(*out);
            *out = NULL;
            return false;
        }
        if (*n == cap) {
            cap = cap ? cap * 2 : 256;
            hz_forest_tree *np = realloc(*out, cap * sizeof *np);
            if (!np || cap > 1000000) {
                free(np ? np : *out);
                *out = NULL;
                fclose(f);
                hz_err_set(err, HZ_ERR_MEMORY, "%s: too many trees", file);
                return false;
            }
            *out = np;
        }
        (*out)[(*n)++] = (hz_forest_tree){.pos = {(float)x, hz_terrain_height_at(t, (float)x, (float)z), (float)z},
                                          .yaw = (float)(yaw * 0.017453292519943295), .scale = (float)sc,
                                          .model = m};
    }
    fclose(f);
    if (*n == 0) {
        hz_err_set(err, HZ_ERR_FORMAT, "forest file '%s' lists no tree", file);
        return false;
    }
    return true;
}

/* The trees as --forest-file reads them back (positions to the centimetre,
 * yaw to a hundredth of a degree). */
static bool write_forest_file(const char *path, const cli_forest *cf, const hz_forest_tree *trees, uint32_t n,
                              hz_err *err)
{
    FILE *f = fopen(path, "w");
    if (!f) {
        hz_err_set(err, HZ_ERR_IO, "cannot write '%s': %s", path, strerror(errno));
        return false;
    }
    fprintf(f, "# horizon forest: %u trees, x,z,model,scale,yaw_degrees (x, z in metres on the map)\n# models:", n);
    for (uint32_t k = 0; k < cf->model_count; k++)
        fprintf(f, " %u=%s", k, cf->models[k]->species[0] ? cf->models[k]->species : "(unnamed)");
    fputc('\n', f);
    for (uint32_t k = 0; k < n; k++)
        fprintf(f, "%.2f,%.2f,%u,%.4f,%.2f\n", trees[k].pos[0], trees[k].pos[2], trees[k].model, trees[k].scale,
                trees[k].yaw * 57.29577951308232);
    bool ok = !ferror(f);
    ok = (fclose(f) == 0) && ok;
    if (!ok)
        hz_err_set(err, HZ_ERR_IO, "cannot write '%s': %s", path, strerror(errno));
    return ok;
}

typedef struct plant_ground {
    const hz_terrain *t;
    const float *tops; /* the objects standing on the ground, or NULL */
} plant_ground;

/* Ground a tree may stand on: real data (not nodata or padding, which is not
 * drawn) where no object stands (the crowns are checked once the models are
 * chosen). */
static bool plantable(const hz_terrain *t, const float *tops, float x, float z)
{
    return hz_terrain_valid_at(t, x, z) && hz_ground_clear(tops, t->hm.size, t->spacing, x, z, 0.0f);
}

/* The ground for planting: none (NaN) where it is not plantable. */
static float ground(void *user, float x, float z)
{
    const plant_ground *g = user;
    return plantable(g->t, g->tops, x, z) ? hz_terrain_height_at(g->t, x, z) : NAN;
}

/* Where model k's baked impostor is kept in the tree cache dir
 * (DIR/impostor-KEY.hzb, about 1 MB compressed), under
 * hz_forest_gpu_impostor_key (what it depends on), which it returns. */
static uint64_t impostor_path(const cli_forest *cf, uint32_t k, const char *dir, char *path, size_t cap)
{
    const uint64_t key = hz_forest_gpu_impostor_key(cf->models[k]);
    snprintf(path, cap, "%s/impostor-%016llx.hzb", dir, (unsigned long long)key);
    return key;
}

/* The models' baked impostors from the tree cache: loaded when present and
 * whole (NULL entries are baked). */
static uint8_t **impostors_load(const cli_opts *o, const cli_forest *cf)
{
    char dir[700], path[800];
    if (!cache_dir(o, dir, sizeof dir))
        return NULL;
    uint8_t **imp = calloc(cf->model_count, sizeof *imp);
    if (!imp)
        return NULL;
    const size_t bytes = hz_forest_gpu_impostor_bytes();
    for (uint32_t k = 0; k < cf->model_count; k++) {
        const uint64_t key = impostor_path(cf, k, dir, path, sizeof path);
        struct stat sb;
        if (stat(path, &sb) != 0)
            continue;
        hz_err e = {0};
        uint8_t *b = malloc(bytes);
        if (b && hz_blob_load(path, key, b, bytes, &e) == HZ_OK) {
            imp[k] = b;
            continue;
        }
        free(b);
        if (!o->quiet)
            fprintf(stderr, "horizon: baking the impostor again: %s\n", b ? e.msg : "out of memory");
    }
    return imp;
}

/* Stores the impostors baked this run (best effort: the forest works without). */
static void impostors_store(const cli_opts *o, const cli_forest *cf)
{
    char dir[700], path[800];
    if (!cache_dir(o, dir, sizeof dir))
        return;
    const size_t bytes = hz_forest_gpu_impostor_bytes();
    uint8_t *b = NULL;
    for (uint32_t k = 0; k < cf->model_count; k++) {
        if (!hz_forest_gpu_impostor_baked(cf->gpu, k))
            continue;
        if (!b && !(b = malloc(bytes)))
            return;
        const uint64_t key = impostor_path(cf, k, dir, path, sizeof path);
        hz_err e = {0};
        if (!mkdir_p(dir) || hz_forest_gpu_impostor_read(cf->gpu, k, b, &e) != HZ_OK ||
            hz_blob_save(path, key, b, bytes, &e) != HZ_OK) {
            if (!o->quiet)
                fprintf(stderr, "horizon: cannot cache the impostor in %s (%s)\n", dir, e.msg[0] ? e.msg : strerror(errno));
        }
    }
    free(b);
}

cli_forest *cli_forest_create(const cli_opts *o, const hz_terrain *t, const float *object_tops)
{
    hz_err err = {0};
    cli_forest *cf = calloc(1, sizeof *cf);
    hz_forest_tree *trees = NULL;
    float *high = NULL;
    if (!cf) {
        fprintf(stderr, "horizon: out of memory\n");
        return NULL;
    }
    double t0 = hz_time_ms();
    if (o->forest_trees) {
        char buf[4096];
        snprintf(buf, sizeof buf, "%s", o->forest_trees);
        uint32_t n = 1;
        for (const char *p = buf; *p; p++)
            n += *p == ',';
        cf->models = calloc(n, sizeof *cf->models);
        high = calloc(n, sizeof *high);
        if (!cf->models || !high) {
            hz_err_set(&err, HZ_ERR_MEMORY, "out of memory");
            goto fail;
        }
        char *save = NULL;
        for (char *tok = strtok_r(buf, ",", &save); tok; tok = strtok_r(NULL, ",", &save)) {
            hz_tree *m = model_file(o, tok, &err);
            if (!m)
                goto fail;
            high[cf->model_count] = !strcmp(m->species, "conifer") ? 1.0f : 0.3f;
            cf->models[cf->model_count++] = m;
        }
        if (!cf->model_count) {
            hz_err_set(&err, HZ_ERR_VALUE, "--forest-trees lists no file");
            goto fail;
        }
    } else {
        cf->models = calloc(4, sizeof *cf->models);
        high = calloc(4, sizeof *high);
        if (!cf->models || !high) {
            hz_err_set(&err, HZ_ERR_MEMORY, "out of memory");
            goto fail;
        }
        for (int k = 0; k < 4; k++) {
            hz_tree *m = cached_model(o, SPECIES[k], NULL, &err);
            if (!m)
                goto fail;
            high[k] = SPECIES_HIGH[k];
            cf->models[cf->model_count++] = m;
        }
    }
    cf->prep_ms = hz_time_ms() - t0;
    float ext = hz_terrain_extent(t);
    cli_forest_area(o, t, object_tops, cf->center, &cf->side);
    float density = o->forest_density > 0 ? o->forest_density : 400.0f;
    uint32_t placed = 0;
    if (o->forest_file) {
        if (!cli_read_forest_file(o->forest_file, t, cf->model_count, &trees, &placed, &err))
            goto fail;
        float lo2[2] = {INFINITY, INFINITY}, hi2[2] = {-INFINITY, -INFINITY};
        for (uint32_t k = 0; k < placed; k++) {
            lo2[0] = fminf(lo2[0], trees[k].pos[0]), hi2[0] = fmaxf(hi2[0], trees[k].pos[0]);
            lo2[1] = fminf(lo2[1], trees[k].pos[2]), hi2[1] = fmaxf(hi2[1], trees[k].pos[2]);
        }
        cf->center[0] = 0.5f * (lo2[0] + hi2[0]);
        cf->center[1] = 0.5f * (lo2[1] + hi2[1]);
        cf->side = fmaxf(fmaxf(hi2[0] - lo2[0], hi2[1] - lo2[1]), 10.0f);
        goto have_trees;
    }
    trees = malloc(o->forest_n * sizeof *trees);
    if (!trees) {
        hz_err_set(&err, HZ_ERR_MEMORY, "out of memory");
        goto fail;
    }
    float lo = t->min_h * t->zscale, hi = t->max_h * t->zscale;
    plant_ground pg = {t, object_tops};
    hz_forest_desc fd = {.count = o->forest_n, .seed = o->forest_seed, .center = {cf->center[0], cf->center[1]},
                         .density = density, .min_h = lo - 1.0f, .max_h = lo + 0.8f * (hi - lo) + 1.0f,
                         .extent_limit = ext, .model_count = cf->model_count, .model_high = high,
                         .height = ground, .height_user = &pg};
    if (hz_forest_place(&fd, trees, &placed, &err) != HZ_OK)
        goto fail;
    if (placed < o->forest_n && !o->quiet)
        fprintf(stderr, "horizon: placed %u of %u trees (the ground around the centre is too steep or high)\n",
                placed, o->forest_n);
    /* None inside the city's buildings. */
    if (object_tops) {
        uint32_t kept = 0;
        for (uint32_t k = 0; k < placed; k++) {
            const hz_tree *m = cf->models[trees[k].model];
            if (hz_ground_clear(object_tops, t->hm.size, t->spacing, trees[k].pos[0], trees[k].pos[2],
                                m->crown_radius * trees[k].scale))
                trees[kept++] = trees[k];
        }
        cf->cleared = placed - kept;
        placed = kept;
        if (cf->cleared && !o->quiet)
            fprintf(stderr, "horizon: %u of the trees would stand in buildings: left out\n", cf->cleared);
    }
have_trees:
    if (o->forest_save && !write_forest_file(o->forest_save, cf, trees, placed, &err))
        goto fail;
    cf->forest = hz_forest_create((const hz_tree *const *)cf->models, cf->model_count, trees, placed, &err);
    if (!cf->forest)
        goto fail;
    uint8_t **imp = impostors_load(o, cf);
    uint32_t to_bake = 0;
    for (uint32_t k = 0; k < cf->model_count; k++)
        to_bake += !(imp && imp[k]);
    if (to_bake && !o->quiet)
        fprintf(stderr, "horizon: baking the impostors of %u tree model%s (cached for next time)\n", to_bake,
                to_bake == 1 ? "" : "s");
    line_progress bake = {.what = "forest", .last_pct = -100, .last_ms = hz_time_ms()};
    const hz_forest_gpu_desc gd = {.impostors = (const uint8_t *const *)imp,
                                   .progress = o->quiet ? NULL : cli_tree_progress,
                                   .progress_user = &bake};
    cf->gpu = hz_forest_gpu_create_with(cf->forest, &gd, &err);
    for (uint32_t k = 0; imp && k < cf->model_count; k++)
        free(imp[k]);
    free(imp);
    if (!cf->gpu)
        goto fail;
    if (to_bake)
        impostors_store(o, cf);
    free(trees);
    free(high);
    return cf;
fail:
    fprintf(stderr, "horizon: forest: %s\n", err.msg);
    free(trees);
    free(high);
    cli_forest_destroy(cf);
    return NULL;
}

void cli_forest_destroy(cli_forest *cf)
{
    if (!cf)
        return;
    hz_forest_gpu_destroy(cf->gpu);
    hz_forest_destroy(cf->forest);
    for (uint32_t k = 0; k < cf->model_count; k++)
        hz_tree_destroy(cf->models[k]);
    free(cf->models);
    free(cf);
}

bool cli_forest_update(cli_forest *cf, const cli_opts *o, const hz_camera *cam, double now_s)
{
    hz_err err = {0};
    if (hz_forest_update(cf->forest, cam, &o->forest, now_s, &cf->frame, &err) != HZ_OK) {
        fprintf(stderr, "horizon: forest: %s\n", err.msg);
        return false;
    }
    return true;
}

/* The model the effects' billboards of a kind show: a conifer for the
 * conifer sprite (by species, else the narrowest crown), another species for
 * the broadleaf one. */
static uint32_t sprite_model(const cli_forest *cf, bool conifer)
{
    uint32_t best = 0;
    float best_ratio = conifer ? INFINITY : -INFINITY;
    for (uint32_t m = 0; m < cf->model_count; m++) {
        const hz_tree *t = cf->models[m];
        bool is_conifer = strstr(t->species, "conifer") != NULL;
        if (is_conifer == conifer)
            return m;
        float ratio = t->crown_radius / fmaxf(t->bound_center[1] + t->bound_radius, 1e-3f);
        if (conifer ? ratio < best_ratio : ratio > best_ratio) {
            best_ratio = ratio;
            best = m;
        }
    }
    return best;
}

int cli_forest_billboards(const cli_forest *cf, const cli_opts *o, hz_renderer *ren)
{
    if (o->textures)
        return 0; /* the user's sprites stay */
    static const struct {
        uint32_t slot, w, h;
        float width_frac; /* as the scatter sizes them */
        bool conifer;
    } kinds[2] = {{HZ_SPRITE_CONIFER, 64, 128, 0.5f, true}, {HZ_SPRITE_BROADLEAF, 128, 128, 0.85f, false}};
    for (int k = 0; k < 2; k++) {
        uint8_t *px = malloc((size_t)kinds[k].w * kinds[k].h * 4);
        hz_err err = {0};
        if (!px) {
            fprintf(stderr, "horizon: out of memory\n");
            return 1;
        }
        uint32_t m = sprite_model(cf, kinds[k].conifer);
        hz_result r = hz_forest_gpu_sprite(cf->gpu, cf->forest, m, kinds[k].width_frac, kinds[k].w, kinds[k].h, px,
                                           &err);
        if (r == HZ_OK)
            r = hz_renderer_set_billboard_texture(ren, kinds[k].slot, px, kinds[k].w, kinds[k].h, &err);
        free(px);
        if (r != HZ_OK) {
            fprintf(stderr, "horizon: forest billboards: %s\n", err.msg);
            return 1;
        }
    }
    return 0;
}

void cli_forest_hook(cli_forest *cf, hz_scene_params *sp)
{
    cf->hook = (hz_forest_hook){.gpu = cf->gpu, .forest = cf->forest, .frame = &cf->frame,
                                .time_draw = cf->hook.time_draw};
    sp->draw_objects = hz_forest_draw_hook;
    sp->draw_objects_user = &cf->hook;
    /* Trees are opaque (cut-outs, no blending) and cover much of the view
     * from above the crowns: drawn before the terrain, they spare the
     * terrain's shading of every pixel they hide. */
    sp->objects_first = true;
}

void cli_forest_area(const cli_opts *o, const hz_terrain *t, const float *object_tops, float center[2], float *side)
{
    float ext = hz_terrain_extent(t);
    float density = o->forest_density > 0 ? o->forest_density : 400.0f;
    *side = sqrtf((float)o->forest_n) * 100.0f / sqrtf(density);
    float mid[2]; /* the middle of the data (padded DEMs: not of the map) */
    hz_terrain_data_centre(t, &mid[0], &mid[1]);
    center[0] = o->forest_at_set ? o->forest_at[0] : mid[0];
    center[1] = o->forest_at_set ? o->forest_at[1] : mid[1];
    if (o->forest_at_set)
        return;
    /* The most plantable square: plantable ground of gentle slopes below the
     * tree line, the nearest to the data's middle among equals. */
    const float lo = t->min_h * t->zscale, hi = t->max_h * t->zscale, line = lo + 0.8f * (hi - lo);
    const float max_tan = tanf(35.0f * 0.0174532925f), e = 5.0f;
    float best = -1.0f, best_d = INFINITY, half = fminf(0.5f * *side, 0.45f * ext);
    for (int gz = 0; gz < 16; gz++)
        for (int gx = 0; gx < 16; gx++) {
            float cx = half + (ext - 2 * half) * ((float)gx + 0.5f) / 16.0f;
            float cz = half + (ext - 2 * half) * ((float)gz + 0.5f) / 16.0f;
            int ok = 0;
            for (int sz = -3; sz <= 3; sz++)
                for (int sx = -3; sx <= 3; sx++) {
                    float x = cx + half * (float)sx / 3.0f, z = cz + half * (float)sz / 3.0f;
                    float h = hz_terrain_height_at(t, x, z);
                    float gxs = (hz_terrain_height_at(t, x + e, z) - hz_terrain_height_at(t, x - e, z)) / (2 * e);
                    float gzs = (hz_terrain_height_at(t, x, z + e) - hz_terrain_height_at(t, x, z - e)) / (2 * e);
                    ok += h <= line && sqrtf(gxs * gxs + gzs * gzs) <= 0.7f * max_tan &&
                          plantable(t, object_tops, x, z);
                }
            float score = (float)ok / 49.0f;
            float d = hypotf(cx - mid[0], cz - mid[1]);
            if (score > best + 1e-4f || (fabsf(score - best) <= 1e-4f && d < best_d)) {
                best = score;
                best_d = d;
                center[0] = cx;
                center[1] = cz;
            }
        }
}

hz_camera cli_forest_camera(const cli_opts *o, const hz_terrain *t)
{
    float ctr[2], side;
    cli_forest_area(o, t, NULL, ctr, &side); /* a city's camera comes from the city */
    hz_camera c = hz_terrain_default_camera(t, o->width, o->height);
    float x = ctr[0], z = ctr[1] + 0.5f * side + 25.0f;
    c.pos[0] = x;
    c.pos[2] = z;
    c.pos[1] = hz_terrain_height_at(t, x, z) + 30.0f;
    /* look toward -z, down to the forest's middle */
    float dy = c.pos[1] - hz_terrain_height_at(t, ctr[0], ctr[1]);
    c.yaw = 0.0f;
    c.pitch = -glm_deg(atan2f(dy, 0.5f * side + 25.0f)) * 0.6f;
    c.znear = 0.3f;
    if (o->fov > 0)
        c.fov_y = o->fov;
    if (o->far > 0)
        c.zfar = o->far;
    c.earth_radius = o->curv.radius;
    return c;
}

hz_result cli_forest_path(const cli_forest *cf, const hz_terrain *t, hz_path *out, hz_err *err)
{
    /* Straight along the forest's diagonal, from inside its rim to inside
     * the other, 22 m above the ground (the highest within 30 m): just above
     * the crowns, looking ahead and down into them. */
    hz_path_key k[61];
    const float half = 0.25f * cf->side;
    const float yaw = glm_deg(atan2f(1.0f, -1.0f)); /* toward +x +z */
    for (int n = 0; n < 61; n++) {
        float u = (float)n / 60.0f;
        float x = cf->center[0] - half + 2.0f * half * u, z = cf->center[1] - half + 2.0f * half * u;
        float g = -INFINITY;
        for (int dz = -2; dz <= 2; dz++)
            for (int dx = -2; dx <= 2; dx++)
                g = fmaxf(g, hz_terrain_height_at(t, x + 15.0f * (float)dx, z + 15.0f * (float)dz));
        k[n] = (hz_path_key){60.0f * u, x, g + 22.0f, z, yaw, -15.0f};
    }
    return hz_path_from_keys(k, 61, "forest", out, err);
}
