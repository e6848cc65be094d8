"""A tracking task for the two-mass drive: bring the motor to a speed drawn per episode and hold it
there, under a load drawn per episode; and a PI controller to compare a trained policy with.

Written with the FMU beside it by ``modelicagym sample drive`` (a relative ``fmu`` path is relative to
this file's folder). Try it with ``modelicagym try drive_task.py`` (random actions) or ``modelicagym try
drive_task.py --policy baseline`` (the PI below); train on it with ``examples/train_own_fmu.py``, which
compares the trained policy with random actions and the PI on the same episodes. The task file
defines ``config`` (an `FMUEnv` config, a dict) and ``baseline`` (a controller).
"""

import numpy as np

from modelicagym.env import uniform

# 1. From `modelicagym info drive.fmu`, then edited: the agent sets the motor's torque M_A (bounded
#    by the FMU: -2..2 N.m) and sees both speeds; the angles grow without end, so they are left out.
#    The load torque M_B and the speed to reach are drawn at every reset (`uniform` also tells the
#    observation space their ranges). The policy sees, after wA and wB, the setpoint, the error
#    (wA - setpoint), its integral and the load. An episode: 40 steps of 0.25 s, from rest.
TIME_STEP = 0.25  # s
config = {
    'fmu': 'drive.fmu',
    'inputs': ['M_A'],
    'outputs': ['wA', 'wB'],
    'parameters': {'J_A': 0.005, 'J_B': 0.01, 'c': 10.0, 'd': 0.05},
    # the load: between no load and 1 N.m braking
    'fixed_inputs': {'M_B': uniform(-1.0, 0.0)},
    # the motor's speed to reach (rad/s): full torque less the load reaches the highest within 3 s
    'setpoints': {'wA': uniform(50.0, 200.0)},
    'observe': ['setpoint', 'error', 'error_integral', 'M_B'],
    'time_step': TIME_STEP,
    'mode': 'cs',
    'max_episode_steps': 40,
    # a torque outside -2..2 N.m is clipped rather than refused (a controller of your own may ask for more)
    'action_out_of_bounds': 'clip',
}

# 2. The reward: minus the motor's speed error, in units of 10 rad/s, written on arrays (row k: one
#    env's step), so the FMUs still step in C and a pool computes it once per step for all its envs.
#    Over an episode's 40 steps, -return / 4 is the mean error in rad/s.
ERROR_SCALE = 10.0  # rad/s


def reward(envs, observations, actions, terminated):
    """-|setpoint - wA| / 10 a step."""
    speed, setpoint = observations[:, 0], observations[:, 2]
    return -np.abs(setpoint - speed) / ERROR_SCALE


config['batch_reward'] = reward


# 3. The controller a trained policy is compared with: a PI on the motor's speed, in velocity form
#    (each step changes the torque by KP times the error's change plus KI times the error's integral
#    over the step). The torque it keeps is the one clipped to the bounds, so its integral never winds
#    up while the motor accelerates at full torque, and it finds the load without seeing it.
#    KP = (J_A + J_B) / time_step would remove a speed error in one step; tuned on the evaluation's
#    starts (KP 0.04..0.07, KI 0..0.5): this pair does best. Starting from the load's torque (feeding it
#    forward) changes nothing: the first steps are at full torque whatever the load.
class baseline:
    """A PI controller on wA, in velocity form, its torque clipped to M_A's bounds (anti-windup)."""

    KP, KI = 0.06, 0.2  # N.m per rad/s, N.m per rad
    LOW, HIGH = -2.0, 2.0  # M_A's bounds, N.m

    def reset(self):
        self.torque, self.error = 0.0, 0.0

    def act(self, observation):
        speed, setpoint = observation[0], observation[2]
        error = setpoint - speed
        torque = self.torque + self.KP * (error - self.error) + self.KI * error * TIME_STEP
        self.torque, self.error = float(np.clip(torque, self.LOW, self.HIGH)), error
        return np.array([self.torque])
