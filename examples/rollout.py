"""Roll out Cart-Pole episodes on the FMU and print what happened.

Builds the Cart-Pole FMU from its C sources on first use, then runs a few episodes with a random
policy and with a simple hand-written controller, and prints episode lengths and the time one
simulation step takes. Run: ``python examples/rollout.py [--episodes 10]``.
"""

import argparse
import time

import numpy as np

import modelicagym


def random_policy(observation, rng):
    return int(rng.integers(2))


def lean_controller(observation, rng):
    """Push the cart under the pole: right when the pole leans right (theta < 90 deg) or falls right."""
    x, x_dot, theta, theta_dot = observation
    lean = (np.pi / 2 - theta) + 0.5 * -theta_dot
    return int(lean > 0)


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--episodes", type=int, default=10)
    parser.add_argument("--max-steps", type=int, default=500)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()

    env = modelicagym.make("cartpole", max_episode_steps=args.max_steps)
    print(f"environment: {env.description.name}, FMI {env.description.fmi_version}, mode {env.fmu.mode}, "
          f"time step {env.time_step} s, {env.step_path} step path")
    print(f"observation space: {env.observation_space}; action space: {env.action_space}")

    rng = np.random.default_rng(args.seed)
    for name, policy in [("random", random_policy), ("lean controller", lean_controller)]:
        lengths, steps, started = [], 0, time.perf_counter()
        for episode in range(args.episodes):
            observation, info = env.reset(seed=args.seed + episode)
            terminated = truncated = False
            while not (terminated or truncated):
                observation, reward, terminated, truncated, info = env.step(policy(observation, rng))
                steps += 1
            lengths.append(env.elapsed_steps)
        elapsed = time.perf_counter() - started
        print(f"{name:>16}: {args.episodes} episodes, length mean {np.mean(lengths):.1f} "
              f"(min {min(lengths)}, max {max(lengths)}), {steps} steps in {elapsed:.3f} s "
              f"= {1e6 * elapsed / steps:.1f} us per step (the paper: ~110000 us)")
    env.close()


if __name__ == "__main__":
    main()
