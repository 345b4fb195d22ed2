/* libFuzzer: camera path CSV (t,x,y,z,yaw,pitch; hz_path_load_csv). A path
 * loads with finite keys in the documented range and sampling it gives a
 * finite camera, or it is refused with a message. */
#include <math.h>
#include <string.h>

#include "fuzz_util.h"
#include "horizon/path.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *file = fuzz_tmp_file("path.csv", data, size);
    if (!file)
        return 0;
    hz_path p;
    hz_err err = {0};
    if (hz_path_load_csv(file, &p, &err) != HZ_OK) {
        if (!err.msg[0])
            abort();
        unlink(file);
        return 0;
    }
    for (size_t k = 0; k < p.count; k++) {
        const hz_path_key *q = &p.keys[k];
        const float v[6] = {q->t, q->x, q->y, q->z, q->yaw, q->pitch};
        for (int c = 0; c < 6; c++)
            if (!isfinite(v[c]) || fabsf(v[c]) > 1e7f)
                abort();
    }
    const float d = hz_path_duration(&p);
    for (int s = 0; s <= 8; s++) {
        hz_camera cam = {.fov_y = 60, .aspect = 1.5f, .znear = 1, .zfar = 1000};
        hz_path_sample(&p, p.keys[0].t + d * (float)s / 8.0f, &cam);
        if (!isfinite(cam.pos[0]) || !isfinite(cam.pos[1]) || !isfinite(cam.pos[2]) || !isfinite(cam.yaw) ||
            !isfinite(cam.pitch))
            abort();
    }
    hz_path_free(&p);
    unlink(file);
    return 0;
}
