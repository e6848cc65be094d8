/* What a wake-up costs on this machine: the round trip of two processes that sleep between posts.
 *
 * The pool's parties sleep between batches wherever polling would hold a core another needs
 * (signal.h). Each such batch then pays two wake-ups, and what one costs depends on the machine,
 * not on us: on a virtual machine whose idle cores halt, waking one takes a trip through the
 * hypervisor (~10 us each way on this project's KVM guest with its halt polling off), where a core
 * that polls before it halts, or bare metal, answers in a few. The benchmarks report it with their
 * conditions, so that a figure from a pool that sleeps is read against the machine it ran on. */
#ifndef MG_WAKE_H
#define MG_WAKE_H

#include <stdint.h>

/* The median nanoseconds of `rounds` (>= 1) round trips between this process and a child it forks,
 * on two different cores, each waking the other with a signal and sleeping on it; -1 with a single
 * usable core or when no child could be made. The child runs nothing but this loop (no Python),
 * then exits; this process is held on its current core meanwhile, then gets its affinity back. */
int64_t mg_wake_round_trip_ns(int64_t rounds);

#endif
