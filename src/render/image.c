/* PNG output for read-back frames (stb_image_write, implemented here). */
#include "horizon/render.h"

#include <errno.h>
#include <string.h>

/* stb is third-party code: keep the project's strict warnings out of it. */
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wconversion"
#pragma GCC diagnostic ignored "-Wsign-conversion"
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wstrict-prototypes"
#pragma GCC diagnostic ignored "-Wunused-parameter"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wunused-function"
#define STB_IMAGE_WRITE_STATIC
#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb_image_write.h>
#pragma GCC diagnostic pop

hz_result hz_image_write_png(const char *path, const uint8_t *rgb, uint32_t width,
                             uint32_t height, hz_err *err)
{
    HZ_ASSERT(path && rgb);
    if (width == 0 || height == 0 || width > 65535u || height > 65535u)
        return hz_err_set(err, HZ_ERR_VALUE, "PNG %s: bad size %ux%u", path, width, height);
    errno = 0;
    if (!stbi_write_png(path, (int)width, (int)height, 3, rgb, (int)(width * 3u))) {
        int e = errno;
        return hz_err_set(err, HZ_ERR_IO, "cannot write PNG %s: %s", path,
                          e ? strerror(e) : "stb_image_write failed");
    }
    return HZ_OK;
}
