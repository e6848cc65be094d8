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
    status = get_outputs(env);
    clock->fmu_time_ns += mg_now_ns() - started;
    if (status > WARNING)
        return fail(env, MG_CALL_GET_OUTPUTS, status);
    env->elapsed_steps = 0;
    return 0;
}

int64_t mg_step_batch(mg_batch *b) {
    int64_t for_python = 0, env_ns = 0, fmu_ns = 0;
    bool timed = *b->timing_enabled;
    bool next_step = b->autoreset_mode == MG_AUTORESET_NEXT_STEP;
    bool same_step = b->autoreset_mode == MG_AUTORESET_SAME_STEP;
    if (same_step) /* envs this call does not reach (a bad action stops it) must not keep a stale mark */
        for (int64_t i = 0; i < b->n; i++)
            if (!b->active[i] || b->in_caller[i] == b->caller)
                b->final_ready[i] = 0;
    for (int64_t i = 0; i < b->n; i++) {
        if (!b->active[i] || b->in_caller[i] != b->caller) {
            b->flags[i] = 0;
            continue;
        }
        mg_env *env = b->envs[i];
        *b->current_env = b->first_env + i;
        size_t obs_bytes = sizeof(double) * (size_t)env->n_outputs;
        int64_t started = timed ? mg_now_ns() : 0;
        int64_t fmu_before = env->clock->fmu_time_ns;
        int32_t f;
        double reward = 0.0;
        if (b->needs_reset[i] == MG_RESET_THEN_STEP) {
            if (!env->native_reset || mg_env_reset(env) != 0) {
                b->flags[i] = MG_PYTHON_RESET;
                for_python++;
                continue;
            }
            b->needs_reset[i] = MG_NO_RESET;
        }
        if (next_step && b->needs_reset[i]) {
            f = env->native_reset && mg_env_reset(env) == 0 ? MG_RESET_DONE : MG_PYTHON_RESET;
            if (f == MG_RESET_DONE)
                b->needs_reset[i] = MG_NO_RESET;
        } else {
            f = mg_env_step(env, b->actions + i * b->action_stride, &reward);
            if (f & MG_BAD_ACTION) {
                b->flags[i] = f;
                return for_python + 1;
            }
            bool ended = f & (MG_TERMINATED | MG_TRUNCATED);
            if (next_step) {
                b->needs_reset[i] = ended;
            } else if (same_step && ended) {
                memcpy(b->final_obs + i * b->obs_stride, env->outputs, obs_bytes);
                f |= env->native_reset && mg_env_reset(env) == 0 ? MG_RESET_DONE : MG_PYTHON_RESET;
            }
        }
        if (!(f & (MG_FMU_ERROR | MG_PYTHON_RESET)))
            memcpy(b->observations + i * b->obs_stride, env->outputs, obs_bytes);
        if (f & (MG_FMU_ERROR | MG_PYTHON_RESET | MG_MODEL_ENDED))
            for_python++;
        else if (same_step && (f & MG_RESET_DONE))
            b->final_ready[i] = 1;
        b->rewards[i] = reward;
        b->terminations[i] = (f & MG_TERMINATED) != 0;
        b->truncations[i] = (f & MG_TRUNCATED) != 0;
        b->flags[i] = f;
        if (timed) {
            env_ns += mg_now_ns() - started;
            fmu_ns += env->clock->fmu_time_ns - fmu_before;
        }
    }
    if (timed) {
        b->timing[0] = env_ns;
        b->timing[1] = fmu_ns;
    }
    return for_python;
}

int32_t mg_serve(mg_server *server) {
    for (;;) {
        if (!mg_signal_wait(server->go, server->spin_ns, server->timeout_ns, server->waiter))
            return MG_SERVE_TIMEOUT;
        int32_t code = *server->command;
        if (code != server->step_code || server->batch == NULL)
            return code;
        if (mg_step_batch(server->batch))
            return MG_SERVE_PYTHON_STEP;
        *server->reply = 0;
        mg_signal_post(server->done);
    }
}

int32_t mg_collect(mg_collector *c) {
    int64_t started = mg_now_ns();
    c->calls++;
    if (c->local && mg_step_batch(c->local)) {
        c->local_ns += mg_now_ns() - started;
        return MG_COLLECT_LOCAL_PYTHON;
    }
    int64_t stepped = mg_now_ns();
    c->local_ns += stepped - started;
    int64_t seen = 0;
    int32_t status = MG_COLLECT_DONE;
    for (; seen < c->n_workers; seen++)
        if (c->stepping[seen] && !mg_signal_wait(c->done[seen], c->spin_ns, c->timeout_ns, c->waiter)) {
            status = MG_COLLECT_SLOW;
            break;
        }
    for (int64_t k = 0; status == MG_COLLECT_DONE && k < c->n_workers; k++)
        if (c->stepping[k] && c->replies[k])
            status = MG_COLLECT_SLOW;
    if (status != MG_COLLECT_DONE)
        for (int64_t k = 0; k < seen; k++)
            if (c->stepping[k])
                mg_signal_post(c->done[k]);
    c->wait_ns += mg_now_ns() - stepped;
    return status;
}

int64_t mg_loop(mg_env *env, int64_t steps, const void *box_action) {
    double reward;
    for (int64_t k = 0; k < steps; k++) {
        int64_t index = k % (env->n_actions > 0 ? env->n_actions : 1);
        int32_t f = mg_env_step(env, env->discrete ? (const void *)&index : box_action, &reward);
        if (f & MG_FMU_ERROR)
            return -1;
        if ((f & (MG_TERMINATED | MG_TRUNCATED)) && mg_env_reset(env))
            return -1;
    }
    return steps;
}
