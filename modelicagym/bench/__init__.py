"""Benchmarks: scripts that measure, print a table and write JSON — never timed unit tests.

This machine is noisy, so every benchmark measures its candidates side by side in one run,
interleaved over several repeats, and reports medians and ratios between them.
"""

from __future__ import annotations

import json
import logging
import os
import statistics
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from modelicagym.bench.machine import wake_conditions
from modelicagym.cores import count_cores
from modelicagym.disk import atomic_write

logger = logging.getLogger(__name__)


def time_rounds(candidates: dict[str, Callable[[], int]], repeats: int) -> dict[str, list[float]]:
    """Run every candidate ``repeats`` times, interleaved; each call returns how many steps it did.

    Returns seconds per step for every round of every candidate.
    """
    samples: dict[str, list[float]] = {name: [] for name in candidates}
    for _ in range(repeats):
        for name, run in candidates.items():
            started = time.perf_counter()
            steps = run()
            samples[name].append((time.perf_counter() - started) / steps)
    return samples


def paired_ratios(numerator: Callable[[], int], denominator: Callable[[], int], rounds: int) -> list[float]:
    """Time per step of ``numerator`` over that of ``denominator``, run back to back ``rounds`` times.

    Each ratio comes from two runs a few milliseconds apart, which a load spike on a shared machine
    mostly hits together, and the order alternates so that neither always runs first: the median of
    these ratios is steadier than a ratio of medians taken over rounds seconds apart.
    """
    ratios = []
    for k in range(rounds):
        first, second = (numerator, denominator) if k % 2 == 0 else (denominator, numerator)
        times = {}
        for run in (first, second):
            started = time.perf_counter()
            steps = run()
            times[run] = (time.perf_counter() - started) / steps
        ratios.append(times[numerator] / times[denominator])
    return ratios


def median(values: Sequence[float]) -> float:
    return statistics.median(values)


def format_table(header: Sequence[str], rows: Sequence[Sequence[Any]]) -> str:
    """A plain-text table, columns aligned, numbers as given."""
    cells = [list(map(str, header))] + [[str(c) for c in row] for row in rows]
    widths = [max(len(row[i]) for row in cells) for i in range(len(header))]
    lines = ["  ".join(c.rjust(w) if i else c.ljust(w) for i, (c, w) in enumerate(zip(row, widths))) for row in cells]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def write_json(path: str | os.PathLike[str], data: dict[str, Any]) -> Path:
    """Write ``data`` atomically (a temp file renamed into place): never a half-written result; a
    full disk is a `DiskFullError` naming the file."""
    path = Path(path)
    with atomic_write(path, elsewhere="choose another file for it (--json)") as handle:
        json.dump(data, handle, indent=2)
    return path


def add_round_arguments(parser: Any, name: str) -> None:
    """``--n``, ``--repeats``, ``--seconds`` and ``--json`` (default ``bench-results/<name>.json``)
    of a benchmark that runs its candidates for interleaved rounds at several numbers of envs."""
    parser.add_argument("--n", type=int, nargs="+", default=[2, 8, 64], help="numbers of envs")
    parser.add_argument("--repeats", type=int, default=3, help="interleaved rounds (median reported)")
    parser.add_argument("--seconds", type=float, default=0.5, help="seconds per round and candidate")
    parser.add_argument("--json", default=f"bench-results/{name}.json", help="where to write the JSON")


def conditions(load_before: tuple[float, float, float], repeats: int, seconds: float) -> tuple[str, dict[str, Any]]:
    """The line that says under what conditions a benchmark ran, and the same for its JSON."""
    load_after = os.getloadavg()
    wake_line, wake = wake_conditions()
    cores = count_cores()
    line = (f"cores: {cores}; load average (1 min) before {load_before[0]:.2f}, after {load_after[0]:.2f}; "
            f"medians of {repeats} interleaved rounds of {seconds} s\n{wake_line}")
    return line, {"cores": cores.cores, "cores_detail": str(cores), "cpu_count": os.cpu_count(),
                  "load_average": {"before": load_before, "after": load_after}, **wake}


