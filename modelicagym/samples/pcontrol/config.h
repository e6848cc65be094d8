/*
 * config.h -- "PControl", a proportional controller for the loop tests (tests/system/test_loops.py):
 *
 *   y = k (r - u)
 *
 *   inputs  r          the setpoint (the agent's action)
 *           u          the measurement, fed back from a plant
 *   outputs y          direct feedthrough of r and u (ModelStructure declares it)
 *   parameters k (tunable)
 */
#ifndef PCONTROL_CONFIG_H
#define PCONTROL_CONFIG_H

#define NX 0
#define NZ 0

enum { VR_R = 1, VR_U = 2, VR_Y = 3, VR_K = 4 };

typedef struct {
    double r, u, y, k;
} ModelData;

#endif /* PCONTROL_CONFIG_H */
