"""PPO in one file, CleanRL-style, on FMU environments stepped by the modelicagym pool.

Everything is here, top to bottom: the pool of environments, the actor-critic network, the rollout,
generalized advantage estimation, the clipped PPO update, progress lines and a learning-curve
plot. The pool is a Gymnasium vector env made with ``autoreset_mode="SameStep"``: an env that ends
is reset in the same step, so the observation after a ``done`` is the next episode's first one, as
this PPO (and CleanRL's) expects. With the defaults it solves the Cart-Pole (mean episode length
>= 475 of 500) in well under a minute on 2 cores. ``--env cartpole-continuous`` (a force action)
or ``--env pendulum`` (the motor-driven swing-up, a costlier FMU) train a Gaussian policy instead:
the continuous cart-pole is solved in seconds; the swing-up improves from a mean return of about
-1,500 to -500 in 300,000 steps (2 minutes), short of the -200 that SB3's PPO with
state-dependent exploration reaches (``examples/sb3_ppo.py --env pendulum``).

``--checkpoint run.pt`` saves everything after every update — the network, the optimizer, the
observation statistics, the random generator and every env's state mid-episode
(``envs.get_states()``) — and a run started with the same file goes on from there exactly, as if
it had never stopped (``--stop-after N`` ends a run after N updates, to try it).

Run: ``python examples/ppo.py [--env cartpole] [--num-envs 8] [--total-steps 200000]``
(needs ``pip install torch==2.13.0`` for a CPU-only torch; ``modelicagym[plots]`` for the plot).
"""

import argparse
import hashlib
import os
import time
from collections import deque

import numpy as np
import torch
from gymnasium import spaces
from torch import nn
from torch.distributions import Categorical, Normal

import modelicagym
from modelicagym.experiments.plots import plot_learning_curve

#: per env, the settings that differ from the defaults below (which learn the cart-poles): the
#: swing-up is judged by its return (the baseline controller averages about -140) and wants a
#: short horizon
PRESETS = {
    "pendulum": dict(max_episode_steps=200, target_length=0, target_return=-200, num_steps=256, epochs=10,
                     minibatch_size=64, gamma=0.9, reward_scale=0.1, total_steps=300_000),
}


def parse_args():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--env", default="cartpole", help="cartpole, cartpole-continuous or pendulum")
    parser.add_argument("--num-envs", type=int, default=8)
    parser.add_argument("--total-steps", type=int, default=200_000)
    parser.add_argument("--num-steps", type=int, default=32, help="steps per env per rollout")
    parser.add_argument("--epochs", type=int, default=20, help="passes over each rollout")
    parser.add_argument("--minibatch-size", type=int, default=256)
    parser.add_argument("--learning-rate", type=float, default=1e-3)
    parser.add_argument("--gamma", type=float, default=0.995)
    parser.add_argument("--gae-lambda", type=float, default=0.95)
    parser.add_argument("--clip", type=float, default=0.2)
    parser.add_argument("--reward-scale", type=float, default=1.0, help="the critic learns scaled rewards "
                        "(progress lines show the env's own)")
    parser.add_argument("--entropy-coef", type=float, default=0.0)
    parser.add_argument("--value-coef", type=float, default=0.5)
    parser.add_argument("--max-grad-norm", type=float, default=0.5)
    parser.add_argument("--initial-std", type=float, help="continuous actions: the policy's first std "
                        "(default: half the largest action)")
    parser.add_argument("--max-episode-steps", type=int, default=500)
    parser.add_argument("--target-length", type=float, default=475, help="stop once the last 20 episodes "
                        "last this long on average (0: train the whole budget)")
    parser.add_argument("--target-return", type=float, help="stop once the last 20 episodes earn this much "
                        "on average")
    parser.add_argument("--threads", type=int, default=1, help="torch threads (the envs use the other cores)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--plot", default="ppo.png", help="where to save the learning curve")
    parser.add_argument("--checkpoint", help="save the run here after every update, and resume from it if it exists")
    parser.add_argument("--stop-after", type=int, help="end the run after this many updates (to resume it later)")
    parser.set_defaults(**PRESETS.get(parser.parse_known_args()[0].env, {}))
    return parser.parse_args()


class ObservationNormalizer:
    """Running mean and variance of the observations (Welford, over batches): the cart position and
    the pole angle have very different scales, and the network learns faster on standardized inputs."""

    def __init__(self, shape):
        self.mean, self.var, self.count = np.zeros(shape), np.ones(shape), 1e-4

    def __call__(self, observations, update=True):
        if update:
            batch_mean, batch_var, n = observations.mean(0), observations.var(0), len(observations)
            delta, total = batch_mean - self.mean, self.count + n
            self.mean = self.mean + delta * n / total
            self.var = (self.var * self.count + batch_var * n + delta**2 * self.count * n / total) / total
            self.count = total
        normalized = (observations - self.mean) / np.sqrt(self.var + 1e-8)
        return torch.as_tensor(np.clip(normalized, -10, 10), dtype=torch.float32)


