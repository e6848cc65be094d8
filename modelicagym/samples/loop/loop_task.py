"""A task for the sample loop: a proportional controller and a plant that close a loop through
direct feedthrough; bring the plant's output to the setpoint given as the action.

Written with its FMUs beside it by ``modelicagym sample loop`` (relative paths in ``fmus`` are
relative to this file's folder). The controller's output ``y = k (r - u)`` depends on its input at
once, and so does the plant's (``der(x) = u``, ``y = x + d u``): a loop no fixed-step master can
solve within a step. The env runs it as co-simulation engines do, reading one connection of the
loop from the previous step; ``env.metadata["loops"]`` (and ``modelicagym info``/``try``) say which.
Try it with ``modelicagym try loop_task.py``.
"""

import numpy as np

config = {
    'fmus': {'controller': 'controller.fmu',           # FMI 2.0, co-simulation
             'plant': 'plant.fmu'},                     # FMI 3.0, co-simulation
    'connections': ['controller.y -> plant.u',          # output -> input, both with direct feedthrough
                    'plant.y -> controller.u'],
    'inputs': ['controller.r'],                         # the setpoint, the action
    'action_bounds': {'controller.r': (-1.0, 1.0)},
    'outputs': ['controller.y', 'plant.y'],
    'parameters': {'controller.k': 1.0},             # k d = 0.5 around the loop: it settles
    'time_step': 0.05,
    'max_episode_steps': 200,
}


def reward(envs, observations, actions, terminated):
    """-|r - y|: the plant's output off the setpoint."""
    return -np.abs(actions[:, 0] - observations[:, 1])


config['batch_reward'] = reward
