"""Train a policy on your own FMU, end to end: a task file in, a policy, its learning curve and a
video of it out.

The task file is Python: the config ``modelicagym info MY.fmu`` prints, pasted, plus a reward and
a termination written in it (``modelicagym sample heater`` writes one, ``heater_task.py``, beside
its FMU; docs/train-own-fmu.md goes through it step by step). Its ``fmu`` path, when relative, is
relative to the task file's folder (`modelicagym.task`). This script:

1. makes a pool of the FMU's envs (``modelicagym.make_vec``) and trains Stable-Baselines3's SAC
   (or PPO, ``--algo ppo``) on it, recording every episode's return;
2. saves the policy (``policy.zip``) and the observation normalization it learned with
   (``normalize.pkl``), then loads both back, as you would later;
3. evaluates the loaded policy on ``--eval-episodes`` episodes of a single env that records its
   strip chart (``render_mode="rgb_array"``), against random actions and the task file's
   ``baseline`` controller (if it defines one) on the same starts, prints one table of the three, and saves
   the first episode as an animated GIF of at most ``--gif-frames`` frames (a frame every few
   steps, the last one always: drawing is what costs, not stepping; ``--gif-frames 0``: no GIF).
   Pillow makes it, which matplotlib already brings: Gymnasium's ``RecordVideo`` would need
   moviepy and an ffmpeg binary for an MP4;
4. writes the learning curve (``learning_curve.csv``, ``learning_curve.png``, with the random
   actions' mean return as a dashed line; when no training episode ended, the picture and a
   printed line say so) and ``run.json`` last (steps, wall time, returns, and each file's size
   and SHA-256).

Every file goes into ``--out`` under a temporary name and is renamed into place when whole.

Run (in a folder of your own inside the repository's, on the sample heater; see docs/train-own-fmu.md)::

    modelicagym sample heater
    python ../examples/train_own_fmu.py heater_task.py --out runs

(needs ``pip install torch==2.13.0`` for a CPU-only torch, then ``pip install "modelicagym[rl,plots]"``).
"""

import argparse
import csv
import hashlib
import json
import pickle
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch
from PIL import Image
from stable_baselines3 import PPO, SAC
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

import modelicagym
from modelicagym import FMUEnv
from modelicagym.console import add_debug_flag, run_command
from modelicagym.disk import atomic_write
from modelicagym.errors import ConfigError
from modelicagym.experiments.plots import plot_learning_curve
from modelicagym.sb3 import SB3VecEnv, folderless_logger
from modelicagym.task import read_task_file

#: each algorithm's class and settings: SAC learns a small control task in a few thousand steps
#: (one gradient step per env step; a learning rate of 1e-3, as RL Zoo's for Pendulum, rather than
#: SB3's 3e-4: on the drive sample's setpoint task it comes within 12-17% of the PI in 20,000 steps, where 3e-4
#: left 18-24%, and the heater does as well); PPO needs more steps but each costs less
ALGORITHMS = {
    "sac": (SAC, dict(learning_starts=500, batch_size=256, gamma=0.95, train_freq=1, learning_rate=1e-3,
                      gradient_steps=-1,  # one gradient step per env step, whatever the number of envs
                      policy_kwargs=dict(net_arch=[64, 64]))),
    "ppo": (PPO, dict(n_steps=256, batch_size=64, n_epochs=10, learning_rate=1e-3, gamma=0.95, gae_lambda=0.95,
                      policy_kwargs=dict(net_arch=[64, 64]))),
}


def read_task(path):
    """The ``config`` dict and ``baseline`` controller (or None) of the task file ``path`` (Python,
    run as a script; ``fmu`` relative to its folder), checked to end its episodes."""
    task = read_task_file(path)
    if not task.config.get("max_episode_steps"):
        raise ConfigError(f"{path}: the config sets no max_episode_steps: an episode would never end")
    return task.config, task.baseline


def make_model(algorithm, envs, seed, settings):
    """``algorithm`` (SAC or PPO) on ``envs``, with the policy their spaces need."""
    if algorithm is SAC and not isinstance(envs.action_space, gym.spaces.Box):
        raise ConfigError(f"SAC acts on float inputs (a Box action space); this FMU's actions are "
                          f"{envs.action_space}: train it with --algo ppo")
    policy = "MultiInputPolicy" if isinstance(envs.observation_space, gym.spaces.Dict) else "MlpPolicy"
    model = algorithm(policy, envs, seed=seed, device="cpu", **settings)
    model.set_logger(folderless_logger(model.verbose))  # SB3's default logger leaves a /tmp/SB3-<date> folder
    return model


