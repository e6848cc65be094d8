/* See step.h. */
#define _GNU_SOURCE
#include "step.h"

#include <math.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "signal.h"

typedef int (*fmi2_values_t)(void *, const uint32_t *, size_t, void *); /* FMI 1.0 and 2.0 fmiSet/Get<Type> */
typedef int (*fmi3_values_t)(void *, const uint32_t *, size_t, void *, size_t);
typedef int (*fmi1_do_step_t)(void *, double, double, char);
typedef int (*fmi2_do_step_t)(void *, double, double, int);
typedef int (*fmi2_get_boolean_status_t)(void *, int, int *);
typedef int (*fmi3_do_step_t)(void *, double, double, bool, bool *, bool *, bool *, double *);
typedef int (*set_state_t)(void *, void *);

enum { OK = 0, WARNING = 1, DISCARD = 2 };
enum { FMI2_TERMINATED_STATUS_KIND = 3 };

/* The worst status of a list of fmiSet/fmiGet calls (ValueBuffer.read/write: max of their statuses). */
static int call_all(const mg_env *env, const mg_call *calls, int64_t n) {
    int worst = OK;
    for (int64_t k = 0; k < n; k++) {
        const mg_call *c = &calls[k];
        int status = env->fmi_version == 3
                         ? ((fmi3_values_t)c->function)(env->component, c->refs, (size_t)c->n_refs, c->values,
                                                        (size_t)c->n_values)
                         : ((fmi2_values_t)c->function)(env->component, c->refs, (size_t)c->n_refs, c->values);
        if (status > worst)
            worst = status;
    }
    return worst;
}

static int set_inputs(mg_env *env) { return call_all(env, env->set_calls, env->n_set_calls); }

/* -- moves: numpy's assignment casts, in C --------------------------------------------------------
 * A source value is read exactly as a double (float types), an int64 (signed, bool) or a uint64,
 * and cast from there to the target type directly (an int64 to float32 rounds once, as numpy does). */

typedef enum { AS_DOUBLE, AS_INT, AS_UINT } value_class;
typedef struct {
    value_class kind;
    double d;
    int64_t i;
    uint64_t u;
} value;

static value load(const void *p, int32_t type) {
    value v = {AS_INT, 0.0, 0, 0};
    switch (type) {
    case MG_TYPE_F64: v.kind = AS_DOUBLE; v.d = *(const double *)p; break;
    case MG_TYPE_F32: v.kind = AS_DOUBLE; v.d = *(const float *)p; break;
    case MG_TYPE_I8: v.i = *(const int8_t *)p; break;
    case MG_TYPE_U8: v.i = *(const uint8_t *)p; break;
    case MG_TYPE_I16: v.i = *(const int16_t *)p; break;
    case MG_TYPE_U16: v.i = *(const uint16_t *)p; break;
    case MG_TYPE_I32: v.i = *(const int32_t *)p; break;
    case MG_TYPE_U32: v.i = *(const uint32_t *)p; break;
    case MG_TYPE_I64: v.i = *(const int64_t *)p; break;
    case MG_TYPE_U64: v.kind = AS_UINT; v.u = *(const uint64_t *)p; break;
    default: v.i = *(const bool *)p; break;
    }
    return v;
}

#define CAST(T, v) ((v).kind == AS_DOUBLE ? (T)(v).d : (v).kind == AS_INT ? (T)(v).i : (T)(v).u)

static double as_double(value v) { return CAST(double, v); }

/* Write v to p as `type`; true if that changed the bytes there. */
static bool store(void *p, int32_t type, value v) {
#define PUT(T)                                                                                                     \
    do {                                                                                                           \
        T x = CAST(T, v);                                                                                          \
        bool changed = memcmp(p, &x, sizeof x) != 0;                                                               \
        memcpy(p, &x, sizeof x);                                                                                   \
        return changed;                                                                                            \
    } while (0)
    switch (type) {
    case MG_TYPE_F64: PUT(double);
    case MG_TYPE_F32: PUT(float);
    case MG_TYPE_I8: PUT(int8_t);
    case MG_TYPE_U8: PUT(uint8_t);
    case MG_TYPE_I16: PUT(int16_t);
    case MG_TYPE_U16: PUT(uint16_t);
    case MG_TYPE_I32: PUT(int32_t);
    case MG_TYPE_U32: PUT(uint32_t);
    case MG_TYPE_I64: PUT(int64_t);
    case MG_TYPE_U64: PUT(uint64_t);
    default: {
        bool x = v.kind == AS_DOUBLE ? v.d != 0.0 : v.kind == AS_INT ? v.i != 0 : v.u != 0;
        bool changed = *(bool *)p != x;
        *(bool *)p = x;
        return changed;
    }
    }
#undef PUT
}

