"""How fine the cart-pole FMU's internal RK4 step must be: error against a tight reference, and cost.

The co-simulation FMU integrates with a fixed RK4 step ``cs_step_size`` inside every ``doStep``.
This study drives the real FMU (FMI 2.0 co-simulation, bounds switched off) with a fixed, seeded
push pattern of the paper's force (+-15 N every 50 ms) over a 2 s horizon (an episode of the
paper's runs lasts 0.5-2 s) and a 10 s one, for a range of internal steps, and reports per step

* the largest absolute error of each state (x, x_dot, theta, theta_dot) against
  ``cs_step_size=1e-5`` over the horizon, at the env steps,
* the cost of one 50 ms env step (medians of interleaved rounds).

``docs/cartpole-solver.md`` records the table and the choice of the default it led to.
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np

from modelicagym.bench import format_table, median, write_json

REFERENCE_STEP = 1e-5
STEPS = (1e-4, 1e-3, 2.5e-3, 5e-3, 1e-2, 2.5e-2, 5e-2)
HORIZONS = (2.0, 10.0)
TIME_STEP = 0.05
STATES = ("x", "x_dot", "theta", "theta_dot")


def _env(cs_step_size: float) -> Any:
    from modelicagym.models.cartpole.env import CartPoleEnv

    return CartPoleEnv(cs_step_size=cs_step_size, x_threshold=1e9, theta_threshold=1e9)


def trajectory(cs_step_size: float, actions: np.ndarray) -> np.ndarray:
    """The states after each env step of ``actions`` (rows), from the default initial state."""
    env = _env(cs_step_size)
    env.reset(seed=0)
    states = np.array([env.step(int(a))[0] for a in actions])
    env.close()
    return states


def step_cost(cs_step_size: float, repeats: int, steps: int) -> float:
    """Median seconds per env step over ``repeats`` rounds (episodes restart every 2 s)."""
    env = _env(cs_step_size)
    env.reset(seed=0)
    per_episode = int(HORIZONS[0] / TIME_STEP)
    samples = []
    for _ in range(repeats):
        started = time.perf_counter()
        for k in range(steps):
            env.step(k & 1)
            if (k + 1) % per_episode == 0:
                env.reset()
        samples.append((time.perf_counter() - started) / steps)
    env.close()
    return median(samples)


def measure(repeats: int = 5, seed: int = 0) -> dict[str, Any]:
    actions = np.random.default_rng(seed).integers(0, 2, size=int(max(HORIZONS) / TIME_STEP))
    reference = trajectory(REFERENCE_STEP, actions)
    rows = []
    costs = {h: [] for h in STEPS}
    for _ in range(repeats):  # interleaved: every step size once per round
        for h in STEPS:
            costs[h].append(step_cost(h, 1, 2000))
    for h in STEPS:
        states = trajectory(h, actions)
        errors = {}
        for horizon in HORIZONS:
            k = int(round(horizon / TIME_STEP))
            worst = np.max(np.abs(states[:k] - reference[:k]), axis=0)
            errors[str(horizon)] = dict(zip(STATES, map(float, worst)))
        rows.append({"cs_step_size": h, "substeps_per_env_step": TIME_STEP / h, "max_abs_error": errors,
                     "seconds_per_env_step": median(costs[h])})
    return {"reference_step": REFERENCE_STEP, "time_step": TIME_STEP, "seed": seed, "rows": rows}


def report(result: dict[str, Any]) -> str:
    header = ["cs_step_size", "substeps", *(f"max err {h:g} s" for h in HORIZONS), "us / env step"]
    rows = [
        (f"{r['cs_step_size']:g}", f"{r['substeps_per_env_step']:g}",
         *(f"{max(r['max_abs_error'][str(h)].values()):.1e}" for h in HORIZONS),
         f"{1e6 * r['seconds_per_env_step']:.1f}")
        for r in result["rows"]
    ]
    return (f"{format_table(header, rows)}\n(largest error over the four states against cs_step_size="
            f"{result['reference_step']:g}; cost through FMUEnv.step, medians of interleaved rounds)")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--repeats", type=int, default=5, help="interleaved rounds for the cost (median reported)")
    parser.add_argument("--json", default="bench-results/solver_accuracy.json", help="where to write the JSON")


def run(args: argparse.Namespace) -> int:
    result = measure(args.repeats)
    print(report(result))
    print(f"wrote {write_json(args.json, result)}")
    return 0


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_arguments(parser)
    raise SystemExit(run(parser.parse_args()))
