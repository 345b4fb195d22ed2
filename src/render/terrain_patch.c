/* cdlod patches on the GPU: a buffer texture of height tiles (a pyramid,
 * every level cut in T x T-cell tiles with a shared border), one static
 * P x P-cell grid in a vertex buffer-less index buffer, and per frame one
 * instance per selected node (8 bytes; 24 for a streamed terrain). The
 * vertex shader (shaders/terrain_patch_vs.glsl) places, stitches and morphs
 * the vertices.
 * The CPU work and the upload per frame are proportional to the nodes. */
#include "render_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "horizon/lod.h"
#include "horizon/pyramid.h"

/* Words per patch instance: streamed a_patch (4) and a_slide (2); in
 * memory 2 (a_patch.xy: the node's corner and its shift and stitching, the
 * tile found from them), so 4 000 patches upload 31 KB a frame. */
#define INST_WORDS_STREAM 6
#define INST_WORDS_MEMORY 2
/* The main view's patches go in PATCH_CHUNKS flushed draws (patch_draw),
 * nearest first, when there are at least PATCH_CHUNK_MIN a chunk. llvmpipe
 * bins each chunk on the drawing thread while its rasteriser threads work
 * on the chunks flushed before, so the first chunk, binned with the
 * rasterisers idle, is small and the chunks grow (ends at CHUNK_END / 20 of
 * the patches). On the peers' 4097^2 flight at tau 2 (2 600 patches,
 * --effects none), equal chunks without the flush after the last: 1 draw
 * 42.4 / 41.8 ms a frame, 2: 39.0 / 38.7, 4: 38.6 / 38.4, 8: 40.7 / 39.8;
 * that last flush takes 0.5 ms more off, and 7 of the 90 ms of a 2049^2
 * frame with the default effects. Growing chunks (5, 10, 20, 30 and 35 %)
 * against 4 equal ones at tau 1.5: the stretch of a frame in which only
 * the drawing thread works falls from about 10 to 5 ms (perf), the frame
 * from 53.2 to 50.6 ms (five alternating pairs; PATCH_CHUNKS is in
 * render_internal.h). */
#define PATCH_CHUNK_MIN 64
static const uint32_t CHUNK_END[PATCH_CHUNKS] = {1, 3, 7, 13, 20};
_Static_assert(PATCH_CHUNKS == 5, "a chunk end per chunk");

/* Flushed draws for n patches. */
static uint32_t patch_chunks(uint32_t n)
{
    return n >= PATCH_CHUNKS * PATCH_CHUNK_MIN ? PATCH_CHUNKS : 1;
}

/* Where chunk c of chunks (patch_chunks) ends among count patches. */
static uint32_t chunk_end(uint32_t c, uint32_t chunks, uint32_t count)
{
    return chunks == 1 ? count : (uint32_t)((uint64_t)count * CHUNK_END[c] / 20);
}

/* Tile texel: h16, morph q, morph target (sum of two h16, 17 bits) low, and
 * its high bit plus a no-data flag. */
enum { TEXEL_CH = 4 };

static void tile_fill(hz_lod *lod, const uint16_t *morph, const uint8_t *valid, uint32_t n, uint32_t T,
                      uint32_t level, uint32_t tx, uint32_t tz, uint16_t *out)
{
    const hz_heightmap *hm = hz_lod_query_heightmap(lod);
    const uint32_t cells = (n - 1) >> level;
    for (uint32_t b = 0; b <= T; b++) {
        uint32_t gj = tz * T + b;
        if (gj > cells)
            gj = cells;
        const uint32_t j = gj << level;
        for (uint32_t a = 0; a <= T; a++) {
            uint32_t gi = tx * T + a;
            if (gi > cells)
                gi = cells;
            const uint32_t i = gi << level;
            uint16_t *o = out + ((size_t)b * (T + 1) + a) * TEXEL_CH;
            const uint32_t t2 = hz_lod_morph_target2(lod, i, j);
            o[0] = hz_heightmap_get16(hm, i, j);
            o[1] = morph[(size_t)j * n + i];
            o[2] = (uint16_t)(t2 & 0xffffu);
            /* bit 0: the target's 17th bit; bit 1: no data here (not drawn) */
            o[3] = (uint16_t)((t2 >> 16) | (valid && !valid[(size_t)j * n + i] ? 2u : 0u));
        }
    }
}

/* The tiles as one buffer texture of layers squares of side texels,
 * RGBA16UI; 0 texels frees them. A buffer texture, not a 2D array: its
 * texel address is one multiply-add, with no per-level strides or offsets
 * to look up. With the rasteriser off (vertex work only), the peers' 4097^2
 * flight at tau 1.35 took 20.3 ms a frame against 21.1 from an array. */
