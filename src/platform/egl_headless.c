/* Headless OpenGL through EGL on Mesa's surfaceless platform: no window, no
 * GPU needed (llvmpipe), no surface at all (EGL_KHR_surfaceless_context), so
 * the renderer draws into its own FBO. */
#include "horizon/render.h"

#include <epoxy/egl.h>
#include <epoxy/gl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct hz_gl {
    EGLDisplay dpy;
    EGLContext ctx;
    int major, minor; /* the version we asked for and got */
    char desc[256];
};

static const char *egl_error_name(EGLint e)
{
    switch (e) {
    case EGL_SUCCESS: return "EGL_SUCCESS";
    case EGL_NOT_INITIALIZED: return "EGL_NOT_INITIALIZED";
    case EGL_BAD_ACCESS: return "EGL_BAD_ACCESS";
    case EGL_BAD_ALLOC: return "EGL_BAD_ALLOC";
    case EGL_BAD_ATTRIBUTE: return "EGL_BAD_ATTRIBUTE";
    case EGL_BAD_CONFIG: return "EGL_BAD_CONFIG";
    case EGL_BAD_CONTEXT: return "EGL_BAD_CONTEXT";
    case EGL_BAD_CURRENT_SURFACE: return "EGL_BAD_CURRENT_SURFACE";
    case EGL_BAD_DISPLAY: return "EGL_BAD_DISPLAY";
    case EGL_BAD_MATCH: return "EGL_BAD_MATCH";
    case EGL_BAD_NATIVE_PIXMAP: return "EGL_BAD_NATIVE_PIXMAP";
    case EGL_BAD_NATIVE_WINDOW: return "EGL_BAD_NATIVE_WINDOW";
    case EGL_BAD_PARAMETER: return "EGL_BAD_PARAMETER";
    case EGL_BAD_SURFACE: return "EGL_BAD_SURFACE";
    case EGL_CONTEXT_LOST: return "EGL_CONTEXT_LOST";
    }
    return "unknown EGL error";
}

static hz_result egl_fail(hz_err *err, const char *what)
{
    EGLint e = eglGetError();
    return hz_err_set(err, HZ_ERR_GL, "EGL: %s failed (%s, 0x%04x)", what, egl_error_name(e), (unsigned)e);
}

static EGLContext create_context(EGLDisplay dpy, EGLConfig cfg, int major, int minor)
{
    const EGLint attrs[] = {
        EGL_CONTEXT_MAJOR_VERSION_KHR, major,
        EGL_CONTEXT_MINOR_VERSION_KHR, minor,
        EGL_CONTEXT_OPENGL_PROFILE_MASK_KHR, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT_KHR,
        EGL_NONE,
    };
    return eglCreateContext(dpy, cfg, EGL_NO_CONTEXT, attrs);
}

