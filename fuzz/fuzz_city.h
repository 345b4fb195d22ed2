/* Shared by the fuzz targets whose parsers make a hz_city (CityJSON, vector
 * footprints): the model's invariants, then its placement into a scene
 * graph, which must succeed or fail with a message. Aborts on a violation;
 * destroys c. */
#ifndef HZ_FUZZ_CITY_H
#define HZ_FUZZ_CITY_H

#include <math.h>
#include <stdlib.h>

#include "horizon/city.h"

static float fuzz_city_ground(void *user, float x, float z)
{
    (void)user;
    return 0.01f * x - 0.02f * z;
}

static inline void fuzz_city_check(hz_city *c)
{
    for (uint32_t t = 0; t < 3 * c->tri_count; t++)
        if (c->tris[t] >= c->vert_count)
            abort();
    for (uint32_t t = 0; t < c->tri_count; t++)
        if (c->tri_kind[t] >= HZ_SURF_KINDS)
            abort();
    for (uint32_t v = 0; v < 3 * c->vert_count; v++)
        if (!isfinite(c->verts[v]))
            abort();
    hz_err err = {0};
    hz_scene *s = hz_scene_create(NULL);
    hz_city_placed pl;
    hz_city_place p = {.origin = {c->extent[0], c->extent[4]}, .ground = fuzz_city_ground};
    if (hz_city_to_scene(c, s, &p, &pl, &err) != HZ_OK) {
        if (!err.msg[0])
            abort();
    } else {
        hz_scene_update(s);
    }
    hz_scene_destroy(s);
    hz_city_destroy(c);
}

#endif