static hz_result tiles_alloc(hz_renderer *r, uint32_t layers, uint32_t texels, hz_err *err)
{
    glDeleteTextures(1, &r->tiles_tex);
    glDeleteBuffers(1, &r->tiles_buf);
    r->tiles_tex = r->tiles_buf = 0;
    if (!texels)
        return HZ_OK;
    GLint max_texels = 0;
    glGetIntegerv(GL_MAX_TEXTURE_BUFFER_SIZE, &max_texels);
    const uint64_t total = (uint64_t)layers * texels * texels;
    if (total > (uint64_t)(max_texels > 0 ? max_texels : 0))
        return hz_err_set(err, HZ_ERR_UNSUPPORTED,
                          "renderer: %u cdlod tiles of %u^2 texels need %llu texels of buffer texture "
                          "(GL_MAX_TEXTURE_BUFFER_SIZE %d)",
                          layers, texels, (unsigned long long)total, max_texels);
    glGenBuffers(1, &r->tiles_buf);
    glBindBuffer(GL_TEXTURE_BUFFER, r->tiles_buf);
    glBufferData(GL_TEXTURE_BUFFER, (GLsizeiptr)(total * TEXEL_CH * sizeof(uint16_t)), NULL, GL_STATIC_DRAW);
    glGenTextures(1, &r->tiles_tex);
    glBindTexture(GL_TEXTURE_BUFFER, r->tiles_tex);
    glTexBuffer(GL_TEXTURE_BUFFER, GL_RGBA16UI, r->tiles_buf);
    glBindTexture(GL_TEXTURE_BUFFER, 0);
    glBindBuffer(GL_TEXTURE_BUFFER, 0);
    hz_result res = hz_gl_check(err, "cdlod tile buffer allocation (GL_RGBA16UI)");
    if (res != HZ_OK)
        tiles_alloc(r, 0, 0, NULL);
    return res;
}

/* Tile layer k's texels (a square of side texels). */
static void tiles_write(uint32_t k, uint32_t texels, const uint16_t *data)
{
    const size_t bytes = (size_t)texels * texels * TEXEL_CH * sizeof(uint16_t);
    glBufferSubData(GL_TEXTURE_BUFFER, (GLintptr)(k * bytes), (GLsizeiptr)bytes, data);
}

static uint32_t inst_words(const hz_renderer *r)
{
    return r->streamed ? INST_WORDS_STREAM : INST_WORDS_MEMORY;
}

/* The instance attributes from instance first on (GL 3.3 has no base
 * instance); the patch VAO and VBO bound. */
static void patch_attribs(const hz_renderer *r, uint32_t first)
{
    const GLsizei stride = (GLsizei)(inst_words(r) * sizeof(uint32_t));
    const size_t at = (size_t)first * (size_t)stride;
    glVertexAttribIPointer(0, r->streamed ? 4 : 2, GL_UNSIGNED_INT, stride, (const void *)at);
    if (r->streamed) {
        glEnableVertexAttribArray(1);
        glVertexAttribIPointer(1, 2, GL_UNSIGNED_INT, stride, (const void *)(at + 4 * sizeof(uint32_t)));
    } else {
        glDisableVertexAttribArray(1); /* the in-memory shader does not read a_slide */
    }
}

/* The static patch: (P+1)^2 vertices, union-jack cells (hz_lod_cell_triangles).
 * NOTE: vertex reuse on llvmpipe (Mesa 22.3, GL_VERTEX_SHADER_INVOCATIONS):
 * the draw module shades each instance's indices in segments of at most
 * 1024, each with a 256-entry cache keyed by index mod 256. An 8-cell patch
 * (384 indices, 81 vertices) is one segment whose indices never collide: 81
 * runs an instance, every vertex once, 0.633 a triangle. 32-cell patches
 * would take 1263 runs for 1089 vertices (blocked index orders 1200 at
 * best); the path that shades each vertex exactly once refuses instanced
 * attributes, and one non-instanced draw of many patches ran 0.656 a
 * triangle and no faster. */
