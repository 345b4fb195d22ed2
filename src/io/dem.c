/* DEM loading: file reading, gzip, format and unit detection, raw layouts
 * (SRTM .hgt, r16, r32), value checks. PNG decoding is in dem_png.c. */
#define _POSIX_C_SOURCE 200809L
#include "io_internal.h"

#include "horizon/safety.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <zlib.h>

/* Decompressed data larger than this is refused (a 16385^2 float grid is 1 GiB). */
#define HZ_IO_MAX_GUNZIP ((size_t)4 << 30)
/* Heights beyond this are not elevations on Earth (or a sane planet). */
#define HZ_IO_MAX_ABS_HEIGHT 100000.0
#define HZ_PI 3.14159265358979323846

void hz_io_progress_step(hz_io_progress *p, uint64_t done)
{
    if (!p || !p->fn || p->total == 0)
        return;
    int pct = (int)(done * 100 / p->total);
    if (pct > 100)
        pct = 100;
    if (pct == p->last_pct)
        return;
    p->last_pct = pct;
    p->fn(p->user, p->label, pct == 100 ? p->total : done, p->total);
}

/* ---- names ---- */

const char *hz_dem_format_name(hz_dem_format f)
{
    switch (f) {
    case HZ_DEM_AUTO: return "auto";
    case HZ_DEM_PNG: return "png";
    case HZ_DEM_TERRARIUM: return "terrarium";
    case HZ_DEM_HGT: return "hgt";
    case HZ_DEM_R16: return "r16";
    case HZ_DEM_R32: return "r32";
    case HZ_DEM_GDAL: return "gdal";
    }
    return "unknown";
}

bool hz_dem_format_parse(const char *s, hz_dem_format *out)
{
    static const hz_dem_format all[] = {HZ_DEM_AUTO, HZ_DEM_PNG, HZ_DEM_TERRARIUM, HZ_DEM_HGT, HZ_DEM_R16, HZ_DEM_R32, HZ_DEM_GDAL};
    if (!s)
        return false;
    for (size_t k = 0; k < sizeof all / sizeof *all; k++) {
        if (!strcmp(s, hz_dem_format_name(all[k]))) {
            if (out)
                *out = all[k];
            return true;
        }
    }
    return false;
}

static double units_factor(hz_dem_units u)
{
    switch (u) {
    case HZ_UNITS_FT: return 0.3048;
    case HZ_UNITS_DM: return 0.1;
    default: return 1.0;
    }
}

/* A GDAL band unit string ("m", "metre", "ft", "US survey foot", "dm"...). */
static hz_dem_units units_from_string(const char *u)
{
    char b[64];
    size_t n = 0;
    for (; u[n] && n + 1 < sizeof b; n++)
        b[n] = (char)tolower((unsigned char)u[n]);
    b[n] = 0;
    if (!strcmp(b, "ft") || !strcmp(b, "foot") || !strcmp(b, "feet") || strstr(b, "us survey foot") ||
        !strcmp(b, "us-ft") || !strcmp(b, "international foot"))
        return HZ_UNITS_FT;
    if (!strcmp(b, "dm") || !strcmp(b, "decimetre") || !strcmp(b, "decimeter"))
        return HZ_UNITS_DM;
    if (!strcmp(b, "m") || !strcmp(b, "metre") || !strcmp(b, "meter") || !strcmp(b, "metres") ||
        !strcmp(b, "meters"))
        return HZ_UNITS_M;
    return HZ_UNITS_AUTO;
}

/* ---- file reading ---- */

typedef struct buf {
    uint8_t *data;
    size_t size;
} buf;

