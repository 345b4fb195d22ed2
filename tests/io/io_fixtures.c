#include "io_fixtures.h"

#include <math.h>
#include <png.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

uint64_t fx_rand(uint64_t *s)
{
    uint64_t z = (*s += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

const char *fx_tmp(const char *name)
{
    static char bufs[8][1024];
    static int next;
    char *b = bufs[next++ & 7];
    snprintf(b, sizeof bufs[0], "%s/%s", HZ_TEST_TMP, name);
    return b;
}

bool fx_write(const char *path, const void *data, size_t n)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return false;
    bool ok = fwrite(data, 1, n, f) == n;
    return fclose(f) == 0 && ok;
}

uint8_t *fx_read(const char *path, size_t *n)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    long sz = ftell(f);
    fseek(f, 0, SEEK_SET);
    uint8_t *d = malloc(sz > 0 ? (size_t)sz : 1);
    *n = d ? fread(d, 1, (size_t)sz, f) : 0;
    fclose(f);
    return d;
}

bool fx_write_gz(const char *path, const void *data, size_t n)
{
    gzFile g = gzopen(path, "wb9");
    if (!g)
        return false;
    bool ok = gzwrite(g, data, (unsigned)n) == (int)n;
    return gzclose(g) == Z_OK && ok;
}

static bool png_common(const char *path, uint32_t w, uint32_t h, int depth, int ctype, bool interlace,
                       const uint8_t *pal_rgb, int pal_n, const uint8_t *rows_data, size_t rowbytes)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return false;
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
    png_infop info = png_create_info_struct(png);
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        fclose(f);
        return false;
    }
    png_init_io(png, f);
    png_set_IHDR(png, info, w, h, depth, ctype, interlace ? PNG_INTERLACE_ADAM7 : PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    if (pal_rgb) {
        png_color pal[256];
        for (int k = 0; k < pal_n; k++)
            pal[k] = (png_color){pal_rgb[3 * k], pal_rgb[3 * k + 1], pal_rgb[3 * k + 2]};
        png_set_PLTE(png, info, pal, pal_n);
    }
    png_write_info(png, info);
    png_bytep *rows = malloc(h * sizeof *rows);
    for (uint32_t y = 0; y < h; y++)
        rows[y] = (png_bytep)(rows_data + y * rowbytes);
    png_write_image(png, rows);
    png_write_end(png, NULL);
    free(rows);
    png_destroy_write_struct(&png, &info);
    return fclose(f) == 0;
}

bool fx_write_png(const char *path, uint32_t w, uint32_t h, int depth, int color_type, bool interlace,
                  const uint16_t *samples)
{
    int ch = color_type == PNG_COLOR_TYPE_GRAY         ? 1
             : color_type == PNG_COLOR_TYPE_GRAY_ALPHA ? 2
             : color_type == PNG_COLOR_TYPE_RGB        ? 3
                                                       : 4;
    size_t rowbytes = (size_t)w * (size_t)ch * (depth == 16 ? 2 : 1);
    uint8_t *d = malloc(rowbytes * h);
    for (size_t k = 0; k < (size_t)w * h * (size_t)ch; k++) {
        if (depth == 16) {
            d[2 * k] = (uint8_t)(samples[k] >> 8); /* big-endian */
            d[2 * k + 1] = (uint8_t)samples[k];
        } else {
            d[k] = (uint8_t)samples[k];
        }
    }
    bool ok = png_common(path, w, h, depth, color_type, interlace, NULL, 0, d, rowbytes);
    free(d);
    return ok;
}

bool fx_write_png_palette(const char *path, uint32_t w, uint32_t h, int depth, const uint8_t *indices,
                          const uint8_t *rgb, int n)
{
    size_t rowbytes = ((size_t)w * (size_t)depth + 7) / 8;
    uint8_t *d = calloc(rowbytes * h, 1);
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            size_t bit = (size_t)x * (size_t)depth;
            uint8_t v = indices[(size_t)y * w + x];
            d[y * rowbytes + bit / 8] |= (uint8_t)(v << (8 - depth - (int)(bit % 8)));
        }
    bool ok = png_common(path, w, h, depth, PNG_COLOR_TYPE_PALETTE, false, rgb, n, d, rowbytes);
    free(d);
    return ok;
}