static hz_result patch_grid(hz_renderer *r, uint32_t P, hz_err *err)
{
    if (r->patch_cells != P) {
        const uint32_t c1 = P + 1;
        uint16_t *idx = malloc((size_t)P * P * 12 * sizeof *idx);
        if (!idx)
            return hz_err_set(err, HZ_ERR_MEMORY, "renderer: out of memory for the patch indices");
        uint16_t *o = idx;
        /* The cells row by row (whole patches), then again block by block in
         * Morton order (neighbouring blocks next to each other, so a patch's
         * shown blocks make few ranges), each row by row. On the peers'
         * flight whole patches in the block order took 2-3 % longer. */
        for (uint32_t w = 0; w < P; w++)
            for (uint32_t u = 0; u < P; u++) {
                uint32_t t[6];
                hz_lod_cell_triangles(((u + w) & 1u) == 0, w * c1 + u, (w + 1) * c1 + u, w * c1 + u + 1,
                                      (w + 1) * c1 + u + 1, t);
                for (int k = 0; k < 6; k++)
                    *o++ = (uint16_t)t[k];
            }
        const uint32_t B = hz_lod_patch_blocks(P), C = P / B;
        for (uint32_t m = 0; m < B * B; m++) {
            uint32_t bx = 0, bz = 0;
            for (uint32_t b = 0; b < 4; b++) {
                bx |= ((m >> (2 * b)) & 1u) << b;
                bz |= ((m >> (2 * b + 1)) & 1u) << b;
            }
            r->block_morton[m] = (uint8_t)(bz * B + bx);
            for (uint32_t w = bz * C; w < (bz + 1) * C; w++)
                for (uint32_t u = bx * C; u < (bx + 1) * C; u++) {
                    uint32_t t[6];
                    hz_lod_cell_triangles(((u + w) & 1u) == 0, w * c1 + u, (w + 1) * c1 + u, w * c1 + u + 1,
                                          (w + 1) * c1 + u + 1, t);
                    for (int k = 0; k < 6; k++)
                        *o++ = (uint16_t)t[k];
                }
        }
        r->patch_blocks = B;
        r->block_indices = C * C * 6;
        if (!r->patch_vao) {
            glGenVertexArrays(1, &r->patch_vao);
            glGenBuffers(1, &r->patch_ibo);
            glGenBuffers(1, &r->patch_vbo);
            glGenBuffers(1, &r->patch_cmd_buf);
        }
        glBindVertexArray(r->patch_vao);
        glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, r->patch_ibo);
        glBufferData(GL_ELEMENT_ARRAY_BUFFER, (GLsizeiptr)((size_t)P * P * 12 * sizeof *idx), idx, GL_STATIC_DRAW);
        glBindBuffer(GL_ARRAY_BUFFER, r->patch_vbo);
        glEnableVertexAttribArray(0);
        glVertexAttribDivisor(0, 1);
        glVertexAttribDivisor(1, 1);
        patch_attribs(r, 0);
        glBindVertexArray(0);
        glBindBuffer(GL_ARRAY_BUFFER, 0);
        free(idx);
        r->patch_cells = P;
        r->patch_index_count = P * P * 6;
    }
    return hz_gl_check(err, "cdlod patch setup");
}

hz_result hz_renderer_set_cdlod(hz_renderer *r, hz_lod *lod, const uint8_t *valid, hz_err *err)
{
    HZ_ASSERT(r && lod);
    hz_result res = fx_check_context(r, err, "hz_renderer_set_cdlod");
    if (res != HZ_OK)
        return res;
    const hz_heightmap *hm = hz_lod_query_heightmap(lod);
    if (!r->has_heights || r->size != hm->size)
        return hz_err_set(err, HZ_ERR_VALUE, "renderer: hz_renderer_set_cdlod needs the same heightmap set first");
    const uint16_t *morph = hz_lod_morph_errors(lod);
    if (!morph)
        return hz_err_set(err, HZ_ERR_MEMORY, "renderer: out of memory for cdlod's morph data");
    const uint32_t n = hm->size, P = hz_lod_patch_cells(lod);
    /* Tiles of T = 256 cells (the whole map when smaller). */
    const uint32_t T = n - 1 < 256 ? n - 1 : 256;
    uint32_t top = 0, layers = 0;
    while (((n - 1) >> top) > T)
        top++;
    for (uint32_t l = 0; l <= top; l++) {
        const uint32_t m = ((n - 1) >> l) / T;
        layers += m * m;
    }
    if (T & (T - 1)) /* the shader addresses tiles by shifts */
        return hz_err_set(err, HZ_ERR_UNSUPPORTED, "renderer: cdlod tiles of %u cells (a %ux%u map is not 2^k + 1)",
                          T, n, n);
    if (top >= 16)
        return hz_err_set(err, HZ_ERR_UNSUPPORTED, "renderer: a %ux%u cdlod pyramid has more than 16 tile levels",
                          n, n);
    uint16_t *buf = malloc((size_t)(T + 1) * (T + 1) * TEXEL_CH * sizeof *buf);
    if (!buf)
        return hz_err_set(err, HZ_ERR_MEMORY, "renderer: out of memory for a %u-texel tile", T + 1);
    hz_gl_drain();
    res = tiles_alloc(r, layers, T + 1, err);
    uint32_t layer = 0;
    glBindBuffer(GL_TEXTURE_BUFFER, r->tiles_buf);
    for (uint32_t l = 0; res == HZ_OK && l <= top; l++) {
        const uint32_t m = ((n - 1) >> l) / T;
        r->tile_base[l] = (int32_t)layer;
        for (uint32_t tz = 0; tz < m; tz++)
            for (uint32_t tx = 0; tx < m; tx++) {
                tile_fill(lod, morph, valid, n, T, l, tx, tz, buf);
                tiles_write(layer++, T + 1, buf);
            }
    }
    glBindBuffer(GL_TEXTURE_BUFFER, 0);
    free(buf);
    if (res == HZ_OK)
        res = hz_gl_check(err, "cdlod tile upload");
    if (res != HZ_OK) {
        tiles_alloc(r, 0, 0, NULL);
        return res;
    }
    r->tile_cells = T;
    r->streamed = false;
    r->tile_masked = false;
    for (size_t k = 0; valid && k < (size_t)n * n && !r->tile_masked; k++)
        r->tile_masked = !valid[k];
    r->tile_top = top;
    r->tile_layers = layers;

    return patch_grid(r, P, err);
}

