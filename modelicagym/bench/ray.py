"""The Ray path next to the local pool: per-step ``VectorEnv`` calls and rollouts of T steps.

For each setting (the default cart-pole and the heavy one, ``cs_step_size=1e-4``) and each T in
``--steps``, interleaved rounds time, in env steps per second:

* ``pool step``: the local pool (`modelicagym.make_vec`), T calls of ``step`` with a policy;
* ``ray step``: `~modelicagym.distributed.RayVectorEnv` (one actor per CPU), T calls of ``step``;
* ``ray rollout``: ``RayVectorEnv.rollout(policy, T)``: one remote call per actor for T steps.

Ray runs on this machine (``ray.init`` with the machine's CPUs, or the cluster at ``--address``)
with its default layout (one actor per CPU), so the figures say what Ray's layer costs, not what
more machines add. Target: the rollout at
T >= 64 reaches >= 0.9x the pool's throughput for the heavy cart-pole.
"""

from __future__ import annotations

import argparse
import logging
import os
import time
from collections.abc import Callable
from typing import Any

import numpy as np

import modelicagym
from modelicagym.bench import format_table, median, write_json
from modelicagym.bench.throughput import SETTINGS

logger = logging.getLogger(__name__)

CANDIDATES = ("pool step", "ray step", "ray rollout")


def push_by_velocity(observations: np.ndarray) -> np.ndarray:
    """A cheap deterministic policy: push the way the pole falls."""
    return (observations[:, 3] > 0).astype(np.int64)


def _stepping(envs: Any, steps: int) -> Callable[[], int]:
    observations, _ = envs.reset(seed=0)

    def run() -> int:
        nonlocal observations
        for _ in range(steps):
            observations = envs.step(push_by_velocity(observations))[0]
        return steps * envs.num_envs

    return run


def _rollouts(envs: Any, steps: int) -> Callable[[], int]:
    envs.reset(seed=0)

    def run() -> int:
        envs.rollout(push_by_velocity, steps)
        return steps * envs.num_envs

    return run


def measure(setting: str, n: int, steps: int, repeats: int, seconds: float, ray_options: dict[str, Any]) -> dict[str, Any]:
    """Env steps per second of each candidate for ``n`` envs and rollouts of ``steps``, medians of
    interleaved rounds of about ``seconds`` each."""
    options = dict(SETTINGS[setting], max_episode_steps=500)
    pool = modelicagym.make_vec("cartpole", n=n, **options)
    remote = modelicagym.make_vec("cartpole", n=n, backend="ray", ray_options=ray_options, **options)
    try:
        runs = {"pool step": _stepping(pool, steps), "ray step": _stepping(remote, steps),
                "ray rollout": _rollouts(remote, steps)}
        calls = {}
        for name, run in runs.items():
            started = time.perf_counter()
            run()
            calls[name] = max(1, int(seconds / max(time.perf_counter() - started, 1e-6)))
        samples: dict[str, list[float]] = {name: [] for name in runs}
        for _ in range(repeats):
            for name, run in runs.items():
                started = time.perf_counter()
                done = sum(run() for _ in range(calls[name]))
                samples[name].append(done / (time.perf_counter() - started))
        num_actors = remote.num_actors
    finally:
        pool.close()
        remote.close()
    rates = {name: median(values) for name, values in samples.items()}
    return {"setting": setting, "n": n, "T": steps, "num_actors": num_actors, "steps_per_second": rates,
            "samples": samples, "rollout_vs_pool": rates["ray rollout"] / rates["pool step"]}


def report(results: list[dict[str, Any]]) -> str:
    """The table of rates and the rollout's ratio to the pool."""
    rows = [(r["setting"], r["n"], r["T"], *(f"{r['steps_per_second'][c]:,.0f}" for c in CANDIDATES),
             f"{r['steps_per_second']['ray step'] / r['steps_per_second']['pool step']:.3f}x",
             f"{r['rollout_vs_pool']:.2f}x") for r in results]
    return "env steps per second:\n" + format_table(
        ("setting", "n", "T", *CANDIDATES, "ray step/pool", "rollout/pool"), rows)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--n", type=int, default=8, help="envs")
    parser.add_argument("--steps", type=int, nargs="+", default=[1, 16, 64, 256], help="T: steps per round trip")
    parser.add_argument("--settings", nargs="+", default=list(SETTINGS), choices=list(SETTINGS))
    parser.add_argument("--repeats", type=int, default=3, help="interleaved rounds (median reported)")
    parser.add_argument("--seconds", type=float, default=0.5, help="seconds per round and candidate")
    parser.add_argument("--address", help="a Ray cluster to use (default: a new Ray on this machine)")
    parser.add_argument("--json", default="bench-results/ray.json", help="where to write the JSON")


def run(args: argparse.Namespace) -> int:
    from modelicagym.distributed import connect

    ray = connect(args.address)
    load_before = os.getloadavg()
    results = []
    for setting in args.settings:
        for steps in args.steps:
            logger.info("measuring %s, T=%d", setting, steps)
            results.append(measure(setting, args.n, steps, args.repeats, args.seconds, {}))
    load_after = os.getloadavg()
    print(report(results))
    print(f"\ncores: {os.cpu_count()}; Ray CPUs: {ray.cluster_resources().get('CPU')}; load average (1 min) before "
          f"{load_before[0]:.2f}, after {load_after[0]:.2f}; medians of {args.repeats} interleaved rounds of "
          f"{args.seconds} s")
    data = {"cores": os.cpu_count(), "load_average": {"before": load_before, "after": load_after}, "results": results}
    print(f"wrote {write_json(args.json, data)}")
    return 0
