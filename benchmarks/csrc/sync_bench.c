/* See sync_bench.h. */
#define _GNU_SOURCE
#include "sync_bench.h"

#include <stdlib.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <unistd.h>

#include "slice.h"

#define MAX_WORKERS 256
#define TIMEOUT_NS 10000000000LL

/* A signal on a cache line of its own, as in the pool's shared memory. */
typedef struct {
    mg_signal signal;
    uint8_t pad[64 - sizeof(mg_signal)];
} line;

typedef struct {
    mg_barrier barrier;
    uint32_t stop; /* the workers exit at their next `go` */
    uint8_t pad[60];
    line go[MAX_WORKERS], done[MAX_WORKERS];
} shared;

static int compare(const void *a, const void *b) {
    int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;
    return (x > y) - (x < y);
}

static void serve(shared *s, int64_t k, int32_t barrier, int64_t spin_ns) {
    mg_waiter waiter = {0};
    mg_signal *go = &s->go[k].signal, *done = &s->done[k].signal;
    for (;;) {
        int got = barrier ? mg_go_wait(go, &s->barrier, k, spin_ns, TIMEOUT_NS, &waiter)
                          : mg_signal_wait(go, spin_ns, TIMEOUT_NS, &waiter);
        if (!got)
            _exit(1);
        if (__atomic_load_n(&s->stop, __ATOMIC_ACQUIRE))
            _exit(0);
        if (barrier)
            mg_answer(&s->barrier, done);
        else
            mg_signal_post(done);
    }
}

/* The former mg_collect: each `done` in turn, one wait for the waiter's account (long if the last
 * post came after the spin time). */
static int per_worker_collect(shared *s, int64_t workers, int64_t spin_ns, mg_waiter *waiter) {
    int64_t started = mg_now_ns(), long_waits = waiter->long_waits, last_post = started;
    for (int64_t k = 0; k < workers; k++) {
        if (!mg_signal_wait(&s->done[k].signal, spin_ns, TIMEOUT_NS, waiter))
            return 0;
        int64_t posted = __atomic_load_n(&s->done[k].signal.posted_ns, __ATOMIC_RELAXED);
        last_post = posted > last_post ? posted : last_post;
    }
    waiter->long_waits = last_post - started > spin_ns ? long_waits + 1 : 0;
    return 1;
}

/* `rounds` steps timed into `times`; 0 if a worker did not answer. */
static int run_rounds(shared *s, mg_collector *c, int32_t barrier, int64_t rounds, int64_t *times) {
    for (int64_t r = 0; r < rounds; r++) {
        int64_t started = mg_now_ns();
        int ok;
        if (barrier) {
            mg_post_step(c);
            ok = mg_collect(c) == MG_COLLECT_DONE;
        } else {
            for (int64_t k = 0; k < c->n_workers; k++)
                mg_signal_post(&s->go[k].signal);
            ok = per_worker_collect(s, c->n_workers, *c->spin_ns, c->waiter);
        }
        if (!ok)
            return 0;
        times[r] = mg_now_ns() - started;
    }
    return 1;
}

static void stop_workers(shared *s, pid_t *pids, int64_t started, int32_t barrier) {
    __atomic_store_n(&s->stop, 1, __ATOMIC_RELEASE);
    for (int64_t k = 0; k < started; k++) {
        if (barrier)
            mg_go_post(&s->go[k].signal, &s->barrier, k);
        else
            mg_signal_post(&s->go[k].signal);
    }
    for (int64_t k = 0; k < started; k++)
        waitpid(pids[k], NULL, 0);
}

int64_t mg_step_sync_ns(int64_t workers, int64_t rounds, int32_t barrier, int64_t go_spin_ns,
                        int64_t collect_spin_ns) {
    if (workers < 1 || workers > MAX_WORKERS || rounds < 1)
        return -1;
    shared *s = mmap(NULL, sizeof(shared), PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
    int64_t *times = malloc((size_t)rounds * sizeof *times);
    pid_t pids[MAX_WORKERS];
    void *go[MAX_WORKERS], *done[MAX_WORKERS];
    int32_t replies[MAX_WORKERS] = {0};
    uint8_t stepping[MAX_WORKERS];
    int64_t started = 0, result = -1;
    if (s == MAP_FAILED || !times)
        goto out;
    for (; started < workers; started++) {
        go[started] = &s->go[started].signal;
        done[started] = &s->done[started].signal;
        stepping[started] = 1;
        pids[started] = fork();
        if (pids[started] == 0)
            serve(s, started, barrier, go_spin_ns);
        if (pids[started] < 0)
            break;
    }
    if (started == workers) {
        mg_waiter waiter = {0};
        mg_collector c = {.n_workers = workers, .go = go, .done = done, .barrier = &s->barrier, .replies = replies,
                          .stepping = stepping, .spin_ns = &collect_spin_ns, .timeout_ns = TIMEOUT_NS,
                          .waiter = &waiter};
        if (run_rounds(s, &c, barrier, rounds, times)) {
            qsort(times, (size_t)rounds, sizeof *times, compare);
            result = times[rounds / 2];
        }
    }
    stop_workers(s, pids, started, barrier);
out:
    free(times);
    if (s != MAP_FAILED)
        munmap(s, sizeof(shared));
    return result;
}