_Static_assert(sizeof ((hz_renderer *)0)->seg_class[0] == PATCH_CLASSES * sizeof(uint32_t),
               "a start per class in each segment");

/* A patch's class in its segment (hz_renderer.seg_class): still or not, and
 * of the finest level over smooth lit map (litmap_smooth_at) or not. */
static uint32_t patch_class(const hz_renderer *r, const hz_patch *q)
{
    const bool fine = q->shift == 0 && litmap_smooth_at(r, q->x0, q->z0);
    const uint32_t c = q->still ? PATCH_STILL_FINE : (q->simple ? PATCH_SIMPLE_FINE : PATCH_MORPH_FINE);
    return fine ? c : c + 1;
}

/* The segments of count patches: the chunks, cut at near. */
static void patch_segments(hz_renderer *r, uint32_t count, uint32_t near)
{
    const uint32_t chunks = patch_chunks(count);
    r->n_seg = 0;
    r->seg[0] = 0;
    for (uint32_t c = 0; c < chunks; c++) {
        const uint32_t ca = c ? chunk_end(c - 1, chunks, count) : 0, cb = chunk_end(c, chunks, count);
        if (near > ca && near < cb) {
            r->seg_flush[r->n_seg] = false;
            r->seg[++r->n_seg] = near;
        }
        if (cb > r->seg[r->n_seg]) {
            r->seg_flush[r->n_seg] = true;
            r->seg[++r->n_seg] = cb;
        }
    }
}

uint32_t hz_renderer_patch_lead(uint32_t count)
{
    const uint32_t chunks = patch_chunks(count);
    return chunk_end(chunks > 1 ? 1 : 0, chunks, count);
}

/* The bits of a patch's blocks in hz_patch.hidden (the others mean nothing). */
static uint16_t blocks_mask(const hz_renderer *r)
{
    return (uint16_t)((1u << (r->patch_blocks * r->patch_blocks)) - 1u);
}

/* Packs segment g of the in-memory patches p into the instance scratch by
 * class, leaving out those hidden marks and the blocks blocks marks (both
 * may be NULL): its class starts and end. */
static void pack_segment(hz_renderer *r, const hz_patch *p, const uint8_t *hidden, const uint16_t *blocks,
                         uint32_t g)
{
    const uint16_t block_mask = blocks_mask(r);
    const uint32_t words = inst_words(r), a = r->seg[g], b = r->seg[g + 1];
    uint32_t num[PATCH_CLASSES] = {0};
    for (uint32_t k = a; k < b; k++)
        if (!hidden || !hidden[k])
            num[patch_class(r, &p[k])]++;
    uint32_t at[PATCH_CLASSES], s = a;
    for (uint32_t c = 0; c < PATCH_CLASSES; s += num[c++])
        r->seg_class[g][c] = at[c] = s;
    r->seg_end[g] = s;
    for (uint32_t k = a; k < b; k++) {
        const hz_patch *q = &p[k];
        if (hidden && hidden[k]) {
            r->late_skipped++;
            continue;
        }
        /* the shader finds the tile: level min(shift, top), (x0 >> level) / T */
        const uint32_t slot = at[patch_class(r, q)]++;
        uint32_t *o = r->inst_scratch + words * (size_t)slot;
        o[0] = q->x0 | (q->z0 << 16);
        o[1] = q->shift | ((uint32_t)q->coarse << 4);
        r->inst_hidden[slot] = (q->hidden | (blocks ? blocks[k] : 0)) & block_mask;
        r->any_hidden |= r->inst_hidden[slot] != 0;
    }
}

/* Instances [a, b) of the scratch into the instance buffer (left bound). */
static void inst_write(hz_renderer *r, uint32_t a, uint32_t b)
{
    const size_t w = inst_words(r) * sizeof(uint32_t);
    glBindBuffer(GL_ARRAY_BUFFER, r->patch_vbo);
    if (b > a)
        glBufferSubData(GL_ARRAY_BUFFER, (GLintptr)(a * w), (GLsizeiptr)((b - a) * w), r->inst_scratch + a * (w / 4));
    r->inst_bytes += b > a ? (b - a) * w : 0;
}

