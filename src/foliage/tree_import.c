/* Tree import through assimp (OBJ, glTF, FBX, ...). Leaves are told from
 * bark by mesh, node or material name. No GL. */
#include "horizon/tree.h"

#include <assimp/cimport.h>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <ctype.h>
#include <errno.h>
#include <float.h>
#include <string.h>
#include <sys/stat.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "foliage_internal.h"
#include "horizon/safety.h"

typedef struct tri_soup {
    float *pos;          /* welded positions */
    uint32_t nv, cap_v;
    uint32_t *idx;
    size_t ni, cap_i;
    /* weld hash */
    uint32_t *hash;
    size_t hcap;
    bool oom;
} tri_soup;

static bool icontains(const char *hay, const char *needle)
{
    size_t n = strlen(needle);
    for (const char *h = hay; *h; h++) {
        size_t k = 0;
        while (k < n && h[k] && tolower((unsigned char)h[k]) == tolower((unsigned char)needle[k]))
            k++;
        if (k == n)
            return true;
    }
    return false;
}

static uint32_t weld(tri_soup *s, const float *p)
{
    if ((size_t)s->nv * 2 >= s->hcap) {
        size_t nc = s->hcap ? s->hcap * 2 : 1u << 14;
        uint32_t *nh = malloc(nc * sizeof *nh);
        if (!nh) {
            s->oom = true;
            return 0;
        }
        memset(nh, 0xff, nc * sizeof *nh);
        for (uint32_t v = 0; v < s->nv; v++) {
            const float *q = &s->pos[v * 3];
            uint64_t h = 1469598103934665603ULL;
            for (int c = 0; c < 3; c++)
                h = (h ^ (uint64_t)(int64_t)llrintf(q[c] * 1e5f)) * 1099511628211ULL;
            size_t at = (size_t)(h ^ (h >> 31)) & (nc - 1);
            while (nh[at] != 0xffffffffu)
                at = (at + 1) & (nc - 1);
            nh[at] = v;
        }
        free(s->hash);
        s->hash = nh;
        s->hcap = nc;
    }
    uint64_t h = 1469598103934665603ULL;
    for (int c = 0; c < 3; c++)
        h = (h ^ (uint64_t)(int64_t)llrintf(p[c] * 1e5f)) * 1099511628211ULL;
    size_t at = (size_t)(h ^ (h >> 31)) & (s->hcap - 1);
    while (s->hash[at] != 0xffffffffu) {
        const float *q = &s->pos[s->hash[at] * 3];
        if (llrintf(q[0] * 1e5f) == llrintf(p[0] * 1e5f) && llrintf(q[1] * 1e5f) == llrintf(p[1] * 1e5f) &&
            llrintf(q[2] * 1e5f) == llrintf(p[2] * 1e5f))
            return s->hash[at];
        at = (at + 1) & (s->hcap - 1);
    }
    if (s->nv == s->cap_v) {
        uint32_t nc = s->cap_v ? s->cap_v * 2 : 4096;
        float *np = realloc(s->pos, (size_t)nc * 3 * sizeof *np);
        if (!np) {
            s->oom = true;
            return 0;
        }
        s->pos = np;
        s->cap_v = nc;
    }
    v3_copy(&s->pos[s->nv * 3], p);
    s->hash[at] = s->nv;
    return s->nv++;
}

static void add_tri(tri_soup *s, uint32_t a, uint32_t b, uint32_t c)
{
    if (s->ni + 3 > s->cap_i) {
        size_t nc = s->cap_i ? s->cap_i * 2 : 12288;
        uint32_t *np = realloc(s->idx, nc * sizeof *np);
        if (!np) {
            s->oom = true;
            return;
        }
        s->idx = np;
        s->cap_i = nc;
    }
    s->idx[s->ni++] = a;
    s->idx[s->ni++] = b;
    s->idx[s->ni++] = c;
}

static void soup_free(tri_soup *s)
{
    free(s->pos);
    free(s->idx);
    free(s->hash);
}

typedef struct import_ctx {
    const struct aiScene *sc;
    const char *const *match;
    size_t nmatch;
    tri_soup leaf, bark;
    float leaf_rgb[3];
    bool leaf_rgb_set;
    /* the first vertex that is not a finite point (NaN or infinite, before
     * or after its node's transform): the import is refused naming it */
    bool bad;
    char bad_mesh[64];
    unsigned bad_vertex;
} import_ctx;

