"""Throughput of your own FMU: a single env, SyncVectorEnv, AsyncVectorEnv and the pool, side by side.

``modelicagym bench fmu MY.fmu`` (or ``system.ssp``: then also its step against its FMUs stepped
alone, `modelicagym.bench.system_alone`) makes envs from the config ``modelicagym info`` prints for the FMU
(``--config file.json`` and ``--set key=value`` change it, as for ``modelicagym try``) and, for
each number of envs n (``--n``, default 2 8 64), times interleaved over several rounds, random
actions sampled from the action space (seeded):

* ``single``: one `FMUEnv` in a plain loop;
* ``sync``: ``gymnasium.vector.SyncVectorEnv`` of n envs (not for an FMU that may be instantiated
  only once per process whose config keeps that rule, ``instances_per_process="one"``: it holds
  every env in this process);
* ``async``: ``gymnasium.vector.AsyncVectorEnv`` (n <= 8: one process per env);
* ``pool``: ``modelicagym.make_vec`` with its default layout;

and reports medians of env steps per second and the pool's ratios to the others; the step path of
the env and of the pool's envs, and why; where the time of a step goes (inside the FMU against the
Python around it: the env's ``fmu_time_ns``, the pool's ``timing()``); and the pool's layout, and
why, in plain words; and the action bounds the random actions were sampled in (those ``try``
assumed named). Each round lasts about ``--seconds`` whatever the FMU costs: a heavy FMU gets fewer
steps, not a longer run. Progress goes to a tqdm bar (the ``progress`` extra) on a terminal, else
(piped into a log, or without tqdm) to one log line a step.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import sys
import time
from collections import Counter
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import asdict
from pathlib import Path
from typing import Any

import gymnasium as gym

import modelicagym
from modelicagym.bench import add_round_arguments, conditions, format_table, median, system_alone, write_json
from modelicagym.bench.throughput import ASYNC_MAX_N, Run, interleaved_rates
from modelicagym.env import FMUEnv
from modelicagym.errors import ArgumentError
from modelicagym.registry import EnvFactory
from modelicagym.system import SystemDescription, open_model
from modelicagym.try_fmu import prepare
from modelicagym.vector.api import LayoutState

logger = logging.getLogger(__name__)

#: actions sampled up front and cycled through, so that sampling costs nothing in the timed loops
ACTIONS = 64
#: the vector candidates, measured for each n next to a single env
VECTORS = ("sync", "async", "pool")
#: a round starts its calibration at one step (one batch): a heavy FMU's first run stays short
FIRST_STEPS = 1


class FMUTime:
    """Wall and FMU nanoseconds of a single env's steps, over the runs it measures."""

    def __init__(self, env: FMUEnv) -> None:
        self.env, self.wall_ns, self.fmu_ns, self.steps = env, 0, 0, 0

    @contextmanager
    def measuring(self, steps: int) -> Iterator[None]:
        fmu_before, started = self.env.fmu_time_ns, time.perf_counter_ns()
        yield
        self.wall_ns += time.perf_counter_ns() - started
        self.fmu_ns += self.env.fmu_time_ns - fmu_before
        self.steps += steps

    def per_step_us(self) -> dict[str, float]:
        steps = max(self.steps, 1)
        wall, fmu = self.wall_ns / steps / 1e3, self.fmu_ns / steps / 1e3
        return {"wall_us": wall, "fmu_us": fmu, "around_us": wall - fmu}


def single_loop(env: FMUEnv, seed: int) -> Run:
    """One env stepped with actions sampled from its space, reset when an episode ends."""
    env.reset(seed=seed)
    env.action_space.seed(seed)
    actions = [env.action_space.sample() for _ in range(ACTIONS)]

    def run(steps: int) -> int:
        for k in range(steps):
            _, _, terminated, truncated, _ = env.step(actions[k % ACTIONS])
            if terminated or truncated:
                env.reset()
        return steps

    return run


