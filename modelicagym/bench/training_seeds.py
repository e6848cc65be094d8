"""``modelicagym bench training --seeds N``: what a user can expect from a preset, over N seeds.

Every (env, algorithm) preset of `modelicagym.sb3_train` is trained with seeds 0..N-1, each run in
its own process (``--jobs`` at a time, one torch thread each), until solved or its budget is
spent. The table gives, per preset, the fraction of seeds that solved within the budget, the
median and range (min-max) of the env steps and wall seconds to solve over the seeds that solved,
and the median and range of the deterministic policy's evaluation return over all seeds; the JSON
also holds every run's learning curve and the conditions (cores, load, torch threads, versions).
Wall times depend on the machine and its load; env steps do not, on one machine.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from importlib.metadata import version
from typing import Any

import numpy as np

from modelicagym.bench import format_table, write_json
from modelicagym.cores import usable_cores
from modelicagym.errors import ModelicaGymError

logger = logging.getLogger(__name__)

#: torch threads per run: the examples' default, and what makes a seed's curve repeatable
THREADS = 1


class SeedRunError(ModelicaGymError):
    """A seeded training run's process failed."""


def run_one(env: str, algorithm: str, seed: int, budget: int | None, eval_episodes: int) -> dict[str, Any]:
    """One seeded run in a fresh process (a pool per run, nothing shared): its `Run.summary`."""
    command = [sys.executable, "-m", __name__, env, algorithm, str(seed), str(budget or 0), str(eval_episodes)]
    logger.info("training %s with %s, seed %d", env, algorithm, seed)
    result = subprocess.run(command, capture_output=True, text=True, check=False)
    if result.returncode != 0:
        raise SeedRunError(f"{env} {algorithm} seed {seed}: the run failed (exit {result.returncode}):\n"
                           f"{result.stderr.strip()[-2000:]}")
    run = json.loads(result.stdout.strip().splitlines()[-1])
    logger.info("%s %s seed %d: %s; evaluation %.1f", env, algorithm, seed,
                f"solved after {run['solved_steps']} steps, {run['solved_seconds']:.0f} s" if run["solved_steps"]
                else f"not solved in {run['steps']} steps, {run['seconds']:.0f} s", np.mean(run["eval_returns"]))
    return run


def _spread(values: list[float], digits: str) -> str:
    """``median [min-max]`` of ``values``, or ``-`` for none."""
    if not values:
        return "-"
    return f"{np.median(values):{digits}} [{min(values):{digits}}, {max(values):{digits}}]"


def summarize(runs: list[dict[str, Any]], budgets: dict[tuple[str, str], int]) -> list[dict[str, Any]]:
    """Per (env, algorithm): seeds, how many solved, and medians and ranges of what they did."""
    groups: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for run in runs:
        groups.setdefault((run["env"], run["algorithm"]), []).append(run)
    summaries = []
    for (env, algorithm), group in groups.items():
        solved = [r for r in group if r["solved_steps"] is not None]
        evals = [float(np.mean(r["eval_returns"])) for r in group]
        steps = [r["solved_steps"] for r in solved]
        seconds = [r["solved_seconds"] for r in solved]
        summaries.append({
            "env": env, "algorithm": algorithm, "seeds": [r["seed"] for r in group], "budget": budgets[env, algorithm],
            "solved": len(solved),
            "steps_to_solve": {"median": _stat(np.median, steps), "min": _stat(min, steps), "max": _stat(max, steps)},
            "seconds_to_solve": {"median": _stat(np.median, seconds), "min": _stat(min, seconds),
                                 "max": _stat(max, seconds)},
            "eval_return": {"median": float(np.median(evals)), "min": min(evals), "max": max(evals),
                            "iqr": [float(q) for q in np.percentile(evals, [25, 75])]},
        })
    return summaries


def _stat(function: Any, values: list[float]) -> float | None:
    return float(function(values)) if values else None


