/*
 * config.h -- "Ball", a bouncing ball with a state event (the ball hits the
 * ground) and a time event (at t_switch the restitution coefficient changes
 * from e to e_late), for model exchange and co-simulation.
 *
 *   der(h) = v,  der(v) = a - g         (a: input, extra vertical acceleration)
 *   event indicator z = h; at a bounce (h <= 0, v < 0): h = 0, v = -e_now * v,
 *   bounces += 1, t_bounce = time; below V_MIN the ball comes to rest.
 *   time event at t_switch: e_now = e_late, t_switched = time.
 */
#ifndef BALL_CONFIG_H
#define BALL_CONFIG_H

#include <stdbool.h>
#include <stdint.h>

#define NX 2 /* h, v */
#define NZ 1 /* h */

enum {
    VR_H = 1,
    VR_DER_H = 2,
    VR_V = 3,
    VR_DER_V = 4,
    VR_A = 5,
    VR_G = 6,
    VR_E = 7,
    VR_E_LATE = 8,
    VR_T_SWITCH = 9,
    VR_H_0 = 10,
    VR_E_NOW = 11,
    VR_BOUNCES = 12,
    VR_T_BOUNCE = 13,
    VR_T_SWITCHED = 14,
    VR_CS_STEP_SIZE = 15,
    VR_Z = 16
};

typedef struct {
    double h, der_h, v, der_v, z;
    double a;
    double g, e, e_late, t_switch, h_0, cs_step_size;
    double e_now, t_bounce, t_switched;
    int32_t bounces;
    bool switched, resting;
} ModelData;

#endif /* BALL_CONFIG_H */
