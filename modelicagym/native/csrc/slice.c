/* See slice.h. */
#include "slice.h"

#include <stdbool.h>
#include <string.h>

#include "last_word.h"

static int64_t step_batch(mg_batch *b);

/* Env i's action row: its row of the shared actions, or a Dict's entries gathered into scratch. */
static const void *action_row(const mg_batch *b, int64_t i) {
    if (!b->n_action_parts)
        return b->actions + i * b->action_stride;
    for (int64_t k = 0; k < b->n_action_parts; k++) {
        const mg_part *part = &b->action_parts[k];
        memcpy(b->scratch + part->offset, part->base + i * part->stride, (size_t)part->bytes);
    }
    return b->scratch;
}

void mg_put_observation(const mg_batch *b, int64_t i, const mg_env *env, bool final) {
    if (env->python_observation)
        return;
    if (!b->n_obs_parts) {
        memcpy((final ? b->final_obs : b->observations) + i * b->obs_stride, env->observation,
               (size_t)env->observation_bytes);
        return;
    }
    for (int64_t k = 0; k < b->n_obs_parts; k++) {
        const mg_part *part = &b->obs_parts[k];
        memcpy((final ? part->final_base : part->base) + i * part->stride, env->observation + part->offset,
               (size_t)part->bytes);
    }
}

int64_t mg_step_batch(mg_batch *b) {
    if (!b->caller)
        return step_batch(b);
    int64_t *before = mg_caller_slot; /* the calling process runs its envs' code: last_word.h */
    mg_caller_slot = b->current_env;
    int64_t for_python = step_batch(b);
    mg_caller_slot = before;
    return for_python;
}

int64_t mg_step_batch_in_range(mg_batch *b, const mg_range *range) {
    if (mg_first_range_outside(range, 1) >= 0)
        return -1;
    return mg_step_batch(b);
}

/* The pool's autoreset in C. Its Python twin is Autoreset in modelicagym/vector/slice/autoreset.py
 * (the Python path, and what C leaves to Python: MG_PYTHON_RESET); change both together.
 * tests/vector/test_autoreset_twins.py steps the same envs both ways in every mode. */
static int64_t step_batch(mg_batch *b) {
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
            f = mg_env_step(env, env->python_inputs ? NULL : action_row(b, i), &reward);
            if (f & MG_BAD_ACTION) {
                b->flags[i] = f;
                return for_python + 1;
            }
            bool ended = f & (MG_TERMINATED | MG_TRUNCATED);
            if (next_step) {
                b->needs_reset[i] = ended;
            } else if (same_step && ended) {
                mg_put_observation(b, i, env, true);
                f |= env->native_reset && mg_env_reset(env) == 0 ? MG_RESET_DONE : MG_PYTHON_RESET;
            }
        }
        if (!(f & (MG_FMU_ERROR | MG_PYTHON_RESET)))
            mg_put_observation(b, i, env, false);
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

/* A worker's bit of the bell's wake-up mask. Workers 32 apart share one: a wake-up for one wakes
 * the other too, which finds no post and sleeps again. */
static uint32_t bell_bit(int64_t slot) { return 1u << (slot % 32); }

void mg_go_post(mg_signal *go, mg_barrier *barrier, int64_t slot) {
    mg_signal_post_bell(go, &barrier->bell, bell_bit(slot));
}

int mg_go_wait(mg_signal *go, mg_barrier *barrier, int64_t slot, int64_t spin_ns, int64_t timeout_ns,
               mg_waiter *waiter) {
    return mg_signal_wait_bell(go, &barrier->bell, bell_bit(slot), spin_ns, timeout_ns, waiter);
}

/* The count first, so that once the parent sees `done` this answer's count has landed (a later
 * step's count never takes it); `done` before `all_done`, so that the parent woken by the last
 * answer finds that worker's `done` there instead of waiting for it. */
void mg_answer(mg_barrier *barrier, mg_signal *done) {
    int last = __atomic_sub_fetch(&barrier->countdown, 1, __ATOMIC_SEQ_CST) == 0;
    mg_signal_post(done);
    if (last)
        mg_signal_post(&barrier->all_done);
}

int32_t mg_serve(mg_server *server) {
    for (;;) {
        int64_t spin_ns = __atomic_load_n(server->spin_ns, __ATOMIC_RELAXED);
        if (!mg_go_wait(server->go, server->barrier, server->slot, spin_ns, server->timeout_ns, server->waiter))
            return MG_SERVE_TIMEOUT;
        int32_t code = *server->command;
        if (code != server->step_code || server->batch == NULL)
            return code;
        if (mg_step_batch(server->batch))
            return MG_SERVE_PYTHON_STEP;
        *server->reply = 0;
        mg_answer(server->barrier, server->done);
    }
}

void mg_post_step(mg_collector *c) {
    mg_barrier *barrier = c->barrier;
    uint32_t members = 0, bits = 0;
    for (int64_t k = 0; k < c->n_workers; k++)
        members += c->stepping[k] != 0;
    /* the count and a clear `all_done` before any worker can see its post and answer */
    __atomic_store_n(&barrier->countdown, members, __ATOMIC_SEQ_CST);
    mg_signal_try(&barrier->all_done);
    for (int64_t k = 0; k < c->n_workers; k++)
        if (c->stepping[k]) {
            mg_signal_set(c->go[k]);
            bits |= bell_bit(k);
        }
    int wake = 0;
    for (int64_t k = 0; k < c->n_workers && !wake; k++)
        wake = c->stepping[k] && mg_signal_sleeps(c->go[k]);
    mg_bell_ring(&barrier->bell, bits, wake);
}

int32_t mg_collect(mg_collector *c) {
    int64_t started = mg_now_ns(), spin_ns = __atomic_load_n(c->spin_ns, __ATOMIC_RELAXED);
    c->calls++;
    /* one wait for the waiter's account, however many workers: `all_done`'s post time is the last answer's */
    int32_t status = mg_signal_wait(&((mg_barrier *)c->barrier)->all_done, spin_ns, c->timeout_ns, c->waiter)
                         ? MG_COLLECT_DONE
                         : MG_COLLECT_SLOW;
    /* Each worker posts its `done` just after counting down: usually there already. Taken so that no
     * later wait finds it; a worker descheduled in between is waited for (no waiter: not the parent's
     * adaptive account). */
    int64_t seen = 0;
    for (; status == MG_COLLECT_DONE && seen < c->n_workers; seen++)
        if (c->stepping[seen] && !mg_signal_wait(c->done[seen], spin_ns, c->timeout_ns, NULL)) {
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
    c->wait_ns += mg_now_ns() - started;
    return status;
}
