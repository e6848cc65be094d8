"""Train the paper's tabular Q-learning agent on Cart-Pole FMUs, several repeats side by side.

Each of ``--repeats`` envs in the multi-process pool gets its own Q-table and seed, so the repeats
are independent runs that happen to share the machine. Prints the learning curve (mean episode
length per block of episodes) and saves the agent, whose Q-tables ``examples/batch_rollout.py
--q-table`` can replay greedily.

Run: ``python examples/train_qlearning.py --episodes 200 --repeats 5 --out agent.npz``
"""

import argparse
import time

import modelicagym
from modelicagym.agents import Discretizer, QLearningAgent, QLearningConfig, train
from modelicagym.models.cartpole.env import CARTPOLE_INTERVALS

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--episodes", type=int, default=200, help="episodes per repeat")
parser.add_argument("--repeats", type=int, default=5, help="independent runs, one env and Q-table each")
parser.add_argument("--force", type=float, default=15.0, help="push force magnitude [N]")
parser.add_argument("--seed", type=int, default=0)
parser.add_argument("--out", default="agent.npz", help="where to save the trained agent")


def main():
    args = parser.parse_args()
    # The paper's setting: 0.05 s steps, +1 per step, -100 on failure, at most 500 steps an episode.
    envs = modelicagym.make_vec("cartpole", n=args.repeats, force=args.force, max_episode_steps=500)
    agent = QLearningAgent(
        Discretizer(CARTPOLE_INTERVALS, n_bins=10),
        n_actions=2,
        n_envs=args.repeats,
        config=QLearningConfig(learning_rate=0.2, discount=1.0, exploration_rate=0.5, exploration_decay=0.99),
        seeds=[args.seed + r for r in range(args.repeats)],
    )

    started = time.perf_counter()
    log = train(envs, agent, args.episodes, seed=args.seed)
    elapsed = time.perf_counter() - started
    envs.close()

    block = max(1, args.episodes // 10)
    print(f"mean episode length over {args.repeats} repeats, per block of {block} episodes:")
    for first in range(0, args.episodes, block):
        lengths = log.lengths[:, first : first + block]
        print(f"  episodes {first + 1:4d}-{first + lengths.shape[1]:4d}: {lengths.mean():6.1f}")
    steps = int(log.env_steps.sum())
    print(f"{steps} env steps in {elapsed:.1f} s ({1e6 * elapsed / steps:.1f} us per step, "
          f"agent {100 * log.agent_seconds / elapsed:.0f} % of it)")
    agent.save(args.out)
    print(f"saved the agent to {args.out}")


if __name__ == "__main__":
    main()
