/* libFuzzer: --forest-file CSV (x,z,model,scale,yaw; cli_read_forest_file).
 * Trees load with finite positions on the terrain, a model below the count
 * and a scale in (0, 100], or the file is refused with a message. */
#include <math.h>
#include <string.h>

#include "cli.h"
#include "fuzz_util.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static hz_terrain *t;
    if (!t) {
        hz_err e = {0};
        t = hz_terrain_create(&(hz_terrain_desc){.generate = HZ_GEN_PERLIN, .gen_size = 33, .seed = 1}, &e);
        if (!t)
            abort();
    }
    const char *file = fuzz_tmp_file("forest.csv", data, size);
    if (!file)
        return 0;
    hz_forest_tree *trees = NULL;
    uint32_t n = 0;
    hz_err err = {0};
    const uint32_t models = 3;
    if (!cli_read_forest_file(file, t, models, &trees, &n, &err)) {
        if (!err.msg[0] || trees)
            abort();
        unlink(file);
        return 0;
    }
    for (uint32_t k = 0; k < n; k++) {
        const hz_forest_tree *q = &trees[k];
        if (!isfinite(q->pos[0]) || !isfinite(q->pos[1]) || !isfinite(q->pos[2]) || !isfinite(q->yaw) ||
            q->model >= models || !(q->scale > 0 && q->scale <= 100))
            abort();
    }
    free(trees);
    unlink(file);
    return 0;
}
