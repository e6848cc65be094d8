"""Swing a pendulum up with a DC motor and hold it upright: continuous control on a costly FMU.

The pendulum FMU (`modelicagym.models.pendulum`) models the motor's armature, a gearbox with a
compliant shaft and LuGre friction, so one 50 ms step costs ~0.4 ms of simulation: the bundled
model where stepping envs in parallel pays. The task follows Gymnasium's ``Pendulum-v1``: the
action is the motor voltage in [-6, 6] V, which cannot lift the pendulum straight up (the stalled
motor gives 2.7 N m against up to 4.9 N m of gravity), so a policy must pump energy by swinging.

Reward, per step, with ``theta`` the angle from upright wrapped to [-pi, pi] (rad), ``omega`` the
angular velocity (rad/s) and ``u`` the voltage (V)::

    reward = -(theta**2 + 0.1 * omega**2 + 0.001 * u**2)

so 0 is the best a step can earn and a pendulum hanging still earns -9.87. Episodes never
terminate; they are truncated after 200 steps (10 s). Each starts at a uniformly random angle
and an angular velocity uniform in [-1, 1] rad/s (give ``theta_0``/``omega_0`` to fix them).
`EnergySwingUp` is a baseline controller for it.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium import spaces

from modelicagym.env.fmu_env import FMUEnv
from modelicagym.models.pendulum import DEFAULT_PARAMETERS, pendulum_fmu

#: Observation: the pendulum's angle as a point on the unit circle, and its angular velocity.
OBSERVATION = ("cos_theta", "sin_theta", "omega")
MAX_VOLTAGE = 6.0
GRAVITY = 9.81


def _uniform(low: float, high: float) -> Any:
    def draw(np_random: np.random.Generator) -> float:
        return float(np_random.uniform(low, high))
    return draw


class PendulumSwingUpEnv(FMUEnv):
    """Swing the motor-driven pendulum up and balance it (see the module docstring for the reward).

    Observation: ``[cos(theta), sin(theta), omega]`` with ``theta`` from upright (rad) and
    ``omega`` in rad/s. Action: the motor voltage, ``Box(-6, 6, (1,))`` V.

    Example::

        import modelicagym

        env = modelicagym.make("pendulum")
        observation, info = env.reset(seed=0)
        observation, reward, terminated, truncated, info = env.step(np.array([6.0]))

    Parameters:
        theta_0, omega_0: the initial angle (rad, 0 upright) and angular velocity (rad/s);
            default: random per episode (see the module docstring).
        max_voltage: the action bound [V].
        max_episode_steps: truncate after this many steps (None: never).
        time_step: seconds per step.
        fmi_version: 2 or 3; mode: ``"cs"`` or ``"me"``.
        model_parameters: further parameters of the FMU (``mass``, ``gear_ratio``, ``cs_step_size``,
            ...: `modelicagym.models.pendulum.DEFAULT_PARAMETERS`).
        fmu_options: further `FMUEnvConfig` keys.
    """

    #: built from our sources (`modelicagym.models`): a pool may step it in the calling process
    safe_in_caller = True

    def __init__(
        self,
        *,
        theta_0: float | None = None,
        omega_0: float | None = None,
        max_voltage: float = MAX_VOLTAGE,
        max_episode_steps: int | None = 200,
        time_step: float = 0.05,
        fmi_version: int = 2,
        mode: str = "cs",
        model_parameters: dict[str, float] | None = None,
        **fmu_options: Any,
    ):
        parameters = {
            "theta_0": _uniform(-np.pi, np.pi) if theta_0 is None else float(theta_0),
            "omega_0": _uniform(-1.0, 1.0) if omega_0 is None else float(omega_0),
            **(model_parameters or {}),
        }
        self.max_voltage = float(max_voltage)
        super().__init__(
            fmu=pendulum_fmu(fmi_version),
            inputs=["u"],
            outputs=list(OBSERVATION),
            parameters=parameters,
            time_step=time_step,
            max_episode_steps=max_episode_steps,
            action_space=spaces.Box(-self.max_voltage, self.max_voltage, (1,), dtype=np.float64),
            mode=mode,
            **fmu_options,
        )

    @classmethod
    def compute_rewards(cls, envs: Sequence[FMUEnv], observations: np.ndarray, actions: np.ndarray,
                        terminated: np.ndarray) -> np.ndarray:
        """The reward of the module docstring, on arrays (row k: env k's step), so the FMU steps in C
        and a pool's slice computes its rewards in one call."""
        cos_theta, sin_theta, omega = observations[:, 0], observations[:, 1], observations[:, 2]
        theta = np.arctan2(sin_theta, cos_theta)
        voltage = np.asarray(actions, dtype=np.float64).reshape(len(envs), -1)[:, 0]
        return -(theta**2 + 0.1 * omega**2 + 0.001 * voltage**2)


class EnergySwingUp:
    """A baseline controller: pump energy with full voltage until the pendulum would reach the top,
    then balance it with a PD law near upright.

    The pendulum's energy ``E = J omega^2 / 2 + m g l cos(theta)`` equals ``m g l`` at rest upright.
    Below it, the full voltage in the direction of motion adds energy fastest; within
    ``catch_angle`` of upright, ``u = -(kp theta + kd omega)`` (clipped) holds the pendulum there.
    Works on one observation or a batch (rows), so it drives a vector env directly.

    Example::

        import modelicagym
        from modelicagym.models.pendulum.env import EnergySwingUp

        env = modelicagym.make("pendulum")
        controller = EnergySwingUp()
        observation, info = env.reset(seed=0)
        for _ in range(200):
            observation, reward, terminated, truncated, info = env.step(controller(observation))
    """

    def __init__(self, max_voltage: float = MAX_VOLTAGE, kp: float = 30.0, kd: float = 4.0,
                 catch_angle: float = 0.5, mass: float = DEFAULT_PARAMETERS["mass"],
                 length: float = DEFAULT_PARAMETERS["length"]):
        self.max_voltage, self.kp, self.kd, self.catch_angle = max_voltage, kp, kd, catch_angle
        self.mass, self.length = mass, length

    def __call__(self, observation: np.ndarray) -> np.ndarray:
        observation = np.asarray(observation, dtype=np.float64)
        cos_theta, sin_theta, omega = np.moveaxis(observation, -1, 0)
        theta = np.arctan2(sin_theta, cos_theta)
        mgl = self.mass * GRAVITY * self.length
        energy = 0.5 * self.mass * self.length**2 * omega**2 + mgl * cos_theta
        pump = np.where(energy < mgl, self.max_voltage * np.where(omega >= 0, 1.0, -1.0), 0.0)
        balance = -(self.kp * theta + self.kd * omega)
        u = np.where(np.abs(theta) < self.catch_angle, balance, pump)
        return np.clip(u, -self.max_voltage, self.max_voltage)[..., None]
