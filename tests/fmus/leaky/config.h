/*
 * config.h -- "Leaky", a first-order lag driven by an input and by noise from the
 * FMU's own random number generator, co-simulation only:
 *
 *   der(x) = -x + u + noise_amplitude * n,   x(0) = x_0
 *
 * where n, uniform in [-1, 1), is drawn at the start of every doStep whose input
 * is not zero (the lag is quiet while nothing drives it) from a xorshift64
 * generator seeded at instantiation. The generator's state is kept
 * beside the instance, outside ModelData, as an exporter's solver or noise
 * source often is: it changes every step but not the initial outputs. The plain
 * model saves it with every FMU state and re-seeds it in fmiReset, so every
 * reset rung reproduces a fresh instance. The noise is co-simulation's (its
 * doStep draws it); model exchange integrates the lag without it.
 *
 * Build-time variants (preprocessor definitions; lifecycle hooks in model.c):
 *   LEAKY_SNAPSHOT  getFMUstate/setFMUstate leave the generator out: a restored
 *                   snapshot goes on with the numbers where the last episode
 *                   left them (fmiReset still re-seeds)
 *   LEAKY_RESET     fmiReset leaves the generator as it was
 */
#ifndef LEAKY_CONFIG_H
#define LEAKY_CONFIG_H

#include <stdint.h>

#define NX 1
#define NZ 0

enum {
    VR_X = 1,
    VR_DER_X = 2,
    VR_U = 3,
    VR_X_0 = 4,
    VR_NOISE_AMPLITUDE = 5,
    VR_CS_STEP_SIZE = 6
};

typedef struct {
    double x, der_x;
    double u;
    double x_0, noise_amplitude, cs_step_size;
    double noise;          /* noise_amplitude * n of the current step (not a variable) */
    uint64_t saved_random; /* the generator's state, copied in when a snapshot is taken */
} ModelData;

#endif /* LEAKY_CONFIG_H */
