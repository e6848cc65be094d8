/* What a pool step's synchronisation costs, apart from any env: the calling process wakes `workers`
 * worker processes that do nothing and waits until all have answered, in C on both sides.
 *
 * Two protocols, so that a benchmark compares them in one run (benchmarks/barrier.py):
 *   - the step's barrier (slice.h: mg_post_step + mg_collect; the workers mg_go_wait + mg_answer);
 *   - the per-worker signals it replaced: a post of each worker's `go` on its own futex word, then
 *     a wait for each worker's `done` in worker order (the former mg_collect, kept here as the
 *     baseline). The pool made those posts from Python, one ctypes call (~0.3 us) each, which this
 *     baseline leaves out: it flatters the old protocol. */
#ifndef MG_SYNC_BENCH_H
#define MG_SYNC_BENCH_H

#include <stdint.h>

/* The median nanoseconds of `rounds` (>= 1) empty steps of `workers` (1..256) forked worker
 * processes, through the barrier (`barrier` 1) or the per-worker signals (0). The workers poll for
 * `go` up to go_spin_ns, the calling process for the answers up to collect_spin_ns (each adapting as
 * signal.h says). -1 when a worker could not be made or did not answer within 10 s. */
int64_t mg_step_sync_ns(int64_t workers, int64_t rounds, int32_t barrier, int64_t go_spin_ns,
                        int64_t collect_spin_ns);

#endif
