/*
 * model.c -- the Noisy test FMU (see config.h).
 */
#include <math.h>

#include "model.h"

static void set_start_values(ModelData *m) {
    m->x = 0.0;
    m->u = 0.0;
    m->u_max = 10.0;
    m->warnings_per_step = 2;
    m->errors_per_step = 500;
    m->stuck = 0;
}

static void get_derivatives(ModelInstance *comp, double dx[]) {
    const ModelData *m = M(comp);
    dx[0] = m->stuck ? 0.0 : -m->x + m->u;
}

static void calculate_values(ModelInstance *comp) {
    double dx[NX];
    get_derivatives(comp, dx);
    M(comp)->der_x = dx[0];
}

static void get_continuous_states(const ModelData *m, double x[]) { x[0] = m->x; }

static void set_continuous_states(ModelData *m, const double x[]) { m->x = x[0]; }

static Status before_step(ModelInstance *comp, double t, double h) {
    ModelData *m = M(comp);
    m->stuck = !(fabs(m->u) <= m->u_max);
    if (m->stuck) {
        for (int k = 1; k <= m->errors_per_step; k++)
            fmu_log(comp, StatusError, LogStatusError,
                    "solver: step size %g below its minimum at t=%g (u=%g), retry %d", h * 1e-9, t, m->u, k);
        return StatusOK; /* the bug: it says OK anyway */
    }
    for (int k = 1; k <= m->warnings_per_step; k++)
        fmu_log(comp, StatusWarning, LogStatusWarning, "solver: reduced the step at t=%g (%d of %d)", t, k,
                m->warnings_per_step);
    return StatusOK;
}

static const VariableInfo variables[] = {
    FLOAT64_VAR(VR_X, x, VarReadOnly),
    FLOAT64_VAR(VR_DER_X, der_x, VarReadOnly),
    FLOAT64_VAR(VR_U, u, VarInput),
    FLOAT64_VAR(VR_U_MAX, u_max, VarFixed),
    INT32_VAR(VR_WARNINGS_PER_STEP, warnings_per_step, VarFixed),
    INT32_VAR(VR_ERRORS_PER_STEP, errors_per_step, VarFixed),
};

const ModelDefinition model_definition = {
    .variables = variables,
    .n_variables = sizeof variables / sizeof variables[0],
    .set_start_values = set_start_values,
    .calculate_values = calculate_values,
    .get_continuous_states = get_continuous_states,
    .set_continuous_states = set_continuous_states,
    .get_derivatives = get_derivatives,
    .before_step = before_step,
};
