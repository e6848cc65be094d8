"""Throughput of the Cart-Pole FMU env under four ways of stepping many envs, side by side.

For each setting (the default co-simulation FMU, and an expensive one whose internal step makes a
``doStep`` cost >= 200 us) and each number of envs n, one run creates

* ``single``: one env stepped in a plain loop (env steps per second of one process),
* ``sync``: ``gymnasium.vector.SyncVectorEnv``,
* ``async``: ``gymnasium.vector.AsyncVectorEnv(shared_memory=True)``,
* ``pool``: modelicagym's ``PoolVectorEnv``,

then times them interleaved over several rounds and reports medians of env steps per second,
the ratios to ``async`` and to ``single``, and the pool's breakdown of a batch step (inside the
FMU, the env's Python code, the pool's own synchronisation and copying).

Targets (DESIGN.md): pool >= 6x async at n=2 and >= 8x at n=8; pool >= 1.5x sync at n=8; with the
expensive step, pool >= 1.8x single on 2 cores.
"""

from __future__ import annotations

import argparse
import logging
import os
import time
from dataclasses import asdict
from typing import Any

import gymnasium as gym
import numpy as np

from modelicagym.bench import format_table, median, write_json
from modelicagym.registry import EnvFactory

logger = logging.getLogger(__name__)

SETTINGS = {
    "default": {},
    "expensive": {"cs_step_size": 3e-5},
}
CANDIDATES = ("single", "sync", "async", "pool")


def _factory(options: dict[str, Any]) -> EnvFactory:
    return EnvFactory("modelicagym.envs.cartpole:CartPoleEnv", dict(options, max_episode_steps=500))


def _make(candidate: str, n: int, options: dict[str, Any]) -> Any:
    from modelicagym.vector import PoolVectorEnv

    fns = [_factory(options) for _ in range(n)]
    if candidate == "single":
        return fns[0]()
    if candidate == "sync":
        return gym.vector.SyncVectorEnv(fns)
    if candidate == "async":
        return gym.vector.AsyncVectorEnv(fns, shared_memory=True)
    return PoolVectorEnv(fns)


def _stepper(candidate: str, env: Any, n: int, seed: int) -> Any:
    """A function ``(batches) -> env steps done`` that steps ``env`` with random actions."""
    rng = np.random.default_rng(seed)
    if candidate == "single":
        env.reset(seed=seed)

        def run_single(batches: int) -> int:
            steps = batches * n
            for action in rng.integers(0, 2, size=steps).tolist():
                _, _, terminated, truncated, _ = env.step(action)
                if terminated or truncated:
                    env.reset()
            return steps

        return run_single
    env.reset(seed=seed)

    def run_vector(batches: int) -> int:
        for actions in rng.integers(0, 2, size=(batches, n)):
            env.step(actions)
        return batches * n

    return run_vector


def _calibrate(run: Any, seconds: float) -> int:
    """How many batches take about ``seconds``."""
    batches, elapsed = 1, 0.0
    while elapsed < seconds / 4:
        batches *= 4
        started = time.perf_counter()
        run(batches)
        elapsed = time.perf_counter() - started
    return max(1, int(batches * seconds / elapsed))


def measure_setting(setting: str, n: int, repeats: int, seconds: float) -> dict[str, Any]:
    """Env steps per second of every candidate for ``n`` envs (medians of interleaved rounds)."""
    options = SETTINGS[setting]
    envs = {c: _make(c, n, options) for c in CANDIDATES}
    try:
        runs = {c: _stepper(c, env, n, seed=k) for k, (c, env) in enumerate(envs.items())}
        batches = {c: _calibrate(run, seconds) for c, run in runs.items()}
        rates: dict[str, list[float]] = {c: [] for c in CANDIDATES}
        for _ in range(repeats):
            for c, run in runs.items():
                started = time.perf_counter()
                steps = run(batches[c])
                rates[c].append(steps / (time.perf_counter() - started))
        pool = envs["pool"]
        pool.set_timing(True)
        runs["pool"](batches["pool"])
        breakdown = asdict(pool.timing())
    finally:
        for env in envs.values():
            env.close()
    medians = {c: median(r) for c, r in rates.items()}
    return {
        "setting": setting,
        "n": n,
        "steps_per_second": medians,
        "samples": rates,
        "pool_vs_async": medians["pool"] / medians["async"],
        "pool_vs_sync": medians["pool"] / medians["sync"],
        "pool_vs_single": medians["pool"] / medians["single"],
        "pool_breakdown": breakdown,
    }


def _doStep_cost(options: dict[str, Any]) -> float:
    env = _factory(options)()
    env.reset(seed=0)
    started, steps = time.perf_counter(), 0
    while time.perf_counter() - started < 0.3:
        if any(env.step(steps % 2)[2:4]):
            env.reset()
        steps += 1
    cost = (time.perf_counter() - started) / steps
    env.close()
    return cost


def report(results: list[dict[str, Any]]) -> str:
    rows = []
    for r in results:
        rate = r["steps_per_second"]
        rows.append((r["setting"], r["n"], *(f"{rate[c]:,.0f}" for c in CANDIDATES),
                     f"{r['pool_vs_async']:.1f}x", f"{r['pool_vs_sync']:.2f}x", f"{r['pool_vs_single']:.2f}x"))
    table = format_table(("setting", "n", *(f"{c} steps/s" for c in CANDIDATES), "pool/async", "pool/sync",
                          "pool/single"), rows)
    breakdown = format_table(
        ("setting", "n", "batch wall us", "in FMU us", "env Python us", "pool overhead us"),
        [(r["setting"], r["n"], *(f"{1e6 * r['pool_breakdown'][k]:.1f}" for k in
                                   ("wall_s", "fmu_s", "env_python_s", "pool_overhead_s"))) for r in results],
    )
    return f"{table}\n\npool step breakdown (critical worker, per batch):\n{breakdown}"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--n", type=int, nargs="+", default=[2, 8, 32], help="numbers of envs")
    parser.add_argument("--settings", nargs="+", default=list(SETTINGS), choices=list(SETTINGS))
    parser.add_argument("--repeats", type=int, default=3, help="interleaved rounds (median reported)")
    parser.add_argument("--seconds", type=float, default=0.5, help="seconds per round and candidate")
    parser.add_argument("--json", default="bench-results/throughput.json", help="where to write the JSON")


def run(args: argparse.Namespace) -> int:
    results = []
    load_before = os.getloadavg()
    step_costs = {s: _doStep_cost(SETTINGS[s]) for s in args.settings}
    for setting in args.settings:
        for n in args.n:
            logger.info("measuring %s, n=%d", setting, n)
            results.append(measure_setting(setting, n, args.repeats, args.seconds))
    print(report(results))
    costs = ", ".join(f"{s}: {1e6 * c:.1f} us" for s, c in step_costs.items())
    load = {"before": load_before, "after": os.getloadavg()}
    print(f"\nsingle-env step cost: {costs}; cores: {os.cpu_count()}; load average (1, 5, 15 min) "
          f"before {load_before[0]:.2f} {load_before[1]:.2f} {load_before[2]:.2f}, after "
          f"{load['after'][0]:.2f} {load['after'][1]:.2f} {load['after'][2]:.2f}")
    data = {"cores": os.cpu_count(), "load_average": load, "single_env_step_seconds": step_costs, "results": results}
    print(f"wrote {write_json(args.json, data)}")
    return 0
