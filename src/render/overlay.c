/* Overlay for the interactive window: HUD text, 2D panels, world-space debug
 * lines and coloured triangles, in one small GL program (see window.h).
 *
 * Everything is queued on the CPU as positions (3 floats) + colours (RGBA8)
 * and streamed each frame. World-space geometry uses the renderer's depth
 * convention (reverse-Z projection, glClipControl ZERO_TO_ONE when present,
 * depth 0 = far) so it is depth-tested against the terrain just drawn. */
#include "horizon/window.h"

#include "gl_util.h"

#include <dlfcn.h>
#include <epoxy/egl.h>
#include <epoxy/gl.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* stb_easy_font is header-only with static functions; not all are used and
 * it is not written for -Wconversion. */
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wconversion"
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wsign-conversion"
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wmissing-braces"
#include <stb_easy_font.h>
#pragma GCC diagnostic pop

typedef struct vqueue {
    float *xyz;      /* 3 per vertex */
    uint8_t *rgba;   /* 4 per vertex */
    size_t count, cap; /* vertices */
} vqueue;

struct hz_overlay {
    void *ctx;        /* the context current at creation: GL names live there */
    GLuint prog, vao, vbo_pos, vbo_col;
    GLint u_viewproj, u_shade, u_override, u_alpha;
    bool clip_control;
    vqueue tris;   /* world triangles */
    vqueue lines;  /* world lines */
    vqueue flat;   /* 2D triangles in pixels (rects, text) */
    char *scratch; /* stb_easy_font output */
    size_t scratch_cap;
};

static const char *overlay_vs =
    "#version 330 core\n"
    "uniform mat4 u_viewproj;\n"
    "layout(location = 0) in vec3 a_pos;\n"
    "layout(location = 1) in vec4 a_color;\n"
    "out vec3 v_world;\n"
    "out vec4 v_color;\n"
    "void main() {\n"
    "    v_world = a_pos;\n"
    "    v_color = a_color;\n"
    "    gl_Position = u_viewproj * vec4(a_pos, 1.0);\n"
    "}\n";

static const char *overlay_fs =
    "#version 330 core\n"
    "uniform int u_shade;      // 1: light by the face normal\n"
    "uniform vec4 u_override;  // alpha > 0: use this colour\n"
    "uniform float u_alpha;    // multiplies alpha\n"
    "in vec3 v_world;\n"
    "in vec4 v_color;\n"
    "out vec4 o_color;\n"
    "void main() {\n"
    "    vec4 c = u_override.a > 0.0 ? u_override : v_color;\n"
    "    if (u_shade != 0) {\n"
    "        vec3 n = normalize(cross(dFdx(v_world), dFdy(v_world)));\n"
    "        if (n.y < 0.0) n = -n;\n"
    "        float l = 0.55 + 0.45 * max(dot(n, normalize(vec3(-0.78, 0.5, 0.36))), 0.0);\n"
    "        c.rgb *= l;\n"
    "    }\n"
    "    o_color = vec4(c.rgb, c.a * u_alpha);\n"
    "}\n";

