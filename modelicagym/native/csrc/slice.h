/* A slice of a pool's envs stepped in one call, with the pool's autoreset; a worker's command loop
 * and the parent's side of a pool step, in C while nothing needs Python.
 *
 * The pool's native path (modelicagym/vector/slice/native_slice.py): mg_step_batch steps each env of the
 * slice with mg_env_step (step.h) and writes its results into the pool's shared arrays; mg_serve,
 * mg_post_step and mg_collect are the two sides of a step's barrier (mg_barrier, below).
 */
#ifndef MG_SLICE_H
#define MG_SLICE_H

#include <stdbool.h>
#include <stdint.h>

#include "actions.h"
#include "signal.h"
#include "step.h"

enum { MG_AUTORESET_NEXT_STEP = 0, MG_AUTORESET_SAME_STEP = 1, MG_AUTORESET_DISABLED = 2 };

/* mg_batch.needs_reset values */
enum { MG_NO_RESET = 0, MG_RESET_THEN_REPORT = 1, MG_RESET_THEN_STEP = 2 };

/* One entry of a Dict space in the pool's shared memory (its own array of the batch): its bytes
 * at `offset` in an env's action row or observation (mg_env.observation) are row i of `base`. */
typedef struct {
    int64_t offset, bytes;
    char *base, *final_base; /* final_base: the entry's final observations (NULL for an action) */
    int64_t stride;
} mg_part;

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
    /* Dict spaces: one array per entry in shared memory; 0 parts: one row at actions / observations */
    const mg_part *action_parts; /* gathered into `scratch` before the env's step */
    int64_t n_action_parts;
    const mg_part *obs_parts; /* scattered from the env's observation */
    int64_t n_obs_parts;
    char *scratch; /* an action row */
} mg_batch;

/* One vector step of the slice, with the autoreset of its mode (an env whose inputs are Python's,
 * mg_env.python_inputs, steps from what Python wrote into its inputs: its action row is not read;
 * one whose observation is Python's gets no observation row written). A native reset that fails becomes
 * MG_PYTHON_RESET (Python's reset ladder handles it). An env whose action is outside the space
 * stops the batch there (MG_BAD_ACTION; later envs are not stepped, as on the Python path).
 * Returns how many envs need Python: MG_FMU_ERROR, MG_PYTHON_RESET, MG_BAD_ACTION, or an info to
 * report (MG_MODEL_ENDED). A plain same-step reset needs none: final_ready marks it. */
int64_t mg_step_batch(mg_batch *batch);

/* mg_step_batch, after the pool's range check of the whole batch's actions (`range`: the shared
 * actions of every env, as the parent checks them before any worker sees them): -1, and nothing
 * stepped, when a value is outside. A step with every env in the calling process is then one call. */
int64_t mg_step_batch_in_range(mg_batch *batch, const mg_range *range);

/* Copy env i's observation (env->observation) into the shared observations, or the final
 * observations when `final`: its row, or a Dict's entries scattered to their arrays. Nothing for
 * an env whose observation is Python's (env->python_observation: Python writes its rows). */
void mg_put_observation(const mg_batch *b, int64_t i, const mg_env *env, bool final);

/* The step's barrier, in the pool's shared memory: what makes waking the k workers of a step and
 * learning that all of them are done cost a constant number of system calls, whatever k.
 *
 * Every worker's `go` waiter sleeps on the one `bell`, on its own bit (signal.h); a step posts the
 * `go` of every stepping worker, rings the bell once and wakes all sleeping ones in one system call
 * (mg_post_step). Each worker answers (mg_answer) by counting `countdown` down, then posting its own
 * `done`; the one that took the count to 0 then posts `all_done`, the one signal the parent waits for.
 * So the parent pays at most one wake-up and one sleep a step; nobody sleeps, no system call.
 *
 * The count is exact only during a step: every answer counts down (a reset's or a call's too), and
 * mg_post_step sets it, and clears a stale `all_done`, before it posts. That is safe because the
 * parent posts a step only when no command is out, and a worker counts down before it posts `done`
 * (once the parent saw a worker done, that worker's count has landed). The count only spares the
 * parent a wait per worker: the workers' `done`s stay the truth (the parent takes each after
 * `all_done`, and Python's slow path waits on them, with timeouts and death checks). */
