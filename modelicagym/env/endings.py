"""A reward or termination written in Python, on the native step path: the FMU steps in C, Python
decides how the step ends.

Users write rewards and terminations in Python. Two ways, and either keeps the FMU's step in C:

* **per env**, as always: an overridden ``compute_reward(observation, action, terminated)`` /
  ``is_terminal(observation)``, or ``reward=f(env, observation, action, terminated)`` /
  ``termination=f(env, observation)`` in the config. Called once per env and step, after C stepped
  the FMU.
* **on arrays**, the fast way in a pool: an overridden classmethod
  ``compute_rewards(envs, observations, actions, terminated)`` / ``are_terminal(envs, observations)``,
  or ``batch_reward=f(envs, observations, actions, terminated)`` / ``batch_termination=f(envs,
  observations)`` in the config. Row ``k`` of each array is ``envs[k]``'s step; they return one
  reward / one flag per row. A pool's slice calls them once per step for all its envs that share
  them; a single env calls them with one row (the default per-env methods do), so a function of
  its rows gives the same numbers either way, to the last bit.

`PythonEndings` is what an env on the native path with such a reward or termination offers the
pool (``env.native_endings``): a key (envs with equal keys are ended in one call) and
:meth:`PythonEndings.finish`. The C side is ``native/csrc/endings.h``.
"""

from __future__ import annotations

import inspect
from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np

from modelicagym.errors import ConfigError, ConfigTypeError

__all__ = ["PythonEndings", "batch_reward_defined", "batch_termination_defined", "check_array_hooks", "overridden",
           "python_endings", "reward_of_one", "termination_of_one"]


def overridden(cls: type, base: type, name: str) -> bool:
    """Whether ``cls`` overrides ``base``'s method ``name`` (plain, class or static method)."""
    method, original = getattr(cls, name), getattr(base, name)
    return getattr(method, "__func__", method) is not getattr(original, "__func__", original)


def check_array_hooks(cls: type, base: type) -> None:
    """``cls``'s overrides of the array forms are classmethods (or staticmethods): they get a
    slice's envs, not one of them; a plain method is refused when the env is made, in one line."""
    for name in ("compute_rewards", "are_terminal"):
        method = inspect.getattr_static(cls, name)
        if overridden(cls, base, name) and not isinstance(method, (classmethod, staticmethod)):
            raise ConfigTypeError(f"{cls.__name__}.{name} must be a classmethod: it gets the envs of a slice and "
                                  "their arrays, not one env (decorate it with @classmethod)")


def batch_reward_defined(env: gym.Env, base: type) -> bool:
    """Whether ``env`` (an `FMUEnv`; ``base`` is `FMUEnv`) has a reward written on arrays."""
    return overridden(type(env), base, "compute_rewards") or env.config.batch_reward is not None


def batch_termination_defined(env: gym.Env, base: type) -> bool:
    """Whether ``env`` has a termination written on arrays."""
    return overridden(type(env), base, "are_terminal") or env.config.batch_termination is not None


def one_row(value: Any) -> Any:
    """``value`` as a batch of one row (a dict observation: each entry), for an array hook called by one env."""
    if isinstance(value, dict):
        return {name: one_row(item) for name, item in value.items()}
    return np.asarray(value)[None]


def reward_of_one(env: gym.Env, observation: Any, action: Any, terminated: bool) -> float:
    """``env``'s reward from its array form (``compute_rewards``), called with one row."""
    cls = type(env)
    rewards = cls.compute_rewards([env], one_row(observation), one_row(action), np.array([terminated], dtype=np.bool_))
    return float(_column(rewards, 1, f"{cls.__name__}.compute_rewards", np.float64)[0])


def termination_of_one(env: gym.Env, observation: Any) -> bool:
    """Whether ``env``'s episode is over, from its array form (``are_terminal``), called with one row."""
    cls = type(env)
    return bool(_column(cls.are_terminal([env], one_row(observation)), 1, f"{cls.__name__}.are_terminal", np.bool_)[0])


def python_endings(env: gym.Env, base: type) -> PythonEndings | None:
    """How ``env``'s steps end in Python after C stepped its FMU, or ``None`` when its config's
    reward and termination bounds say it all (C decides)."""
    cls, config = type(env), env.config
    per_env_reward = overridden(cls, base, "compute_reward") or config.reward is not None
    per_env_termination = overridden(cls, base, "is_terminal") or callable(config.termination)
    batch_reward, batch_termination = batch_reward_defined(env, base), batch_termination_defined(env, base)
    if not (per_env_reward or per_env_termination or batch_reward or batch_termination):
        return None
    return PythonEndings(cls, config, per_env_reward, per_env_termination, batch_reward, batch_termination)


class PythonEndings:
    """The reward and termination of an env's native steps, in Python (see the module docstring).

    ``termination``: the termination is Python's (C then checks no bounds; it still reports the
    model ending the simulation, which terminates the episode whatever Python says). The reward is
    always Python's: the paper's default reward depends on the termination.
    """

    def __init__(self, cls: type, config: Any, per_env_reward: bool, per_env_termination: bool,
                 batch_reward: bool, batch_termination: bool) -> None:
        self._cls = cls
        self.termination = per_env_termination or batch_termination
        #: envs with the same key are ended by one call (their class, and their config's array hooks)
        self.key = (cls, config.batch_reward, config.batch_termination, self.termination)
        #: the hooks run per env, on the env itself: they may keep state in it, so its two copies
        #: in an adaptive pool (one per process) could disagree
        self.per_env = (per_env_reward and not batch_reward) or (per_env_termination and not batch_termination)
        parts = []
        if per_env_reward or batch_reward:
            parts.append("the reward ("
                         + ("compute_rewards on arrays" if batch_reward else "compute_reward per env") + ")")
        if self.termination:
            parts.append("the termination ("
                         + ("are_terminal on arrays" if batch_termination else "is_terminal per env") + ")")
        #: what of the step Python computes after C: ``step_path_reason`` names them
        self.parts = parts

    def finish(self, envs: Sequence[gym.Env], observations: np.ndarray, actions: np.ndarray,
               terminated: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The rewards and terminations of steps C took for ``envs`` (all with this key): row ``k``
        of ``observations`` / ``actions`` is ``envs[k]``'s; ``terminated`` holds C's verdict (the
        model ended the simulation, or bounds C checked)."""
        cls, n = self._cls, len(envs)
        if self.termination:
            python = _column(cls.are_terminal(envs, observations), n, f"{cls.__name__}.are_terminal", np.bool_)
            terminated = python | terminated
        rewards = _column(cls.compute_rewards(envs, observations, actions, terminated), n,
                          f"{cls.__name__}.compute_rewards", np.float64)
        return rewards, terminated


def _column(values: Any, n: int, what: str, dtype: type) -> np.ndarray:
    """``values`` as a ``(n,)`` array of ``dtype``, or a `ConfigError` saying what the hook returned."""
    array = np.asarray(values)
    if array.shape != (n,):
        raise ConfigError(f"{what} returned an array of shape {array.shape} for {n} envs; it must return shape ({n},)")
    return array.astype(dtype, copy=False)
