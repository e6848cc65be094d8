/*
 * model.c -- the NoInputs test FMU (see config.h).
 */
#include "model.h"

#define V_MIN 0.1 /* below this rebound speed the ball stays on the ground */

static void set_start_values(ModelData *m) {
    m->g = 9.81;
    m->e = 0.7;
    m->h_0 = 1.0;
    m->h = m->h_0;
    m->v = 0.0;
    m->bounces = 0;
    m->resting = false;
}

static Status initialize(ModelInstance *comp) {
    ModelData *m = M(comp);
    if (!(m->g > 0.0) || !(m->e >= 0.0 && m->e <= 1.0) || !(m->h_0 >= 0.0)) {
        fmu_log(comp, StatusError, LogStatusError,
                "invalid parameters: need g > 0, e in [0, 1], h_0 >= 0 (got g=%g e=%g h_0=%g)",
                m->g, m->e, m->h_0);
        return StatusError;
    }
    m->h = m->h_0;
    m->v = 0.0;
    m->bounces = 0;
    m->resting = false;
    return StatusOK;
}

static void get_derivatives(ModelInstance *comp, double dx[]) {
    const ModelData *m = M(comp);
    dx[0] = m->resting ? 0.0 : m->v;
    dx[1] = m->resting ? 0.0 : -m->g;
}

static void get_event_indicators(ModelInstance *comp, double z[]) {
    const ModelData *m = M(comp);
    z[0] = m->resting ? 1.0 : m->h;
}

static void calculate_values(ModelInstance *comp) {
    ModelData *m = M(comp);
    double dx[NX];
    get_derivatives(comp, dx);
    m->der_h = dx[0];
    m->der_v = dx[1];
}

static Status event_update(ModelInstance *comp) {
    ModelData *m = M(comp);
    if (!m->resting && m->h <= 0.0 && m->v < 0.0) {
        m->h = 0.0;
        m->v = -m->e * m->v;
        m->bounces++;
        if (m->v < V_MIN) {
            m->v = 0.0;
            m->resting = true;
        }
        comp->s.event.values_changed = true;
    }
    return StatusOK;
}

static void get_continuous_states(const ModelData *m, double x[]) {
    x[0] = m->h;
    x[1] = m->v;
}

static void set_continuous_states(ModelData *m, const double x[]) {
    m->h = x[0];
    m->v = x[1];
}

static const VariableInfo variables[] = {
    FLOAT64_VAR(VR_H, h, VarReadOnly),
    FLOAT64_VAR(VR_DER_H, der_h, VarReadOnly),
    FLOAT64_VAR(VR_V, v, VarReadOnly),
    FLOAT64_VAR(VR_DER_V, der_v, VarReadOnly),
    FLOAT64_VAR(VR_G, g, VarFixed),
    FLOAT64_VAR(VR_E, e, VarTunable),
    FLOAT64_VAR(VR_H_0, h_0, VarFixed),
    INT32_VAR(VR_BOUNCES, bounces, VarReadOnly),
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
    .get_event_indicators = get_event_indicators,
    .event_update = event_update,
};
