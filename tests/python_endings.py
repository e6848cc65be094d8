"""Cart-pole envs whose reward and termination are written in Python, each way a user can write
them (per env or on arrays; in the config or in a subclass), with the same numbers every way: for
tests that compare the native step path with the Python path."""

from __future__ import annotations

from functools import partial
from typing import Any

import numpy as np

from modelicagym import FMUEnv
from modelicagym.models.cartpole import OUTPUTS, cartpole_fmu
from modelicagym.models.cartpole.env import UPRIGHT, CartPoleEnv

#: per env, as Python floats: no power or library call whose scalar and array forms could round differently


def reward(env: Any, observation: np.ndarray, action: Any, terminated: bool) -> float:
    tilt = observation[2] - UPRIGHT
    return float(-(tilt * tilt) - 0.1 * abs(observation[0]) + 0.01 * action - 10.0 * terminated)


def termination(env: Any, observation: np.ndarray) -> bool:
    return bool(abs(observation[0]) > 0.8 or abs(observation[2] - UPRIGHT) > 0.15)


def batch_reward(envs: Any, observations: np.ndarray, actions: np.ndarray, terminated: np.ndarray) -> np.ndarray:
    tilt = observations[:, 2] - UPRIGHT
    return -(tilt * tilt) - 0.1 * np.abs(observations[:, 0]) + 0.01 * actions - 10.0 * terminated


def batch_termination(envs: Any, observations: np.ndarray) -> np.ndarray:
    return (np.abs(observations[:, 0]) > 0.8) | (np.abs(observations[:, 2] - UPRIGHT) > 0.15)


class PerEnvCartPole(CartPoleEnv):
    """The reward and termination overridden per env."""

    def compute_reward(self, observation: Any, action: Any, terminated: bool) -> float:
        return reward(self, observation, action, terminated)

    def is_terminal(self, observation: Any) -> bool:
        return termination(self, observation)


class ArrayCartPole(CartPoleEnv):
    """The reward and termination overridden on arrays."""

    @classmethod
    def compute_rewards(cls, envs: Any, observations: Any, actions: Any, terminated: Any) -> np.ndarray:
        return batch_reward(envs, observations, actions, terminated)

    @classmethod
    def are_terminal(cls, envs: Any, observations: Any) -> np.ndarray:
        return batch_termination(envs, observations)


def config_cartpole(**config: Any) -> FMUEnv:
    """The cart-pole's FMU as a plain FMUEnv config (a termination callable needs one: CartPoleEnv sets bounds)."""
    return FMUEnv(fmu=cartpole_fmu(), inputs=["f"], outputs=list(OUTPUTS), time_step=0.05,
                  parameters={"theta_0": float(UPRIGHT - 0.05)}, action_table=[[-15.0], [15.0]], **config)


#: every way to write them: name -> env maker taking FMUEnv config keys
KINDS = {
    "per env, config": partial(config_cartpole, reward=reward, termination=termination),
    "arrays, config": partial(config_cartpole, batch_reward=batch_reward, batch_termination=batch_termination),
    "per env, class": PerEnvCartPole,
    "arrays, class": ArrayCartPole,
    "reward on arrays, bounds in C": partial(CartPoleEnv, batch_reward=batch_reward),
}


def endings_fns(kind: str, n: int) -> tuple[list, list]:
    """Env fns of ``kind`` on the native path, and the same envs on the Python path."""
    make = KINDS[kind]
    native = [partial(make, max_episode_steps=5 + 4 * i) for i in range(n)]
    python = [partial(make, max_episode_steps=5 + 4 * i, step_path="python") for i in range(n)]
    return native, python
