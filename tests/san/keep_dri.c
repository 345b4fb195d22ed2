/* Sanitizer runs only (LD_PRELOAD): keeps Mesa's DRI driver loaded for the
 * life of the process. Mesa dlcloses it when the last X display closes; a
 * leak inside it is then reported from an "<unknown module>" that no
 * suppression can name. With the driver pinned (RTLD_NODELETE) its frames
 * keep the name swrast_dri.so, which tests/san/lsan.supp suppresses. */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdlib.h>

__attribute__((constructor)) static void keep_dri(void)
{
    const char *path = getenv("HZ_SAN_KEEP_DRI");
    if (path && *path)
        (void)dlopen(path, RTLD_LAZY | RTLD_GLOBAL | RTLD_NODELETE);
}