hz_overlay *hz_overlay_create(hz_err *err)
{
    void *ctx = hz_gl_current_context();
    if (!ctx) {
        hz_err_set(err, HZ_ERR_GL, "overlay: no current OpenGL context");
        return NULL;
    }
    hz_overlay *o = calloc(1, sizeof *o);
    if (!o) {
        hz_err_set(err, HZ_ERR_MEMORY, "out of memory");
        return NULL;
    }
    o->ctx = ctx;
    while (glGetError() != GL_NO_ERROR) {
    }
    o->clip_control = epoxy_gl_version() >= 45 || epoxy_has_gl_extension("GL_ARB_clip_control");
    o->prog = hz_gl_program(overlay_vs, overlay_fs, "overlay", err);
    if (!o->prog)
        goto fail;
    o->u_viewproj = glGetUniformLocation(o->prog, "u_viewproj");
    o->u_shade = glGetUniformLocation(o->prog, "u_shade");
    o->u_override = glGetUniformLocation(o->prog, "u_override");
    o->u_alpha = glGetUniformLocation(o->prog, "u_alpha");

    glGenVertexArrays(1, &o->vao);
    glGenBuffers(1, &o->vbo_pos);
    glGenBuffers(1, &o->vbo_col);
    glBindVertexArray(o->vao);
    glBindBuffer(GL_ARRAY_BUFFER, o->vbo_pos);
    glEnableVertexAttribArray(0);
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 0, (const void *)0);
    glBindBuffer(GL_ARRAY_BUFFER, o->vbo_col);
    glEnableVertexAttribArray(1);
    glVertexAttribPointer(1, 4, GL_UNSIGNED_BYTE, GL_TRUE, 0, (const void *)0);
    glBindVertexArray(0);
    glBindBuffer(GL_ARRAY_BUFFER, 0);
    GLenum e = glGetError();
    if (e != GL_NO_ERROR) {
        hz_err_set(err, HZ_ERR_GL, "overlay: GL setup failed (0x%04x)", (unsigned)e);
        goto fail;
    }
    return o;

fail:
    hz_overlay_destroy(o);
    return NULL;
}

void hz_overlay_destroy(hz_overlay *o)
{
    if (!o)
        return;
    /* In another context (or none) our names mean nothing: they die with
     * their own context. */
    if (hz_gl_current_context() == o->ctx) {
        glDeleteProgram(o->prog);
        glDeleteVertexArrays(1, &o->vao);
        glDeleteBuffers(1, &o->vbo_pos);
        glDeleteBuffers(1, &o->vbo_col);
    }
    vqueue *qs[3] = {&o->tris, &o->lines, &o->flat};
    for (int k = 0; k < 3; k++) {
        free(qs[k]->xyz);
        free(qs[k]->rgba);
    }
    free(o->scratch);
    free(o);
}

/* Makes room for n more vertices; false when out of memory. */
static bool reserve(vqueue *q, size_t n)
{
    if (q->count + n <= q->cap)
        return true;
    size_t cap = q->cap ? q->cap : 1024;
    while (cap < q->count + n)
        cap *= 2;
    float *xyz = realloc(q->xyz, cap * 3 * sizeof *xyz);
    if (!xyz)
        return false;
    q->xyz = xyz;
    uint8_t *rgba = realloc(q->rgba, cap * 4);
    if (!rgba)
        return false;
    q->rgba = rgba;
    q->cap = cap;
    return true;
}

static uint8_t to_u8(float v)
{
    v = v < 0.0f ? 0.0f : v > 1.0f ? 1.0f : v;
    return (uint8_t)lroundf(v * 255.0f);
}

static void push(vqueue *q, float x, float y, float z, const uint8_t c[4])
{
    float *p = q->xyz + 3 * q->count;
    p[0] = x;
    p[1] = y;
    p[2] = z;
    memcpy(q->rgba + 4 * q->count, c, 4);
    q->count++;
}

static void rgba8(const float rgba[4], uint8_t c[4])
{
    for (int k = 0; k < 4; k++)
        c[k] = to_u8(rgba[k]);
}

void hz_overlay_rect(hz_overlay *o, float x, float y, float w, float h, const float rgba[4])
{
    if (!reserve(&o->flat, 6))
        return;
    uint8_t c[4];
    rgba8(rgba, c);
    push(&o->flat, x, y, 0, c);
    push(&o->flat, x + w, y, 0, c);
    push(&o->flat, x + w, y + h, 0, c);
    push(&o->flat, x, y, 0, c);
    push(&o->flat, x + w, y + h, 0, c);
    push(&o->flat, x, y + h, 0, c);
}

