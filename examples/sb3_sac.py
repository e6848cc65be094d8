"""Train Stable-Baselines3's SAC, off-policy, on the pendulum swing-up stepped by the pool.

SAC learns from a replay buffer, so it needs far fewer env steps than PPO; on this machine its
gradient steps, not the FMU, are then the cost. The preset (``modelicagym.sb3_train``) is RL
Baselines3 Zoo's Pendulum-v1 SAC (learning rate 1e-3) collecting from 4 envs of the pool at once:
``train_freq=1`` trains after every vector step (4 env steps), with ``gradient_steps=2``: half a
gradient step per env step, where a single-env SAC does one (``gradient_steps=-1`` would do that:
one per env step collected), to halve the updates' time, which dominates; ``learning_starts``
fills the buffer with 1,000 random steps first. Training stops once the mean return of the last
20 episodes reaches -200; then the deterministic policy is evaluated and the learning curve saved.

Run: ``python examples/sb3_sac.py [--seed 0] [--envs 4] [--steps 50000] [--save sac.zip]``
(needs ``pip install torch==2.13.0`` for a CPU-only torch, then ``pip install "modelicagym[rl,plots]"``).
"""

from sb3_ppo import main

if __name__ == "__main__":
    main("sac", "SAC", __doc__)
