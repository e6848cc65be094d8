/* See step.h. */
#define _GNU_SOURCE
#include "step.h"

#include <stdbool.h>
#include <stddef.h>
#include <string.h>

#include "signal.h"

typedef int (*fmi2_set_real_t)(void *, const uint32_t *, size_t, const double *);
typedef int (*fmi2_get_real_t)(void *, const uint32_t *, size_t, double *);
typedef int (*fmi2_do_step_t)(void *, double, double, int);
typedef int (*fmi2_get_boolean_status_t)(void *, int, int *);
typedef int (*fmi3_set_float64_t)(void *, const uint32_t *, size_t, const double *, size_t);
typedef int (*fmi3_get_float64_t)(void *, const uint32_t *, size_t, double *, size_t);
typedef int (*fmi3_do_step_t)(void *, double, double, bool, bool *, bool *, bool *, double *);
typedef int (*set_state_t)(void *, void *);

enum { OK = 0, WARNING = 1, DISCARD = 2 };
enum { FMI2_TERMINATED_STATUS_KIND = 3 };

static int set_inputs(mg_env *env) {
    if (env->n_inputs == 0)
        return OK;
    if (env->fmi_version == 2)
        return ((fmi2_set_real_t)env->set_real)(env->component, env->input_refs, (size_t)env->n_inputs, env->inputs);
    return ((fmi3_set_float64_t)env->set_real)(env->component, env->input_refs, (size_t)env->n_inputs, env->inputs,
                                               (size_t)env->n_inputs);
}

static int get_outputs(mg_env *env) {
    if (env->fmi_version == 2)
        return ((fmi2_get_real_t)env->get_real)(env->component, env->output_refs, (size_t)env->n_outputs,
                                                env->outputs);
    return ((fmi3_get_float64_t)env->get_real)(env->component, env->output_refs, (size_t)env->n_outputs,
                                               env->outputs, (size_t)env->n_outputs);
}

/* doStep as `binding.do_step_call` maps it: OK, `ended` set when the model ended the simulation
 * (discard + terminated in FMI 2; terminateSimulation in FMI 3), else the failing status. */
static int do_step(mg_env *env, double t, double h, bool *ended) {
    *ended = false;
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

/* Copy the action's input values; false (nothing written) if it is outside the action space.
 * In model exchange, new input values end the solver's continuous run. */
static bool write_action(mg_env *env, const void *action) {
    const double *values;
    if (env->discrete) {
        int64_t index = *(const int64_t *)action;
        if (index < 0 || index >= env->n_actions)
            return false;
        values = env->action_table + index * env->n_inputs;
    } else {
        values = action;
        if (env->action_low)
            for (int64_t k = 0; k < env->n_inputs; k++)
                if (!(env->action_low[k] <= values[k] && values[k] <= env->action_high[k]))
                    return false; /* also NaN */
    }
    size_t bytes = sizeof(double) * (size_t)env->n_inputs;
    if (env->integrator && memcmp(env->inputs, values, bytes) != 0)
        env->integrator->continuous = 0;
    memcpy(env->inputs, values, bytes);
    return true;
}

/* FMUInstance.step: set inputs, doStep to origin + (steps + 1) * dt, get outputs. */
static int32_t advance(mg_env *env) {
    mg_clock *clock = env->clock;
    double dt = env->time_step;
    if (dt != clock->dt) {
        clock->origin = clock->time;
        clock->dt = dt;
        clock->steps = 0;
    }
    double now = clock->time;
    double target = clock->origin + (double)(clock->steps + 1) * dt;
    int64_t started = mg_now_ns();
    int status = set_inputs(env);
    if (status > WARNING)
        return fail(env, MG_CALL_SET_INPUTS, status);
    bool ended;
    if (env->integrator) {
        int32_t outcome = mg_integrator_advance(env->integrator, now, target);
        if (outcome == MG_INTEGRATOR_FAILED)
            return fail(env, MG_CALL_INTEGRATE, 0);
        ended = outcome == MG_INTEGRATOR_TERMINATE;
    } else {
        status = do_step(env, now, target - now, &ended);
        if (status != OK)
            return fail(env, MG_CALL_DO_STEP, status);
    }
    if (ended)
        clock->terminated = 1;
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
        memcpy(recorder->inputs + k * recorder->input_bytes, env->inputs, (size_t)recorder->input_bytes);
        memcpy(recorder->outputs + k * recorder->output_bytes, env->outputs, (size_t)recorder->output_bytes);
    }
    return 0;
}

int32_t mg_env_step(mg_env *env, const void *action, double *reward) {
    *reward = 0.0;
    if (!write_action(env, action))
        return MG_BAD_ACTION;
    int32_t flags = advance(env);
    if (flags)
        return flags; /* Python reports the error: truncation with info["fmu_error"] */
    bool terminated = false;
    for (int64_t k = 0; k < env->n_bounds; k++) {
        double value = env->outputs[env->bound_index[k]];
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
    int64_t started = mg_now_ns();
    int status = ((set_state_t)env->set_state)(env->component, env->snapshot);
    if (status > WARNING) {
        env->fmi_status = status;
        env->failed_call = MG_CALL_SET_STATE;
        return MG_FMU_ERROR;
    }
    memcpy(env->inputs, env->input_starts, sizeof(double) * (size_t)env->n_inputs);
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