#: what a user runs before and while training, in the order ``bench --help`` lists them
USER_BENCHMARKS = (
    ("fmu", "own_fmu", "your FMU: one env, Sync/AsyncVectorEnv and the pool, side by side"),
    ("step-paths", "step_paths", "one env of your FMU on the native step path, the Python path and our C loop"),
    ("throughput", "throughput", "the cart-pole stepped every way a user can, by number of envs"),
    ("shared", "shared_machine", "the same on a shared machine: a busy process, two trainings, a learner"),
    ("training", "training", "PPO on every vector env, where the time goes; --seeds N: the presets over seeds"),
    ("ray", "ray", "scaling out: Ray actors next to the local pool, per-step calls and rollouts"),
)
#: what measures modelicagym's own parts, under ``bench internals``
INTERNAL_BENCHMARKS = (
    ("fmi-calls", "fmi_calls", "one cart-pole step, layer by layer: doStep, the FMI calls, FMUEnv.step"),
    ("model-exchange", "model_exchange", "each solver (CVode, Euler, RK4) on both step paths against co-simulation"),
    ("autoreset", "autoreset", "the pool in each autoreset mode: same-step against next-step"),
    ("python-reward", "python_reward", "a reward written in Python (per env, on arrays) against the native one"),
    ("partial-batches", "partial_batches", "send/recv (EnvPool's partial batches) against the barrier step"),
    ("balance", "balance", "the layout balanced by cost, for envs whose cost varies with their state"),
    ("pool-gain", "pool_gain", "the default pool against one env, per FMU, with the bar each must meet"),
    ("once-per-process", "once_per_process", "once per process: copies of its binary against one env a worker"),
    ("init-once", "init_once", 'a pool\'s start, each env initializing against init="once"'),
    ("saved-states", "saved_states", "bytes and microseconds per saved and loaded state"),
    ("load-trial", "load_trial", "an FMU binary's first load (tried in a child) against a kept verdict"),
    ("barrier", "barrier", "an empty step's synchronisation, by number of workers"),
    ("runner", "runner", "the paper study's training loop against the bare pool, part by part"),
    ("solver-accuracy", "solver_accuracy", "the cart-pole's internal step: error against cost"),
)


def _add_benchmark(which: Any, name: str, module_name: str, summary: str | None = None) -> None:
    import argparse
    import importlib

    module = importlib.import_module(f"modelicagym.bench.{module_name}")
    doc = (module.__doc__ or "").strip().splitlines()
    sub = which.add_parser(name, help=summary or doc[0], description=doc[0] if doc else None,
                           formatter_class=argparse.RawDescriptionHelpFormatter)
    module.add_arguments(sub)
    sub.set_defaults(benchmark_run=module.run)


def add_arguments(parser: Any) -> None:
    """``modelicagym bench``: the benchmarks a user runs (`USER_BENCHMARKS`), then ``bench internals``,
    the benchmarks of modelicagym's own parts (`INTERNAL_BENCHMARKS`); their arguments."""
    parser.description = ("Measure before you train: each benchmark runs its candidates side by side in "
                          "interleaved rounds, prints a table with the machine's cores and load, and writes JSON "
                          "to bench-results/.")
    which = parser.add_subparsers(dest="benchmark", required=True, metavar="BENCHMARK",
                                  title="benchmarks (modelicagym bench BENCHMARK --help)")
    for name, module_name, summary in USER_BENCHMARKS:
        _add_benchmark(which, name, module_name, summary)
    internals = which.add_parser(
        "internals", help="benchmarks of modelicagym's own parts: FMI calls, solvers, the pool's mechanisms",
        description="Benchmarks of modelicagym's own parts, which its design and its figures rest on.")
    inner = internals.add_subparsers(dest="internal_benchmark", required=True, metavar="BENCHMARK",
                                     title="benchmarks (modelicagym bench internals BENCHMARK --help)")
    for name, module_name, summary in INTERNAL_BENCHMARKS:
        _add_benchmark(inner, name, module_name, summary)


def main(args: Any) -> int:
    return args.benchmark_run(args)
