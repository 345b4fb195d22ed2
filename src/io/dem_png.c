/* PNG heightmaps through libpng: decode from memory (grey 8/16-bit, grey
 * palette, Terrarium RGB) and write 16-bit grey. libpng checks chunk CRCs and
 * the zlib stream, so corrupt files fail instead of decoding to noise. */
#include "io_internal.h"

#include <errno.h>
#include <math.h>
#include <png.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The state lives in the caller's frame (not in the function that calls
 * setjmp), so nothing changed between setjmp and longjmp is indeterminate. */
typedef struct png_job {
    const char *path;
    const uint8_t *data;
    size_t size, pos;
    char msg[sizeof(((hz_err *)0)->msg)];
    uint8_t *row;       /* one decoded row (non-interlaced) */
    uint8_t *image;     /* whole decoded image (interlaced) */
    png_bytep *rows;
    FILE *file;         /* writer only */
} png_job;

static void job_error(png_structp png, png_const_charp msg)
{
    png_job *j = png_get_error_ptr(png);
    snprintf(j->msg, sizeof j->msg, "%s", msg ? msg : "unknown libpng error");
    png_longjmp(png, 1);
}

static void job_warning(png_structp png, png_const_charp msg)
{
    (void)png;
    (void)msg; /* ancillary-chunk trouble only; the pixels are still checked */
}

static void job_read(png_structp png, png_bytep out, size_t n)
{
    png_job *j = png_get_io_ptr(png);
    if (n > j->size - j->pos)
        png_error(png, "unexpected end of file (the PNG is truncated)");
    memcpy(out, j->data + j->pos, n);
    j->pos += n;
}

/* Palette that maps index -> grey level, or NULL-equivalent if not all grey. */
typedef struct grey_palette {
    bool grey;
    int count;
    uint8_t level[256];
} grey_palette;

static float terrarium_h(const uint8_t *p)
{
    return (float)p[0] * 256.0f + (float)p[1] + (float)p[2] / 256.0f - 32768.0f;
}

/* Converts one decoded row into floats. Returns false (with job->msg) on a
 * palette index beyond the palette. *all_grey is cleared on any non-grey pixel. */
static bool convert_row(png_job *j, const uint8_t *src, float *dst, uint32_t w, int channels, int depth,
                        const grey_palette *pal, bool colour, bool *all_grey)
{
    if (colour) {
        /* 8-bit RGB(A) after png_set_scale_16. */
        bool grey = *all_grey;
        for (uint32_t i = 0; i < w; i++) {
            const uint8_t *p = src + (size_t)i * (size_t)channels;
            grey = grey && p[0] == p[1] && p[1] == p[2];
            dst[i] = terrarium_h(p);
        }
        *all_grey = grey;
        return true;
    }
    if (pal) {
        for (uint32_t i = 0; i < w; i++) {
            uint8_t k = src[i];
            if (k >= pal->count) {
                snprintf(j->msg, sizeof j->msg, "pixel uses palette index %d but the palette has %d entries", k,
                         pal->count);
                return false;
            }
            dst[i] = (float)pal->level[k];
        }
        return true;
    }
    if (depth == 16) {
        for (uint32_t i = 0; i < w; i++) {
            const uint8_t *p = src + (size_t)i * (size_t)channels * 2;
            dst[i] = (float)((p[0] << 8) | p[1]);
        }
    } else {
        for (uint32_t i = 0; i < w; i++)
            dst[i] = (float)src[(size_t)i * (size_t)channels];
    }
    return true;
}

typedef struct png_shape {
    uint32_t w, h;
    int channels, depth;
    bool colour;
    grey_palette pal;
    bool use_pal;
    bool all_grey;
} png_shape;

/* Everything that can longjmp. Returns 0 on success, 1 on a libpng error
 * (message in j->msg), 2 on our own format error (message in j->msg), 3 on
 * out of memory, 4 if the image is too large. */
