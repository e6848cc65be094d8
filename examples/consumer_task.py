"""A task for examples/train_own_fmu.py on an FMU with many inputs: hold a room at 22 degC with
the valve of a chilled water coil, the pressures, temperatures and heat gains held by the task.

The FMU is the test FMU ``tests/fmus/consumer`` (``modelicagym build tests/fmus/consumer --out
consumer.fmu``), in the shape of a third-party export: six inputs without declared ranges, a
default experiment of 1 s in 2 ms steps. It is kept beside this file: a relative ``fmu`` path is
relative to the task file's folder. docs/train-own-fmu.md ("An FMU with many inputs") goes through each choice.
"""

import numpy as np

# 1. Pasted from `modelicagym info consumer.fmu`, then edited where the comments say.
config = {
    'fmu': 'consumer.fmu',
    'inputs': ['valve'],  # info's choice: the one input without a unit, the command
    'outputs': ['T_room', 'T_return', 'm_flow', 'Q_flow'],
    'parameters': {'C_room': 500000.0, 'UA': 3000.0, 'T_room_0': 297.15},
    'fixed_inputs': {
        'p_supply': 300000.0,
        'p_return': 120000.0,
        'T_supply': 279.15,
        'T_amb': lambda rng: rng.uniform(298.15, 308.15),  # edited: a summer day, drawn every episode
        'Q_gain': 2000.0,
    },
    'action_bounds': {
        'valve': (0.0, 1.0),  # edited: info's placeholder None; the valve's documented range
    },
    'time_step': 60.0,  # edited from 0.002: `modelicagym try consumer_task.py --step valve` (docs/train-own-fmu.md)
    'mode': 'cs',
    'max_episode_steps': 120,  # edited from 500: two hours an episode
}

# 2. The task: the room at 22 degC, the water pumped at a price. Written on arrays (row k: one
#    env's step), so the FMUs still step in C and a pool computes it once per step for all its envs.
SETPOINT = 295.15  # K
PUMPING_COST = 0.5  # per unit of valve opening, against 1 per kelvin off the setpoint


def reward(envs, observations, actions, terminated):
    """-|T_room - 22 degC| - 0.5 valve a step."""
    return -np.abs(observations[:, 0] - SETPOINT) - PUMPING_COST * actions[:, 0]


config['batch_reward'] = reward
