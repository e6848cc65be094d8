"""Seeded Stable-Baselines3 runs on the pool: the presets that solve our tasks, and one run of them.

A `Preset` holds everything a run needs to be repeated: the algorithm (PPO or SAC) and its
settings, the number of envs in the pool, the env step budget, the episode length and when the
task counts as solved (the mean episode length or return of the last 20 training episodes reaching
a goal). `train` runs one preset with one seed until it is solved or the budget is spent, then
evaluates the deterministic policy. The examples (``examples/sb3_ppo.py``, ``examples/sb3_sac.py``)
and ``modelicagym bench training --seeds N`` share them, so the figures in the documentation
(docs/training.md) come from the code a user runs.

The same preset, seed and torch thread count give the same learning curve on one machine (the
pool's results depend only on the seeds and actions; SB3 seeds torch, NumPy and the envs).
Another machine may differ: torch's CPU kernels, BLAS and the thread count change float rounding,
and RL training amplifies any difference.

Needs the ``rl`` extra; ``import modelicagym`` never imports this module.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

import modelicagym
from modelicagym.errors import ArgumentError
from modelicagym.sb3 import SB3VecEnv, folderless_logger

__all__ = ["PRESETS", "Preset", "Run", "preset", "train"]

logger = logging.getLogger(__name__)

#: how many of the last training episodes the solved criterion and the learning curve average
WINDOW = 20


@dataclass(frozen=True)
class Preset:
    """One algorithm's settings for one registered env, and when that env counts as solved."""

    env: str
    algorithm: str  # "ppo" or "sac"
    settings: dict[str, Any]
    envs: int
    budget: int
    max_episode_steps: int
    measure: str  # "length" or "return": of the last WINDOW training episodes
    goal: float
    normalize: bool = False  # observations through VecNormalize
    policy_kwargs: dict[str, Any] = field(default_factory=dict)

    def with_settings(self, **settings: Any) -> Preset:
        """This preset with some algorithm settings changed (tests use shorter rollouts)."""
        return replace(self, settings={**self.settings, **settings})


_CARTPOLE_PPO = {"n_steps": 32, "batch_size": 256, "n_epochs": 20, "learning_rate": 1e-3, "gamma": 0.995,
                 "gae_lambda": 0.95}

#: (env, algorithm) -> preset. The pendulum's are RL Baselines3 Zoo's Pendulum-v1 settings (our
#: task is Pendulum-v1 on a motor drive): PPO with gSDE on 4 envs, SAC with a 1e-3 learning rate,
#: here collecting from 4 envs with 2 gradient steps per vector step of 4 env steps (the zoo does one
#: per env step; half as many halve the time of the updates, the cost of SAC on 2 cores).
PRESETS: dict[tuple[str, str], Preset] = {
    ("cartpole", "ppo"): Preset("cartpole", "ppo", _CARTPOLE_PPO, envs=8, budget=200_000, max_episode_steps=500,
                                measure="length", goal=475, normalize=True),
    ("cartpole-continuous", "ppo"): Preset(  # forces of +-15 N: the policy starts exploring with a std of ~7 N
        "cartpole-continuous", "ppo", _CARTPOLE_PPO, envs=8, budget=300_000, max_episode_steps=500,
        measure="length", goal=475, normalize=True, policy_kwargs={"log_std_init": 2.0}),
    ("pendulum", "ppo"): Preset(
        "pendulum", "ppo", {"n_steps": 1024, "batch_size": 64, "n_epochs": 10, "learning_rate": 1e-3, "gamma": 0.9,
                            "gae_lambda": 0.95, "clip_range": 0.2, "ent_coef": 0.0, "use_sde": True,
                            "sde_sample_freq": 4},
        envs=4, budget=200_000, max_episode_steps=200, measure="return", goal=-200),
    ("pendulum", "sac"): Preset(
        "pendulum", "sac", {"learning_rate": 1e-3, "train_freq": 1, "gradient_steps": 2, "learning_starts": 1000},
        envs=4, budget=50_000, max_episode_steps=200, measure="return", goal=-200),
}


def preset(env: str, algorithm: str) -> Preset:
    """The preset of ``algorithm`` on ``env``; a clear error for a pair that has none."""
    try:
        return PRESETS[env, algorithm]
    except KeyError:
        known = ", ".join(f"{e} ({a})" for e, a in PRESETS)
        raise ArgumentError(f"no {algorithm} preset for env {env!r}; presets: {known}") from None


