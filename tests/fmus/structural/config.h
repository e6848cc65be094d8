/*
 * config.h -- "Lags": a cascade of `stages` first-order lags driven by the input u,
 * where `stages` is a structural parameter (causality="structuralParameter", UInt64): as the
 * standard demands, it can be set in configuration mode only (the framework's VarStructural), so
 * an importer that sets it like any parameter gets an Error from fmi3SetUInt64. FMI 2.0 has no
 * structural parameters: its model description leaves `stages` out (it stays at 2).
 *
 *   der(x1) = (u - x1) / tau,  der(xi) = (x(i-1) - xi) / tau  for i <= stages (else 0),
 *   y = x(stages)
 */
#ifndef STRUCTURAL_CONFIG_H
#define STRUCTURAL_CONFIG_H

#include <stdint.h>

#define NX 4 /* x1..x4: the largest cascade */
#define NZ 0
#define MAX_STAGES 4

enum { VR_X = 1, VR_DER_X = 5, VR_U = 9, VR_Y = 10, VR_TAU = 11, VR_STAGES = 12 };

typedef struct {
    double x[MAX_STAGES], der_x[MAX_STAGES];
    double u, y;
    double tau;
    uint64_t stages;
} ModelData;

#endif /* STRUCTURAL_CONFIG_H */
