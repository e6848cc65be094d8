/*
 * model.c -- the Staircase test FMU (see config.h).
 */
#include "model.h"

#include <math.h>

/* A time event is due this close before its time, as importers may reach it a little early:
 * co-simulation handles an event that lies within 1e-6 internal steps after a communication
 * point at that point (fmu_solver.c), and a fixed-step model-exchange solver whose summed
 * steps come within rounding of nextEventTime may call that the event. */
#define EVENT_TOLERANCE (1e-6 * DEFAULT_CS_STEP_SIZE)

/* The state an episode starts from: x at rest on the ground floor, no stair taken yet. */
static void reset_state(ModelData *m) {
    m->x = 0.0;
    m->level = 0.0;
    m->t_last_event = -1.0;
    m->steps_taken = 0;
    m->iterations = 0;
    m->stopped = false;
    m->pending = false;
}

static void set_start_values(ModelData *m) {
    m->u = 0.0;
    m->period = 0.3;
    m->height = 1.0;
    m->t_stop = 100.0;
    m->k = 2.0;
    reset_state(m);
}

static Status initialize(ModelInstance *comp) {
    ModelData *m = M(comp);
    if (!(m->period > 0.0)) {
        fmu_log(comp, StatusError, LogStatusError, "invalid parameters: need period > 0 (got period=%g)",
                m->period);
        return StatusError;
    }
    reset_state(m);
    return StatusOK;
}

static void get_derivatives(ModelInstance *comp, double dx[]) {
    const ModelData *m = M(comp);
    dx[0] = m->level - m->k * m->x + m->u;
}

static void calculate_values(ModelInstance *comp) {
    ModelData *m = M(comp);
    get_derivatives(comp, &m->der_x);
}

static Status event_update(ModelInstance *comp) {
    ModelData *m = M(comp);
    const double time = comp->s.time;
    const double t_stair = (double)(m->steps_taken + 1) * m->period;
    m->iterations++;
    if (time >= m->t_stop - EVENT_TOLERANCE) {
        m->stopped = true;
        m->t_last_event = time;
        comp->s.event.terminate_simulation = true;
        fmu_log(comp, StatusOK, LogEvents, "stop at t=%.17g", time);
        return StatusOK;
    }
    if (time >= t_stair - EVENT_TOLERANCE) {
        if ((m->steps_taken + 1) % 3 == 0 && !m->pending) {
            m->pending = true; /* every 3rd stair: take it on the next pass */
            comp->s.event.new_discrete_states_needed = true;
            return StatusOK;
        }
        m->pending = false;
        m->level += m->height;
        m->steps_taken++;
        m->t_last_event = time;
        fmu_log(comp, StatusOK, LogEvents, "stair %d at t=%.17g: level = %g", (int)m->steps_taken, time,
                m->level);
    }
    comp->s.event.next_event_time_defined = true;
    comp->s.event.next_event_time = fmin((double)(m->steps_taken + 1) * m->period, m->t_stop);
    return StatusOK;
}

static void get_continuous_states(const ModelData *m, double x[]) { x[0] = m->x; }

static void set_continuous_states(ModelData *m, const double x[]) { m->x = x[0]; }

static const VariableInfo variables[] = {
    FLOAT64_VAR(VR_X, x, VarReadOnly),
    FLOAT64_VAR(VR_DER_X, der_x, VarReadOnly),
    FLOAT64_VAR(VR_U, u, VarInput),
    FLOAT64_VAR(VR_PERIOD, period, VarFixed),
    FLOAT64_VAR(VR_HEIGHT, height, VarFixed),
    FLOAT64_VAR(VR_T_STOP, t_stop, VarFixed),
    FLOAT64_VAR(VR_K, k, VarFixed),
    FLOAT64_VAR(VR_LEVEL, level, VarReadOnly),
    INT32_VAR(VR_STEPS_TAKEN, steps_taken, VarReadOnly),
    FLOAT64_VAR(VR_T_LAST_EVENT, t_last_event, VarReadOnly),
    INT32_VAR(VR_ITERATIONS, iterations, VarReadOnly),
    BOOLEAN_VAR(VR_STOPPED, stopped, VarReadOnly),
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
    .event_update = event_update,
};
