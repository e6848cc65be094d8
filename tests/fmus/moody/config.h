/*
 * config.h -- "Moody", a first-order lag whose step cost depends on its state,
 * for model exchange and co-simulation:
 *
 *   der(x) = (u - x) / tau,   x(0) = x_0         (u: input)
 *
 * While x > threshold the model is in its "moody" phase (a stiff phase, an
 * event storm in FMUs in the wild): co-simulation's internal RK4 then runs at
 * cs_step_size / ratio instead of cs_step_size, so a doStep costs `ratio` times
 * more (100 by default). The step size is chosen from the state at the start of
 * each doStep. The output `effort` says which phase the model is in (1 or ratio).
 * An agent (or a random policy) that pushes x above the threshold makes its env
 * expensive; a per-env threshold makes some envs of a pool moody more often.
 */
#ifndef MOODY_CONFIG_H
#define MOODY_CONFIG_H

#define NX 1 /* x */
#define NZ 0

enum {
    VR_X = 1,
    VR_DER_X = 2,
    VR_U = 3,
    VR_TAU = 4,
    VR_X_0 = 5,
    VR_THRESHOLD = 6,
    VR_RATIO = 7,
    VR_CS_STEP_SIZE = 8,
    VR_EFFORT = 9
};

typedef struct {
    double x, der_x;
    double u;
    double tau, x_0, threshold, ratio, cs_step_size;
    double effort;
} ModelData;

#endif /* MOODY_CONFIG_H */
