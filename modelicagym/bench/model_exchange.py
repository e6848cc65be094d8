"""Model exchange against co-simulation: one Cart-Pole env, random pushes, each solver on both paths.

Measured side by side in one run (interleaved rounds, medians), ``FMUEnv.step`` steps per second:

* ``co-simulation``: the FMU's internal RK4, on the native step path (the yardstick);
* model exchange with ``cvode`` (Adams until the model proves stiff, then BDF) at the default
  tolerance (1e-10) and at 1e-6, ``cvode-bdf`` (BDF throughout, as fmpy) at the default tolerance,
  and forward Euler at ``solver_step=1e-3``: each on the native path (the solver loop in C,
  `modelicagym.native.integrator`) and on the Python path (``step_path="python"``).

Target (issue 15): model exchange with CVode at the default tolerance on the native path reaches
at least 0.5x the co-simulation rate. (That the answers agree is tested: tests/test_native_integrator.py.)
"""

from __future__ import annotations

import argparse
import logging
from typing import Any

import numpy as np

from modelicagym.bench import format_table, median, time_rounds, write_json

logger = logging.getLogger(__name__)

#: row name -> FMUEnv options (model exchange rows also run with step_path="python")
SOLVERS: dict[str, dict[str, Any]] = {
    "cvode": {"mode": "me"},
    "cvode, tolerance 1e-6": {"mode": "me", "tolerance": 1e-6},
    "cvode-bdf": {"mode": "me", "solver": "cvode-bdf"},
    "euler, step 1e-3": {"mode": "me", "solver": "euler", "solver_step": 1e-3},
}
CO_SIMULATION = "co-simulation"


def _loop(env: Any, actions: np.ndarray) -> Any:
    """Step ``env`` through ``actions``, resetting when an episode ends."""
    env.reset(seed=0)
    step, reset = env.step, env.reset

    def run() -> int:
        for action in actions.tolist():
            _, _, terminated, truncated, _ = step(action)
            if terminated or truncated:
                reset()
        return len(actions)

    return run


def measure(steps: int = 20_000, python_steps: int = 2_000, repeats: int = 5, fmi_version: int = 2) -> dict[str, Any]:
    """Seconds per ``FMUEnv.step`` of each row (the Python path's rows take ``python_steps`` a round)."""
    import modelicagym

    rng = np.random.default_rng(0)
    actions, python_actions = rng.integers(0, 2, size=steps), rng.integers(0, 2, size=python_steps)
    envs = {CO_SIMULATION: modelicagym.make("cartpole", fmi_version=fmi_version)}
    for name, options in SOLVERS.items():
        envs[f"{name} (native)"] = modelicagym.make("cartpole", fmi_version=fmi_version, **options)
        envs[f"{name} (python)"] = modelicagym.make("cartpole", fmi_version=fmi_version, step_path="python", **options)
    candidates = {name: _loop(env, python_actions if name.endswith("(python)") else actions) for name, env in envs.items()}
    samples = time_rounds(candidates, repeats)
    paths = {name: env.unwrapped.step_path for name, env in envs.items()}
    for env in envs.values():
        env.close()
    per_step = {name: median(values) for name, values in samples.items()}
    cs = per_step[CO_SIMULATION]
    return {
        "fmi_version": fmi_version,
        "steps": steps,
        "python_steps": python_steps,
        "repeats": repeats,
        "step_paths": paths,
        "seconds_per_step": per_step,
        "rate_vs_co_simulation": {name: cs / s for name, s in per_step.items()},
        "native_vs_python": {name: per_step[f"{name} (python)"] / per_step[f"{name} (native)"] for name in SOLVERS},
    }


def report(result: dict[str, Any]) -> str:
    per_step, vs_cs = result["seconds_per_step"], result["rate_vs_co_simulation"]
    rows = [(name, f"{1e6 * s:.1f}", f"{1 / s:,.0f}", f"{vs_cs[name]:.2f}") for name, s in per_step.items()]
    table = format_table(("FMUEnv.step", "us/step", "steps/s", "rate vs co-simulation"), rows)
    speedups = ", ".join(f"{name} {ratio:.0f}x" for name, ratio in result["native_vs_python"].items())
    return (
        f"{table}\n\n"
        f"native path / Python path: {speedups}\n"
        f"model exchange (cvode, default tolerance) / co-simulation: {vs_cs['cvode (native)']:.2f} (target >= 0.5)"
    )


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--steps", type=int, default=20_000, help="steps per round on the native path")
    parser.add_argument("--python-steps", type=int, default=2_000, help="steps per round on the Python path")
    parser.add_argument("--repeats", type=int, default=5, help="interleaved rounds (median reported)")
    parser.add_argument("--fmi-version", type=int, default=2, choices=(2, 3))
    parser.add_argument("--json", default="bench-results/model_exchange.json", help="where to write the JSON")


def run(args: argparse.Namespace) -> int:
    result = measure(args.steps, args.python_steps, args.repeats, args.fmi_version)
    print(report(result))
    print(f"\nwrote {write_json(args.json, result)}")
    return 0
