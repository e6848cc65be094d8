/* See actions.h. */
#include "actions.h"

int64_t mg_first_outside_int64(const int64_t *values, int64_t n, int64_t low, int64_t high) {
    for (int64_t i = 0; i < n; i++)
        if (values[i] < low || values[i] > high)
            return i;
    return -1;
}

int64_t mg_first_outside_float64(const double *values, int64_t n, int64_t width, const double *low,
                                 const double *high) {
    for (int64_t i = 0; i < n; i++)
        for (int64_t k = 0; k < width; k++) {
            double v = values[i * width + k];
            if (!(low[k] <= v && v <= high[k]))
                return i;
        }
    return -1;
}

int64_t mg_first_range_outside(const mg_range *ranges, int64_t count) {
    for (int64_t r = 0; r < count; r++) {
        const mg_range *range = &ranges[r];
        int64_t outside = range->is_float
            ? mg_first_outside_float64(range->values, range->n, range->width, range->low, range->high)
            : mg_first_outside_int64(range->values, range->n * range->width, range->low_int, range->high_int);
        if (outside >= 0)
            return r;
    }
    return -1;
}
