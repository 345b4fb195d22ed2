#define _POSIX_C_SOURCE 200809L
#include "horizon/core.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <time.h>
#include <unistd.h>
#include <sys/resource.h>

hz_result hz_err_set(hz_err *err, hz_result code, const char *fmt, ...)
{
    if (err) {
        err->code = code;
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err->msg, sizeof err->msg, fmt, ap);
        va_end(ap);
    }
    return code;
}

const char *hz_result_name(hz_result r)
{
    switch (r) {
    case HZ_OK: return "ok";
    case HZ_ERR_IO: return "io";
    case HZ_ERR_FORMAT: return "format";
    case HZ_ERR_VALUE: return "value";
    case HZ_ERR_MEMORY: return "memory";
    case HZ_ERR_GL: return "gl";
    case HZ_ERR_UNSUPPORTED: return "unsupported";
    }
    return "unknown";
}

void hz_progress_stderr(void *user, const char *label, uint64_t done, uint64_t total)
{
    if (!user && !isatty(STDERR_FILENO))
        return;
    if (total == 0)
        total = 1;
    int pct = (int)(done * 100 / total);
    int bar = pct * 30 / 100;
    char b[31];
    memset(b, '#', (size_t)bar);
    memset(b + bar, '.', (size_t)(30 - bar));
    b[30] = 0;
    fprintf(stderr, "\r%-24s [%s] %3d%%", label ? label : "", b, pct);
    if (done >= total)
        fputc('\n', stderr);
    fflush(stderr);
}

double hz_time_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

uint64_t hz_peak_rss_bytes(void)
{
    struct rusage ru;
    if (getrusage(RUSAGE_SELF, &ru) != 0)
        return 0;
    return (uint64_t)ru.ru_maxrss * 1024u; /* Linux: kilobytes */
}