@dataclass
class Run:
    """What one seeded run did: its learning curve ``(env steps, mean return, mean length)`` of the
    last WINDOW episodes after every episode end, when it was solved (``None``: not within the
    budget), how long it trained, and the deterministic policy's evaluation returns."""

    env: str
    algorithm: str
    seed: int
    curve: list[tuple[int, float, float]]
    solved_steps: int | None
    solved_seconds: float | None
    steps: int
    seconds: float
    eval_returns: list[float]
    model: Any = field(default=None, repr=False)

    def summary(self) -> dict[str, Any]:
        """The run without its model, for JSON."""
        return {key: value for key, value in vars(self).items() if key != "model"}


def train(spec: Preset, seed: int, *, envs: int | None = None, budget: int | None = None,
          max_episode_steps: int | None = None, eval_episodes: int = 10,
          on_point: Callable[[int, float, float, float], None] | None = None) -> Run:
    """Train ``spec`` with ``seed`` on a pool of ``envs`` envs (default: the preset's) until solved or
    ``budget`` env steps, then evaluate the deterministic policy for ``eval_episodes`` episodes.

    ``on_point(steps, seconds, mean_return, mean_length)`` sees every point of the learning curve.
    Set torch's thread count before calling: it changes the floats, so the curve.
    """
    from stable_baselines3 import PPO, SAC
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.evaluation import evaluate_policy
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

    algorithms = {"ppo": PPO, "sac": SAC}
    if spec.algorithm not in algorithms:
        raise ArgumentError(f"preset algorithm {spec.algorithm!r}: one of {', '.join(algorithms)}")
    envs = envs or spec.envs
    pool = modelicagym.make_vec(spec.env, n=envs, max_episode_steps=max_episode_steps or spec.max_episode_steps,
                                autoreset_mode="SameStep")
    venv: Any = VecMonitor(SB3VecEnv(pool))
    if spec.normalize:
        venv = VecNormalize(venv, norm_reward=False)
    index = {"return": 1, "length": 2}[spec.measure]

    class Curve(BaseCallback):
        """Records the curve at every episode end and stops training once the goal is reached."""

        def __init__(self) -> None:
            super().__init__()
            self.episodes: list[tuple[float, float]] = []
            self.curve: list[tuple[int, float, float]] = []
            self.solved: tuple[int, float] | None = None
            self.started = 0.0

        def _on_training_start(self) -> None:
            self.started = time.perf_counter()

        def _on_step(self) -> bool:
            ended = [info["episode"] for info in self.locals["infos"] if "episode" in info]
            if not ended:
                return True
            self.episodes += [(float(e["r"]), float(e["l"])) for e in ended]
            recent = np.array(self.episodes[-WINDOW:])
            point = (self.num_timesteps, float(recent[:, 0].mean()), float(recent[:, 1].mean()))
            self.curve.append(point)
            elapsed = time.perf_counter() - self.started
            if on_point is not None:
                on_point(point[0], elapsed, point[1], point[2])
            if len(recent) == WINDOW and point[index] >= spec.goal:
                self.solved = (self.num_timesteps, elapsed)
                return False
            return True

    curve = Curve()
    try:
        model = algorithms[spec.algorithm]("MlpPolicy", venv, seed=seed, device="cpu", policy_kwargs=spec.policy_kwargs,
                                           **spec.settings)
        model.set_logger(folderless_logger(model.verbose))
        model.learn(budget or spec.budget, callback=curve)
        seconds = time.perf_counter() - curve.started
        if spec.normalize:
            venv.training = False
        returns, _ = evaluate_policy(model, venv, n_eval_episodes=eval_episodes, return_episode_rewards=True)
    finally:
        venv.close()
    solved_steps, solved_seconds = curve.solved if curve.solved else (None, None)
    logger.info("%s %s seed %d: %s after %d steps, %.1f s; evaluation %.1f", spec.env, spec.algorithm, seed,
                "solved" if curve.solved else "not solved", model.num_timesteps, seconds, np.mean(returns))
    return Run(spec.env, spec.algorithm, seed, curve.curve, solved_steps, solved_seconds, model.num_timesteps,
               seconds, [float(r) for r in returns], model)
