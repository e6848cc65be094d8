"""Balance by measured cost: a pool of envs whose step cost varies 10-100x with their state.

The envs are the moody test FMU (``tests/fmus/moody``: a lag whose co-simulation step costs
``ratio`` = 100 times more while its state x is above a threshold; ~5 us calm, ~250 us moody on
the target machine), given as a user gives any FMU, so the pool's default isolates them (a worker
stands in for the calling process). Random pushes drive x across the threshold, so an env's cost
changes within episodes. Two settings:

* ``skewed``: the first half of the envs have threshold 0 (moody about half the time), the others
  2 (never moody, x stays in [-1, 1]): the planned layout puts every moody env in the same worker;
* ``even``: every env has threshold 0.5 (moody now and then, each in turn).

Candidates, interleaved rounds of random pushes, medians of env steps per second: ``sync``
(`gymnasium.vector.SyncVectorEnv`: one process, every env in turn), ``fixed`` (the pool with
``adapt_layout=False``: the planned workers, no balance) and ``pool`` (the default: the stand-in's
layout, consolidated or spread, and the spread balanced by the parties' measured costs,
`modelicagym.vector.layout.cost_model`). The pool's final layout is reported. Target:
``pool`` faster than ``fixed`` on ``skewed``.
"""

from __future__ import annotations

import argparse
import functools
import logging
import os
from pathlib import Path
from typing import Any

import gymnasium as gym

import modelicagym
from modelicagym.bench import conditions, format_table, median, write_json
from modelicagym.bench.throughput import interleaved_rates, vector_loop
from modelicagym.errors import ConfigError
from modelicagym.vector import PoolVectorEnv

logger = logging.getLogger(__name__)

#: the moody FMU's sources in a checkout of the repository
MOODY_SOURCES = Path(__file__).resolve().parents[1] / "tests" / "fmus" / "moody"
SETTINGS = ("skewed", "even")
CANDIDATES = ("sync", "fixed", "pool")
EPISODE_STEPS = 200


def moody_fmu(path: str | None) -> Path:
    """The moody FMU: ``path``, or built from the checkout's sources (cached)."""
    if path is not None:
        return Path(path)
    if not MOODY_SOURCES.is_dir():
        raise ConfigError(f"no moody FMU: pass --fmu, or run from a checkout with {MOODY_SOURCES}")
    from modelicagym.fmu.build import build_source_fmu

    return build_source_fmu(MOODY_SOURCES, 2)


def thresholds(setting: str, n: int) -> list[float]:
    """Per env, the state above which its steps cost 100x more."""
    if setting == "even":
        return [0.5] * n
    return [0.0 if k < n // 2 else 2.0 for k in range(n)]


def env_fns(fmu: Path, setting: str, n: int) -> list[functools.partial]:
    configs = [{"fmu": str(fmu), "inputs": ["u"], "outputs": ["x", "effort"], "time_step": 0.05,
                "action_table": [[-1.0], [1.0]], "parameters": {"threshold": threshold},
                "max_episode_steps": EPISODE_STEPS} for threshold in thresholds(setting, n)]
    return [functools.partial(modelicagym.FMUEnv, config) for config in configs]


def measure_group(fmu: Path, setting: str, n: int, repeats: int, seconds: float) -> dict[str, Any]:
    """Env steps per second of every candidate (medians of interleaved rounds) and the pool's layout."""
    fns = env_fns(fmu, setting, n)
    made: dict[str, gym.vector.VectorEnv] = {}
    try:
        made["sync"] = gym.vector.SyncVectorEnv(fns)
        made["fixed"] = PoolVectorEnv(fns, adapt_layout=False)
        made["pool"] = PoolVectorEnv(fns)
        runs = {name: vector_loop(envs, n, seed=n) for name, envs in made.items()}
        samples, _ = interleaved_rates(runs, repeats, seconds)
        layout = made["pool"].layout
    finally:
        for envs in made.values():
            envs.close()
    rates = {name: median(values) for name, values in samples.items()}
    return {"setting": setting, "n": n, "steps_per_second": rates, "samples": samples,
            "ratios": {"pool/fixed": rates["pool"] / rates["fixed"], "pool/sync": rates["pool"] / rates["sync"],
                       "fixed/sync": rates["fixed"] / rates["sync"]},
            "pool_layout": str(layout), "envs_in_stand_in": layout.envs_in_stand_in, "switches": layout.switches}


def report(results: list[dict[str, Any]]) -> str:
    table = format_table(
        ("setting", "n", *CANDIDATES, "pool/fixed", "pool/sync", "fixed/sync", "stand-in envs", "switches"),
        [(r["setting"], r["n"], *(f"{r['steps_per_second'][c]:,.0f}" for c in CANDIDATES),
          *(f"{r['ratios'][k]:.2f}x" for k in ("pool/fixed", "pool/sync", "fixed/sync")),
          f"{r['envs_in_stand_in']}/{r['n']}", r["switches"]) for r in results],
    )
    layouts = "\n".join(f"{r['setting']} n={r['n']}: {r['pool_layout']}" for r in results)
    return f"env steps per second (moody FMU):\n{table}\n\nthe pool's layout at the end:\n{layouts}"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--fmu", help="the moody FMU (default: built from tests/fmus/moody)")
    parser.add_argument("--settings", nargs="+", default=list(SETTINGS), choices=SETTINGS)
    parser.add_argument("--n", type=int, nargs="+", default=[8], help="numbers of envs")
    parser.add_argument("--repeats", type=int, default=5, help="interleaved rounds (median reported)")
    parser.add_argument("--seconds", type=float, default=2.0, help="seconds per round and candidate")
    parser.add_argument("--json", default="bench-results/balance.json", help="where to write the JSON")


def run(args: argparse.Namespace) -> int:
    fmu = moody_fmu(args.fmu)
    load_before = os.getloadavg()
    results = []
    for setting in args.settings:
        for n in args.n:
            logger.info("measuring %s, n=%d", setting, n)
            results.append(measure_group(fmu, setting, n, args.repeats, args.seconds))
    line, data = conditions(load_before, args.repeats, args.seconds)
    print(report(results))
    print(f"\n{line}")
    print(f"wrote {write_json(args.json, {**data, 'results': results})}")
    return 0
