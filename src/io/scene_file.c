/* Scene files (docs/scene.md): jansson for the JSON, assimp for models,
 * the georeference (PROJ) for CRS and lon/lat positions. */
#define _GNU_SOURCE
#include "horizon/scene_file.h"

#include <errno.h>
#include <float.h>
#include <jansson.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <assimp/cimport.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

/* Metres: the largest |coordinate| of a node's position and of a model's
 * vertices (the model in its own units, before the node's scale). */
#define SCENE_MAX_M 1e8

typedef struct model {
    char *name;
    hz_vertex *v;
    uint32_t vc;
    uint32_t *idx;
    uint32_t ic;
    uint32_t material;     /* index into materials, UINT32_MAX = the node's or default */
    uint32_t mesh;         /* scene mesh once built, HZ_MESH_NONE before */
} model;

typedef struct mat_def {
    char *name;
    hz_material m;
    uint32_t scene_index;
} mat_def;

struct hz_scene_file {
    json_t *root;
    char name[256];
    char dir[1024];
    model *models;
    uint32_t model_count;
    mat_def *mats;
    uint32_t mat_count;
    hz_scene_file_info info;
    char path[1024];       /* JSON path of the current check */
    hz_err *err;
};

static hz_result fail(hz_scene_file *f, hz_result code, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
static hz_result fail(hz_scene_file *f, hz_result code, const char *fmt, ...)
{
    char msg[400];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return hz_err_set(f->err, code, "%s: %s%s%s", f->name, f->path, f->path[0] ? ": " : "", msg);
}

/* Appends ".key" or "[i]" to the path; returns the old length to restore. */
static size_t push_key(hz_scene_file *f, const char *key)
{
    size_t n = strlen(f->path);
    snprintf(f->path + n, sizeof f->path - n, "%s%.100s", n ? "." : "", key);
    return n;
}

static size_t push_index(hz_scene_file *f, size_t i)
{
    size_t n = strlen(f->path);
    snprintf(f->path + n, sizeof f->path - n, "[%zu]", i);
    return n;
}

static bool only_keys(hz_scene_file *f, json_t *obj, const char *const *allowed)
{
    const char *key;
    json_t *v;
    json_object_foreach(obj, key, v)
    {
        bool ok = false;
        for (const char *const *a = allowed; *a && !ok; a++)
            ok = !strcmp(key, *a);
        if (!ok) {
            char list[300] = "";
            for (const char *const *a = allowed; *a; a++)
                snprintf(list + strlen(list), sizeof list - strlen(list), "%s%s", a == allowed ? "" : ", ", *a);
            fail(f, HZ_ERR_FORMAT, "unknown member \"%.60s\" (expected %s)", key, list);
            return false;
        }
    }
    return true;
}

/* A finite number in [lo, hi] at obj.key (absent: keeps *out, true). */
static bool get_num(hz_scene_file *f, json_t *obj, const char *key, double lo, double hi, double *out)
{
    json_t *v = json_object_get(obj, key);
    if (!v)
        return true;
    size_t n = push_key(f, key);
    bool ok = false;
    if (!json_is_number(v))
        fail(f, HZ_ERR_FORMAT, "must be a number");
    else if (!isfinite(json_number_value(v)) || json_number_value(v) < lo || json_number_value(v) > hi)
        fail(f, HZ_ERR_VALUE, "must be in [%g, %g] (got %g)", lo, hi, json_number_value(v));
    else {
        *out = json_number_value(v);
        ok = true;
    }
    f->path[n] = 0;
    return ok;
}

/* An array of exactly n finite numbers in [lo, hi]. */
static bool get_vec(hz_scene_file *f, json_t *obj, const char *key, size_t n, double lo, double hi, double *out)
{
    json_t *v = json_object_get(obj, key);
    if (!v)
        return true;
    size_t pn = push_key(f, key);
    if (!json_is_array(v) || json_array_size(v) != n) {
        fail(f, HZ_ERR_FORMAT, "must be an array of %zu numbers", n);
        return false;
    }
    for (size_t k = 0; k < n; k++) {
        json_t *q = json_array_get(v, k);
        double x = json_is_number(q) ? json_number_value(q) : NAN;
        if (!json_is_number(q) || !isfinite(x) || x < lo || x > hi) {
            push_index(f, k);
            if (!json_is_number(q))
                fail(f, HZ_ERR_FORMAT, "must be a number");
            else
                fail(f, HZ_ERR_VALUE, "must be in [%g, %g] (got %g)", lo, hi, x);
            return false;
        }
        out[k] = x;
    }
    f->path[pn] = 0;
    return true;
}

void hz_scene_file_destroy(hz_scene_file *f)
{
    if (!f)
        return;
    for (uint32_t k = 0; k < f->model_count; k++) {
        free(f->models[k].name);
        free(f->models[k].v);
        free(f->models[k].idx);
    }
    for (uint32_t k = 0; k < f->mat_count; k++)
        free(f->mats[k].name);
    free(f->models);
    free(f->mats);
    json_decref(f->root);
    free(f);
}

static void resolve(const hz_scene_file *f, const char *p, char *out, size_t cap)
{
    int n = p[0] == '/' || !strcmp(f->dir, ".") ? snprintf(out, cap, "%s", p) : snprintf(out, cap, "%s/%s", f->dir, p);
    if (n < 0 || (size_t)n >= cap)
        out[0] = 0; /* too long: no such file (the loader says so) */
}

/* A box of w x h x d metres, base centred on the origin (y from 0 to h);
 * each side's two triangles share its diagonal (occluders pair them). */
static bool make_box(model *m, const double s[3])
{
    static const float face[6][4][3] = {
        {{0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}}, /* +z */
        {{1, 0, 0}, {0, 0, 0}, {0, 1, 0}, {1, 1, 0}}, /* -z */
        {{1, 0, 1}, {1, 0, 0}, {1, 1, 0}, {1, 1, 1}}, /* +x */
        {{0, 0, 0}, {0, 0, 1}, {0, 1, 1}, {0, 1, 0}}, /* -x */
        {{0, 1, 1}, {1, 1, 1}, {1, 1, 0}, {0, 1, 0}}, /* +y */
        {{0, 0, 0}, {1, 0, 0}, {1, 0, 1}, {0, 0, 1}}, /* -y */
    };
    static const float nrm[6][3] = {{0, 0, 1}, {0, 0, -1}, {1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}};
    m->v = malloc(24 * sizeof *m->v);
    m->idx = malloc(36 * sizeof *m->idx);
    if (!m->v || !m->idx)
        return false;
    for (uint32_t fc = 0; fc < 6; fc++) {
        for (uint32_t k = 0; k < 4; k++) {
            hz_vertex *v = &m->v[4 * fc + k];
            v->pos[0] = (float)((face[fc][k][0] - 0.5) * s[0]);
            v->pos[1] = (float)(face[fc][k][1] * s[1]);
            v->pos[2] = (float)((face[fc][k][2] - 0.5) * s[2]);
            memcpy(v->normal, nrm[fc], sizeof v->normal);
        }
        const uint32_t q[6] = {0, 1, 2, 0, 2, 3};
        for (int k = 0; k < 6; k++)
            m->idx[6 * fc + (uint32_t)k] = 4 * fc + q[k];
    }
    m->vc = 24;
    m->ic = 36;
    return true;
}

static hz_result load_model_file(hz_scene_file *f, model *m, const char *file)
{
    char path[1100];
    resolve(f, file, path, sizeof path);
    /* ValidateDataStructure: some importers (PLY, OFF) pass faces whose
     * indices lie past the mesh's vertices; the validation refuses them. */
    const struct aiScene *sc =
        aiImportFile(path, aiProcess_ValidateDataStructure | aiProcess_Triangulate | aiProcess_PreTransformVertices |
                               aiProcess_GenSmoothNormals | aiProcess_JoinIdenticalVertices | aiProcess_SortByPType);
    if (!sc)
        return fail(f, HZ_ERR_FORMAT, "cannot read model %s: %s", path, aiGetErrorString());
    uint64_t vc = 0, ic = 0;
    for (unsigned k = 0; k < sc->mNumMeshes; k++) {
        const struct aiMesh *am = sc->mMeshes[k];
        if (!(am->mPrimitiveTypes & aiPrimitiveType_TRIANGLE))
            continue;
        vc += am->mNumVertices;
        ic += 3ull * am->mNumFaces;
    }
    if (!ic || vc > UINT32_MAX / 2 || ic > UINT32_MAX / 2) {
        aiReleaseImport(sc);
        return fail(f, HZ_ERR_FORMAT, "model %s has %s", path, ic ? "too many triangles" : "no triangles");
    }
    m->v = malloc((size_t)vc * sizeof *m->v);
    m->idx = malloc((size_t)ic * sizeof *m->idx);
    if (!m->v || !m->idx) {
        aiReleaseImport(sc);
        return fail(f, HZ_ERR_MEMORY, "out of memory for model %s", path);
    }
    uint32_t nv = 0, ni = 0;
    for (unsigned k = 0; k < sc->mNumMeshes; k++) {
        const struct aiMesh *am = sc->mMeshes[k];
        if (!(am->mPrimitiveTypes & aiPrimitiveType_TRIANGLE))
            continue;
        for (unsigned i = 0; i < am->mNumVertices; i++) {
            hz_vertex *v = &m->v[nv + i];
            v->pos[0] = am->mVertices[i].x;
            v->pos[1] = am->mVertices[i].y;
            v->pos[2] = am->mVertices[i].z;
            if (am->mNormals) {
                v->normal[0] = am->mNormals[i].x;
                v->normal[1] = am->mNormals[i].y;
                v->normal[2] = am->mNormals[i].z;
            } else {
                v->normal[0] = v->normal[2] = 0;
                v->normal[1] = 1;
            }
            for (int c = 0; c < 3; c++)
                if (!(fabs(v->pos[c]) <= SCENE_MAX_M)) { /* NaN too */
                    aiReleaseImport(sc);
                    return fail(f, HZ_ERR_VALUE, "model %s: vertex %u of mesh %u is not finite or lies beyond %.0e m",
                                path, i, k, SCENE_MAX_M);
                }
        }
        for (unsigned fc = 0; fc < am->mNumFaces; fc++) {
            const struct aiFace *fa = &am->mFaces[fc];
            if (fa->mNumIndices != 3)
                continue;
            if (fa->mIndices[0] >= am->mNumVertices || fa->mIndices[1] >= am->mNumVertices ||
                fa->mIndices[2] >= am->mNumVertices) {
                aiReleaseImport(sc);
                return fail(f, HZ_ERR_FORMAT, "model %s: a face's vertex index is out of range", path);
            }
            for (int c = 0; c < 3; c++)
                m->idx[ni++] = nv + fa->mIndices[c];
        }
        nv += am->mNumVertices;
    }
    aiReleaseImport(sc);
    m->vc = nv;
    m->ic = ni;
    return HZ_OK;
}

static uint32_t find_material(const hz_scene_file *f, const char *name)
{
    for (uint32_t k = 0; k < f->mat_count; k++)
        if (!strcmp(f->mats[k].name, name))
            return k;
    return UINT32_MAX;
}

static uint32_t find_model(const hz_scene_file *f, const char *name)
{
    for (uint32_t k = 0; k < f->model_count; k++)
        if (!strcmp(f->models[k].name, name))
            return k;
    return UINT32_MAX;
}

static hz_result read_terrain_lights(hz_scene_file *f)
{
    json_t *t = json_object_get(f->root, "terrain");
    hz_scene_file_info *in = &f->info;
    if (t) {
        size_t n = push_key(f, "terrain");
        static const char *const keys[] = {"dem", "generate", "size", "seed", "amplitude", "spacing", NULL};
        if (!json_is_object(t))
            return fail(f, HZ_ERR_FORMAT, "must be an object");
        if (!only_keys(f, t, keys))
            return f->err ? f->err->code : HZ_ERR_FORMAT;
        json_t *dem = json_object_get(t, "dem"), *gen = json_object_get(t, "generate");
        if (!!dem == !!gen)
            return fail(f, HZ_ERR_FORMAT, "needs exactly one of \"dem\" and \"generate\"");
        if (dem) {
            if (!json_is_string(dem) || !json_string_value(dem)[0])
                return fail(f, HZ_ERR_FORMAT, "dem: must be a file name");
            resolve(f, json_string_value(dem), in->dem, sizeof in->dem);
        } else {
            const char *g = json_is_string(gen) ? json_string_value(gen) : "";
            if (strcmp(g, "perlin") && strcmp(g, "diamond"))
                return fail(f, HZ_ERR_VALUE, "generate: must be \"perlin\" or \"diamond\"");
            snprintf(in->generate, sizeof in->generate, "%s", g);
        }
        double size = 0, seed = 1, amp = 0, sp = 0;
        if (!get_num(f, t, "size", 3, 16385, &size) || !get_num(f, t, "seed", 0, 9007199254740992.0, &seed) ||
            !get_num(f, t, "amplitude", 0, 20000, &amp) || !get_num(f, t, "spacing", 0, 100000, &sp))
            return f->err ? f->err->code : HZ_ERR_VALUE;
        in->size = (uint32_t)size;
        in->seed = (uint64_t)seed;
        in->amplitude = (float)amp;
        in->spacing = (float)sp;
        in->has_terrain = true;
        f->path[n] = 0;
    }
    json_t *l = json_object_get(f->root, "lights");
    if (l) {
        size_t n = push_key(f, "lights");
        static const char *const keys[] = {"sun", NULL};
        if (!json_is_object(l))
            return fail(f, HZ_ERR_FORMAT, "must be an object");
        if (!only_keys(f, l, keys))
            return HZ_ERR_FORMAT;
        double sun[2] = {0, 0};
        if (!get_vec(f, l, "sun", 2, -360, 360, sun))
            return f->err ? f->err->code : HZ_ERR_VALUE;
        if (json_object_get(l, "sun")) {
            if (sun[1] < -90 || sun[1] > 90) {
                push_key(f, "sun");
                return fail(f, HZ_ERR_VALUE, "elevation must be in [-90, 90] (got %g)", sun[1]);
            }
            in->has_sun = true;
            in->sun[0] = (float)sun[0];
            in->sun[1] = (float)sun[1];
        }
        f->path[n] = 0;
    }
    return HZ_OK;
}

static hz_result read_materials(hz_scene_file *f)
{
    json_t *ms = json_object_get(f->root, "materials");
    size_t n = push_key(f, "materials");
    size_t count = ms ? json_object_size(ms) : 0;
    if (ms && !json_is_object(ms))
        return fail(f, HZ_ERR_FORMAT, "must be an object of named materials");
    f->mats = calloc(count + 1, sizeof *f->mats);
    if (!f->mats)
        return fail(f, HZ_ERR_MEMORY, "out of memory");
    /* Material 0: the default, for nodes and models naming none. */
    f->mats[0] = (mat_def){strdup("default"), {.color = {0.7f, 0.7f, 0.68f}, .name = "default"}, 0};
    f->mat_count = 1;
    if (!f->mats[0].name)
        return fail(f, HZ_ERR_MEMORY, "out of memory");
    const char *key;
    json_t *v;
    if (ms)
        json_object_foreach(ms, key, v)
        {
            size_t k = push_key(f, key);
            static const char *const keys[] = {"color", NULL};
            if (!json_is_object(v))
                return fail(f, HZ_ERR_FORMAT, "must be an object");
            if (!only_keys(f, v, keys))
                return HZ_ERR_FORMAT;
            double c[3] = {0.7, 0.7, 0.7};
            if (!get_vec(f, v, "color", 3, 0, 1, c))
                return f->err ? f->err->code : HZ_ERR_VALUE;
            uint32_t idx = strcmp(key, "default") ? f->mat_count++ : 0;
            mat_def *d = &f->mats[idx];
            free(d->name);
            d->name = strdup(key);
            if (!d->name)
                return fail(f, HZ_ERR_MEMORY, "out of memory");
            d->m = (hz_material){.color = {(float)c[0], (float)c[1], (float)c[2]}};
            snprintf(d->m.name, sizeof d->m.name, "%s", key);
            f->path[k] = 0;
        }
    f->path[n] = 0;
    f->info.materials = f->mat_count;
    return HZ_OK;
}

static hz_result read_models(hz_scene_file *f)
{
    json_t *ms = json_object_get(f->root, "models");
    if (!ms)
        return HZ_OK;
    size_t n = push_key(f, "models");
    if (!json_is_object(ms))
        return fail(f, HZ_ERR_FORMAT, "must be an object of named models");
    f->models = calloc(json_object_size(ms) + 1, sizeof *f->models);
    if (!f->models)
        return fail(f, HZ_ERR_MEMORY, "out of memory");
    const char *key;
    json_t *v;
    json_object_foreach(ms, key, v)
    {
        size_t k = push_key(f, key);
        static const char *const keys[] = {"box", "file", "material", NULL};
        if (!json_is_object(v))
            return fail(f, HZ_ERR_FORMAT, "must be an object");
        if (!only_keys(f, v, keys))
            return HZ_ERR_FORMAT;
        model *m = &f->models[f->model_count++];
        m->mesh = HZ_MESH_NONE;
        m->material = UINT32_MAX;
        if (!(m->name = strdup(key)))
            return fail(f, HZ_ERR_MEMORY, "out of memory");
        json_t *box = json_object_get(v, "box"), *file = json_object_get(v, "file");
        if (!!box == !!file)
            return fail(f, HZ_ERR_FORMAT, "needs exactly one of \"box\" ([w, h, d] metres) and \"file\"");
        if (box) {
            double s[3];
            if (!get_vec(f, v, "box", 3, 1e-3, 1e5, s))
                return f->err ? f->err->code : HZ_ERR_VALUE;
            if (!make_box(m, s))
                return fail(f, HZ_ERR_MEMORY, "out of memory");
        } else {
            if (!json_is_string(file) || !json_string_value(file)[0]) {
                push_key(f, "file");
                return fail(f, HZ_ERR_FORMAT, "must be a file name");
            }
            hz_result r = load_model_file(f, m, json_string_value(file));
            if (r != HZ_OK)
                return r;
        }
        json_t *mat = json_object_get(v, "material");
        if (mat) {
            push_key(f, "material");
            if (!json_is_string(mat) || (m->material = find_material(f, json_string_value(mat))) == UINT32_MAX)
                return fail(f, HZ_ERR_VALUE, "unknown material \"%.60s\"",
                            json_is_string(mat) ? json_string_value(mat) : "?");
        }
        f->path[k] = 0;
    }
    f->path[n] = 0;
    f->info.models = f->model_count;
    return HZ_OK;
}

/* Checks one node and its children (recursion depth is bounded by
 * jansson's parser, 2048 levels). */
static hz_result check_node(hz_scene_file *f, json_t *nd, bool top)
{
    static const char *const keys[] = {"name",  "position", "crs",   "lonlat", "clamp",    "yaw",        "pitch",
                                       "roll",  "axis",     "angle", "scale",  "model",    "material",   "attributes",
                                       "children", NULL};
    if (!json_is_object(nd))
        return fail(f, HZ_ERR_FORMAT, "a node must be an object");
    if (!only_keys(f, nd, keys))
        return HZ_ERR_FORMAT;
    json_t *name = json_object_get(nd, "name");
    if (name && !json_is_string(name)) {
        push_key(f, "name");
        return fail(f, HZ_ERR_FORMAT, "must be a string");
    }
    int where = !!json_object_get(nd, "position") + !!json_object_get(nd, "crs") + !!json_object_get(nd, "lonlat");
    if (where > 1)
        return fail(f, HZ_ERR_FORMAT, "give one of \"position\", \"crs\" and \"lonlat\"");
    if (!top && (json_object_get(nd, "crs") || json_object_get(nd, "lonlat")))
        return fail(f, HZ_ERR_FORMAT, "\"crs\" and \"lonlat\" place top-level nodes only (children are placed "
                                      "relative to their parent with \"position\")");
    double v3[3], a = 0;
    if (!get_vec(f, nd, "position", 3, -SCENE_MAX_M, SCENE_MAX_M, v3) || !get_vec(f, nd, "crs", 3, -1e9, 1e9, v3) ||
        !get_vec(f, nd, "lonlat", 3, -1e6, 1e6, v3) || !get_num(f, nd, "yaw", -3600, 3600, &a) ||
        !get_num(f, nd, "pitch", -3600, 3600, &a) || !get_num(f, nd, "roll", -3600, 3600, &a) ||
        !get_num(f, nd, "angle", -3600, 3600, &a) || !get_vec(f, nd, "axis", 3, -1e6, 1e6, v3))
        return f->err ? f->err->code : HZ_ERR_VALUE;
    json_t *ll = json_object_get(nd, "lonlat");
    if (ll) {
        double lon = json_number_value(json_array_get(ll, 0)), lat = json_number_value(json_array_get(ll, 1));
        if (lon < -180 || lon > 180 || lat < -90 || lat > 90) {
            push_key(f, "lonlat");
            return fail(f, HZ_ERR_VALUE, "longitude in [-180, 180], latitude in [-90, 90] (got %g, %g)", lon, lat);
        }
    }
    if (json_object_get(nd, "axis")) {
        if (!json_object_get(nd, "angle"))
            return fail(f, HZ_ERR_FORMAT, "\"axis\" needs \"angle\" (degrees)");
        if (json_object_get(nd, "yaw") || json_object_get(nd, "pitch") || json_object_get(nd, "roll"))
            return fail(f, HZ_ERR_FORMAT, "give either yaw/pitch/roll or axis/angle");
        if (v3[0] == 0 && v3[1] == 0 && v3[2] == 0) {
            push_key(f, "axis");
            return fail(f, HZ_ERR_VALUE, "must not be zero");
        }
    } else if (json_object_get(nd, "angle")) {
        return fail(f, HZ_ERR_FORMAT, "\"angle\" needs \"axis\"");
    }
    json_t *sc = json_object_get(nd, "scale");
    if (sc) {
        double s3[3];
        if (json_is_number(sc)) {
            if (!get_num(f, nd, "scale", 1e-6, 1e6, s3))
                return f->err ? f->err->code : HZ_ERR_VALUE;
        } else if (!get_vec(f, nd, "scale", 3, 1e-6, 1e6, s3)) {
            return f->err ? f->err->code : HZ_ERR_VALUE;
        }
    }
    json_t *cl = json_object_get(nd, "clamp");
    if (cl && (!json_is_string(cl) || (strcmp(json_string_value(cl), "ground") && strcmp(json_string_value(cl), "none")))) {
        push_key(f, "clamp");
        return fail(f, HZ_ERR_VALUE, "must be \"ground\" or \"none\"");
    }
    json_t *md = json_object_get(nd, "model");
    if (md && (!json_is_string(md) || find_model(f, json_string_value(md)) == UINT32_MAX)) {
        push_key(f, "model");
        return fail(f, HZ_ERR_VALUE, "unknown model \"%.60s\"", json_is_string(md) ? json_string_value(md) : "?");
    }
    json_t *mt = json_object_get(nd, "material");
    if (mt && (!json_is_string(mt) || find_material(f, json_string_value(mt)) == UINT32_MAX)) {
        push_key(f, "material");
        return fail(f, HZ_ERR_VALUE, "unknown material \"%.60s\"", json_is_string(mt) ? json_string_value(mt) : "?");
    }
    json_t *at = json_object_get(nd, "attributes");
    if (at && !json_is_object(at)) {
        push_key(f, "attributes");
        return fail(f, HZ_ERR_FORMAT, "must be an object");
    }
    f->info.nodes++;
    json_t *ch = json_object_get(nd, "children");
    if (ch) {
        size_t n = push_key(f, "children");
        if (!json_is_array(ch))
            return fail(f, HZ_ERR_FORMAT, "must be an array of nodes");
        for (size_t k = 0; k < json_array_size(ch); k++) {
            size_t m = push_index(f, k);
            hz_result r = check_node(f, json_array_get(ch, k), false);
            if (r != HZ_OK)
                return r;
            f->path[m] = 0;
        }
        f->path[n] = 0;
    }
    return HZ_OK;
}

hz_scene_file *hz_scene_file_open_memory(const char *data, size_t size, const char *name, const char *dir,
                                         hz_scene_file_info *info, hz_err *err)
{
    hz_scene_file *f = calloc(1, sizeof *f);
    if (!f) {
        hz_err_set(err, HZ_ERR_MEMORY, "scene: out of memory");
        return NULL;
    }
    f->err = err;
    snprintf(f->name, sizeof f->name, "%s", name ? name : "scene");
    snprintf(f->dir, sizeof f->dir, "%s", dir && dir[0] ? dir : ".");
    json_error_t je;
    f->root = json_loadb(data, size, JSON_REJECT_DUPLICATES, &je);
    hz_result r = HZ_OK;
    if (!f->root) {
        hz_err_set(err, HZ_ERR_FORMAT, "%s: line %d, column %d: %s", f->name, je.line, je.column, je.text);
        hz_scene_file_destroy(f);
        return NULL;
    }
    static const char *const keys[] = {"horizon_scene", "terrain", "lights", "materials", "models", "nodes", NULL};
    json_t *nodes = json_object_get(f->root, "nodes");
    if (!json_is_object(f->root)) {
        r = fail(f, HZ_ERR_FORMAT, "a scene is a JSON object");
    } else if (!only_keys(f, f->root, keys)) {
        r = HZ_ERR_FORMAT;
    } else if (!json_is_array(nodes)) {
        push_key(f, "nodes");
        r = fail(f, HZ_ERR_FORMAT, "missing or not an array of nodes");
    } else if ((r = read_terrain_lights(f)) == HZ_OK && (r = read_materials(f)) == HZ_OK &&
               (r = read_models(f)) == HZ_OK) {
        size_t n = push_key(f, "nodes");
        for (size_t k = 0; k < json_array_size(nodes) && r == HZ_OK; k++) {
            size_t m = push_index(f, k);
            r = check_node(f, json_array_get(nodes, k), true);
            if (r == HZ_OK)
                f->path[m] = 0;
        }
        if (r == HZ_OK)
            f->path[n] = 0;
    }
    if (r != HZ_OK) {
        if (err && !err->msg[0])
            hz_err_set(err, r, "%s: invalid scene", f->name);
        hz_scene_file_destroy(f);
        return NULL;
    }
    if (info)
        *info = f->info;
    return f;
}

hz_scene_file *hz_scene_file_open(const char *path, hz_scene_file_info *info, hz_err *err)
{
    FILE *fp = fopen(path, "rb");
    if (!fp) {
        hz_err_set(err, HZ_ERR_IO, "%s: %s", path, strerror(errno));
        return NULL;
    }
    size_t cap = 1 << 16, len = 0;
    char *buf = malloc(cap);
    for (;;) {
        if (!buf) {
            fclose(fp);
            hz_err_set(err, HZ_ERR_MEMORY, "%s: out of memory", path);
            return NULL;
        }
        size_t got = fread(buf + len, 1, cap - len, fp);
        len += got;
        if (len < cap)
            break;
        if (cap >= (256u << 20)) {
            fclose(fp);
            free(buf);
            hz_err_set(err, HZ_ERR_VALUE, "%s: larger than 256 MiB", path);
            return NULL;
        }
        cap *= 2;
        char *nb = realloc(buf, cap);
        if (!nb)
            free(buf);
        buf = nb;
    }
    fclose(fp);
    char dir[1024];
    snprintf(dir, sizeof dir, "%s", path);
    char *slash = strrchr(dir, '/');
    if (slash)
        *slash = 0;
    else
        snprintf(dir, sizeof dir, ".");
    hz_scene_file *f = hz_scene_file_open_memory(buf, len, path, dir, info, err);
    free(buf);
    return f;
}

/* ---- build ------------------------------------------------------------------ */

typedef struct builder {
    hz_scene_file *f;
    hz_scene *s;
    const hz_scene_file_place *p;
    hz_scene_file_stats st;
} builder;

static void vec_of(json_t *a, double *out, size_t n)
{
    for (size_t k = 0; k < n; k++)
        out[k] = json_number_value(json_array_get(a, k));
}

static hz_result build_node(builder *b, json_t *nd, uint32_t parent)
{
    hz_scene_file *f = b->f;
    json_t *name = json_object_get(nd, "name");
    uint32_t id = hz_scene_add_node(b->s, parent, json_is_string(name) ? json_string_value(name) : NULL);
    if (!id)
        return fail(f, HZ_ERR_MEMORY, "out of memory adding nodes");
    b->st.nodes++;
    double pos[3] = {0, 0, 0};
    json_t *v;
    if ((v = json_object_get(nd, "position"))) {
        vec_of(v, pos, 3);
    } else if ((v = json_object_get(nd, "crs")) || (v = json_object_get(nd, "lonlat"))) {
        const bool ll = json_object_get(nd, "lonlat") != NULL;
        double q[3];
        vec_of(v, q, 3);
        if (!b->p->georef) {
            push_key(f, ll ? "lonlat" : "crs");
            return fail(f, HZ_ERR_VALUE, "needs a terrain with a georeference (a DEM with a CRS)");
        }
        double x, z;
        if (ll) {
            hz_err e2 = {0};
            if (hz_georef_lonlat_to_local(b->p->georef, q[0], q[1], &x, &z, &e2) != HZ_OK) {
                push_key(f, "lonlat");
                return fail(f, HZ_ERR_VALUE, "PROJ cannot place it: %s", e2.msg);
            }
        } else {
            hz_georef_crs_to_local(b->p->georef, q[0], q[1], &x, &z);
        }
        pos[0] = x;
        pos[1] = q[2];
        pos[2] = z;
    }
    hz_scene_set_translation(b->s, id, (float[3]){(float)pos[0], (float)pos[1], (float)pos[2]});
    if ((v = json_object_get(nd, "axis"))) {
        double ax[3];
        vec_of(v, ax, 3);
        hz_scene_set_axis_angle(b->s, id, (float[3]){(float)ax[0], (float)ax[1], (float)ax[2]},
                                (float)json_number_value(json_object_get(nd, "angle")));
    } else {
        json_t *y = json_object_get(nd, "yaw"), *p = json_object_get(nd, "pitch"), *r = json_object_get(nd, "roll");
        if (y || p || r)
            hz_scene_set_ypr(b->s, id, (float)json_number_value(y), (float)json_number_value(p),
                             (float)json_number_value(r));
    }
    if ((v = json_object_get(nd, "scale"))) {
        double s3[3];
        if (json_is_number(v))
            s3[0] = s3[1] = s3[2] = json_number_value(v);
        else
            vec_of(v, s3, 3);
        hz_scene_set_scale(b->s, id, (float[3]){(float)s3[0], (float)s3[1], (float)s3[2]});
    }
    json_t *md = json_object_get(nd, "model"), *mt = json_object_get(nd, "material");
    if (md) {
        model *m = &f->models[find_model(f, json_string_value(md))];
        if (m->mesh == HZ_MESH_NONE) {
            hz_err e2 = {0};
            m->mesh = hz_scene_add_mesh(b->s, m->v, m->vc, m->idx, m->ic, &e2);
            if (m->mesh == HZ_MESH_NONE)
                return fail(f, e2.code, "model %s: %s", m->name, e2.msg);
            b->st.meshes++;
        }
        uint32_t mi = mt ? find_material(f, json_string_value(mt)) : m->material != UINT32_MAX ? m->material : 0;
        hz_scene_set_mesh(b->s, id, m->mesh, f->mats[mi].scene_index);
        b->st.objects++;
    }
    json_t *at = json_object_get(nd, "attributes");
    if (at) {
        char *txt = json_dumps(at, JSON_COMPACT);
        hz_err e2 = {0};
        hz_result r = txt ? hz_scene_set_attributes(b->s, id, txt, &e2) : HZ_ERR_MEMORY;
        free(txt);
        if (r != HZ_OK)
            return fail(f, HZ_ERR_MEMORY, "out of memory for attributes");
    }
    json_t *cl = json_object_get(nd, "clamp");
    if (cl && !strcmp(json_string_value(cl), "ground")) {
        if (!b->p->ground) {
            push_key(f, "clamp");
            return fail(f, HZ_ERR_VALUE, "needs a terrain to stand on");
        }
        /* The node's origin goes to the lowest ground under its footprint (its
         * mesh's world box corners and its origin), plus its own height as an
         * offset: nothing floats on a slope. */
        hz_scene_update(b->s);
        mat4 w;
        hz_scene_world_matrix(b->s, id, w);
        double g = b->p->ground(b->p->ground_user, w[3][0], w[3][2]);
        hz_box bx;
        hz_scene_node_bounds(b->s, id, &bx);
        if (!hz_box_is_empty(&bx))
            for (int k = 0; k < 4; k++) {
                float gx = k & 1 ? bx.max[0] : bx.min[0], gz = k & 2 ? bx.max[2] : bx.min[2];
                g = fmin(g, b->p->ground(b->p->ground_user, gx, gz));
            }
        if (isfinite(g)) {
            /* World dy -> the parent's frame. */
            mat4 pw, inv;
            if (parent)
                hz_scene_world_matrix(b->s, parent, pw);
            else
                glm_mat4_identity(pw);
            glm_mat4_inv(pw, inv);
            double dy = g + pos[1] - w[3][1];
            vec3 d;
            glm_mat4_mulv3(inv, (vec3){0, (float)dy, 0}, 0, d);
            hz_scene_translate(b->s, id, d);
            b->st.clamped++;
        }
    }
    json_t *ch = json_object_get(nd, "children");
    if (ch) {
        size_t n = push_key(f, "children");
        for (size_t k = 0; k < json_array_size(ch); k++) {
            size_t m = push_index(f, k);
            hz_result r = build_node(b, json_array_get(ch, k), id);
            if (r != HZ_OK)
                return r;
            f->path[m] = 0;
        }
        f->path[n] = 0;
    }
    return HZ_OK;
}

hz_result hz_scene_file_build(hz_scene_file *f, hz_scene *s, const hz_scene_file_place *p, hz_scene_file_stats *stats,
                              hz_err *err)
{
    double t0 = hz_time_ms();
    static const hz_scene_file_place none = {0};
    builder b = {.f = f, .s = s, .p = p ? p : &none};
    f->err = err;
    f->path[0] = 0;
    for (uint32_t k = 0; k < f->mat_count; k++) {
        f->mats[k].scene_index = hz_scene_add_material(s, &f->mats[k].m);
        if (f->mats[k].scene_index == HZ_MESH_NONE)
            return fail(f, HZ_ERR_MEMORY, "out of memory");
    }
    for (uint32_t k = 0; k < f->model_count; k++)
        f->models[k].mesh = HZ_MESH_NONE;
    json_t *nodes = json_object_get(f->root, "nodes");
    size_t n = push_key(f, "nodes");
    for (size_t k = 0; k < json_array_size(nodes); k++) {
        size_t m = push_index(f, k);
        hz_result r = build_node(&b, json_array_get(nodes, k), HZ_NODE_NONE);
        if (r != HZ_OK)
            return r;
        f->path[m] = 0;
    }
    f->path[n] = 0;
    hz_scene_update(s);
    b.st.ms = hz_time_ms() - t0;
    if (stats)
        *stats = b.st;
    return HZ_OK;
}
