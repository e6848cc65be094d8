"""A task for the room heater: hold a room at 21 degC with an electric heater.

Written with the FMU beside it by ``modelicagym sample heater`` (a relative ``fmu`` path is relative
to this file's folder). Try it with ``modelicagym try heater_task.py``; train on it with
``examples/train_own_fmu.py``. Make a file like this one for your FMU: paste what ``modelicagym info
MY.fmu`` prints under "a config to start from", then write the task below it. The training script
(and ``modelicagym try``) reads one name from this file: ``config``, an `FMUEnv` config (a dict).
"""

import numpy as np

# 1. Pasted from `modelicagym info heater.fmu`, then edited: an hour an episode (60 steps of
#    60 s), and the room at a random temperature at every reset (a parameter may be a function
#    of the env's random generator).
config = {
    'fmu': 'heater.fmu',
    'inputs': ['u'],
    'outputs': ['T', 'P'],
    'parameters': {'C': 60000.0, 'G': 100.0, 'P_max': 3000.0, 'T_amb': 5.0,
                   'T_0': lambda rng: rng.uniform(10.0, 28.0)},
    'time_step': 60.0,
    'mode': 'cs',
    'max_episode_steps': 60,
}

# 2. The task. Rewards and terminations are ordinary config keys (see docs/env.md, "Reward and
#    termination"). The reward is written on arrays (row k: one env's step), so the FMUs still
#    step in C and a pool computes it once per step for all its envs.
SETPOINT = 21.0  # degC
ACTUATION_COST = 0.1  # per unit of u squared, against 1 per kelvin off the setpoint
OVERHEAT_PENALTY = 100.0


def reward(envs, observations, actions, terminated):
    """-|T - 21| - 0.1 u^2 a step, and -100 on the step the room overheats."""
    temperature, command = observations[:, 0], actions[:, 0]
    return -np.abs(temperature - SETPOINT) - ACTUATION_COST * command**2 - OVERHEAT_PENALTY * terminated


config['batch_reward'] = reward
config['termination'] = {'T': (0.0, 30.0)}  # the episode ends when the room leaves 0..30 degC
