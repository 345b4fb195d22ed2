/* libFuzzer: 3D model files, read by assimp, into horizon's two consumers of
 * them: tree import (hz_tree_import: leaf and bark meshes by name, their
 * connected pieces, leaf nodes, the tree built from them) and scene models
 * (a scene file's "models": {"m": {"file": ...}}). The input is written as
 * an .obj, the text format trees are brought in as, so assimp's OBJ reader
 * runs first and the mutations reach our conversion behind it. A model is
 * refused with a message, or it becomes a tree that validates and a scene
 * whose world boxes are finite; never a crash, a hang or a leak. */
#include <stdio.h>
#include <string.h>

#include "fuzz_scene_file.h"
#include "fuzz_util.h"
#include "horizon/tree.h"

static float flat(void *user, float x, float z)
{
    (void)user, (void)x, (void)z;
    return 10.0f;
}

static void tree(const char *path)
{
    hz_err err = {0};
    /* A small budget: the import's own check refuses what would not fit. */
    hz_tree_import_desc d = {.path = path, .max_memory = 64u << 20};
    hz_tree *t = hz_tree_import(&d, &err);
    if (!t) {
        if (!err.msg[0])
            abort(); /* a refusal names its reason */
        return;
    }
    if (hz_tree_validate(t, &err) != HZ_OK || t->leaf_count == 0)
        abort(); /* an imported tree is consistent and has leaves */
    hz_tree_destroy(t);
}

static void scene(const char *dir, const char *file)
{
    char json[1024];
    int n = snprintf(json, sizeof json,
                     "{\"horizon_scene\":1,\"models\":{\"m\":{\"file\":\"%s\"}},"
                     "\"nodes\":[{\"name\":\"a\",\"model\":\"m\",\"position\":[5,0,5],\"clamp\":\"ground\"}]}",
                     file);
    if (n <= 0 || (size_t)n >= sizeof json)
        abort();
    hz_err err = {0};
    hz_scene_file *f = hz_scene_file_open_memory(json, (size_t)n, "fuzz.scene.json", dir, NULL, &err);
    if (!f) {
        if (!err.msg[0])
            abort();
        return;
    }
    fuzz_scene_file_check(f, flat);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path = fuzz_tmp_file("model.obj", data, size);
    if (!path)
        return 0;
    tree(path);
    const char *slash = strrchr(path, '/');
    char dir[512];
    snprintf(dir, sizeof dir, "%.*s", (int)(slash - path), path);
    scene(dir, slash + 1);
    remove(path);
    return 0;
}