static int decode(png_job *j, png_structp png, png_infop info, png_shape *s, hz_grid *g, hz_io_progress *prog)
{
    if (setjmp(png_jmpbuf(png)))
        return 1;
    png_set_read_fn(png, j, job_read);
    png_set_user_limits(png, HZ_IO_MAX_SIDE, HZ_IO_MAX_SIDE);
    png_read_info(png, info);
    png_uint_32 w, h;
    int depth, ctype, interlace;
    png_get_IHDR(png, info, &w, &h, &depth, &ctype, &interlace, NULL, NULL);
    /* A PNG cannot decode to more than ~1032x its compressed size (deflate's
     * limit), so a header that promises more is a lie: refuse before
     * allocating. */
    int file_channels = png_get_channels(png, info);
    uint64_t raw = (uint64_t)h * (((uint64_t)w * (uint64_t)file_channels * (uint64_t)depth + 7) / 8 + 1);
    if (raw > (uint64_t)j->size * 1100u + 65536u) {
        snprintf(j->msg, sizeof j->msg,
                 "header says %ux%u but the file (%zu bytes) is far too small for that: truncated or corrupt",
                 (unsigned)w, (unsigned)h, j->size);
        return 2;
    }
    s->use_pal = false;
    s->pal.grey = false;
    if (ctype == PNG_COLOR_TYPE_PALETTE) {
        png_colorp plte = NULL;
        int n = 0;
        if (!png_get_PLTE(png, info, &plte, &n) || n <= 0) {
            snprintf(j->msg, sizeof j->msg, "palette image without a palette");
            return 2;
        }
        s->pal.grey = true;
        s->pal.count = n > 256 ? 256 : n;
        for (int k = 0; k < s->pal.count; k++) {
            if (plte[k].red != plte[k].green || plte[k].green != plte[k].blue)
                s->pal.grey = false;
            s->pal.level[k] = plte[k].red;
        }
        if (s->pal.grey) {
            png_set_packing(png); /* 1/2/4-bit indices -> one byte each */
            s->use_pal = true;
        } else {
            png_set_palette_to_rgb(png);
        }
    } else if (ctype == PNG_COLOR_TYPE_GRAY && depth < 8) {
        png_set_expand_gray_1_2_4_to_8(png);
    }
    if (ctype & PNG_COLOR_MASK_COLOR)
        png_set_scale_16(png);
    int passes = png_set_interlace_handling(png);
    png_read_update_info(png, info);
    s->w = w;
    s->h = h;
    s->channels = png_get_channels(png, info);
    s->depth = png_get_bit_depth(png, info);
    s->colour = (png_get_color_type(png, info) & PNG_COLOR_MASK_COLOR) != 0 && !s->use_pal;
    s->all_grey = true;
    size_t rowbytes = png_get_rowbytes(png, info);
    size_t want_row = (size_t)w * (size_t)s->channels * (size_t)(s->depth == 16 ? 2 : 1);
    if ((s->depth != 8 && s->depth != 16) || (s->colour && (s->channels < 3 || s->depth != 8)) ||
        rowbytes < want_row) {
        snprintf(j->msg, sizeof j->msg, "unsupported PNG layout (colour type %d, %d bits, %d channels)", ctype,
                 s->depth, s->channels);
        return 2;
    }
    hz_err aerr;
    hz_result ar = hz_grid_alloc(g, w, h, &aerr);
    if (ar != HZ_OK) {
        snprintf(j->msg, sizeof j->msg, "%s", aerr.msg);
        return ar == HZ_ERR_MEMORY ? 3 : 4;
    }
    prog->total = h;
    const grey_palette *pal = s->use_pal ? &s->pal : NULL;
    if (passes == 1) {
        j->row = malloc(rowbytes);
        if (!j->row)
            return 3;
        for (png_uint_32 y = 0; y < h; y++) {
            png_read_row(png, j->row, NULL);
            if (!convert_row(j, j->row, g->z + (size_t)y * w, w, s->channels, s->depth, pal, s->colour,
                             &s->all_grey))
                return 2;
            hz_io_progress_step(prog, y + 1);
        }
    } else {
        j->image = malloc(rowbytes * h);
        j->rows = malloc(sizeof *j->rows * h);
        if (!j->image || !j->rows)
            return 3;
        for (png_uint_32 y = 0; y < h; y++)
            j->rows[y] = j->image + rowbytes * y;
        png_read_image(png, j->rows);
        for (png_uint_32 y = 0; y < h; y++) {
            if (!convert_row(j, j->rows[y], g->z + (size_t)y * w, w, s->channels, s->depth, pal, s->colour,
                             &s->all_grey))
                return 2;
            hz_io_progress_step(prog, y + 1);
        }
    }
    /* NOTE: png_read_end is skipped on purpose: the pixels are complete and
     * checked; trailing chunks (text, time) do not matter here. */
    return 0;
}

