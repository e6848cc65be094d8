"""Roll out many Cart-Pole episodes on the multi-process pool and save the trajectories.

A policy — random, or the greedy policy of a Q-table saved by ``QLearningAgent.save`` (e.g. one
trained by ``examples/train_qlearning.py``) — drives ``--envs`` FMU environments in parallel
until ``--episodes`` episodes have finished. Every transition is recorded; the result is one
compressed ``.npz`` with a row per step (env, episode, step, observation, action, reward, flags)
and a summary is printed at the end.

Run: ``python examples/batch_rollout.py --episodes 200 --envs 8 [--q-table agent.npz] --out rollout.npz``
"""

import argparse
import os
import tempfile
import time

import numpy as np

import modelicagym
from modelicagym.agents import EpisodeTracker

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--episodes", type=int, default=100, help="episodes to finish in total")
parser.add_argument("--envs", type=int, default=8, help="environments stepped in parallel")
parser.add_argument("--max-steps", type=int, default=500, help="steps after which an episode is truncated")
parser.add_argument("--q-table", help="a saved QLearningAgent (.npz): act greedily with its first Q-table")
parser.add_argument("--out", default="rollout.npz", help="where to write the trajectories")
parser.add_argument("--seed", type=int, default=0)


def make_policy(q_table_path, envs, seed):
    """``observations -> actions`` for the whole batch."""
    if q_table_path is None:
        envs.action_space.seed(seed)
        return lambda observations: envs.action_space.sample()
    from modelicagym.agents import QLearningAgent

    agent = QLearningAgent.load(q_table_path)
    q_table = agent.q_table[0]
    return lambda observations: q_table[agent.discretizer.states(observations)].argmax(axis=1)


def main():
    args = parser.parse_args()
    envs = modelicagym.make_vec("cartpole", n=args.envs, max_episode_steps=args.max_steps)
    policy = make_policy(args.q_table, envs, args.seed)
    try:
        from tqdm import tqdm
        progress = tqdm(total=args.episodes, unit="episode")
    except ImportError:
        progress = None

    columns = {name: [] for name in ("env", "episode", "step", "observation", "action", "reward",
                                     "terminated", "truncated")}
    episode_of_env = np.arange(args.envs)          # episode numbers are handed out in order
    next_episode = args.envs
    tracker = EpisodeTracker(args.envs)            # skips the autoreset steps, counts the episodes
    lengths, returns = [], []

    started = time.perf_counter()
    observations, _ = envs.reset(seed=args.seed)
    while len(lengths) < args.episodes:
        actions = policy(observations)
        next_observations, rewards, terminations, truncations, _ = envs.step(actions)
        recorded = tracker.live(episode_of_env < args.episodes)
        for name, value in (("env", np.arange(args.envs)), ("episode", episode_of_env), ("step", tracker.length),
                            ("observation", observations), ("action", actions), ("reward", rewards),
                            ("terminated", terminations), ("truncated", truncations)):
            columns[name].append(np.asarray(value)[recorded])
        ended, ended_lengths, ended_returns = tracker.update(recorded, rewards, terminations, truncations)
        lengths += ended_lengths.tolist()
        returns += ended_returns.tolist()
        if progress is not None:
            progress.update(len(ended))
        episode_of_env[ended] = np.arange(next_episode, next_episode + len(ended))
        next_episode += len(ended)
        observations = next_observations
    elapsed = time.perf_counter() - started
    envs.close()
    if progress is not None:
        progress.close()

    data = {name: np.concatenate(parts) for name, parts in columns.items()}
    directory = os.path.dirname(os.path.abspath(args.out))
    with tempfile.NamedTemporaryFile(dir=directory, suffix=".npz", delete=False) as handle:
        np.savez_compressed(handle, **data)  # written next to the target, then renamed: never half-written
    os.replace(handle.name, args.out)

    steps = len(data["reward"])
    print(f"{len(lengths)} episodes, {steps} steps on {args.envs} envs in {elapsed:.2f} s "
          f"({steps / elapsed:,.0f} steps/s)")
    print(f"episode length: mean {np.mean(lengths):.1f}, min {min(lengths)}, max {max(lengths)}; "
          f"return: mean {np.mean(returns):.1f}")
    print(f"trajectories: {args.out} ({', '.join(f'{k}{list(v.shape)}' for k, v in data.items())})")


if __name__ == "__main__":
    main()