/* stb_easy_font only knows printable ASCII. */
static char *sanitise(const char *text)
{
    size_t n = strlen(text);
    char *s = malloc(n + 1);
    if (!s)
        return NULL;
    for (size_t i = 0; i < n; i++) {
        unsigned char ch = (unsigned char)text[i];
        s[i] = ch == '\n' || (ch >= 32 && ch < 127) ? (char)ch : '?';
    }
    s[n] = 0;
    return s;
}

void hz_overlay_text(hz_overlay *o, float x, float y, float scale, const float rgba[4], const char *text)
{
    if (!text || !text[0])
        return;
    char *s = sanitise(text);
    if (!s)
        return;
    /* ~270 bytes per character on average; leave room for the worst. */
    size_t need = strlen(s) * 640 + 64;
    if (need > (size_t)INT_MAX) {
        free(s);
        return;
    }
    if (need > o->scratch_cap) {
        char *p = realloc(o->scratch, need);
        if (!p) {
            free(s);
            return;
        }
        o->scratch = p;
        o->scratch_cap = need;
    }
    int quads = stb_easy_font_print(0.0f, 0.0f, s, NULL, o->scratch, (int)need);
    free(s);
    if (quads <= 0 || !reserve(&o->flat, (size_t)quads * 6))
        return;
    uint8_t c[4];
    rgba8(rgba, c);
    static const int corner[6] = {0, 1, 2, 0, 2, 3};
    for (int q = 0; q < quads; q++) {
        const char *quad = o->scratch + (size_t)q * 64;
        for (int k = 0; k < 6; k++) {
            float v[2];
            memcpy(v, quad + corner[k] * 16, sizeof v);
            push(&o->flat, x + v[0] * scale, y + v[1] * scale, 0, c);
        }
    }
}

void hz_overlay_text_size(const char *text, float scale, float *width, float *height)
{
    char *s = text ? sanitise(text) : NULL;
    float w = 0, h = 0;
    if (s) {
        w = (float)stb_easy_font_width(s) * scale;
        h = (float)stb_easy_font_height(s) * scale;
    }
    free(s);
    if (width)
        *width = w;
    if (height)
        *height = h;
}

void hz_overlay_line(hz_overlay *o, const vec3 a, const vec3 b, const float rgba[4])
{
    if (!reserve(&o->lines, 2))
        return;
    uint8_t c[4];
    rgba8(rgba, c);
    push(&o->lines, a[0], a[1], a[2], c);
    push(&o->lines, b[0], b[1], b[2], c);
}

void hz_overlay_box(hz_overlay *o, const vec3 box[2], const float rgba[4])
{
    if (!reserve(&o->lines, 24))
        return;
    uint8_t c[4];
    rgba8(rgba, c);
    /* Corner k has x from bit 0, y from bit 1, z from bit 2. */
    static const int edges[12][2] = {{0, 1}, {2, 3}, {4, 5}, {6, 7}, {0, 2}, {1, 3},
                                     {4, 6}, {5, 7}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};
    for (int e = 0; e < 12; e++)
        for (int k = 0; k < 2; k++) {
            int v = edges[e][k];
            push(&o->lines, box[v & 1][0], box[(v >> 1) & 1][1], box[(v >> 2) & 1][2], c);
        }
}

