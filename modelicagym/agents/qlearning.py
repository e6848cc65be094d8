"""Tabular epsilon-greedy Q-learning, batched: one independent Q-table per env of a vector env.

The update is the paper's Q-learning rule,
``Q(s, a) += lr * (r + gamma * max_a' Q(s', a') - Q(s, a))``, applied to all envs of a batch at once
with numpy fancy indexing (no Python loop over envs).

End of episodes: on *termination* (the pole fell, the cart left the track) ``s'`` is not a real
state, so there is no bootstrap: the target is ``r``. On *truncation* (the step limit) the episode
could have continued, so the target bootstraps from ``s'`` (``bootstrap_on_truncation=True``). The
paper's published code does neither distinction: it bootstraps on every transition, terminal ones
included, from the Q-value of the next epsilon-greedy action (a SARSA-style target).

Randomness: env ``i`` owns its own ``numpy.random.Generator`` (Q-table initialisation and the
epsilon-greedy draws), so a batch of ``n`` envs behaves exactly like ``n`` single-env agents
created with the same seeds and fed the same transitions. The draws are taken from each generator
in blocks, which keeps the per-step hot path free of a Python loop over envs.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import asdict, dataclass, fields
from typing import BinaryIO

import numpy as np

from modelicagym.agents.discretization import Discretizer
from modelicagym.agents.native_qlearning import NativeQLearning, native_library
from modelicagym.errors import ArgumentError, ConfigError

__all__ = ["QLearningAgent", "QLearningConfig", "SeedLike"]

SeedLike = int | np.random.SeedSequence | None

_DRAWS_PER_STEP = 2  # one uniform for "explore?", one for the random action
_BLOCK_STEPS = 256


@dataclass(frozen=True)
class QLearningConfig:
    """Hyperparameters; the defaults are the paper's values.

    ``exploration_rate`` is the initial epsilon; it is multiplied by ``exploration_decay`` after
    every learned step of the env (across episodes, never reset). The Q-table starts uniform in
    ``[q_init_low, q_init_high]``.
    """

    learning_rate: float = 0.2
    discount: float = 1.0
    exploration_rate: float = 0.5
    exploration_decay: float = 0.99
    q_init_low: float = -1.0
    q_init_high: float = 1.0
    bootstrap_on_truncation: bool = True

    def __post_init__(self) -> None:
        checks = {
            "learning_rate": 0.0 < self.learning_rate <= 1.0,
            "discount": 0.0 <= self.discount <= 1.0,
            "exploration_rate": 0.0 <= self.exploration_rate <= 1.0,
            "exploration_decay": 0.0 <= self.exploration_decay <= 1.0,
            "q_init_low": self.q_init_low <= self.q_init_high,
        }
        bad = [name for name, ok in checks.items() if not ok]
        if bad:
            raise ConfigError(f"invalid Q-learning hyperparameters {bad}: {self}")


def _generators(seeds: SeedLike | Sequence[SeedLike], n_envs: int) -> list[np.random.Generator]:
    """One generator per env: a single seed is spread with ``SeedSequence.spawn``."""
    if seeds is None or isinstance(seeds, (int, np.integer, np.random.SeedSequence)):
        root = seeds if isinstance(seeds, np.random.SeedSequence) else np.random.SeedSequence(seeds)
        return [np.random.default_rng(child) for child in root.spawn(n_envs)]
    seeds = list(seeds)
    if len(seeds) != n_envs:
        raise ArgumentError(f"got {len(seeds)} seeds for {n_envs} envs")
    return [np.random.default_rng(seed) for seed in seeds]


class _UniformBlocks:
    """Per-env uniform draws, fetched ``_BLOCK_STEPS`` steps at a time from each env's generator."""

    def __init__(self, generators: list[np.random.Generator]) -> None:
        self._generators = generators
        self._block = np.empty((len(generators), 0, _DRAWS_PER_STEP))
        self._next = 0

    def take(self) -> np.ndarray:
        """The next ``(n_envs, _DRAWS_PER_STEP)`` draws."""
        if self._next == self._block.shape[1]:
            self._block = np.stack([g.random((_BLOCK_STEPS, _DRAWS_PER_STEP)) for g in self._generators])
            self._next = 0
        draws = self._block[:, self._next]
        self._next += 1
        return draws


