/*
 * model.c -- the Motor sample FMU (see config.h for its equations).
 */
#include "model.h"

static void set_start_values(ModelData *m) {
    m->tau = 0.0;
    m->u = 0.0;
    m->w = 0.0;
    m->k = 0.5;
    m->T_m = 0.05;
    m->w_max = 3000.0;
}

static double torque_set(const ModelData *m) { return m->k * (m->u - m->w / m->w_max); }

static void get_derivatives(ModelInstance *comp, double dx[]) {
    const ModelData *m = M(comp);
    dx[0] = (torque_set(m) - m->tau) / m->T_m;
}

static void calculate_values(ModelInstance *comp) {
    ModelData *m = M(comp);
    double dx[NX];
    get_derivatives(comp, dx);
    m->der_tau = dx[0];
    m->tau_set = torque_set(m);
    m->saturated = m->u > 1.0 || m->u < -1.0;
}

static void get_continuous_states(const ModelData *m, double x[]) { x[0] = m->tau; }

static void set_continuous_states(ModelData *m, const double x[]) { m->tau = x[0]; }

static double cs_step_size(const ModelInstance *comp) {
    (void)comp;
    return 1e-3;
}

static const VariableInfo variables[] = {
    FLOAT64_VAR(VR_TAU, tau, VarReadOnly),
    FLOAT64_VAR(VR_DER_TAU, der_tau, VarReadOnly),
    FLOAT64_VAR(VR_U, u, VarInput),
    FLOAT64_VAR(VR_W, w, VarInput),
    FLOAT64_VAR(VR_TAU_SET, tau_set, VarReadOnly),
    FLOAT64_VAR(VR_K, k, VarTunable),
    FLOAT64_VAR(VR_T_M, T_m, VarFixed),
    FLOAT64_VAR(VR_W_MAX, w_max, VarFixed),
    BOOLEAN_VAR(VR_SATURATED, saturated, VarReadOnly),
};

const ModelDefinition model_definition = {
    .variables = variables,
    .n_variables = sizeof variables / sizeof variables[0],
    .set_start_values = set_start_values,
    .calculate_values = calculate_values,
    .get_continuous_states = get_continuous_states,
    .set_continuous_states = set_continuous_states,
    .get_derivatives = get_derivatives,
    .cs_step_size = cs_step_size,
};
