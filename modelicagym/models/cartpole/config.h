/*
 * config.h -- compile-time configuration of the Cart-Pole model for the
 * modelicagym FMU framework (see ../csrc/model.h).
 */
#ifndef CARTPOLE_CONFIG_H
#define CARTPOLE_CONFIG_H

#define NX 4 /* x, x_dot, theta, theta_dot */
#define NZ 0 /* no state events */

/* Value references (identical in the FMI 1.0, 2.0 and 3.0 model descriptions). */
enum {
    VR_F = 1,
    VR_X = 2,
    VR_X_DOT = 3,
    VR_THETA = 4,
    VR_THETA_DOT = 5,
    VR_DER_X = 6,
    VR_DER_X_DOT = 7,
    VR_DER_THETA = 8,
    VR_DER_THETA_DOT = 9,
    VR_M_CART = 10,
    VR_M_POLE = 11,
    VR_LENGTH = 12,
    VR_DIAMETER = 13,
    VR_DENSITY = 14,
    VR_THETA_0 = 15,
    VR_THETA_DOT_0 = 16,
    VR_X_0 = 17,
    VR_X_DOT_0 = 18,
    VR_CS_STEP_SIZE = 19
};

/* The states' value references, for FMI 1.0's fmiGetStateValueReferences. */
#define STATE_VALUE_REFERENCES {VR_X, VR_X_DOT, VR_THETA, VR_THETA_DOT}

typedef struct {
    double f; /* input force on the cart [N] */
    /* continuous states (also the outputs) */
    double x, x_dot, theta, theta_dot;
    /* their derivatives */
    double der_x, der_x_dot, der_theta, der_theta_dot;
    /* fixed parameters */
    double m_cart, m_pole, length, diameter, density;
    double theta_0, theta_dot_0, x_0, x_dot_0;
    /* tunable: internal RK4 step of co-simulation [s] */
    double cs_step_size;
} ModelData;

#endif /* CARTPOLE_CONFIG_H */
