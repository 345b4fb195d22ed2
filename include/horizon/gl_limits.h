/* horizon GL limits the commands check before long work. */
#ifndef HORIZON_GL_LIMITS_H
#define HORIZON_GL_LIMITS_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The most heightmap samples the current GL context's renderer takes
 * (GL_MAX_TEXTURE_BUFFER_SIZE texels, at most 2^31 - 1); 0 when there is no
 * current context or the value is unknown. Needs a current context. */
uint64_t hz_gl_query_max_heightmap_samples(void);
/* The most layers of one array texture (GL_MAX_ARRAY_TEXTURE_LAYERS): the
 * tile slots a streamed terrain's cache can have; 0 when unknown. Needs a
 * current context. */
uint32_t hz_gl_query_max_tile_layers(void);

#ifdef __cplusplus
}
#endif
#endif