static bool is_leaf(import_ctx *ic, const struct aiNode *node, const struct aiMesh *mesh)
{
    struct aiString mname;
    const struct aiMaterial *mat = ic->sc->mMaterials ? ic->sc->mMaterials[mesh->mMaterialIndex] : NULL;
    bool have_mat = mat && aiGetMaterialString(mat, AI_MATKEY_NAME, &mname) == aiReturn_SUCCESS;
    for (size_t k = 0; k < ic->nmatch; k++)
        if (icontains(node->mName.data, ic->match[k]) || icontains(mesh->mName.data, ic->match[k]) ||
            (have_mat && icontains(mname.data, ic->match[k])))
            return true;
    return false;
}

static void walk(import_ctx *ic, const struct aiNode *node, struct aiMatrix4x4 parent)
{
    struct aiMatrix4x4 m = parent;
    aiMultiplyMatrix4(&m, &node->mTransformation);
    for (unsigned k = 0; k < node->mNumMeshes; k++) {
        if (node->mMeshes[k] >= ic->sc->mNumMeshes)
            continue; /* (ValidateDataStructure refuses it already) */
        const struct aiMesh *mesh = ic->sc->mMeshes[node->mMeshes[k]];
        bool leaf = is_leaf(ic, node, mesh);
        tri_soup *s = leaf ? &ic->leaf : &ic->bark;
        if (leaf && !ic->leaf_rgb_set && ic->sc->mMaterials && mesh->mMaterialIndex < ic->sc->mNumMaterials) {
            struct aiColor4D col;
            if (aiGetMaterialColor(ic->sc->mMaterials[mesh->mMaterialIndex], AI_MATKEY_COLOR_DIFFUSE, &col) ==
                    aiReturn_SUCCESS &&
                (col.r != col.g || col.g != col.b)) {
                v3_set(ic->leaf_rgb, col.r, col.g, col.b);
                ic->leaf_rgb_set = true;
            }
        }
        for (unsigned f = 0; f < mesh->mNumFaces; f++) {
            const struct aiFace *face = &mesh->mFaces[f];
            if (face->mNumIndices != 3 || face->mIndices[0] >= mesh->mNumVertices ||
                face->mIndices[1] >= mesh->mNumVertices || face->mIndices[2] >= mesh->mNumVertices)
                continue; /* points and lines (and, defensively, indices out of range) */
            uint32_t w[3];
            bool finite = true;
            for (int c = 0; c < 3 && finite; c++) {
                struct aiVector3D v = mesh->mVertices[face->mIndices[c]];
                aiTransformVecByMatrix4(&v, &m);
                finite = isfinite(v.x) && isfinite(v.y) && isfinite(v.z);
                if (!finite && !ic->bad) {
                    ic->bad = true;
                    snprintf(ic->bad_mesh, sizeof ic->bad_mesh, "%.63s", mesh->mName.data);
                    ic->bad_vertex = face->mIndices[c];
                }
                const float p[3] = {v.x, v.y, v.z};
                if (finite)
                    w[c] = weld(s, p);
            }
            if (finite && w[0] != w[1] && w[1] != w[2] && w[0] != w[2])
                add_tri(s, w[0], w[1], w[2]);
        }
    }
    for (unsigned k = 0; k < node->mNumChildren; k++)
        walk(ic, node->mChildren[k], m);
}

/* Union-find over vertices; returns per-vertex component ids 0..*ncomp-1. */
static uint32_t *components(const tri_soup *s, uint32_t *ncomp)
{
    uint32_t *par = malloc((s->nv ? s->nv : 1) * sizeof *par);
    if (!par)
        return NULL;
    for (uint32_t v = 0; v < s->nv; v++)
        par[v] = v;
    for (size_t k = 0; k < s->ni; k += 3)
        for (int e = 1; e < 3; e++) {
            uint32_t a = s->idx[k], b = s->idx[k + e];
            while (par[a] != a)
                a = par[a] = par[par[a]];
            while (par[b] != b)
                b = par[b] = par[par[b]];
            if (a != b)
                par[a > b ? a : b] = a < b ? a : b;
        }
    uint32_t *id = malloc((s->nv ? s->nv : 1) * sizeof *id);
    if (!id) {
        free(par);
        return NULL;
    }
    uint32_t n = 0;
    for (uint32_t v = 0; v < s->nv; v++) {
        uint32_t r = v;
        while (par[r] != r)
            r = par[r];
        id[v] = r == v ? n++ : 0xffffffffu;
    }
    for (uint32_t v = 0; v < s->nv; v++) {
        uint32_t r = v;
        while (par[r] != r)
            r = par[r];
        id[v] = id[r];
    }
    free(par);
    *ncomp = n;
    return id;
}

