/* See endings.h. */
#include "endings.h"

#include <stdbool.h>
#include <string.h>

#include "last_word.h"

static bool stepped_here(const mg_batch *b, int64_t i) {
    return b->active[i] && b->in_caller[i] == b->caller;
}

int64_t mg_step_open(mg_batch *b, uint8_t *open) {
    mg_step_batch(b);
    int64_t count = 0;
    bool stopped = false; /* an action outside the space stopped the batch: later envs were not stepped */
    for (int64_t i = 0; i < b->n; i++) {
        int32_t f = b->flags[i];
        bool opened = false;
        if (!stopped && stepped_here(b, i)) {
            stopped = f & MG_BAD_ACTION;
            opened = !stopped && !(f & (MG_FMU_ERROR | MG_RESET_DONE | MG_PYTHON_RESET));
        }
        open[i] = opened;
        count += opened;
    }
    return count;
}

/* The pool's autoreset after Python ended the steps: as step_batch (slice.c) applies it, and as its
 * Python twin Autoreset (modelicagym/vector/slice/autoreset.py) does; change all three together. */
static int64_t end_steps(mg_batch *b, int32_t mode, const uint8_t *open, int64_t *fmu_ns) {
    int64_t for_python = 0;
    bool same_step = mode == MG_AUTORESET_SAME_STEP;
    for (int64_t i = 0; i < b->n; i++) {
        if (!stepped_here(b, i))
            continue;
        int32_t f = b->flags[i];
        if (f & MG_BAD_ACTION)
            return for_python + 1;
        if (same_step)
            b->final_ready[i] = 0;
        if (open[i]) {
            mg_env *env = b->envs[i];
            *b->current_env = b->first_env + i;
            bool ended = b->terminations[i] || b->truncations[i];
            if (b->terminations[i])
                f |= MG_TERMINATED;
            if (mode == MG_AUTORESET_NEXT_STEP) {
                b->needs_reset[i] = ended;
            } else if (same_step && ended) {
                mg_put_observation(b, i, env, true);
                int64_t fmu_before = env->clock->fmu_time_ns;
                bool reset = env->native_reset && mg_env_reset(env) == 0;
                *fmu_ns += env->clock->fmu_time_ns - fmu_before;
                if (reset) {
                    f |= MG_RESET_DONE;
                    mg_put_observation(b, i, env, false);
                } else {
                    f |= MG_PYTHON_RESET;
                }
            }
            b->flags[i] = f;
        }
        if (f & (MG_FMU_ERROR | MG_PYTHON_RESET | MG_MODEL_ENDED))
            for_python++;
        else if (same_step && (f & MG_RESET_DONE))
            b->final_ready[i] = 1;
    }
    return for_python;
}

int64_t mg_end_steps(mg_batch *b, int32_t mode, const uint8_t *open) {
    bool timed = *b->timing_enabled;
    int64_t started = timed ? mg_now_ns() : 0;
    int64_t *before = mg_caller_slot; /* the resets run the envs' code: last_word.h */
    if (b->caller)
        mg_caller_slot = b->current_env;
    int64_t fmu_ns = 0;
    int64_t for_python = end_steps(b, mode, open, &fmu_ns);
    mg_caller_slot = before;
    if (timed) {
        b->timing[0] += mg_now_ns() - started;
        b->timing[1] += fmu_ns;
    }
    return for_python;
}
