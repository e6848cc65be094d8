/* The native step path: config-defined FMU envs stepped in C through the FMU's own functions.
 *
 * An mg_env describes one env of `FMUEnv` whose FMU steps in C (see modelicagym/env/native_step.py
 * for when that holds): co-simulation, or model exchange with the native integrator (integrator.h),
 * its discrete inputs set in event mode at every step as the Python path does; inputs and outputs of every FMI
 * type but String/Binary (scalars and FMI 3.0 arrays, one fmiSet/fmiGet call per type), the action
 * converted to the inputs (a Box, MultiDiscrete, MultiBinary, Discrete, or a flattened Dict),
 * looked up in a table (a Discrete), or written into the input buffers by Python (an overridden
 * action_to_inputs: mg_env_step's action is NULL), bound
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

/* The value types a native step moves, as numpy names them (the dtypes of the FMU instance's
 * buffers, of the action and of the observation): MG_TYPE_BOOL is numpy's bool (FMI 3.0's
 * fmi3Boolean); FMI 2.0's fmi2Boolean is an MG_TYPE_I32, FMI 1.0's fmiBoolean an MG_TYPE_I8. A move
 * converts as numpy's assignment casts (C casts from the source value, never through a wider type). */
enum {
    MG_TYPE_F64 = 0, MG_TYPE_F32 = 1, MG_TYPE_I8 = 2, MG_TYPE_U8 = 3, MG_TYPE_I16 = 4, MG_TYPE_U16 = 5,
    MG_TYPE_I32 = 6, MG_TYPE_U32 = 7, MG_TYPE_I64 = 8, MG_TYPE_U64 = 9, MG_TYPE_BOOL = 10,
};

/* One fmiSet<Type> / fmiGet<Type> call of a step: all the inputs (or outputs) of one FMI type, in
 * the FMU instance's own buffer (fmu/buffers.py ValueBuffer, one group). */
typedef struct {
    void *function; /* fmi2SetInteger, fmi3GetFloat32, <modelIdentifier>_fmiSetReal, ... */
    const uint32_t *refs;
    int64_t n_refs;
    void *values;
    int64_t n_values; /* FMI 3.0 arrays: more values than references */
    int64_t n_bytes;
} mg_call;

/* One value moved and converted: an action value to an input (source: a byte offset in the action
 * row, target: an address in an input buffer), or an output to the observation (source: an
 * address in an output buffer, target: a byte offset in mg_env.observation). */
typedef struct {
    int64_t source, target;
    int32_t source_type, target_type; /* MG_TYPE_* */
} mg_move;

typedef struct mg_system mg_system;

typedef struct {
    int32_t fmi_version; /* 1, 2 or 3 (0: a system, `system`) */
    int32_t discrete;    /* 1: action is an int64 index into action_table; 0: an action row */
    int32_t python_inputs;      /* 1: Python writes the input values (action_to_inputs) before each step:
                                   mg_env_step moves and checks no action, whatever it is given */
    int32_t python_observation; /* 1: the observation is Python's (observation()): a pool's slice writes
                                   none of this env's observation rows (slice.h mg_put_observation) */
    void *component;
    void *do_step, *get_boolean_status, *set_state;
    void *snapshot; /* FMU state taken after initialization (NULL: no native reset) */
    mg_integrator *integrator;       /* model exchange: the solver loop; NULL: co-simulation (doStep) */
    int32_t event_mode_inputs;       /* model exchange with discrete inputs: a step sets them in event mode */
    int32_t snapshot_has_next_event; /* model exchange: the time event pending when the snapshot was taken */
    double snapshot_next_event_time;
    const mg_call *set_calls; /* one per FMI type of the inputs */
    int64_t n_set_calls;
    const mg_call *get_calls; /* one per FMI type of the outputs */
    int64_t n_get_calls;
    const mg_move *action_moves; /* action row (or action_table row) -> input values, in variable order */
    int64_t n_inputs;            /* input values (array elements count one each); 0 when Python writes them */
    const char *input_starts;    /* the input buffers' bytes after a reset, in set_calls order */
    const mg_move *observation_moves; /* output values -> the observation, in variable order */
    int64_t n_outputs;
    char *observation; /* the observation as the env's observation space holds it (flat) */
    int64_t observation_bytes;
    const double *action_table; /* n_actions x n_inputs */
    int64_t n_actions;
    /* bounds per action value, compared as doubles; a value outside them or not finite is refused (NULL: none) */
    const double *action_low, *action_high;
    const int64_t *bound_index; /* observation_moves index of each termination bound */
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
    mg_system *system; /* not NULL: this env steps a system of components (below), not one FMU */
} mg_env;