class EpisodeLog(BaseCallback):
    """Records every finished training episode: (env steps, seconds, return, length)."""

    def __init__(self):
        super().__init__()
        self.rows = []
        self.started = time.perf_counter()

    def _on_step(self):
        for info in self.locals["infos"]:
            if "episode" in info:  # VecMonitor's record of an episode that just ended
                seconds = time.perf_counter() - self.started
                self.rows.append((self.num_timesteps, round(seconds, 3), info["episode"]["r"], info["episode"]["l"]))
                if len(self.rows) % 20 == 0:
                    recent = np.mean([row[2] for row in self.rows[-20:]])
                    print(f"{self.num_timesteps:>8} steps  {seconds:6.1f} s  mean return of the last 20 episodes "
                          f"{recent:9.2f}")
        return True


def run_episode(env, act, seed, frames=None, every=1, start=None):
    """One episode of ``env`` with ``act(observation) -> action`` (``start()`` called after the
    reset, if given); its return. With ``frames`` (a list), the strip chart is drawn into it every
    ``every`` steps and at the episode's end."""
    observation, _ = env.reset(seed=seed)
    if start is not None:
        start()
    total, done, steps = 0.0, False, 0
    while not done:
        observation, reward, terminated, truncated, _ = env.step(act(observation))
        total += reward
        steps += 1
        done = terminated or truncated
        if frames is not None and (done or steps % every == 0):
            frames.append(env.render())
    return total


def save_gif(frames, path, fps):
    """The frames as an animated GIF at ``path``, ``fps`` frames a second, looping."""
    images = [Image.fromarray(frame) for frame in frames]
    with atomic_write(path, "wb") as f:
        images[0].save(f, format="GIF", save_all=True, append_images=images[1:], duration=round(1000 / fps), loop=0)


