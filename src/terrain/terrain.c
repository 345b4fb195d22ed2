#include "horizon/terrain.h"

#include "horizon/safety.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Peak bytes per heightmap sample of a command on a terrain: the float grid
 * and its fitted copy, the heightmap, the LOD data and the renderer's and
 * effects' per-sample copies. Measured (peak RSS difference 2049^2 -> 4097^2,
 * `horizon render --generate perlin`): 16 for cdlod, 13 for roam; bench's
 * reference surfaces add 8. */
#define TERRAIN_BYTES_PER_SAMPLE 24u

/* The terrain a side x side heightmap makes, checked against the budget and
 * the sample limit before any work. hint: what else the user can do (after
 * "import it as a pyramid and stream it"). */
static hz_result check_side(const hz_terrain_desc *d, uint32_t side, const char *what, const char *hint, hz_err *err)
{
    /* The memory first: it is what the user can raise (--max-memory). */
    const uint64_t n = (uint64_t)side * side;
    char w[400];
    snprintf(w, sizeof w, "%s: a %ux%u terrain", what, side, side);
    hz_result r = hz_mem_check(n * TERRAIN_BYTES_PER_SAMPLE, d->max_memory, w, err);
    if (r != HZ_OK)
        return r;
    if (d->max_samples && n > d->max_samples)
        return hz_err_set(err, HZ_ERR_UNSUPPORTED,
                          "%s: a %ux%u heightmap has %llu samples, more than this GPU takes "
                          "(GL_MAX_TEXTURE_BUFFER_SIZE = %llu texels) in memory: import it as a pyramid and stream it "
                          "(horizon import DEM... --out NAME.hzp, then --terrain NAME.hzp), or %s",
                          what, side, side, (unsigned long long)n, (unsigned long long)d->max_samples, hint);
    return HZ_OK;
}

/* The largest 2^n + 1 side whose square the GPU takes (0: none over 2). */
static uint32_t largest_side(uint64_t max_samples)
{
    uint32_t s = 0;
    for (uint32_t k = 1; k < 31; k++) {
        const uint64_t side = ((uint64_t)1 << k) + 1;
        if (side * side > max_samples)
            break;
        s = (uint32_t)side;
    }
    return s;
}

/* The spacing (rounded up to 0.1 m) at which hi samples spaced spacing
 * apart take at most side samples. */
static double spacing_to_fit(float spacing, uint32_t hi, uint32_t side)
{
    return ceil((double)spacing * (hi - 1) / (side - 1) * 10.0 * (1.0 + 1e-6)) / 10.0;
}

/* What a DEM of w x h samples can do instead of streaming: a georeferenced
 * one is resampled to --spacing (the spacing that brings its longer side
 * into the largest square the GPU takes, rounded up to 0.1 m); another one
 * can be cropped to its centred square, when that fits, or cut. */
static void dem_hint(const hz_terrain_desc *d, uint32_t w, uint32_t h, bool georef, float spacing, char *out,
                     size_t cap)
{
    const uint32_t top = largest_side(d->max_samples), hi = w > h ? w : h;
    const uint32_t crop = hz_grid_fit_side(w, h, HZ_FIT_CROP);
    if (georef && top > 2 && spacing > 0 && hi > 1) {
        snprintf(out, cap, "resample it with --spacing %.1f (at most %ux%u samples; it is %.1f m now)",
                 spacing_to_fit(spacing, hi, top), top, top, (double)spacing);
    } else if (crop > 2 && crop <= top) {
        snprintf(out, cap, "keep its centred %ux%u square with --fit crop", crop, crop);
    } else {
        snprintf(out, cap, "cut it to at most %ux%u samples (gdal_translate -srcwin)", top, top);
    }
}

/* A DEM kept whole on a square grid that is mostly padding (a tile that
 * reprojection made taller than wide, just past a power of two): the
 * spacing that fits its longer side in the next smaller grid, a quarter of
 * the samples, memory and setup time, is appended to the fitting note. Only
 * when the user chose no spacing and a georeference allows resampling. */