static hz_result read_file(const char *path, buf *out, hz_err *err)
{
    out->data = NULL;
    out->size = 0;
    FILE *f = fopen(path, "rb");
    if (!f)
        return hz_err_set(err, HZ_ERR_IO, "cannot open '%s': %s", path, strerror(errno));
    struct stat st;
    if (fstat(fileno(f), &st) != 0) {
        int e = errno;
        fclose(f);
        return hz_err_set(err, HZ_ERR_IO, "cannot read '%s': %s", path, strerror(e));
    }
    if (S_ISDIR(st.st_mode)) {
        fclose(f);
        return hz_err_set(err, HZ_ERR_IO, "cannot read '%s': it is a directory", path);
    }
    if (!S_ISREG(st.st_mode)) {
        fclose(f);
        return hz_err_set(err, HZ_ERR_IO, "cannot read '%s': not a regular file", path);
    }
    if (st.st_size == 0) {
        fclose(f);
        return hz_err_set(err, HZ_ERR_FORMAT, "'%s' is empty (0 bytes)", path);
    }
    size_t n = (size_t)st.st_size;
    out->data = malloc(n);
    if (!out->data) {
        fclose(f);
        return hz_err_set(err, HZ_ERR_MEMORY, "cannot read '%s': out of memory for %zu bytes", path, n);
    }
    size_t got = fread(out->data, 1, n, f);
    int e = ferror(f) ? errno : 0;
    fclose(f);
    if (got != n) {
        free(out->data);
        out->data = NULL;
        if (e)
            return hz_err_set(err, HZ_ERR_IO, "cannot read '%s': %s", path, strerror(e));
        return hz_err_set(err, HZ_ERR_IO, "short read on '%s': got %zu of %zu bytes (file changed?)", path, got, n);
    }
    out->size = n;
    return HZ_OK;
}

static hz_result gunzip(const char *path, const buf *in, buf *out, uint64_t budget, hz_io_progress *prog,
                        hz_err *err)
{
    out->data = NULL;
    out->size = 0;
    if (in->size < 2 || in->data[0] != 0x1f || in->data[1] != 0x8b)
        return hz_err_set(err, HZ_ERR_FORMAT,
                          "'%s' is not a gzip file: the name ends in .gz but the data does not start "
                          "with the gzip magic bytes 1f 8b",
                          path);
    if (in->size < 18)
        return hz_err_set(err, HZ_ERR_FORMAT, "'%s': truncated gzip file (%zu bytes, a gzip stream needs at least 18)",
                          path, in->size);
    /* The trailer's ISIZE (size mod 2^32) is only a hint: never trust it for
     * more than deflate's ~1032:1 ratio allows. */
    const uint8_t *t = in->data + in->size - 4;
    size_t isize = (size_t)t[0] | (size_t)t[1] << 8 | (size_t)t[2] << 16 | (size_t)t[3] << 24;
    size_t cap = in->size < HZ_IO_MAX_GUNZIP / 1100 ? in->size * 1100 : HZ_IO_MAX_GUNZIP;
    /* The decompressed data is sized by the input: within the memory budget. */
    const uint64_t mem = budget ? budget : hz_mem_budget_default();
    const bool budget_cap = cap > mem;
    if (budget_cap)
        cap = (size_t)mem;
    size_t alloc = isize > 0 && isize <= cap ? isize : in->size * 4;
    if (alloc > cap)
        alloc = cap;
    if (alloc < 4096)
        alloc = 4096;
    z_stream zs;
    memset(&zs, 0, sizeof zs);
    if (inflateInit2(&zs, 16 + MAX_WBITS) != Z_OK)
        return hz_err_set(err, HZ_ERR_MEMORY, "'%s': cannot initialise zlib", path);
    hz_result r = HZ_OK;
    uint8_t *o = malloc(alloc);
    size_t out_len = 0;
    if (!o) {
        r = hz_err_set(err, HZ_ERR_MEMORY, "'%s': out of memory for %zu decompressed bytes", path, alloc);
        goto done;
    }
    if (in->size > UINT32_MAX) {
        r = hz_err_set(err, HZ_ERR_UNSUPPORTED, "'%s': compressed files over 4 GiB are not supported", path);
        goto done;
    }
    zs.next_in = in->data;
    zs.avail_in = (uInt)in->size;
    prog->total = in->size;
    for (;;) {
        if (out_len == alloc) {
            if (alloc >= cap && budget_cap) {
                char what[600];
                snprintf(what, sizeof what, "'%s': decompressing", path);
                r = hz_mem_check((uint64_t)cap + 1, mem, what, err);
                goto done;
            }
            if (alloc >= cap) {
                r = hz_err_set(err, HZ_ERR_FORMAT,
                               "'%s' decompresses to more than %zu bytes: too large for a DEM, refused", path, cap);
                goto done;
            }
            size_t na = alloc > cap / 2 ? cap : alloc * 2;
            uint8_t *no = realloc(o, na);
            if (!no) {
                r = hz_err_set(err, HZ_ERR_MEMORY, "'%s': out of memory for %zu decompressed bytes", path, na);
                goto done;
            }
            o = no;
            alloc = na;
        }
        /* 1 MB at a time so progress can be reported. */
        size_t room = alloc - out_len < (1u << 20) ? alloc - out_len : (1u << 20);
        zs.next_out = o + out_len;
        zs.avail_out = (uInt)room;
        int zr = inflate(&zs, Z_NO_FLUSH);
        out_len += room - zs.avail_out;
        hz_io_progress_step(prog, in->size - zs.avail_in);
        if (zr == Z_STREAM_END) {
            if (zs.avail_in == 0)
                break;
            /* Another gzip member may follow (concatenated .gz files). */
            if (zs.avail_in >= 2 && zs.next_in[0] == 0x1f && zs.next_in[1] == 0x8b) {
                inflateReset(&zs);
                continue;
            }
            bool zeros = true; /* tape-style zero padding is harmless */
            for (uInt k = 0; k < zs.avail_in && zeros; k++)
                zeros = zs.next_in[k] == 0;
            if (!zeros) {
                r = hz_err_set(err, HZ_ERR_FORMAT, "'%s': %u bytes of trailing garbage after the gzip data", path,
                               zs.avail_in);
                goto done;
            }
            break;
        }
        if (zr == Z_OK)
            continue;
        if (zr == Z_BUF_ERROR) {
            if (zs.avail_in == 0) {
                r = hz_err_set(err, HZ_ERR_FORMAT,
                               "'%s': truncated gzip file: the compressed data ends early "
                               "(%zu bytes decompressed so far)",
                               path, out_len);
                goto done;
            }
            continue; /* output full: grown at the top of the loop */
        }
        if (zr == Z_MEM_ERROR) {
            r = hz_err_set(err, HZ_ERR_MEMORY, "'%s': out of memory in zlib", path);
            goto done;
        }
        r = hz_err_set(err, HZ_ERR_FORMAT, "'%s': corrupt gzip data (%s)", path, zs.msg ? zs.msg : "zlib error");
        goto done;
    }
    if (out_len == 0) {
        r = hz_err_set(err, HZ_ERR_FORMAT, "'%s' decompresses to 0 bytes", path);
        goto done;
    }
    out->data = o;
    out->size = out_len;
    o = NULL;
done:
    inflateEnd(&zs);
    free(o);
    return r;
}

