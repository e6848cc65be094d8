"""A pool of an FMU allowed one instance per process: private copies of its binary against one env per worker.

``python -m benchmarks once-per-process MY.fmu`` makes envs from the config ``modelicagym info``
prints for the FMU (``--config`` and ``--set`` change it, as for ``modelicagym bench fmu``) and,
for each number of envs n (``--n``, default 2 8), times interleaved over several rounds, random
actions sampled from the action space:

* ``single``: one `FMUEnv` in a plain loop;
* ``copies``: ``modelicagym.make_vec`` with its default layout, each further instance in a process
  on a private copy of the binary (``instances_per_process="copies"``, the default);
* ``one``: the same with ``instances_per_process="one"``: one env per worker, as every such pool
  was laid out before the copies.

Each pool is stepped ``--warm`` seconds before the rounds, so that the adaptive layout has made its
first try. Then, for ``--start-n`` envs (default 64), the time from ``make_vec`` to the end of the
first reset, alternating the two settings over the rounds. Prints medians and ratios, writes JSON.
"""

from __future__ import annotations

import argparse
import os
import time
from typing import Any

import modelicagym
from modelicagym.bench import add_round_arguments, conditions, format_table, median, write_json
from modelicagym.bench.own_fmu import add_config_arguments, single_loop, vector_loop
from modelicagym.bench.throughput import interleaved_rates
from modelicagym.env import FMUEnv
from modelicagym.errors import ArgumentError
from modelicagym.fmu import open_fmu
from modelicagym.try_fmu import try_config

#: the settings of ``instances_per_process`` compared (each a candidate of that name)
SETTINGS = ("copies", "one")


def measure_group(config: dict[str, Any], n: int, repeats: int, seconds: float, warm: float) -> dict[str, Any]:
    """Env steps per second of a single env and of the pool under each setting (medians of
    interleaved rounds), and the pools' layouts."""
    made: list[Any] = []
    try:
        single = FMUEnv(dict(config))
        made.append(single)
        runs = {"single": single_loop(single, 1)}
        pools = {}
        for name in SETTINGS:
            pools[name] = modelicagym.make_vec({**config, "instances_per_process": name}, n=n)
            made.append(pools[name])
            runs[name] = vector_loop(pools[name], n, seed=n)
        for name in SETTINGS:  # the adaptive layout's first try, before the rounds
            deadline = time.perf_counter() + warm
            while time.perf_counter() < deadline:
                runs[name](n)
        samples, _ = interleaved_rates(runs, repeats, seconds, first=1)
        layouts = {name: str(pool.layout) for name, pool in pools.items()}
    finally:
        for closer in made:
            closer.close()
    rates = {name: median(values) for name, values in samples.items()}
    return {"n": n, "steps_per_second": rates, "samples": samples, "layouts": layouts,
            "ratios": {f"{name}/single": rates[name] / rates["single"] for name in SETTINGS}}


def start_seconds(config: dict[str, Any], n: int, setting: str) -> float:
    """Seconds from ``make_vec`` to the end of the first reset of ``n`` envs under ``setting``."""
    started = time.perf_counter()
    envs = modelicagym.make_vec({**config, "instances_per_process": setting}, n=n)
    try:
        envs.reset(seed=0)
        return time.perf_counter() - started
    finally:
        envs.close()


def measure_start(config: dict[str, Any], n: int, repeats: int) -> dict[str, Any]:
    """The pool's start under each setting, alternating over ``repeats`` rounds."""
    samples: dict[str, list[float]] = {name: [] for name in SETTINGS}
    for k in range(repeats):
        for name in (SETTINGS if k % 2 == 0 else SETTINGS[::-1]):
            samples[name].append(start_seconds(config, n, name))
    return {"n": n, "seconds": {name: median(values) for name, values in samples.items()}, "samples": samples}


def report(results: list[dict[str, Any]], start: dict[str, Any] | None) -> str:
    rows = [(r["n"], f"{r['steps_per_second']['single']:,.0f}",
             *(f"{r['steps_per_second'][name]:,.0f} ({r['ratios'][f'{name}/single']:.2f}x)" for name in SETTINGS))
            for r in results]
    lines = [format_table(("n", "single", "pool, copies (/single)", "pool, one per worker (/single)"), rows)]
    lines += [f"n={r['n']} {name}: {layout}" for r in results for name, layout in r["layouts"].items()]
    if start is not None:
        seconds = start["seconds"]
        lines.append(f"start (make_vec to the first reset's end) at n={start['n']}: copies {seconds['copies']:.2f} s, "
                     f"one per worker {seconds['one']:.2f} s")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    if min(args.n) < 1 or args.repeats < 1 or args.seconds <= 0 or args.warm < 0:
        raise ArgumentError("once-per-process: --n and --repeats at least 1, --seconds more than 0, "
                            "--warm at least 0")
    load_before = os.getloadavg()
    config = try_config(args.fmu, config_file=args.config, settings=args.set, validate=not args.no_validate)
    if not open_fmu(config["fmu"], validate=not args.no_validate).once_per_process(config.get("mode")):
        raise ArgumentError(f"once-per-process: {args.fmu} does not declare "
                            "canBeInstantiatedOnlyOncePerProcess: both settings would lay its envs out alike")
    results = [measure_group(config, n, args.repeats, args.seconds, args.warm) for n in args.n]
    start = measure_start(config, args.start_n, args.repeats) if args.start_n else None
    line, machine = conditions(load_before, args.repeats, args.seconds)
    print(report(results, start))
    print(f"\n{line}; pools warmed {args.warm} s")
    path = write_json(args.json, {"fmu": str(config["fmu"]), "config": {k: str(v) for k, v in config.items()},
                                  **machine, "warm": args.warm, "results": results, "start": start})
    print(f"wrote {path}")
    return 0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_config_arguments(parser)
    add_round_arguments(parser, "once-per-process")
    parser.set_defaults(n=[2, 8])
    parser.add_argument("--warm", type=float, default=2.0, help="seconds each pool steps before the rounds")
    parser.add_argument("--start-n", type=int, default=64, help="envs of the start-up timing (0: none)")