static void padding_hint(const hz_terrain_desc *d, const hz_grid_fit_info *fi, uint32_t side, bool georef,
                         float spacing, char *note, size_t cap)
{
    const uint32_t hi = fi->data_w > fi->data_h ? fi->data_w : fi->data_h, half = (side - 1) / 2 + 1;
    if (d->fit != HZ_FIT_AUTO || d->spacing > 0 || !georef || !(spacing > 0) || side < 5 || hi <= half ||
        2 * (uint64_t)fi->data_w * fi->data_h >= (uint64_t)side * side)
        return;
    const size_t n = strlen(note);
    snprintf(note + n, cap - n, "%s%.0f %% padding: --spacing %.1f fits it in %ux%u, a quarter of the samples",
             n ? "; " : "", 100.0 * (1.0 - (double)fi->data_w * fi->data_h / ((double)side * side)),
             spacing_to_fit(spacing, hi, half), half, half);
}

static const char *base_name(const char *p)
{
    const char *s = strrchr(p, '/');
    return s ? s + 1 : p;
}

/* A DEM of w x h samples against the budget and the sample limit, as the
 * terrain will fit it (hz_dem_desc.size_check: before the samples are read). */
static hz_result dem_size_ok(void *user, uint32_t w, uint32_t h, double spacing, bool georef, hz_err *err)
{
    const hz_terrain_desc *d = user;
    const uint32_t side = hz_grid_fit_side(w, h, d->fit);
    if (!side)
        return HZ_OK; /* too small: refused by name later */
    char hint[160];
    dem_hint(d, w, h, georef, d->spacing > 0 ? d->spacing : (float)spacing, hint, sizeof hint);
    return check_side(d, side, base_name(d->dem_path_count ? d->dem_paths[0] : d->dem_path), hint, err);
}

/* Marks every invalid sample that is not connected (4-neighbours, through
 * invalid samples) to the grid's edge as valid: voids enclosed by data are
 * drawn with their filled heights. Returns false if out of memory. */
/* Pushes v, growing the stack; false (the stack freed) when out of memory. */
static bool stack_push(uint32_t **stack, size_t *top, size_t *cap, uint32_t v)
{
    if (*top == *cap) {
        uint32_t *ns = realloc(*stack, 2 * *cap * sizeof *ns);
        if (!ns) {
            free(*stack);
            *stack = NULL;
            return false;
        }
        *stack = ns;
        *cap *= 2;
    }
    (*stack)[(*top)++] = v;
    return true;
}

static bool unmask_enclosed(uint8_t *valid, uint32_t n, uint64_t *count)
{
    size_t cap = 1u << 16, top = 0;
    uint32_t *stack = malloc(cap * sizeof *stack);
    if (!stack)
        return false;
    /* 2 = invalid and reachable from the edge. */
    for (uint32_t k = 0; k < n; k++) {
        const uint32_t edge[4] = {k, (n - 1) * n + k, k * n, k * n + n - 1};
        for (int e = 0; e < 4; e++)
            if (valid[edge[e]] == 0) {
                valid[edge[e]] = 2;
                if (!stack_push(&stack, &top, &cap, edge[e]))
                    return false;
            }
    }
    while (top) {
        uint32_t v = stack[--top], i = v % n, j = v / n;
        uint32_t nb[4];
        int m = 0;
        if (i > 0) nb[m++] = v - 1;
        if (i + 1 < n) nb[m++] = v + 1;
        if (j > 0) nb[m++] = v - n;
        if (j + 1 < n) nb[m++] = v + n;
        for (int q = 0; q < m; q++) {
            if (valid[nb[q]] != 0)
                continue;
            valid[nb[q]] = 2;
            if (!stack_push(&stack, &top, &cap, nb[q]))
                return false;
        }
    }
    free(stack);
    uint64_t c = 0;
    for (size_t k = 0; k < (size_t)n * n; k++) {
        valid[k] = valid[k] != 2;
        c += valid[k];
    }
    *count = c;
    return true;
}