/* ---- name analysis ---- */

typedef struct name_info {
    char base[256];  /* lower-case file name without directories and ".gz" */
    const char *ext; /* points into base, after the last '.', or "" */
    bool gz;
} name_info;

static void analyse_name(const char *path, name_info *ni)
{
    const char *s = strrchr(path, '/');
    s = s ? s + 1 : path;
    size_t n = strlen(s);
    if (n >= sizeof ni->base)
        n = sizeof ni->base - 1;
    for (size_t k = 0; k < n; k++)
        ni->base[k] = (char)tolower((unsigned char)s[k]);
    ni->base[n] = 0;
    ni->gz = n > 3 && !strcmp(ni->base + n - 3, ".gz");
    if (ni->gz)
        ni->base[n - 3] = 0;
    const char *dot = strrchr(ni->base, '.');
    ni->ext = dot ? dot + 1 : "";
}

/* "_<number>m" followed by a non-alphanumeric character or the end: metres per sample. */
static float name_metres(const char *b)
{
    for (const char *p = strchr(b, '_'); p; p = strchr(p + 1, '_')) {
        const char *q = p + 1;
        if (!isdigit((unsigned char)*q))
            continue;
        char *end;
        double v = strtod(q, &end);
        if (*end == 'm' && !isalnum((unsigned char)end[1]) && v > 0.0 && v <= 10000.0)
            return (float)v;
    }
    return 0.0f;
}

/* word occurs in b and is not followed by a digit ("srtm3" but not "srtm30"). */
static bool has_token(const char *b, const char *word)
{
    size_t n = strlen(word);
    for (const char *p = strstr(b, word); p; p = strstr(p + 1, word))
        if (!isdigit((unsigned char)p[n]))
            return true;
    return false;
}

