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

/* One array of a batch to range-check: `n` rows of `width` values, int64 within [low_int, high_int]
 * or doubles within [low[k], high[k]] (NaN is outside). */
typedef struct {
    const void *values;
    int64_t n;
    int64_t width;
    int32_t is_float;
    int64_t low_int;
    int64_t high_int;
    const double *low;
    const double *high;
} mg_range;

/* The index of the first of `count` ranges with a value outside, or -1: a Dict's batch, every key
 * in one call. */
int64_t mg_first_range_outside(const mg_range *ranges, int64_t count);

#endif
