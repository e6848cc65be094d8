"""Train a batched tabular agent on a vector env until every env has finished its episodes.

The loop assumes the vector env's NEXT_STEP autoreset (gymnasium's default and the pool's): after
env ``i`` returns ``terminated`` or ``truncated``, its next ``step`` ignores the action, resets the
env and returns the first observation of the new episode with reward 0. That transition is not part
of any episode, so it is neither learned from nor counted. Once an env has finished its
``n_episodes`` it is no longer stepped when the vector env can step a subset of its envs (the
pool's ``step_envs``); otherwise it keeps being stepped with the others and its transitions are
ignored. The episodes are the same either way: the agent draws its random numbers for every env.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import gymnasium
import numpy as np
from gymnasium.vector import AutoresetMode, SyncVectorEnv, VectorEnv

from modelicagym.agents.episodes import EpisodeTracker
from modelicagym.agents.qlearning import QLearningAgent
from modelicagym.errors import ArgumentError

__all__ = ["TrainingLog", "train"]


@dataclass
class TrainingLog:
    """What happened during :func:`train`, per env.

    ``lengths[i, k]`` and ``returns[i, k]`` are the number of steps and the sum of rewards of
    episode ``k`` of env ``i``; ``env_steps[i]`` counts the steps learned from (the sum of
    ``lengths[i]``), ``env_steps_stepped[i]`` the steps env ``i`` took (autoresets and, without
    subset steps, the steps after its last episode included); ``vector_steps`` counts calls to
    the vector env; ``agent_seconds`` is the time spent in the agent (discretising, acting,
    learning).
    """

    lengths: np.ndarray
    returns: np.ndarray
    env_steps: np.ndarray
    env_steps_stepped: np.ndarray
    vector_steps: int
    agent_seconds: float


def _as_vector_env(env: gymnasium.Env | VectorEnv) -> VectorEnv:
    """A vector env as is; a single env wrapped as a vector env of one."""
    if isinstance(env, VectorEnv):
        return env
    return SyncVectorEnv([lambda: env], autoreset_mode=AutoresetMode.NEXT_STEP)


def train(
    envs: gymnasium.Env | VectorEnv,
    agent: QLearningAgent,
    n_episodes: int,
    *,
    seed: int | Sequence[int] | None = None,
    on_episodes: Callable[[int], None] | None = None,
) -> TrainingLog:
    """Run ``agent`` on ``envs`` until each env has completed ``n_episodes`` episodes.

    ``seed`` is passed to the first ``reset``. ``on_episodes(k)`` is called whenever ``k > 0``
    episodes have just been completed (for progress reporting).
    """
    envs = _as_vector_env(envs)
    mode = AutoresetMode(envs.metadata.get("autoreset_mode", AutoresetMode.NEXT_STEP))
    if mode is not AutoresetMode.NEXT_STEP:
        raise ArgumentError(f"train() needs a vector env with NEXT_STEP autoreset, got {mode}")
    n = envs.num_envs
    if agent.n_envs != n:
        raise ArgumentError(f"the agent has {agent.n_envs} Q-tables for {n} envs")
    if n_episodes < 1:
        raise ArgumentError(f"n_episodes must be >= 1, got {n_episodes}")

    lengths = np.zeros((n, n_episodes), dtype=np.int64)
    returns = np.zeros((n, n_episodes), dtype=np.float64)
    finished = np.zeros(n, dtype=np.int64)
    tracker = EpisodeTracker(n)
    stepped = np.zeros(n, dtype=np.int64)
    vector_steps = 0
    agent_seconds = 0.0
    step_envs = getattr(envs, "step_envs", None)

    observations, _ = envs.reset(seed=seed)
    clock = time.perf_counter()
    states = agent.states(observations)
    wanted, everyone = np.ones(n, dtype=bool), True  # the envs with episodes to go
    while True:
        actions = agent.act(states)
        agent_seconds += time.perf_counter() - clock
        if everyone or step_envs is None:
            observations, rewards, terminated, truncated, _ = envs.step(actions)
            stepped += 1
        else:
            observations, rewards, terminated, truncated = _step_subset(step_envs, observations, actions, wanted)
            stepped += wanted
        vector_steps += 1
        clock = time.perf_counter()
        next_states = agent.states(observations)
        live = tracker.live(wanted)
        agent.learn(states, actions, rewards, next_states, terminated, truncated, mask=live)
        ended, ended_lengths, ended_returns = tracker.update(live, rewards, terminated, truncated)
        if ended.size:
            lengths[ended, finished[ended]] = ended_lengths
            returns[ended, finished[ended]] = ended_returns
            finished[ended] += 1
            if on_episodes is not None:
                on_episodes(int(ended.size))
            wanted = finished < n_episodes
            everyone = bool(wanted.all())
            if not wanted.any():
                break
        states = next_states
    agent_seconds += time.perf_counter() - clock
    return TrainingLog(lengths, returns, lengths.sum(axis=1), stepped, vector_steps, agent_seconds)


def _step_subset(
    step_envs: Callable[..., tuple], observations: np.ndarray, actions: np.ndarray, wanted: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Step only the ``wanted`` envs; the others keep their observation, with reward 0 and no end."""
    sub_observations, sub_rewards, sub_terminated, sub_truncated, _ = step_envs(actions[wanted], wanted)
    observations = observations.copy()
    observations[wanted] = sub_observations
    rewards = np.zeros(len(wanted), dtype=np.float64)
    rewards[wanted] = sub_rewards
    terminated = np.zeros(len(wanted), dtype=bool)
    terminated[wanted] = sub_terminated
    truncated = np.zeros(len(wanted), dtype=bool)
    truncated[wanted] = sub_truncated
    return observations, rewards, terminated, truncated
