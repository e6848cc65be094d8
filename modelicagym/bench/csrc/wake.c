/* See wake.h. */
#define _GNU_SOURCE
#include "wake.h"

#include <sched.h>
#include <stdlib.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <unistd.h>

#include "signal.h"

static int compare(const void *a, const void *b) {
    int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;
    return (x > y) - (x < y);
}

/* Another core this process may run on than `cpu`, or -1. */
static int other_cpu(const cpu_set_t *allowed, int cpu) {
    for (int k = 0; k < CPU_SETSIZE; k++)
        if (k != cpu && CPU_ISSET(k, allowed))
            return k;
    return -1;
}

static void pin(int cpu) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(cpu, &set);
    sched_setaffinity(0, sizeof set, &set);
}

int64_t mg_wake_round_trip_ns(int64_t rounds) {
    if (rounds < 1)
        rounds = 1;
    cpu_set_t allowed;
    int here = sched_getcpu(), there = -1;
    if (here >= 0 && sched_getaffinity(0, sizeof allowed, &allowed) == 0)
        there = other_cpu(&allowed, here);
    if (there < 0)
        return -1;
    mg_signal *signals = mmap(NULL, 2 * sizeof(mg_signal), PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
    int64_t *times = malloc((size_t)rounds * sizeof *times);
    if (signals == MAP_FAILED || !times) {
        free(times);
        if (signals != MAP_FAILED)
            munmap(signals, 2 * sizeof(mg_signal));
        return -1;
    }
    pin(here); /* each process on a core of its own, as a pool's parties are */
    pid_t child = fork();
    if (child == 0) {
        pin(there);
        for (int64_t k = 0; k < rounds; k++) {
            if (!mg_signal_wait(&signals[0], 0, 1000000000, NULL))
                _exit(1);
            mg_signal_post(&signals[1]);
        }
        _exit(0);
    }
    int64_t result = -1;
    if (child > 0) {
        int64_t k = 0;
        for (; k < rounds; k++) {
            int64_t start = mg_now_ns();
            mg_signal_post(&signals[0]);
            if (!mg_signal_wait(&signals[1], 0, 1000000000, NULL))
                break;
            times[k] = mg_now_ns() - start;
        }
        waitpid(child, NULL, 0);
        if (k == rounds) {
            qsort(times, (size_t)rounds, sizeof *times, compare);
            result = times[rounds / 2];
        }
    }
    sched_setaffinity(0, sizeof allowed, &allowed);
    free(times);
    munmap(signals, 2 * sizeof(mg_signal));
    return result;
}