def vector_loop(envs: gym.vector.VectorEnv, n: int, seed: int) -> Run:
    """``envs`` stepped with batches of sampled actions (autoreset: the vector env's own)."""
    envs.reset(seed=seed)
    envs.action_space.seed(seed)
    actions = [envs.action_space.sample() for _ in range(ACTIONS)]

    def run(steps: int) -> int:
        batches = max(1, steps // n)
        for k in range(batches):
            envs.step(actions[k % ACTIONS])
        return batches * n

    return run


def make_vector(candidate: str, n: int, config: Mapping[str, Any]) -> gym.vector.VectorEnv:
    """``candidate`` ("pool", "sync" or "async") of ``n`` envs of ``config``."""
    if candidate == "pool":
        return modelicagym.make_vec(dict(config), n=n)
    fns = [EnvFactory("modelicagym.env:FMUEnv", dict(config)) for _ in range(n)]
    if candidate == "sync":
        return gym.vector.SyncVectorEnv(fns)
    return gym.vector.AsyncVectorEnv(fns, shared_memory=True)


def skipped(candidate: str, n: int, one_per_process: bool) -> str | None:
    """Why ``candidate`` is not measured at ``n`` envs (``None``: it is)."""
    if candidate == "async" and n > ASYNC_MAX_N:
        return f"AsyncVectorEnv starts one process per env: measured up to n={ASYNC_MAX_N}"
    if candidate == "sync" and one_per_process:
        return ("the FMU may be instantiated only once per process and the config keeps that rule "
                "(instances_per_process='one'): SyncVectorEnv cannot hold two")
    return None


def describe_paths(paths: list[tuple[str, str]]) -> list[dict[str, Any]]:
    """The distinct (path, reason) of a pool's envs, with how many envs take each."""
    return [{"path": path, "reason": reason, "envs": count} for (path, reason), count in Counter(paths).items()]


def measure_group(config: Mapping[str, Any], n: int, repeats: int, seconds: float, one_per_process: bool,
                  progress: Callable[[str], None]) -> dict[str, Any]:
    """Env steps per second of a single env and of the vector candidates for ``n`` envs, interleaved;
    the single env's time in and around the FMU; the pool's step paths, layout and step breakdown.
    Each n is its own group, so the envs of other groups do not share the machine with these."""
    closers: list[Any] = []
    vectors: dict[str, Run] = {}
    skips = {}
    try:
        pool = None
        for candidate in VECTORS:  # before the single env: AsyncVectorEnv makes (and closes) an env here
            why = skipped(candidate, n, one_per_process)
            if why is not None:
                skips[candidate] = why
                continue
            envs = make_vector(candidate, n, config)
            closers.append(envs)
            vectors[candidate] = vector_loop(envs, n, seed=n)
            pool = envs if candidate == "pool" else pool
        single = FMUEnv(dict(config))
        closers.append(single)
        single_path = {"path": single.step_path, "reason": single.step_path_reason}
        runs = {"single": single_loop(single, 1), **vectors}
        progress(f"n={n}: envs made")
        samples, steps = interleaved_rates(runs, repeats, seconds, FIRST_STEPS,
                                           progress=lambda what: progress(f"n={n}, {what}"))
        clock = FMUTime(single)  # where the time goes, in one more round of each (timing costs a little)
        with clock.measuring(steps["single"]):
            runs["single"](steps["single"])
        pool.set_timing(True)
        runs["pool"](steps["pool"])
        timing = pool.timing()
        progress(f"n={n}: timed")
        pool_part = {
            "num_workers": pool.num_workers, "caller_steps": pool.caller_steps, "layout": str(timing.layout),
            "plain_layout": plain_layout(n, pool.layout),
            "layout_reason": pool.layout.reason, "step_paths": describe_paths(list(pool.step_paths)),
            "timing": asdict(timing),
        }
    finally:
        for env in closers:
            env.close()
    rates = {name: median(values) for name, values in samples.items()}
    ratios = {name: rates["pool"] / rates[name] for name in rates if name != "pool"}
    return {"n": n, "steps_per_second": rates, "samples": samples, "steps_per_round": steps, "ratios": ratios,
            "skipped": skips, "single_step_path": single_path, "single_time": clock.per_step_us(), "pool": pool_part}


def report(head: dict[str, Any], results: list[dict[str, Any]]) -> str:
    """The tables: rates, the pool's ratios, where a step's time goes, and the pool's layout."""
    def rate(r: dict[str, Any], key: str) -> str:
        value = r["steps_per_second"].get(key)
        return "-" if value is None else f"{value:,.0f}"

    def ratio(r: dict[str, Any], key: str) -> str:
        value = r["ratios"].get(key)
        return "-" if value is None else f"{value:.2f}x"

    rates = format_table(
        ("n", "single", "sync", "async", "pool", "pool/single", "pool/sync", "pool/async"),
        [(r["n"], *(rate(r, c) for c in ("single", *VECTORS)), *(ratio(r, c) for c in ("single", "sync", "async")))
         for r in results],
    )
    def share(part: float, whole: float) -> str:
        return f"{100 * part / whole:.0f}%" if whole > 0 else "-"

    single = format_table(
        ("group n", "wall us", "in FMU us", "around us", "in FMU"),
        [(r["n"], *(f"{t[k]:.1f}" for k in ("wall_us", "fmu_us", "around_us")), share(t["fmu_us"], t["wall_us"]))
         for r in results for t in (r["single_time"],)],
    )
    pool = format_table(
        ("n", "wall us", "in FMU us", "env Python us", "pool overhead us", "in FMU", "all workers in FMU us"),
        [(r["n"], *(f"{1e6 * t[k]:.1f}" for k in ("wall_s", "fmu_s", "env_python_s", "pool_overhead_s")),
          share(t["fmu_s"], t["wall_s"]), f"{1e6 * t['fmu_total_s']:.1f}")
         for r in results for t in (r["pool"]["timing"],)],
    )
    paths = [f"single env: {head['step_path']['path']} ({head['step_path']['reason']})"]
    for r in results:
        for p in r["pool"]["step_paths"]:
            paths.append(f"pool n={r['n']}: {p['envs']} env(s) {p['path']} ({p['reason']})")
    layouts = [r["pool"]["plain_layout"] for r in results]
    skips = sorted({f"{name}: {why}" for r in results for name, why in r["skipped"].items()})
    lines = [
        f"{head['model']} (FMI {head['fmi_version']}, mode {head['mode']!r}): {head['fmu']}",
        f"random actions sampled in: {head['action_bounds']}",
        "", "step path:", *(f"  {line}" for line in paths),
        "", f"env steps per second:\n{rates}",
        "", f"a single env's step: inside the FMU against around it (the env's Python, the loop):\n{single}",
        "", "a pool's batch of n steps, its critical worker's slice (wall = in FMU + env Python + pool overhead: "
            f"waking, waiting, copying):\n{pool}",
        "", "pool layout:", *(f"  {line}" for line in layouts),
    ]
    if skips:
        lines += ["", "not measured:", *(f"  {line}" for line in skips)]
    return "\n".join(lines)


def plain_layout(n: int, state: LayoutState) -> str:
    """The pool's layout for ``n`` envs in a sentence: which processes step them, and whether the
    pool moves them (the full state, with the measurement behind its last move, is in the JSON)."""
    mine = state.envs_in_stand_in if state.stand_in else state.envs_in_caller
    where = ("a worker standing in for your process (an FMU's code runs in your process only where it says it is "
             "safe)") if state.stand_in else "your process"
    workers = f"{state.num_workers} worker process{'' if state.num_workers == 1 else 'es'}"
    how = ("the pool moves envs between them at episode boundaries, to where it measures they step faster"
           if state.adaptive else "the pool keeps them there")
    return (f"pool n={n}: {mine} of the {n} envs step{'s' if mine == 1 else ''} in {where}, the other {n - mine} in "
            f"{workers}; {how}")


def bounds_line(config: Mapping[str, Any], assumed: tuple[str, ...]) -> str:
    """The bounds the random actions are sampled in: the config's ``action_bounds`` (those ``try``
    assumed, as nothing in the FMU says their range, named so), else each input's declared range."""
    bounds = config.get("action_bounds") or {}
    parts = [f"{name} in [{low:g}, {high:g}]" + (" (assumed: nothing in the FMU says its range; give action_bounds "
                                                 "with --set)" if name in assumed else "")
             for name, (low, high) in bounds.items()]
    declared = [name for name in config.get("inputs") or () if name not in bounds]
    if declared:
        parts.append(f"{', '.join(declared)} in the range the FMU declares")
    if config.get("action_table") is not None:
        parts = [f"the rows of action_table ({len(config['action_table'])})"]
    return "; ".join(parts) or "no inputs"


def _tqdm() -> Any:
    """tqdm's bar class, or None without the ``progress`` extra."""
    try:
        from tqdm import tqdm
    except ImportError:
        return None
    return tqdm


@contextmanager
def progress_reporter(total: int) -> Iterator[Callable[[str], None]]:
    """A tqdm bar's step (the ``progress`` extra) when stderr is a terminal; else (a log, a pipe,
    no tqdm) one log line a step."""
    tqdm = _tqdm() if sys.stderr.isatty() else None
    if tqdm is None:
        done = [0]

        def log(what: str) -> None:
            done[0] += 1
            logger.info("[%d/%d] %s", done[0], total, what)

        yield log
        return
    with tqdm(total=total, unit="step", desc="bench fmu", leave=False) as bar:
        def advance(what: str) -> None:
            bar.set_postfix_str(what, refresh=False)
            bar.update()

        yield advance


def add_config_arguments(parser: argparse.ArgumentParser) -> None:
    """The FMU and how its config changes ``info``'s suggestion (``try_config``'s arguments)."""
    parser.add_argument("fmu", help="path of the .fmu file")
    parser.add_argument("--config", help="a JSON file of FMUEnv keys that replace the suggested config's")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="change one config key, the value read as JSON (e.g. --set time_step=0.01)")
    parser.add_argument("--no-validate", action="store_true", help="skip schema validation of modelDescription.xml")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_config_arguments(parser)
    add_round_arguments(parser, "fmu")
    parser.set_defaults(json=None)
    parser.description = (f"{(__doc__ or '').splitlines()[0]} The JSON goes to bench-results/fmu-<FMU name>.json "
                          "unless --json says where.")


