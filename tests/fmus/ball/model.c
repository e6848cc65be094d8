/*
 * model.c -- the Ball test FMU (see config.h).
 */
#include "model.h"

#define V_MIN 0.1 /* below this rebound speed the ball stays on the ground */

static void set_start_values(ModelData *m) {
    m->a = 0.0;
    m->g = 9.81;
    m->e = 0.8;
    m->e_late = 0.5;
    m->t_switch = 1.5;
    m->h_0 = 1.0;
    m->cs_step_size = 1e-3;
    m->h = m->h_0;
    m->v = 0.0;
    m->e_now = m->e;
    m->bounces = 0;
    m->t_bounce = -1.0;
    m->t_switched = -1.0;
    m->switched = false;
    m->resting = false;
}

static Status initialize(ModelInstance *comp) {
    ModelData *m = M(comp);
    if (!(m->g > 0.0) || !(m->e >= 0.0 && m->e <= 1.0) || !(m->e_late >= 0.0 && m->e_late <= 1.0) ||
        !(m->h_0 >= 0.0) || !(m->cs_step_size > 0.0)) {
        fmu_log(comp, StatusError, LogStatusError,
                "invalid parameters: need g > 0, e and e_late in [0, 1], h_0 >= 0, cs_step_size > 0 "
                "(got g=%g e=%g e_late=%g h_0=%g cs_step_size=%g)",
                m->g, m->e, m->e_late, m->h_0, m->cs_step_size);
        return StatusError;
    }
    m->h = m->h_0;
    m->v = 0.0;
    m->e_now = m->e;
    m->bounces = 0;
    m->t_bounce = -1.0;
    m->t_switched = -1.0;
    m->switched = false;
    m->resting = false;
    return StatusOK;
}

static void get_derivatives(ModelInstance *comp, double dx[]) {
    const ModelData *m = M(comp);
    dx[0] = m->resting ? 0.0 : m->v;
    dx[1] = m->resting ? 0.0 : m->a - m->g;
}

static void get_event_indicators(ModelInstance *comp, double z[]) {
    const ModelData *m = M(comp);
    z[0] = m->resting ? 1.0 : m->h;
}

static void calculate_values(ModelInstance *comp) {
    ModelData *m = M(comp);
    double dx[NX], z[NZ];
    get_derivatives(comp, dx);
    get_event_indicators(comp, z);
    m->der_h = dx[0];
    m->der_v = dx[1];
    m->z = z[0];
}

static Status event_update(ModelInstance *comp) {
    ModelData *m = M(comp);
    const double time = comp->s.time;
    if (!m->switched && time >= m->t_switch) {
        m->switched = true;
        m->e_now = m->e_late;
        m->t_switched = time;
        fmu_log(comp, StatusOK, LogEvents, "time event at t=%.17g: e = %g", time, m->e_now);
    }
    if (!m->resting && m->h <= 0.0 && m->v < 0.0) {
        m->h = 0.0;
        m->v = -m->e_now * m->v;
        m->bounces++;
        m->t_bounce = time;
        if (m->v < V_MIN) {
            m->v = 0.0;
            m->resting = true;
        }
        comp->s.event.values_changed = true;
        fmu_log(comp, StatusOK, LogEvents, "bounce %d at t=%.17g", (int)m->bounces, time);
    }
    if (!m->switched) {
        comp->s.event.next_event_time_defined = true;
        comp->s.event.next_event_time = m->t_switch;
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

static double cs_step_size(const ModelInstance *comp) { return comp->s.data.cs_step_size; }

static const VariableInfo variables[] = {
    FLOAT64_VAR(VR_H, h, VarReadOnly),
    FLOAT64_VAR(VR_DER_H, der_h, VarReadOnly),
    FLOAT64_VAR(VR_V, v, VarReadOnly),
    FLOAT64_VAR(VR_DER_V, der_v, VarReadOnly),
    FLOAT64_VAR(VR_A, a, VarInput),
    FLOAT64_VAR(VR_G, g, VarFixed),
    FLOAT64_VAR(VR_E, e, VarFixed),
    FLOAT64_VAR(VR_E_LATE, e_late, VarFixed),
    FLOAT64_VAR(VR_T_SWITCH, t_switch, VarFixed),
    FLOAT64_VAR(VR_H_0, h_0, VarFixed),
    FLOAT64_VAR(VR_E_NOW, e_now, VarReadOnly),
    INT32_VAR(VR_BOUNCES, bounces, VarReadOnly),
    FLOAT64_VAR(VR_T_BOUNCE, t_bounce, VarReadOnly),
    FLOAT64_VAR(VR_T_SWITCHED, t_switched, VarReadOnly),
    FLOAT64_VAR(VR_CS_STEP_SIZE, cs_step_size, VarTunable),
    FLOAT64_VAR(VR_Z, z, VarReadOnly),
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
    .cs_step_size = cs_step_size,
};
