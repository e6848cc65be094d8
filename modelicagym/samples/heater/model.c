/*
 * model.c -- the RoomHeater sample FMU (see config.h for its equations).
 */
#include "model.h"

static void set_start_values(ModelData *m) {
    m->u = 0.0;
    m->C = 6e4;
    m->G = 100.0;
    m->P_max = 3000.0;
    m->T_amb = 5.0;
    m->T_0 = 15.0;
    m->T = m->T_0;
}

static Status initialize(ModelInstance *comp) {
    ModelData *m = M(comp);
    if (!(m->C > 0.0) || !(m->G >= 0.0) || !(m->P_max >= 0.0)) {
        fmu_log(comp, StatusError, LogStatusError, "invalid parameters: need C > 0, G >= 0, P_max >= 0 (got C=%g G=%g P_max=%g)",
                m->C, m->G, m->P_max);
        return StatusError;
    }
    m->T = m->T_0;
    return StatusOK;
}

static double heating_power(const ModelData *m) {
    const double u = m->u < 0.0 ? 0.0 : (m->u > 1.0 ? 1.0 : m->u);
    return m->P_max * u;
}

static void get_derivatives(ModelInstance *comp, double dx[]) {
    const ModelData *m = M(comp);
    dx[0] = (heating_power(m) - m->G * (m->T - m->T_amb)) / m->C;
}

static void calculate_values(ModelInstance *comp) {
    ModelData *m = M(comp);
    double dx[NX];
    get_derivatives(comp, dx);
    m->der_T = dx[0];
    m->P = heating_power(m);
}

static void get_continuous_states(const ModelData *m, double x[]) { x[0] = m->T; }

static void set_continuous_states(ModelData *m, const double x[]) { m->T = x[0]; }

/* co-simulation's internal RK4 step: a second is exact enough for a 600 s time constant */
static double cs_step_size(const ModelInstance *comp) {
    (void)comp;
    return 1.0;
}

static const VariableInfo variables[] = {
    FLOAT64_VAR(VR_T, T, VarReadOnly),
    FLOAT64_VAR(VR_DER_T, der_T, VarReadOnly),
    FLOAT64_VAR(VR_U, u, VarInput),
    FLOAT64_VAR(VR_P, P, VarReadOnly),
    FLOAT64_VAR(VR_C, C, VarFixed),
    FLOAT64_VAR(VR_G, G, VarFixed),
    FLOAT64_VAR(VR_P_MAX, P_max, VarFixed),
    FLOAT64_VAR(VR_T_AMB, T_amb, VarFixed),
    FLOAT64_VAR(VR_T_0, T_0, VarFixed),
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