hz_result patch_upload_late(hz_renderer *r, const hz_patch *p, uint32_t count, uint32_t near, hz_job *job,
                            const uint8_t *hidden, const uint16_t *blocks, hz_err *err)
{
    if (!r->tiles_tex)
        return hz_err_set(err, HZ_ERR_VALUE, "renderer: cdlod patches to draw before hz_renderer_set_cdlod");
    const uint32_t words = inst_words(r);
    const size_t bytes = (size_t)count * words * sizeof(uint32_t);
    if (bytes > r->inst_scratch_cap) {
        uint32_t *s = realloc(r->inst_scratch, bytes);
        if (!s)
            return hz_err_set(err, HZ_ERR_MEMORY, "renderer: out of memory for %u patch instances", count);
        r->inst_scratch = s;
        r->inst_scratch_cap = bytes;
    }
    if (count > r->inst_hidden_cap) {
        uint16_t *h = realloc(r->inst_hidden, count * sizeof *h);
        if (!h)
            return hz_err_set(err, HZ_ERR_MEMORY, "renderer: out of memory for %u patch instances", count);
        r->inst_hidden = h;
        r->inst_hidden_cap = count;
    }
    const uint16_t block_mask = blocks_mask(r);
    r->any_hidden = false;
    r->cmd_bytes = 0;
    r->inst_bytes = 0;
    const uint32_t T = r->tile_cells, n = r->size;
    for (uint32_t k = 0; k < count; k++) {
        const hz_patch *q = &p[k];
        if (!r->streamed) {
            if (q->shift > 15 || (q->coarse & ~15u) || q->x0 > 65535 || q->z0 > 65535 ||
                ((r->patch_cells << q->shift) + q->x0 > n - 1) || ((r->patch_cells << q->shift) + q->z0 > n - 1))
                return hz_err_set(err, HZ_ERR_VALUE, "renderer: patch %u (%u, %u, shift %u) lies outside the map", k,
                                  q->x0, q->z0, q->shift);
            continue;
        }
        /* a repeating terrain's patches may be one period off the map */
        const int64_t lo = r->wrap ? -(int64_t)(n - 1) : 0, hi = r->wrap ? 2 * (int64_t)(n - 1) : (int64_t)(n - 1);
        const int64_t x0 = r->wrap ? (int64_t)(int32_t)q->x0 : (int64_t)q->x0;
        const int64_t z0 = r->wrap ? (int64_t)(int32_t)q->z0 : (int64_t)q->z0;
        const int64_t span = (int64_t)r->patch_cells << (q->shift > 23 ? 23 : q->shift);
        if (q->shift > 23 || (q->coarse & ~15u) || q->layer1 == 0 || q->layer1 > r->tile_layers ||
            (uint64_t)q->ox + r->patch_cells > T || (uint64_t)q->oz + r->patch_cells > T || x0 < lo || z0 < lo ||
            x0 + span > hi || z0 + span > hi)
            return hz_err_set(err, HZ_ERR_VALUE, "renderer: streamed patch %u (%u, %u, shift %u, slot %u) is invalid",
                              k, q->x0, q->z0, q->shift, q->layer1);
        uint32_t *o = r->inst_scratch + words * (size_t)k;
        o[0] = q->x0;
        o[1] = q->z0;
        o[2] = (q->layer1 - 1) | ((uint32_t)q->shift << 16);
        o[3] = q->ox | ((uint32_t)q->oz << 12) | ((uint32_t)q->coarse << 28);
        /* slide-in: the least morph inside, then along W E N S */
        o[4] = q->slide | ((uint32_t)q->slide_edge[0] << 8) | ((uint32_t)q->slide_edge[1] << 16) |
               ((uint32_t)q->slide_edge[2] << 24);
        o[5] = q->slide_edge[3];
        r->inst_hidden[k] = q->hidden & block_mask;
        r->any_hidden |= r->inst_hidden[k] != 0;
    }
    patch_segments(r, count, near);
    /* late culling: the segments from the lead on wait (streamed patches are never culled late) */
    const uint32_t lead = hz_renderer_patch_lead(count);
    r->late_seg = r->n_seg; /* (late_skipped, late_wait_ms: reset by hz_renderer_draw) */
    r->late_p = NULL;
    r->late_job = NULL;
    r->late_hidden = NULL;
    r->late_blocks = NULL;
    if (job && hidden && !r->streamed && lead < count) {
        r->late_seg = 0;
        while (r->late_seg < r->n_seg && r->seg[r->late_seg] < lead)
            r->late_seg++;
        r->late_p = p;
        r->late_job = job;
        r->late_hidden = hidden;
        r->late_blocks = blocks;
    }
    for (uint32_t g = 0; g < r->n_seg; g++) {
        if (r->streamed) { /* streamed patches are all PATCH_MORPH, in order */
            for (uint32_t c = 0; c < PATCH_CLASSES; c++)
                r->seg_class[g][c] = r->seg[g];
            r->seg_end[g] = r->seg[g + 1];
        } else if (g < r->late_seg) {
            pack_segment(r, p, NULL, NULL, g);
        }
    }
    glBindBuffer(GL_ARRAY_BUFFER, r->patch_vbo);
    if (bytes > r->inst_cap || bytes < r->inst_cap / 4) {
        r->inst_cap = bytes + bytes / 4 + 64;
    }
    glBufferData(GL_ARRAY_BUFFER, (GLsizeiptr)r->inst_cap, NULL, GL_STREAM_DRAW);
    inst_write(r, 0, r->seg[r->late_seg]);
    glBindBuffer(GL_ARRAY_BUFFER, 0);
    r->n_inst = count;
    return hz_gl_check(err, "patch instance upload");
}

