/* Reference for bench/loop_bench.py: how late the host wakes a periodic SCHED_FIFO thread
 * that needs no Python lock. Run during each load phase next to urc's own loop thread, it
 * separates what the host (kernel, VM, other load) adds from what CPython adds (waiting
 * for the GIL while the event-loop thread serves requests).
 *
 * usage: rt_probe PERIOD_MS SECONDS  -> prints one JSON line (lateness percentiles, ms)
 * Same priority as urc's loop thread (SCHED_FIFO 10); falls back to normal scheduling
 * and says so ("rt": 0) where real-time scheduling is not allowed. */
#define _GNU_SOURCE
#include <sched.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

static int by_value(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv) {
    if (argc != 3) { fprintf(stderr, "usage: rt_probe PERIOD_MS SECONDS\n"); return 2; }
    double period_ms = atof(argv[1]), seconds = atof(argv[2]);
    long n = (long)(seconds * 1000.0 / period_ms);
    if (period_ms <= 0 || n < 1) { fprintf(stderr, "rt_probe: bad period or duration\n"); return 2; }
    struct sched_param sp = {.sched_priority = 10};
    int rt = sched_setscheduler(0, SCHED_FIFO, &sp) == 0;
    double *late_ms = malloc(n * sizeof *late_ms);
    long period_ns = (long)(period_ms * 1e6);
    struct timespec due, now;
    clock_gettime(CLOCK_MONOTONIC, &due);
    for (long i = 0; i < n; i++) {
        due.tv_nsec += period_ns;
        while (due.tv_nsec >= 1000000000L) { due.tv_nsec -= 1000000000L; due.tv_sec++; }
        clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &due, NULL);
        clock_gettime(CLOCK_MONOTONIC, &now);
        late_ms[i] = (now.tv_sec - due.tv_sec) * 1e3 + (now.tv_nsec - due.tv_nsec) / 1e6;
    }
    qsort(late_ms, n, sizeof *late_ms, by_value);
    printf("{\"rt\": %d, \"wakeups\": %ld, \"late_p50_ms\": %.3f, \"late_p99_ms\": %.3f, \"late_max_ms\": %.3f}\n",
           rt, n, late_ms[n / 2], late_ms[(long)(n * 0.99)], late_ms[n - 1]);
    free(late_ms);
    return 0;
}
