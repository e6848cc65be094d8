"""Runs of an env after its state was saved, here or in a fresh process (tests of env states)."""

from __future__ import annotations

import os
import pickle
import subprocess
import sys
from pathlib import Path
from typing import Any, Callable

_CHILD = """
import pickle, sys
from state_runs import run
factory, state, actions = pickle.load(open(sys.argv[1], "rb"))
env = factory()
env.unwrapped.set_state(state)
pickle.dump(run(env, actions), open(sys.argv[2], "wb"))
"""


def run(env: Any, actions: list[Any]) -> list[tuple]:
    """Step ``env`` with ``actions`` (resetting after an episode ends): each step's results, time and steps."""
    results = []
    for action in actions:
        observation, reward, terminated, truncated, info = env.step(action)
        results.append((pickle.dumps(observation), reward, terminated, truncated, sorted(info),
                        env.unwrapped.time, env.unwrapped.elapsed_steps))
        if terminated or truncated:
            results.append((pickle.dumps(env.reset()[0]), env.unwrapped.time))
    return results


def run_in_another_process(folder: Path, factory: Callable[[], Any], state: Any, actions: list[Any]) -> list[tuple]:
    """`run` in a fresh Python process, on an env made by ``factory`` that loads ``state`` first."""
    given, taken = folder / "given.pkl", folder / "taken.pkl"
    given.write_bytes(pickle.dumps((factory, state, actions)))
    environment = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in sys.path if p)}
    subprocess.run([sys.executable, "-c", _CHILD, str(given), str(taken)], check=True, timeout=300, env=environment)
    return pickle.loads(taken.read_bytes())