/* Principal axes of a point set (Jacobi on the 3x3 covariance), major first. */
static void principal_axes(const float *pts, const uint32_t *sel, uint32_t n, const float *c, float axes[3][3])
{
    double a[3][3] = {{0}}, v[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    for (uint32_t k = 0; k < n; k++) {
        const float *p = &pts[sel[k] * 3];
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                a[i][j] += (double)(p[i] - c[i]) * (double)(p[j] - c[j]);
    }
    for (int sweep = 0; sweep < 30; sweep++) {
        double off = fabs(a[0][1]) + fabs(a[0][2]) + fabs(a[1][2]);
        if (off < 1e-18)
            break;
        for (int p = 0; p < 2; p++)
            for (int q = p + 1; q < 3; q++) {
                if (fabs(a[p][q]) < 1e-30)
                    continue;
                double th = 0.5 * atan2(2 * a[p][q], a[q][q] - a[p][p]);
                double cs = cos(th), sn = sin(th);
                for (int k = 0; k < 3; k++) {
                    double akp = a[k][p], akq = a[k][q];
                    a[k][p] = cs * akp - sn * akq;
                    a[k][q] = sn * akp + cs * akq;
                }
                for (int k = 0; k < 3; k++) {
                    double apk = a[p][k], aqk = a[q][k];
                    a[p][k] = cs * apk - sn * aqk;
                    a[q][k] = sn * apk + cs * aqk;
                }
                for (int k = 0; k < 3; k++) {
                    double vkp = v[k][p], vkq = v[k][q];
                    v[k][p] = cs * vkp - sn * vkq;
                    v[k][q] = sn * vkp + cs * vkq;
                }
            }
    }
    int ord[3] = {0, 1, 2};
    for (int i = 0; i < 3; i++)
        for (int j = i + 1; j < 3; j++)
            if (a[ord[j]][ord[j]] > a[ord[i]][ord[i]]) {
                int t = ord[i];
                ord[i] = ord[j];
                ord[j] = t;
            }
    for (int i = 0; i < 3; i++) {
        for (int k = 0; k < 3; k++)
            axes[i][k] = (float)v[k][ord[i]];
        v3_norm(axes[i]);
    }
}

typedef struct piece {
    uint32_t first, count; /* into a vertex-id list */
    float c[3];
} piece;

typedef struct leaf_rec {
    hz_tree_leaf leaf;
    uint32_t piece;  /* nearest bark piece */
    float key;       /* projection for splitting */
} leaf_rec;

static int cmp_leaf(const void *a, const void *b)
{
    const leaf_rec *x = a, *y = b;
    if (x->piece != y->piece)
        return (x->piece > y->piece) - (x->piece < y->piece);
    return (x->key > y->key) - (x->key < y->key);
}

/* Groups vertex ids by component. */
static piece *group(const tri_soup *s, const uint32_t *comp, uint32_t ncomp, uint32_t **order)
{
    piece *pc = calloc(ncomp ? ncomp : 1, sizeof *pc);
    uint32_t *ord = malloc((s->nv ? s->nv : 1) * sizeof *ord);
    if (!pc || !ord) {
        free(pc);
        free(ord);
        return NULL;
    }
    for (uint32_t v = 0; v < s->nv; v++)
        pc[comp[v]].count++;
    uint32_t at = 0;
    for (uint32_t k = 0; k < ncomp; k++) {
        pc[k].first = at;
        at += pc[k].count;
        pc[k].count = 0;
    }
    for (uint32_t v = 0; v < s->nv; v++) {
        piece *p = &pc[comp[v]];
        ord[p->first + p->count++] = v;
        v3_add(p->c, p->c, &s->pos[v * 3]);
    }
    for (uint32_t k = 0; k < ncomp; k++)
        v3_scale(pc[k].c, pc[k].c, 1.0f / (float)(pc[k].count ? pc[k].count : 1));
    *order = ord;
    return pc;
}

hz_tree *hz_tree_import(const hz_tree_import_desc *desc, hz_err *err)
{
    hz_tree_import_desc d = *desc;
    static const char *const default_match[] = {"leaf", "leaves", "foliage", "needle"};
    const char *one[1] = {d.leaf_match};
    if (!d.path) {
        hz_err_set(err, HZ_ERR_VALUE, "import: no file given");
        return NULL;
    }
    if (d.scale <= 0)
        d.scale = 1.0f;
    if (!d.node_leaves)
        d.node_leaves = 48;
    if (d.node_leaves > 4096 || !isfinite(d.scale) || (d.up && d.up != 'y' && d.up != 'z')) {
        hz_err_set(err, HZ_ERR_VALUE, "import: bad options (node leaves %u, scale %g, up '%c')", d.node_leaves,
                   (double)d.scale, d.up ? d.up : '?');
        return NULL;
    }
    /* Budget: assimp holds the whole scene, text formats expand ~20x. */
    struct stat fst;
    if (stat(d.path, &fst) != 0) {
        hz_err_set(err, HZ_ERR_IO, "import: cannot open '%s': %s", d.path, strerror(errno));
        return NULL;
    }
    if (hz_mem_check((uint64_t)fst.st_size * 20u, d.max_memory, "import (assimp scene)", err) != HZ_OK)
        return NULL;
    /* ValidateDataStructure: some importers (PLY, OFF) pass faces whose
     * indices lie past the mesh's vertices; the validation refuses them. */
    const struct aiScene *sc =
        aiImportFile(d.path, aiProcess_ValidateDataStructure | aiProcess_Triangulate | aiProcess_SortByPType);
    if (!sc || !sc->mRootNode) {
        hz_err_set(err, HZ_ERR_FORMAT, "import: cannot read '%s': %s", d.path, aiGetErrorString());
        if (sc)
            aiReleaseImport(sc);
        return NULL;
    }
    uint64_t mesh_bytes = 0;
    for (unsigned k = 0; k < sc->mNumMeshes; k++)
        mesh_bytes += (uint64_t)sc->mMeshes[k]->mNumVertices * 48u + (uint64_t)sc->mMeshes[k]->mNumFaces * 64u;
    if (hz_mem_check(mesh_bytes, d.max_memory, "import (meshes)", err) != HZ_OK) {
        aiReleaseImport(sc);
        return NULL;
    }
    import_ctx ic = {.sc = sc, .match = d.leaf_match ? one : default_match, .nmatch = d.leaf_match ? 1 : 4};
    struct aiMatrix4x4 id;
    aiIdentityMatrix4(&id);
    walk(&ic, sc->mRootNode, id);
    aiReleaseImport(sc);
    hz_tree *t = NULL;
    uint32_t *lcomp = NULL, *bcomp = NULL, *lord = NULL, *bord = NULL;
    piece *lp = NULL, *bp = NULL;
    leaf_rec *lr = NULL;
    if (ic.leaf.oom || ic.bark.oom) {
        hz_err_set(err, HZ_ERR_MEMORY, "import: out of memory");
        goto done;
    }
    if (ic.bad) {
        hz_err_set(err, HZ_ERR_FORMAT, "import: '%s': vertex %u of mesh '%s' is not a finite point (NaN or infinite)",
                   d.path, ic.bad_vertex, ic.bad_mesh);
        goto done;
    }
    if (ic.leaf.ni == 0 || ic.bark.ni == 0) {
        hz_err_set(err, HZ_ERR_FORMAT,
                   "import: '%s' has %zu leaf and %zu bark triangles; need both (leaves are meshes whose mesh, node "
                   "or material name contains %s)",
                   d.path, ic.leaf.ni / 3, ic.bark.ni / 3, d.leaf_match ? d.leaf_match : "leaf/leaves/foliage/needle");
        goto done;
    }
    /* Up axis and units: y up, metres, trunk base at the origin. */
    float lo[3] = {FLT_MAX, FLT_MAX, FLT_MAX}, hi[3] = {-FLT_MAX, -FLT_MAX, -FLT_MAX};
    tri_soup *soups[2] = {&ic.leaf, &ic.bark};
    for (int s = 0; s < 2; s++)
        for (uint32_t v = 0; v < soups[s]->nv; v++)
            for (int c = 0; c < 3; c++) {
                lo[c] = fminf(lo[c], soups[s]->pos[v * 3 + c]);
                hi[c] = fmaxf(hi[c], soups[s]->pos[v * 3 + c]);
            }
    char up = d.up;
    if (!up)
        up = (hi[2] - lo[2]) > (hi[1] - lo[1]) && (hi[2] - lo[2]) > (hi[0] - lo[0]) ? 'z' : 'y';
    for (int s = 0; s < 2; s++)
        for (uint32_t v = 0; v < soups[s]->nv; v++) {
            float *p = &soups[s]->pos[v * 3];
            if (up == 'z') {
                float y = p[1];
                p[1] = p[2];
                p[2] = -y;
            }
            v3_scale(p, p, d.scale);
        }
    uint32_t nlc = 0, nbc = 0;
    lcomp = components(&ic.leaf, &nlc);
    bcomp = components(&ic.bark, &nbc);
    if (!lcomp || !bcomp || !(lp = group(&ic.leaf, lcomp, nlc, &lord)) || !(bp = group(&ic.bark, bcomp, nbc, &bord))) {
        hz_err_set(err, HZ_ERR_MEMORY, "import: out of memory");
        goto done;
    }
    /* Trunk: the bark piece reaching lowest. Shift so its base is the origin. */
    uint32_t trunk = 0;
    float ymin = FLT_MAX;
    for (uint32_t v = 0; v < ic.bark.nv; v++)
        if (ic.bark.pos[v * 3 + 1] < ymin) {
            ymin = ic.bark.pos[v * 3 + 1];
            trunk = bcomp[v];
        }
    float shift[3] = {-bp[trunk].c[0], -ymin, -bp[trunk].c[2]};
    for (int s = 0; s < 2; s++)
        for (uint32_t v = 0; v < soups[s]->nv; v++)
            v3_add(&soups[s]->pos[v * 3], &soups[s]->pos[v * 3], shift);
    for (uint32_t k = 0; k < nlc; k++)
        v3_add(lp[k].c, lp[k].c, shift);
    for (uint32_t k = 0; k < nbc; k++)
        v3_add(bp[k].c, bp[k].c, shift);

    /* Leaves: each connected leaf piece refit as a quad; its nearest bark piece. */
    lr = calloc(nlc, sizeof *lr);
    t = calloc(1, sizeof *t);
    if (!lr || !t) {
        hz_err_set(err, HZ_ERR_MEMORY, "import: out of memory");
        goto fail;
    }
    for (uint32_t k = 0; k < nlc; k++) {
        float ax[3][3];
        const uint32_t *sel = lord + lp[k].first;
        principal_axes(ic.leaf.pos, sel, lp[k].count, lp[k].c, ax);
        float e0 = 0, e1 = 0;
        for (uint32_t j = 0; j < lp[k].count; j++) {
            float q[3];
            v3_sub(q, &ic.leaf.pos[sel[j] * 3], lp[k].c);
            e0 = fmaxf(e0, fabsf(v3_dot(q, ax[0])));
            e1 = fmaxf(e1, fabsf(v3_dot(q, ax[1])));
        }
        hz_tree_leaf *lf = &lr[k].leaf;
        v3_copy(lf->c, lp[k].c);
        v3_scale(lf->u, ax[0], fmaxf(e0, 1e-4f));
        v3_scale(lf->v, ax[1], fmaxf(e1, 1e-4f));
        float best = FLT_MAX;
        for (uint32_t v = 0; v < ic.bark.nv; v++) {
            float dd[3];
            v3_sub(dd, &ic.bark.pos[v * 3], lf->c);
            float d2 = v3_dot(dd, dd);
            if (d2 < best) {
                best = d2;
                lr[k].piece = bcomp[v];
            }
        }
    }
    /* Sort leaves by piece, then along each piece's leaf spread, and cut
     * into nodes of at most node_leaves. */
    for (uint32_t k = 0; k < nlc; k++) {
        float dd[3];
        v3_sub(dd, lr[k].leaf.c, bp[lr[k].piece].c);
        float ax[3];
        v3_sub(ax, bp[lr[k].piece].c, bp[trunk].c);
        if (v3_len(ax) < 1e-4f)
            v3_set(ax, 0, 1, 0);
        v3_norm(ax);
        lr[k].key = v3_dot(dd, ax);
    }
    qsort(lr, nlc, sizeof *lr, cmp_leaf);
    /* Branch table: trunk, the other pieces (level 2), one twig per node (level 3). */
    uint32_t nnodes = 0;
    for (uint32_t k = 0; k < nlc;) {
        uint32_t e = k;
        while (e < nlc && lr[e].piece == lr[k].piece)
            e++;
        nnodes += (e - k + d.node_leaves - 1) / d.node_leaves;
        k = e;
    }
    uint32_t *piece_branch = malloc(nbc * sizeof *piece_branch);
    t->branches = calloc((size_t)nbc + nnodes, sizeof *t->branches);
    t->nodes = calloc(nnodes ? nnodes : 1, sizeof *t->nodes);
    t->leaves = malloc(nlc * sizeof *t->leaves);
    if (!piece_branch || !t->branches || !t->nodes || !t->leaves) {
        free(piece_branch);
        hz_err_set(err, HZ_ERR_MEMORY, "import: out of memory");
        goto fail;
    }
    uint32_t nb = 0;
    for (uint32_t pass = 0; pass < 2; pass++)
        for (uint32_t k = 0; k < nbc; k++) {
            if ((pass == 0) != (k == trunk))
                continue;
            float ax[3][3];
            principal_axes(ic.bark.pos, bord + bp[k].first, bp[k].count, bp[k].c, ax);
            float emin = FLT_MAX, emax = -FLT_MAX, rad = 0;
            if (ax[0][1] < 0)
                v3_scale(ax[0], ax[0], -1.0f);
            for (uint32_t j = 0; j < bp[k].count; j++) {
                float q[3];
                v3_sub(q, &ic.bark.pos[bord[bp[k].first + j] * 3], bp[k].c);
                float s = v3_dot(q, ax[0]);
                emin = fminf(emin, s);
                emax = fmaxf(emax, s);
                float r[3];
                v3_madd(r, q, ax[0], -s);
                rad = fmaxf(rad, v3_len(r));
            }
            hz_tree_branch *br = &t->branches[nb];
            br->parent = nb == 0 ? HZ_TREE_NONE : 0;
            br->level = nb == 0 ? 1 : 2;
            br->leaf_node = HZ_TREE_NONE;
            v3_madd(br->base, bp[k].c, ax[0], emin);
            v3_madd(br->tip, bp[k].c, ax[0], emax);
            v3_copy(br->dir, ax[0]);
            br->length = emax - emin;
            br->radius = rad;
            piece_branch[k] = nb++;
        }
    uint32_t nn = 0, nl = 0;
    for (uint32_t k = 0; k < nlc;) {
        uint32_t e = k;
        while (e < nlc && lr[e].piece == lr[k].piece)
            e++;
        uint32_t chunks = (e - k + d.node_leaves - 1) / d.node_leaves;
        for (uint32_t c = 0; c < chunks; c++) {
            uint32_t a = k + (uint32_t)((uint64_t)(e - k) * c / chunks);
            uint32_t b = k + (uint32_t)((uint64_t)(e - k) * (c + 1) / chunks);
            float cen[3] = {0, 0, 0};
            for (uint32_t j = a; j < b; j++) {
                t->leaves[nl + j - a] = lr[j].leaf;
                v3_add(cen, cen, lr[j].leaf.c);
            }
            v3_scale(cen, cen, 1.0f / (float)(b - a));
            const hz_tree_branch *pb = &t->branches[piece_branch[lr[k].piece]];
            hz_tree_branch *tw = &t->branches[nb];
            tw->parent = piece_branch[lr[k].piece];
            tw->level = pb->level + 1;
            tw->leaf_node = nn;
            /* A twig from the nearest point of its branch axis to the leaves' centre. */
            float axv[3], q[3];
            v3_sub(axv, pb->tip, pb->base);
            float L2 = fmaxf(v3_dot(axv, axv), 1e-8f);
            v3_sub(q, cen, pb->base);
            float s = fminf(fmaxf(v3_dot(q, axv) / L2, 0.0f), 1.0f);
            v3_madd(tw->base, pb->base, axv, s);
            v3_copy(tw->tip, cen);
            v3_sub(tw->dir, tw->tip, tw->base);
            tw->length = v3_len(tw->dir);
            if (tw->length < 1e-4f) {
                v3_set(tw->dir, 0, 1, 0);
                tw->length = 1e-4f;
            }
            v3_norm(tw->dir);
            tw->radius = 0.0f;
            t->nodes[nn] = (hz_tree_node){.branch = nb, .first = nl, .count = b - a, .bsl = 1};
            nl += b - a;
            nn++;
            nb++;
        }
        k = e;
    }
    free(piece_branch);
    t->branch_count = nb;
    t->node_count = nn;
    t->leaf_count = nl;
    t->levels = 1;
    for (uint32_t b = 0; b < nb; b++)
        if (t->branches[b].level > t->levels)
            t->levels = t->branches[b].level;
    /* Bark mesh: trunk triangles first. */
    t->bark.pos = malloc((size_t)ic.bark.nv * 3 * sizeof(float));
    t->bark.nrm = calloc((size_t)ic.bark.nv * 3, sizeof(float));
    t->bark.idx = malloc(ic.bark.ni * sizeof(uint32_t));
    if (!t->bark.pos || !t->bark.nrm || !t->bark.idx) {
        hz_err_set(err, HZ_ERR_MEMORY, "import: out of memory");
        goto fail;
    }
    memcpy(t->bark.pos, ic.bark.pos, (size_t)ic.bark.nv * 3 * sizeof(float));
    t->bark.vertex_count = ic.bark.nv;
    uint32_t ni = 0;
    for (int pass = 0; pass < 2; pass++) {
        for (size_t k = 0; k < ic.bark.ni; k += 3)
            if ((bcomp[ic.bark.idx[k]] == trunk) == (pass == 0)) {
                memcpy(&t->bark.idx[ni], &ic.bark.idx[k], 3 * sizeof(uint32_t));
                ni += 3;
            }
        t->bark_level_end[pass] = ni;
    }
    for (uint32_t l = 2; l < t->levels; l++)
        t->bark_level_end[l] = ni;
    t->bark.index_count = ni;
    for (uint32_t k = 0; k < ni; k += 3) {
        const uint32_t *ix = &t->bark.idx[k];
        float e1[3], e2[3], n[3];
        v3_sub(e1, &t->bark.pos[ix[1] * 3], &t->bark.pos[ix[0] * 3]);
        v3_sub(e2, &t->bark.pos[ix[2] * 3], &t->bark.pos[ix[0] * 3]);
        v3_cross(n, e1, e2);
        for (int c = 0; c < 3; c++)
            v3_add(&t->bark.nrm[ix[c] * 3], &t->bark.nrm[ix[c] * 3], n);
    }
    for (uint32_t v = 0; v < t->bark.vertex_count; v++) {
        v3_norm(&t->bark.nrm[v * 3]);
        if (v3_len(&t->bark.nrm[v * 3]) < 0.5f)
            v3_set(&t->bark.nrm[v * 3], 0, 1, 0);
    }
    const char *base = strrchr(d.path, '/');
    snprintf(t->species, sizeof t->species, "%s", base ? base + 1 : d.path);
    char *dot = strrchr(t->species, '.');
    if (dot)
        *dot = 0;
    if (ic.leaf_rgb_set)
        v3_copy(t->leaf_color, ic.leaf_rgb);
    else
        v3_set(t->leaf_color, 0.22f, 0.36f, 0.08f);
    v3_set(t->bark_color, 0.55f, 0.52f, 0.48f);
    hz_tree_finish(t);
    if (hz_tree_validate(t, err) != HZ_OK) {
        if (err) { /* which file it came from */
            char why[sizeof err->msg];
            snprintf(why, sizeof why, "%s", err->msg);
            hz_err_set(err, HZ_ERR_FORMAT, "import: '%s': %s", d.path, why);
        }
        goto fail;
    }
    goto done;
fail:
    hz_tree_destroy(t);
    t = NULL;
done:
    free(lcomp);
    free(bcomp);
    free(lord);
    free(bord);
    free(lp);
    free(bp);
    free(lr);
    soup_free(&ic.leaf);
    soup_free(&ic.bark);
    return t;
}