hz_result patch_upload(hz_renderer *r, const hz_patch *p, uint32_t count, uint32_t near, hz_err *err)
{
    return patch_upload_late(r, p, count, near, NULL, NULL, NULL, err);
}

/* The late segments, once the culling job is done: packed without the
 * hidden patches and uploaded. */
static void late_pack(hz_renderer *r)
{
    if (!r->late_job)
        return;
    r->late_wait_ms = hz_job_wait(r->late_job);
    for (uint32_t g = r->late_seg; g < r->n_seg; g++) {
        pack_segment(r, r->late_p, r->late_hidden, r->late_blocks, g);
        inst_write(r, r->seg[g], r->seg_end[g]);
    }
    r->late_job = NULL;
}

void patch_late_end(hz_renderer *r)
{
    if (r->late_job) { /* a frame that never drew its far patches: still waited for */
        late_pack(r);
        glBindBuffer(GL_ARRAY_BUFFER, 0);
    }
    r->late_p = NULL;
    r->late_hidden = NULL;
    r->late_blocks = NULL;
}

uint32_t patch_detail_split(const hz_renderer *r, const hz_patch *p, uint32_t count, const float eye[3], float dist)
{
    /* From the farthest back: the first patch from which on every patch's
     * footprint (x0.. x0 + P << shift samples, z alike) is at least dist
     * from the eye horizontally (the order is nearest first only to within
     * 3 %, so each is checked). */
    const double sp = r->spacing, d2 = (double)dist * dist;
    uint32_t k = count;
    while (k > 0) {
        const hz_patch *q = &p[k - 1];
        const double x0 = r->wrap ? (double)(int32_t)q->x0 : (double)q->x0;
        const double z0 = r->wrap ? (double)(int32_t)q->z0 : (double)q->z0;
        const double span = (double)((uint64_t)r->patch_cells << (q->shift > 30 ? 30 : q->shift));
        const double dx = fmax(fmax(x0 * sp - eye[0], eye[0] - (x0 + span) * sp), 0.0);
        const double dz = fmax(fmax(z0 * sp - eye[2], eye[2] - (z0 + span) * sp), 0.0);
        if (!(dx * dx + dz * dz >= d2))
            break;
        k--;
    }
    return k;
}

/* Binds program tp and sets its patch uniforms. */
static void patch_program(const hz_renderer *r, const prog_variant *tp)
{
    const GLint *loc = tp->loc;
    glUseProgram(tp->prog);
    glUniform1i(loc[TL_SIZE], (GLint)r->patch_cells);
    glUniform1i(loc[TL_MAP], r->streamed && r->wrap ? 0 : (GLint)r->size);
    glUniform1i(loc[TL_TILE], (GLint)r->tile_cells);
    GLint shift = 0;
    while ((2u << shift) <= r->tile_cells)
        shift++;
    glUniform1i(loc[TL_TILE_SHIFT], shift); /* in memory tile_cells is a power of two */
    glUniform1i(loc[TL_TOP], (GLint)r->tile_top);
    glUniform1iv(loc[TL_BASE], 16, r->tile_base);
}

/* One indirect command: count indices from first, instances [base, base + n). */
static void push_cmd(hz_renderer *r, size_t *nc, uint32_t count, uint32_t n, uint32_t first, uint32_t base)
{
    uint32_t *c = r->patch_cmds + 5 * (*nc)++;
    c[0] = count, c[1] = n, c[2] = first, c[3] = 0, c[4] = base;
}

/* Instances [a, b) with some hidden blocks: one indirect command per run
 * of whole patches (instanced) and per range of shown blocks of the
 * others. False when out of memory (nothing drawn). */
