/* libFuzzer: .hzt tree files (hz_tree_load_mem). A file is refused with a
 * message or loads into a tree that validates; never a crash or a leak. */
#include <string.h>

#include "fuzz_util.h"
#include "horizon/tree.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    hz_err err = {0};
    hz_tree *t = hz_tree_load_mem(data, size, &err);
    if (!t) {
        if (!err.msg[0])
            abort(); /* a refusal names its reason */
        return 0;
    }
    if (hz_tree_validate(t, &err) != HZ_OK)
        abort(); /* a loaded tree is consistent */
    /* What was loaded saves and loads again. */
    uint8_t *buf = NULL;
    size_t n = 0;
    if (hz_tree_save_mem(t, &buf, &n, &err) != HZ_OK)
        abort();
    hz_tree *u = hz_tree_load_mem(buf, n, &err);
    if (!u || u->leaf_count != t->leaf_count || u->branch_count != t->branch_count)
        abort();
    hz_tree_destroy(u);
    free(buf);
    hz_tree_destroy(t);
    return 0;
}