def gif_every(length, frames):
    """Draw a frame every this many steps, so that an episode of up to ``length`` steps gives at most
    ``frames`` frames, its last step among them (0: no frames)."""
    if frames <= 1:
        return frames and length + 1  # the last step's frame alone, or none
    return -(-length // (frames - 1))


def no_curve_reason(config, args):
    """Why no training episode ended, and what to change, in one line."""
    length = config["max_episode_steps"]
    return (f"no training episode ended in {args.steps} steps: an episode lasts up to {length} steps on each of "
            f"{args.envs} envs, so at least {length * args.envs} steps are needed; train longer (--steps) or "
            "shorten the episodes (max_episode_steps)")


def evaluation_table(results, seeds):
    """The lines of the evaluation's table: each controller's mean, lowest and highest return."""
    lines = [f"evaluation on {len(seeds)} episodes (the same seeds, {seeds[0]}..{seeds[-1]}, for each):",
             f"  {'controller':<24}{'mean return':>12}{'lowest':>12}{'highest':>12}"]
    lines += [f"  {name:<24}{np.mean(returns):>12.2f}{np.min(returns):>12.2f}{np.max(returns):>12.2f}"
              for name, returns in results.items()]
    return lines


def save_curve(rows, path):
    with atomic_write(path, "w") as f:
        writer = csv.writer(f)
        writer.writerow(["env_steps", "seconds", "episode_return", "episode_length"])
        writer.writerows(rows)


def train(args):
    torch.set_num_threads(args.threads)  # the FMUs use the other cores
    config, baseline = read_task(args.task)
    out = Path(args.out)
    algorithm, settings = ALGORITHMS[args.algo]

    # 1. Train on a pool of the FMU's envs (same-step autoreset: what SB3 expects).
    pool = modelicagym.make_vec(config, n=args.envs, autoreset_mode="SameStep")
    envs = VecNormalize(VecMonitor(SB3VecEnv(pool)), norm_reward=False)
    print(f"{Path(config['fmu']).name}: {args.algo.upper()} on {args.envs} envs in the pool, {args.steps} steps")
    try:
        model = make_model(algorithm, envs, args.seed, settings)
        log = EpisodeLog()
        model.learn(args.steps, callback=log)
    finally:
        envs.close()
    seconds = time.perf_counter() - log.started
    print(f"trained {model.num_timesteps} steps in {seconds:.1f} s, {len(log.rows)} episodes")

    # 2. Save the policy and the observation statistics it was trained with; load them back.
    with atomic_write(out / "policy.zip", "wb") as f:
        model.save(f)
    with atomic_write(out / "normalize.pkl", "wb") as f:
        pickle.dump(envs, f)  # what VecNormalize.save writes; VecNormalize.load reads it
    policy = algorithm.load(out / "policy.zip", device="cpu")
    with open(out / "normalize.pkl", "rb") as f:
        normalize = pickle.load(f)

    def act(observation):
        return policy.predict(normalize.normalize_obs(observation), deterministic=True)[0]

    # 3. Evaluate it on one env that records its strip chart; film the first episode in a few frames.
    env = FMUEnv(config, render_mode="rgb_array")
    every = gif_every(config["max_episode_steps"], args.gif_frames)
    try:
        frames = []
        seeds = [10_000 + i for i in range(args.eval_episodes)]
        returns = [run_episode(env, act, seed=seed, frames=frames if i == 0 and every else None, every=every)
                   for i, seed in enumerate(seeds)]
        env.action_space.seed(args.seed)
        random_returns = [run_episode(env, lambda _: env.action_space.sample(), seed=seed) for seed in seeds]
        baseline_returns = None if baseline is None else [
            run_episode(env, baseline.act, seed=seed, start=baseline.reset) for seed in seeds]
    finally:
        env.close()
    results = {f"trained policy ({args.algo.upper()})": returns, "random actions": random_returns}
    if baseline_returns is not None:
        results["the task's baseline"] = baseline_returns
    print("\n".join(evaluation_table(results, seeds)))
    if frames:
        save_gif(frames, out / "evaluation.gif", args.fps)

    # 4. The learning curve, and run.json last: what was run, what came out, which files.
    save_curve(log.rows, out / "learning_curve.csv")
    curve = [(row[0], *np.mean([recent[2:] for recent in log.rows[max(0, i - 19):i + 1]], axis=0))
             for i, row in enumerate(log.rows)]  # the mean return and length of the last 20 episodes
    if not curve:
        print(no_curve_reason(config, args))
    plot_learning_curve(curve, out / "learning_curve.png", f"{args.algo.upper()} on {Path(config['fmu']).name}, "
                        "last 20 episodes", reference=("random actions", float(np.mean(random_returns))),
                        empty=no_curve_reason(config, args))
    files = {path.name: {"bytes": path.stat().st_size, "sha256": hashlib.sha256(path.read_bytes()).hexdigest()}
             for path in sorted(out.iterdir()) if path.is_file() and not path.name.startswith(".") and path.name != "run.json"}
    summary = {
        "task": str(args.task), "fmu": str(config["fmu"]), "algorithm": args.algo, "envs": args.envs, "seed": args.seed,
        "env_steps": model.num_timesteps, "seconds": round(seconds, 1), "training_episodes": len(log.rows),
        "evaluation_returns": returns, "random_returns": random_returns, "baseline_returns": baseline_returns,
        "gif_frames": len(frames),
        "gif_every": every, "files": files,
    }
    with atomic_write(out / "run.json", "w") as f:
        json.dump(summary, f, indent=2)
    print(f"saved {', '.join(files)} and run.json to {out}")
    return 0


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("task", help="the task file: a Python file defining config = {...} (`modelicagym sample heater` "
                                     "writes one)")
    parser.add_argument("--out", required=True, help="the folder for the policy, curve, GIF and run.json")
    parser.add_argument("--algo", default="sac", choices=list(ALGORITHMS))
    parser.add_argument("--steps", type=int, default=5000, help="env steps to train (default: 5000)")
    parser.add_argument("--envs", type=int, default=4, help="envs stepped in parallel (default: 4)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--eval-episodes", type=int, default=5,
                        help="episodes the saved policy and random actions are evaluated on (default: 5)")
    parser.add_argument("--gif-frames", type=int, default=40,
                        help="at most this many frames of the first evaluation episode in evaluation.gif, a frame "
                             "every few steps (default: 40; 0: no GIF)")
    parser.add_argument("--fps", type=float, default=10.0, help="frames a second of the GIF (default: 10)")
    parser.add_argument("--threads", type=int, default=1, help="torch threads (default: 1)")
    add_debug_flag(parser)
    args = parser.parse_args()
    if args.eval_episodes < 1 or args.envs < 1 or args.steps < 1 or args.fps <= 0 or args.gif_frames < 0:
        parser.error("--steps, --envs and --eval-episodes take at least 1, --gif-frames at least 0, --fps more than 0")
    return run_command(train, args)


if __name__ == "__main__":
    sys.exit(main())
