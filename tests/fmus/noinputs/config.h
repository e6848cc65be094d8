/*
 * config.h -- "NoInputs", a bouncing ball without inputs: the only thing to act on is its tunable
 * restitution coefficient e (FMI lets a master change a tunable parameter between steps), the
 * shape of third-party FMUs whose `modelicagym info` config takes tunable parameters as actions.
 *
 *   der(h) = v,  der(v) = -g;  event indicator z = h; at a bounce (h <= 0, v < 0):
 *   h = 0, v = -e * v, bounces += 1; below V_MIN the ball comes to rest.
 */
#ifndef NOINPUTS_CONFIG_H
#define NOINPUTS_CONFIG_H

#include <stdbool.h>
#include <stdint.h>

#define NX 2 /* h, v */
#define NZ 1 /* h */

enum {
    VR_H = 1, VR_DER_H = 2, VR_V = 3, VR_DER_V = 4, VR_G = 5, VR_E = 6, VR_H_0 = 7, VR_BOUNCES = 8
};

typedef struct {
    double h, der_h, v, der_v;
    double g, e, h_0;
    int32_t bounces;
    bool resting;
} ModelData;

#endif /* NOINPUTS_CONFIG_H */
