/*
 * model.c -- the FeedPlant test FMU (see config.h for its equations).
 */
#include "model.h"

static void set_start_values(ModelData *m) {
    m->u = 0.0;
    m->d = 0.5;
    m->x_0 = 0.0;
    m->x = m->x_0;
}

static Status initialize(ModelInstance *comp) {
    ModelData *m = M(comp);
    m->x = m->x_0;
    return StatusOK;
}

static void get_derivatives(ModelInstance *comp, double dx[]) { dx[0] = M(comp)->u; }

static void calculate_values(ModelInstance *comp) {
    ModelData *m = M(comp);
    m->der_x = m->u;
    m->y = m->x + m->d * m->u;
}

static void get_continuous_states(const ModelData *m, double x[]) { x[0] = m->x; }

static void set_continuous_states(ModelData *m, const double x[]) { m->x = x[0]; }

static double cs_step_size(const ModelInstance *comp) {
    (void)comp;
    return 1e-3;
}

static const VariableInfo variables[] = {
    FLOAT64_VAR(VR_X, x, VarReadOnly),
    FLOAT64_VAR(VR_DER_X, der_x, VarReadOnly),
    FLOAT64_VAR(VR_U, u, VarInput),
    FLOAT64_VAR(VR_Y, y, VarReadOnly),
    FLOAT64_VAR(VR_D, d, VarTunable),
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
    .cs_step_size = cs_step_size,
};