/* -- systems of FMUs (modelicagym/system/master.py, its master algorithm in C) ----------------------
 * A system env's mg_env has no FMU calls of its own: its action moves write the system's input
 * values, its observation moves read the system's output values, and `advance` runs the master:
 * the action's values to the components' inputs, then per communication step each component's own
 * step (an FMU: its mg_env, python_inputs, no action, bounds or observation; a table: mg_table),
 * the connections copied along the way (Gauss-Seidel: into each component just before it steps;
 * Jacobi: all of them first), then the components' outputs to the system's output values. After each
 * communication step the loop guard (system/loops.py) checks the values the system's loops carry from
 * the previous step: one beyond `guard_bound` or not finite fails the step (MG_CALL_LOOP_GUARD). */

/* One connection: target = scale * source + shift (the identity copies as a move does). */
typedef struct {
    int64_t source, target; /* addresses in the components' (or the system's) value buffers */
    int32_t source_type, target_type;
    double scale, shift;
} mg_link;

/* A time table: each output interpolated linearly in time (+ *offset), its end values held, as numpy's interp. */
typedef struct {
    const double *times;
    int64_t n_times;
    const double *values; /* n_outputs rows of n_times: output k's column */
    double *const *outputs; /* where output k goes */
    int64_t n_outputs;
    const double *offset;
    mg_clock *clock;
} mg_table;

typedef struct {
    mg_env *env;         /* an FMU component (NULL: a table) */
    mg_table *table;
    const mg_link *links; /* the connections into it */
    int64_t n_links;
    const mg_link *action_links; /* the system's input values -> its inputs */
    int64_t n_action_links;
    int32_t inputs_changed; /* scratch: its input bytes changed since its last step (model exchange restarts) */
} mg_component;

struct mg_system {
    mg_component *components; /* in stepping order */
    int64_t n_components;
    int32_t jacobi;
    int32_t substeps;
    const mg_link *output_links; /* the components' outputs -> the system's output values */
    int64_t n_output_links;
    int64_t failed_component; /* the component (stepping order) whose call failed, with MG_FMU_ERROR */
    const mg_link *guards; /* the loop guard's values: `source`, `source_type` (LoopGuard's order) */
    int64_t n_guards;
    double guard_bound;
    int64_t failed_guard; /* the guard's value beyond the bound, with MG_CALL_LOOP_GUARD */
};

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
    MG_CALL_LOOP_GUARD = 7, /* a system's loop diverged (mg_system.failed_guard) */
};

/* One step of one env. `action` points to an int64 (discrete) or an action row (action_moves).
 * Returns the flags; the reward is written to *reward. The outputs are in the instance's buffers
 * afterwards, and the observation in env->observation.
 * `action` NULL, or env->python_inputs: the inputs are already in the instance's buffers (Python
 * computed them, e.g. an overridden action_to_inputs: env/native_step.py); nothing is moved or
 * checked, and in model exchange Python has already decided whether the solver restarts (new
 * input bytes), as write_action would. Such an env has no action_moves (n_inputs 0). */
int32_t mg_env_step(mg_env *env, const void *action, double *reward);

/* Restore the snapshot (a reset on the "snapshot" rung); 0 on success, else MG_FMU_ERROR. */
int32_t mg_env_reset(mg_env *env);

#endif