/* Read the outputs and convert them into the observation. */
static int get_outputs(mg_env *env) {
    int status = call_all(env, env->get_calls, env->n_get_calls);
    for (int64_t k = 0; k < env->n_outputs; k++) {
        const mg_move *m = &env->observation_moves[k];
        store(env->observation + m->target, m->target_type, load((const void *)(intptr_t)m->source, m->source_type));
    }
    return status;
}

/* doStep as `binding.do_step_call` maps it: OK, `ended` set when the model ended the simulation
 * (discard + terminated in FMI 2; terminateSimulation in FMI 3), else the failing status. */
static int do_step(mg_env *env, double t, double h, bool *ended) {
    *ended = false;
    if (env->fmi_version == 1) { /* FMI 1.0 cannot say the model ended: a discard is a failure */
        int status = ((fmi1_do_step_t)env->do_step)(env->component, t, h, 1);
        return status <= WARNING ? OK : status;
    }
    if (env->fmi_version == 2) {
        int status = ((fmi2_do_step_t)env->do_step)(env->component, t, h, 1);
        if (status <= WARNING)
            return OK;
        if (status == DISCARD) {
            int terminated = 0;
            int s = ((fmi2_get_boolean_status_t)env->get_boolean_status)(env->component, FMI2_TERMINATED_STATUS_KIND,
                                                                         &terminated);
            if (s <= WARNING && terminated) {
                *ended = true;
                return OK;
            }
        }
        return status;
    }
    bool event = false, terminate = false, early = false;
    double last = 0.0;
    int status = ((fmi3_do_step_t)env->do_step)(env->component, t, h, true, &event, &terminate, &early, &last);
    if (terminate && status <= DISCARD) {
        *ended = true;
        return OK;
    }
    return status <= WARNING ? OK : status;
}

static int32_t fail(mg_env *env, int call, int status) {
    env->fmi_status = status;
    env->failed_call = call;
    env->clock->broken = 1;
    return MG_FMU_ERROR;
}

/* Convert the action's values into the inputs; false (nothing written) if one is outside the
 * action space's bounds or not finite (the single env leaves this check of an array's values to C).
 * In model exchange, new input values end the solver's continuous run. */
static bool write_action(mg_env *env, const void *action) {
    const char *row = action;
    if (env->discrete) {
        int64_t index = *(const int64_t *)action;
        if (index < 0 || index >= env->n_actions)
            return false;
        row = (const char *)(env->action_table + index * env->n_inputs);
    } else if (env->action_low) {
        for (int64_t k = 0; k < env->n_inputs; k++) {
            const mg_move *m = &env->action_moves[k];
            double x = as_double(load(row + m->source, m->source_type));
            if (!(isfinite(x) && env->action_low[k] <= x && x <= env->action_high[k]))
                return false; /* NaN and infinity too, as check_action refuses them */
        }
    }
    bool changed = false;
    for (int64_t k = 0; k < env->n_inputs; k++) {
        const mg_move *m = &env->action_moves[k];
        changed |= store((void *)(intptr_t)m->target, m->target_type, load(row + m->source, m->source_type));
    }
    if (env->integrator && changed)
        env->integrator->continuous = 0;
    return true;
}

/* The recorder's row: the bytes of the calls' buffers, one after the other (ValueBuffer.snapshot). */
static void record_values(char *row, const mg_call *calls, int64_t n) {
    for (int64_t k = 0; k < n; k++) {
        memcpy(row, calls[k].values, (size_t)calls[k].n_bytes);
        row += calls[k].n_bytes;
    }
}

/* Model exchange with discrete inputs, as FMUInstance.step: FMI lets a step set them in event mode
 * only, so it sets the time, enters event mode, sets the inputs, settles the event iteration
 * (`ended`: the model asked to terminate) and returns to continuous-time mode. */
