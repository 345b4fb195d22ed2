/* libFuzzer: .hzt tree files (hz_tree_load_mem). Each input is loaded as it
 * is and once more with its last 4 bytes replaced by the right CRC-32, so
 * mutations reach the parser behind the checksum. A file is refused with a
 * message, or loads into a tree that validates and saves and loads again
 * the same; never a crash or a leak. */
#include <string.h>

#include "fuzz_util.h"
#include "horizon/tree.h"

static void check(const uint8_t *data, size_t size)
{
    hz_err err = {0};
    hz_tree *t = hz_tree_load_mem(data, size, &err);
    if (!t) {
        if (!err.msg[0])
            abort(); /* a refusal names its reason */
        return;
    }
    if (hz_tree_validate(t, &err) != HZ_OK)
        abort(); /* a loaded tree is consistent */
    uint8_t *buf = NULL;
    size_t n = 0;
    if (hz_tree_save_mem(t, &buf, &n, &err) != HZ_OK)
        abort();
    hz_tree *u = hz_tree_load_mem(buf, n, &err);
    if (!u || u->leaf_count != t->leaf_count || u->branch_count != t->branch_count ||
        u->bark.index_count != t->bark.index_count || u->hull.index_count != t->hull.index_count)
        abort();
    hz_tree_destroy(u);
    free(buf);
    hz_tree_destroy(t);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    check(data, size);
    if (size < 8)
        return 0;
    uint8_t *c = malloc(size);
    if (!c)
        return 0;
    memcpy(c, data, size);
    uint32_t crc = hz_tree_crc32(c, size - 4);
    for (int k = 0; k < 4; k++)
        c[size - 4 + k] = (uint8_t)(crc >> (8 * k));
    if (memcmp(c, data, size))
        check(c, size);
    free(c);
    return 0;
}
