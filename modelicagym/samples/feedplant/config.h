/*
 * config.h -- "FeedPlant", an integrator with direct feedthrough for the loop tests
 * (tests/system/test_loops.py):
 *
 *   der(x) = u,   y = x + d u,   x(0) = x_0
 *
 *   inputs  u          (1)
 *   outputs x          the state: no direct feedthrough
 *           y          direct feedthrough of u (ModelStructure declares it)
 *   parameters d (tunable), x_0 (fixed)
 *
 * Over a communication step with u held, x grows by h u (its RK4 is exact on a constant
 * derivative, up to rounding).
 */
#ifndef FEEDPLANT_CONFIG_H
#define FEEDPLANT_CONFIG_H

#define NX 1 /* x */
#define NZ 0

enum { VR_X = 1, VR_DER_X = 2, VR_U = 3, VR_Y = 4, VR_D = 5, VR_X_0 = 6 };

typedef struct {
    double x, der_x, u, y, d, x_0;
} ModelData;

#endif /* FEEDPLANT_CONFIG_H */
