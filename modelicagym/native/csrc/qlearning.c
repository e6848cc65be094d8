/* See qlearning.h. Each expression is written as numpy evaluates its counterpart. */
#include "qlearning.h"

void mg_q_states(const mg_qlearner *a, const double *obs, int64_t *states) {
    for (int64_t i = 0; i < a->n_envs; i++) {
        int64_t state = 0;
        for (int64_t v = 0; v < a->n_vars; v++) {
            double x = obs[i * a->n_vars + v];
            const double *edges = a->edges + v * a->max_edges;
            int64_t bin = 0;
            for (int64_t k = 0; k < a->max_edges; k++)
                bin += x >= edges[k];
            state += bin * a->strides[v];
        }
        states[i] = state;
    }
}

static int64_t greedy(const double *row, int64_t n_actions) {
    int64_t best = 0;
    for (int64_t k = 1; k < n_actions; k++)
        if (row[k] > row[best])
            best = k;
    return best;
}

void mg_q_act(const mg_qlearner *a, const int64_t *states, const double *draws, int64_t *actions) {
    for (int64_t i = 0; i < a->n_envs; i++) {
        if (draws[2 * i] < a->epsilon[i]) {
            int64_t random = (int64_t)(draws[2 * i + 1] * (double)a->n_actions);
            actions[i] = random < a->n_actions - 1 ? random : a->n_actions - 1;
        } else {
            actions[i] = greedy(a->q + (i * a->n_states + states[i]) * a->n_actions, a->n_actions);
        }
    }
}

void mg_q_learn(const mg_qlearner *a, const int64_t *states, const int64_t *actions, const double *rewards,
                const int64_t *next_states, const uint8_t *terminated, const uint8_t *truncated,
                const uint8_t *mask) {
    for (int64_t i = 0; i < a->n_envs; i++) {
        if (!mask[i])
            continue;
        const double *next = a->q + (i * a->n_states + next_states[i]) * a->n_actions;
        double future = next[0];
        for (int64_t k = 1; k < a->n_actions; k++)
            if (next[k] > future)
                future = next[k];
        if (terminated[i] || (!a->bootstrap_on_truncation && truncated[i]))
            future = 0.0;
        double target = rewards[i] + a->discount * future;
        double *entry = a->q + (i * a->n_states + states[i]) * a->n_actions + actions[i];
        *entry += a->learning_rate * (target - *entry);
        a->epsilon[i] *= a->exploration_decay;
    }
}
