"""Train SAC on a system of two FMUs: a motor (the actuator) turning a shaft (the plant) against a
load torque read from a table, the three connected as one environment and stepped by the pool.

The FMUs and the table are those ``modelicagym sample system`` writes (``motor.fmu``, FMI 2.0;
``inertia.fmu``, FMI 3.0, built from the package's C sources on first use and cached; ``load.csv``).
The motor's torque drives the shaft; the shaft's speed, in rad/s, comes back to the motor in rpm (its
back-EMF): the connection converts it by the units both FMUs declare. The CSV table (a slow load with
a step in it) drives the shaft's load torque; each episode starts at a random time of it (the table's
``time_offset`` parameter, drawn at every reset). The task: hold the shaft at 20 rad/s with the
motor's command, whatever the load. The master is Gauss-Seidel: the table, then the motor, then
the shaft, each taking the latest values (``"master": "jacobi"`` for Jacobi).

Run: ``python examples/system_sac.py [--envs 4] [--steps 20000] [--seed 0]``
(needs ``pip install torch==2.13.0`` for a CPU-only torch, then ``pip install "modelicagym[rl]"``).
"""

import argparse
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np
from stable_baselines3 import SAC
from stable_baselines3.common.vec_env import VecMonitor

import modelicagym
from modelicagym import FMUEnv
from modelicagym.samples import write_sample
from modelicagym.sb3 import SB3VecEnv, folderless_logger

SETPOINT = 20.0  # rad/s
TABLE_SECONDS = 20.0  # of load schedule in load.csv: episodes (2 s at most by default) start anywhere in the first 18


def reward(envs, observations, actions, terminated):
    """Minus the speed error relative to the setpoint, a little for the command: on arrays, once
    a step for all the pool's envs."""
    speed, command = observations[:, 0], actions[:, 0]
    return -np.abs(speed - SETPOINT) / SETPOINT - 0.01 * command**2


def start_in_the_table(rng):
    return float(rng.uniform(0.0, TABLE_SECONDS - 2.0))


parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
parser.add_argument("--envs", type=int, default=4)
parser.add_argument("--steps", type=int, default=20_000)
parser.add_argument("--max-episode-steps", type=int, default=200)
parser.add_argument("--seed", type=int, default=0)
args = parser.parse_args()

# 1. the components: the sample's two FMUs built from C sources, and its load schedule as a CSV table
folder = Path(tempfile.mkdtemp(prefix="system-sac-"))
write_sample("system", folder)
config = {
    "fmus": {"motor": str(folder / "motor.fmu"), "plant": str(folder / "inertia.fmu"),
             "load": str(folder / "load.csv")},
    "connections": [("motor.tau", "plant.tau"), ("plant.w", "motor.w"), ("load.torque", "plant.tau_load")],
    "inputs": ["motor.u"],
    "outputs": ["plant.w", "motor.tau", "load.torque"],
    "parameters": {"load.time_offset": start_in_the_table},
    "time_step": 0.01,
    "max_episode_steps": args.max_episode_steps,
    "batch_reward": reward,
}

# 2. the pool of systems, as Stable-Baselines3 sees it
envs = VecMonitor(SB3VecEnv(modelicagym.make_vec(config, n=args.envs)))
print(f"{args.envs} envs of a system of {len(config['fmus'])} components: motor, plant and load")

# 3. SAC, one gradient step per env step collected
model = SAC("MlpPolicy", envs, learning_starts=500, batch_size=256, gamma=0.95, train_freq=1, gradient_steps=-1,
            policy_kwargs=dict(net_arch=[64, 64]), seed=args.seed, device="cpu")
model.set_logger(folderless_logger())
started = time.perf_counter()
model.learn(args.steps)
print(f"trained {args.steps} steps in {time.perf_counter() - started:.0f} s")
envs.close()

# 4. the policy against a fixed command on the same starts: mean speed error over an episode
env = FMUEnv(config)
print(f"step path: {env.step_path} ({env.step_path_reason})")


def mean_error(policy):
    errors = []
    for episode in range(5):
        observation, _ = env.reset(seed=100 + episode)
        done = False
        while not done:
            observation, _, terminated, truncated, _ = env.step(policy(observation))
            errors.append(abs(observation[0] - SETPOINT))
            done = terminated or truncated
    return float(np.mean(errors))


trained = mean_error(lambda observation: model.predict(observation, deterministic=True)[0])
fixed = mean_error(lambda observation: np.array([0.1]))  # what holds 20 rad/s with no load
env.close()
shutil.rmtree(folder)
print(f"mean speed error: trained policy {trained:.2f} rad/s, a fixed command of 0.1 {fixed:.2f} rad/s")
