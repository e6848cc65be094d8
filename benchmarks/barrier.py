"""An empty batch's cost: waking the workers of a step and learning that all are done, by worker count.

Each round forks ``workers`` processes that do nothing but answer (``mg_step_sync_ns``,
``benchmarks/csrc/sync_bench.h``: C on both sides, no Python, no env) and times empty steps through:

* ``barrier``: the step's barrier the pool uses (``mg_post_step`` + ``mg_collect``): one wake-up
  system call for all sleeping workers, one for the calling process;
* ``per-worker``: the signals it replaced: each worker's ``go`` posted on its own futex word, each
  ``done`` waited for in turn (up to two system calls per worker and batch). Its posts are in C
  here, where the pool made them from Python (~0.3 µs a worker more).

Both under two waiting policies: ``asleep`` (nobody polls: every batch pays every wake-up, as on a
crowded machine) and ``pool`` (the polls the pool would choose for that many stepping workers on
this machine: `dispatch.go_poll_time` / `collect_poll_time`). By default 1 .. cores-1 workers
(each with a core, the caller on the last); ``--workers`` measures any counts, those with as many
workers as cores or more marked oversubscribed. Rounds of the two protocols are interleaved;
the table gives medians over rounds of each round's median step.
"""

from __future__ import annotations

import argparse
import os
import time
from typing import Any

from modelicagym.bench import conditions, format_table, median, write_json

#: the pool's default spin time (seconds)
SPIN_TIME = 100e-6
PROTOCOLS = {"per-worker": 0, "barrier": 1}


def default_workers(cores: int) -> list[int]:
    """1 .. cores-1 workers (at least one)."""
    return list(range(1, max(cores, 2)))


def spins(policy: str, workers: int, cores: int) -> tuple[int, int]:
    """Nanoseconds the workers poll for ``go`` and the caller for their answers, under ``policy``."""
    if policy == "asleep":
        return 0, 0
    from modelicagym.vector.api import collect_poll_time, go_poll_time

    return (round(go_poll_time(SPIN_TIME, workers, cores) * 1e9),
            round(collect_poll_time(SPIN_TIME, workers, cores) * 1e9))


def measure(workers: list[int], policies: list[str], steps: int, repeats: int, cores: int) -> list[dict[str, Any]]:
    """Per worker count and policy: each protocol's median microseconds per empty step, over rounds."""
    from benchmarks.native import sync_library

    library = sync_library()
    samples: dict[tuple[int, str, str], list[float]] = {}
    for _ in range(repeats):
        for count in workers:
            for policy in policies:
                go_spin, collect_spin = spins(policy, count, cores)
                for name, barrier in PROTOCOLS.items():
                    nanoseconds = library.mg_step_sync_ns(count, steps, barrier, go_spin, collect_spin)
                    if nanoseconds < 0:
                        raise RuntimeError(f"{count} workers ({name}, {policy}): a worker did not answer")
                    samples.setdefault((count, policy, name), []).append(nanoseconds / 1e3)
    results = []
    for count in workers:
        for policy in policies:
            row = {"workers": count, "oversubscribed": count >= cores, "policy": policy,
                   "spin_ns": dict(zip(("go", "collect"), spins(policy, count, cores)))}
            for name in PROTOCOLS:
                row[f"{name}_us"] = median(samples[count, policy, name])
                row[f"{name}_rounds_us"] = samples[count, policy, name]
            row["ratio"] = row["per-worker_us"] / row["barrier_us"]
            results.append(row)
    return results


def report(results: list[dict[str, Any]]) -> str:
    rows = [[f"{r['workers']}{' (oversubscribed)' if r['oversubscribed'] else ''}", r["policy"],
             f"{r['per-worker_us']:.1f}", f"{r['barrier_us']:.1f}", f"{r['ratio']:.2f}x"] for r in results]
    return format_table(["workers", "waits", "per-worker us", "barrier us", "per-worker / barrier"], rows)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--workers", type=int, nargs="+", default=None,
                        help="worker counts (default 1 .. usable cores - 1; more than that is oversubscribed)")
    parser.add_argument("--policies", nargs="+", default=["asleep", "pool"], choices=["asleep", "pool"])
    parser.add_argument("--steps", type=int, default=2000, help="empty steps per round (their median is a round's)")
    parser.add_argument("--repeats", type=int, default=5, help="interleaved rounds (median reported)")
    parser.add_argument("--json", default="bench-results/barrier.json", help="where to write the JSON")


def run(args: argparse.Namespace) -> int:
    from modelicagym.cores import usable_cores

    load_before, cores = os.getloadavg(), usable_cores()
    workers = args.workers or default_workers(cores)
    started = time.perf_counter()
    results = measure(workers, args.policies, args.steps, args.repeats, cores)
    round_seconds = (time.perf_counter() - started) / (args.repeats * len(workers) * len(args.policies) * len(PROTOCOLS))
    line, machine = conditions(load_before, args.repeats, round(round_seconds, 3))
    print(f"an empty step's synchronisation, {cores} usable cores\n{report(results)}\n{line}")
    path = write_json(args.json, {"benchmark": "barrier", "usable_cores": cores, "steps": args.steps,
                                  "results": results, "conditions": machine})
    print(f"wrote {path}")
    return 0