def layer_init(layer, std=2**0.5, bias=0.0):
    torch.nn.init.orthogonal_(layer.weight, std)
    torch.nn.init.constant_(layer.bias, bias)
    return layer


class Agent(nn.Module):
    """An actor and a critic, two hidden layers of 64 each; a categorical policy for a discrete
    action space, a Gaussian with a learned state-independent std for a continuous one."""

    def __init__(self, observation_space, action_space, initial_std=None):
        super().__init__()
        n_inputs = int(np.prod(observation_space.shape))
        self.discrete = isinstance(action_space, spaces.Discrete)
        n_outputs = int(action_space.n) if self.discrete else int(np.prod(action_space.shape))

        def body(out, std):
            return nn.Sequential(layer_init(nn.Linear(n_inputs, 64)), nn.Tanh(),
                                 layer_init(nn.Linear(64, 64)), nn.Tanh(), layer_init(nn.Linear(64, out), std=std))

        self.critic = body(1, 1.0)
        self.actor = body(n_outputs, 0.01)
        if not self.discrete:
            std = initial_std or 0.5 * float(np.max(np.abs([action_space.low, action_space.high])))
            self.log_std = nn.Parameter(torch.full((n_outputs,), float(np.log(std))))

    def value(self, x):
        return self.critic(x).squeeze(-1)

    def policy(self, x):
        if self.discrete:
            return Categorical(logits=self.actor(x))
        return Normal(self.actor(x), self.log_std.exp().expand(x.shape[0], -1))

    def act(self, x, action=None):
        """An action (sampled unless given), its log-probability, the entropy and the value."""
        policy = self.policy(x)
        if action is None:
            action = policy.sample()
        log_prob, entropy = policy.log_prob(action), policy.entropy()
        if not self.discrete:
            log_prob, entropy = log_prob.sum(-1), entropy.sum(-1)
        return action, log_prob, entropy, self.value(x)


def save_checkpoint(path, run):
    """Write ``run`` (a dict of tensors, arrays and the pool's states) to ``path`` atomically."""
    temporary = f"{path}.tmp"
    torch.save(run, temporary)
    os.replace(temporary, path)


