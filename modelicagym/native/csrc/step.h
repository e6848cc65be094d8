/* The native step path: config-defined FMU envs stepped in C through the FMU's own functions.
 *
 * An mg_env describes one env of `FMUEnv` whose step is fully defined by its config (see
 * modelicagym/env/native_step.py for when that holds): co-simulation, or model exchange with the
 * native integrator (integrator.h) and continuous inputs; Float64 scalar inputs and
 * outputs, the action copied to the inputs (a Box) or looked up in a table (a Discrete), bound
 * termination, the paper's positive/negative reward, truncation after max_episode_steps.
 * Python fills it in (pointers into the FMU instance's own value buffers and its clock), so the
 * Python path and the native path read and write the same memory: either may take any step.
 *
 * mg_env_step does exactly what FMUEnv.step does on the Python path; what it must not do (an FMU
 * that returns Error or logs an error loop, a reset that is not a plain snapshot restore) it leaves
 * to Python by its return flags. While a fresh instance's first episode is recorded (the clock's
 * recorder), it records each step as the Python path does.
 */
#ifndef MG_STEP_H
#define MG_STEP_H

#include <stdint.h>

#include "integrator.h"

/* The first steps of a fresh instance, recorded to check a reset rung against (fmu/reference.py):
 * row k of each array is step k. Either step path appends while count < capacity. */
typedef struct {
    double *dts;                       /* the step's dt */
    char *inputs, *outputs;            /* the input values it wrote, the outputs it read (bytes) */
    int64_t input_bytes, output_bytes; /* bytes of a row */
    int64_t capacity, count;
} mg_recorder;

/* FMUInstance's time bookkeeping (modelicagym/fmu/clock.py): time = origin + steps * dt. */
typedef struct {
    double time, origin, dt, start_time;
    int64_t steps;
    int64_t fmu_time_ns; /* cumulative nanoseconds inside FMU calls */
    int32_t terminated;  /* the model ended the simulation */
    int32_t broken;      /* an FMU call failed: the next reset re-instantiates (Python) */
    int32_t log_errors;      /* error-level messages the FMU logged since the last step or reset (fmu/logs.py) */
    int32_t log_error_limit; /* more in one step is an error loop: the step fails (MG_CALL_LOG_ERRORS) */
    mg_recorder *recorder;   /* not NULL: record this step (the first episode of a fresh instance) */
} mg_clock;

typedef struct {
    int32_t fmi_version; /* 2 or 3 */
    int32_t discrete;    /* 1: action is an int64 index into action_table; 0: n_inputs float64 */
    void *component;
    void *set_real, *get_real, *do_step, *get_boolean_status, *set_state;
    void *snapshot; /* FMU state taken after initialization (NULL: no native reset) */
    mg_integrator *integrator;       /* model exchange: the solver loop; NULL: co-simulation (doStep) */
    int32_t snapshot_has_next_event; /* model exchange: the time event pending when the snapshot was taken */
    double snapshot_next_event_time;
    const uint32_t *input_refs;
    double *inputs;
    const double *input_starts;
    int64_t n_inputs;
    const uint32_t *output_refs;
    double *outputs;
    int64_t n_outputs;
    const double *action_table; /* n_actions x n_inputs */
    int64_t n_actions;
    const double *action_low, *action_high; /* Box bounds per input (NULL: none) */
    const int64_t *bound_index; /* output index of each termination bound */
    const double *bound_low, *bound_high;
    int64_t n_bounds;
    double time_step;
    double positive_reward, negative_reward;
    int64_t max_episode_steps; /* < 0: never truncate */
    int64_t elapsed_steps;
    int32_t native_reset; /* a reset is a snapshot restore: Python verified the rung and the key */
    int32_t fmi_status;   /* the failing FMI status when MG_FMU_ERROR is returned */
    int32_t failed_call;  /* which call failed: MG_CALL_* */
    mg_clock *clock;
} mg_env;

/* Flags returned by mg_env_step / per env by mg_step_batch (slice.h). */
enum {
    MG_TERMINATED = 1,     /* terminated (bounds, or the model) */
    MG_TRUNCATED = 2,      /* truncated after max_episode_steps */
    MG_MODEL_ENDED = 4,    /* the model ended the simulation: info["fmu_terminated"] */
    MG_FMU_ERROR = 8,      /* an FMU call failed: Python reports it (env->fmi_status, env->failed_call) */
    MG_RESET_DONE = 16,    /* batch: the env was reset natively in this step (autoreset) */
    MG_PYTHON_RESET = 32,  /* batch: the env needs an autoreset that only Python can do */
    MG_BAD_ACTION = 64,    /* the action is outside the action space: nothing was stepped */
};
enum {
    MG_CALL_SET_INPUTS = 1,
    MG_CALL_DO_STEP = 2,
    MG_CALL_GET_OUTPUTS = 3,
    MG_CALL_SET_STATE = 4,
    MG_CALL_INTEGRATE = 5,
    MG_CALL_LOG_ERRORS = 6, /* the calls returned OK, but the FMU logged more errors than clock->log_error_limit */
};

/* One step of one env. `action` points to an int64 (discrete) or n_inputs doubles. Returns the
 * flags; the reward is written to *reward. The outputs are in env->outputs afterwards. */
int32_t mg_env_step(mg_env *env, const void *action, double *reward);

/* Restore the snapshot (a reset on the "snapshot" rung); 0 on success, else MG_FMU_ERROR. */
int32_t mg_env_reset(mg_env *env);

/* The physical limit (bench_loop.c, for the benchmarks only): `steps` steps of one env with a fixed action pattern (action k % n_actions,
 * or the Box action given), resetting natively at every episode end; returns the steps done or
 * -1 on an FMU error. */
int64_t mg_loop(mg_env *env, int64_t steps, const void *box_action);

#endif
