"""Partial batches against the barrier step, with envs of unequal cost.

A pool of ``n`` cart-poles in two workers, where the second worker's envs integrate a hundred times
finer (``cs_step_size=5e-5`` instead of ``5e-3``: about fifty times the cost per step), is stepped
two ways, through the public API only, with random actions:

* ``step``: ``pool.step(actions)``, every env every time: each batch waits for the slowest env;
* ``send/recv``: ``make_vec(..., batch_size=n // 2)``, EnvPool's loop (``recv`` the first
  ``n // 2`` envs done, ``send`` them their next actions): cheap envs never wait for costly ones.

Both are timed interleaved over several rounds; the table gives medians of env steps per second
and their ratio. Under the barrier the light worker idles while the heavy one steps; with partial
batches it keeps stepping its envs (which are then stepped more often than the heavy ones, as in
EnvPool: each env's own trajectory is unchanged).
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
from modelicagym.vector import PoolVectorEnv

logger = logging.getLogger(__name__)

#: the internal step of the light and of the heavy envs (seconds)
LIGHT, HEAVY = 5e-3, 5e-5


def unequal_options(n: int) -> list[dict[str, Any]]:
    """Per env: the first half light, the second heavy (one worker each with two workers)."""
    return [{"cs_step_size": HEAVY if i >= n // 2 else LIGHT, "max_episode_steps": 200} for i in range(n)]


def barrier_run(pool: PoolVectorEnv) -> Callable[[int], int]:
    """Steps of every env at once; returns env steps done."""
    rng = np.random.default_rng(0)

    def run(batches: int) -> int:
        for _ in range(batches):
            pool.step(rng.integers(0, 2, pool.num_envs))
        return batches * pool.num_envs

    return run


def partial_run(pool: PoolVectorEnv) -> Callable[[int], int]:
    """EnvPool's loop: receive ``batch_size`` envs, send them their next actions."""
    rng = np.random.default_rng(0)

    def run(batches: int) -> int:
        for _ in range(batches):
            *_, infos = pool.recv()
            ids = infos["env_id"]
            pool.send(rng.integers(0, 2, len(ids)), ids)
        return batches * pool.batch_size

    return run


def measure(n: int, num_workers: int, repeats: int, seconds: float) -> dict[str, Any]:
    """Env steps per second of both ways, medians of ``repeats`` interleaved rounds."""
    options = {"options_per_env": unequal_options(n), "num_workers": num_workers}
    barrier = modelicagym.make_vec("cartpole", n=n, **options)
    partial = modelicagym.make_vec("cartpole", n=n, batch_size=n // 2, **options)
    try:
        barrier.reset(seed=0)
        partial.async_reset(seed=0)
        runs = {"step": barrier_run(barrier), "send/recv": partial_run(partial)}
        sizes = {name: _calibrate(run, seconds) for name, run in runs.items()}
        rates: dict[str, list[float]] = {name: [] for name in runs}
        for _ in range(repeats):
            for name, run in runs.items():
                started = time.perf_counter()
                steps = run(sizes[name])
                rates[name].append(steps / (time.perf_counter() - started))
    finally:
        barrier.close()
        partial.close()
    medians = {name: median(values) for name, values in rates.items()}
    return {"n": n, "num_workers": num_workers, "batch_size": n // 2, "steps_per_second": medians,
            "rounds": rates, "ratio": medians["send/recv"] / medians["step"]}


def _calibrate(run: Callable[[int], int], seconds: float) -> int:
    """How many batches take about ``seconds``."""
    batches, elapsed = 16, 0.0
    while elapsed < seconds / 4:
        batches *= 4
        started = time.perf_counter()
        run(batches)
        elapsed = time.perf_counter() - started
    return max(1, int(batches * seconds / elapsed))


def report(results: list[dict[str, Any]]) -> str:
    rows = [
        [r["n"], r["num_workers"], r["batch_size"], f"{r['steps_per_second']['step']:,.0f}",
         f"{r['steps_per_second']['send/recv']:,.0f}", f"{r['ratio']:.2f}x"]
        for r in results
    ]
    return format_table(["n", "workers", "batch_size", "step [env steps/s]", "send/recv [env steps/s]",
                         "send/recv / step"], rows)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--n", type=int, nargs="+", default=[8, 16], help="numbers of envs")
    parser.add_argument("--workers", type=int, default=2, help="worker processes")
    parser.add_argument("--repeats", type=int, default=3, help="interleaved rounds (median reported)")
    parser.add_argument("--seconds", type=float, default=0.5, help="seconds per round and candidate")
    parser.add_argument("--json", default="bench-results/partial-batches.json", help="where to write the JSON")


def run(args: argparse.Namespace) -> int:
    load_before = os.getloadavg()
    results = []
    for n in args.n:
        logger.info("measuring n=%d", n)
        results.append(measure(n, args.workers, args.repeats, args.seconds))
    print(report(results))
    print(f"\ncores: {os.cpu_count()}; load average (1 min) before {load_before[0]:.2f}, after "
          f"{os.getloadavg()[0]:.2f}; medians of {args.repeats} interleaved rounds of {args.seconds} s; "
          f"light envs cs_step_size={LIGHT}, heavy {HEAVY}")
    data = {"cores": os.cpu_count(), "load_average_before": load_before, "results": results}
    print(f"wrote {write_json(args.json, data)}")
    return 0
