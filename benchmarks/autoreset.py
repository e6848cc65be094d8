"""The pool's steps per second in each autoreset mode, same-step against next-step.

Stable-Baselines3 and most deep-RL code expect ``SAME_STEP`` autoreset (the env that ended is reset
in the step that ended it; its last observation goes in ``infos["final_obs"]``), Gymnasium's
default is ``NEXT_STEP``. For each n one run creates the cart-pole pool (``make_vec``) in each
mode, and ``SyncVectorEnv`` in ``SAME_STEP`` for reference, then times them interleaved over
several rounds with random actions (episodes of ~20 steps: at n=64 a few envs end every step).

Target: the pool's ``SAME_STEP`` >= 0.8x its ``NEXT_STEP`` at n=64.
"""

from __future__ import annotations

import argparse
import logging
import os
from typing import Any

import gymnasium as gym
from gymnasium.vector import AutoresetMode

from modelicagym.bench import add_round_arguments, conditions, format_table, median, write_json
from modelicagym.bench.throughput import EPISODE_STEPS, interleaved_rates, make_vector, vector_loop

logger = logging.getLogger(__name__)

#: (candidate, autoreset mode) pairs measured for each n
CANDIDATES = (
    ("pool", AutoresetMode.NEXT_STEP),
    ("pool", AutoresetMode.SAME_STEP),
    ("pool", AutoresetMode.DISABLED),
    ("sync", AutoresetMode.SAME_STEP),
)


def _name(candidate: str, mode: AutoresetMode) -> str:
    return f"{candidate} {mode.value}"


def measure(n: int, repeats: int, seconds: float) -> dict[str, Any]:
    """Steps per second of every candidate at ``n`` envs: medians of interleaved rounds."""
    closers: list[gym.vector.VectorEnv] = []
    runs = {}
    try:
        for candidate, mode in CANDIDATES:
            envs = make_vector(candidate, n, {"max_episode_steps": EPISODE_STEPS}, mode)
            closers.append(envs)
            runs[_name(candidate, mode)] = vector_loop(envs, n, seed=n, autoreset=mode)
        samples, _ = interleaved_rates(runs, repeats, seconds)
    finally:
        for envs in closers:
            envs.close()
    rates = {name: median(values) for name, values in samples.items()}
    next_step = rates[_name("pool", AutoresetMode.NEXT_STEP)]
    return {"n": n, "steps_per_second": rates, "samples": samples,
            "same_over_next": rates[_name("pool", AutoresetMode.SAME_STEP)] / next_step,
            "disabled_over_next": rates[_name("pool", AutoresetMode.DISABLED)] / next_step}


def report(results: list[dict[str, Any]]) -> str:
    names = [_name(candidate, mode) for candidate, mode in CANDIDATES]
    rates = format_table(
        ("n", *names, "pool same/next", "target"),
        [(r["n"], *(f"{r['steps_per_second'][name]:,.0f}" for name in names), f"{r['same_over_next']:.2f}x",
          ">= 0.8x" if r["n"] == 64 else "-") for r in results],
    )
    return f"env steps per second by autoreset mode:\n{rates}"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_round_arguments(parser, "autoreset")


def run(args: argparse.Namespace) -> int:
    load_before = os.getloadavg()
    results = []
    for n in args.n:
        logger.info("measuring n=%d", n)
        results.append(measure(n, args.repeats, args.seconds))
    line, data = conditions(load_before, args.repeats, args.seconds)
    print(report(results))
    print(f"\n{line}")
    print(f"wrote {write_json(args.json, {**data, 'results': results})}")
    return 0
