/*
 * config.h -- "SlowInit", a first-order lag whose initialization takes long, as
 * FMUs with a big initial-equation system do (one FMPy report: 140 s of a 240 s
 * run): the test FMU of the pool's init="once" and its start-time benchmark.
 *
 *   der(x) = (u - x) / tau,  y = x,  x(0) = x_0
 *   input u (Float64, -1..1), output y, parameters tau (> 0), x_0,
 *   init_seconds (>= 0): CPU seconds fmiExitInitializationMode spends, busy,
 *   before it sets x = x_0 (a solver's work: it uses a core, as a real one does)
 */
#ifndef SLOWINIT_CONFIG_H
#define SLOWINIT_CONFIG_H

#define NX 1 /* x */
#define NZ 0

enum { VR_Y = 1, VR_DER_X = 2, VR_U = 3, VR_TAU = 4, VR_X_0 = 5, VR_INIT_SECONDS = 6 };

typedef struct {
    double x, der_x;
    double u;
    double tau, x_0, init_seconds;
} ModelData;

#endif /* SLOWINIT_CONFIG_H */