typedef struct {
    uint32_t bell;          /* futex word every worker's `go` waiter sleeps on: each post bumps it */
    uint32_t pad_bell[15];  /* each word on a cache line of its own */
    uint32_t countdown;     /* workers of the step yet to answer */
    uint32_t pad_countdown[15];
    mg_signal all_done;     /* posted by the answer that takes countdown to 0 */
    uint8_t pad_all_done[64 - sizeof(mg_signal)];
} mg_barrier;

/* Post worker `slot`'s `go` alone (a command other than a pool step, a held or partial batch's step). */
void mg_go_post(mg_signal *go, mg_barrier *barrier, int64_t slot);

/* A worker's wait for its `go`, asleep on the barrier's bell (mg_signal_wait's policy and result). */
int mg_go_wait(mg_signal *go, mg_barrier *barrier, int64_t slot, int64_t spin_ns, int64_t timeout_ns,
               mg_waiter *waiter);

/* A worker's answer to any command: count the step down, then post its `done` (see mg_barrier). */
void mg_answer(mg_barrier *barrier, mg_signal *done);

/* A worker's command loop, in C while the commands are steps Python need not see.
 * Waits for `go` (mg_go_wait); on a STEP command of a native slice runs mg_step_batch and, when no
 * env needs Python, answers (reply NONE, mg_answer) and waits again. Returns to Python with
 * MG_SERVE_TIMEOUT (no command within timeout_ns: Python checks its parent is alive),
 * MG_SERVE_PYTHON_STEP (the step ran; batch->flags say what Python must finish, then answer), or
 * any other command code for Python to run. */
typedef struct {
    mg_batch *batch; /* NULL: the slice is not native; every command goes to Python */
    void *go, *done; /* mg_signal (signal.h) */
    void *barrier;   /* mg_barrier */
    int64_t slot;    /* the worker's index (its bit of the bell) */
    const int32_t *command;
    int32_t *reply;
    int32_t step_code;
    const int64_t *spin_ns; /* how long to poll for `go`, in shared memory: the parent changes it */
    int64_t timeout_ns;
    mg_waiter *waiter; /* the adaptive state of the worker's waits for `go` (signal.h) */
} mg_server;

enum { MG_SERVE_TIMEOUT = -1, MG_SERVE_PYTHON_STEP = -2 };
int32_t mg_serve(mg_server *server);

/* The parent's side of a pool step: mg_post_step posts every stepping worker's `go` (their command
 * slots already say STEP); after the calling process stepped its own slice
 * (vector/dispatch/dispatcher.py: Dispatcher.run_own_slice), mg_collect waits for `all_done`, takes every
 * stepping worker's `done` and checks that none has a reply. It returns MG_COLLECT_DONE when the
 * batch is complete; MG_COLLECT_SLOW when the workers did not all answer within timeout_ns or one
 * has a reply (every `done` consumed here is posted again, so Python's slow path finds it). */
typedef struct {
    int64_t n_workers;
    void **go, **done;      /* mg_signal of each worker */
    void *barrier;          /* mg_barrier */
    const int32_t *replies; /* reply slot of each worker (worker k: replies[k]) */
    const uint8_t *stepping; /* per worker: it steps (else it is neither woken nor waited for) */
    const int64_t *spin_ns; /* how long to poll for the workers */
    int64_t timeout_ns;
    mg_waiter *waiter; /* the adaptive state of the parent's waits for `all_done` (signal.h) */
    /* out, summed over calls until Python clears them: calls, and time waiting for the workers
     * (the adaptive layout's measurement, vector/layout/placement.py) */
    int64_t calls, wait_ns;
} mg_collector;

enum { MG_COLLECT_DONE = 0, MG_COLLECT_SLOW = 1 };
void mg_post_step(mg_collector *collector);
int32_t mg_collect(mg_collector *collector);

#endif
