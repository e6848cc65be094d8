"""The experiments runner's cost per vector step against the bare pool's, part by part.

For each sweep of the paper (its pool size ``n``: 15 or 25 cart-poles) one run times, interleaved
over several rounds:

* ``runner``: the sweep as ``modelicagym reproduce`` trains it (`run_sweep`: the pool, the
  batched Q-learning agent, the episode bookkeeping), per vector step: its wall time, split into
  the time outside the pool (``agent_seconds``: discretising, acting, learning, bookkeeping) and
  the rest (the pool's ``step``/``step_envs``);
* ``bare pool``: the same pool (``make_vec`` with the sweep's options, pool timing on as the runner
  has it) stepped with random actions;
* the agent's calls alone (``states`` + ``act`` + ``learn`` on ``n`` envs) and the episode
  tracker's ``update``, on made-up transitions.

The table gives medians; the target is runner / bare pool <= 2.
"""

from __future__ import annotations

import argparse
import logging
import os
import time
from typing import Any

import numpy as np

import modelicagym
from modelicagym.agents import Discretizer, QLearningAgent
from modelicagym.agents.episodes import EpisodeTracker
from modelicagym.bench import format_table, median, write_json
from modelicagym.experiments.config import SweepConfig
from modelicagym.experiments.paper import PAPER_SWEEPS
from modelicagym.experiments.runner import run_sweep

logger = logging.getLogger(__name__)


def runner_round(config: SweepConfig) -> dict[str, float]:
    """One training run of the sweep: microseconds per vector step, in all and outside the pool."""
    timing = run_sweep(config, progress=False).timing
    steps = timing["vector_steps"]
    return {"runner_us": 1e6 * timing["wall_seconds"] / steps, "outside_pool_us": 1e6 * timing["agent_seconds"] / steps}


def bare_pool_round(config: SweepConfig, steps: int) -> float:
    """Microseconds per ``step`` of the sweep's pool, random actions, pool timing on."""
    n = len(config.settings) * config.repeats
    options = [dict(setting.options) for setting in config.settings for _ in range(config.repeats)]
    envs = modelicagym.make_vec(config.env, n, options_per_env=options, **config.base_options)
    try:
        envs.reset(seed=0)
        envs.set_timing(True)
        actions = np.random.default_rng(0).integers(0, 2, (steps, n))
        started = time.perf_counter()
        for k in range(steps):
            envs.step(actions[k])
        return 1e6 * (time.perf_counter() - started) / steps
    finally:
        envs.close()


def agent_parts(config: SweepConfig, steps: int) -> dict[str, float]:
    """Microseconds per vector step of the agent's calls and of the episode bookkeeping alone."""
    n = len(config.settings) * config.repeats
    spec = config.agent
    discretizer = Discretizer(spec.intervals, spec.n_bins)
    agent = QLearningAgent(discretizer, 2, n_envs=n, config=spec.q_learning, seeds=0)
    rng = np.random.default_rng(0)
    observations = rng.normal(scale=0.1, size=(steps, n, agent.discretizer.n_variables))
    rewards, ends = np.ones(n), rng.random((steps, n)) < 0.05
    states = agent.states(observations[0])
    started = time.perf_counter()
    for k in range(steps):
        actions = agent.act(states)
        next_states = agent.states(observations[k])
        agent.learn(states, actions, rewards, next_states, ends[k], ends[k], mask=~ends[k])
        states = next_states
    agent_us = 1e6 * (time.perf_counter() - started) / steps
    tracker, wanted = EpisodeTracker(n), np.ones(n, dtype=bool)
    started = time.perf_counter()
    for k in range(steps):
        tracker.update(tracker.live(wanted), rewards, ends[k], ends[k])
    return {"agent_calls_us": agent_us, "bookkeeping_us": 1e6 * (time.perf_counter() - started) / steps}


def measure(name: str, repeats: int, steps: int) -> dict[str, Any]:
    config = PAPER_SWEEPS[name]
    rounds: dict[str, list[float]] = {}
    for _ in range(repeats):
        parts = {**runner_round(config), "bare_pool_us": bare_pool_round(config, steps), **agent_parts(config, steps)}
        for key, value in parts.items():
            rounds.setdefault(key, []).append(value)
    medians = {key: median(values) for key, values in rounds.items()}
    medians["pool_in_runner_us"] = medians["runner_us"] - medians["outside_pool_us"]
    medians["ratio"] = medians["runner_us"] / medians["bare_pool_us"]
    return {"sweep": name, "num_envs": len(config.settings) * config.repeats, **medians, "rounds": rounds}


def report(results: list[dict[str, Any]]) -> str:
    rows = [
        [r["sweep"], r["num_envs"], f"{r['runner_us']:.1f}", f"{r['pool_in_runner_us']:.1f}",
         f"{r['outside_pool_us']:.1f}", f"{r['agent_calls_us']:.1f}", f"{r['bookkeeping_us']:.1f}",
         f"{r['bare_pool_us']:.1f}", f"{r['ratio']:.2f}x"]
        for r in results
    ]
    return format_table(["sweep", "n", "runner us", "of it pool", "outside pool", "agent calls", "bookkeeping",
                         "bare pool us", "runner / bare"], rows)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--sweeps", nargs="+", default=["force", "masses"], choices=list(PAPER_SWEEPS))
    parser.add_argument("--repeats", type=int, default=3, help="interleaved rounds (median reported)")
    parser.add_argument("--steps", type=int, default=5000, help="vector steps of the bare pool and agent rounds")
    parser.add_argument("--json", default="bench-results/runner.json", help="where to write the JSON")


def run(args: argparse.Namespace) -> int:
    load_before = os.getloadavg()
    results = [measure(name, args.repeats, args.steps) for name in args.sweeps]
    print(report(results))
    print(f"\nmicroseconds per vector step; cores: {os.cpu_count()}; load average (1 min) before "
          f"{load_before[0]:.2f}, after {os.getloadavg()[0]:.2f}; medians of {args.repeats} interleaved rounds")
    data = {"cores": os.cpu_count(), "load_average_before": load_before, "results": results}
    print(f"wrote {write_json(args.json, data)}")
    return 0
