/*
 * model.c -- the Probe test FMU (see config.h for its variables, equations and
 * build-time variants).
 */
#include <signal.h>
#include <unistd.h>

#include "model.h"

static void set_start_values(ModelData *m) {
    int j;
    m->gear = 0;
    m->mode = MODE_OFF;
    m->enable = false;
    m->boost = false;
    m->force = 0.0;
    for (j = 0; j < 3; j++) {
        m->u[j] = 0.0;
    }
    m->trim = 0;
    m->tag = 0;
    m->position_0 = 0.0;
    m->gain = 1.0;
    m->fault = FAULT_NONE;
    m->fault_after = 0;
    m->position = m->position_0;
    m->steps = 0;
}

static int32_t direction(int32_t mode) {
    return mode == MODE_HEAT ? 1 : mode == MODE_COOL ? -1 : 0;
}

static Status initialize(ModelInstance *comp) {
    ModelData *m = M(comp);
    if (m->gear < 0 || m->gear > 4 || m->mode < MODE_OFF || m->mode > MODE_COOL ||
        m->fault < FAULT_NONE || m->fault > FAULT_HANG || m->fault_after < 0) {
        fmu_log(comp, StatusError, LogStatusError,
                "invalid values: need gear in 0..4, mode in 1..3, fault in 0..3 and "
                "fault_after >= 0 (got gear=%d mode=%d fault=%d fault_after=%d)",
                (int)m->gear, (int)m->mode, (int)m->fault, (int)m->fault_after);
        return StatusError;
    }
    m->position = m->position_0;
    return StatusOK;
}

static void calculate_values(ModelInstance *comp) {
    ModelData *m = M(comp);
    int j;
    m->speed = m->enable ? m->gear * direction(m->mode) * (m->boost ? 2 : 1) : 0;
    m->der_position = m->speed + m->gain * m->force;
    m->clock = comp->s.time;
    m->mode_out = m->mode;
    m->moving = m->der_position != 0.0;
    m->limit = 10.0 * m->gain;
    m->ticks = (int64_t)m->steps * INT64_C(1000000000000);
    m->thrust = (float)(m->gain * m->force);
    m->level = (uint16_t)(1000 + 10 * m->trim);
    m->tag_out = m->tag;
    for (j = 0; j < 3; j++) {
        m->y[0][j] = m->gear * m->u[j];
        m->y[1][j] = m->u[j] + comp->s.time;
        m->positive[j] = m->u[j] > 0.0;
    }
}

static void get_continuous_states(const ModelData *m, double x[]) { x[0] = m->position; }

static void set_continuous_states(ModelData *m, const double x[]) { m->position = x[0]; }

static void get_derivatives(ModelInstance *comp, double dx[]) {
    ModelData *m = M(comp);
    int32_t speed = m->enable ? m->gear * direction(m->mode) * (m->boost ? 2 : 1) : 0;
    dx[0] = speed + m->gain * m->force;
}

/* Fault injection: the doStep after `fault_after` completed ones misbehaves. */
static Status before_step(ModelInstance *comp, double t, double h) {
    ModelData *m = M(comp);
    (void)h;
    if (m->fault != FAULT_NONE && m->steps >= m->fault_after) {
        switch (m->fault) {
        case FAULT_TERMINATE:
            fmu_log(comp, StatusOK, LogEvents, "injected fault: the model ends the simulation at t=%g", t);
            comp->s.event.terminate_simulation = true;
            return StatusDiscard;
        case FAULT_ERROR:
            fmu_log(comp, StatusError, LogStatusError,
                    "injected fault: doStep at t=%g fails after %d steps", t, (int)m->steps);
            return StatusError;
        case FAULT_CRASH: {
            volatile int *null_pointer = NULL;
            *null_pointer = 42;   /* segmentation fault */
            raise(SIGSEGV);       /* in case the write above did not fault */
            return StatusFatal;
        }
        case FAULT_HANG:
            for (;;)
                pause(); /* doStep never returns (until the process is killed) */
        default:
            break;
        }
    }
    m->steps++;
    comp->s.dirty = true;
    return StatusOK;
}