hz_gl *hz_gl_create_headless(hz_err *err)
{
    /* Client extensions (queried without a display). */
    if (!epoxy_has_egl_extension(EGL_NO_DISPLAY, "EGL_EXT_platform_base") ||
        !epoxy_has_egl_extension(EGL_NO_DISPLAY, "EGL_MESA_platform_surfaceless")) {
        const char *ext = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
        hz_err_set(err, HZ_ERR_GL,
                   "EGL: no surfaceless platform (need EGL_EXT_platform_base and "
                   "EGL_MESA_platform_surfaceless; is Mesa's libegl-mesa0 installed?). "
                   "Client extensions: %s",
                   ext && *ext ? ext : "(none)");
        return NULL;
    }

    hz_gl *gl = calloc(1, sizeof *gl);
    if (!gl) {
        hz_err_set(err, HZ_ERR_MEMORY, "out of memory");
        return NULL;
    }
    gl->dpy = EGL_NO_DISPLAY;
    gl->ctx = EGL_NO_CONTEXT;

    gl->dpy = eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, NULL);
    if (gl->dpy == EGL_NO_DISPLAY) {
        egl_fail(err, "eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA) returned no display;");
        goto fail;
    }
    EGLint emaj = 0, emin = 0;
    if (!eglInitialize(gl->dpy, &emaj, &emin)) {
        egl_fail(err, "eglInitialize on the surfaceless display (no usable Mesa driver?)");
        gl->dpy = EGL_NO_DISPLAY;
        goto fail;
    }
    if (!epoxy_has_egl_extension(gl->dpy, "EGL_KHR_surfaceless_context")) {
        hz_err_set(err, HZ_ERR_GL, "EGL %d.%d: display lacks EGL_KHR_surfaceless_context", emaj, emin);
        goto fail;
    }
    if (emaj * 10 + emin < 15 && !epoxy_has_egl_extension(gl->dpy, "EGL_KHR_create_context")) {
        hz_err_set(err, HZ_ERR_GL, "EGL %d.%d: cannot request a GL version (no EGL 1.5, no EGL_KHR_create_context)",
                   emaj, emin);
        goto fail;
    }
    if (!eglBindAPI(EGL_OPENGL_API)) {
        egl_fail(err, "eglBindAPI(EGL_OPENGL_API) (desktop OpenGL not supported by this EGL)");
        goto fail;
    }

    const EGLint cfg_attrs[] = {
        EGL_SURFACE_TYPE, EGL_PBUFFER_BIT,
        EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT,
        EGL_RED_SIZE, 8, EGL_GREEN_SIZE, 8, EGL_BLUE_SIZE, 8,
        EGL_NONE,
    };
    EGLConfig cfg = NULL;
    EGLint ncfg = 0;
    if (!eglChooseConfig(gl->dpy, cfg_attrs, &cfg, 1, &ncfg) || ncfg < 1) {
        /* We never make a surface, so a config-less context is as good. */
        if (!epoxy_has_egl_extension(gl->dpy, "EGL_KHR_no_config_context")) {
            hz_err_set(err, HZ_ERR_GL, "EGL: no config with EGL_OPENGL_BIT and no EGL_KHR_no_config_context");
            goto fail;
        }
        cfg = EGL_NO_CONFIG_KHR;
    }

    /* 4.5 core is what we target; 3.3 core still runs the shaders (the
     * renderer then works without glClipControl, see renderer.c). */
    static const int versions[][2] = {{4, 5}, {3, 3}};
    EGLint last_error = EGL_SUCCESS;
    for (size_t k = 0; k < sizeof versions / sizeof versions[0] && gl->ctx == EGL_NO_CONTEXT; k++) {
        gl->ctx = create_context(gl->dpy, cfg, versions[k][0], versions[k][1]);
        if (gl->ctx != EGL_NO_CONTEXT) {
            gl->major = versions[k][0];
            gl->minor = versions[k][1];
        } else {
            last_error = eglGetError();
        }
    }
    if (gl->ctx == EGL_NO_CONTEXT) {
        hz_err_set(err, HZ_ERR_GL, "EGL: eglCreateContext refused OpenGL 4.5 core and 3.3 core (%s, 0x%04x)",
                   egl_error_name(last_error), (unsigned)last_error);
        goto fail;
    }
    if (!eglMakeCurrent(gl->dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, gl->ctx)) {
        egl_fail(err, "eglMakeCurrent (surfaceless)");
        goto fail;
    }

    const char *renderer = (const char *)glGetString(GL_RENDERER);
    const char *version = (const char *)glGetString(GL_VERSION);
    if (!renderer || !version) {
        hz_err_set(err, HZ_ERR_GL, "GL: context is current but glGetString returned NULL (GL error 0x%04x)",
                   (unsigned)glGetError());
        goto fail;
    }
    snprintf(gl->desc, sizeof gl->desc, "%s | %s", renderer, version);
    return gl;

fail:
    hz_gl_destroy(gl);
    return NULL;
}

void hz_gl_destroy(hz_gl *gl)
{
    if (!gl)
        return;
    if (gl->dpy != EGL_NO_DISPLAY) {
        if (gl->ctx != EGL_NO_CONTEXT) {
            if (eglGetCurrentContext() == gl->ctx)
                eglMakeCurrent(gl->dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
            eglDestroyContext(gl->dpy, gl->ctx);
        }
        /* NOTE: no eglTerminate, on purpose. EGL hands the same display to
         * every caller in the process, and terminating it kills every context
         * on it, including other live hz_gl objects (Mesa 22 lacks
         * EGL_KHR_display_reference); it also unloads the driver, which makes
         * LeakSanitizer report the driver's still-referenced allocations.
         * Re-initialising an initialised display is a no-op, so the display
         * simply lives until the process exits. */
    }
    free(gl);
}

const char *hz_gl_describe(const hz_gl *gl)
{
    return gl ? gl->desc : "(no GL context)";
}
