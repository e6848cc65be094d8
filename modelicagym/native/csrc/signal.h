/* A wake-up signal between two processes, in shared memory, and a waiter that spins only while
 * spinning pays.
 *
 * One party posts, one party waits; the protocol of the pool alternates them strictly (the
 * parent posts a worker's "go", the worker posts its "done"), so a signal is a binary semaphore:
 * post sets it, a successful wait clears it. The poster makes the wake-up system call only when
 * somebody sleeps.
 *
 * How a waiter waits (the policy; docs/design.md, "Waiting", says why): a post usually comes
 * within microseconds while a futex wake-up costs tens of them, so a wait first polls, for up to
 * the caller's spin time, and then sleeps on the futex. But a poll holds a core, and on a machine
 * with more runnable threads than cores it holds the core that the party it waits for (or anybody
 * else) needs. So a wait sleeps at once, without polling, when
 *
 *   - the machine is crowded: the kernel's CPU pressure (/proc/pressure/cpu, the time some
 *     runnable thread waited for a core; /proc/loadavg's runnable count where there is no PSI)
 *     says runnable threads outnumber the cores, or a poll of this process was descheduled
 *     (a gap in its clock readings); both are re-read at most once a millisecond and keep the
 *     process from polling for a hold time that doubles while crowding persists; or
 *   - this waiter's previous wait outlasted the spin time (its partner computes between posts:
 *     an agent thinking, an update epoch, a heavy step): polling would only burn a core. A wait
 *     whose post then comes within the spin time turns polling back on. "Comes" is the post's own
 *     time stamp, not the wake-up's: two parties that both sleep would otherwise count each
 *     other's wake-up latency and never poll again.
 *
 * The struct lives in memory shared by the processes (MAP_SHARED), each on a cache line of its
 * own; zeroed memory is an unposted signal. A waiter is private to the process that waits.
 *
 * A bell: waiters of several signals may sleep on one shared futex word instead of their signal's
 * own, each on its own bits of the word's wake-up mask (FUTEX_WAIT_BITSET). Every post to one of
 * the signals bumps the word; the poster's wake-up wakes only the bits it names. So one poster can
 * post many signals and wake all their sleeping waiters with a single system call (the pool's step:
 * slice.h, mg_post_step), and still post just one of them, waking only its waiter.
 */
#ifndef MG_SIGNAL_H
#define MG_SIGNAL_H

#include <stdint.h>

typedef struct {
    uint32_t posted;   /* 1 after post, 0 after a successful wait (the futex word) */
    uint32_t sleepers; /* waiters inside futex_wait */
    int64_t posted_ns; /* CLOCK_MONOTONIC of the last post: would a poll have caught it? */
} mg_signal;

/* One waiting party's adaptive state and what its waits did (zeroed: a fresh waiter). */
typedef struct {
    int64_t ready;   /* waits that found the post already there */
    int64_t spun;    /* waits that a poll ended */
    int64_t slept;   /* waits that polled, then slept */
    int64_t blocked; /* waits that slept at once (crowded machine or long waits) */
    int64_t long_waits; /* consecutive waits that outlasted the spin time */
} mg_waiter;

/* Set the signal and wake its waiter if it sleeps. */
void mg_signal_post(mg_signal *signal);

/* Wait for a post and clear it, polling for up to spin_ns nanoseconds when that pays (above),
 * then sleeping. `waiter` may be NULL (no adaptation to this party's own waits).
 * timeout_ns < 0 waits forever. Returns 1 when a post was consumed, 0 on timeout. */
int mg_signal_wait(mg_signal *signal, int64_t spin_ns, int64_t timeout_ns, mg_waiter *waiter);

/* mg_signal_wait for a waiter that sleeps on `bell` (a futex word in shared memory, see above) on
 * `bits` (not 0), where mg_signal_wait sleeps on the signal's own word. */
int mg_signal_wait_bell(mg_signal *signal, uint32_t *bell, uint32_t bits, int64_t spin_ns, int64_t timeout_ns,
                        mg_waiter *waiter);

/* Post a signal whose waiter sleeps on `bell` on `bits`: set it, ring the bell, wake its waiter if it
 * sleeps. */
void mg_signal_post_bell(mg_signal *signal, uint32_t *bell, uint32_t bits);

/* The parts of mg_signal_post_bell, for a poster that posts several signals with one ring and one
 * wake-up: set each signal (no wake-up), note which of their waiters sleep (mg_signal_sleeps, after
 * every set), then ring once, waking the sleepers' bits (`wake` 0: nobody sleeps, no system call). */
void mg_signal_set(mg_signal *signal);
int mg_signal_sleeps(const mg_signal *signal);
void mg_bell_ring(uint32_t *bell, uint32_t bits, int wake);

/* Consume a post if there is one, without waiting: 1 if there was. */
int mg_signal_try(mg_signal *signal);

/* 1 while this process's waits sleep at once because the machine is crowded (re-read at most once
 * a millisecond); for the pool's layout and tests. */
int mg_machine_crowded(void);

/* The machine's one load probe, as the pool's layout reads it (modelicagym/vector/layout/machine_load.py):
 * the CPU pressure's "some" total in microseconds as of the last reading (read now if one is due), -1
 * where the pressure cannot be read. Its readings are the crowding check's own: one reader a process. */
int64_t mg_machine_stall_us(void);

/* Nanoseconds of CLOCK_MONOTONIC. */
int64_t mg_now_ns(void);

#endif