class QLearningAgent:
    """Epsilon-greedy tabular Q-learning over ``n_envs`` independent Q-tables.

    Observations are mapped to states by ``discretizer``; the Q-tables are ``q_table[env, state,
    action]``. The agent works on batches: ``states``, ``actions``, rewards and flags are arrays of
    length ``n_envs``. With ``native=True`` (default) ``states``, ``act`` and ``learn`` are one call
    each into our native library (`modelicagym.agents.native_qlearning`: the same results, bit for
    bit), where it can be built; the numpy path otherwise.
    """

    def __init__(
        self,
        discretizer: Discretizer,
        n_actions: int,
        *,
        n_envs: int = 1,
        config: QLearningConfig | None = None,
        seeds: SeedLike | Sequence[SeedLike] = None,
        native: bool = True,
    ) -> None:
        if n_actions < 1 or n_envs < 1:
            raise ArgumentError(f"need n_actions >= 1 and n_envs >= 1, got {n_actions}, {n_envs}")
        self.discretizer = discretizer
        self.config = config or QLearningConfig()
        self.n_envs = n_envs
        self.n_actions = n_actions
        generators = _generators(seeds, n_envs)
        shape = (discretizer.n_states, n_actions)
        low, high = self.config.q_init_low, self.config.q_init_high
        self._q_table = np.stack([g.uniform(low, high, shape) for g in generators])
        self._epsilon = np.full(n_envs, self.config.exploration_rate)
        self._draws = _UniformBlocks(generators)
        self._envs = np.arange(n_envs)
        self._native = self._native_path(native)

    def _native_path(self, native: bool) -> NativeQLearning | None:
        """The C hot path over this agent's arrays, if ``native`` and our library can be built."""
        library = native_library() if native else None
        if library is None:
            return None
        config = self.config
        return NativeQLearning(
            library, self._q_table, self._epsilon, self.discretizer, config.learning_rate, config.discount,
            config.exploration_decay, config.bootstrap_on_truncation,
        )

    def __getstate__(self) -> dict:
        """Pickled (e.g. back from a Ray task) without the C bindings, which are made anew."""
        return {**self.__dict__, "_native": self._native is not None}

    def __setstate__(self, state: dict) -> None:
        native = state.pop("_native")
        self.__dict__.update(state)
        self._native = self._native_path(native)

    @property
    def q_table(self) -> np.ndarray:
        """The Q-tables, shape ``(n_envs, n_states, n_actions)``."""
        return self._q_table

    @q_table.setter
    def q_table(self, value: np.ndarray) -> None:
        # Copied into the array learn() updates in place (through flat views, or in C).
        value = np.asarray(value, dtype=np.float64)
        if value.shape != self._q_table.shape:
            raise ArgumentError(f"Q-table shape {value.shape} != {self._q_table.shape}")
        self._q_table[...] = value

    @property
    def epsilon(self) -> np.ndarray:
        """The exploration rate of every env, shape ``(n_envs,)``."""
        return self._epsilon

    @epsilon.setter
    def epsilon(self, value: np.ndarray) -> None:
        value = np.asarray(value, dtype=np.float64)
        if value.shape != self._epsilon.shape:
            raise ArgumentError(f"epsilon shape {value.shape} != {self._epsilon.shape}")
        self._epsilon[...] = value

    def states(self, observations: np.ndarray) -> np.ndarray:
        """State indices of a batch of observations, shape ``(n_envs, d)`` -> ``(n_envs,)``."""
        if self._native is not None and np.shape(observations) == (self.n_envs, self.discretizer.n_variables):
            return self._native.states(observations)
        return self.discretizer.states(observations)

    def act(self, states: np.ndarray, *, greedy: bool = False) -> np.ndarray:
        """Epsilon-greedy actions for every env (the greedy ones with ``greedy=True``).

        Every non-greedy call consumes one draw per env, whether or not the env uses its action.
        Ties in the greedy choice go to the lowest action index.
        """
        if self._native is not None and not greedy:
            return self._native.act(states, self._draws.take())
        best = self.q_table[self._envs, states].argmax(axis=1)
        if greedy:
            return best
        draws = self._draws.take()
        explore = draws[:, 0] < self.epsilon
        random_actions = np.minimum((draws[:, 1] * self.n_actions).astype(np.int64), self.n_actions - 1)
        return np.where(explore, random_actions, best)

    def learn(
        self,
        states: np.ndarray,
        actions: np.ndarray,
        rewards: np.ndarray,
        next_states: np.ndarray,
        terminated: np.ndarray,
        truncated: np.ndarray,
        mask: np.ndarray | None = None,
    ) -> None:
        """Apply the Q-learning update to the envs where ``mask`` is true, then decay their epsilon.

        Envs outside ``mask`` (an autoreset step, an env that finished its episodes) are untouched.
        """
        if self._native is not None:
            mask = np.ones(self.n_envs, dtype=np.bool_) if mask is None else mask
            self._native.learn(states, actions, rewards, next_states, terminated, truncated, mask)
            return
        envs = self._envs if mask is None else np.flatnonzero(mask)
        if envs.size == 0:
            return
        # Flat views: row ``env * n_states + state`` of ``rows``, entry ``row * n_actions + action``.
        rows = self.q_table.reshape(-1, self.n_actions)
        first_row = envs * self.discretizer.n_states
        future = rows[first_row + next_states[envs]].max(axis=1)
        stop = np.asarray(terminated)[envs]
        if not self.config.bootstrap_on_truncation:
            stop = stop | np.asarray(truncated)[envs]
        future[stop] = 0.0
        target = np.asarray(rewards, dtype=np.float64)[envs] + self.config.discount * future
        entries = (first_row + states[envs]) * self.n_actions + actions[envs]
        flat = self.q_table.reshape(-1)
        flat[entries] += self.config.learning_rate * (target - flat[entries])
        self.epsilon[envs] *= self.config.exploration_decay

    def predict(self, observation: np.ndarray, env_index: int = 0) -> int:
        """Greedy action for one observation from the Q-table of ``env_index``: the learned policy."""
        observation = np.asarray(observation)
        if observation.ndim != 1:
            raise ArgumentError(f"predict takes one observation of shape (d,), got shape {observation.shape}")
        state = self.discretizer.states(observation)
        return int(self.q_table[env_index, state].argmax())

    def save(self, file: str | os.PathLike[str] | BinaryIO) -> None:
        """Write Q-tables, epsilons, discretizer and hyperparameters to ``file`` (``.npz``; a path,
        written as given, or a binary file object).

        Generator states are not saved: a loaded agent explores with fresh draws.
        """
        arrays = {f"discretizer_{k}": v for k, v in self.discretizer.to_dict().items()}
        arrays.update({f"config_{k}": np.asarray(v) for k, v in asdict(self.config).items()})
        if hasattr(file, "write"):
            np.savez(file, q_table=self.q_table, epsilon=self.epsilon, **arrays)
            return
        with open(file, "wb") as f:
            self.save(f)

    @classmethod
    def load(cls, path: str | os.PathLike[str], *, seeds: SeedLike | Sequence[SeedLike] = None) -> QLearningAgent:
        """Read an agent written by :meth:`save`."""
        with np.load(path) as data:
            discretizer = Discretizer.from_dict(
                {k.removeprefix("discretizer_"): data[k] for k in data.files if k.startswith("discretizer_")}
            )
            config = QLearningConfig(**{f.name: data[f"config_{f.name}"].item() for f in fields(QLearningConfig)})
            q_table, epsilon = data["q_table"], data["epsilon"]
        agent = cls(discretizer, q_table.shape[2], n_envs=q_table.shape[0], config=config, seeds=seeds)
        agent.q_table = q_table
        agent.epsilon = np.array(epsilon, dtype=np.float64)
        return agent
