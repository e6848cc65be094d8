/* A wake-up signal between two processes, in shared memory: spin, then sleep on a futex.
 *
 * One party posts, one party waits; the protocol of the pool alternates them strictly (the
 * parent posts a worker's "go", the worker posts its "done"), so a signal is a binary semaphore:
 * post sets it, a successful wait clears it. A waiter first polls for up to a spin time (the
 * post usually comes within microseconds, and a futex wake-up costs tens of them on an idle
 * machine), then sleeps on the futex; the poster makes the wake-up system call only when somebody
 * sleeps.
 *
 * The struct lives in memory shared by the processes (MAP_SHARED), each on a cache line of its
 * own; zeroed memory is an unposted signal.
 */
#ifndef MG_SIGNAL_H
#define MG_SIGNAL_H

#include <stdint.h>

typedef struct {
    uint32_t posted;   /* 1 after post, 0 after a successful wait (the futex word) */
    uint32_t sleepers; /* waiters inside futex_wait */
} mg_signal;

/* Set the signal and wake its waiter if it sleeps. */
void mg_signal_post(mg_signal *signal);

/* Wait for a post and clear it. Polls for spin_ns nanoseconds (pausing the core; yielding it when
 * `yield` is non-zero, for when there may be more busy parties than cores), then sleeps.
 * timeout_ns < 0 waits forever. Returns 1 when a post was consumed, 0 on timeout. */
int mg_signal_wait(mg_signal *signal, int64_t spin_ns, int64_t timeout_ns, int yield);

/* Consume a post if there is one, without waiting: 1 if there was. */
int mg_signal_try(mg_signal *signal);

/* Nanoseconds of CLOCK_MONOTONIC. */
int64_t mg_now_ns(void);

#endif
