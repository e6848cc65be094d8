/* See loop.h. mg_env_step and mg_env_reset are the production library's (step.c). */
#include "loop.h"

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
