"""The Ray actor of `RayVectorEnv`: a slice of envs in a local vector env on its node.

An `EnvHost` creates its envs itself (FMU instances cannot travel), in `EnvHost.start` (its
constructor is light, so that the driver can tell an actor Ray has placed from one still waiting
for CPUs), in a local `~modelicagym.vector.PoolVectorEnv`: the actor's process steps a slice
itself and ``cpus - 1`` workers the rest, so the actor uses exactly the CPUs Ray reserved for it
(with one CPU it steps them all, 3x what ``SyncVectorEnv`` does). The results are
``SyncVectorEnv``'s, step by step. Besides the vector API it runs whole rollouts with a policy shipped
once (:meth:`EnvHost.rollout`), the pattern that amortises a remote call over many steps.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv

from modelicagym.errors import ArgumentError, ModelicaGymError
from modelicagym.vector import EnvError
from modelicagym.vector.api import env_info

__all__ = ["EnvHost", "Policy", "Rollout", "local_vector_env"]

#: ``policy(observations) -> actions`` for a batch of one actor's envs
Policy = Callable[[np.ndarray], Any]


def local_vector_env(
    env_fns: Sequence[Callable[[], gym.Env]],
    cpus: int,
    autoreset_mode: AutoresetMode,
    pool_options: Mapping[str, Any] | None = None,
) -> VectorEnv:
    """The vector env of one node's share: a pool over ``cpus`` processes, the caller included
    (with one CPU the caller steps every env itself, in one C call where the envs allow); its
    waits plan for the actor's ``cpus``, not for the node's cores."""
    from modelicagym.vector import PoolVectorEnv

    options = {"num_workers": cpus - 1, "caller_steps": True, "cores": cpus, **(pool_options or {})}
    return PoolVectorEnv(list(env_fns), autoreset_mode=autoreset_mode, **options)


@dataclass
class Rollout:
    """``steps`` steps of one actor's envs: ``observations[t]`` is what the policy saw at step
    ``t`` and ``actions[t]`` what it chose; ``rewards``, ``terminations`` and ``truncations[t]``
    what the step returned; ``last_observations`` the observations after the last step. Axis 1 is
    the env, in the order of ``env_indices`` (indices in the whole vector env). ``infos`` holds the
    non-empty infos only: ``infos[t, env_index]`` is what that env's step ``t`` reported."""

    env_indices: np.ndarray
    observations: np.ndarray
    actions: np.ndarray
    rewards: np.ndarray
    terminations: np.ndarray
    truncations: np.ndarray
    last_observations: np.ndarray
    infos: dict[tuple[int, int], dict[str, Any]] = field(default_factory=dict)

    @classmethod
    def concatenate(cls, rollouts: Sequence[Rollout]) -> Rollout:
        """One rollout of all the envs of ``rollouts`` (same ``steps``), envs in their order."""
        def joined(name: str, axis: int) -> np.ndarray:
            return np.concatenate([getattr(r, name) for r in rollouts], axis=axis)

        return cls(joined("env_indices", 0), joined("observations", 1), joined("actions", 1), joined("rewards", 1),
                   joined("terminations", 1), joined("truncations", 1), joined("last_observations", 0),
                   {key: info for r in rollouts for key, info in r.infos.items()})