static int32_t set_inputs_in_event_mode(mg_env *env, double now, bool *ended) {
    mg_integrator *integrator = env->integrator;
    int32_t outcome = mg_integrator_enter_event(integrator, now);
    if (outcome == MG_INTEGRATOR_OK) {
        int status = set_inputs(env);
        if (status > WARNING)
            return fail(env, MG_CALL_SET_INPUTS, status);
        outcome = mg_integrator_settle_event(integrator, now);
    }
    if (outcome == MG_INTEGRATOR_FAILED)
        return fail(env, MG_CALL_INTEGRATE, 0);
    *ended = outcome == MG_INTEGRATOR_TERMINATE;
    return 0;
}

static int32_t advance_system(mg_env *env);

/* A new time step counts its steps from the current time (simulation time is origin + steps * dt: no drift). */
static void rebase_clock(mg_clock *clock, double dt) {
    if (dt != clock->dt) {
        clock->origin = clock->time;
        clock->dt = dt;
        clock->steps = 0;
    }
}

/* FMUInstance.step: set inputs, doStep (or integrate) to origin + (steps + 1) * dt, get outputs. */
static int32_t advance(mg_env *env) {
    if (env->system)
        return advance_system(env);
    mg_clock *clock = env->clock;
    double dt = env->time_step;
    rebase_clock(clock, dt);
    double now = clock->time;
    double target = clock->origin + (double)(clock->steps + 1) * dt;
    int64_t started = mg_now_ns();
    bool ended = false;
    int status;
    if (env->event_mode_inputs) {
        int32_t flags = set_inputs_in_event_mode(env, now, &ended);
        if (flags)
            return flags;
    } else if ((status = set_inputs(env)) > WARNING) {
        return fail(env, MG_CALL_SET_INPUTS, status);
    }
    /* ended already: the model ended the simulation in the inputs' event; no integration, as the Python path */
    if (!ended && env->integrator) {
        int32_t outcome = mg_integrator_advance(env->integrator, now, target);
        if (outcome == MG_INTEGRATOR_FAILED)
            return fail(env, MG_CALL_INTEGRATE, 0);
        ended = outcome == MG_INTEGRATOR_TERMINATE;
    } else if (!ended) {
        status = do_step(env, now, target - now, &ended);
        if (status != OK)
            return fail(env, MG_CALL_DO_STEP, status);
    }
    if (ended || env->integrator) /* model exchange, as FMUInstance.step: each step says anew (a step past the end too) */
        clock->terminated = ended;
    clock->steps += 1;
    clock->time = target;
    status = get_outputs(env);
    clock->fmu_time_ns += mg_now_ns() - started;
    if (status > WARNING)
        return fail(env, MG_CALL_GET_OUTPUTS, status);
    if (clock->log_errors) { /* as FMUInstance.step: an error loop ends the episode */
        if (clock->log_errors > clock->log_error_limit)
            return fail(env, MG_CALL_LOG_ERRORS, OK);
        clock->log_errors = 0;
    }
    mg_recorder *recorder = clock->recorder;
    if (recorder && recorder->count < recorder->capacity) { /* as Reference.record */
        int64_t k = recorder->count++;
        recorder->dts[k] = dt;
        record_values(recorder->inputs + k * recorder->input_bytes, env->set_calls, env->n_set_calls);
        record_values(recorder->outputs + k * recorder->output_bytes, env->get_calls, env->n_get_calls);
    }
    return 0;
}

/* -- systems (step.h) --------------------------------------------------------------------------- */

/* Copy `links` as SystemInstance._copy does; true if a target's bytes changed. */
static bool copy_links(const mg_link *links, int64_t n) {
    bool changed = false;
    for (int64_t k = 0; k < n; k++) {
        const mg_link *l = &links[k];
        value v = load((const void *)(intptr_t)l->source, l->source_type);
        if (l->scale != 1.0 || l->shift != 0.0) {
            v.d = l->scale * as_double(v) + l->shift;
            v.kind = AS_DOUBLE;
        }
        changed |= store((void *)(intptr_t)l->target, l->target_type, v);
    }
    return changed;
}

static void read_table(mg_table *table);

/* TableInstance.step: the clock moved as an FMU's, each output read at the new time. */
static void advance_table(mg_table *table, double dt) {
    mg_clock *clock = table->clock;
    if (dt != clock->dt) {
        clock->origin = clock->time;
        clock->dt = dt;
        clock->steps = 0;
    }
    clock->steps += 1;
    clock->time = clock->origin + (double)clock->steps * dt;
    read_table(table);
}