void hz_overlay_frustum(hz_overlay *o, const hz_camera *cam, const float rgba[4])
{
    const float fov = glm_rad(cam->fov_y > 0 ? cam->fov_y : 60.0f);
    const float aspect = cam->aspect > 0 ? cam->aspect : 16.0f / 9.0f;
    const float zn = cam->znear > 0 ? cam->znear : 1.0f, zf = cam->zfar > 0 ? cam->zfar : 100000.0f;
    vec3 f, r, u, up = {0, 1, 0};
    hz_camera_forward(cam, f);
    glm_vec3_crossn(f, up, r);
    glm_vec3_cross(r, f, u);
    vec3 corner[2][4];
    const float dist[2] = {zn, zf};
    for (int p = 0; p < 2; p++) {
        float hh = tanf(fov * 0.5f) * dist[p], hw = hh * aspect;
        for (int k = 0; k < 4; k++) {
            float sx = (k == 1 || k == 2) ? 1.0f : -1.0f, sy = k >= 2 ? 1.0f : -1.0f;
            for (int a = 0; a < 3; a++)
                corner[p][k][a] = cam->pos[a] + f[a] * dist[p] + r[a] * sx * hw + u[a] * sy * hh;
        }
    }
    for (int p = 0; p < 2; p++)
        for (int k = 0; k < 4; k++)
            hz_overlay_line(o, corner[p][k], corner[p][(k + 1) % 4], rgba);
    for (int k = 0; k < 4; k++) {
        hz_overlay_line(o, corner[0][k], corner[1][k], rgba);
        /* From the eye too, so a far frustum still shows where it starts. */
        hz_overlay_line(o, cam->pos, corner[0][k], rgba);
    }
}

bool hz_overlay_triangles(hz_overlay *o, size_t n, float **xyz, uint8_t **rgba)
{
    if (n > SIZE_MAX / 64 || !reserve(&o->tris, 3 * n))
        return false;
    *xyz = o->tris.xyz + 3 * o->tris.count;
    *rgba = o->tris.rgba + 4 * o->tris.count;
    o->tris.count += 3 * n;
    return true;
}

size_t hz_overlay_queued_bytes(const hz_overlay *o)
{
    return (o->tris.count + o->lines.count + o->flat.count) * 16;
}

static void upload(const hz_overlay *o, const vqueue *q)
{
    glBindBuffer(GL_ARRAY_BUFFER, o->vbo_pos);
    glBufferData(GL_ARRAY_BUFFER, (GLsizeiptr)(q->count * 3 * sizeof(float)), q->xyz, GL_STREAM_DRAW);
    glBindBuffer(GL_ARRAY_BUFFER, o->vbo_col);
    glBufferData(GL_ARRAY_BUFFER, (GLsizeiptr)(q->count * 4), q->rgba, GL_STREAM_DRAW);
    glBindBuffer(GL_ARRAY_BUFFER, 0);
}

static void set_common(const hz_overlay *o, int shade, const float override[4], float alpha)
{
    static const float none[4] = {0, 0, 0, 0};
    glUniform1i(o->u_shade, shade);
    glUniform4fv(o->u_override, 1, override ? override : none);
    glUniform1f(o->u_alpha, alpha);
}

