/* Internal GL helpers: program building and error checks. */
#include "gl_util.h"

#include <dlfcn.h>
#include <epoxy/egl.h>
#include <stdio.h>
#include <string.h>

static const char *gl_error_name(GLenum e)
{
    switch (e) {
    case GL_NO_ERROR: return "GL_NO_ERROR";
    case GL_INVALID_ENUM: return "GL_INVALID_ENUM";
    case GL_INVALID_VALUE: return "GL_INVALID_VALUE";
    case GL_INVALID_OPERATION: return "GL_INVALID_OPERATION";
    case GL_INVALID_FRAMEBUFFER_OPERATION: return "GL_INVALID_FRAMEBUFFER_OPERATION";
    case GL_OUT_OF_MEMORY: return "GL_OUT_OF_MEMORY";
    case GL_STACK_UNDERFLOW: return "GL_STACK_UNDERFLOW";
    case GL_STACK_OVERFLOW: return "GL_STACK_OVERFLOW";
    }
    return "unknown GL error";
}

void hz_gl_drain(void)
{
    for (int k = 0; k < 16 && glGetError() != GL_NO_ERROR; k++) {
    }
}

hz_result hz_gl_check(hz_err *err, const char *what)
{
    GLenum e = glGetError();
    if (e == GL_NO_ERROR)
        return HZ_OK;
    hz_gl_drain();
    return hz_err_set(err, HZ_ERR_GL, "GL: %s failed: %s (0x%04x)", what, gl_error_name(e), (unsigned)e);
}

void *hz_gl_current_context(void)
{
    EGLContext egl = eglGetCurrentContext();
    if (egl != EGL_NO_CONTEXT)
        return egl;
    static const char *const libs[] = {"libGLX.so.0", "libGL.so.1"};
    for (size_t k = 0; k < sizeof libs / sizeof libs[0]; k++) {
        void *lib = dlopen(libs[k], RTLD_LAZY | RTLD_NOLOAD);
        if (!lib)
            continue;
        void *(*get_current)(void) = (void *(*)(void))dlsym(lib, "glXGetCurrentContext");
        void *glx = get_current ? get_current() : NULL;
        dlclose(lib);
        if (glx)
            return glx;
    }
    return NULL;
}

bool hz_gl_has_context(void)
{
    return hz_gl_current_context() != NULL;
}

/* Drops the trailing newlines and spaces of a GL info log. */
static void trim_log(char *buf)
{
    size_t n = strlen(buf);
    while (n && (buf[n - 1] == '\n' || buf[n - 1] == '\r' || buf[n - 1] == ' '))
        buf[--n] = 0;
}

GLuint hz_gl_compile(GLenum type, GLsizei count, const char *const *parts, const GLint *lens, const char *name,
                     hz_err *err)
{
    GLuint s = glCreateShader(type);
    if (!s) {
        hz_gl_check(err, "glCreateShader");
        return 0;
    }
    glShaderSource(s, count, parts, lens);
    glCompileShader(s);
    GLint ok = GL_FALSE;
    glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
    if (!ok) {
        char log[400] = "";
        glGetShaderInfoLog(s, (GLsizei)sizeof log, NULL, log);
        trim_log(log);
        hz_err_set(err, HZ_ERR_GL, "GL: shader %s failed to compile: %s", name, log[0] ? log : "(empty log)");
        glDeleteShader(s);
        return 0;
    }
    return s;
}

GLuint hz_gl_link(GLuint vs, GLuint fs, const char *name, hz_err *err)
{
    if (!vs || !fs) {
        glDeleteShader(vs);
        glDeleteShader(fs);
        return 0;
    }
    GLuint p = glCreateProgram();
    glAttachShader(p, vs);
    glAttachShader(p, fs);
    glLinkProgram(p);
    glDeleteShader(vs); /* the program keeps them alive */
    glDeleteShader(fs);
    GLint ok = GL_FALSE;
    glGetProgramiv(p, GL_LINK_STATUS, &ok);
    if (!ok) {
        char log[400] = "";
        glGetProgramInfoLog(p, (GLsizei)sizeof log, NULL, log);
        trim_log(log);
        hz_err_set(err, HZ_ERR_GL, "GL: program %s failed to link: %s", name, log[0] ? log : "(empty log)");
        glDeleteProgram(p);
        return 0;
    }
    return p;
}

void hz_gl_set_curvature(GLuint prog, const hz_camera *cam)
{
    const GLint loc = glGetUniformLocation(prog, "hz_curv");
    if (loc < 0)
        return;
    const float R = cam->earth_radius;
    glProgramUniform3f(prog, loc, cam->pos[0], cam->pos[2], R != 0.0f ? 0.5f / R : 0.0f);
}

GLuint hz_gl_program(const char *vs_src, const char *fs_src, const char *name, hz_err *err)
{
    return hz_gl_program_defs(vs_src, fs_src, NULL, name, err);
}

GLuint hz_gl_compile_defs(GLenum type, const char *src, const char *defs, const char *name, hz_err *err)
{
    if (!defs || !defs[0])
        return hz_gl_compile(type, 1, &src, NULL, name, err);
    const char *nl = strchr(src, '\n');
    if (!nl || strncmp(src, "#version", 8) != 0) {
        hz_err_set(err, HZ_ERR_GL, "GL: shader %s does not start with a #version line", name);
        return 0;
    }
    const char *parts[4] = {src, defs, "\n#line 2\n", nl + 1};
    const GLint lens[4] = {(GLint)(nl + 1 - src), -1, -1, -1};
    return hz_gl_compile(type, 4, parts, lens, name, err);
}

GLuint hz_gl_program_defs(const char *vs_src, const char *fs_src, const char *defs, const char *name, hz_err *err)
{
    char vn[64], fn[64];
    snprintf(vn, sizeof vn, "%s_vs.glsl", name);
    snprintf(fn, sizeof fn, "%s_fs.glsl", name);
    GLuint vs = hz_gl_compile_defs(GL_VERTEX_SHADER, vs_src, defs, vn, err);
    GLuint fs = vs ? hz_gl_compile_defs(GL_FRAGMENT_SHADER, fs_src, defs, fn, err) : 0;
    return hz_gl_link(vs, fs, name, err);
}

void hz_gl_buffer_texture(GLuint *buf, GLuint *tex, GLenum fmt, const void *data, size_t bytes, GLenum usage)
{
    if (!*buf)
        glGenBuffers(1, buf);
    if (!*tex)
        glGenTextures(1, tex);
    glBindBuffer(GL_TEXTURE_BUFFER, *buf);
    glBufferData(GL_TEXTURE_BUFFER, (GLsizeiptr)(bytes ? bytes : 16), bytes ? data : NULL, usage);
    glBindTexture(GL_TEXTURE_BUFFER, *tex);
    glTexBuffer(GL_TEXTURE_BUFFER, fmt, *buf);
    glBindTexture(GL_TEXTURE_BUFFER, 0);
    glBindBuffer(GL_TEXTURE_BUFFER, 0);
}
