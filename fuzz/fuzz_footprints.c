/* libFuzzer: vector building footprints (hz_city_load_footprints: OGR, our
 * ring cleaning, extrusion and triangulation) and their placement into a
 * scene graph. The first byte picks the file name, so the format OGR
 * detects: GeoJSON, CSV with a WKT column, KML or GML. A file loads with
 * every triangle's vertices in range and finite coordinates, or it is
 * refused with a message. */
#include <math.h>
#include <string.h>

#include "fuzz_util.h"
#include "horizon/city.h"

static float flat(void *user, float x, float z)
{
    (void)user;
    return 0.01f * x - 0.02f * z;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static const char *const names[] = {"f.geojson", "f.csv", "f.kml", "f.gml"};
    if (size < 1)
        return 0;
    const char *path = fuzz_tmp_file(names[data[0] % 4], data + 1, size - 1);
    if (!path)
        return 0;
    hz_err err = {0};
    hz_city *c = hz_city_load_footprints(path, NULL, &err);
    if (!c) {
        if (!err.msg[0])
            abort();
        unlink(path);
        return 0;
    }
    for (uint32_t t = 0; t < 3 * c->tri_count; t++)
        if (c->tris[t] >= c->vert_count)
            abort();
    for (uint32_t t = 0; t < c->tri_count; t++)
        if (c->tri_kind[t] >= HZ_SURF_KINDS)
            abort();
    for (uint32_t v = 0; v < 3 * c->vert_count; v++)
        if (!isfinite(c->verts[v]))
            abort();
    hz_scene *s = hz_scene_create(NULL);
    hz_city_placed pl;
    hz_city_place p = {.origin = {c->extent[0], c->extent[4]}, .ground = flat};
    if (hz_city_to_scene(c, s, &p, &pl, &err) != HZ_OK) {
        if (!err.msg[0])
            abort();
    } else {
        hz_scene_update(s);
    }
    hz_scene_destroy(s);
    hz_city_destroy(c);
    unlink(path);
    return 0;
}
