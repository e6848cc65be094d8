"""Envs on the native and the Python step path, for tests that compare the two."""

from __future__ import annotations

from functools import partial
from typing import Any

import numpy as np

import modelicagym
from modelicagym import FMUEnv


def probe_env(path: Any, **config: Any) -> FMUEnv:
    """The probe FMU as a Box-action env of Float64 inputs and outputs (native-capable)."""
    parameters = {"gear": 1, "enable": True, **config.pop("parameters", {})}
    config.setdefault("termination", {"position": (-3.0, 3.0)})
    return FMUEnv(fmu=path, inputs=["force"], outputs=["position", "clock"], parameters=parameters, time_step=0.1, **config)



def cartpole_fns(n: int, **options: Any) -> tuple[list, list]:
    """Env fns on the native path, and the same envs forced onto the Python path."""
    native = [partial(modelicagym.make, "cartpole", max_episode_steps=5 + 4 * i, **options) for i in range(n)]
    python = [partial(modelicagym.make, "cartpole", max_episode_steps=5 + 4 * i, step_path="python", **options)
              for i in range(n)]
    return native, python


def assert_same_steps(native: Any, python: Any, actions: list[Any], seed: int = 0) -> int:
    """Step both envs with ``actions`` (resetting both after an episode ends); returns the episodes."""
    assert np.array_equal(native.reset(seed=seed)[0], python.reset(seed=seed)[0])
    episodes = 0
    for step, action in enumerate(actions):
        a, b = native.step(action), python.step(action)
        assert np.array_equal(a[0], b[0]), f"observation differs at step {step}"
        assert a[1:] == b[1:], f"reward/terminated/truncated/info differ at step {step}: {a[1:]} vs {b[1:]}"
        assert native.unwrapped.elapsed_steps == python.unwrapped.elapsed_steps
        assert native.unwrapped.fmu.time == python.unwrapped.fmu.time
        if a[2] or a[3]:
            episodes += 1
            assert np.array_equal(native.reset()[0], python.reset()[0])
    return episodes
