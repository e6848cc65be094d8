/*
 * model.c -- the Lags test FMU (see config.h).
 */
#include "model.h"

static void set_start_values(ModelData *m) {
    int i;
    for (i = 0; i < MAX_STAGES; i++) {
        m->x[i] = 0.0;
    }
    m->u = 0.0;
    m->tau = 0.5;
    m->stages = 2;
}

static Status initialize(ModelInstance *comp) {
    ModelData *m = M(comp);
    int i;
    if (!(m->tau > 0.0) || m->stages < 1 || m->stages > MAX_STAGES) {
        fmu_log(comp, StatusError, LogStatusError,
                "invalid parameters: need tau > 0, stages in [1, %d] (got tau=%g stages=%llu)",
                MAX_STAGES, m->tau, (unsigned long long)m->stages);
        return StatusError;
    }
    for (i = 0; i < MAX_STAGES; i++) {
        m->x[i] = 0.0;
    }
    return StatusOK;
}

static void get_derivatives(ModelInstance *comp, double dx[]) {
    const ModelData *m = M(comp);
    int i;
    for (i = 0; i < MAX_STAGES; i++) {
        const double in = i == 0 ? m->u : m->x[i - 1];
        dx[i] = (uint64_t)i < m->stages ? (in - m->x[i]) / m->tau : 0.0;
    }
}

static void calculate_values(ModelInstance *comp) {
    ModelData *m = M(comp);
    get_derivatives(comp, m->der_x);
    m->y = m->x[m->stages - 1];
}

static void get_continuous_states(const ModelData *m, double x[]) {
    int i;
    for (i = 0; i < MAX_STAGES; i++) {
        x[i] = m->x[i];
    }
}

static void set_continuous_states(ModelData *m, const double x[]) {
    int i;
    for (i = 0; i < MAX_STAGES; i++) {
        m->x[i] = x[i];
    }
}

#define STAGE(i) \
    FLOAT64_VAR(VR_X + (i), x[i], VarReadOnly), FLOAT64_VAR(VR_DER_X + (i), der_x[i], VarReadOnly)

static const VariableInfo variables[] = {
    STAGE(0), STAGE(1), STAGE(2), STAGE(3),
    FLOAT64_VAR(VR_U, u, VarInput),
    FLOAT64_VAR(VR_Y, y, VarReadOnly),
    FLOAT64_VAR(VR_TAU, tau, VarFixed),
    UINT64_VAR(VR_STAGES, stages, VarStructural),
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
