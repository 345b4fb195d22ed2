#define _POSIX_C_SOURCE 200809L
#include "horizon/core.h"

#include <pthread.h>
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

/* A task reports its first line after this long, then every LINE_PCT
 * percent or LINE_MS, whichever first. */
#define LINE_AFTER_MS 2000.0
#define LINE_MS 10000.0
#define LINE_PCT 10

bool hz_progress_line(hz_progress_lines *st, FILE *f, const char *label, uint64_t done, uint64_t total,
                      double now_ms)
{
    if (!label)
        label = "";
    if (total == 0)
        total = 1;
    if (done > total)
        done = total;
    if (strncmp(st->label, label, sizeof st->label - 1) || done < st->last_done || st->start_ms == 0) {
        memset(st, 0, sizeof *st); /* a new task */
        snprintf(st->label, sizeof st->label, "%s", label);
        st->start_ms = now_ms > 0 ? now_ms : 1e-9;
    }
    st->last_done = done;
    const int pct = (int)(done * 100 / total);
    bool say;
    if (st->finished)
        say = false;
    else if (st->line_ms == 0) /* nothing said yet: quiet for short work */
        say = now_ms - st->start_ms >= LINE_AFTER_MS;
    else
        say = pct >= st->line_pct + LINE_PCT || now_ms - st->line_ms >= LINE_MS || done == total;
    if (!say)
        return false;
    fprintf(f, "horizon: %s: %d%% (%llu/%llu)\n", label, pct, (unsigned long long)done, (unsigned long long)total);
    fflush(f);
    st->line_ms = now_ms > 0 ? now_ms : 1e-9;
    st->line_pct = pct;
    st->finished = done == total;
    return true;
}

void hz_progress_stderr(void *user, const char *label, uint64_t done, uint64_t total)
{
    if (!isatty(STDERR_FILENO)) {
        /* stderr is one per process: so is the state of its lines */
        static pthread_mutex_t lock = PTHREAD_MUTEX_INITIALIZER;
        static hz_progress_lines shared;
        pthread_mutex_lock(&lock);
        hz_progress_line(user ? user : &shared, stderr, label, done, total, hz_time_ms());
        pthread_mutex_unlock(&lock);
        return;
    }
    if (total == 0)
        total = 1;
    int pct = (int)(done * 100 / total);
    pct = pct > 100 ? 100 : pct;
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

static void *job_main(void *p)
{
    hz_job *job = p;
    job->fn(job->arg);
    return NULL;
}

bool hz_job_start(hz_job *job, void (*fn)(void *arg), void *arg)
{
    HZ_ASSERT(job && fn);
    hz_job_wait(job);
    job->fn = fn;
    job->arg = arg;
    if (pthread_create(&job->thread, NULL, job_main, job) == 0) {
        job->running = true;
        return true;
    }
    fn(arg);
    return false;
}

double hz_job_wait(hz_job *job)
{
    if (!job || !job->running)
        return 0.0;
    const double t0 = hz_time_ms();
    pthread_join(job->thread, NULL);
    job->running = false;
    return hz_time_ms() - t0;
}

uint64_t hz_peak_rss_bytes(void)
{
    struct rusage ru;
    if (getrusage(RUSAGE_SELF, &ru) != 0)
        return 0;
    return (uint64_t)ru.ru_maxrss * 1024u; /* Linux: kilobytes */
}