hz_terrain *hz_terrain_create(const hz_terrain_desc *desc, hz_err *err)
{
    hz_terrain *t = calloc(1, sizeof *t);
    hz_grid g = {0};
    if (!t) {
        hz_err_set(err, HZ_ERR_MEMORY, "terrain: out of memory");
        return NULL;
    }
    if (desc->spacing < 0 || !isfinite(desc->spacing) || desc->spacing > 1e5f) {
        hz_err_set(err, HZ_ERR_VALUE, "spacing must be a positive number of metres (got %g)", (double)desc->spacing);
        goto fail;
    }
    if (desc->zscale < 0 || !isfinite(desc->zscale) || desc->zscale > 1e4f) {
        hz_err_set(err, HZ_ERR_VALUE, "zscale must be a positive number (got %g)", (double)desc->zscale);
        goto fail;
    }
    const bool ranged = desc->height_min != 0.0f || desc->height_max != 0.0f;
    if (ranged && (!isfinite(desc->height_min) || !isfinite(desc->height_max) ||
                   !(desc->height_min < desc->height_max))) {
        hz_err_set(err, HZ_ERR_VALUE, "height range: MIN must be below MAX (got %g, %g)", (double)desc->height_min,
                   (double)desc->height_max);
        goto fail;
    }
    if (ranged && !desc->dem_path && desc->dem_path_count == 0) {
        hz_err_set(err, HZ_ERR_VALUE, "a height range maps a DEM file's stored values; a generated terrain has none "
                                      "(use --amplitude)");
        goto fail;
    }
    if (ranged && desc->units != HZ_UNITS_AUTO && desc->units != HZ_UNITS_RAW) {
        hz_err_set(err, HZ_ERR_VALUE, "a height range maps the stored values to metres: it replaces the units "
                                      "(give one or the other)");
        goto fail;
    }
    if (!isfinite(desc->height_offset) || fabsf(desc->height_offset) > 1e5f) {
        hz_err_set(err, HZ_ERR_VALUE, "height offset must be in [-1e5, 1e5] metres (got %g)",
                   (double)desc->height_offset);
        goto fail;
    }
    double t0 = hz_time_ms();
    float default_spacing;
    hz_georef *geo = NULL;
    hz_grid_fit_info fi = {0};
    if (desc->dem_path || desc->dem_path_count > 0) {
        hz_dem_desc dd = {.path = desc->dem_path, .paths = desc->dem_paths, .path_count = desc->dem_path_count,
                          .format = desc->format, .units = ranged ? HZ_UNITS_RAW : desc->units,
                          .width = desc->raw_width, .height = desc->raw_height, .metric = true, .crs = desc->crs,
                          .spacing = desc->spacing, .georef = &geo,
                          .progress = desc->progress, .progress_user = desc->progress_user,
                          .max_memory = desc->max_memory, .size_check = dem_size_ok, .size_check_user = (void *)desc};
        if (hz_dem_load(&dd, &g, &t->info, err) != HZ_OK)
            goto fail;
        if (ranged && !(t->info.full_scale > 0)) {
            hz_err_set(err, HZ_ERR_VALUE, "'%s' stores metres (Terrarium), not normalised values: a height range "
                                          "does not apply", base_name(dd.path_count ? dd.paths[0] : dd.path));
            hz_georef_destroy(geo);
            goto fail;
        }
        /* What fitting will make of it, before filling and fitting (GDAL
         * inputs were checked before reading; the others are checked here). */
        if (dem_size_ok((void *)desc, g.width, g.height, t->info.spacing_hint, geo != NULL, err) != HZ_OK) {
            hz_georef_destroy(geo);
            goto fail;
        }
        t->voids_filled = t->info.voids;
        t->file_samples = (uint64_t)t->info.file_width * t->info.file_height;
        if (desc->dem_path_count > 1)
            snprintf(t->source, sizeof t->source, "%u files (%s ...)", t->info.files,
                     base_name(desc->dem_paths[0]));
        else if (t->info.files > 1)
            snprintf(t->source, sizeof t->source, "%s (%u files)",
                     base_name(desc->dem_path_count ? desc->dem_paths[0] : desc->dem_path), t->info.files);
        else
            snprintf(t->source, sizeof t->source, "%s",
                     base_name(desc->dem_path_count ? desc->dem_paths[0] : desc->dem_path));
        default_spacing = t->info.spacing_hint > 0 ? t->info.spacing_hint : 30.0f;
    } else {
        hz_gen_desc gd = {.kind = desc->generate ? desc->generate : HZ_GEN_PERLIN,
                          .size = desc->gen_size ? desc->gen_size : 4097,
                          .seed = desc->seed, .amplitude = desc->amplitude,
                          .progress = desc->progress, .progress_user = desc->progress_user};
        if (check_side(desc, gd.size, "generated terrain", "a smaller --size", err) != HZ_OK)
            goto fail;
        if (hz_generate(&gd, &g, err) != HZ_OK)
            goto fail;
        snprintf(t->source, sizeof t->source, "%s %u seed %llu",
                 gd.kind == HZ_GEN_DIAMOND ? "diamond" : "perlin", gd.size, (unsigned long long)gd.seed);
        default_spacing = 10.0f;
    }
    if (ranged || desc->height_offset != 0.0f) {
        /* NaN voids stay NaN. */
        const double k = ranged ? ((double)desc->height_max - desc->height_min) / t->info.full_scale : 1.0;
        const double b = (ranged ? (double)desc->height_min : 0.0) + desc->height_offset;
        for (size_t s = 0; s < (size_t)g.width * g.height; s++)
            g.z[s] = (float)(g.z[s] * k + b);
    }
    if (hz_grid_fit(&g, desc->fit, &fi, t->note, sizeof t->note, err) != HZ_OK) {
        hz_georef_destroy(geo);
        goto fail;
    }
    t->valid = fi.valid;
    t->valid_count = fi.valid_count;
    padding_hint(desc, &fi, g.width, geo != NULL, t->info.spacing_hint, t->note, sizeof t->note);
    if (t->valid && desc->fill_voids && !unmask_enclosed(t->valid, g.width, &t->valid_count)) {
        hz_georef_destroy(geo);
        hz_err_set(err, HZ_ERR_MEMORY, "terrain: out of memory finding the enclosed voids");
        goto fail;
    }
    t->data_x = fi.x0 > 0 ? (uint32_t)fi.x0 : 0;
    t->data_y = fi.y0 > 0 ? (uint32_t)fi.y0 : 0;
    t->data_w = fi.data_w;
    t->data_h = fi.data_h;
    if (geo) {
        /* The georeference of the heightmap grid: sample (0, 0) is the file's (-x0, -y0). */
        t->georef = hz_georef_shifted(geo, -fi.x0, -fi.y0, g.width, g.height);
        hz_georef_destroy(geo);
        if (!t->georef) {
            hz_err_set(err, HZ_ERR_MEMORY, "terrain: out of memory for the georeference");
            goto fail;
        }
    }
    t->load_ms = hz_time_ms() - t0;
    t0 = hz_time_ms();
    if (hz_heightmap_create(&t->hm, &g, desc->layout, err) != HZ_OK)
        goto fail;
    hz_grid_free(&g);
    t->spacing = desc->spacing > 0 ? desc->spacing : default_spacing;
    t->zscale = desc->zscale > 0 ? desc->zscale : 1.0f;
    t->min_h = t->hm.offset;
    t->max_h = t->hm.offset + 65535.0f * t->hm.scale;
    if (!ranged && (desc->dem_path || desc->dem_path_count) && t->max_h > 9000.0f) {
        /* Above Everest (8849 m): most likely a normalised file. */
        const size_t len = strlen(t->note);
        snprintf(t->note + len, sizeof t->note - len,
                 "%sheights reach %.0f m, higher than any mountain: if the file is normalised (0..65535), "
                 "give its range with --height-range MIN,MAX", len ? "; " : "", (double)t->max_h);
    }
    t->lod = hz_lod_create(&(hz_lod_desc){.hm = &t->hm, .spacing = t->spacing, .zscale = t->zscale,
                                          .propagate_c = desc->propagate_c, .patch_cells = desc->patch_cells,
                                          .holes = t->valid != NULL,
                                          .progress = desc->progress,
                                          .progress_user = desc->progress_user},
                           err);
    if (!t->lod)
        goto fail;
    t->prep_ms = hz_time_ms() - t0;
    return t;
fail:
    hz_grid_free(&g);
    hz_terrain_destroy(t);
    return NULL;
}