void fx_terrarium(float h, uint8_t rgb[3])
{
    double v = (double)h + 32768.0;
    int r = (int)(v / 256.0);
    int g = (int)(v - r * 256.0);
    int b = (int)((v - r * 256.0 - g) * 256.0);
    rgb[0] = (uint8_t)r;
    rgb[1] = (uint8_t)g;
    rgb[2] = (uint8_t)b;
}

/* ---- the case set ---- */

static fx_case *add(fx_case *c, size_t *n, const char *name, hz_dem_format want, uint32_t w, uint32_t h,
                    float tol)
{
    fx_case *k = &c[(*n)++];
    memset(k, 0, sizeof *k);
    k->name = name;
    k->want = want;
    k->w = w;
    k->h = h;
    k->tol = tol;
    k->z = malloc((size_t)w * h * sizeof(float));
    return k;
}

static void put_be16(uint8_t *p, int v)
{
    p[0] = (uint8_t)((unsigned)v >> 8);
    p[1] = (uint8_t)v;
}

size_t fx_make_cases(fx_case **out)
{
    fx_case *c = calloc(32, sizeof *c);
    size_t n = 0;
    uint64_t s = 12345;
    hz_err err;

    { /* 16-bit grey written by hz_dem_write_png16 with lo=0, hi=65535: identity */
        fx_case *k = add(c, &n, "rt_png16.png", HZ_DEM_PNG, 33, 21, 0.0f);
        hz_grid g = {k->w, k->h, k->z};
        for (size_t i = 0; i < (size_t)k->w * k->h; i++)
            k->z[i] = (float)(fx_rand(&s) % 65536);
        k->z[0] = 0.0f;
        k->z[1] = 65535.0f;
        if (hz_dem_write_png16(fx_tmp(k->name), &g, 0.0f, 65535.0f, &err) != HZ_OK)
            fprintf(stderr, "write png16: %s\n", err.msg);
        uint8_t *b;
        size_t bn = 0;
        b = fx_read(fx_tmp(k->name), &bn);
        fx_write_gz(fx_tmp("rt_png16.png.gz"), b, bn);
        free(b);
        fx_case *kz = add(c, &n, "rt_png16.png.gz", HZ_DEM_PNG, 33, 21, 0.0f);
        memcpy(kz->z, k->z, (size_t)k->w * k->h * sizeof(float));
    }
    { /* decimetres and feet by name */
        static const char *names[2] = {"rt_sthelens_10m_dm16.png", "rt_everest_3as_ft16.png"};
        static const double f[2] = {0.1, 0.3048};
        for (int u = 0; u < 2; u++) {
            fx_case *k = add(c, &n, names[u], HZ_DEM_PNG, 19, 26, 1e-3f);
            uint16_t *smp = malloc((size_t)k->w * k->h * 2);
            for (size_t i = 0; i < (size_t)k->w * k->h; i++) {
                smp[i] = (uint16_t)(5000 + fx_rand(&s) % 25000);
                k->z[i] = (float)((double)smp[i] * f[u]);
            }
            fx_write_png(fx_tmp(k->name), k->w, k->h, 16, PNG_COLOR_TYPE_GRAY, false, smp);
            free(smp);
        }
    }
    { /* 8-bit grey, grey+alpha 16-bit, interlaced 16-bit */
        fx_case *k = add(c, &n, "rt_grey8.png", HZ_DEM_PNG, 29, 17, 0.0f);
        uint16_t *smp = malloc((size_t)k->w * k->h * 2 * 2);
        for (size_t i = 0; i < (size_t)k->w * k->h; i++) {
            smp[i] = (uint16_t)(fx_rand(&s) % 256);
            k->z[i] = smp[i];
        }
        fx_write_png(fx_tmp(k->name), k->w, k->h, 8, PNG_COLOR_TYPE_GRAY, false, smp);
        k = add(c, &n, "rt_grey_alpha16.png", HZ_DEM_PNG, 23, 14, 0.0f);
        for (size_t i = 0; i < (size_t)k->w * k->h; i++) {
            smp[2 * i] = (uint16_t)(fx_rand(&s) % 65536);
            smp[2 * i + 1] = (uint16_t)(fx_rand(&s) % 65536); /* alpha: ignored */
            k->z[i] = smp[2 * i];
        }
        fx_write_png(fx_tmp(k->name), k->w, k->h, 16, PNG_COLOR_TYPE_GRAY_ALPHA, false, smp);
        k = add(c, &n, "rt_interlaced16.png", HZ_DEM_PNG, 27, 19, 0.0f);
        for (size_t i = 0; i < (size_t)k->w * k->h; i++) {
            smp[i] = (uint16_t)(fx_rand(&s) % 65536);
            k->z[i] = smp[i];
        }
        fx_write_png(fx_tmp(k->name), k->w, k->h, 16, PNG_COLOR_TYPE_GRAY, true, smp);
        free(smp);
    }
    { /* grey palettes, 8-bit and 4-bit, with a non-identity index -> level map */
        uint8_t pal[256 * 3];
        for (int i = 0; i < 256; i++)
            pal[3 * i] = pal[3 * i + 1] = pal[3 * i + 2] = (uint8_t)((i * 37 + 11) & 255);
        fx_case *k = add(c, &n, "rt_palette8.png", HZ_DEM_PNG, 31, 22, 0.0f);
        uint8_t *idx = malloc((size_t)k->w * k->h);
        for (size_t i = 0; i < (size_t)k->w * k->h; i++) {
            idx[i] = (uint8_t)(fx_rand(&s) % 256);
            k->z[i] = pal[3 * idx[i]];
        }
        fx_write_png_palette(fx_tmp(k->name), k->w, k->h, 8, idx, pal, 256);
        k = add(c, &n, "rt_palette4.png", HZ_DEM_PNG, 21, 13, 0.0f);
        for (size_t i = 0; i < (size_t)k->w * k->h; i++) {
            idx[i] = (uint8_t)(fx_rand(&s) % 16);
            k->z[i] = pal[3 * idx[i]];
        }
        fx_write_png_palette(fx_tmp(k->name), k->w, k->h, 4, idx, pal, 16);
        free(idx);
    }
    { /* Terrarium RGB (by name), RGBA (auto: colour -> Terrarium), grey-as-RGB */
        fx_case *k = add(c, &n, "rt_terrarium_z9_x270_y178.png", HZ_DEM_TERRARIUM, 24, 24, 0.0f);
        uint16_t *smp = malloc((size_t)k->w * k->h * 4 * 2);
        for (size_t i = 0; i < (size_t)k->w * k->h; i++) {
            float hgt = -500.0f + (float)(fx_rand(&s) % 4500000) / 1000.0f;
            uint8_t rgb[3];
            fx_terrarium(hgt, rgb);
            for (int q = 0; q < 3; q++)
                smp[3 * i + q] = rgb[q];
            k->z[i] = (float)rgb[0] * 256.0f + (float)rgb[1] + (float)rgb[2] / 256.0f - 32768.0f;
        }
        fx_write_png(fx_tmp(k->name), k->w, k->h, 8, PNG_COLOR_TYPE_RGB, false, smp);
        uint8_t *b;
        size_t bn = 0;
        b = fx_read(fx_tmp(k->name), &bn);
        fx_write_gz(fx_tmp("rt_terrarium_z9_x270_y178.png.gz"), b, bn);
        free(b);
        fx_case *kz = add(c, &n, "rt_terrarium_z9_x270_y178.png.gz", HZ_DEM_TERRARIUM, 24, 24, 0.0f);
        memcpy(kz->z, k->z, (size_t)k->w * k->h * sizeof(float));

        k = add(c, &n, "rt_tile_rgba.png", HZ_DEM_TERRARIUM, 17, 11, 0.0f);
        for (size_t i = 0; i < (size_t)k->w * k->h; i++) {
            float hgt = (float)(fx_rand(&s) % 3000000) / 1000.0f;
            uint8_t rgb[3];
            fx_terrarium(hgt, rgb);
            for (int q = 0; q < 3; q++)
                smp[4 * i + q] = rgb[q];
            smp[4 * i + 3] = 255;
            k->z[i] = (float)rgb[0] * 256.0f + (float)rgb[1] + (float)rgb[2] / 256.0f - 32768.0f;
        }
        fx_write_png(fx_tmp(k->name), k->w, k->h, 8, PNG_COLOR_TYPE_RGB_ALPHA, false, smp);

        k = add(c, &n, "rt_grey_as_rgb.png", HZ_DEM_PNG, 15, 12, 0.0f);
        for (size_t i = 0; i < (size_t)k->w * k->h; i++) {
            uint16_t v = (uint16_t)(fx_rand(&s) % 256);
            smp[3 * i] = smp[3 * i + 1] = smp[3 * i + 2] = v;
            k->z[i] = v;
        }
        fx_write_png(fx_tmp(k->name), k->w, k->h, 8, PNG_COLOR_TYPE_RGB, false, smp);
        free(smp);
    }
    { /* SRTM hgt with voids and negative heights; the same layout as *int16be.raw */
        const char *names[2] = {"rt_tile.hgt", "rt_mosaic_25x25_int16be.raw"};
        const uint32_t side[2] = {31, 25};
        for (int v = 0; v < 2; v++) {
            uint32_t w = side[v];
            fx_case *k = add(c, &n, names[v], HZ_DEM_HGT, w, w, 0.0f);
            uint8_t *b = malloc((size_t)w * w * 2);
            for (size_t i = 0; i < (size_t)w * w; i++) {
                int hv = (int)(fx_rand(&s) % 9000) - 430;
                if (i % 97 == 5)
                    hv = -32768; /* void */
                if (i == 1)
                    hv = 32767;
                if (i == 2)
                    hv = -32767;
                put_be16(b + 2 * i, hv);
                k->z[i] = hv == -32768 ? NAN : (float)hv;
            }
            fx_write(fx_tmp(k->name), b, (size_t)w * w * 2);
            char gzname[128];
            snprintf(gzname, sizeof gzname, "%s.gz", names[v]);
            fx_write_gz(fx_tmp(gzname), b, (size_t)w * w * 2);
            fx_case *kz = add(c, &n, v ? "rt_mosaic_25x25_int16be.raw.gz" : "rt_tile.hgt.gz", HZ_DEM_HGT, w, w,
                              0.0f);
            memcpy(kz->z, k->z, (size_t)w * w * sizeof(float));
            free(b);
        }
    }
    { /* r16: non-square with an explicit size, square from the byte count */
        fx_case *k = add(c, &n, "rt_grid.r16", HZ_DEM_R16, 40, 24, 0.0f);
        k->raw_w = 40;
        k->raw_h = 24;
        uint8_t *b = malloc(40 * 24 * 2);
        for (size_t i = 0; i < 40 * 24; i++) {
            uint16_t v = (uint16_t)(fx_rand(&s) % 65536);
            b[2 * i] = (uint8_t)v; /* little-endian */
            b[2 * i + 1] = (uint8_t)(v >> 8);
            k->z[i] = v;
        }
        fx_write(fx_tmp(k->name), b, 40 * 24 * 2);
        fx_write_gz(fx_tmp("rt_grid.r16.gz"), b, 40 * 24 * 2);
        fx_case *kz = add(c, &n, "rt_grid.r16.gz", HZ_DEM_R16, 40, 24, 0.0f);
        kz->raw_w = 40;
        kz->raw_h = 24;
        memcpy(kz->z, k->z, 40 * 24 * sizeof(float));
        free(b);
        k = add(c, &n, "rt_square.r16", HZ_DEM_R16, 32, 32, 0.0f);
        b = malloc(32 * 32 * 2);
        for (size_t i = 0; i < 32 * 32; i++) {
            uint16_t v = (uint16_t)(fx_rand(&s) % 65536);
            b[2 * i] = (uint8_t)v;
            b[2 * i + 1] = (uint8_t)(v >> 8);
            k->z[i] = v;
        }
        fx_write(fx_tmp(k->name), b, 32 * 32 * 2);
        free(b);
    }
    { /* r32 with NaN voids, negative and fractional heights */
        fx_case *k = add(c, &n, "rt_grid.r32", HZ_DEM_R32, 30, 20, 0.0f);
        k->raw_w = 30;
        k->raw_h = 20;
        uint8_t *b = malloc(30 * 20 * 4);
        for (size_t i = 0; i < 30 * 20; i++) {
            float v = (float)((int)(fx_rand(&s) % 2000000) - 500000) / 256.0f;
            if (i % 53 == 7)
                v = NAN;
            uint32_t u;
            memcpy(&u, &v, 4);
            for (int q = 0; q < 4; q++)
                b[4 * i + q] = (uint8_t)(u >> (8 * q));
            k->z[i] = v;
        }
        fx_write(fx_tmp(k->name), b, 30 * 20 * 4);
        fx_write_gz(fx_tmp("rt_grid.r32.gz"), b, 30 * 20 * 4);
        fx_case *kz = add(c, &n, "rt_grid.r32.gz", HZ_DEM_R32, 30, 20, 0.0f);
        kz->raw_w = 30;
        kz->raw_h = 20;
        memcpy(kz->z, k->z, 30 * 20 * sizeof(float));
        free(b);
    }
    *out = c;
    return n;
}

