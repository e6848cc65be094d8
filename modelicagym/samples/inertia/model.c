/*
 * model.c -- the Inertia sample FMU (see config.h for its equations).
 */
#include "model.h"

static void set_start_values(ModelData *m) {
    m->phi = 0.0;
    m->tau = 0.0;
    m->tau_load = 0.0;
    m->J = 0.01;
    m->d = 0.001;
    m->w_0 = 0.0;
    m->w = m->w_0;
}

static Status initialize(ModelInstance *comp) {
    ModelData *m = M(comp);
    if (!(m->J > 0.0)) {
        fmu_log(comp, StatusError, LogStatusError, "invalid parameter: need J > 0 (got J=%g)", m->J);
        return StatusError;
    }
    m->phi = 0.0;
    m->w = m->w_0;
    return StatusOK;
}

static void get_derivatives(ModelInstance *comp, double dx[]) {
    const ModelData *m = M(comp);
    dx[0] = m->w;
    dx[1] = (m->tau + m->tau_load - m->d * m->w) / m->J;
}

static void calculate_values(ModelInstance *comp) {
    ModelData *m = M(comp);
    double dx[NX];
    get_derivatives(comp, dx);
    m->der_phi = dx[0];
    m->der_w = dx[1];
    m->a = dx[1];
}

static void get_continuous_states(const ModelData *m, double x[]) {
    x[0] = m->phi;
    x[1] = m->w;
}

static void set_continuous_states(ModelData *m, const double x[]) {
    m->phi = x[0];
    m->w = x[1];
}

static double cs_step_size(const ModelInstance *comp) {
    (void)comp;
    return 1e-3;
}

static const VariableInfo variables[] = {
    FLOAT64_VAR(VR_PHI, phi, VarReadOnly),
    FLOAT64_VAR(VR_DER_PHI, der_phi, VarReadOnly),
    FLOAT64_VAR(VR_W, w, VarReadOnly),
    FLOAT64_VAR(VR_DER_W, der_w, VarReadOnly),
    FLOAT64_VAR(VR_TAU, tau, VarInput),
    FLOAT64_VAR(VR_TAU_LOAD, tau_load, VarInput),
    FLOAT64_VAR(VR_A, a, VarReadOnly),
    FLOAT64_VAR(VR_J, J, VarFixed),
    FLOAT64_VAR(VR_D, d, VarFixed),
    FLOAT64_VAR(VR_W_0, w_0, VarFixed),
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