void hz_terrain_destroy(hz_terrain *t)
{
    if (!t)
        return;
    hz_lod_destroy(t->lod);
    hz_heightmap_destroy(&t->hm);
    hz_georef_destroy(t->georef);
    free(t->valid);
    free(t);
}

size_t hz_terrain_filter_triangles(const hz_terrain *t, uint32_t *idx, size_t count)
{
    if (!t->valid)
        return count;
    const uint8_t *v = t->valid;
    size_t o = 0;
    for (size_t k = 0; k + 2 < count; k += 3) {
        uint32_t a = idx[k], b = idx[k + 1], c = idx[k + 2];
        if (v[a] && v[b] && v[c]) {
            idx[o++] = a;
            idx[o++] = b;
            idx[o++] = c;
        }
    }
    return o;
}

float hz_terrain_extent(const hz_terrain *t)
{
    return (float)(t->hm.size - 1) * t->spacing;
}

float hz_terrain_height_at(const hz_terrain *t, float x, float z)
{
    float fi = x / t->spacing, fj = z / t->spacing, m = (float)(t->hm.size - 1);
    fi = fi < 0 ? 0 : fi > m ? m : fi;
    fj = fj < 0 ? 0 : fj > m ? m : fj;
    return hz_heightmap_get(&t->hm, (uint32_t)lroundf(fi), (uint32_t)lroundf(fj)) * t->zscale;
}

