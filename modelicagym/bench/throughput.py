"""Throughput of the Cart-Pole env stepped every way a user can, against the physical limit.

For each setting (the default cart-pole, and a heavy one whose internal step ``cs_step_size=1e-4``
emulates a costlier model) one run creates, through the public API only:

* ``single``: one ``modelicagym.make("cartpole")`` env in a plain loop, on its fastest (native)
  path; ``single_python``: the same env forced onto the Python path (``step_path="python"``);
* ``c_loop``: a loop in C over the same FMU binary (set the force, ``doStep``, get the four states,
  check the bounds, restore the snapshot at an episode's end) on one core: the physical limit;
* for each n: ``sync`` (``gymnasium.vector.SyncVectorEnv``), ``async``
  (``gymnasium.vector.AsyncVectorEnv``, for n <= 8: one process per env), and ``pool``
  (``modelicagym.make_vec``, its default layout);

then times them all interleaved over several rounds, random actions, and reports medians of env
steps per second, the pool's ratios to the others, and where a pool step's time goes.

Targets (2 cores): pool >= 1.5x single at n=2 and >= 1.8x at n=8;
>= 1.5x sync and >= 8x async at n=8; >= 1.5x the C loop at n=64; heavy: >= 1.8x single at n=2,
>= 1.85x at n=8. See docs/design.md for the step budget.
"""

from __future__ import annotations

import argparse
import ctypes
import logging
import os
import time
from collections.abc import Callable
from dataclasses import asdict
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode

import modelicagym
from modelicagym.bench import add_round_arguments, conditions, format_table, median, write_json
from modelicagym.bench.native import bench_library
from modelicagym.errors import ConfigError
from modelicagym.fmu.errors import FMUError
from modelicagym.registry import EnvFactory

logger = logging.getLogger(__name__)

SETTINGS = {
    "default": {},
    "heavy": {"cs_step_size": 1e-4},
}
#: vector candidates, measured for each n next to the single-env ones
VECTORS = ("sync", "async", "pool")
#: AsyncVectorEnv starts one process per env: beyond this it only measures the machine's swapping
ASYNC_MAX_N = 8
EPISODE_STEPS = 500

Run = Callable[[int], int]


def _options(setting: str) -> dict[str, Any]:
    return dict(SETTINGS[setting], max_episode_steps=EPISODE_STEPS)


def single_loop(env: gym.Env, seed: int) -> Run:
    rng = np.random.default_rng(seed)
    env.reset(seed=seed)

    def run(steps: int) -> int:
        for action in rng.integers(0, 2, size=steps).tolist():
            _, _, terminated, truncated, _ = env.step(action)
            if terminated or truncated:
                env.reset()
        return steps

    return run


def c_loop(env: gym.Env) -> Run:
    """``mg_loop`` (`modelicagym.bench.native`) over the env's own FMU instance (alternating pushes)."""
    native = env.unwrapped.native_step
    if native is None or env.unwrapped.python_edges:
        raise ConfigError(f"the C loop needs the whole step in C: {env.unwrapped.step_path_reason}")
    env.reset(seed=0)
    env.action_space.seed(0)
    env.step(env.action_space.sample())  # a first episode that steps: the reference of the rung's check
    env.reset()  # the second reset checks the snapshot rung: from then on a reset is a restore
    if not native.state.native_reset:
        raise ConfigError("the C loop needs resets by snapshot restore (reset_rung 'snapshot')")
    loop, state = bench_library().mg_loop, ctypes.byref(native.state)

    def run(steps: int) -> int:
        if loop(state, steps, None) != steps:
            raise FMUError("the C loop stopped on an FMU error")
        return steps

    return run