/* TableInstance.read_outputs: each output at the table's time, as numpy.interp. */
static void read_table(mg_table *table) {
    mg_clock *clock = table->clock;
    int64_t started = mg_now_ns();
    const double *x = table->times;
    int64_t n = table->n_times;
    double t = clock->time + *table->offset;
    int64_t j = 0; /* x[j] <= t < x[j + 1] */
    if (t > x[0] && t < x[n - 1]) {
        int64_t high = n - 1;
        while (high - j > 1) {
            int64_t mid = (j + high) / 2;
            if (x[mid] <= t)
                j = mid;
            else
                high = mid;
        }
    }
    for (int64_t k = 0; k < table->n_outputs; k++) {
        const double *y = table->values + k * n;
        double result;
        if (!(t > x[0]))
            result = y[0];
        else if (!(t < x[n - 1]))
            result = y[n - 1];
        else if (x[j] == t)
            result = y[j];
        else {
            double slope = (y[j + 1] - y[j]) / (x[j + 1] - x[j]);
            result = slope * (t - x[j]) + y[j];
            if (result != result) /* NaN: numpy's second try */
                result = slope * (t - x[j + 1]) + y[j + 1];
        }
        *table->outputs[k] = result;
    }
    clock->fmu_time_ns += mg_now_ns() - started;
}

/* LoopGuard.first_failure (system/loops.py): the first guarded value beyond the bound or not finite, or -1. */
static int64_t loop_guard_failure(const mg_system *system) {
    for (int64_t k = 0; k < system->n_guards; k++) {
        const mg_link *g = &system->guards[k];
        double v = as_double(load((const void *)(intptr_t)g->source, g->source_type));
        if (!(fabs(v) <= system->guard_bound))
            return k;
    }
    return -1;
}

/* SystemInstance.step (system/master.py), whose docstring states the master algorithm. */
static int32_t advance_system(mg_env *env) {
    mg_system *system = env->system;
    mg_clock *clock = env->clock;
    double dt = env->time_step;
    rebase_clock(clock, dt);
    for (int64_t c = 0; c < system->n_components; c++) {
        mg_component *component = &system->components[c];
        component->inputs_changed = copy_links(component->action_links, component->n_action_links);
    }
    bool ended = false;
    for (int32_t sub = 0; sub < system->substeps && !ended; sub++) {
        for (int64_t c = 0; c < system->n_components && system->jacobi; c++) {
            mg_component *component = &system->components[c];
            component->inputs_changed |= copy_links(component->links, component->n_links);
        }
        for (int64_t c = 0; c < system->n_components; c++) {
            mg_component *component = &system->components[c];
            if (!system->jacobi)
                component->inputs_changed |= copy_links(component->links, component->n_links);
            if (component->table) {
                advance_table(component->table, dt / system->substeps);
                continue;
            }
            mg_env *fmu = component->env;
            if (fmu->integrator && component->inputs_changed) /* as FMUInstance.note_written_inputs */
                fmu->integrator->continuous = 0;
            component->inputs_changed = 0;
            int32_t flags = advance(fmu);
            if (flags) {
                system->failed_component = c;
                env->fmi_status = fmu->fmi_status;
                env->failed_call = fmu->failed_call;
                return flags;
            }
            ended |= fmu->clock->terminated != 0;
        }
        int64_t diverged = loop_guard_failure(system);
        if (diverged >= 0) {
            system->failed_guard = diverged;
            env->fmi_status = 0;
            env->failed_call = MG_CALL_LOOP_GUARD;
            return MG_FMU_ERROR;
        }
    }
    clock->steps += 1;
    clock->time = clock->origin + (double)clock->steps * dt;
    clock->terminated = ended;
    copy_links(system->output_links, system->n_output_links);
    get_outputs(env); /* no FMU calls of its own: the observation moves */
    return 0;
}

/* SystemInstance.reset on the snapshot rung of every FMU (Python checked each one's snapshot and
 * key, and each table's offset, in bind): every component back at its start, the connections
 * settled once in stepping order (SystemInstance._started), the observation read. */
