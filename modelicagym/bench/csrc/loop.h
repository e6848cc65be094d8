/* The physical limit the benchmarks compare with: one env stepped in a C loop, no Python. */
#ifndef MG_BENCH_LOOP_H
#define MG_BENCH_LOOP_H

#include "step.h"

/* `steps` steps of one env with a fixed action pattern (action k % n_actions, or the Box action
 * given), resetting natively at every episode end; returns the steps done or -1 on an FMU error. */
int64_t mg_loop(mg_env *env, int64_t steps, const void *box_action);

#endif