def vector_loop(
    envs: gym.vector.VectorEnv, n: int, seed: int, autoreset: AutoresetMode = AutoresetMode.NEXT_STEP
) -> Run:
    """Steps ``envs`` with random pushes; with ``autoreset=DISABLED`` it resets the envs that
    ended itself (``reset_mask``), as a user of that mode does."""
    rng = np.random.default_rng(seed)
    envs.reset(seed=seed)
    by_hand = autoreset is AutoresetMode.DISABLED

    def run(steps: int) -> int:
        batches = max(1, steps // n)
        for actions in rng.integers(0, 2, size=(batches, n)):
            _, _, terminations, truncations, _ = envs.step(actions)
            if by_hand and (ended := terminations | truncations).any():
                envs.reset(options={"reset_mask": ended})
        return batches * n

    return run


def make_vector(candidate: str, n: int, options: dict[str, Any],
                autoreset_mode: AutoresetMode = AutoresetMode.NEXT_STEP) -> gym.vector.VectorEnv:
    """``candidate`` ("pool", "sync" or "async") of ``n`` cart-poles made with ``options``."""
    if candidate == "pool":
        return modelicagym.make_vec("cartpole", n=n, autoreset_mode=autoreset_mode, **options)
    fns = [EnvFactory("modelicagym.models.cartpole.env:CartPoleEnv", options) for _ in range(n)]
    if candidate == "sync":
        return gym.vector.SyncVectorEnv(fns, autoreset_mode=autoreset_mode)
    return gym.vector.AsyncVectorEnv(fns, shared_memory=True, autoreset_mode=autoreset_mode)


def calibrate(run: Run, seconds: float, first: int = 256) -> int:
    """How many env steps take about ``seconds``: runs of ``first`` steps, then 4 times as many
    each, until one takes a quarter of ``seconds`` (a small ``first`` keeps a heavy env's
    calibration short)."""
    steps = first
    while True:
        started = time.perf_counter()
        steps = run(steps)
        elapsed = time.perf_counter() - started
        if elapsed >= seconds / 4:
            return max(1, int(steps * seconds / elapsed))
        steps *= 4


def interleaved_rates(
    runs: dict[str, Run], repeats: int, seconds: float, first: int = 256,
    progress: Callable[[str], None] = lambda what: None,
) -> tuple[dict[str, list[float]], dict[str, int]]:
    """Steps per second of every run in each of ``repeats`` interleaved rounds of about ``seconds``,
    and the steps a round of each takes (`calibrate`, from ``first`` steps). ``progress`` is told
    what was done after each calibration and round."""
    steps = {}
    for name, run in runs.items():
        steps[name] = calibrate(run, seconds, first)
        progress(f"{name}: calibrated")
    samples: dict[str, list[float]] = {name: [] for name in runs}
    for k in range(repeats):
        for name, run in runs.items():
            started = time.perf_counter()
            done = run(steps[name])
            samples[name].append(done / (time.perf_counter() - started))
            progress(f"{name}: round {k + 1}/{repeats}")
    return samples, steps


def measure_group(setting: str, n: int, repeats: int, seconds: float) -> dict[str, Any]:
    """Env steps per second of the single-env candidates and of the vector ones for ``n`` envs
    (medians of interleaved rounds: every ratio compares rates measured side by side), and the
    pool's breakdown of a batch step. Each n is its own group, so idle envs of other groups do not
    share the machine with the measured ones."""
    options = _options(setting)
    closers: list[Any] = []
    runs: dict[str, Run] = {}
    try:
        single = modelicagym.make("cartpole", **options)
        python = modelicagym.make("cartpole", step_path="python", **options)
        limit = modelicagym.make("cartpole", **options)
        closers += [single, python, limit]
        runs["single"], runs["single_python"], runs["c_loop"] = single_loop(single, 1), single_loop(python, 2), c_loop(limit)
        for candidate in VECTORS:
            if candidate == "async" and n > ASYNC_MAX_N:
                continue
            envs = make_vector(candidate, n, options)
            closers.append(envs)
            runs[candidate] = vector_loop(envs, n, seed=n)
        pool = envs
        samples, steps = interleaved_rates(runs, repeats, seconds)
        pool.set_timing(True)
        runs["pool"](steps["pool"])
        breakdown = asdict(pool.timing())
        breakdown["step_paths"] = sorted({path for path, _ in pool.step_paths})
        breakdown["num_workers"] = pool.num_workers
    finally:
        for env in closers:
            env.close()
    rates = {name: median(values) for name, values in samples.items()}
    return {"setting": setting, "n": n, "options": options, "steps_per_second": rates, "samples": samples,
            "ratios": ratios(rates), "pool_breakdown": breakdown}


def ratios(rates: dict[str, float]) -> dict[str, float | None]:
    """The pool's rate over each other candidate's (``None`` where not measured)."""
    others = ("single", "single_python", "sync", "async", "c_loop")
    return {name: (rates["pool"] / rates[name] if name in rates else None) for name in others}


def report(results: list[dict[str, Any]]) -> str:
    def rate(r: dict[str, Any], key: str) -> str:
        value = r["steps_per_second"].get(key)
        return "-" if value is None else f"{value:,.0f}"

    def ratio(value: float | None) -> str:
        return "-" if value is None else f"{value:.2f}x"

    columns = ("single", "single_python", "c_loop", "sync", "async", "pool")
    rates = format_table(
        ("setting", "n", "single (native)", "single (python)", "C loop", "sync", "async", "pool"),
        [(r["setting"], r["n"], *(rate(r, c) for c in columns)) for r in results],
    )
    vs = ("single", "sync", "async", "c_loop")
    pool = format_table(
        ("setting", "n", "pool/single", "pool/sync", "pool/async", "pool/C loop"),
        [(r["setting"], r["n"], *(ratio(r["ratios"][k]) for k in vs)) for r in results],
    )
    breakdown = format_table(
        ("setting", "n", "workers", "path", "batch wall us", "in FMU us", "env Python us", "pool overhead us"),
        [(r["setting"], r["n"], b["num_workers"], "+".join(b["step_paths"]),
          *(f"{1e6 * b[k]:.1f}" for k in ("wall_s", "fmu_s", "env_python_s", "pool_overhead_s")))
         for r in results for b in (r["pool_breakdown"],)],
    )
    return (f"env steps per second:\n{rates}\n\nthe pool against the others, same rounds:\n{pool}\n\n"
            f"pool step breakdown (the critical slice, per batch):\n{breakdown}")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--settings", nargs="+", default=list(SETTINGS), choices=list(SETTINGS))
    add_round_arguments(parser, "throughput")


def run(args: argparse.Namespace) -> int:
    load_before = os.getloadavg()
    results = []
    for setting in args.settings:
        for n in args.n:
            logger.info("measuring %s, n=%d", setting, n)
            results.append(measure_group(setting, n, args.repeats, args.seconds))
    line, data = conditions(load_before, args.repeats, args.seconds)
    print(report(results))
    print(f"\n{line}")
    print(f"wrote {write_json(args.json, {**data, 'results': results})}")
    return 0