class EnvHost:
    """One actor's envs (made into a Ray actor class by `RayVectorEnv`; plain Python here)."""

    def __init__(
        self,
        env_fns: Sequence[Callable[[], gym.Env]],
        env_indices: Sequence[int],
        cpus: int,
        autoreset_mode: AutoresetMode,
        pool_options: Mapping[str, Any] | None = None,
    ) -> None:
        self.env_indices = np.asarray(env_indices, dtype=np.int64)
        self._recipe = (list(env_fns), cpus, autoreset_mode, pool_options)
        self.envs: VectorEnv | None = None
        self.observations: Any = None
        self.policy: Policy | None = None

    def pid(self) -> int:
        """The actor's process id: answered as soon as Ray has placed the actor."""
        return os.getpid()

    def start(self) -> dict[str, Any]:
        """Create the envs (a first use may build FMUs); returns `describe`."""
        if self.envs is None:
            self.envs = local_vector_env(*self._recipe)
        return self.describe()

    def describe(self) -> dict[str, Any]:
        """Spaces, metadata and where it runs: what the driver's vector env needs to know."""
        envs = self.envs
        return {"single_observation_space": envs.single_observation_space,
                "single_action_space": envs.single_action_space, "metadata": envs.metadata,
                "render_mode": envs.render_mode, "spec": getattr(envs, "spec", None), "pid": os.getpid()}

    def reset(self, seeds: list[int | None], options: dict[str, Any] | None) -> tuple[Any, dict[str, Any]]:
        """``reset`` of the local vector env."""
        self.observations, infos = self.envs.reset(seed=seeds, options=options)
        return self.observations, infos

    def step(self, actions: Any) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """``step`` of the local vector env."""
        result = self.envs.step(actions)
        self.observations = result[0]
        return result

    def call(self, name: str, args: tuple[Any, ...], kwargs: dict[str, Any]) -> tuple[Any, ...]:
        """``call`` of the local vector env."""
        return tuple(self.envs.call(name, *args, **kwargs))

    def set_attr(self, name: str, values: list[Any]) -> None:
        """``set_attr`` of the local vector env, one value per env."""
        self.envs.set_attr(name, values)

    def get_states(self) -> Any:
        """``get_states`` of the local pool: its envs' states and reset flags (a `VectorState`)."""
        return self.envs.get_states()

    def check_states(self, states: Any) -> None:
        """``check_states`` of the local pool, changing nothing."""
        with self._env_named("refuses its state, before any env changed"):
            self.envs.check_states(states)

    def set_states(self, states: Any) -> None:
        """``set_states`` of the local pool."""
        with self._env_named("could not load its state"):
            self.envs.set_states(states)

    @contextmanager
    def _env_named(self, what: str) -> Iterator[None]:
        """An env's error from the local pool raised as its own type, naming the env by its index
        in the whole vector env (the pool's `EnvError` types are made at run time, and Ray could not
        unpickle them in the driver)."""
        try:
            yield
        except EnvError as error:
            if error.env_index is None:
                raise
            index = int(self.env_indices[error.env_index])
            original = error.original
            kind = type(original) if isinstance(original, ModelicaGymError) else ArgumentError
            raise kind(f"env {index} {what}: {original if original is not None else error}") from None

    def set_policy(self, policy: Policy) -> None:
        """Keep ``policy`` for the following rollouts (Ray resolves the object reference)."""
        self.policy = policy

    def rollout(self, steps: int) -> Rollout:
        """Step the envs ``steps`` times from where they are, actions from the policy."""
        if self.policy is None:
            raise ArgumentError("no policy: RayVectorEnv.rollout(policy, steps) ships one")
        if self.observations is None:
            raise ArgumentError("reset the envs before a rollout")
        if steps < 1:
            raise ArgumentError(f"steps must be >= 1, got {steps}")
        first = np.asarray(self.observations)
        n = len(self.env_indices)
        observations = np.empty((steps, *first.shape), dtype=first.dtype)
        actions: np.ndarray | None = None
        rewards = np.empty((steps, n), dtype=np.float64)
        terminations = np.empty((steps, n), dtype=np.bool_)
        truncations = np.empty((steps, n), dtype=np.bool_)
        infos: dict[tuple[int, int], dict[str, Any]] = {}
        for t in range(steps):
            observations[t] = self.observations
            action = np.asarray(self.policy(observations[t]))
            if actions is None:
                actions = np.empty((steps, *action.shape), dtype=action.dtype)
            actions[t] = action
            self.observations, rewards[t], terminations[t], truncations[t], step_infos = self.envs.step(action)
            if step_infos:
                for j, index in enumerate(self.env_indices.tolist()):
                    if info := env_info(step_infos, j):
                        infos[t, index] = info
        return Rollout(self.env_indices, observations, actions, rewards, terminations, truncations,
                       np.asarray(self.observations).copy(), infos)

    def close(self) -> None:
        """Close the local vector env (its pool's processes end with it)."""
        if self.envs is not None:
            self.envs.close()
