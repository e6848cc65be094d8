"""Recording and comparing what vector envs return, to prove the pool behaves like gymnasium's own."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, SyncVectorEnv

from modelicagym.vector import PoolVectorEnv


def assert_same(a: Any, b: Any, where: str = "") -> None:
    """Deep equality of vector-env results: arrays (dtype, shape, values), dicts, tuples, objects."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and a.keys() == b.keys(), f"{where}: keys {a.keys()} != {b.keys()}"
        for key in a:
            assert_same(a[key], b[key], f"{where}[{key!r}]")
    elif isinstance(a, (tuple, list)):
        assert type(a) is type(b) and len(a) == len(b), f"{where}: {a!r} != {b!r}"
        for k, (x, y) in enumerate(zip(a, b)):
            assert_same(x, y, f"{where}[{k}]")
    elif isinstance(a, np.ndarray):
        assert isinstance(b, np.ndarray), f"{where}: {type(b)} is not an array"
        assert (a.dtype, a.shape) == (b.dtype, b.shape), f"{where}: {a.dtype}{a.shape} != {b.dtype}{b.shape}"
        if a.dtype == object:
            for k, (x, y) in enumerate(zip(a, b)):
                assert_same(x, y, f"{where}[{k}]")
        else:
            np.testing.assert_array_equal(a, b, err_msg=where)
    else:
        assert type(a) is type(b) and a == b, f"{where}: {a!r} != {b!r}"


def rollout(envs: gym.vector.VectorEnv, steps: int, seed: int = 7) -> list:
    """Everything a vector env returns over ``steps`` steps; in DISABLED mode ended envs are reset
    with a reset mask (whose results are recorded too)."""
    records: list[Any] = [envs.reset(seed=seed)]
    envs.action_space.seed(seed)
    disabled = envs.metadata["autoreset_mode"] is AutoresetMode.DISABLED
    for _ in range(steps):
        result = envs.step(envs.action_space.sample())
        records.append(result)
        ended = result[2] | result[3]
        if disabled and ended.any():
            records.append(envs.reset(options={"reset_mask": ended}))
    return records


def assert_native_equals_python(native_fns: list, python_fns: list, steps: int = 150, **pool_options: Any) -> None:
    """The pool over ``native_fns`` (every env on the native path) gives what SyncVectorEnv over ``python_fns`` gives."""
    mode = pool_options.get("autoreset_mode", AutoresetMode.NEXT_STEP)
    sync = SyncVectorEnv(python_fns, autoreset_mode=mode)
    with PoolVectorEnv(native_fns, **pool_options) as pool:
        assert {path for path, _ in pool.step_paths} == {"native"}, pool.step_paths
        expected, actual = rollout(sync, steps), rollout(pool, steps)
    sync.close()
    assert_same(expected, actual)


class Flipping:
    """A policy that moves every movable env to the other side every ``every`` parts it observes
    (its parties never apart)."""

    apart = home_slower = False

    def __init__(self, movable: int, every: int) -> None:
        self.movable, self.target, self.switches, self.last_decision = movable, 0, 0, ""
        self._every, self._seen = every, 0

    def observe(self, *measured: Any, **parties: Any) -> bool:
        self._seen += 1
        if self._seen % self._every:
            return False
        self.target = self.movable - self.target
        self.switches += 1
        self.last_decision = f"{self.target} movable envs to the calling process: scripted"
        return True


def flipping(pool: PoolVectorEnv, every: int) -> Flipping:
    """Put a `Flipping` policy in place of the pool's adaptive layout policy."""
    policy = Flipping(pool._placement.policy.movable, every)
    pool._placement.policy = policy
    return policy


def rollout_recording_layouts(envs: Any, steps: int, seed: int = 7) -> tuple[list, set[int]]:
    """As ``vector_rollouts.rollout``, and how many envs the calling process (or the worker standing
    in for it) stepped after each step."""
    records: list[Any] = [envs.reset(seed=seed)]
    envs.action_space.seed(seed)
    disabled = envs.metadata["autoreset_mode"] is AutoresetMode.DISABLED
    in_caller = set()
    for _ in range(steps):
        result = envs.step(envs.action_space.sample())
        records.append(result)
        records.append(envs.get_attr("elapsed_steps"))
        ended = result[2] | result[3]
        if disabled and ended.any():
            records.append(envs.reset(options={"reset_mask": ended}))
        if isinstance(envs, PoolVectorEnv):
            in_caller.add(envs.layout.envs_in_caller + envs.layout.envs_in_stand_in)
    return records, in_caller
