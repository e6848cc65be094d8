/*
 * model.c -- the NoOutputs test FMU (see config.h).
 */
#include "model.h"

static void set_start_values(ModelData *m) {
    m->f = 0.0;
    m->k = 4.0;
    m->c = 0.5;
    m->x_0 = 1.0;
    m->x = m->x_0;
    m->v = 0.0;
}

static Status initialize(ModelInstance *comp) {
    ModelData *m = M(comp);
    if (!(m->k > 0.0) || !(m->c >= 0.0)) {
        fmu_log(comp, StatusError, LogStatusError,
                "invalid parameters: need k > 0, c >= 0 (got k=%g c=%g)", m->k, m->c);
        return StatusError;
    }
    m->x = m->x_0;
    m->v = 0.0;
    return StatusOK;
}

static void get_derivatives(ModelInstance *comp, double dx[]) {
    const ModelData *m = M(comp);
    dx[0] = m->v;
    dx[1] = m->f - m->k * m->x - m->c * m->v;
}

static void calculate_values(ModelInstance *comp) {
    ModelData *m = M(comp);
    double dx[NX];
    get_derivatives(comp, dx);
    m->der_x = dx[0];
    m->der_v = dx[1];
}

static void get_continuous_states(const ModelData *m, double x[]) {
    x[0] = m->x;
    x[1] = m->v;
}

static void set_continuous_states(ModelData *m, const double x[]) {
    m->x = x[0];
    m->v = x[1];
}

static const VariableInfo variables[] = {
    FLOAT64_VAR(VR_X, x, VarReadOnly),
    FLOAT64_VAR(VR_DER_X, der_x, VarReadOnly),
    FLOAT64_VAR(VR_V, v, VarReadOnly),
    FLOAT64_VAR(VR_DER_V, der_v, VarReadOnly),
    FLOAT64_VAR(VR_F, f, VarInput),
    FLOAT64_VAR(VR_K, k, VarFixed),
    FLOAT64_VAR(VR_C, c, VarFixed),
    FLOAT64_VAR(VR_X_0, x_0, VarFixed),
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
};
