/* libFuzzer: horizon view's input script (view_script_load). A script loads
 * into events sorted by frame with known kinds and finite values, or is
 * refused with a message; nothing crashes or leaks. */
#include <math.h>
#include <string.h>

#include "fuzz_util.h"
#include "view_input.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *file = fuzz_tmp_file("view.script", data, size);
    if (!file)
        return 0;
    script s = {0};
    const float dt = size % 3 == 0 ? 1.0f / 30.0f : size % 3 == 1 ? 1e-4f : 10.0f;
    int rc = view_script_load(file, dt, &s);
    if (rc == 0) {
        for (size_t k = 0; k < s.count; k++) {
            const script_event *e = &s.ev[k];
            if ((unsigned)e->kind > EV_QUIT || (k && e->frame < s.ev[k - 1].frame) || e->frame > 100000001u)
                abort();
            for (int c = 0; c < 5; c++)
                if (!isfinite(e->v[c]))
                    abort();
            if (e->kind == EV_SCREENSHOT && (!e->file || !e->file[0]))
                abort();
        }
    } else if (rc != 1 && rc != 2) {
        abort();
    }
    script_free(&s);
    unlink(file);
    return 0;
}
