/*
 * model.c -- the Tank test FMU (see config.h).
 */
#include "model.h"

static void set_start_values(ModelData *m) {
    m->p_amb = 101325.0;
    m->tau = 1.0;
    m->T = 293.15;
    m->p = 101325.0;
}

static Status initialize(ModelInstance *comp) {
    ModelData *m = M(comp);
    if (!(m->tau > 0.0) || !(m->T > 0.0)) {
        fmu_log(comp, StatusError, LogStatusError,
                "invalid parameters: need tau > 0, T > 0 (got tau=%g T=%g)", m->tau, m->T);
        return StatusError;
    }
    m->p = 101325.0;
    return StatusOK;
}

static void get_derivatives(ModelInstance *comp, double dx[]) {
    const ModelData *m = M(comp);
    dx[0] = (m->p_amb - m->p) / m->tau;
}

static void calculate_values(ModelInstance *comp) {
    ModelData *m = M(comp);
    double dx[NX];
    get_derivatives(comp, dx);
    m->der_p = dx[0];
    m->rho = m->p / (R_AIR * m->T);
}

static Status before_step(ModelInstance *comp, double t, double h) {
    const ModelData *m = M(comp);
    (void)h;
    if (!(m->p_amb >= P_LOW && m->p_amb <= P_HIGH)) {
        fmu_log(comp, StatusError, LogStatusError,
                "t=%g: ambient pressure %g Pa is outside the range of the model's correlations "
                "[%g, %g] Pa", t, m->p_amb, P_LOW, P_HIGH);
        return StatusError;
    }
    return StatusOK;
}

static void get_continuous_states(const ModelData *m, double x[]) { x[0] = m->p; }

static void set_continuous_states(ModelData *m, const double x[]) { m->p = x[0]; }

static const VariableInfo variables[] = {
    FLOAT64_VAR(VR_P, p, VarReadOnly),
    FLOAT64_VAR(VR_DER_P, der_p, VarReadOnly),
    FLOAT64_VAR(VR_P_AMB, p_amb, VarInput),
    FLOAT64_VAR(VR_RHO, rho, VarReadOnly),
    FLOAT64_VAR(VR_TAU, tau, VarFixed),
    FLOAT64_VAR(VR_T, T, VarFixed),
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
    .before_step = before_step,
};
