/* Tabular Q-learning on a batch of envs, one C call per part of a training step: the numpy
 * agent of modelicagym/agents/qlearning.py operation for operation (same IEEE results), without
 * its ~50 numpy calls per step. */
#ifndef MG_QLEARNING_H
#define MG_QLEARNING_H

#include <stdint.h>

typedef struct {
    int64_t n_envs, n_states, n_actions;
    int64_t n_vars, max_edges;
    double *q;              /* n_envs x n_states x n_actions */
    double *epsilon;        /* n_envs */
    const double *edges;    /* n_vars x max_edges bin edges, padded with +inf */
    const int64_t *strides; /* n_vars: mixed-radix place value of each variable's bin */
    double learning_rate, discount, exploration_decay;
    int32_t bootstrap_on_truncation;
} mg_qlearner;

/* State index of each env's observation (row i of the n_envs x n_vars obs). */
void mg_q_states(const mg_qlearner *a, const double *obs, int64_t *states);

/* Epsilon-greedy action of each env from its two uniform draws (row i of n_envs x 2). */
void mg_q_act(const mg_qlearner *a, const int64_t *states, const double *draws, int64_t *actions);

/* The Q-learning update for every env whose mask is set, then the decay of its epsilon. */
void mg_q_learn(const mg_qlearner *a, const int64_t *states, const int64_t *actions, const double *rewards,
                const int64_t *next_states, const uint8_t *terminated, const uint8_t *truncated,
                const uint8_t *mask);

#endif
