/*
 * config.h -- "NoOutputs", a damped oscillator pushed by an input force that declares no outputs:
 * its continuous states x and v are local variables, the shape of third-party model-exchange FMUs
 * that `modelicagym info` observes through their states.
 *
 *   der(x) = v,  der(v) = f - k * x - c * v
 */
#ifndef NOOUTPUTS_CONFIG_H
#define NOOUTPUTS_CONFIG_H

#define NX 2 /* x, v */
#define NZ 0

enum { VR_X = 1, VR_DER_X = 2, VR_V = 3, VR_DER_V = 4, VR_F = 5, VR_K = 6, VR_C = 7, VR_X_0 = 8 };

typedef struct {
    double x, der_x, v, der_v;
    double f;
    double k, c, x_0;
} ModelData;

#endif /* NOOUTPUTS_CONFIG_H */
