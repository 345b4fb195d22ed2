/* What every GDAL reader of ours shares (gdal_util.h): the one-time set-up,
 * the last error's message, and the block-size bound. */
#include "gdal_util.h"

#include <cpl_conv.h>
#include <cpl_error.h>
#include <stdint.h>

/* The largest block GDAL may read at once. */
#define MAX_BLOCK_BYTES ((uint64_t)256 << 20)

void hz_io_gdal_setup(void)
{
    /* Reading a large .gz through /vsigzip/ would otherwise leave a
     * FILE.gz.properties (its index) beside it, in a folder that may be
     * read-only or shared. */
    CPLSetConfigOption("CPL_VSIL_GZIP_WRITE_PROPERTIES", "NO");
    GDALAllRegister();
}

const char *hz_io_gdal_msg(const char *fallback)
{
    const char *m = CPLGetLastErrorMsg();
    return m && m[0] ? m : fallback;
}

hz_result hz_io_gdal_blocks_ok(GDALDatasetH ds, int bands, const char *label, hz_err *err)
{
    for (int b = 1; b <= bands && b <= GDALGetRasterCount(ds); b++) {
        GDALRasterBandH band = GDALGetRasterBand(ds, b);
        int bx = 0, by = 0;
        GDALGetBlockSize(band, &bx, &by);
        const uint64_t bytes = (uint64_t)(bx > 0 ? bx : 1) * (uint64_t)(by > 0 ? by : 1) *
                               (uint64_t)GDALGetDataTypeSizeBytes(GDALGetRasterDataType(band)) * (uint64_t)bands;
        if (bytes > MAX_BLOCK_BYTES)
            return hz_err_set(err, HZ_ERR_UNSUPPORTED,
                              "%s is stored in blocks of %d x %d samples (%.0f MB each, more than %u MB): re-tile it "
                              "(gdal_translate -co TILED=YES)",
                              label, bx, by, (double)bytes / (1 << 20), (unsigned)(MAX_BLOCK_BYTES >> 20));
    }
    return HZ_OK;
}