bool hz_terrain_valid_at(const hz_terrain *t, float x, float z)
{
    const float fi = x / t->spacing, fj = z / t->spacing, m = (float)(t->hm.size - 1);
    if (!(fi >= -0.5f && fj >= -0.5f && fi <= m + 0.5f && fj <= m + 0.5f))
        return false;
    long i = lroundf(fi), j = lroundf(fj);
    i = i < 0 ? 0 : i > (long)m ? (long)m : i;
    j = j < 0 ? 0 : j > (long)m ? (long)m : j;
    return !t->valid || t->valid[(size_t)j * t->hm.size + (size_t)i];
}

float hz_terrain_surface_at(const hz_terrain *t, float x, float z)
{
    const float m = (float)(t->hm.size - 1);
    float fi = x / t->spacing, fj = z / t->spacing;
    fi = fi < 0 ? 0 : fi > m ? m : fi;
    fj = fj < 0 ? 0 : fj > m ? m : fj;
    uint32_t i = (uint32_t)fi, j = (uint32_t)fj;
    if (i >= t->hm.size - 1)
        i = t->hm.size - 2;
    if (j >= t->hm.size - 1)
        j = t->hm.size - 2;
    const float u = fi - (float)i, v = fj - (float)j;
    const float a = hz_heightmap_get(&t->hm, i, j), b = hz_heightmap_get(&t->hm, i, j + 1);
    const float c = hz_heightmap_get(&t->hm, i + 1, j), d = hz_heightmap_get(&t->hm, i + 1, j + 1);
    /* The cell's two triangles (union jack, hz_lod_cell_triangles): along
     * the main diagonal (i, j)-(i+1, j+1) when i + j is even, else along
     * (i, j+1)-(i+1, j). */
    float h;
    if (((i + j) & 1u) == 0)
        h = v <= u ? a + u * (c - a) + v * (d - c) : a + v * (b - a) + u * (d - b);
    else
        h = u + v <= 1.0f ? a + u * (c - a) + v * (b - a) : d + (1.0f - u) * (b - d) + (1.0f - v) * (c - d);
    return h * t->zscale;
}

/* The centre of the DEM's samples (not of the padded map), world metres. */
void hz_terrain_data_centre(const hz_terrain *t, float *x, float *z)
{
    uint32_t w = t->data_w ? t->data_w : t->hm.size, h = t->data_h ? t->data_h : t->hm.size;
    *x = ((float)t->data_x + 0.5f * (float)(w - 1)) * t->spacing;
    *z = ((float)t->data_y + 0.5f * (float)(h - 1)) * t->spacing;
}