static double cs_step_size(const ModelInstance *comp) {
    (void)comp;
    return 0.01; /* the dynamics are piecewise linear: RK4 is exact at any step */
}

/* ------------------------------------------------- build-time variants */

#ifdef ONCE_PER_PROCESS
static int live_instances = 0;

static Status refuse_a_second_instance(ModelInstance *comp) {
    if (live_instances > 0) {
        fmu_log(comp, StatusError, LogStatusError,
                "this FMU can be instantiated only once per process, and %d instance(s) are alive",
                live_instances);
        return StatusError;
    }
    live_instances++;
    return StatusOK;
}

static void count_a_freed_instance(ModelInstance *comp) {
    (void)comp;
    live_instances--;
}
#endif

#ifdef BUGGY_RESET
/* The bug: the step counter survives fmiReset. */
static void keep_steps(ModelInstance *comp, const ModelData *before) {
    M(comp)->steps = before->steps;
}
#endif

#ifdef NO_SNAPSHOTS
static Status refuse_snapshots(ModelInstance *comp) {
    fmu_log(comp, StatusError, LogStatusError, "getFMUstate is not supported by this FMU");
    return StatusError;
}
#endif

#ifdef INEXACT_SNAPSHOTS
/* The bug: a state that is not restored exactly. */
static void restore_inexactly(ModelInstance *comp) { M(comp)->position += 1e-9; }
#endif

/* ------------------------------------------------------ model definition */

static const VariableInfo variables[] = {
    INT32_VAR(VR_GEAR, gear, VarInput),
    ENUM_VAR(VR_MODE, mode, VarInput),
    BOOLEAN_VAR(VR_ENABLE, enable, VarInput),
    BOOLEAN_VAR(VR_BOOST, boost, VarInput),
    FLOAT64_VAR(VR_FORCE, force, VarInput),
    FLOAT64_VAR(VR_U, u, VarInput),
    INT8_VAR(VR_TRIM, trim, VarInput),
    UINT64_VAR(VR_TAG, tag, VarInput),
    FLOAT64_VAR(VR_POSITION, position, VarReadOnly),
    FLOAT64_VAR(VR_DER_POSITION, der_position, VarReadOnly),
    FLOAT64_VAR(VR_CLOCK, clock, VarReadOnly),
    INT32_VAR(VR_SPEED, speed, VarReadOnly),
    ENUM_VAR(VR_MODE_OUT, mode_out, VarReadOnly),
    BOOLEAN_VAR(VR_MOVING, moving, VarReadOnly),
    INT32_VAR(VR_STEPS, steps, VarReadOnly),
    FLOAT64_VAR(VR_Y, y, VarReadOnly),
    BOOLEAN_VAR(VR_POSITIVE, positive, VarReadOnly),
    INT64_VAR(VR_TICKS, ticks, VarReadOnly),
    FLOAT32_VAR(VR_THRUST, thrust, VarReadOnly),
    UINT16_VAR(VR_LEVEL, level, VarReadOnly),
    UINT64_VAR(VR_TAG_OUT, tag_out, VarReadOnly),
    FLOAT64_VAR(VR_POSITION_0, position_0, VarFixed),
    ENUM_VAR(VR_FAULT, fault, VarFixed),
    INT32_VAR(VR_FAULT_AFTER, fault_after, VarFixed),
    FLOAT64_VAR(VR_GAIN, gain, VarTunable),
    FLOAT64_VAR(VR_LIMIT, limit, VarReadOnly),
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
    .cs_step_size = cs_step_size,
#ifdef ONCE_PER_PROCESS
    .on_instantiate = refuse_a_second_instance,
    .on_free = count_a_freed_instance,
#endif
#ifdef BUGGY_RESET
    .on_reset = keep_steps,
#endif
#ifdef NO_SNAPSHOTS
    .on_get_state = refuse_snapshots,
#endif
#ifdef INEXACT_SNAPSHOTS
    .on_set_state = restore_inexactly,
#endif
};
