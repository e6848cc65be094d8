/* Range checks of a batch of actions, for the pool's parent before anything reaches a worker:
 * a few hundred nanoseconds where numpy needs microseconds for small batches. */
#ifndef MG_ACTIONS_H
#define MG_ACTIONS_H

#include <stdint.h>

/* The index of the first value outside [low, high], or -1. */
int64_t mg_first_outside_int64(const int64_t *values, int64_t n, int64_t low, int64_t high);

/* `values` is n rows of `width` doubles: the index of the first row with a value outside
 * [low[k], high[k]] (NaN is outside), or -1. */
int64_t mg_first_outside_float64(const double *values, int64_t n, int64_t width, const double *low,
                                 const double *high);

#endif