def main():
    args = parse_args()
    torch.manual_seed(args.seed)
    torch.set_num_threads(args.threads)

    # the environments: FMUs in the pool's worker processes and in this one
    envs = modelicagym.make_vec(args.env, n=args.num_envs, max_episode_steps=args.max_episode_steps,
                                autoreset_mode="SameStep")
    print(f"{args.env}: {args.num_envs} envs, {envs.layout}")
    n, steps_per_rollout = args.num_envs, args.num_steps
    agent = Agent(envs.single_observation_space, envs.single_action_space, args.initial_std)
    optimizer = torch.optim.Adam(agent.parameters(), lr=args.learning_rate, eps=1e-5)
    normalize = ObservationNormalizer(envs.single_observation_space.shape)
    action_space = envs.single_action_space

    # rollout storage
    observations = torch.zeros((steps_per_rollout, n, *envs.single_observation_space.shape))
    actions = torch.zeros((steps_per_rollout, n, *action_space.shape))
    log_probs, rewards, dones, values = (torch.zeros((steps_per_rollout, n)) for _ in range(4))

    # episode statistics, kept here: the envs live in other processes
    episode_return, episode_length = np.zeros(n), np.zeros(n, dtype=np.int64)
    recent = deque(maxlen=20)  # (return, length) of the last episodes
    curve, started, global_step = [], time.perf_counter(), 0
    next_observation = normalize(envs.reset(seed=args.seed)[0])
    next_done = torch.zeros(n)
    first_iteration = 1
    if args.checkpoint and os.path.exists(args.checkpoint):  # resume: every env mid-episode, as saved
        run = torch.load(args.checkpoint, weights_only=False)
        agent.load_state_dict(run["agent"])
        optimizer.load_state_dict(run["optimizer"])
        torch.set_rng_state(run["torch_rng"])
        envs.set_states(run["envs"])
        normalize.mean, normalize.var, normalize.count = run["normalizer"]
        next_observation, next_done = run["next_observation"], run["next_done"]
        episode_return, episode_length, global_step = run["episode_return"], run["episode_length"], run["global_step"]
        recent.extend(run["recent"])
        curve, first_iteration = run["curve"], run["iteration"] + 1
        print(f"resumed from {args.checkpoint} after update {run['iteration']} ({global_step} steps)")

    for iteration in range(first_iteration, args.total_steps // (n * steps_per_rollout) + 1):
        # collect a rollout
        for t in range(steps_per_rollout):
            observations[t], dones[t] = next_observation, next_done
            with torch.no_grad():
                action, log_prob, _, value = agent.act(next_observation)
            actions[t], log_probs[t], values[t] = action, log_prob, value
            env_action = action.numpy()
            if not agent.discrete:
                env_action = np.clip(env_action, action_space.low, action_space.high)
            observation, reward, terminated, truncated, _ = envs.step(env_action)
            done = terminated | truncated
            rewards[t] = torch.as_tensor(reward * args.reward_scale, dtype=torch.float32)
            next_observation, next_done = normalize(observation), torch.as_tensor(done, dtype=torch.float32)
            global_step += n
            episode_return += reward
            episode_length += 1
            for i in np.flatnonzero(done):
                recent.append((episode_return[i], episode_length[i]))
            episode_return[done], episode_length[done] = 0.0, 0

        # generalized advantage estimation
        with torch.no_grad():
            next_value = agent.value(next_observation)
            advantages = torch.zeros_like(rewards)
            last = torch.zeros(n)
            for t in reversed(range(steps_per_rollout)):
                following_done = next_done if t == steps_per_rollout - 1 else dones[t + 1]
                following_value = next_value if t == steps_per_rollout - 1 else values[t + 1]
                delta = rewards[t] + args.gamma * following_value * (1 - following_done) - values[t]
                last = delta + args.gamma * args.gae_lambda * (1 - following_done) * last
                advantages[t] = last
            returns = advantages + values

        # the clipped PPO update, over shuffled minibatches
        batch = (observations.flatten(0, 1), actions.flatten(0, 1), log_probs.flatten(), advantages.flatten(),
                 returns.flatten())
        size = n * steps_per_rollout
        for _ in range(args.epochs):
            order = torch.randperm(size)
            for start in range(0, size, args.minibatch_size):
                index = order[start : start + args.minibatch_size]
                b_obs, b_actions, b_log_probs, b_advantages, b_returns = (x[index] for x in batch)
                b_actions = b_actions.long() if agent.discrete else b_actions
                _, new_log_prob, entropy, new_value = agent.act(b_obs, b_actions)
                ratio = (new_log_prob - b_log_probs).exp()
                b_advantages = (b_advantages - b_advantages.mean()) / (b_advantages.std() + 1e-8)
                policy_loss = torch.max(-b_advantages * ratio,
                                        -b_advantages * ratio.clamp(1 - args.clip, 1 + args.clip)).mean()
                value_loss = 0.5 * ((new_value - b_returns) ** 2).mean()
                loss = policy_loss + args.value_coef * value_loss - args.entropy_coef * entropy.mean()
                optimizer.zero_grad()
                loss.backward()
                nn.utils.clip_grad_norm_(agent.parameters(), args.max_grad_norm)
                optimizer.step()

        if args.checkpoint:
            save_checkpoint(args.checkpoint, dict(
                agent=agent.state_dict(), optimizer=optimizer.state_dict(), torch_rng=torch.get_rng_state(),
                envs=envs.get_states(), normalizer=(normalize.mean, normalize.var, normalize.count),
                next_observation=next_observation, next_done=next_done, episode_return=episode_return,
                episode_length=episode_length, global_step=global_step, recent=list(recent), curve=curve,
                iteration=iteration))

        # progress, and stop once solved
        if recent:
            mean_return, mean_length = np.mean([r for r, _ in recent]), np.mean([length for _, length in recent])
            curve.append((global_step, mean_return, mean_length))
            elapsed = time.perf_counter() - started
            if iteration % max(1, 2048 // size) == 0:
                print(f"{global_step:>8} steps  {elapsed:6.1f} s  {global_step / elapsed:8.0f} steps/s  "
                      f"mean return {mean_return:8.1f}  mean length {mean_length:6.1f}")
            long_enough = args.target_length and mean_length >= args.target_length
            good_enough = args.target_return is not None and mean_return >= args.target_return
            if len(recent) == recent.maxlen and (long_enough or good_enough):
                print(f"solved: mean episode {'length' if long_enough else 'return'} >= "
                      f"{args.target_length if long_enough else args.target_return:g} after {global_step} steps, "
                      f"{elapsed:.1f} s")
                break
        if args.stop_after and iteration - first_iteration + 1 >= args.stop_after:
            print(f"stopped after update {iteration} ({global_step} steps)")
            break
    else:
        print(f"trained for {global_step} steps, {time.perf_counter() - started:.1f} s")
    weights = b"".join(p.detach().numpy().tobytes() for p in agent.parameters())
    print(f"network fingerprint: {hashlib.sha256(weights).hexdigest()[:16]}")

    envs.close()
    if curve:
        if plot_learning_curve(curve, args.plot, f"PPO (one file) on {args.env}, last 20 episodes"):
            print(f"saved the learning curve to {args.plot}")


if __name__ == "__main__":
    main()
