/*
 * config.h -- "Stimulus", a source without inputs, in the shape of the stimulus FMU of OMSimulator's
 * DC-motor SSP (Modelica.Blocks.Sources.Step and Constant exported together): the signals a test
 * bench feeds a system under test, set by parameters.
 *
 *   y = offset + (time >= start_time ? height : 0)
 *   load = load_k
 *
 *   outputs y, load
 *   parameters height, offset, start_time (tunable; start_time in s), load_k (fixed)
 *
 * A system of it and a plant has no input: what an agent can act on is its tunable levels.
 */
#ifndef STIMULUS_CONFIG_H
#define STIMULUS_CONFIG_H

#define NX 0
#define NZ 0

enum { VR_Y = 1, VR_LOAD = 2, VR_HEIGHT = 3, VR_OFFSET = 4, VR_START_TIME = 5, VR_LOAD_K = 6 };

typedef struct {
    double y, load, height, offset, start_time, load_k;
} ModelData;

#endif /* STIMULUS_CONFIG_H */
