/* GL limits for the commands' early checks (see horizon/gl_limits.h). */
#include "horizon/gl_limits.h"

#include <epoxy/gl.h>
#include <limits.h>

uint64_t hz_gl_query_max_heightmap_samples(void)
{
    /* The heights live in one texture buffer (renderer.c). */
    for (int k = 0; k < 16 && glGetError() != GL_NO_ERROR; k++) {
    }
    GLint v = 0;
    glGetIntegerv(GL_MAX_TEXTURE_BUFFER_SIZE, &v);
    if (glGetError() != GL_NO_ERROR || v <= 0)
        return 0;
    return (uint64_t)v < (uint64_t)INT_MAX ? (uint64_t)v : (uint64_t)INT_MAX;
}

uint32_t hz_gl_query_max_tile_layers(void)
{
    for (int k = 0; k < 16 && glGetError() != GL_NO_ERROR; k++) {
    }
    GLint v = 0;
    glGetIntegerv(GL_MAX_ARRAY_TEXTURE_LAYERS, &v);
    if (glGetError() != GL_NO_ERROR || v <= 0)
        return 0;
    return (uint32_t)v;
}
