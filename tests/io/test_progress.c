/* The plain progress lines of hz_progress_stderr when stderr is not a
 * terminal (hz_progress_line, on a clock of the test's): nothing for short
 * work, then one line per 10 % or per 10 s, whichever first, one at the end;
 * plain lines (no carriage return); a new label or done going back is a new
 * task. And hz_job, the core's other helper for long work. */
#include <pthread.h>
#include <stdatomic.h>
#include <unistd.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "horizon/core.h"

/* Runs the calls (done[k] at t[k] ms) and returns what was printed. */
static char *run(hz_progress_lines *st, const char *label, const uint64_t *done, const double *t, int n, uint64_t total,
                 int *lines)
{
    FILE *f = tmpfile();
    assert_non_null(f);
    *lines = 0;
    for (int k = 0; k < n; k++)
        *lines += hz_progress_line(st, f, label, done[k], total, t[k]);
    long sz = ftell(f);
    rewind(f);
    char *s = calloc((size_t)sz + 1, 1);
    assert_int_equal(fread(s, 1, (size_t)sz, f), (size_t)sz);
    fclose(f);
    return s;
}

static void test_short_work_is_silent(void **state)
{
    (void)state;
    hz_progress_lines st = {0};
    uint64_t done[101];
    double t[101];
    for (int k = 0; k <= 100; k++)
        done[k] = (uint64_t)k, t[k] = 1000.0 + 15.0 * k; /* 1.5 s in all */
    int lines;
    char *s = run(&st, "LOD data", done, t, 101, 100, &lines);
    assert_int_equal(lines, 0);
    assert_string_equal(s, "");
    free(s);
}

static void test_every_ten_percent(void **state)
{
    (void)state;
    hz_progress_lines st = {0};
    uint64_t done[1001];
    double t[1001];
    for (int k = 0; k <= 1000; k++)
        done[k] = (uint64_t)k, t[k] = 5000.0 + 20.0 * k; /* 20 s, 1 % every 200 ms */
    int lines;
    char *s = run(&st, "generate perlin", done, t, 1001, 1000, &lines);
    /* quiet for 2 s (10 %), then 10 %, 20 % ... 100 % */
    assert_int_equal(lines, 10);
    assert_null(strchr(s, '\r'));
    assert_non_null(strstr(s, "horizon: generate perlin: 10% (100/1000)\n"));
    assert_non_null(strstr(s, "horizon: generate perlin: 50% (500/1000)\n"));
    assert_non_null(strstr(s, "horizon: generate perlin: 100% (1000/1000)\n"));
    assert_null(strstr(s, "horizon: generate perlin: 15%"));
    free(s);
}

static void test_every_ten_seconds_when_slow(void **state)
{
    (void)state;
    hz_progress_lines st = {0};
    /* 1 % per 4 s: the clock, not the percentage, sets the pace */
    uint64_t done[101];
    double t[101];
    for (int k = 0; k <= 100; k++)
        done[k] = (uint64_t)k, t[k] = 4000.0 * k;
    int lines;
    char *s = run(&st, "import", done, t, 101, 100, &lines);
    /* first at 4 s (1 %), then every 12 s (the first call 10 s or more after the last line), then the end */
    int expect = 0;
    double last = -1;
    for (int k = 0; k <= 100; k++)
        if ((last < 0 && t[k] >= 2000.0) || (last >= 0 && t[k] - last >= 10000.0) || k == 100) {
            expect++;
            last = t[k];
        }
    assert_int_equal(lines, expect);
    assert_true(lines > 30);
    assert_non_null(strstr(s, "horizon: import: 1% (1/100)\n"));
    assert_non_null(strstr(s, "horizon: import: 4% (4/100)\n"));
    assert_null(strstr(s, "horizon: import: 2% "));
    free(s);
}

static void test_new_task(void **state)
{
    (void)state;
    hz_progress_lines st = {0};
    const uint64_t d1[] = {0, 50, 100};
    const double t1[] = {0.0, 3000.0, 6000.0};
    int lines;
    char *s = run(&st, "a", d1, t1, 3, 100, &lines);
    assert_int_equal(lines, 2); /* 50 % (after 2 s), 100 % */
    free(s);
    /* the same label from 0 again: a new task, quiet for its first 2 s */
    const double t2[] = {6100.0, 6500.0, 7000.0};
    s = run(&st, "a", d1, t2, 3, 100, &lines);
    assert_int_equal(lines, 0);
    free(s);
    const double t3[] = {7100.0, 9500.0, 9600.0};
    s = run(&st, "b", d1, t3, 3, 100, &lines);
    assert_int_equal(lines, 2);
    assert_string_equal(s, "horizon: b: 50% (50/100)\nhorizon: b: 100% (100/100)\n");
    free(s);
}

typedef struct job_probe {
    atomic_int go, done;
    pthread_t ran_on;
} job_probe;

static void probe_run(void *arg)
{
    job_probe *p = arg;
    for (int k = 0; k < 2000 && !atomic_load(&p->go); k++) /* at most 2 s (run inline: never) */
        usleep(1000);
    if (!atomic_load(&p->go))
        return;
    p->ran_on = pthread_self();
    atomic_store(&p->done, atomic_load(&p->done) + 1);
}

/* A job runs on a thread of its own, concurrently with its starter, and
 * hz_job_wait returns once it has finished; waiting again, or for a job
 * never started, returns at once; a job can be started again. */
static void test_job_runs_alongside(void **state)
{
    (void)state;
    hz_job job = {0};
    assert_true(hz_job_wait(&job) == 0.0);
    job_probe p = {0};
    assert_true(hz_job_start(&job, probe_run, &p));
    assert_true(job.running);
    usleep(20000);
    assert_int_equal(atomic_load(&p.done), 0); /* it waits for go: not run inline */
    atomic_store(&p.go, 1);
    assert_true(hz_job_wait(&job) >= 0.0);
    assert_false(job.running);
    assert_int_equal(atomic_load(&p.done), 1);
    assert_false(pthread_equal(p.ran_on, pthread_self()));
    assert_true(hz_job_wait(&job) == 0.0);
    assert_int_equal(atomic_load(&p.done), 1);
    assert_true(hz_job_start(&job, probe_run, &p)); /* again (go is set) */
    hz_job_wait(&job);
    assert_int_equal(atomic_load(&p.done), 2);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_job_runs_alongside),
        cmocka_unit_test(test_short_work_is_silent),
        cmocka_unit_test(test_every_ten_percent),
        cmocka_unit_test(test_every_ten_seconds_when_slow),
        cmocka_unit_test(test_new_task),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
