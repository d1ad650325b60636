/* Reference for bench/step_pulse_bench.py: the timing loop of lg's pulse thread (lgPthTx.c,
 * joan2937/lg: one clock_nanosleep to an absolute deadline per edge, the deadline advanced
 * by the nominal half period whatever the wake-up was), without the gpiochip write (there
 * is no GPIO here). Normal scheduling, as lg's thread has.
 *
 * usage: step_probe STEP_HZ SECONDS  -> one JSON line: edge lateness percentiles (us), the
 * shortest high or low time that came out (us) and how many were under 2 us (a DRV8825
 * needs 1.9 us: such a pulse may be missed by the chip) */
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
    if (argc != 4) { fprintf(stderr, "usage: step_probe STEP_HZ SECONDS PRIORITY\n"); return 2; }
    double hz = atof(argv[1]), seconds = atof(argv[2]);
    int prio = atoi(argv[3]), rt = 0;
    if (prio > 0) {
        struct sched_param sp = {.sched_priority = prio};
        rt = sched_setscheduler(0, SCHED_FIFO, &sp) == 0;
    }
    long edges = (long)(seconds * hz * 2.0);
    if (hz <= 0 || edges < 2) { fprintf(stderr, "step_probe: bad rate or duration\n"); return 2; }
    long half_ns = (long)(0.5e9 / hz);
    double *late_us = malloc(edges * sizeof *late_us);
    struct timespec due, now, prev;
    long short_pulses = 0;
    double shortest_us = 1e12;
    clock_gettime(CLOCK_MONOTONIC, &due);
    prev = due;
    for (long i = 0; i < edges; i++) {
        due.tv_nsec += half_ns;
        while (due.tv_nsec >= 1000000000L) { due.tv_nsec -= 1000000000L; due.tv_sec++; }
        while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &due, NULL)) {}
        clock_gettime(CLOCK_MONOTONIC, &now);
        late_us[i] = (now.tv_sec - due.tv_sec) * 1e6 + (now.tv_nsec - due.tv_nsec) / 1e3;
        double width_us = (now.tv_sec - prev.tv_sec) * 1e6 + (now.tv_nsec - prev.tv_nsec) / 1e3;
        if (i > 0) {
            if (width_us < shortest_us) shortest_us = width_us;
            if (width_us < 2.0) short_pulses++;
        }
        prev = now;
    }
    qsort(late_us, edges, sizeof *late_us, by_value);
    printf("{\"rt\": %d, \"edges\": %ld, \"late_p50_us\": %.1f, \"late_p99_us\": %.1f, \"late_max_us\": %.1f, "
           "\"shortest_us\": %.1f, \"under_2us\": %ld}\n", rt, edges, late_us[edges / 2],
           late_us[(long)(edges * 0.99)], late_us[edges - 1], shortest_us, short_pulses);
    free(late_us);
    return 0;
}
