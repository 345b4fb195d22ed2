/* libFuzzer: draped imagery (hz_imagery_load: GDAL opens the image, warps it
 * onto a terrain footprint in EPSG:32632, and it is cut into tiles and an
 * overview). The first byte picks the format: GeoTIFF, or PNG / JPEG with a
 * world file; for those the second byte is the length of the world file's
 * text that follows, the rest is the image. An image loads with textures of
 * the promised sizes and a coverage in [0, 1], or it is refused with a
 * message, within the memory bound. */
#include <math.h>
#include <string.h>

#include "fuzz_util.h"
#include "horizon/imagery.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static const char *const names[] = {"f.tif", "f.png", "f.jpg"};
    static const char *const worlds[] = {NULL, "f.pgw", "f.jgw"};
    static hz_georef *geo;
    if (!geo) {
        /* 65 samples 10 m apart, sample (0, 0) centred at (500000, 5200000) */
        const double gt[6] = {499995.0, 10.0, 0, 5200005.0, 0, -10.0};
        geo = hz_georef_create("EPSG:32632", gt, 65, 65, NULL);
        if (!geo)
            abort();
    }
    if (size < 1)
        return 0;
    const int k = data[0] % 3;
    data++, size--;
    char world[512] = "";
    if (worlds[k]) {
        if (size < 1)
            return 0;
        size_t n = data[0];
        if (n > size - 1)
            n = size - 1;
        const char *wp = fuzz_tmp_file(worlds[k], data + 1, n);
        if (!wp)
            return 0;
        snprintf(world, sizeof world, "%s", wp);
        data += 1 + n, size -= 1 + n;
    }
    const char *path = fuzz_tmp_file(names[k], data, size);
    if (!path)
        return 0;
    hz_imagery_desc d = {.path = path, .target = geo, .samples = 65, .spacing = 10.0, .max_side = 2048,
                         .max_bytes = (uint64_t)64 << 20};
    hz_imagery im;
    hz_err err = {0};
    if (hz_imagery_load(&d, &im, &err) != HZ_OK) {
        if (!err.msg[0])
            abort();
    } else {
        if (im.side == 0 || im.side > d.max_side || !im.overview_rgba || im.overview_side == 0)
            abort();
        if (im.tiles && (!im.tile_rgba || (uint64_t)im.tiles * im.tile < im.side))
            abort();
        if (!(im.coverage >= 0 && im.coverage <= 1))
            abort();
        hz_imagery_free(&im);
    }
    unlink(path);
    if (world[0])
        unlink(world);
    return 0;
}