static float spacing_hint(const name_info *ni, hz_dem_format f, uint32_t w, uint32_t h)
{
    const char *b = ni->base;
    if (has_token(b, "_3as") || has_token(b, "srtm3") || has_token(b, "3arcsec"))
        return 90.0f;
    if (has_token(b, "_1as") || has_token(b, "srtm1") || has_token(b, "1arcsec"))
        return 30.0f;
    float m = name_metres(b);
    if (m > 0.0f)
        return m;
    if (f == HZ_DEM_HGT && w == h) {
        if (w == 1201)
            return 90.0f;
        if (w == 3601)
            return 30.0f;
    }
    if (f == HZ_DEM_TERRARIUM && w == h) {
        /* Web-mercator tile "z<Z>_x<X>_y<Y>": ground size of a pixel at the tile centre. */
        const char *p = strstr(b, "_z");
        unsigned z, x, y;
        if (p && sscanf(p, "_z%u_x%u_y%u", &z, &x, &y) == 3 && z <= 24 && y < (1u << z)) {
            double nt = (double)(1u << z);
            double lat = atan(sinh(HZ_PI * (1.0 - 2.0 * ((double)y + 0.5) / nt)));
            return (float)(2.0 * HZ_PI * 6378137.0 * cos(lat) / (nt * (double)w));
        }
    }
    return 0.0f;
}

static hz_result unknown_format(const char *path, const name_info *ni, hz_err *err)
{
    if (!strcmp(ni->ext, "tif") || !strcmp(ni->ext, "tiff"))
        return hz_err_set(err, HZ_ERR_FORMAT,
                          "'%s' is not a TIFF file (GDAL does not recognise its header): corrupt, or not a GeoTIFF",
                          path);
    if (!strcmp(ni->ext, "zip"))
        return hz_err_set(err, HZ_ERR_FORMAT, "'%s': not a zip archive holding a raster GDAL can read (truncated or corrupt?)", path);
    if (!strcmp(ni->ext, "raw"))
        return hz_err_set(err, HZ_ERR_FORMAT,
                          "'%s': cannot tell the sample type of a .raw file from its name; "
                          "pass --format r16 (uint16 LE), r32 (float32 LE) or hgt (int16 big-endian)",
                          path);
    return hz_err_set(err, HZ_ERR_FORMAT,
                      "'%s': unknown DEM format (extension '.%s'): GDAL does not recognise it (GeoTIFF, SRTM .hgt/.hgt.zip, "
                      "ENVI .hdr, ASCII grid, VRT ...), and ours are .png (16/8-bit grey, Terrarium RGB), "
                      ".hgt, .r16, .r32, *int16be*.raw, each optionally .gz; "
                      "or pass --format png|terrarium|hgt|r16|r32",
                      path, ni->ext);
}

/* ---- raw layouts ---- */

static uint64_t isqrt64(uint64_t n)
{
    uint64_t r = (uint64_t)sqrt((double)n);
    while (r * r > n)
        r--;
    while ((r + 1) * (r + 1) <= n)
        r++;
    return r;
}

