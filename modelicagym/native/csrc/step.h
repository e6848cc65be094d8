/* The native step path: config-defined FMU envs stepped in C through the FMU's own functions.
 *
 * An mg_env describes one env of `FMUEnv` whose step is fully defined by its config (see
 * modelicagym/native/step.py for when that holds): co-simulation, or model exchange with the
 * native integrator (integrator.h) and continuous inputs; Float64 scalar inputs and
 * outputs, the action copied to the inputs (a Box) or looked up in a table (a Discrete), bound
 * termination, the paper's positive/negative reward, truncation after max_episode_steps.
 * Python fills it in (pointers into the FMU instance's own value buffers and its clock), so the
 * Python path and the native path read and write the same memory: either may take any step.
 *
 * mg_env_step does exactly what FMUEnv.step does on the Python path; what it must not do (an FMU
 * that returns Error, a reset that is not a plain snapshot restore) it leaves to Python by its
 * return flags.
 */
#ifndef MG_STEP_H
#define MG_STEP_H

#include <stdint.h>

#include "integrator.h"
#include "signal.h"

/* FMUInstance's time bookkeeping (modelicagym/fmu/clock.py): time = origin + steps * dt. */
typedef struct {
    double time, origin, dt, start_time;
    int64_t steps;
    int64_t fmu_time_ns; /* cumulative nanoseconds inside FMU calls */
    int32_t terminated;  /* the model ended the simulation */
    int32_t broken;      /* an FMU call failed: the next reset re-instantiates (Python) */
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

/* Flags returned by mg_env_step / per env by mg_step_batch. */
enum {
    MG_TERMINATED = 1,     /* terminated (bounds, or the model) */
    MG_TRUNCATED = 2,      /* truncated after max_episode_steps */
    MG_MODEL_ENDED = 4,    /* the model ended the simulation: info["fmu_terminated"] */
    MG_FMU_ERROR = 8,      /* an FMU call failed: Python reports it (env->fmi_status, env->failed_call) */
    MG_RESET_DONE = 16,    /* batch: the env was reset natively in this step (autoreset) */
    MG_PYTHON_RESET = 32,  /* batch: the env needs an autoreset that only Python can do */
    MG_BAD_ACTION = 64,    /* the action is outside the action space: nothing was stepped */
};
enum { MG_CALL_SET_INPUTS = 1, MG_CALL_DO_STEP = 2, MG_CALL_GET_OUTPUTS = 3, MG_CALL_SET_STATE = 4, MG_CALL_INTEGRATE = 5 };
enum { MG_AUTORESET_NEXT_STEP = 0, MG_AUTORESET_SAME_STEP = 1, MG_AUTORESET_DISABLED = 2 };

/* mg_batch.needs_reset values */
enum { MG_NO_RESET = 0, MG_RESET_THEN_REPORT = 1, MG_RESET_THEN_STEP = 2 };

/* One step of one env. `action` points to an int64 (discrete) or n_inputs doubles. Returns the
 * flags; the reward is written to *reward. The outputs are in env->outputs afterwards. */
int32_t mg_env_step(mg_env *env, const void *action, double *reward);

/* Restore the snapshot (a reset on the "snapshot" rung); 0 on success, else MG_FMU_ERROR. */
int32_t mg_env_reset(mg_env *env);

/* A slice of a pool's envs and where its results go: row i of each batch array is env i of the
 * slice. Action and observation rows are action_stride and obs_stride bytes apart. */
typedef struct {
    mg_env **envs;
    int64_t n;
    int32_t autoreset_mode;
    const char *actions;
    int64_t action_stride;
    char *observations;
    int64_t obs_stride;
    char *final_obs; /* SAME_STEP: the final observation of an env reset in this step (same stride) */
    uint8_t *final_ready; /* SAME_STEP, per env: 1 if C reset it in this step and Python has nothing
                             to add (its final_obs row and an empty final_info say it all), else 0 */
    double *rewards;
    uint8_t *terminations, *truncations;
    uint8_t *needs_reset; /* MG_RESET_THEN_REPORT: the env ended last step (NEXT_STEP) and this step
                             is its reset; MG_RESET_THEN_STEP: it moved here at an episode boundary
                             (SAME_STEP): reset it silently, then step it */
    const uint8_t *active; /* per env: step it in this call (the pool's step mask); else flags 0 */
    const uint8_t *in_caller; /* per env: 1 if the calling process steps it, 0 if its worker does */
    int32_t caller;           /* this slice is the calling process's (1) or a worker's (0): an env
                                 is stepped here when active and in_caller[i] == caller */
    int32_t *flags;       /* per env, the flags of this step */
    int64_t *current_env; /* the pool index of the env being stepped (to name it if the FMU crashes) */
    int64_t first_env;    /* the pool index of envs[0] */
    const uint8_t *timing_enabled;
    int64_t *timing; /* {env ns, fmu ns} of the batch, written when *timing_enabled */
} mg_batch;

/* One vector step of the slice, with the autoreset of its mode. A native reset that fails becomes
 * MG_PYTHON_RESET (Python's reset ladder handles it). An env whose action is outside the space
 * stops the batch there (MG_BAD_ACTION; later envs are not stepped, as on the Python path).
 * Returns how many envs need Python: MG_FMU_ERROR, MG_PYTHON_RESET, MG_BAD_ACTION, or an info to
 * report (MG_MODEL_ENDED). A plain same-step reset needs none: final_ready marks it. */
int64_t mg_step_batch(mg_batch *batch);

/* A worker's command loop, in C while the commands are steps Python need not see.
 * Waits for `go`; on a STEP command of a native slice runs mg_step_batch and, when no env needs
 * Python, answers (reply NONE, post `done`) and waits again. Returns to Python with
 * MG_SERVE_TIMEOUT (no command within timeout_ns: Python checks its parent is alive),
 * MG_SERVE_PYTHON_STEP (the step ran; batch->flags say what Python must finish, then answer), or
 * any other command code for Python to run. */
typedef struct {
    mg_batch *batch; /* NULL: the slice is not native; every command goes to Python */
    void *go, *done; /* mg_signal (signal.h) */
    const int32_t *command;
    int32_t *reply;
    int32_t step_code;
    int64_t spin_ns, timeout_ns;
    mg_waiter *waiter; /* the adaptive state of the worker's waits for `go` (signal.h) */
} mg_server;

enum { MG_SERVE_TIMEOUT = -1, MG_SERVE_PYTHON_STEP = -2 };
int32_t mg_serve(mg_server *server);

/* The parent's side of a pool step, after it posted every worker's `go`: step its own native
 * slice (if any), then wait for every worker's `done` and check that none has a reply. Returns
 * MG_COLLECT_DONE when the batch is complete; MG_COLLECT_LOCAL_PYTHON when the local slice needs
 * Python to finish its step (the workers are not waited for); MG_COLLECT_SLOW when a worker did not
 * post within timeout_ns or has a reply (every `done` consumed here is posted again, so Python's
 * slow path finds it). */
typedef struct {
    mg_batch *local; /* NULL: the calling process steps no native slice */
    int64_t n_workers;
    void **done;           /* mg_signal of each worker */
    const int32_t *replies; /* reply slot of each worker (worker k: replies[k]) */
    const uint8_t *stepping; /* per worker: it was woken for this step (else it is not waited for) */
    int64_t spin_ns, timeout_ns;
    mg_waiter *waiter; /* the adaptive state of the parent's waits for `done` (signal.h) */
    /* out, summed over calls until Python clears them: calls, time stepping the local slice, then
     * waiting for the workers (the adaptive layout's measurement, vector/placement.py) */
    int64_t calls, local_ns, wait_ns;
} mg_collector;

enum { MG_COLLECT_DONE = 0, MG_COLLECT_LOCAL_PYTHON = 1, MG_COLLECT_SLOW = 2 };
int32_t mg_collect(mg_collector *collector);

/* The physical limit: `steps` steps of one env with a fixed action pattern (action k % n_actions,
 * or the Box action given), resetting natively at every episode end; returns the steps done or
 * -1 on an FMU error. */
int64_t mg_loop(mg_env *env, int64_t steps, const void *box_action);

#endif
