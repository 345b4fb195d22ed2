/* GDAL's one-time setup for every reader of ours (DEMs, imagery,
 * footprints): drivers registered, and nothing written next to the user's
 * files. Reading a large .gz through /vsigzip/ would otherwise leave a
 * FILE.gz.properties (its index) beside it, in a folder that may be
 * read-only or shared. */
#include "io_internal.h"

#include <cpl_conv.h>
#include <gdal.h>

void hz_io_gdal_setup(void)
{
    CPLSetConfigOption("CPL_VSIL_GZIP_WRITE_PROPERTIES", "NO");
    GDALAllRegister();
}
