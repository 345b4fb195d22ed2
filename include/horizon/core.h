/* horizon core: result codes, error messages, timing, progress, memory.
 * No GL, no globals. */
#ifndef HORIZON_CORE_H
#define HORIZON_CORE_H

#include <stddef.h>
#include <stdint.h>
#include <stdbool.h>
#include <stdio.h>
#include <pthread.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Result of any operation that can fail because of the environment or the data
 * (missing file, corrupt data, GL failure). 0 is success. */
typedef enum hz_result {
    HZ_OK = 0,
    HZ_ERR_IO,          /* file missing, unreadable, short read */
    HZ_ERR_FORMAT,      /* data is not what it claims to be, truncated, unknown format */
    HZ_ERR_VALUE,       /* NaN/inf heights, nonsense parameters */
    HZ_ERR_MEMORY,      /* allocation failed */
    HZ_ERR_GL,          /* GL/EGL failure (context, shader compile, FBO) */
    HZ_ERR_UNSUPPORTED  /* a valid request we do not handle */
} hz_result;

/* Human readable error, filled by any function that takes a hz_err* (may be NULL). */
typedef struct hz_err {
    hz_result code;
    char msg[512];
} hz_err;

/* Sets err->code and a printf-formatted message; returns code. err may be NULL. */
hz_result hz_err_set(hz_err *err, hz_result code, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

/* Name of a result code ("io", "format", ...). */
const char *hz_result_name(hz_result r);

/* Progress callback for long work: done of total units, label says what.
 * Called at most ~100 times per job. user is the desc's progress_user. */
typedef void (*hz_progress_fn)(void *user, const char *label, uint64_t done, uint64_t total);

/* A ready-made progress callback for long work. When stderr is a terminal:
 * a bar redrawn in place, the line finished when done == total. Otherwise
 * (logs, CI, pipes): plain lines "horizon: LABEL: P% (done/total)", none for
 * work shorter than 2 s, then one every 10 % or every 10 s, whichever comes
 * first, and one at the end (hz_progress_line). user: NULL (one shared state
 * for the process's stderr, thread-safe), or a hz_progress_lines of the
 * caller's. A caller's --quiet passes no callback at all. */
void hz_progress_stderr(void *user, const char *label, uint64_t done, uint64_t total);

/* The state of the plain progress lines of one task (zero it to start). */
typedef struct hz_progress_lines {
    char label[64];      /* the task being reported */
    uint64_t last_done;  /* done at the last call (done going back starts a new task) */
    double start_ms;     /* when the task was first reported */
    double line_ms;      /* when the last line was printed; 0: none yet */
    int line_pct;        /* percentage on the last line */
    bool finished;       /* its 100 % line is out */
} hz_progress_lines;

/* The line rule of hz_progress_stderr, on a clock of the caller's (ms):
 * prints to f at most one line and says whether it did. */
bool hz_progress_line(hz_progress_lines *st, FILE *f, const char *label, uint64_t done, uint64_t total,
                      double now_ms);

/* Monotonic wall clock in milliseconds. */
double hz_time_ms(void);

/* A function run on a thread of its own while the caller goes on, and
 * waited for later (a frame's horizon cull runs while the renderer draws the
 * nearest patches). Zero it before its first start; free of resources
 * between a wait and the next start. */
typedef struct hz_job {
    void (*fn)(void *arg);
    void *arg;
    pthread_t thread;
    bool running; /* started on a thread and not yet waited for */
} hz_job;

/* Runs fn(arg) on a new thread; waits first for a job still running. When
 * no thread can be made, runs it here before returning (false). */
bool hz_job_start(hz_job *job, void (*fn)(void *arg), void *arg);

/* Waits until the job's function has returned; at once when it has
 * already been waited for or never started. Returns the milliseconds it
 * waited. */
double hz_job_wait(hz_job *job);

/* Peak resident set size of this process in bytes (0 if unknown). */
uint64_t hz_peak_rss_bytes(void);

/* Debug assertion for programmer misuse (NULL where not allowed, counts out of range). */
#ifdef NDEBUG
#define HZ_ASSERT(c) ((void)0)
#else
#include <assert.h>
#define HZ_ASSERT(c) assert(c)
#endif

#ifdef __cplusplus
}
#endif
#endif
