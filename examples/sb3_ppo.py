"""Train Stable-Baselines3's PPO on FMU environments stepped by the modelicagym pool.

The pool (``modelicagym.make_vec``) runs the FMUs in worker processes and the calling process;
``SB3VecEnv`` gives it SB3's VecEnv API. With the defaults it solves the Cart-Pole (mean episode
length >= 475 of 500) in about a minute on 2 cores, then evaluates the policy and saves a
learning-curve plot. ``--env cartpole-continuous`` (a force action) or ``--env pendulum`` (the
motor-driven swing-up, a costlier FMU) train a continuous-action policy on the same script.

Run: ``python examples/sb3_ppo.py [--env cartpole] [--envs 8] [--steps 200000]``
(needs ``pip install torch==2.13.0`` for a CPU-only torch, then ``pip install "modelicagym[rl,plots]"``).
"""

import argparse
import time

import numpy as np
import torch
from stable_baselines3 import PPO
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.evaluation import evaluate_policy
from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

import modelicagym
from modelicagym.experiments.plots import plot_learning_curve
from modelicagym.sb3 import SB3VecEnv, folderless_logger

#: per env: the PPO settings that learn it, the step budget, the episode length, and when it counts
#: as solved: the mean episode length or return of the last 20 episodes reaching a target
PRESETS = {
    "cartpole": dict(
        steps=200_000, max_episode_steps=500, target=("length", 475),
        ppo=dict(n_steps=32, batch_size=256, n_epochs=20, learning_rate=1e-3, gamma=0.995, gae_lambda=0.95),
    ),
    "cartpole-continuous": dict(  # forces of +-15 N: the policy starts exploring with a std of ~7 N
        steps=300_000, max_episode_steps=500, target=("length", 475),
        ppo=dict(n_steps=32, batch_size=256, n_epochs=20, learning_rate=1e-3, gamma=0.995, gae_lambda=0.95,
                 policy_kwargs=dict(log_std_init=2.0)),
    ),
    "pendulum": dict(  # the baseline controller (EnergySwingUp) averages a return of about -140
        steps=300_000, max_episode_steps=200, target=("return", -200),
        ppo=dict(n_steps=512, batch_size=64, n_epochs=10, learning_rate=1e-3, gamma=0.9, gae_lambda=0.95,
                 use_sde=True, sde_sample_freq=4),
    ),
}


class Progress(BaseCallback):
    """Prints progress after every few rollouts, records the learning curve, and stops training
    once the mean length or return of the last 20 episodes reaches the target."""

    def __init__(self, target, every):
        super().__init__()
        self.target, self.every = target, every
        self.curve = []  # (env steps, mean episode return, mean episode length) after each rollout
        self.started = time.perf_counter()
        self.rollouts = 0

    def _on_step(self):
        return True

    def _on_rollout_end(self):
        self.rollouts += 1
        episodes = self.model.ep_info_buffer
        if not episodes:
            return
        recent = list(episodes)[-20:]
        mean_return, mean_length = np.mean([e["r"] for e in recent]), np.mean([e["l"] for e in recent])
        self.curve.append((self.num_timesteps, mean_return, mean_length))
        elapsed = time.perf_counter() - self.started
        if self.rollouts % self.every == 0:
            print(f"{self.num_timesteps:>8} steps  {elapsed:6.1f} s  {self.num_timesteps / elapsed:8.0f} steps/s  "
                  f"mean return {mean_return:8.1f}  mean length {mean_length:6.1f}")
        measure, goal = self.target
        if len(recent) == 20 and {"length": mean_length, "return": mean_return}[measure] >= goal:
            self.model.solved_at = (self.num_timesteps, elapsed)

    def _on_rollout_start(self):
        if getattr(self.model, "solved_at", None):
            raise StopTraining


class StopTraining(Exception):
    """Raised between rollouts once the target is reached (SB3 checks callbacks only per step)."""


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--env", default="cartpole", choices=list(PRESETS))
    parser.add_argument("--envs", type=int, default=8, help="environments stepped in parallel")
    parser.add_argument("--steps", type=int, help="env step budget (default: the env's preset)")
    parser.add_argument("--max-episode-steps", type=int, help="default: the env's preset")
    parser.add_argument("--threads", type=int, default=1, help="torch threads (the envs use the other cores)")
    parser.add_argument("--eval-episodes", type=int, default=10)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--plot", default="sb3_ppo.png", help="where to save the learning curve")
    args = parser.parse_args()
    preset = PRESETS[args.env]
    torch.set_num_threads(args.threads)

    max_episode_steps = args.max_episode_steps or preset["max_episode_steps"]
    pool = modelicagym.make_vec(args.env, n=args.envs, max_episode_steps=max_episode_steps, autoreset_mode="SameStep")
    envs = VecNormalize(VecMonitor(SB3VecEnv(pool)), norm_reward=False)
    print(f"{args.env}: {args.envs} envs, {pool.layout}")
    model = PPO("MlpPolicy", envs, seed=args.seed, device="cpu", **preset["ppo"])
    model.set_logger(folderless_logger(model.verbose))  # SB3's default logger makes a /tmp/SB3-<date> folder
    progress = Progress(preset["target"], every=max(1, 2048 // (args.envs * preset["ppo"]["n_steps"])))
    try:
        model.learn(args.steps or preset["steps"], callback=progress)
    except StopTraining:
        pass
    solved = getattr(model, "solved_at", None)
    if solved:
        measure, goal = preset["target"]
        print(f"solved: mean episode {measure} >= {goal} after {solved[0]} steps, {solved[1]:.1f} s")
    else:
        print(f"not solved within {model.num_timesteps} steps")

    envs.training = False
    returns, lengths = evaluate_policy(model, envs, n_eval_episodes=args.eval_episodes, return_episode_rewards=True)
    print(f"evaluation: {len(returns)} episodes, mean return {np.mean(returns):.1f}, "
          f"mean length {np.mean(lengths):.1f}")
    if progress.curve:
        if plot_learning_curve(progress.curve, args.plot, f"PPO (Stable-Baselines3) on {args.env}, last 20 episodes"):
            print(f"saved the learning curve to {args.plot}")
    envs.close()


if __name__ == "__main__":
    main()
