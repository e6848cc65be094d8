/*
 * fmu_solver.c -- event updates, the fixed-step RK4 co-simulation step and the
 * model-exchange calls, independent of the FMI version (see fmu_instance.h).
 */
#include "fmu_internal.h"

#include <math.h>

#define MAX_EVENT_ITERATIONS 100
#define STATE_EVENT_TOLERANCE 1e-12 /* relative, in time */

/* ---------------------------------------------------------------- events */

/* One event update: clear the flags, let the model update, log what happened. */
static Status event_update(ModelInstance *comp) {
    EventFlags *e = &comp->s.event;
    Status status = StatusOK;
    e->new_discrete_states_needed = false;
    e->terminate_simulation = false;
    e->nominals_changed = false;
    e->values_changed = false;
    e->next_event_time_defined = false;
    if (model_definition.event_update) {
        status = model_definition.event_update(comp);
    }
    comp->s.dirty = true;
    fmu_log(comp, StatusOK, LogEvents,
            "event update at t=%.17g: values changed %d, terminate %d, next event %s%.17g",
            comp->s.time, e->values_changed, e->terminate_simulation,
            e->next_event_time_defined ? "at t=" : "undefined, ",
            e->next_event_time_defined ? e->next_event_time : 0.0);
    return status;
}

static void store_event_indicators(ModelInstance *comp) {
    if (NZ > 0) {
        model_definition.get_event_indicators(comp, comp->s.z_prev);
    }
}

/* Co-simulation: iterate event updates until the model is settled. */
Status fmu_cs_event_iteration(ModelInstance *comp) {
    int i;
    for (i = 0; i < MAX_EVENT_ITERATIONS; i++) {
        Status status = event_update(comp);
        if (status > StatusWarning || comp->s.event.terminate_simulation ||
            !comp->s.event.new_discrete_states_needed) {
            store_event_indicators(comp);
            return status;
        }
    }
    return fmu_fail(comp, "event iteration did not converge after %d updates", MAX_EVENT_ITERATIONS);
}

/* ----------------------------------------------------- co-simulation RK4 */

/* Evaluate dx/dt at time t for the states x (written into ModelData). */
static void derivatives_at(ModelInstance *comp, double t, const double x[], double dx[]) {
    comp->s.time = t;
    model_definition.set_continuous_states(M(comp), x);
    model_definition.get_derivatives(comp, dx);
}

