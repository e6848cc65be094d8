"""Envs on the native and the Python step path, for tests that compare the two."""

from __future__ import annotations

from functools import partial
from typing import Any

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
