"""Recording and comparing what vector envs return, to prove the pool behaves like gymnasium's own."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode


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