static bool patch_run_blocks(hz_renderer *r, uint32_t a, uint32_t b)
{
    const uint32_t B2 = r->patch_blocks * r->patch_blocks;
    /* at most one command per whole run, and B2 / 2 + 1 ranges per patch */
    const size_t need = (size_t)(b - a) * (B2 / 2 + 1) + 1;
    if (need > r->patch_cmds_cap) {
        uint32_t *c = realloc(r->patch_cmds, need * 5 * sizeof *c);
        if (!c)
            return false;
        r->patch_cmds = c;
        r->patch_cmds_cap = need;
    }
    size_t nc = 0;
    uint32_t whole = a; /* the run of whole patches so far: [whole, k) */
    for (uint32_t k = a; k < b; k++) {
        const uint16_t hid = r->inst_hidden[k];
        if (!hid)
            continue;
        if (whole < k)
            push_cmd(r, &nc, r->patch_index_count, k - whole, 0, whole);
        whole = k + 1;
        for (uint32_t m = 0; m < B2;) {
            if (hid >> r->block_morton[m] & 1u) {
                m++;
                continue;
            }
            uint32_t e = m + 1;
            while (e < B2 && !(hid >> r->block_morton[e] & 1u))
                e++;
            push_cmd(r, &nc, (e - m) * r->block_indices, 1, r->patch_index_count + m * r->block_indices, k);
            m = e;
        }
    }
    if (whole < b)
        push_cmd(r, &nc, r->patch_index_count, b - whole, 0, whole);
    if (!nc)
        return true;
    patch_attribs(r, 0); /* the commands' base instances address the instances */
    glBindBuffer(GL_DRAW_INDIRECT_BUFFER, r->patch_cmd_buf);
    glBufferData(GL_DRAW_INDIRECT_BUFFER, (GLsizeiptr)(nc * 5 * sizeof(uint32_t)), r->patch_cmds, GL_STREAM_DRAW);
    r->cmd_bytes += nc * 5 * sizeof(uint32_t);
    glMultiDrawElementsIndirect(GL_TRIANGLES, GL_UNSIGNED_SHORT, (const void *)0, (GLsizei)nc, 0);
    glBindBuffer(GL_DRAW_INDIRECT_BUFFER, 0);
    return true;
}

/* Instances [a, b) with program tp (bound when it is not the current one). */
static void patch_run(hz_renderer *r, const prog_variant *tp, const prog_variant **bound, uint32_t a, uint32_t b)
{
    if (a >= b)
        return;
    if (*bound != tp) {
        glUseProgram(tp->prog);
        *bound = tp;
    }
    if (r->any_hidden) {
        uint32_t k = a;
        while (k < b && !r->inst_hidden[k])
            k++;
        if (k < b && patch_run_blocks(r, a, b))
            return;
    }
    patch_attribs(r, a);
    glDrawElementsInstanced(GL_TRIANGLES, (GLsizei)r->patch_index_count, GL_UNSIGNED_SHORT, (const void *)0,
                            (GLsizei)(b - a));
}