static int32_t reset_system(mg_env *env) {
    mg_system *system = env->system;
    for (int64_t c = 0; c < system->n_components; c++) {
        mg_component *component = &system->components[c];
        if (component->table) {
            mg_clock *clock = component->table->clock;
            clock->time = clock->origin = clock->start_time;
            clock->dt = 0.0;
            clock->steps = 0;
            read_table(component->table);
            continue;
        }
        int32_t flags = mg_env_reset(component->env);
        if (flags) {
            system->failed_component = c;
            env->fmi_status = component->env->fmi_status;
            env->failed_call = component->env->failed_call;
            return flags;
        }
    }
    for (int64_t c = 0; c < system->n_components; c++) {
        mg_component *component = &system->components[c];
        copy_links(component->links, component->n_links);
        mg_env *fmu = component->env;
        if (!component->n_links || !fmu || fmu->event_mode_inputs)
            continue;
        int call = MG_CALL_SET_INPUTS;
        int status = set_inputs(fmu);
        if (status <= WARNING) {
            call = MG_CALL_GET_OUTPUTS;
            status = get_outputs(fmu);
        }
        if (status > WARNING) {
            system->failed_component = c;
            env->fmi_status = status;
            env->failed_call = call;
            return fail(fmu, call, status);
        }
    }
    mg_clock *clock = env->clock;
    clock->time = clock->origin = clock->start_time;
    clock->dt = 0.0;
    clock->steps = 0;
    clock->terminated = 0;
    copy_links(system->output_links, system->n_output_links);
    get_outputs(env);
    env->elapsed_steps = 0;
    return 0;
}

int32_t mg_env_step(mg_env *env, const void *action, double *reward) {
    *reward = 0.0;
    if (action && !env->python_inputs && !write_action(env, action))
        return MG_BAD_ACTION; /* NULL or python_inputs: Python wrote the inputs (step.h) */
    int32_t flags = advance(env);
    if (flags)
        return flags; /* Python reports the error: truncation with info["fmu_error"] */
    bool terminated = false;
    for (int64_t k = 0; k < env->n_bounds; k++) {
        const mg_move *m = &env->observation_moves[env->bound_index[k]];
        double value = as_double(load((const void *)(intptr_t)m->source, m->source_type));
        if (!(env->bound_low[k] <= value && value <= env->bound_high[k])) {
            terminated = true;
            break;
        }
    }
    if (env->clock->terminated) {
        terminated = true;
        flags |= MG_MODEL_ENDED;
    }
    env->elapsed_steps += 1;
    if (terminated)
        flags |= MG_TERMINATED;
    if (env->max_episode_steps >= 0 && env->elapsed_steps >= env->max_episode_steps)
        flags |= MG_TRUNCATED;
    *reward = terminated ? env->negative_reward : env->positive_reward;
    return flags;
}

int32_t mg_env_reset(mg_env *env) {
    mg_clock *clock = env->clock;
    if (clock->broken || !env->native_reset)
        return MG_FMU_ERROR;
    if (env->system)
        return reset_system(env);
    int64_t started = mg_now_ns();
    int status = ((set_state_t)env->set_state)(env->component, env->snapshot);
    if (status > WARNING) {
        env->fmi_status = status;
        env->failed_call = MG_CALL_SET_STATE;
        return MG_FMU_ERROR;
    }
    const char *starts = env->input_starts; /* as ValueBuffer.fill_start_values */
    for (int64_t k = 0; k < env->n_set_calls; k++) {
        memcpy(env->set_calls[k].values, starts, (size_t)env->set_calls[k].n_bytes);
        starts += env->set_calls[k].n_bytes;
    }
    mg_integrator *integrator = env->integrator;
    if (integrator) { /* as ModelExchangeIntegrator.restart */
        integrator->has_next_event = env->snapshot_has_next_event;
        integrator->next_event_time = env->snapshot_next_event_time;
        if (mg_integrator_open(integrator, clock->start_time) != MG_INTEGRATOR_OK)
            return fail(env, MG_CALL_INTEGRATE, 0);
    }
    clock->time = clock->origin = clock->start_time;
    clock->dt = 0.0;
    clock->steps = 0;
    clock->terminated = 0;
    clock->log_errors = 0;
    status = get_outputs(env);
    clock->fmu_time_ns += mg_now_ns() - started;
    if (status > WARNING)
        return fail(env, MG_CALL_GET_OUTPUTS, status);
    env->elapsed_steps = 0;
    return 0;
}
