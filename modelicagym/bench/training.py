"""End-to-end PPO training on every vector env a user could pick, and where its time goes.

For each model (the light cart-pole, ~1 µs of FMU work a step; the motor-driven pendulum swing-up,
~0.4 ms) and each torch thread count (torch's default, and one thread), one run trains
Stable-Baselines3's PPO (``examples/sb3_ppo.py``'s settings for that model, the same for every
candidate) on n envs stepped by:

* ``pool``: ``modelicagym.make_vec`` through `modelicagym.sb3.SB3VecEnv` (same-step autoreset);
* ``sync`` / ``async``: Gymnasium's ``SyncVectorEnv`` / ``AsyncVectorEnv`` through the same adapter;
* ``dummy`` / ``subproc``: SB3's own ``DummyVecEnv`` / ``SubprocVecEnv``;

interleaved over several rounds of a fixed step budget, and reports the median training steps per
second and how a round's time splits: stepping the envs, the policy during rollouts, the PPO
update. With ``--solve`` it also trains each candidate on each model until it is solved (the
cart-pole: a mean episode length of the last 20 episodes of 475; the pendulum: a mean return of
-200), and reports the wall time. With ``--seeds N`` it instead trains every preset of
`modelicagym.sb3_train` (PPO and SAC) with N seeds until solved: see `training_seeds`.

Targets (2 cores): on the heavy model at n=8, the pool >= 1.2x ``dummy`` and
``sync``, and >= 1.5x ``subproc``, in training steps per second.
"""

from __future__ import annotations

import argparse
import logging
import os
import time
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode

import modelicagym
from modelicagym.bench import conditions, format_table, median, training_seeds, write_json
from modelicagym.registry import ENVIRONMENTS, EnvFactory

logger = logging.getLogger(__name__)



#: the models trained: `modelicagym.sb3_train`'s PPO preset of each (``examples/sb3_ppo.py``'s)
MODELS = ("cartpole", "pendulum")
CANDIDATES = ("pool", "sync", "async", "dummy", "subproc")


def _preset(model: str) -> Any:
    from modelicagym.sb3_train import preset

    return preset(model, "ppo")


def make_candidate(candidate: str, model: str, n: int) -> Any:
    """The SB3 ``VecEnv`` of ``candidate`` over ``n`` envs of ``model``."""
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    from modelicagym.sb3 import SB3VecEnv

    spec = _preset(model)
    options = {"max_episode_steps": spec.max_episode_steps}
    fns = [EnvFactory(ENVIRONMENTS[spec.env][1], options) for _ in range(n)]
    if candidate == "pool":
        return SB3VecEnv(modelicagym.make_vec(spec.env, n=n, autoreset_mode=AutoresetMode.SAME_STEP, **options))
    if candidate == "sync":
        return SB3VecEnv(gym.vector.SyncVectorEnv(fns, autoreset_mode=AutoresetMode.SAME_STEP))
    if candidate == "async":
        return SB3VecEnv(gym.vector.AsyncVectorEnv(fns, shared_memory=True, autoreset_mode=AutoresetMode.SAME_STEP))
    if candidate == "dummy":
        return DummyVecEnv(fns)
    return SubprocVecEnv(fns, start_method="forkserver")


class _Split:
    """Times a training run's parts: the envs' steps (a VecEnv wrapper), the rollouts, the updates."""

    def __init__(self) -> None:
        self.env = self.rollout = 0.0

    def wrap(self, venv: Any) -> Any:
        from stable_baselines3.common.vec_env import VecEnvWrapper

        split = self

        class Timed(VecEnvWrapper):
            def reset(self) -> Any:
                return self.venv.reset()

            def step_wait(self) -> Any:
                started = time.perf_counter()
                result = self.venv.step_wait()
                split.env += time.perf_counter() - started
                return result

        return Timed(venv)

    def callback(self) -> Any:
        from stable_baselines3.common.callbacks import BaseCallback

        split = self

        class Rollouts(BaseCallback):
            def _on_rollout_start(self) -> None:
                self.started = time.perf_counter()

            def _on_rollout_end(self) -> None:
                split.rollout += time.perf_counter() - self.started

            def _on_step(self) -> bool:
                return True

        return Rollouts()


def _trainer(candidate: str, model: str, n: int, steps: int) -> Callable[[], dict[str, float]]:
    """A round: PPO trains ``steps`` more env steps on the candidate; returns its rate and split."""
    from stable_baselines3 import PPO

    from modelicagym.sb3 import folderless_logger

    split = _Split()
    venv = split.wrap(make_candidate(candidate, model, n))
    spec = _preset(model)
    ppo = PPO("MlpPolicy", venv, seed=0, device="cpu", policy_kwargs=spec.policy_kwargs, **spec.settings)
    ppo.set_logger(folderless_logger(ppo.verbose))

    def run() -> dict[str, float]:
        split.env = split.rollout = 0.0
        started = time.perf_counter()
        ppo.learn(steps, callback=split.callback(), reset_num_timesteps=False)
        wall = time.perf_counter() - started
        return {"steps_per_second": steps / wall, "env": split.env / wall,
                "policy": (split.rollout - split.env) / wall, "update": (wall - split.rollout) / wall}

    run.close = venv.close  # type: ignore[attr-defined]
    return run


