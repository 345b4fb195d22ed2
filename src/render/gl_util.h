/* Internal GL helpers shared by the render module: errors, contexts, programs. */
#ifndef HZ_GL_UTIL_H
#define HZ_GL_UTIL_H

#include <epoxy/gl.h>

#include "horizon/camera.h"
#include "horizon/core.h"

/* Compiles one shader from count source parts (lens as glShaderSource; NULL
 * = NUL-terminated). 0 + err quoting the GL log on failure. */
GLuint hz_gl_compile(GLenum type, GLsizei count, const char *const *parts, const GLint *lens, const char *name,
                     hz_err *err);
/* Links a program from two compiled shaders and deletes them (the program
 * keeps them alive); either 0 -> 0 (err already set by the compile). */
GLuint hz_gl_link(GLuint vs, GLuint fs, const char *name, hz_err *err);
/* Compiles one shader with defs (e.g. "#define X 1\n"; NULL or "" for none)
 * inserted after its #version line; the rest keeps the file's line numbers.
 * 0 + err on failure. */
GLuint hz_gl_compile_defs(GLenum type, const char *src, const char *defs, const char *name, hz_err *err);
/* Compiles and links a vertex + fragment program; 0 + err (quoting the GL
 * log) on failure. name is used in messages ("leaf" -> leaf_vs.glsl). */
GLuint hz_gl_program(const char *vs_src, const char *fs_src, const char *name, hz_err *err);
/* The same with defs (e.g. "#define X 1\n", NULL for none) inserted after
 * the #version line of both shaders: compile-time variants. llvmpipe runs
 * both sides of a branch on a uniform under a mask, so an optional path
 * that a uniform switches off still costs every fragment; a variant
 * without it does not. */
GLuint hz_gl_program_defs(const char *vs_src, const char *fs_src, const char *defs, const char *name, hz_err *err);
/* Sets the Earth curvature uniform hz_curv (shaders/curvature.glsl) of prog
 * for cam: its eye and earth_radius (0: flat; negative: a mirrored pass).
 * Programs without it are left alone. Call wherever u_viewproj is set. */
void hz_gl_set_curvature(GLuint prog, const hz_camera *cam);
/* HZ_OK, or HZ_ERR_GL naming `what` and the GL error. Clears the error flag. */
hz_result hz_gl_check(hz_err *err, const char *what);

/* A texture buffer of format fmt holding bytes of data (NULL: uninitialised;
 * 0 bytes: a 16-byte placeholder). Creates *buf and *tex when they are 0,
 * else refills them. */
void hz_gl_buffer_texture(GLuint *buf, GLuint *tex, GLenum fmt, const void *data, size_t bytes, GLenum usage);
/* Discards stale GL errors. */
void hz_gl_drain(void);
/* The current context of any API (EGL, or GLX through an already loaded
 * libGLX/libGL), NULL if none.
 * WARNING: libepoxy abort()s on any GL call without a current context, so
 * every entry point checks first. */
void *hz_gl_current_context(void);
/* Whether a GL/EGL/GLX context is current. */
bool hz_gl_has_context(void);

#endif
