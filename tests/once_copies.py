"""Runs of FMUs allowed one instance per process (``probe_once``, ``moody_once``), here or in a
fresh process, and the folders of private library copies a process keeps (tests of
`modelicagym.fmu.library_copies`). Run as a script, it makes one env of the JSON config on stdin,
runs the actions given and prints the trajectory: what a process holding one instance gives."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
from fmu_family import build

from modelicagym.fmu.library_copies import copies_root

REPO = Path(__file__).resolve().parents[1]

#: per family member: an FMUEnv config (without the FMU) whose action is one float
CONFIGS: dict[str, dict[str, Any]] = {
    "probe_once": {"inputs": ["force"], "outputs": ["position", "steps"], "time_step": 0.1},
    "moody_once": {"inputs": ["u"], "outputs": ["x", "effort"], "parameters": {"threshold": 1e9}},
}


def config(name: str, fmi_version: int, **settings: Any) -> dict[str, Any]:
    """The FMUEnv config of ``name`` for FMI ``fmi_version``, updated by ``settings``."""
    return {"fmu": str(build(name, fmi_version)), **CONFIGS[name], **settings}


def actions(seed: int, steps: int) -> list[float]:
    """Random actions in [-1, 1]."""
    return np.random.default_rng(seed).uniform(-1.0, 1.0, steps).tolist()


def observed(observation: Any) -> list[str]:
    """Every value of an observation (a dict or an array), exactly (floats as hex)."""
    values = observation.values() if isinstance(observation, dict) else [observation]
    return [float(v).hex() for value in values for v in np.ravel(value)]


def trajectory(env: Any, steps: list[float]) -> list[list[str]]:
    """``env`` reset, then stepped with ``steps``: every observation, exactly."""
    observations = [observed(env.reset(seed=0)[0])]
    for action in steps:
        observations.append(observed(env.step(np.array([action]))[0]))
    return observations


def trajectory_in_a_process(env_config: dict[str, Any], steps: list[float]) -> list[list[str]]:
    """`trajectory` of one env of ``env_config``, alone in a fresh Python process."""
    environment = {**os.environ, "PYTHONPATH": str(REPO)}
    done = subprocess.run([sys.executable, __file__], input=json.dumps([env_config, steps]), text=True,
                          capture_output=True, check=True, timeout=300, env=environment)
    return json.loads(done.stdout)


def copy_folders(pid: int) -> list[Path]:
    """The folders of library copies process ``pid`` keeps (one per process; none if it made no copy)."""
    root = copies_root()
    return sorted(root.glob(f"{pid}-*")) if root.is_dir() else []


def copies_in(folder: Path) -> list[str]:
    """The copies in a process's folder (one sub-folder each)."""
    return sorted(p.name for p in folder.iterdir() if p.is_dir())


if __name__ == "__main__":
    from modelicagym.env import FMUEnv

    given, given_steps = json.loads(sys.stdin.read())
    print(json.dumps(trajectory(FMUEnv(given), given_steps)))
