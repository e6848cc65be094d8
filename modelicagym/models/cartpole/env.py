"""The Cart-Pole use case of the ModelicaGym paper, on our own Cart-Pole FMU.

Two actions push the cart left or right with a fixed force magnitude; the episode ends when the
cart leaves the track (|x| > 2.4 m) or the pole falls more than 12 degrees from upright; rewards
are +1 per step and -100 on failure, as in the paper. `CartPoleContinuousEnv` is the same task
with a continuous force, for policies such as PPO's or SAC's Gaussian ones.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces

from modelicagym.env.fmu_env import FMUEnv
from modelicagym.models.cartpole import OUTPUTS, cartpole_fmu

UPRIGHT = np.pi / 2

#: The paper's intervals for the cart-pole observation ``[x, x_dot, theta, theta_dot]``
#: (m, m/s, rad, rad/s); theta is measured from the +x axis, so upright is pi/2.
CARTPOLE_INTERVALS: tuple[tuple[float, float], ...] = (
    (-2.4, 2.4),
    (-1.0, 1.0),
    (float(np.deg2rad(78.0)), float(np.deg2rad(102.0))),
    (-2.0, 2.0),
)


class CartPoleEnv(FMUEnv):
    """Balance a pole on a cart by pushing the cart left (action 0) or right (action 1).

    Observation: ``[x, x_dot, theta, theta_dot]`` in m, m/s, rad, rad/s; ``theta`` is measured
    from the +x axis, so upright is pi/2.

    Example::

        import modelicagym

        env = modelicagym.make("cartpole", force=11.0, m_cart=5.0)
        observation, info = env.reset(seed=0)
        observation, reward, terminated, truncated, info = env.step(1)

    Parameters:
        force: force magnitude of a push [N].
        m_cart, m_pole, length, diameter, density, theta_0, theta_dot_0, x_0, x_dot_0: the
            model's parameters (SI units; ``theta_0`` in rad).
        time_step: seconds per step.
        positive_reward / negative_reward: reward per surviving step / on failure.
        max_episode_steps: truncate after this many steps (None: never).
        x_threshold [m], theta_threshold [rad]: the failure bounds.
        fmi_version: 1, 2 or 3; mode: ``"cs"`` or ``"me"`` (FMI 1.0 builds the FMU of that mode).
        cs_step_size: the FMU's internal co-simulation integration step [s] (None: its default).
        render_mode: ``"rgb_array"`` draws the scene into a numpy image.
        fmu_options: further `FMUEnvConfig` keys (e.g. ``reset_rung``, ``solver``).
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 20}
    #: the action is a force in [-force, force] N (`CartPoleContinuousEnv`), not a push left or right
    continuous = False

    #: built from our sources (`modelicagym.models`): a pool may step it in the calling process
    safe_in_caller = True

    def __init__(
        self,
        *,
        force: float = 15.0,
        m_cart: float = 10.0,
        m_pole: float = 1.0,
        length: float = 2.0,
        diameter: float = 0.05,
        density: float = 900.0,
        theta_0: float = float(np.deg2rad(85.0)),
        theta_dot_0: float = 0.0,
        x_0: float = 0.0,
        x_dot_0: float = 0.0,
        time_step: float = 0.05,
        positive_reward: float = 1.0,
        negative_reward: float = -100.0,
        max_episode_steps: int | None = None,
        x_threshold: float = 2.4,
        theta_threshold: float = float(np.deg2rad(12.0)),
        fmi_version: int = 2,
        mode: str = "cs",
        cs_step_size: float | None = None,
        render_mode: str | None = None,
        **fmu_options: Any,
    ):
        parameters = dict(
            m_cart=m_cart, m_pole=m_pole, length=length, diameter=diameter, density=density,
            theta_0=theta_0, theta_dot_0=theta_dot_0, x_0=x_0, x_dot_0=x_dot_0,
        )
        if cs_step_size is not None:
            parameters["cs_step_size"] = cs_step_size
        self.force = float(force)
        self.x_threshold = float(x_threshold)
        self.theta_threshold = float(theta_threshold)
        super().__init__(
            fmu=cartpole_fmu(fmi_version, mode),
            inputs=["f"],
            outputs=list(OUTPUTS),
            parameters=parameters,
            time_step=time_step,
            max_episode_steps=max_episode_steps,
            positive_reward=positive_reward,
            negative_reward=negative_reward,
            termination={"x": (-self.x_threshold, self.x_threshold),
                         "theta": (UPRIGHT - self.theta_threshold, UPRIGHT + self.theta_threshold)},
            **self._actions(),
            mode=mode,
            render_mode=render_mode,
            **fmu_options,
        )

    def _actions(self) -> dict[str, Any]:
        """The config entry that makes the action space: two pushes, or a continuous force."""
        if self.continuous:
            return {"action_space": spaces.Box(-self.force, self.force, (1,), dtype=np.float64)}
        return {"action_table": [[-self.force], [self.force]]}

    def render(self) -> np.ndarray | None:
        if self.render_mode != "rgb_array":
            return None
        from modelicagym.models.cartpole.drawing import draw_cartpole

        x, theta = float(self.fmu.outputs.views["x"]), float(self.fmu.outputs.views["theta"])
        pole = float(self.config.parameters["length"]) / 2
        return draw_cartpole(x, theta, pole, self.x_threshold)


class CartPoleContinuousEnv(CartPoleEnv):
    """`CartPoleEnv` with a continuous action: the force on the cart, in ``[-force, force]`` N.

    Same model, observation, reward and termination; ``force`` (default 15 N) bounds the action
    instead of fixing the push. Registered as ``ModelicaGym/CartPoleContinuous-v0``.

    Example::

        import numpy as np
        import modelicagym

        env = modelicagym.make("cartpole-continuous")
        observation, info = env.reset(seed=0)
        observation, reward, terminated, truncated, info = env.step(np.array([2.5]))
    """

    continuous = True