/* One classical Runge-Kutta step from t to t_next; leaves time at t_next. */
static void rk4_substep(ModelInstance *comp, double t, double t_next) {
    const double dt = t_next - t;
    double x0[NX_ALLOC], xt[NX_ALLOC], k1[NX_ALLOC], k2[NX_ALLOC], k3[NX_ALLOC], k4[NX_ALLOC];
    int i;
    if (NX > 0) {
        model_definition.get_continuous_states(M(comp), x0);
        comp->s.time = t;
        model_definition.get_derivatives(comp, k1);
        for (i = 0; i < NX; i++) {
            xt[i] = x0[i] + 0.5 * dt * k1[i];
        }
        derivatives_at(comp, t + 0.5 * dt, xt, k2);
        for (i = 0; i < NX; i++) {
            xt[i] = x0[i] + 0.5 * dt * k2[i];
        }
        derivatives_at(comp, t + 0.5 * dt, xt, k3);
        for (i = 0; i < NX; i++) {
            xt[i] = x0[i] + dt * k3[i];
        }
        derivatives_at(comp, t_next, xt, k4);
        for (i = 0; i < NX; i++) {
            xt[i] = x0[i] + dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
        model_definition.set_continuous_states(M(comp), xt);
    }
    comp->s.time = t_next;
    comp->s.dirty = true;
}

/* Has an event indicator changed sign since z_prev (the last accepted substep end)? */
static bool indicators_crossed(ModelInstance *comp) {
    double z[NZ_ALLOC];
    int i;
    if (NZ == 0) {
        return false;
    }
    model_definition.get_event_indicators(comp, z);
    for (i = 0; i < NZ; i++) {
        if ((z[i] > 0.0) != (comp->s.z_prev[i] > 0.0)) {
            return true;
        }
    }
    return false;
}

/* A substep from t (states x0) to t_hi crossed an indicator: bisect the substep length
 * down to STATE_EVENT_TOLERANCE and leave the states just past the crossing. */
static double locate_state_event(ModelInstance *comp, double t, const double x0[], double t_hi) {
    double t_lo = t;
    while (t_hi - t_lo > STATE_EVENT_TOLERANCE * fmax(1.0, fabs(t_hi))) {
        const double t_mid = 0.5 * (t_lo + t_hi);
        model_definition.set_continuous_states(M(comp), x0);
        rk4_substep(comp, t, t_mid);
        if (indicators_crossed(comp)) {
            t_hi = t_mid;
        } else {
            t_lo = t_mid;
        }
    }
    model_definition.set_continuous_states(M(comp), x0);
    rk4_substep(comp, t, t_hi);
    return t_hi;
}

static bool time_event_due(const ModelInstance *comp, double t, double eps) {
    return comp->s.event.next_event_time_defined && comp->s.event.next_event_time <= t + eps;
}

/* Integrate from t_start to t_end on a substep grid anchored at t_start (re-anchored at
 * events). Time events cut a substep at next_event_time; state events are located in
 * their substep by bisection. */
static Status integrate(ModelInstance *comp, double t_start, double t_end, double hs) {
    const double eps = 1e-6 * hs; /* shorter final substeps merge into the previous one */
    double t = t_start, anchor = t_start;
    double x0[NX_ALLOC];
    long k = 0;
    comp->s.time = t_start;
    for (;;) {
        bool time_event = time_event_due(comp, t, eps);
        if (time_event && comp->s.event.next_event_time > t) {
            /* a time event within rounding ahead: step to it exactly (the model decides at its
             * own time whether it has come), or leave it to the next doStep if it lies beyond */
            if (comp->s.event.next_event_time > t_end) {
                time_event = false;
            } else {
                rk4_substep(comp, t, comp->s.event.next_event_time);
                t = comp->s.event.next_event_time;
            }
        }
        if (indicators_crossed(comp) || time_event) {
            Status status = fmu_cs_event_iteration(comp);
            if (status > StatusWarning) {
                return status;
            }
            if (comp->s.event.terminate_simulation) {
                comp->s.terminated = true;
                comp->s.last_successful_time = t;
                return StatusDiscard;
            }
            if (time_event_due(comp, t, 0.0)) {
                return fmu_fail(comp, "next_event_time %.17g does not lie after t=%.17g",
                                comp->s.event.next_event_time, t);
            }
            anchor = t;
            k = 0;
        }
        if (t >= t_end) {
            break;
        }
        {
            double t_next = anchor + (double)(k + 1) * hs;
            if (t_next > t_end - eps) {
                t_next = t_end;
            }
            if (comp->s.event.next_event_time_defined && comp->s.event.next_event_time < t_next) {
                t_next = comp->s.event.next_event_time;
            }
            if (NX > 0) {
                model_definition.get_continuous_states(M(comp), x0);
            }
            rk4_substep(comp, t, t_next);
            if (NX > 0 && indicators_crossed(comp)) {
                t_next = locate_state_event(comp, t, x0, t_next);
            }
            t = t_next;
            k++;
        }
    }
    comp->s.time = t_end;
    comp->s.last_successful_time = t_end;
    return StatusOK;
}

Status fmu_do_step(ModelInstance *comp, double t, double h, bool *terminated,
                   double *last_successful_time) {
    Status status = StatusOK;
    double hs;
    if (!comp) {
        return StatusError;
    }
    if (comp->type != CoSimulation) {
        return fmu_fail(comp, "doStep: the instance was instantiated for model exchange");
    }
    if (!fmu_allowed(comp, "doStep", ModeStep)) {
        return StatusError;
    }
    if (comp->s.terminated) {
        fmu_log(comp, StatusDiscard, LogStatusDiscard, "doStep: the simulation has terminated");
        status = StatusDiscard;
    } else if (!(h >= 0.0)) {
        return fmu_fail(comp, "doStep: communicationStepSize %.17g must be >= 0", h);
    } else if (fabs(t - comp->s.time) > 1e-9 * fmax(1.0, fabs(t))) {
        return fmu_fail(comp, "doStep: currentCommunicationPoint %.17g differs from the FMU time %.17g",
                    t, comp->s.time);
    } else {
        hs = model_definition.cs_step_size ? model_definition.cs_step_size(comp) : DEFAULT_CS_STEP_SIZE;
        if (!(hs > 0.0)) {
            return fmu_fail(comp, "doStep: internal step size %.17g must be > 0", hs);
        }
        comp->s.time = t;
        if (model_definition.before_step) {
            status = model_definition.before_step(comp, t, h);
            if (status >= StatusError) {
                comp->s.mode = ModeError;
                return status;
            }
            if (comp->s.event.terminate_simulation) {
                comp->s.terminated = true;
                status = StatusDiscard;
            }
        }
        if (status != StatusDiscard) {
            status = integrate(comp, t, t + h, hs);
            if (status >= StatusError) {
                comp->s.mode = ModeError;
            }
        } else {
            comp->s.last_successful_time = t;
        }
    }
    *terminated = comp->s.terminated;
    *last_successful_time = comp->s.last_successful_time;
    return status;
}

/* ------------------------------------------------------- model exchange */

static Status check_me(ModelInstance *comp, const char *function, unsigned modes) {
    if (comp->type != ModelExchange) {
        return fmu_fail(comp, "%s: the instance was instantiated for co-simulation", function);
    }
    return fmu_allowed(comp, function, modes) ? StatusOK : StatusError;
}

static Status check_size(ModelInstance *comp, const char *function, size_t n, size_t expected,
                         const void *array) {
    if (n != expected) {
        return fmu_fail(comp, "%s: %zu values given, the model has %zu", function, n, expected);
    }
    if (n > 0 && !array) {
        return fmu_fail(comp, "%s: NULL array", function);
    }
    return StatusOK;
}

Status fmu_set_time(ModelInstance *comp, double time) {
    if (!comp || check_me(comp, "setTime", ModeEvent | ModeContinuousTime) != StatusOK) {
        return StatusError;
    }
    comp->s.time = time;
    comp->s.dirty = true;
    return StatusOK;
}

Status fmu_set_continuous_states(ModelInstance *comp, const double x[], size_t nx) {
    if (!comp || check_me(comp, "setContinuousStates", ModeEvent | ModeContinuousTime) != StatusOK ||
        check_size(comp, "setContinuousStates", nx, NX, x) != StatusOK) {
        return StatusError;
    }
    if (NX > 0) {
        model_definition.set_continuous_states(M(comp), x);
    }
    comp->s.dirty = true;
    return StatusOK;
}

Status fmu_get_continuous_states(ModelInstance *comp, double x[], size_t nx) {
    Status status;
    if (!comp || !fmu_allowed(comp, "getContinuousStates", MODES_INITIALIZED | ModeError) ||
        check_size(comp, "getContinuousStates", nx, NX, x) != StatusOK) {
        return StatusError;
    }
    status = fmu_update_values(comp);
    if (NX > 0 && status <= StatusWarning) {
        model_definition.get_continuous_states(M(comp), x);
    }
    return status;
}

/* Before get_derivatives / get_event_indicators: they read ModelData's states, inputs and
 * parameters only (the RK4 calls them so), not calculated values. Only initialization mode, where
 * the initialize hook computes states from parameters, needs the values brought up to date; a
 * solver's many right-hand sides between two reads of the outputs skip calculate_values. */
static Status prepare_model_functions(ModelInstance *comp) {
    return comp->s.mode == ModeInitialization ? fmu_update_values(comp) : StatusOK;
}

Status fmu_get_derivatives(ModelInstance *comp, double dx[], size_t nx) {
    Status status;
    int i;
    if (!comp || !fmu_allowed(comp, "getDerivatives", MODES_INITIALIZED | ModeError) ||
        check_size(comp, "getDerivatives", nx, NX, dx) != StatusOK) {
        return StatusError;
    }
    status = prepare_model_functions(comp);
    if (NX > 0 && status <= StatusWarning) {
        model_definition.get_derivatives(comp, dx);
        for (i = 0; i < NX; i++) {
            if (!isfinite(dx[i])) {
                return fmu_fail(comp, "getDerivatives: the derivative of state %d is %g at t=%.17g", i, dx[i],
                                comp->s.time);
            }
        }
    }
    return status;
}

Status fmu_get_event_indicators(ModelInstance *comp, double z[], size_t nz) {
    Status status;
    if (!comp || !fmu_allowed(comp, "getEventIndicators", MODES_INITIALIZED | ModeError) ||
        check_size(comp, "getEventIndicators", nz, NZ, z) != StatusOK) {
        return StatusError;
    }
    status = prepare_model_functions(comp);
    if (NZ > 0 && status <= StatusWarning) {
        model_definition.get_event_indicators(comp, z);
    }
    return status;
}

Status fmu_get_nominals(ModelInstance *comp, double nominals[], size_t nx) {
    size_t i;
    if (!comp || check_size(comp, "getNominalsOfContinuousStates", nx, NX, nominals) != StatusOK) {
        return StatusError;
    }
    for (i = 0; i < nx; i++) {
        nominals[i] = 1.0;
    }
    return StatusOK;
}

Status fmu_enter_event_mode(ModelInstance *comp) {
    if (!comp || check_me(comp, "enterEventMode", ModeEvent | ModeContinuousTime) != StatusOK) {
        return StatusError;
    }
    comp->s.mode = ModeEvent;
    return StatusOK;
}

Status fmu_update_discrete_states(ModelInstance *comp, EventFlags *flags) {
    Status status;
    if (!comp || check_me(comp, "updateDiscreteStates", ModeEvent) != StatusOK) {
        return StatusError;
    }
    status = event_update(comp);
    *flags = comp->s.event;
    return status;
}

Status fmu_enter_continuous_time_mode(ModelInstance *comp) {
    if (!comp || check_me(comp, "enterContinuousTimeMode", ModeEvent) != StatusOK) {
        return StatusError;
    }
    comp->s.mode = ModeContinuousTime;
    return StatusOK;
}

Status fmu_completed_integrator_step(ModelInstance *comp, bool *enter_event_mode,
                                     bool *terminate_simulation) {
    if (!comp || check_me(comp, "completedIntegratorStep", ModeContinuousTime) != StatusOK) {
        return StatusError;
    }
    *enter_event_mode = false;
    *terminate_simulation = false;
    return StatusOK;
}


Status fmu_me_event_update(ModelInstance *comp, bool intermediate, EventFlags *flags) {
    Status status = StatusOK, s;
    bool values_changed = false;
    int i;
    if (!comp) {
        return StatusError;
    }
    if (comp->s.mode == ModeContinuousTime) {
        status = fmu_enter_event_mode(comp);
        if (status > StatusWarning) {
            return status;
        }
    }
    for (i = 0; i < MAX_EVENT_ITERATIONS; i++) {
        s = fmu_update_discrete_states(comp, flags);
        status = s > status ? s : status;
        values_changed = values_changed || flags->values_changed;
        flags->values_changed = values_changed;
        if (status > StatusWarning || flags->terminate_simulation) {
            return status;
        }
        if (!flags->new_discrete_states_needed) {
            s = fmu_enter_continuous_time_mode(comp);
            return s > status ? s : status;
        }
        if (intermediate) {
            return status;
        }
    }
    return fmu_fail(comp, "event iteration did not converge after %d updates", MAX_EVENT_ITERATIONS);
}
