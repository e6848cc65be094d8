/*
 * config.h -- "Stiff", a stiff linear model without events, for model exchange
 * and co-simulation:
 *
 *   der(x1) = -lambda * (x1 - u),  der(x2) = x1 - x2
 *   x1(0) = x1_0, x2(0) = x2_0      (u: input; lambda = 1e4 by default)
 *
 * Its eigenvalues are -lambda and -1. An explicit solver is stable only for
 * steps below about 2.8 / lambda (RK4), so co-simulation, whose internal RK4
 * runs at the tunable cs_step_size, defaults to 1e-5 s: correct, just slow
 * (1e5 substeps per simulated second). Model exchange with an implicit solver
 * (CVode's BDF) takes large steps once x1 has settled.
 */
#ifndef STIFF_CONFIG_H
#define STIFF_CONFIG_H

#define NX 2 /* x1, x2 */
#define NZ 0

enum {
    VR_X1 = 1,
    VR_DER_X1 = 2,
    VR_X2 = 3,
    VR_DER_X2 = 4,
    VR_U = 5,
    VR_LAMBDA = 6,
    VR_X1_0 = 7,
    VR_X2_0 = 8,
    VR_CS_STEP_SIZE = 9
};

typedef struct {
    double x1, der_x1, x2, der_x2;
    double u;
    double lambda, x1_0, x2_0, cs_step_size;
} ModelData;

#endif /* STIFF_CONFIG_H */
