/*
 * model.c -- the Stimulus test FMU (see config.h for its equations).
 */
#include "model.h"

static void set_start_values(ModelData *m) {
    m->height = 1.0;
    m->offset = 0.0;
    m->start_time = 0.0;
    m->load_k = -0.5;
}

static void calculate_values(ModelInstance *comp) {
    ModelData *m = M(comp);
    m->y = m->offset + (comp->s.time >= m->start_time ? m->height : 0.0);
    m->load = m->load_k;
}

static const VariableInfo variables[] = {
    FLOAT64_VAR(VR_Y, y, VarReadOnly),
    FLOAT64_VAR(VR_LOAD, load, VarReadOnly),
    FLOAT64_VAR(VR_HEIGHT, height, VarTunable),
    FLOAT64_VAR(VR_OFFSET, offset, VarTunable),
    FLOAT64_VAR(VR_START_TIME, start_time, VarTunable),
    FLOAT64_VAR(VR_LOAD_K, load_k, VarFixed),
};

const ModelDefinition model_definition = {
    .variables = variables,
    .n_variables = sizeof variables / sizeof variables[0],
    .set_start_values = set_start_values,
    .calculate_values = calculate_values,
};
