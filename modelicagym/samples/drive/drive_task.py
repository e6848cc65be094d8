"""A task for the two-mass drive: bring the motor to 200 rad/s and hold it there, whatever the load.

Written with the FMU beside it by ``modelicagym sample drive`` (a relative ``fmu`` path is relative to
this file's folder). Try it with ``modelicagym try drive_task.py``; train on it with
``examples/train_own_fmu.py``. The task file defines one name, ``config``: an `FMUEnv` config (a dict).
"""

import numpy as np

# 1. From `modelicagym info drive.fmu`, then edited: the agent sets the motor's torque M_A (bounded
#    by the FMU: -2..2 N.m) and sees both speeds; the angles grow without end, so they are left out.
#    The load torque M_B is drawn at every reset (a held input may be a function of the env's random
#    generator): between no load and 1 N.m braking. An episode: 50 steps of 0.1 s, from rest.
config = {
    'fmu': 'drive.fmu',
    'inputs': ['M_A'],
    'outputs': ['wA', 'wB'],
    'parameters': {'J_A': 0.005, 'J_B': 0.01, 'c': 10.0, 'd': 0.05},
    'fixed_inputs': {'M_B': lambda rng: rng.uniform(-1.0, 0.0)},
    'time_step': 0.1,
    'mode': 'cs',
    'max_episode_steps': 50,
}

# 2. The task: the reward is minus the motor's speed error, written on arrays (row k: one env's
#    step), so the FMUs still step in C and a pool computes it once per step for all its envs.
SETPOINT = 200.0  # rad/s


def reward(envs, observations, actions, terminated):
    """-|200 - wA| a step, in rad/s."""
    return -np.abs(SETPOINT - observations[:, 0])


config['batch_reward'] = reward