/* Works out width x height of a raw file of size bytes with bps bytes per sample. */
static hz_result raw_shape(const char *path, hz_dem_format f, size_t size, uint32_t bps, uint32_t dw, uint32_t dh,
                           uint32_t *w, uint32_t *h, hz_err *err)
{
    const char *fname = hz_dem_format_name(f);
    if (dw == 0 && dh != 0)
        dw = dh;
    if (dw != 0) {
        if (dh == 0)
            dh = dw;
        if (dw > HZ_IO_MAX_SIDE || dh > HZ_IO_MAX_SIDE)
            return hz_err_set(err, HZ_ERR_VALUE, "'%s': size %ux%u exceeds the limit of %u per side", path, dw, dh,
                              HZ_IO_MAX_SIDE);
        uint64_t want = (uint64_t)dw * dh * bps;
        if (want != size)
            return hz_err_set(err, HZ_ERR_FORMAT,
                              "'%s': expected %llu bytes for a %ux%u %s grid (%u bytes per sample), got %zu: "
                              "the file is %s or the size (--raw-size) is wrong",
                              path, (unsigned long long)want, dw, dh, fname, bps, size,
                              size < want ? "truncated" : "too long");
        *w = dw;
        *h = dh;
        return HZ_OK;
    }
    if (size % bps)
        return hz_err_set(err, HZ_ERR_FORMAT,
                          "'%s': %zu bytes is not a whole number of %u-byte %s samples: truncated or not a %s file",
                          path, size, bps, fname, fname);
    uint64_t n = size / bps, s = isqrt64(n);
    if (s * s != n) {
        if (f == HZ_DEM_HGT)
            return hz_err_set(err, HZ_ERR_FORMAT,
                              "'%s': %zu bytes is not a square SRTM tile (side = sqrt(bytes/2) = %.1f is not whole; "
                              "a 1201x1201 tile has 2884802 bytes, 3601x3601 has 25934402): truncated or not .hgt",
                              path, size, sqrt((double)n));
        return hz_err_set(err, HZ_ERR_FORMAT,
                          "'%s': %zu bytes = %llu samples is not a square grid (sqrt = %.1f): "
                          "the file is truncated, or pass its size with --raw-size WxH",
                          path, size, (unsigned long long)n, sqrt((double)n));
    }
    if (s < 2 || s > HZ_IO_MAX_SIDE)
        return hz_err_set(err, HZ_ERR_FORMAT, "'%s': %zu bytes gives a %llux%llu grid; sides must be 2..%u", path,
                          size, (unsigned long long)s, (unsigned long long)s, HZ_IO_MAX_SIDE);
    *w = *h = (uint32_t)s;
    return HZ_OK;
}

static hz_result decode_raw(const char *path, hz_dem_format f, const buf *b, const hz_dem_desc *d, hz_grid *g,
                            hz_err *err)
{
    uint32_t bps = f == HZ_DEM_R32 ? 4 : 2, w = 0, h = 0;
    hz_result r = raw_shape(path, f, b->size, bps, d->width, d->height, &w, &h, err);
    if (r != HZ_OK)
        return r;
    char what[600];
    snprintf(what, sizeof what, "'%s': a %ux%u grid", path, w, h);
    if ((r = hz_mem_check((uint64_t)w * h * sizeof(float), d->max_memory, what, err)) != HZ_OK)
        return r;
    if ((r = hz_grid_alloc(g, w, h, err)) != HZ_OK)
        return r;
    size_t n = (size_t)w * h;
    const uint8_t *p = b->data;
    if (f == HZ_DEM_HGT) {
        for (size_t k = 0; k < n; k++) {
            int16_t v = (int16_t)(uint16_t)((p[2 * k] << 8) | p[2 * k + 1]);
            g->z[k] = v == INT16_MIN ? NAN : (float)v;
        }
    } else if (f == HZ_DEM_R16) {
        for (size_t k = 0; k < n; k++)
            g->z[k] = (float)(uint16_t)(p[2 * k] | (p[2 * k + 1] << 8));
    } else {
        for (size_t k = 0; k < n; k++) {
            uint32_t u = (uint32_t)p[4 * k] | (uint32_t)p[4 * k + 1] << 8 | (uint32_t)p[4 * k + 2] << 16 |
                         (uint32_t)p[4 * k + 3] << 24;
            float v;
            memcpy(&v, &u, sizeof v);
            g->z[k] = v;
        }
    }
    return HZ_OK;
}

/* Applies units, counts voids (NaN), refuses inf and absurd heights. */
static hz_result finish_values(const char *path, hz_grid *g, double factor, uint64_t *voids, hz_err *err)
{
    size_t n = (size_t)g->width * g->height;
    uint64_t nv = 0;
    for (size_t k = 0; k < n; k++) {
        float v = g->z[k];
        if (isnan(v)) {
            nv++;
            continue;
        }
        double m = (double)v * factor;
        if (isinf(v) || fabs(m) > HZ_IO_MAX_ABS_HEIGHT) {
            size_t i = k % g->width, j = k / g->width;
            if (isinf(v))
                return hz_err_set(err, HZ_ERR_VALUE,
                                  "'%s': sample (column %zu, row %zu) is %cinf: heights must be finite "
                                  "(NaN marks a void)",
                                  path, i, j, v > 0 ? '+' : '-');
            return hz_err_set(err, HZ_ERR_VALUE,
                              "'%s': sample (column %zu, row %zu) = %g m is not a plausible elevation "
                              "(|h| > %g m); wrong format or units? If it marks no-data, store NaN instead",
                              path, i, j, m, HZ_IO_MAX_ABS_HEIGHT);
        }
        g->z[k] = (float)m;
    }
    *voids = nv;
    return HZ_OK;
}

