"""Model exchange against co-simulation: one Cart-Pole env, random pushes, each solver on both paths.

Measured side by side in one run (interleaved rounds, medians), ``FMUEnv.step`` steps per second:

* ``co-simulation``: the FMU's internal RK4, on the native step path (the yardstick);
* model exchange with ``cvode`` (Adams until the model proves stiff, then BDF) at the default
  tolerance (1e-10) and at 1e-6, ``cvode-bdf`` (BDF throughout, as fmpy) at the default tolerance,
  forward Euler at ``solver_step=1e-3``, and ``rk4`` (classical Runge-Kutta) at the co-simulation
  FMU's own internal step, 5e-3, where it gives co-simulation's numbers: each on the native path
  (the solver loop in C, `modelicagym.fmu.native_integrator`) and on the Python path
  (``step_path="python"``).

Target: model exchange with CVode at the default tolerance on the native path reaches
at least 0.5x the co-simulation rate. That ratio is measured on its own, as the median over many
back-to-back pairs of short runs (`modelicagym.bench.paired_ratios`): the table's rounds run
seconds apart, and load on a shared machine moves its ratio by +-0.1 from run to run. (That the
answers agree is tested: tests/fmu/test_native_integrator.py.)
"""

from __future__ import annotations

import argparse
import logging
from typing import Any

import numpy as np

from modelicagym.bench import format_table, median, paired_ratios, time_rounds, write_json

logger = logging.getLogger(__name__)

#: row name -> FMUEnv options (model exchange rows also run with step_path="python")
SOLVERS: dict[str, dict[str, Any]] = {
    "cvode": {"mode": "me"},
    "cvode, tolerance 1e-6": {"mode": "me", "tolerance": 1e-6},
    "cvode-bdf": {"mode": "me", "solver": "cvode-bdf"},
    "euler, step 1e-3": {"mode": "me", "solver": "euler", "solver_step": 1e-3},
    "rk4, step 5e-3": {"mode": "me", "solver": "rk4", "solver_step": 5e-3},
}
CO_SIMULATION = "co-simulation"
#: the row the target is about
TARGET_ROW = "cvode (native)"


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


def measure(steps: int = 20_000, python_steps: int = 2_000, repeats: int = 5, fmi_version: int = 2,
            target_steps: int = 4_000, target_rounds: int = 41) -> dict[str, Any]:
    """Seconds per ``FMUEnv.step`` of each row (the Python path's rows take ``python_steps`` a round),
    and the target's ratio from ``target_rounds`` back-to-back pairs of ``target_steps`` steps."""
    import modelicagym

    rng = np.random.default_rng(0)
    actions, python_actions = rng.integers(0, 2, size=steps), rng.integers(0, 2, size=python_steps)
    envs = {CO_SIMULATION: modelicagym.make("cartpole", fmi_version=fmi_version)}
    for name, options in SOLVERS.items():
        envs[f"{name} (native)"] = modelicagym.make("cartpole", fmi_version=fmi_version, **options)
        envs[f"{name} (python)"] = modelicagym.make("cartpole", fmi_version=fmi_version, step_path="python", **options)
    candidates = {name: _loop(env, python_actions if name.endswith("(python)") else actions) for name, env in envs.items()}
    samples = time_rounds(candidates, repeats)
    pairs = paired_ratios(_loop(envs[CO_SIMULATION], actions[:target_steps]),
                          _loop(envs[TARGET_ROW], actions[:target_steps]), target_rounds)
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
        "target": {
            "row": TARGET_ROW,
            "steps": target_steps,
            "rounds": target_rounds,
            "rate_vs_co_simulation": median(pairs),
            "quartiles": [float(q) for q in np.percentile(pairs, [25, 75])],
        },
    }


def report(result: dict[str, Any]) -> str:
    per_step, vs_cs, target = result["seconds_per_step"], result["rate_vs_co_simulation"], result["target"]
    q1, q3 = target["quartiles"]
    rows = [(name, f"{1e6 * s:.1f}", f"{1 / s:,.0f}", f"{vs_cs[name]:.2f}") for name, s in per_step.items()]
    table = format_table(("FMUEnv.step", "us/step", "steps/s", "rate vs co-simulation"), rows)
    speedups = ", ".join(f"{name} {ratio:.0f}x" for name, ratio in result["native_vs_python"].items())
    return (
        f"{table}\n\n"
        f"native path / Python path: {speedups}\n"
        f"model exchange (cvode, default tolerance) / co-simulation, median of {target['rounds']} back-to-back "
        f"pairs: {target['rate_vs_co_simulation']:.2f} (quartiles {q1:.2f}-{q3:.2f}; target >= 0.5)"
    )


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--steps", type=int, default=20_000, help="steps per round on the native path")
    parser.add_argument("--python-steps", type=int, default=2_000, help="steps per round on the Python path")
    parser.add_argument("--repeats", type=int, default=5, help="interleaved rounds (median reported)")
    parser.add_argument("--target-steps", type=int, default=4_000, help="steps per run of the target's pairs")
    parser.add_argument("--target-rounds", type=int, default=41, help="back-to-back pairs for the target's ratio")
    parser.add_argument("--fmi-version", type=int, default=2, choices=(2, 3))
    parser.add_argument("--json", default="bench-results/model_exchange.json", help="where to write the JSON")


def run(args: argparse.Namespace) -> int:
    result = measure(args.steps, args.python_steps, args.repeats, args.fmi_version, args.target_steps, args.target_rounds)
    print(report(result))
    print(f"\nwrote {write_json(args.json, result)}")
    return 0
