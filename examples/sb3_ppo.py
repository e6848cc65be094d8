"""Train Stable-Baselines3's PPO on FMU environments stepped by the modelicagym pool.

The pool (``modelicagym.make_vec``) runs the FMUs in worker processes and the calling process;
``SB3VecEnv`` gives it SB3's VecEnv API. The settings, budget and goal of each env are the presets
of ``modelicagym.sb3_train`` (the pendulum's are RL Baselines3 Zoo's Pendulum-v1 PPO: 4 envs,
rollouts of 1024 steps, gamma 0.9, gSDE). Training stops once the mean episode length (cart-pole)
or return (pendulum) of the last 20 episodes reaches the goal; then the deterministic policy is
evaluated and the learning curve saved. ``--env cartpole-continuous`` (a force action) or ``--env
pendulum`` (the motor-driven swing-up, a costlier FMU) train a continuous-action policy on the same
script. A seed gives the same run on one machine; what to expect over seeds is in docs/training.md
(``modelicagym bench training --seeds 5``).

Run: ``python examples/sb3_ppo.py [--env cartpole] [--seed 0] [--envs N] [--steps N]``
(needs ``pip install torch==2.13.0`` for a CPU-only torch, then ``pip install "modelicagym[rl,plots]"``).
"""

import argparse

import numpy as np
import torch

from modelicagym.experiments.plots import plot_learning_curve
from modelicagym.sb3_train import PRESETS, preset, train


def main(algorithm="ppo", title="PPO", description=__doc__):
    envs = sorted({env for env, a in PRESETS if a == algorithm})
    parser = argparse.ArgumentParser(description=description, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--env", default=envs[0], choices=envs)
    parser.add_argument("--envs", type=int, help="environments stepped in parallel (default: the env's preset)")
    parser.add_argument("--steps", type=int, help="env step budget (default: the env's preset)")
    parser.add_argument("--max-episode-steps", type=int, help="default: the env's preset")
    parser.add_argument("--threads", type=int, default=1, help="torch threads (the envs use the other cores)")
    parser.add_argument("--eval-episodes", type=int, default=10)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--plot", default=f"sb3_{algorithm}.png", help="where to save the learning curve")
    parser.add_argument("--save", help="where to save the trained model (SB3's .zip)")
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    spec = preset(args.env, algorithm)
    print(f"{args.env}, {title}, seed {args.seed}: {args.envs or spec.envs} envs, {spec.settings}")

    last = [-1e9]

    def show(steps, seconds, mean_return, mean_length):
        if steps - last[0] >= 4000:
            last[0] = steps
            print(f"{steps:>8} steps  {seconds:6.1f} s  {steps / seconds:8.0f} steps/s  "
                  f"mean return {mean_return:8.1f}  mean length {mean_length:6.1f}", flush=True)

    run = train(spec, args.seed, envs=args.envs, budget=args.steps, max_episode_steps=args.max_episode_steps,
                eval_episodes=args.eval_episodes, on_point=show)
    if run.solved_steps is not None:
        print(f"solved: mean episode {spec.measure} >= {spec.goal:g} after {run.solved_steps} steps, "
              f"{run.solved_seconds:.1f} s")
    else:
        print(f"not solved within {run.steps} steps ({run.seconds:.1f} s)")
    print(f"evaluation: {len(run.eval_returns)} episodes, mean return {np.mean(run.eval_returns):.1f} "
          "(the deterministic policy)")
    if run.curve and plot_learning_curve(run.curve, args.plot, f"{title} (Stable-Baselines3) on {args.env}, "
                                         f"seed {args.seed}, last 20 episodes"):
        print(f"saved the learning curve to {args.plot}")
    if args.save:
        run.model.save(args.save)
        print(f"saved the model to {args.save}")


if __name__ == "__main__":
    main()