def measure(model: str, n: int, threads: int | None, repeats: int, steps: int) -> dict[str, Any]:
    """Training steps per second (medians) and the time split of every candidate."""
    import torch

    default_threads = torch.get_num_threads()
    torch.set_num_threads(threads or default_threads)
    runs: dict[str, Any] = {}
    try:
        for candidate in CANDIDATES:
            runs[candidate] = _trainer(candidate, model, n, steps)
            runs[candidate]()  # warm-up: the first rollout also builds the network
        samples: dict[str, list[dict[str, float]]] = {name: [] for name in runs}
        for _ in range(repeats):
            for name, run in runs.items():
                samples[name].append(run())
    finally:
        for run in runs.values():
            run.close()
        torch.set_num_threads(default_threads)
    results = {name: {key: median([s[key] for s in values]) for key in values[0]} for name, values in samples.items()}
    pool = results["pool"]["steps_per_second"]
    return {"model": model, "n": n, "threads": threads or default_threads, "results": results,
            "pool_over": {name: pool / r["steps_per_second"] for name, r in results.items() if name != "pool"}}


def time_to_solve(candidate: str, model: str, n: int, budget: int) -> float | None:
    """Seconds PPO takes on ``candidate`` to solve ``model`` (None: not within ``budget`` steps)."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

    from modelicagym.sb3 import folderless_logger

    spec = _preset(model)
    key = {"length": "l", "return": "r"}[spec.measure]
    venv = VecMonitor(make_candidate(candidate, model, n))
    if spec.normalize:
        venv = VecNormalize(venv, norm_reward=False)

    class Solved(BaseCallback):
        def _on_step(self) -> bool:
            episodes = list(self.model.ep_info_buffer)[-20:]
            return not (len(episodes) == 20 and np.mean([e[key] for e in episodes]) >= spec.goal)

    try:
        ppo = PPO("MlpPolicy", venv, seed=0, device="cpu", policy_kwargs=spec.policy_kwargs, **spec.settings)
        ppo.set_logger(folderless_logger(ppo.verbose))
        started = time.perf_counter()
        ppo.learn(budget, callback=Solved())
        elapsed = time.perf_counter() - started
        return elapsed if ppo.num_timesteps < budget else None
    finally:
        venv.close()


def report(results: list[dict[str, Any]], solves: dict[str, dict[str, float | None]]) -> str:
    rows = []
    for r in results:
        for name in CANDIDATES:
            c = r["results"][name]
            rows.append((r["model"], r["n"], r["threads"], name, f"{c['steps_per_second']:,.0f}",
                         *(f"{100 * c[k]:.0f}%" for k in ("env", "policy", "update")),
                         "-" if name == "pool" else f"{r['pool_over'][name]:.2f}x"))
    table = format_table(("model", "n", "torch threads", "vector env", "training steps/s", "envs", "policy",
                          "update", "pool/this"), rows)
    text = f"PPO training, steps per second and where the time goes:\n{table}"
    if solves:
        goals = ", ".join(f"{model}: mean episode {_preset(model).measure} >= {_preset(model).goal:g}"
                          for model in solves)
        solved = format_table(("model", "vector env", "seconds to solve"),
                              [(model, name, "not solved" if s is None else f"{s:.1f}")
                               for model, times in solves.items() for name, s in times.items()])
        text += f"\n\ntime to solve ({goals}):\n{solved}"
    return text


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--models", nargs="+", default=list(MODELS), choices=list(MODELS))
    parser.add_argument("--n", type=int, nargs="+", default=[8], help="numbers of envs")
    parser.add_argument("--threads", type=int, nargs="+", default=[0, 1],
                        help="torch threads (0: torch's default)")
    parser.add_argument("--repeats", type=int, default=3, help="interleaved rounds (median reported)")
    parser.add_argument("--steps", type=int, default=4096, help="env steps per round and candidate")
    parser.add_argument("--solve", action="store_true", help="also time each candidate to solve each model")
    parser.add_argument("--solve-budget", type=int, default=300_000)
    parser.add_argument("--json", help="where to write the JSON (default: bench-results/training.json, "
                        "with --seeds bench-results/training-seeds.json)")
    parser.add_argument("--seeds", type=int, default=0,
                        help="train every preset with seeds 0..N-1 until solved instead (see training_seeds.py)")
    training_seeds.add_arguments(parser)


def run(args: argparse.Namespace) -> int:
    if args.seeds:
        return training_seeds.run(args)
    load_before = os.getloadavg()
    results = []
    for model in args.models:
        for n in args.n:
            for threads in args.threads:
                logger.info("measuring %s, n=%d, %s torch threads", model, n, threads or "default")
                results.append(measure(model, n, threads or None, args.repeats, args.steps))
    solves = {model: {name: time_to_solve(name, model, max(args.n), args.solve_budget) for name in CANDIDATES}
              for model in args.models} if args.solve else {}
    line, data = conditions(load_before, args.repeats, float("nan"))
    print(report(results, solves))
    print(f"\n{line.split('; medians')[0]}; medians of {args.repeats} interleaved rounds of {args.steps} env steps")
    print(f"wrote {write_json(args.json or 'bench-results/training.json', {**data, 'results': results, 'seconds_to_solve': solves})}")
    return 0
