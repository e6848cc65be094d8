/*
 * config.h -- "Gain", a static gain with an offset for the loop tests (tests/system/test_loops.py):
 *
 *   y = k u + b
 *
 *   inputs  u          (1)
 *   outputs y          direct feedthrough of u (ModelStructure declares it)
 *   parameters k, b (tunable)
 *
 * Two of them make a power bond (a source y = E - R i, a load i = v / R_L), three a ring, and a
 * loop gain above one a loop that diverges when read with a one-step delay.
 */
#ifndef GAIN_CONFIG_H
#define GAIN_CONFIG_H

#define NX 0
#define NZ 0

enum { VR_U = 1, VR_Y = 2, VR_K = 3, VR_B = 4 };

typedef struct {
    double u, y, k, b;
} ModelData;

#endif /* GAIN_CONFIG_H */
