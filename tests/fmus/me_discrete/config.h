/*
 * config.h -- "Shifter", a model-exchange test FMU whose discrete inputs change its dynamics and
 * its events (the family: tests/fmu_family.py), as OpenModelica or Dymola exports with Integer
 * and Boolean inputs do. FMI lets an importer set such inputs in event mode only.
 *
 *   inputs   gear (Int32, 0..3), direction (enumeration Direction: forward=1, reverse=2),
 *            stop (Boolean), level (Float64, variability "discrete", -1..1),
 *            FMI 3.0 only: bias (Int64, -3..3), weight (UInt8, 0..4)
 *   outputs  x (continuous state), crossings, ticks, updates, shifts (Int32)
 *   params   period (fixed, > 0), jam_gear (fixed, Int32; -1: none)
 *
 * Equations:
 *   der(x) = sign(direction) * (gear + 0.5 * weight) + level + 0.25 * bias - 0.5 * x
 *   event indicator z = x - level: a state event where x crosses the level (crossings += 1)
 *   time events every `period`: x jumps to x / 2 (ticks += 1)
 * Every event update (updates += 1; input events included):
 *   gear == jam_gear: the update fails (Error, with a logged message);
 *   stop: the model asks to terminate the simulation;
 *   a gear other than the last one seen: shifts += 1, and a second pass is needed.
 */
#ifndef SHIFTER_CONFIG_H
#define SHIFTER_CONFIG_H

#include <stdbool.h>
#include <stdint.h>

#define NX 1 /* x */
#define NZ 1 /* x - level */

enum {
    VR_GEAR = 1,
    VR_DIRECTION = 2,
    VR_STOP = 3,
    VR_LEVEL = 4,
    VR_BIAS = 5,
    VR_WEIGHT = 6,
    VR_X = 10,
    VR_DER_X = 11,
    VR_CROSSINGS = 12,
    VR_TICKS = 13,
    VR_UPDATES = 14,
    VR_SHIFTS = 15,
    VR_Z = 16,
    VR_PERIOD = 20,
    VR_JAM_GEAR = 21
};

enum { DIRECTION_FORWARD = 1, DIRECTION_REVERSE = 2 };

typedef struct {
    /* inputs */
    int32_t gear, direction;
    bool stop;
    double level;
    int64_t bias;
    uint8_t weight;
    /* state, derivative, outputs */
    double x, der_x, z;
    int32_t crossings, ticks, updates, shifts;
    /* parameters */
    double period;
    int32_t jam_gear;
    /* discrete states */
    double next_tick;
    int32_t seen_gear;
    bool above;
} ModelData;

#endif /* SHIFTER_CONFIG_H */
