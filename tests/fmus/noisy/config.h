/*
 * config.h -- "Noisy", a first-order lag whose solver talks too much,
 * co-simulation only:
 *
 *   der(x) = -x + u,   x(0) = 0
 *
 * Its input u declares no range. Within |u| <= u_max every doStep logs
 * warnings_per_step warnings (when debug logging is on), as exported FMUs do; an
 * input beyond u_max drives its "solver" into an error loop: doStep logs
 * errors_per_step error messages and still returns OK (the state is not
 * advanced), as third-party FMUs do when an unbounded input is sampled far from
 * the model's physical range. Model exchange integrates the lag silently.
 */
#ifndef NOISY_CONFIG_H
#define NOISY_CONFIG_H

#include <stdint.h>

#define NX 1
#define NZ 0

enum {
    VR_X = 1,
    VR_DER_X = 2,
    VR_U = 3,
    VR_U_MAX = 4,
    VR_WARNINGS_PER_STEP = 5,
    VR_ERRORS_PER_STEP = 6
};

typedef struct {
    double x, der_x;
    double u;
    double u_max;
    int32_t warnings_per_step, errors_per_step;
    int32_t stuck; /* the last doStep was caught in the error loop (not a variable) */
} ModelData;

#endif /* NOISY_CONFIG_H */