hz_result hz_io_png_decode(const char *path, const uint8_t *data, size_t size, hz_dem_format want,
                           bool name_terrarium, hz_io_progress *prog, hz_grid *g, hz_png_result *res,
                           hz_err *err)
{
    g->z = NULL;
    g->width = g->height = 0;
    if (size < 8 || png_sig_cmp(data, 0, 8) != 0)
        return hz_err_set(err, HZ_ERR_FORMAT, "'%s' is not a PNG file (no PNG signature in the first 8 bytes)",
                          path);
    png_job job = {.path = path, .data = data, .size = size};
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &job, job_error, job_warning);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (!png || !info) {
        png_destroy_read_struct(&png, &info, NULL);
        return hz_err_set(err, HZ_ERR_MEMORY, "'%s': out of memory creating the PNG decoder", path);
    }
    png_shape shape;
    memset(&shape, 0, sizeof shape);
    int rc = decode(&job, png, info, &shape, g, prog);
    png_destroy_read_struct(&png, &info, NULL);
    free(job.row);
    free(job.image);
    free(job.rows);
    hz_result r = HZ_OK;
    if (rc == 1)
        r = hz_err_set(err, HZ_ERR_FORMAT, "'%s': corrupt or truncated PNG: %s", path, job.msg);
    else if (rc == 2)
        r = hz_err_set(err, HZ_ERR_FORMAT, "'%s': %s", path, job.msg);
    else if (rc == 3)
        r = hz_err_set(err, HZ_ERR_MEMORY, "'%s': out of memory decoding the PNG", path);
    else if (rc == 4)
        r = hz_err_set(err, HZ_ERR_FORMAT, "'%s': %s", path, job.msg);
    else if (want == HZ_DEM_TERRARIUM && !shape.colour)
        r = hz_err_set(err, HZ_ERR_FORMAT,
                       "'%s' is a greyscale PNG, but Terrarium tiles are RGB: use --format png", path);
    if (r != HZ_OK) {
        hz_grid_free(g);
        return r;
    }
    res->terrarium = shape.colour;
    res->bit_depth = shape.colour ? 8u : (uint32_t)shape.depth;
    if (shape.colour && want != HZ_DEM_TERRARIUM && shape.all_grey && (want == HZ_DEM_PNG || !name_terrarium)) {
        /* An RGB image whose pixels are all grey is a grey heightmap saved as
         * colour, not a Terrarium tile (those change R only every 256 m, so
         * R=G=B everywhere does not happen). Undo the Terrarium formula:
         * h + 32768 = R * (257 + 1/256) exactly in float. */
        size_t n = (size_t)g->width * g->height;
        for (size_t k = 0; k < n; k++)
            g->z[k] = (float)(int)((g->z[k] + 32768.0f) / 257.00390625f + 0.5f);
        res->terrarium = false;
        res->bit_depth = 8;
    } else if (shape.colour && want == HZ_DEM_PNG) {
        hz_grid_free(g);
        return hz_err_set(err, HZ_ERR_FORMAT,
                          "'%s' is a colour PNG: use --format terrarium for Terrarium tiles "
                          "(h = R*256 + G + B/256 - 32768), or convert it to 16-bit grey",
                          path);
    }
    return HZ_OK;
}

/* ---- writer ---- */

static int encode(png_job *j, png_structp png, png_infop info, const hz_grid *g, float lo, float hi)
{
    if (setjmp(png_jmpbuf(png)))
        return 1;
    png_init_io(png, j->file);
    png_set_IHDR(png, info, g->width, g->height, 16, PNG_COLOR_TYPE_GRAY, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    double scale = hi > lo ? 65535.0 / ((double)hi - (double)lo) : 0.0;
    for (uint32_t y = 0; y < g->height; y++) {
        const float *src = g->z + (size_t)y * g->width;
        for (uint32_t x = 0; x < g->width; x++) {
            double v = ((double)src[x] - lo) * scale + 0.5;
            /* NaN (void) and anything below lo -> 0; above hi -> 65535. */
            uint32_t q = v >= 65535.0 ? 65535u : v > 0.0 ? (uint32_t)v : 0u;
            j->row[2 * x] = (uint8_t)(q >> 8); /* PNG samples are big-endian */
            j->row[2 * x + 1] = (uint8_t)(q & 0xff);
        }
        png_write_row(png, j->row);
    }
    png_write_end(png, NULL);
    return 0;
}

hz_result hz_dem_write_png16(const char *path, const hz_grid *g, float lo, float hi, hz_err *err)
{
    HZ_ASSERT(path && g && g->z);
    if (!(lo <= hi) || !isfinite(lo) || !isfinite(hi))
        return hz_err_set(err, HZ_ERR_VALUE, "write '%s': bad value range [%g, %g]", path, (double)lo, (double)hi);
    if (lo == hi)
        hz_grid_range(g, &lo, &hi);
    png_job job = {.path = path};
    job.file = fopen(path, "wb");
    if (!job.file)
        return hz_err_set(err, HZ_ERR_IO, "cannot create '%s': %s", path, strerror(errno));
    job.row = malloc((size_t)g->width * 2);
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &job, job_error, job_warning);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    hz_result r = HZ_OK;
    if (!png || !info || !job.row)
        r = hz_err_set(err, HZ_ERR_MEMORY, "write '%s': out of memory", path);
    else if (encode(&job, png, info, g, lo, hi) != 0)
        r = hz_err_set(err, HZ_ERR_IO, "write '%s': %s", path, job.msg);
    png_destroy_write_struct(&png, &info);
    free(job.row);
    if (fclose(job.file) != 0 && r == HZ_OK)
        r = hz_err_set(err, HZ_ERR_IO, "write '%s': %s", path, strerror(errno));
    if (r != HZ_OK)
        remove(path);
    return r;
}