void fx_free_cases(fx_case *cases, size_t n)
{
    for (size_t i = 0; i < n; i++)
        free(cases[i].z);
    free(cases);
}

bool fx_write_tiff_claim(const char *path, uint32_t w, uint32_t h, uint16_t bands, uint16_t bits,
                         uint16_t sample_format, uint16_t compression, double x0, double y0, double px, uint16_t epsg)
{
    uint8_t b[512] = {'I', 'I', 42, 0, 8, 0, 0, 0};
    size_t at = 8, extra = 8 + 2 + 16 * 12 + 4;
    const struct {
        uint16_t tag, type;
        uint32_t count;
        double d[6];
        uint32_t u[16];
    } e[] = {
        {256, 4, 1, {0}, {w}},
        {257, 4, 1, {0}, {h}},
        {258, 3, bands, {0}, {bits, bits, bits, bits}},
        {259, 3, 1, {0}, {compression}},
        {262, 3, 1, {0}, {bands >= 3 ? 2u : 1u}},
        {273, 4, 1, {0}, {0}},
        {277, 3, 1, {0}, {bands}},
        {278, 4, 1, {0}, {h}},
        {279, 4, 1, {0}, {12}},
        {284, 3, 1, {0}, {1}},
        {339, 3, bands, {0}, {sample_format, sample_format, sample_format, sample_format}},
        {33550, 12, 3, {px, px, 0}, {0}},
        {33922, 12, 6, {0, 0, 0, x0, y0, 0}, {0}},
        {34735, 3, 16, {0}, {1, 1, 0, 3, 1024, 0, 1, 1, 1025, 0, 1, 1, 3072, 0, 1, epsg}},
    };
    const uint16_t n = sizeof e / sizeof *e;
    if (bands < 1 || bands > 4)
        return false;
    memcpy(b + at, &n, 2);
    at += 2;
    size_t strip_entry = 0;
    for (uint16_t k = 0; k < n; k++) {
        memcpy(b + at, &e[k].tag, 2), memcpy(b + at + 2, &e[k].type, 2), memcpy(b + at + 4, &e[k].count, 4);
        const size_t sz = e[k].type == 12 ? 8 : e[k].type == 4 ? 4 : 2, len = sz * e[k].count;
        uint8_t *dst = len <= 4 ? b + at + 8 : b + extra;
        for (uint32_t i = 0; i < e[k].count; i++) {
            if (e[k].type == 12) {
                memcpy(dst + 8 * i, &e[k].d[i], 8);
            } else if (e[k].type == 4) {
                memcpy(dst + 4 * i, &e[k].u[i], 4);
            } else {
                const uint16_t v = (uint16_t)e[k].u[i];
                memcpy(dst + 2 * i, &v, 2);
            }
        }
        if (len > 4) {
            const uint32_t off = (uint32_t)extra;
            memcpy(b + at + 8, &off, 4);
            extra += len;
        }
        if (e[k].tag == 273)
            strip_entry = at + 8;
        at += 12;
    }
    const uint32_t strip = (uint32_t)extra;
    memcpy(b + strip_entry, &strip, 4);
    extra += 12; /* 12 bytes of data (zeros), whatever is claimed */
    return extra <= sizeof b && fx_write(path, b, extra);
}
