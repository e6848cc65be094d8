/*
 * model.c -- the Moody test FMU (see config.h).
 */
#include "model.h"

static void set_start_values(ModelData *m) {
    m->u = 0.0;
    m->tau = 0.5;
    m->x_0 = 0.0;
    m->threshold = 0.5;
    m->ratio = 100.0;
    m->cs_step_size = 1e-3;
    m->x = m->x_0;
    m->effort = 1.0;
}

static double effort(const ModelData *m) { return m->x > m->threshold ? m->ratio : 1.0; }

static Status initialize(ModelInstance *comp) {
    ModelData *m = M(comp);
    if (!(m->tau > 0.0) || !(m->ratio >= 1.0) || !(m->cs_step_size > 0.0)) {
        fmu_log(comp, StatusError, LogStatusError,
                "invalid parameters: need tau > 0, ratio >= 1, cs_step_size > 0 (got tau=%g ratio=%g cs_step_size=%g)",
                m->tau, m->ratio, m->cs_step_size);
        return StatusError;
    }
    m->x = m->x_0;
    m->effort = effort(m);
    return StatusOK;
}

static void get_derivatives(ModelInstance *comp, double dx[]) {
    const ModelData *m = M(comp);
    dx[0] = (m->u - m->x) / m->tau;
}

static void calculate_values(ModelInstance *comp) {
    ModelData *m = M(comp);
    double dx[NX];
    get_derivatives(comp, dx);
    m->der_x = dx[0];
    m->effort = effort(m);
}

static void get_continuous_states(const ModelData *m, double x[]) { x[0] = m->x; }

static void set_continuous_states(ModelData *m, const double x[]) { m->x = x[0]; }

/* the moody phase needs `ratio` times more internal steps */
static double cs_step_size(const ModelInstance *comp) {
    const ModelData *m = &comp->s.data;
    return m->cs_step_size / effort(m);
}

static const VariableInfo variables[] = {
    FLOAT64_VAR(VR_X, x, VarReadOnly),
    FLOAT64_VAR(VR_DER_X, der_x, VarReadOnly),
    FLOAT64_VAR(VR_U, u, VarInput),
    FLOAT64_VAR(VR_TAU, tau, VarFixed),
    FLOAT64_VAR(VR_X_0, x_0, VarFixed),
    FLOAT64_VAR(VR_THRESHOLD, threshold, VarFixed),
    FLOAT64_VAR(VR_RATIO, ratio, VarFixed),
    FLOAT64_VAR(VR_CS_STEP_SIZE, cs_step_size, VarTunable),
    FLOAT64_VAR(VR_EFFORT, effort, VarReadOnly),
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
