/*
 * model.c -- the Stiff test FMU (see config.h).
 */
#include "model.h"

static void set_start_values(ModelData *m) {
    m->u = 1.0;
    m->lambda = 1e4;
    m->x1_0 = 0.0;
    m->x2_0 = 0.0;
    m->cs_step_size = 1e-5;
    m->x1 = m->x1_0;
    m->x2 = m->x2_0;
}

static Status initialize(ModelInstance *comp) {
    ModelData *m = M(comp);
    if (!(m->lambda > 0.0) || !(m->cs_step_size > 0.0)) {
        fmu_log(comp, StatusError, LogStatusError,
                "invalid parameters: need lambda > 0, cs_step_size > 0 (got lambda=%g cs_step_size=%g)",
                m->lambda, m->cs_step_size);
        return StatusError;
    }
    m->x1 = m->x1_0;
    m->x2 = m->x2_0;
    return StatusOK;
}

static void get_derivatives(ModelInstance *comp, double dx[]) {
    const ModelData *m = M(comp);
    dx[0] = -m->lambda * (m->x1 - m->u);
    dx[1] = m->x1 - m->x2;
}

static void calculate_values(ModelInstance *comp) {
    ModelData *m = M(comp);
    double dx[NX];
    get_derivatives(comp, dx);
    m->der_x1 = dx[0];
    m->der_x2 = dx[1];
}

static void get_continuous_states(const ModelData *m, double x[]) {
    x[0] = m->x1;
    x[1] = m->x2;
}

static void set_continuous_states(ModelData *m, const double x[]) {
    m->x1 = x[0];
    m->x2 = x[1];
}

static double cs_step_size(const ModelInstance *comp) { return comp->s.data.cs_step_size; }

static const VariableInfo variables[] = {
    FLOAT64_VAR(VR_X1, x1, VarReadOnly),
    FLOAT64_VAR(VR_DER_X1, der_x1, VarReadOnly),
    FLOAT64_VAR(VR_X2, x2, VarReadOnly),
    FLOAT64_VAR(VR_DER_X2, der_x2, VarReadOnly),
    FLOAT64_VAR(VR_U, u, VarInput),
    FLOAT64_VAR(VR_LAMBDA, lambda, VarFixed),
    FLOAT64_VAR(VR_X1_0, x1_0, VarFixed),
    FLOAT64_VAR(VR_X2_0, x2_0, VarFixed),
    FLOAT64_VAR(VR_CS_STEP_SIZE, cs_step_size, VarTunable),
};

const ModelDefinition model_definition = {
    .variables = variables,
    .n_variables = sizeof variables / sizeof variables[0],
    .set_start_values = set_start_values,
    .initialize = initialize,
    .calculate_values = calculate_values,
    .get_continuous_states = get_continuous_states,
    .set_continuous_states = set_continuous_states,
    .get_derivatives = get_derivatives,
    .cs_step_size = cs_step_size,
};
