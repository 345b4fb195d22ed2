/* libFuzzer: scene files (hz_scene_file_open_memory + build). A scene is
 * refused with a message naming the file, or it builds into a scene graph
 * whose world boxes are finite. */
#include <math.h>
#include <string.h>

#include "fuzz_scene_file.h"
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
    /* Model files are fuzzed by fuzz_model: here the scene's folder does
     * not exist, so a model file named in it cannot be read. */
    hz_scene_file *f = hz_scene_file_open_memory((const char *)data, size, "fuzz.scene.json", "/nonexistent", NULL,
                                                 &err);
    if (!f) {
        if (!err.msg[0] || !strstr(err.msg, "fuzz.scene.json"))
            abort();
        return 0;
    }
    fuzz_scene_file_check(f, hills);
    return 0;
}
