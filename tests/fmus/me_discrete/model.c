/*
 * model.c -- the Shifter test FMU (see config.h).
 */
#include "model.h"

static void set_start_values(ModelData *m) {
    m->gear = 1;
    m->direction = DIRECTION_FORWARD;
    m->stop = false;
    m->level = 0.0;
    m->bias = 0;
    m->weight = 0;
    m->period = 0.25;
    m->jam_gear = -1;
    m->x = 0.0;
    m->crossings = m->ticks = m->updates = m->shifts = 0;
}

static Status initialize(ModelInstance *comp) {
    ModelData *m = M(comp);
    if (!(m->period > 0.0)) {
        fmu_log(comp, StatusError, LogStatusError, "invalid parameter: need period > 0 (got %g)", m->period);
        return StatusError;
    }
    m->x = 0.0;
    m->crossings = m->ticks = m->updates = m->shifts = 0;
    m->next_tick = comp->s.time + m->period;
    m->seen_gear = m->gear;
    m->above = m->x > m->level;
    return StatusOK;
}

static void get_derivatives(ModelInstance *comp, double dx[]) {
    const ModelData *m = M(comp);
    double sign = m->direction == DIRECTION_REVERSE ? -1.0 : 1.0;
    dx[0] = sign * (m->gear + 0.5 * m->weight) + m->level + 0.25 * (double)m->bias - 0.5 * m->x;
}

static void get_event_indicators(ModelInstance *comp, double z[]) {
    const ModelData *m = M(comp);
    z[0] = m->x - m->level;
}

static void calculate_values(ModelInstance *comp) {
    double dx[NX], z[NZ];
    get_derivatives(comp, dx);
    get_event_indicators(comp, z);
    M(comp)->der_x = dx[0];
    M(comp)->z = z[0];
}

static Status event_update(ModelInstance *comp) {
    ModelData *m = M(comp);
    const double time = comp->s.time;
    bool above;
    m->updates++;
    if (m->gear == m->jam_gear) {
        fmu_log(comp, StatusError, LogStatusError, "gear %d jams at t=%.17g", (int)m->gear, time);
        return StatusError;
    }
    if (m->stop) {
        fmu_log(comp, StatusOK, LogEvents, "stop is set: the model ends the simulation at t=%.17g", time);
        comp->s.event.terminate_simulation = true;
        return StatusOK;
    }
    if (m->gear != m->seen_gear) {
        m->seen_gear = m->gear;
        m->shifts++;
        comp->s.event.new_discrete_states_needed = true;
    }
    while (time >= m->next_tick - 1e-9) {
        m->x *= 0.5;
        m->ticks++;
        m->next_tick += m->period;
        comp->s.event.values_changed = true;
    }
    above = m->x > m->level;
    if (above != m->above) {
        m->above = above;
        m->crossings++;
    }
    comp->s.event.next_event_time_defined = true;
    comp->s.event.next_event_time = m->next_tick;
    return StatusOK;
}

static void get_continuous_states(const ModelData *m, double x[]) { x[0] = m->x; }

static void set_continuous_states(ModelData *m, const double x[]) { m->x = x[0]; }

static const VariableInfo variables[] = {
    INT32_VAR(VR_GEAR, gear, VarInput),
    ENUM_VAR(VR_DIRECTION, direction, VarInput),
    BOOLEAN_VAR(VR_STOP, stop, VarInput),
    FLOAT64_VAR(VR_LEVEL, level, VarInput),
    INT64_VAR(VR_BIAS, bias, VarInput),
    UINT8_VAR(VR_WEIGHT, weight, VarInput),
    FLOAT64_VAR(VR_X, x, VarReadOnly),
    FLOAT64_VAR(VR_DER_X, der_x, VarReadOnly),
    INT32_VAR(VR_CROSSINGS, crossings, VarReadOnly),
    INT32_VAR(VR_TICKS, ticks, VarReadOnly),
    INT32_VAR(VR_UPDATES, updates, VarReadOnly),
    INT32_VAR(VR_SHIFTS, shifts, VarReadOnly),
    FLOAT64_VAR(VR_Z, z, VarReadOnly),
    FLOAT64_VAR(VR_PERIOD, period, VarFixed),
    INT32_VAR(VR_JAM_GEAR, jam_gear, VarFixed),
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
