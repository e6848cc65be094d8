"""Benchmarks: scripts that measure, print a table and write JSON — never timed unit tests.

This machine is noisy, so every benchmark measures its candidates side by side in one run,
interleaved over several repeats, and reports medians and ratios between them.

The modules here are what a user runs (``modelicagym bench NAME``: `modelicagym.cli.BENCHMARKS`),
and this package holds the helpers they share. The benchmarks of modelicagym's own parts, which only
matter to whoever changes them, live in a clone's ``benchmarks/`` (``python -m benchmarks --help``)
and use these helpers too.
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
