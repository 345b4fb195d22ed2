/* libFuzzer: vector building footprints (hz_city_load_footprints: OGR, our
 * ring cleaning, extrusion and triangulation) and their placement into a
 * scene graph. The first byte picks the file name, so the format OGR
 * detects: GeoJSON, CSV with a WKT column, KML or GML. A file loads with
 * every triangle's vertices in range and finite coordinates, or it is
 * refused with a message. */
#include <string.h>

#include "fuzz_util.h"
#include "fuzz_city.h"

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
    fuzz_city_check(c);
    unlink(path);
    return 0;
}
