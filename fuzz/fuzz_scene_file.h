/* Shared by the fuzz targets that read a scene file (fuzz_scene, and
 * fuzz_model through a scene naming the model): the opened file builds into
 * a scene graph whose world boxes are finite, or fails with a message.
 * Aborts on a violation; destroys f. */
#ifndef HZ_FUZZ_SCENE_FILE_H
#define HZ_FUZZ_SCENE_FILE_H

#include <math.h>
#include <stdlib.h>

#include "horizon/scene_file.h"

static inline void fuzz_scene_file_check(hz_scene_file *f, hz_ground_fn ground)
{
    hz_err err = {0};
    hz_scene *s = hz_scene_create(NULL);
    hz_scene_file_place p = {.ground = ground};
    if (hz_scene_file_build(f, s, &p, NULL, &err) != HZ_OK) {
        if (!err.msg[0])
            abort(); /* a refusal names its reason */
    } else {
        hz_box b;
        hz_scene_bounds(s, &b);
        if (!hz_box_is_empty(&b))
            for (int k = 0; k < 3; k++)
                if (!isfinite(b.min[k]) || !isfinite(b.max[k]))
                    abort();
    }
    hz_scene_destroy(s);
    hz_scene_file_destroy(f);
}

#endif
