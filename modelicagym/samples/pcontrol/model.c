/*
 * model.c -- the PControl test FMU (see config.h for its equation).
 */
#include "model.h"

static void set_start_values(ModelData *m) {
    m->r = 0.0;
    m->u = 0.0;
    m->k = 1.0;
}

static void calculate_values(ModelInstance *comp) {
    ModelData *m = M(comp);
    m->y = m->k * (m->r - m->u);
}

static const VariableInfo variables[] = {
    FLOAT64_VAR(VR_R, r, VarInput),
    FLOAT64_VAR(VR_U, u, VarInput),
    FLOAT64_VAR(VR_Y, y, VarReadOnly),
    FLOAT64_VAR(VR_K, k, VarTunable),
};

const ModelDefinition model_definition = {
    .variables = variables,
    .n_variables = sizeof variables / sizeof variables[0],
    .set_start_values = set_start_values,
    .calculate_values = calculate_values,
};
