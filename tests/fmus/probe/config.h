/*
 * config.h -- "Probe", the test FMU for what the runtime must handle besides
 * floats (the family: tests/fmu_family.py):
 *
 *   inputs   gear (Int32, 0..4), mode (enumeration Mode: off=1, heat=2, cool=3),
 *            enable, boost (Boolean), force (Float64, -10..10),
 *            FMI 3.0 only: u (Float64[3]), trim (Int8, -100..100),
 *            tag (UInt64, no bounds)
 *   outputs  position (continuous state), clock (= time), speed (Int32, -8..8),
 *            mode_out (Mode), moving (Boolean), steps (Int32, no bounds),
 *            FMI 3.0 only: y (Float64[2,3]), positive (Boolean[3]), ticks (Int64),
 *            thrust (Float32), level (UInt16, no bounds), tag_out (UInt64)
 *   params   position_0, fault (enumeration Fault), fault_after (fixed),
 *            gain (tunable), limit (calculated: 10 * gain, cannot be set)
 *
 * Equations:
 *   speed     = enable ? gear * direction(mode) * (boost ? 2 : 1) : 0
 *               with direction(off) = 0, direction(heat) = +1, direction(cool) = -1
 *   der(position) = speed + gain * force
 *   y[0][j] = gear * u[j],  y[1][j] = u[j] + time,  positive[j] = u[j] > 0
 *   steps     = number of doStep calls in this episode (co-simulation)
 *   ticks     = steps * 10^12 (beyond the Int32 range)
 *   thrust    = gain * force, rounded to Float32
 *   level     = 1000 + 10 * trim
 *   tag_out   = tag
 *
 * Fault injection (co-simulation): the doStep after `fault_after` completed
 * ones ends the episode (fault = terminate: Discard + terminated), fails with a
 * logged message (fault = error) or crashes the process with SIGSEGV
 * (fault = crash), or never returns (fault = hang).
 *
 * Build-time variants (preprocessor definitions; lifecycle hooks in model.c):
 *   ONCE_PER_PROCESS  refuse a second live instance in the process
 *   NO_SNAPSHOTS      refuse getFMUstate (pair with canGetAndSetFMUstate="false")
 *   BUGGY_RESET       fmiReset leaves `steps` un-reset (an exporter bug)
 *   INEXACT_SNAPSHOTS setFMUstate restores `position` with an error of 1e-9
 */
#ifndef PROBE_CONFIG_H
#define PROBE_CONFIG_H

#include <stdbool.h>
#include <stdint.h>

#define NX 1 /* position */
#define NZ 0

enum {
    VR_GEAR = 1,
    VR_MODE = 2,
    VR_ENABLE = 3,
    VR_BOOST = 4,
    VR_FORCE = 5,
    VR_U = 6,
    VR_POSITION = 10,
    VR_DER_POSITION = 11,
    VR_CLOCK = 12,
    VR_SPEED = 13,
    VR_MODE_OUT = 14,
    VR_MOVING = 15,
    VR_STEPS = 16,
    VR_Y = 17,
    VR_POSITIVE = 18,
    VR_TICKS = 19,
    VR_POSITION_0 = 20,
    VR_FAULT = 21,
    VR_FAULT_AFTER = 22,
    VR_GAIN = 23,
    VR_LIMIT = 24,
    VR_TRIM = 25,
    VR_TAG = 26,
    VR_THRUST = 27,
    VR_LEVEL = 28,
    VR_TAG_OUT = 29
};

enum { MODE_OFF = 1, MODE_HEAT = 2, MODE_COOL = 3 };
enum { FAULT_NONE = 0, FAULT_TERMINATE = 1, FAULT_ERROR = 2, FAULT_CRASH = 3, FAULT_HANG = 4 };

typedef struct {
    /* inputs */
    int32_t gear, mode;
    bool enable, boost;
    double force;
    double u[3];
    int8_t trim;
    uint64_t tag;
    /* state, derivative and outputs */
    double position, der_position, clock;
    int32_t speed, mode_out, steps;
    bool moving;
    double y[2][3];
    bool positive[3];
    int64_t ticks;
    float thrust;
    uint16_t level;
    uint64_t tag_out;
    /* parameters */
    double position_0, gain, limit;
    int32_t fault, fault_after;
} ModelData;

#endif /* PROBE_CONFIG_H */
