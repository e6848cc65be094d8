"""A task for the sample system: a motor turning a shaft against a load from a table; hold the shaft
at 20 rad/s with the motor's command.

Written with its FMUs and table beside it by ``modelicagym sample system`` (relative paths in
``fmus`` are relative to this file's folder). The motor's torque drives the shaft; the shaft's
speed, in rad/s, comes back to the motor in rpm (its back-EMF): the connection converts it by the
units both FMUs declare. Each episode starts at a random time of the load table (its
``time_offset`` parameter, drawn at every reset). Try it with ``modelicagym try system_task.py``.
``drive.ssp`` holds the same system in one file (with the load table's start at 0).
"""

import numpy as np

config = {
    'fmus': {'motor': 'motor.fmu',                             # FMI 2.0, co-simulation
             'plant': {'fmu': 'inertia.fmu', 'mode': 'me'},    # FMI 3.0, model exchange
             'load': 'load.csv'},                              # a time table: time, torque
    'connections': [('motor.tau', 'plant.tau'),                # output -> input
                    ('plant.w', 'motor.w'),                    # rad/s -> rpm, by their units
                    ('load.torque', 'plant.tau_load')],
    'inputs': ['motor.u'],                                     # the motor's command, -1..1
    'outputs': ['plant.w', 'motor.tau', 'load.torque'],
    'parameters': {'plant.J': 0.02, 'load.time_offset': lambda rng: rng.uniform(0.0, 18.0)},
    'time_step': 0.01,
    'max_episode_steps': 200,
}

SETPOINT = 20.0  # rad/s


def reward(envs, observations, actions, terminated):
    """Minus the shaft's speed error relative to the setpoint, a little for the command: on arrays
    (row k: one env's step), once a step for all of a pool's envs."""
    speed, command = observations[:, 0], actions[:, 0]
    return -np.abs(speed - SETPOINT) / SETPOINT - 0.01 * command**2


config['batch_reward'] = reward