hz_result hz_overlay_draw(hz_overlay *o, const hz_overlay_frame *frame, hz_err *err)
{
    HZ_ASSERT(o && frame);
    hz_result res = HZ_OK;
    if (frame->width == 0 || frame->height == 0 || frame->width > INT_MAX || frame->height > INT_MAX) {
        res = hz_err_set(err, HZ_ERR_VALUE, "overlay: bad target size %ux%u", frame->width, frame->height);
        goto done;
    }
    if (hz_gl_current_context() != o->ctx) {
        res = hz_err_set(err, HZ_ERR_GL, "overlay: draw without the overlay's OpenGL context current");
        goto done;
    }
    if (!frame->cam && (o->tris.count || o->lines.count)) {
        res = hz_err_set(err, HZ_ERR_VALUE, "overlay: world-space geometry queued but no camera given");
        goto done;
    }
    while (glGetError() != GL_NO_ERROR) {
    }
    glViewport(0, 0, (GLsizei)frame->width, (GLsizei)frame->height);
    glDisable(GL_SCISSOR_TEST);
    glDisable(GL_CULL_FACE);
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    if (frame->clear) {
        glDepthMask(GL_TRUE);
        glClearColor(frame->clear_rgb[0], frame->clear_rgb[1], frame->clear_rgb[2], 1.0f);
        glClearDepth(0.0);
        glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    }
    glUseProgram(o->prog);
    glBindVertexArray(o->vao);

    if (o->tris.count || o->lines.count) {
        mat4 view, proj, vp;
        hz_camera_view(frame->cam, view);
        hz_camera_proj_reverse_z(frame->cam, proj);
        glm_mat4_mul(proj, view, vp);
        glUniformMatrix4fv(o->u_viewproj, 1, GL_FALSE, (const float *)vp);
        if (o->clip_control)
            glClipControl(GL_LOWER_LEFT, GL_ZERO_TO_ONE);
        glEnable(GL_DEPTH_TEST);

        if (o->tris.count) {
            upload(o, &o->tris);
            glDisable(GL_BLEND);
            glDepthFunc(GL_GREATER);
            glDepthMask(GL_TRUE);
            set_common(o, frame->shade_triangles, NULL, 1.0f);
            glDrawArrays(GL_TRIANGLES, 0, (GLsizei)o->tris.count);
            if (frame->wire_triangles) {
                static const float dark[4] = {0.05f, 0.05f, 0.08f, 1.0f};
                glPolygonMode(GL_FRONT_AND_BACK, GL_LINE);
                glEnable(GL_POLYGON_OFFSET_LINE);
                glPolygonOffset(1.0f, 1.0f);
                glDepthFunc(GL_GEQUAL);
                glDepthMask(GL_FALSE);
                set_common(o, 0, dark, 1.0f);
                glDrawArrays(GL_TRIANGLES, 0, (GLsizei)o->tris.count);
                glPolygonMode(GL_FRONT_AND_BACK, GL_FILL);
                glDisable(GL_POLYGON_OFFSET_LINE);
            }
        }
        if (o->lines.count) {
            upload(o, &o->lines);
            glEnable(GL_BLEND);
            glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
            glDepthMask(GL_FALSE);
            /* Visible parts solid, hidden parts faint. */
            glDepthFunc(GL_GEQUAL);
            set_common(o, 0, NULL, 1.0f);
            glDrawArrays(GL_LINES, 0, (GLsizei)o->lines.count);
            glDepthFunc(GL_LESS);
            set_common(o, 0, NULL, 0.3f);
            glDrawArrays(GL_LINES, 0, (GLsizei)o->lines.count);
        }
        glDepthMask(GL_TRUE);
        glDisable(GL_DEPTH_TEST);
        if (o->clip_control)
            glClipControl(GL_LOWER_LEFT, GL_NEGATIVE_ONE_TO_ONE);
    }

    if (o->flat.count) {
        /* Pixels, y down -> clip space. */
        mat4 ortho;
        glm_mat4_zero(ortho);
        ortho[0][0] = 2.0f / (float)frame->width;
        ortho[1][1] = -2.0f / (float)frame->height;
        ortho[2][2] = 1.0f;
        ortho[3][0] = -1.0f;
        ortho[3][1] = 1.0f;
        ortho[3][3] = 1.0f;
        glUniformMatrix4fv(o->u_viewproj, 1, GL_FALSE, (const float *)ortho);
        upload(o, &o->flat);
        glDisable(GL_DEPTH_TEST);
        glEnable(GL_BLEND);
        glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
        set_common(o, 0, NULL, 1.0f);
        glDrawArrays(GL_TRIANGLES, 0, (GLsizei)o->flat.count);
    }
    glDisable(GL_BLEND);
    glBindVertexArray(0);
    glUseProgram(0);
    GLenum e = glGetError();
    if (e != GL_NO_ERROR)
        res = hz_err_set(err, e == GL_OUT_OF_MEMORY ? HZ_ERR_MEMORY : HZ_ERR_GL, "overlay: draw failed (GL 0x%04x)",
                         (unsigned)e);
done:
    o->tris.count = o->lines.count = o->flat.count = 0;
    return res;
}
