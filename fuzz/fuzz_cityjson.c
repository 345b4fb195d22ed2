/* libFuzzer: CityJSON (hz_city_load_memory) and its placement into a scene
 * graph. A model loads with every triangle's vertices in range, finite
 * coordinates and known surface kinds, and places into a scene, or it is
 * refused with a message. */
#include <string.h>

#include "fuzz_util.h"
#include "fuzz_city.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    hz_err err = {0};
    hz_city *c = hz_city_load_memory((const char *)data, size, "fuzz.city.json", NULL, &err);
    if (!c) {
        if (!err.msg[0])
            abort();
        return 0;
    }
    fuzz_city_check(c);
    return 0;
}
