"""A tracking task for examples/train_own_fmu.py: drive a shaft to a speed drawn per episode, under a
load drawn per episode, with no subclass; and a PI controller to compare the trained policy with.

The FMU is the test FMU ``tests/fmus/inertia`` (``modelicagym build tests/fmus/inertia --fmi-version 3
--out shaft.fmu``), kept beside this file: a shaft of inertia J = 0.01 kg.m2 with viscous friction
d = 0.001 N.m.s/rad (its speed ``w`` follows the torque with a lag of J/d = 10 s and settles at
(tau + tau_load) / d), its angle ``phi`` the integral of the speed.
"""

import numpy as np

from modelicagym.env import uniform

config = {
    'fmu': 'shaft.fmu',
    'inputs': ['tau'],
    'outputs': ['w'],
    'action_bounds': {'tau': (-1.0, 1.0)},
    # the load: a braking torque drawn at every reset; `uniform` tells the observation space its range
    'fixed_inputs': {'tau_load': uniform(-0.3, 0.0)},
    # the speed to reach, drawn at every reset (rad/s)
    'setpoints': {'w': uniform(100.0, 400.0)},
    # what the policy sees after w: the setpoint, the error's integral and the load
    'observe': ['setpoint', 'error_integral', 'tau_load'],
    'time_step': 0.5,
    'max_episode_steps': 60,
    'mode': 'cs',
    # the PI below asks for torques beyond the bounds while it accelerates: clip them, as SB3 does its own
    'action_out_of_bounds': 'clip',
}


def reward(envs, observations, actions, terminated):
    """Minus the speed error, in units of 10 rad/s (the return is minus the summed error)."""
    speed, setpoint = observations[:, 0], observations[:, 1]
    return -np.abs(speed - setpoint) / 10.0


config['batch_reward'] = reward


class baseline:
    """A PI controller with its own integral, which stops integrating while the torque is at a
    bound (anti-windup); the load is fed forward, as the policy sees it too."""

    KP, KI = 0.02, 0.002  # N.m per rad/s, N.m per rad

    def reset(self):
        self.integral = 0.0

    def act(self, observation):
        speed, setpoint, _, load = observation
        error = setpoint - speed
        torque = self.KP * error + self.KI * self.integral + 0.001 * setpoint - load
        if -1.0 < torque < 1.0:
            self.integral += error * config['time_step']
        return np.clip(np.array([torque]), -1.0, 1.0)
