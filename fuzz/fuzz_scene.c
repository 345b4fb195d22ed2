/* libFuzzer: scene files (hz_scene_file_open_memory + build). A scene is
 * refused with a message naming the file, or it builds into a scene graph
 * whose world boxes are finite. */
#include <math.h>
#include <string.h>

#include "fuzz_util.h"
#include "horizon/scene_file.h"

static float hills(void *user, float x, float z)
{
    (void)user;
    return 50.0f + 10.0f * sinf(0.01f * x) * cosf(0.013f * z);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    hz_err err = {0};
    /* Model files are not fuzzed here (assimp has its own fuzzers): only
     * names that cannot exist are reachable from the temporary folder. */
    hz_scene_file *f = hz_scene_file_open_memory((const char *)data, size, "fuzz.scene.json", "/nonexistent", NULL,
                                                 &err);
    if (!f) {
        if (!err.msg[0] || !strstr(err.msg, "fuzz.scene.json"))
            abort();
        return 0;
    }
    hz_scene *s = hz_scene_create(NULL);
    hz_scene_file_place p = {.ground = hills};
    if (hz_scene_file_build(f, s, &p, NULL, &err) != HZ_OK) {
        if (!err.msg[0])
            abort();
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
    return 0;
}