hz_result hz_dem_load(const hz_dem_desc *desc, hz_grid *out, hz_dem_info *info, hz_err *err)
{
    HZ_ASSERT(desc && out);
    out->z = NULL;
    out->width = out->height = 0;
    if ((!desc->path || !desc->path[0]) && desc->path_count == 0)
        return hz_err_set(err, HZ_ERR_VALUE, "no DEM file given");
    if ((unsigned)desc->format > HZ_DEM_GDAL)
        return hz_err_set(err, HZ_ERR_VALUE, "'%s': invalid format value %d", desc->path, (int)desc->format);
    if ((unsigned)desc->units > HZ_UNITS_RAW)
        return hz_err_set(err, HZ_ERR_VALUE, "'%s': invalid units value %d", desc->path, (int)desc->units);
    if (desc->georef)
        *desc->georef = NULL;
    const char *path = desc->path && desc->path_count == 0 ? desc->path : "mosaic";
    name_info ni;
    analyse_name(path, &ni);
    if (info)
        memset(info, 0, sizeof *info);

    if (desc->path_count > 0 || desc->format == HZ_DEM_GDAL ||
        (desc->format == HZ_DEM_AUTO && hz_io_gdal_wants(path))) {
        hz_dem_info gi;
        memset(&gi, 0, sizeof gi);
        char band_units[64];
        hz_result r = hz_io_gdal_load(desc, out, &gi, band_units, sizeof band_units, err);
        if (r != HZ_OK)
            return r;
        hz_dem_units units = desc->units;
        if (units == HZ_UNITS_AUTO)
            units = units_from_string(band_units);
        if (units == HZ_UNITS_AUTO)
            units = strstr(ni.base, "_ft16") ? HZ_UNITS_FT : strstr(ni.base, "_dm16") ? HZ_UNITS_DM : HZ_UNITS_M;
        uint64_t voids = 0;
        r = finish_values(desc->path_count > 0 ? "mosaic" : path, out, units_factor(units), &voids, err);
        if (r != HZ_OK) {
            hz_grid_free(out);
            if (desc->georef) {
                hz_georef_destroy(*desc->georef);
                *desc->georef = NULL;
            }
            return r;
        }
        gi.units = units;
        gi.voids = voids;
        /* An SRTM tile keeps its name: it is the same data as our own .hgt reader gives. */
        gi.format = !strcmp(gi.driver, "SRTMHGT") ? HZ_DEM_HGT : HZ_DEM_GDAL;
        if (gi.spacing_hint <= 0)
            gi.spacing_hint = spacing_hint(&ni, gi.format, out->width, out->height);
        if (info)
            *info = gi;
        return HZ_OK;
    }

    buf file = {0}, data = {0};
    hz_result r = read_file(path, &file, err);
    if (r != HZ_OK)
        return r;
    if (ni.gz) {
        hz_io_progress prog = {desc->progress, desc->progress_user, "decompress", 0, -1};
        r = gunzip(path, &file, &data, desc->max_memory, &prog, err);
        free(file.data);
        if (r != HZ_OK)
            return r;
    } else {
        data = file;
    }

    hz_dem_format f = desc->format;
    if (f == HZ_DEM_AUTO) {
        const char *e = ni.ext;
        if (!strcmp(e, "png"))
            f = HZ_DEM_PNG;
        else if (!strcmp(e, "hgt"))
            f = HZ_DEM_HGT;
        else if (!strcmp(e, "r16"))
            f = HZ_DEM_R16;
        else if (!strcmp(e, "r32"))
            f = HZ_DEM_R32;
        else if (!strcmp(e, "raw") && strstr(ni.base, "int16be"))
            f = HZ_DEM_HGT;
        else if (!strcmp(e, "raw") && (strstr(ni.base, "float32le") || strstr(ni.base, "f32le")))
            f = HZ_DEM_R32;
        else if (!strcmp(e, "raw") && (strstr(ni.base, "uint16le") || strstr(ni.base, "u16le")))
            f = HZ_DEM_R16;
        else if (data.size >= 8 && !memcmp(data.data, "\x89PNG\r\n\x1a\n", 8))
            f = HZ_DEM_PNG; /* content wins over an unknown extension */
        else {
            free(data.data);
            return unknown_format(path, &ni, err);
        }
    }

    hz_dem_units units = desc->units;
    uint32_t png_bits = 16;
    bool name_terrarium = strstr(ni.base, "terrarium") != NULL;
    if ((f == HZ_DEM_PNG || f == HZ_DEM_TERRARIUM) && data.size >= 24 && !memcmp(data.data + 12, "IHDR", 4)) {
        /* The grid the header asks for (decoded as floats) and, for an
         * interlaced image, the whole decoded image too: before decoding. */
        const uint8_t *p = data.data + 16;
        uint64_t pw = (uint64_t)p[0] << 24 | (uint64_t)p[1] << 16 | (uint64_t)p[2] << 8 | p[3];
        uint64_t ph = (uint64_t)p[4] << 24 | (uint64_t)p[5] << 16 | (uint64_t)p[6] << 8 | p[7];
        uint64_t px_bytes = sizeof(float);
        if (data.size >= 29 && data.data[28] != 0) {
            static const uint8_t channels[7] = {1, 0, 3, 1, 2, 0, 4};
            uint64_t ch = data.data[25] < 7 && channels[data.data[25]] ? channels[data.data[25]] : 4;
            px_bytes += ch * (data.data[24] > 8 ? 2 : 1);
        }
        char what[600];
        snprintf(what, sizeof what, "'%s': a %llux%llu grid", path, (unsigned long long)pw, (unsigned long long)ph);
        if (pw <= HZ_IO_MAX_SIDE && ph <= HZ_IO_MAX_SIDE &&
            (r = hz_mem_check(pw * ph * px_bytes, desc->max_memory, what, err)) != HZ_OK) {
            free(data.data);
            return r;
        }
    }
    if (f == HZ_DEM_PNG || f == HZ_DEM_TERRARIUM) {
        hz_io_progress prog = {desc->progress, desc->progress_user, "decode png", 0, -1};
        hz_png_result pr;
        r = hz_io_png_decode(path, data.data, data.size, desc->format, name_terrarium, &prog, out, &pr, err);
        free(data.data);
        if (r != HZ_OK)
            return r;
        f = pr.terrarium ? HZ_DEM_TERRARIUM : HZ_DEM_PNG;
        png_bits = pr.bit_depth;
    } else {
        r = decode_raw(path, f, &data, desc, out, err);
        free(data.data);
        if (r != HZ_OK)
            return r;
    }
    if (units == HZ_UNITS_AUTO) {
        if (f != HZ_DEM_TERRARIUM && strstr(ni.base, "_ft16"))
            units = HZ_UNITS_FT;
        else if (f != HZ_DEM_TERRARIUM && strstr(ni.base, "_dm16"))
            units = HZ_UNITS_DM;
        else
            units = HZ_UNITS_M;
    }
    uint64_t voids = 0;
    r = finish_values(path, out, units_factor(units), &voids, err);
    if (r != HZ_OK) {
        hz_grid_free(out);
        return r;
    }
    if (info) {
        info->format = f;
        info->units = units;
        info->voids = voids;
        info->spacing_hint = spacing_hint(&ni, f, out->width, out->height);
        info->files = 1;
        info->file_width = out->width;
        info->file_height = out->height;
        info->file_voids = voids;
        info->full_scale = f == HZ_DEM_TERRARIUM ? 0.0
                           : f == HZ_DEM_PNG     ? (png_bits == 8 ? 255.0 : 65535.0)
                           : f == HZ_DEM_R16     ? 65535.0
                           : f == HZ_DEM_HGT     ? 32767.0
                                                 : 1.0;
    }
    return HZ_OK;
}