def run(args: argparse.Namespace) -> int:
    for option, values in (("--n", args.n), ("--repeats", [args.repeats])):
        if min(values) < 1:
            raise ArgumentError(f"bench fmu {option}: at least 1, got {min(values)}")
    if args.seconds <= 0:
        raise ArgumentError(f"bench fmu --seconds: more than 0, got {args.seconds}")
    load_before = os.getloadavg()
    prepared = prepare(args.fmu, config_file=args.config, settings=args.set, validate=not args.no_validate)
    config = prepared.config
    description = open_model(config.get("fmu"), fmus=config.get("fmus"), connections=config.get("connections", ()),
                             validate=config.get("validate", True))
    once = description.once_per_process(config.get("mode"))
    one_per_process = once and config.get("instances_per_process", "copies") == "one"
    if isinstance(description, SystemDescription):  # a system: its FMUs' versions, and the master as the mode
        fmi_version: Any = "+".join(sorted({str(c.description.fmi_version) for c in description.components.values()
                                            if c.description is not None}))
        mode = f"system, {config.get('master', 'gauss-seidel')}"
    else:
        fmi_version, mode = description.fmi_version, config.get("mode") or description.default_mode()
    head = {"fmu": str(config.get("fmu") or description.name), "model": description.model_name,
            "fmi_version": fmi_version, "mode": mode, "once_per_process": once,
            "config": json.loads(json.dumps(config, default=str)),
            "action_bounds": bounds_line(config, prepared.assumed)}
    candidates = [1 + sum(skipped(c, n, one_per_process) is None for c in VECTORS) for n in args.n]  # single + vectors
    total = sum(1 + k * (1 + args.repeats) + 1 for k in candidates)
    results = []
    with progress_reporter(total) as progress:
        for n in args.n:
            results.append(measure_group(config, n, args.repeats, args.seconds, one_per_process, progress))
        if isinstance(description, SystemDescription):
            head["alone"] = system_alone.measure(config, description, args.repeats, args.seconds, single_loop,
                                                 progress=lambda what: progress(f"alone: {what}"))
    head["step_path"] = results[0]["single_step_path"]
    line, data = conditions(load_before, args.repeats, args.seconds)
    print(report(head, results))
    if "alone" in head:
        print("\n" + "\n".join(system_alone.report_lines(head["alone"])))
    print(f"\n{line}")
    out = args.json or f"bench-results/fmu-{Path(args.fmu).stem}.json"
    data = {**head, **data, "repeats": args.repeats, "seconds": args.seconds, "results": results}
    print(f"wrote {write_json(out, data)}")
    return 0
