"""Sample Cart-Pole rollouts on a Ray cluster with a policy shipped once.

Connects to Ray (``--address``, else a new Ray on this machine), puts ``--envs`` FMU environments
in Ray actors (by default one per CPU, each stepping its share in its own process), and collects
``--rounds`` rollouts of ``--steps`` steps with the "lean" controller: each round is one remote
call per actor, which steps its envs ``--steps`` times and sends the arrays back. Prints, per
round, the env steps per second and the episodes that ended, then what the envs reported.

Needs the Ray extra: ``pip install -e ".[ray]"``.
Run: ``python examples/ray_rollouts.py --envs 8 --steps 256 --rounds 5 [--address HOST:PORT]``
"""

import argparse
import time

import numpy as np

import modelicagym
from modelicagym.distributed import Rollout, connect

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--envs", type=int, default=8, help="environments in all")
parser.add_argument("--steps", type=int, default=256, help="steps per rollout (T)")
parser.add_argument("--rounds", type=int, default=5, help="rollouts to collect")
parser.add_argument("--max-steps", type=int, default=200, help="steps after which an episode is truncated")
parser.add_argument("--address", help="a Ray cluster's address (default: a new Ray on this machine)")
parser.add_argument("--seed", type=int, default=0)


def lean_controller(observations):
    """Push each cart under its pole: right when the pole leans or falls right (theta < 90 deg)."""
    theta, theta_dot = observations[:, 2], observations[:, 3]
    return ((np.pi / 2 - theta) - 0.5 * theta_dot > 0).astype(np.int64)


def main():
    args = parser.parse_args()
    ray = connect(args.address)
    print(f"Ray: {ray.cluster_resources().get('CPU', 0):g} CPUs on {len(ray.nodes())} node(s)")

    envs = modelicagym.make_vec("cartpole", n=args.envs, backend="ray", max_episode_steps=args.max_steps)
    print(f"{envs.num_envs} envs in {envs.num_actors} actor(s): "
          + ", ".join(f"envs {p.envs.start}-{p.envs.stop - 1} on {p.cpus} CPU(s)" for p in envs.plans))
    envs.reset(seed=args.seed)

    ended_lengths, running = [], np.zeros(envs.num_envs, dtype=np.int64)
    for round_ in range(args.rounds):
        started = time.perf_counter()
        batch = Rollout.concatenate(envs.rollout(lean_controller, steps=args.steps))
        elapsed = time.perf_counter() - started
        for t in range(args.steps):  # episode lengths from the flags (NEXT_STEP autoreset)
            running += 1
            ended = batch.terminations[t] | batch.truncations[t]
            ended_lengths.extend(running[ended].tolist())
            running[ended] = -1  # the next step is the reset, which is not an env step
        print(f"round {round_}: {batch.rewards.size} env steps in {elapsed * 1e3:.1f} ms "
              f"= {batch.rewards.size / elapsed:,.0f} steps/s; episodes ended so far: {len(ended_lengths)}")

    if ended_lengths:
        print(f"episode length: mean {np.mean(ended_lengths):.1f}, max {max(ended_lengths)} "
              f"(truncated at {args.max_steps})")
    print(f"infos reported: {len(batch.infos)} in the last round")
    envs.close()


if __name__ == "__main__":
    main()
