/*
 * config.h -- "Staircase", time events and event iteration, for model exchange
 * and co-simulation: a discrete staircase `level` drives a continuous state x.
 *
 *   der(x) = level - k * x + u        (u: input; x(0) = 0)
 *   time events at t = n * period, n = 1, 2, ...: level = level + height,
 *   steps_taken += 1, t_last_event = time; so level(t) = height * floor(t / period).
 *   Every 3rd stair takes two event-iteration passes: the first only sets the
 *   helper `pending` and asks for new_discrete_states_needed, the second takes
 *   the stair. `iterations` counts every event-update pass (the one after
 *   initialization included), so after n stairs it is 1 + n + n / 3.
 *   time event at t_stop: terminate_simulation, stopped = true, t_last_event =
 *   time (a stair due at t_stop is not taken).
 *
 * Between stairs, with u constant, x relaxes exponentially towards
 * (level + u) / k at rate k.
 */
#ifndef STAIRCASE_CONFIG_H
#define STAIRCASE_CONFIG_H

#include <stdbool.h>
#include <stdint.h>

#define NX 1 /* x */
#define NZ 0

enum {
    VR_X = 1,
    VR_DER_X = 2,
    VR_U = 3,
    VR_PERIOD = 4,
    VR_HEIGHT = 5,
    VR_T_STOP = 6,
    VR_K = 7,
    VR_LEVEL = 8,
    VR_STEPS_TAKEN = 9,
    VR_T_LAST_EVENT = 10,
    VR_ITERATIONS = 11,
    VR_STOPPED = 12
};

typedef struct {
    double x, der_x;
    double u;
    double period, height, t_stop, k;
    double level, t_last_event;
    int32_t steps_taken, iterations;
    bool stopped, pending;
} ModelData;

#endif /* STAIRCASE_CONFIG_H */