void hz_terrain_focus(const hz_terrain *t, float *x, float *z, float *h)
{
    /* The highest real sample (nodata and padding excluded), on a grid of at
     * most ~1024^2 samples: the summit or the crater rim, what a first view
     * of a place should show. */
    const uint32_t n = t->hm.size, step = n > 1024 ? (n + 1023) / 1024 : 1;
    const uint32_t i0 = t->data_w ? t->data_x : 0, j0 = t->data_h ? t->data_y : 0;
    const uint32_t i1 = t->data_w ? t->data_x + t->data_w : n, j1 = t->data_h ? t->data_y + t->data_h : n;
    float best = -INFINITY;
    uint32_t bi = (i0 + i1) / 2, bj = (j0 + j1) / 2;
    for (uint32_t j = j0; j < j1 && j < n; j += step)
        for (uint32_t i = i0; i < i1 && i < n; i += step) {
            if (t->valid && !t->valid[(size_t)j * n + i])
                continue;
            const float v = hz_heightmap_get(&t->hm, i, j);
            if (v > best) {
                best = v;
                bi = i;
                bj = j;
            }
        }
    *x = (float)bi * t->spacing;
    *z = (float)bj * t->spacing;
    *h = (best > -INFINITY ? best : hz_heightmap_get(&t->hm, bi, bj)) * t->zscale;
}

/* The DEM's samples as a world rectangle (x0, z0) - (x1, z1). */
static void data_rect(const hz_terrain *t, float r[4])
{
    uint32_t w = t->data_w ? t->data_w : t->hm.size, h = t->data_h ? t->data_h : t->hm.size;
    r[0] = (float)t->data_x * t->spacing;
    r[1] = (float)t->data_y * t->spacing;
    r[2] = (float)(t->data_x + w - 1) * t->spacing;
    r[3] = (float)(t->data_y + h - 1) * t->spacing;
}

static float ground_of(void *user, float x, float z)
{
    return hz_terrain_height_at(user, x, z);
}

hz_camera hz_terrain_default_camera(const hz_terrain *t, uint32_t width, uint32_t height)
{
    float rect[4], focus[3], centre[2];
    data_rect(t, rect);
    hz_terrain_data_centre(t, &centre[0], &centre[1]);
    hz_terrain_focus(t, &focus[0], &focus[2], &focus[1]);
    return hz_camera_summit_view(rect, centre, focus, (t->max_h - t->min_h) * t->zscale, hz_terrain_extent(t),
                                 ground_of, (void *)t, width, height);
}

/* Highest ground within radius metres of (x, z), sampled on a coarse grid. */
static float max_ground_near(const hz_terrain *t, float x, float z, float radius)
{
    float m = -INFINITY;
    for (int dz = -4; dz <= 4; dz++)
        for (int dx = -4; dx <= 4; dx++)
            m = fmaxf(m, hz_terrain_height_at(t, x + radius * (float)dx / 4.0f, z + radius * (float)dz / 4.0f));
    return m;
}