def table(summaries: list[dict[str, Any]], runs: list[dict[str, Any]]) -> str:
    rows = []
    for s in summaries:
        group = [r for r in runs if (r["env"], r["algorithm"]) == (s["env"], s["algorithm"])]
        rows.append((s["env"], s["algorithm"], f"{s['budget']:,}", f"{s['solved']}/{len(s['seeds'])}",
                     _spread([r["solved_steps"] for r in group if r["solved_steps"] is not None], ",.0f"),
                     _spread([r["solved_seconds"] for r in group if r["solved_seconds"] is not None], ".0f"),
                     _spread([float(np.mean(r["eval_returns"])) for r in group], ".0f")))
    return format_table(("env", "algorithm", "budget", "solved", "env steps to solve", "seconds to solve",
                         "evaluation return"), rows)


def conditions(load_before: tuple[float, float, float], jobs: int) -> dict[str, Any]:
    """Cores, load, threads, concurrency and versions of a seed study."""
    import torch

    return {"cores": usable_cores(), "load_average": {"before": load_before, "after": os.getloadavg()},
            "torch_threads": THREADS, "runs_at_once": jobs, "python": sys.version.split()[0],
            "versions": {name: version(name) for name in ("torch", "stable-baselines3", "gymnasium", "numpy")},
            "torch_blas": _blas(torch.__config__.show())}


def _blas(config: str) -> str:
    return next((line.split("=", 1)[1].strip() for line in config.splitlines() if "BLAS_INFO" in line), "unknown")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--algorithms", nargs="+", default=["ppo", "sac"], choices=["ppo", "sac"],
                        help="with --seeds: the algorithms to train (each where it has a preset)")
    parser.add_argument("--jobs", type=int, default=2, help="with --seeds: runs at once, each its own process")
    parser.add_argument("--budget", type=int, help="with --seeds: env steps per run (default: each preset's)")
    parser.add_argument("--eval-episodes", type=int, default=10, help="with --seeds: deterministic evaluation")


def run(args: argparse.Namespace) -> int:
    from modelicagym.sb3_train import PRESETS

    presets = [p for (env, algorithm), p in PRESETS.items() if env in args.models and algorithm in args.algorithms]
    if not presets:
        raise SeedRunError(f"no preset for models {args.models} and algorithms {args.algorithms}")
    load_before = os.getloadavg()
    jobs = [(p.env, p.algorithm, seed) for p in presets for seed in range(args.seeds)]
    with ThreadPoolExecutor(max_workers=max(1, args.jobs)) as executor:
        runs = list(executor.map(lambda job: run_one(*job, args.budget, args.eval_episodes), jobs))
    budgets = {(p.env, p.algorithm): args.budget or p.budget for p in presets}
    summaries = summarize(runs, budgets)
    data = conditions(load_before, args.jobs)
    print(f"{args.seeds} seeds per preset; solved: the mean return (pendulum) or length (cart-pole) of the last 20 "
          "training episodes reaching the goal within the budget; steps and seconds to solve over the seeds that "
          "solved; evaluation: the deterministic policy's mean return, all seeds; median [min, max]")
    print(table(summaries, runs))
    load = data["load_average"]
    print(f"\ncores: {data['cores']}; load average (1 min) before {load['before'][0]:.2f}, after "
          f"{load['after'][0]:.2f}; {THREADS} torch thread per run, {args.jobs} runs at once; "
          + ", ".join(f"{k} {v}" for k, v in data["versions"].items()))
    path = write_json(args.json or "bench-results/training-seeds.json", {**data, "summaries": summaries, "runs": runs})
    print(f"wrote {path}")
    return 0


def _main() -> None:
    """A run's process: train one preset with one seed, print its summary as the last line."""
    import torch

    from modelicagym.sb3_train import preset, train

    env, algorithm, seed, budget, eval_episodes = sys.argv[1:6]
    torch.set_num_threads(THREADS)
    result = train(preset(env, algorithm), int(seed), budget=int(budget) or None, eval_episodes=int(eval_episodes))
    print(json.dumps(result.summary()))


if __name__ == "__main__":
    _main()
