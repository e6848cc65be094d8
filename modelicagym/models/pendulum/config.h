/*
 * config.h -- compile-time configuration of the motor-driven pendulum model for
 * the modelicagym FMU framework (see ../csrc/model.h and model.c).
 */
#ifndef PENDULUM_CONFIG_H
#define PENDULUM_CONFIG_H

#define NX 6 /* theta, omega, twist, omega_m, current, z */
#define NZ 0 /* no state events */

/* Value references (identical in the FMI 2.0 and 3.0 model descriptions). */
enum {
    VR_U = 1,
    VR_THETA = 2,
    VR_OMEGA = 3,
    VR_TWIST = 4,
    VR_OMEGA_M = 5,
    VR_CURRENT = 6,
    VR_Z = 7,
    VR_COS_THETA = 8,
    VR_SIN_THETA = 9,
    VR_FRICTION_TORQUE = 10,
    VR_DER_THETA = 11,
    VR_DER_OMEGA = 12,
    VR_DER_TWIST = 13,
    VR_DER_OMEGA_M = 14,
    VR_DER_CURRENT = 15,
    VR_DER_Z = 16,
    VR_MASS = 20,
    VR_LENGTH = 21,
    VR_DAMPING = 22,
    VR_GEAR_RATIO = 23,
    VR_K_MOTOR = 24,
    VR_RESISTANCE = 25,
    VR_INDUCTANCE = 26,
    VR_J_MOTOR = 27,
    VR_K_SHAFT = 28,
    VR_D_SHAFT = 29,
    VR_T_COULOMB = 30,
    VR_T_STICTION = 31,
    VR_V_STRIBECK = 32,
    VR_SIGMA0 = 33,
    VR_SIGMA1 = 34,
    VR_SIGMA2 = 35,
    VR_THETA_0 = 36,
    VR_OMEGA_0 = 37,
    VR_CS_STEP_SIZE = 38
};

/* The states' value references, for FMI 1.0's fmiGetStateValueReferences. */
#define STATE_VALUE_REFERENCES {VR_THETA, VR_OMEGA, VR_TWIST, VR_OMEGA_M, VR_CURRENT, VR_Z}

typedef struct {
    double u; /* input: armature voltage [V] */
    /* continuous states */
    double theta, omega, twist, omega_m, current, z;
    /* outputs and locals calculated from the states */
    double cos_theta, sin_theta, friction_torque;
    /* the states' derivatives */
    double der_theta, der_omega, der_twist, der_omega_m, der_current, der_z;
    /* fixed parameters */
    double mass, length, damping, gear_ratio, k_motor, resistance, inductance, j_motor;
    double k_shaft, d_shaft, t_coulomb, t_stiction, v_stribeck, sigma0, sigma1, sigma2;
    double theta_0, omega_0;
    /* tunable: internal RK4 step of co-simulation [s] */
    double cs_step_size;
} ModelData;

#endif /* PENDULUM_CONFIG_H */