void patch_draw(hz_renderer *r, const prog_variant *const prog[PATCH_CLASSES], uint32_t first, uint32_t end)
{
    if (end > r->n_inst)
        end = r->n_inst;
    if (first >= end)
        return;
    /* a class without its own program draws with the next more general one */
    const prog_variant *tp = prog[PATCH_MORPH], *use[PATCH_CLASSES];
    use[PATCH_MORPH] = tp;
    use[PATCH_MORPH_FINE] = prog[PATCH_MORPH_FINE] ? prog[PATCH_MORPH_FINE] : tp;
    use[PATCH_SIMPLE] = prog[PATCH_SIMPLE] ? prog[PATCH_SIMPLE] : tp;
    use[PATCH_SIMPLE_FINE] = prog[PATCH_SIMPLE_FINE]  ? prog[PATCH_SIMPLE_FINE]
                             : prog[PATCH_MORPH_FINE] ? use[PATCH_MORPH_FINE]
                                                      : use[PATCH_SIMPLE];
    use[PATCH_STILL] = prog[PATCH_STILL] ? prog[PATCH_STILL] : tp;
    use[PATCH_STILL_FINE] = prog[PATCH_STILL_FINE] ? prog[PATCH_STILL_FINE] : use[PATCH_STILL];
    glActiveTexture(GL_TEXTURE0 + FX_UNIT_TILES);
    glBindTexture(GL_TEXTURE_BUFFER, r->tiles_tex);
    /* each program once, tp last: bound */
    for (uint32_t c = 0; c < PATCH_CLASSES; c++) {
        bool seen = use[c] == tp;
        for (uint32_t d = 0; d < c; d++)
            seen |= use[d] == use[c];
        if (!seen)
            patch_program(r, use[c]);
    }
    patch_program(r, tp);
    const prog_variant *bound = tp;
    glBindVertexArray(r->patch_vao);
    /* Over missing data the variants clip the triangles touching it away
     * (terrain_patch_vs.glsl). */
    if (r->tile_masked)
        glEnable(GL_CLIP_DISTANCE0);
    /* llvmpipe bins a whole scene on this thread before its rasteriser
     * threads start on it. Drawn in a few chunks (nearest first), each
     * flushed, the near patches are rasterised while the far ones and the
     * rest of the frame are still being binned. A GPU does not care. */
    glBindBuffer(GL_ARRAY_BUFFER, r->patch_vbo);
    for (uint32_t g = 0; g < r->n_seg; g++) {
        /* segment g as far as it lies in [first, end), class by class */
        const uint32_t sa = r->seg[g] > first ? r->seg[g] : first, sb = r->seg[g + 1] < end ? r->seg[g + 1] : end;
        if (sa >= sb)
            continue;
        if (g >= r->late_seg)
            late_pack(r); /* (leaves the instance buffer bound) */
        for (uint32_t c = 0; c < PATCH_CLASSES; c++) {
            const uint32_t ca = r->seg_class[g][c], cb = c + 1 < PATCH_CLASSES ? r->seg_class[g][c + 1] : r->seg_end[g];
            const uint32_t a = ca > sa ? ca : sa, b = cb < sb ? cb : sb;
            if (a >= b)
                continue;
            patch_run(r, use[c], &bound, a, b);
            if (use[c]->key & FX_VARIANT_FINE)
                r->fine_patches += b - a;
        }
        if (r->seg_flush[g] && sb == r->seg[g + 1])
            glFlush(); /* at each chunk's end, the last one's too: the terrain is
                          rasterised while the sky, forest and objects are binned */
    }
    if (bound != tp)
        glUseProgram(tp->prog);
    glDisable(GL_CLIP_DISTANCE0);
    patch_attribs(r, 0);
    glBindBuffer(GL_ARRAY_BUFFER, 0);
    glBindVertexArray(r->vao);
}

void patch_destroy(hz_renderer *r)
{
    tiles_alloc(r, 0, 0, NULL);
    glDeleteVertexArrays(1, &r->patch_vao);
    glDeleteBuffers(1, &r->patch_ibo);
    glDeleteBuffers(1, &r->patch_vbo);
    glDeleteBuffers(1, &r->patch_cmd_buf);
    free(r->inst_scratch);
    free(r->inst_hidden);
    free(r->patch_cmds);
}

hz_result hz_renderer_set_stream(hz_renderer *r, const hz_pyr_info *info, uint32_t slots, uint32_t texels, hz_err *err)
{
    HZ_ASSERT(r && info);
    hz_result res = fx_check_context(r, err, "hz_renderer_set_stream");
    if (res != HZ_OK)
        return res;
    if (slots == 0 || texels < 5 || texels - 3 > 4095)
        return hz_err_set(err, HZ_ERR_VALUE, "renderer: a tile cache of %u slots of %u texels", slots, texels);
    hz_gl_drain();
    res = tiles_alloc(r, slots, texels, err);
    if (res != HZ_OK) {
        char why[sizeof err->msg];
        snprintf(why, sizeof why, "%s", err ? err->msg : "renderer: no room for the tile cache");
        return hz_err_set(err, res, "%s: lower --cache-mb", why);
    }
    r->streamed = true;
    r->wrap = info->wrap;
    r->tile_cells = texels - 3; /* a one-texel apron around each tile */
    r->tile_layers = slots;
    r->tile_top = 0;
    r->tile_masked = info->nodata > 0 || info->data_w < info->size || info->data_h < info->size;
    r->has_heights = false;
    r->size = info->size;
    r->spacing = (float)info->spacing;
    r->hscale = (float)info->h_scale;
    r->hoffset = (float)info->h_offset;
    r->hmin = (float)(info->h_offset + info->h_scale * info->h_min);
    r->hmax = (float)(info->h_offset + info->h_scale * info->h_max);
    return patch_grid(r, info->patch_cells, err);
}

hz_result hz_renderer_stream_upload(hz_renderer *r, uint32_t slot, const uint16_t *texels, hz_err *err)
{
    if (!r->streamed || slot >= r->tile_layers)
        return hz_err_set(err, HZ_ERR_VALUE, "renderer: no tile slot %u (hz_renderer_set_stream first)", slot);
    glBindBuffer(GL_TEXTURE_BUFFER, r->tiles_buf);
    tiles_write(slot, r->tile_cells + 3, texels);
    glBindBuffer(GL_TEXTURE_BUFFER, 0);
    return hz_gl_check(err, "tile upload");
}
