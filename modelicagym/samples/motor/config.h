/*
 * config.h -- "Motor", the actuator of `modelicagym sample system` (and of the
 * system tests): a torque motor with a first-order lag and back-EMF, driven by
 * a command.
 *
 *   tau_set = k (u - w / w_max),   T_m der(tau) = tau_set - tau,   tau(0) = 0
 *
 *   inputs  u          command (1)
 *           w          the shaft's speed (rpm), fed back from the load
 *   outputs tau        torque on the shaft (N.m), the state: no direct feedthrough
 *           tau_set    the torque asked for (N.m): direct feedthrough of u and w
 *           saturated  |u| > 1 (a Boolean: for the type-mismatch refusal)
 *   parameters k (N.m, tunable), T_m (s), w_max (rpm)
 *
 * The speed in rpm while the load reports rad/s gives a unit conversion along
 * the connection; tau_set gives an algebraic loop when it feeds a load whose
 * output depends on its torque directly and comes back into u or w.
 */
#ifndef MOTOR_CONFIG_H
#define MOTOR_CONFIG_H

#define NX 1 /* tau */
#define NZ 0

enum { VR_TAU = 1, VR_DER_TAU = 2, VR_U = 3, VR_W = 4, VR_TAU_SET = 5, VR_K = 6, VR_T_M = 7, VR_W_MAX = 8,
       VR_SATURATED = 9 };

typedef struct {
    double tau, der_tau;
    double u, w, tau_set;
    double k, T_m, w_max;
    bool saturated;
} ModelData;

#endif /* MOTOR_CONFIG_H */