hz_result hz_terrain_path(const hz_terrain *t, const char *name, hz_path *out, hz_err *err)
{
    enum { MAXK = 160 };
    hz_path_key k[MAXK];
    size_t n = 0;
    /* Over the DEM's samples (the padding of a non-square DEM is not drawn). */
    const uint32_t dmin = t->data_w && t->data_h ? (t->data_w < t->data_h ? t->data_w : t->data_h) : t->hm.size;
    const float E = (float)(dmin - 1) * t->spacing;
    float cx, cz;
    hz_terrain_data_centre(t, &cx, &cz);
    const float relief = (t->max_h - t->min_h) * t->zscale;
    const float duration = 60.0f;
    if (!strcmp(name, "flyover")) {
        /* A fast jet: 300 m/s for 60 s (or the whole diagonal of a smaller
         * map). */
        const float clearance = fmaxf(60.0f, 0.05f * relief);
        const float len = fminf(0.8f * E, 300.0f * duration / sqrtf(2.0f)); /* along x (and z) */
        /* Through the highest ground (hz_terrain_focus), along the diagonal
         * (NW-SE or SW-NE) that crosses more of the DEM there, the segment
         * slid along it to stay inside the DEM's samples. */
        float fx, fz, fh, rect[4];
        hz_terrain_focus(t, &fx, &fz, &fh);
        data_rect(t, rect);
        float lo[2], hi[2];
        for (int d = 0; d < 2; d++) {
            /* x = fx + s, z = fz + s (d = 0) or fz - s (d = 1): the chord s in [lo, hi]. */
            const float zs = d == 0 ? 1.0f : -1.0f;
            const float za = (rect[1] - fz) * zs, zb = (rect[3] - fz) * zs;
            lo[d] = fmaxf(rect[0] - fx, fminf(za, zb));
            hi[d] = fminf(rect[2] - fx, fmaxf(za, zb));
        }
        const int d = hi[1] - lo[1] > hi[0] - lo[0] ? 1 : 0;
        const float zs = d == 0 ? 1.0f : -1.0f;
        const float L = fminf(len, hi[d] - lo[d]);
        const float s0 = glm_clamp(-0.5f * L, lo[d], hi[d] - L);
        const float x0 = fx + s0, x1 = fx + s0 + L, z0 = fz + zs * s0, z1 = fz + zs * (s0 + L);
        const float yaw = glm_deg(atan2f(1.0f, -zs)); /* toward +x, +z or -z */
        for (n = 0; n < 61; n++) {
            float u = (float)n / 60.0f, x = x0 + u * (x1 - x0), z = z0 + u * (z1 - z0);
            k[n] = (hz_path_key){u * duration, x, max_ground_near(t, x, z, 0.03f * E) + clearance, z, yaw, -8.0f};
        }
    } else if (!strcmp(name, "orbit")) {
        const float r = 0.3f * E, y = t->max_h * t->zscale + 0.25f * E;
        const float pitch = -glm_deg(atanf((y - hz_terrain_height_at(t, cx, cz)) / r));
        for (n = 0; n < 73; n++) {
            float a = glm_rad(5.0f * (float)n);
            float x = cx + r * sinf(a), z = cz - r * cosf(a);
            /* look at the centre: direction (cx - x, cz - z) */
            float yaw = glm_deg(atan2f(cx - x, -(cz - z)));
            k[n] = (hz_path_key){duration * (float)n / 72.0f, x, y, z, yaw, pitch};
        }
    } else if (!strcmp(name, "ground")) {
        /* Walk from the centre along the most open of 16 headings (the one
         * whose terrain rises least above the eye within half the map), so the
         * view reaches the horizon instead of a hillside. Keys every 2.5 m; the
         * eye 2 m above the highest point of the full-resolution surface within
         * 4 m, so the spline between keys stays above the ground. */
        const float speed = 5.0f, step = duration * speed / 120.0f;
        const float eye0 = hz_terrain_surface_at(t, cx, cz) + 2.0f;
        float best = INFINITY, best_yaw = 90.0f;
        for (int h = 0; h < 16; h++) {
            const float yaw = 22.5f * (float)h, dx = sinf(glm_rad(yaw)), dz = -cosf(glm_rad(yaw));
            float worst = -INFINITY;
            for (float d = 20.0f; d < 0.5f * E; d *= 1.15f)
                worst = fmaxf(worst, (hz_terrain_surface_at(t, cx + d * dx, cz + d * dz) - eye0) / d);
            if (worst < best) {
                best = worst;
                best_yaw = yaw;
            }
        }
        const float dx = sinf(glm_rad(best_yaw)), dz = -cosf(glm_rad(best_yaw));
        for (n = 0; n < 121; n++) {
            const float x = cx + dx * step * (float)n, z = cz + dz * step * (float)n;
            float g = -INFINITY;
            for (int q = -4; q <= 4; q++)
                for (int r = -4; r <= 4; r++)
                    g = fmaxf(g, hz_terrain_surface_at(t, x + 1.0f * (float)q, z + 1.0f * (float)r));
            k[n] = (hz_path_key){duration * (float)n / 120.0f, x, g + 2.0f, z, best_yaw, 0.0f};
        }
    } else {
        return hz_err_set(err, HZ_ERR_VALUE, "unknown path '%s': use flyover, orbit, ground or a CSV file", name);
    }
    return hz_path_from_keys(k, n, name, out, err);
}
