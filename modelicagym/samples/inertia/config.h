/*
 * config.h -- "Inertia", the plant of `modelicagym sample system` (and of the
 * system tests): a shaft with friction, turned by a motor's torque against a
 * load torque.
 *
 *   der(phi) = w,   J der(w) = tau + tau_load - d w,   phi(0) = 0, w(0) = w_0
 *
 *   inputs  tau        the motor's torque (N.m)
 *           tau_load   a load torque (N.m): an exogenous input, e.g. from a table
 *   outputs phi        angle (rad), a state
 *           w          speed (rad/s), a state
 *           a          acceleration (rad/s2): direct feedthrough of tau and tau_load
 *   parameters J (kg.m2), d (N.m.s/rad), w_0 (rad/s)
 */
#ifndef INERTIA_CONFIG_H
#define INERTIA_CONFIG_H

#define NX 2 /* phi, w */
#define NZ 0

enum { VR_PHI = 1, VR_DER_PHI = 2, VR_W = 3, VR_DER_W = 4, VR_TAU = 5, VR_TAU_LOAD = 6, VR_A = 7, VR_J = 8,
       VR_D = 9, VR_W_0 = 10 };

typedef struct {
    double phi, der_phi, w, der_w;
    double tau, tau_load, a;
    double J, d, w_0;
} ModelData;

#endif /* INERTIA_CONFIG_H */
