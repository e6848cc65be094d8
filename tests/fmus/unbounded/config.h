/*
 * config.h -- "Tank": a vessel whose pressure p follows the ambient pressure p_amb,
 * an input in Pa that declares no min/max (start 101325), as exporters often leave it. Random
 * actions on an unbounded Box are drawn around 0 Pa, where the model's correlations do not hold:
 * doStep then logs an error and returns Error, the shape of a third-party FMU whose solver went
 * into an error loop on such inputs.
 *
 *   der(p) = (p_amb - p) / tau,  rho = p / (R_AIR * T)
 *   doStep (co-simulation) fails while p_amb is outside [P_LOW, P_HIGH].
 */
#ifndef UNBOUNDED_CONFIG_H
#define UNBOUNDED_CONFIG_H

#define NX 1 /* p */
#define NZ 0
#define P_LOW 2e4  /* Pa */
#define P_HIGH 5e5 /* Pa */
#define R_AIR 287.05

enum { VR_P = 1, VR_DER_P = 2, VR_P_AMB = 3, VR_RHO = 4, VR_TAU = 5, VR_T = 6 };

typedef struct {
    double p, der_p;
    double p_amb, rho;
    double tau, T;
} ModelData;

#endif /* UNBOUNDED_CONFIG_H */
