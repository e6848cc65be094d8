"""Envs whose inputs or observation are computed in Python around a native FMU step, as users write
them: an overridden ``observation`` (a Box of derived features), an overridden ``action_to_inputs``
(a ``Discrete`` action mapped to input values, or to a dict of a subset of the inputs), both, and
each with a reward and termination written in Python; on the bundled cart-pole (any FMI version and
mode) and on the probe test FMU (integer and boolean inputs). Module-level classes, so that a
pool's workers can make them."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces

from modelicagym import FMUEnv
from modelicagym.models.cartpole.env import UPRIGHT, CartPoleEnv


class FeatureCartPole(CartPoleEnv):
    """The observation as derived features, float32: x, x_dot, cos(theta), sin(theta), theta_dot."""

    stateless_hooks = True  # its hooks keep no state: a pool may move it between processes

    def make_observation_space(self) -> spaces.Space:
        return spaces.Box(-np.inf, np.inf, (5,), np.float32)

    def observation(self) -> np.ndarray:
        x, x_dot, theta, theta_dot = self.fmu.outputs.flat
        return np.array([x, x_dot, np.cos(theta), np.sin(theta), theta_dot], dtype=np.float32)


class ThreeForceCartPole(CartPoleEnv):
    """A ``Discrete(3)`` action: push left, nothing, push right (repeated actions keep the inputs)."""

    stateless_hooks = True

    def make_action_space(self) -> spaces.Space:
        return spaces.Discrete(3)

    def action_to_inputs(self, action: Any) -> list[float]:
        return [(-self.force, 0.0, self.force)[int(action)]]


class BothCartPole(FeatureCartPole, ThreeForceCartPole):
    """Both edges in Python."""


class Endings:
    """A reward and termination written in Python, per env, from whatever the observation is."""

    def compute_reward(self, observation: Any, action: Any, terminated: bool) -> float:
        return float(np.sum(np.asarray(observation, dtype=np.float64)) * 0.01 + int(action) - 10.0 * terminated)

    def is_terminal(self, observation: Any) -> bool:
        outputs = self.fmu.outputs.views
        return bool(abs(float(outputs["x"])) > 0.8 or abs(float(outputs["theta"]) - UPRIGHT) > 0.15)


class FeatureCartPoleEndings(Endings, FeatureCartPole):
    pass


class ThreeForceCartPoleEndings(Endings, ThreeForceCartPole):
    pass


class BothCartPoleEndings(Endings, BothCartPole):
    pass


#: name -> the class, and what Python computes around the C step
CARTPOLES = {
    "observation": (FeatureCartPole, ("observation",)),
    "inputs": (ThreeForceCartPole, ("inputs",)),
    "both": (BothCartPole, ("inputs", "observation")),
    "observation+endings": (FeatureCartPoleEndings, ("observation",)),
    "inputs+endings": (ThreeForceCartPoleEndings, ("inputs",)),
    "both+endings": (BothCartPoleEndings, ("inputs", "observation")),
}

PROBE_INPUTS = ["gear", "mode", "enable", "boost", "force"]
PROBE_OUTPUTS = ["position", "speed", "moving", "steps"]


class GearboxProbe(FMUEnv):
    """The probe FMU driven by a ``Discrete(10)`` action mapped to a dict of a subset of its
    inputs (an integer, a boolean and a float; ``mode`` and ``boost`` keep their start values), its
    observation derived from outputs of three types; bounds on ``position`` (checked in C)."""

    stateless_hooks = True

    def __init__(self, path: Path, **config: Any) -> None:
        config = {"time_step": 0.1, "max_episode_steps": 13, "termination": {"position": (-2.5, 2.5)}, **config}
        super().__init__(fmu=path, inputs=PROBE_INPUTS, outputs=PROBE_OUTPUTS, **config)

    def make_action_space(self) -> spaces.Space:
        return spaces.Discrete(10)

    def action_to_inputs(self, action: Any) -> dict[str, Any]:
        a = int(action)
        return {"gear": a % 5, "enable": a >= 5, "force": 0.25 * (a % 3 - 1)}

    def make_observation_space(self) -> spaces.Space:
        return spaces.Box(-np.inf, np.inf, (4,), np.float64)

    def observation(self) -> np.ndarray:
        outputs = self.fmu.outputs.views
        return np.array([2.0 * outputs["position"], 0.5 * outputs["speed"], outputs["moving"], outputs["steps"]])


class GearboxProbeEndings(GearboxProbe):
    """The same, with its reward in Python (on the observation above)."""

    def compute_reward(self, observation: Any, action: Any, terminated: bool) -> float:
        return float(observation[0] - observation[1] + int(action) - 5.0 * terminated)


class CountingBothCartPole(BothCartPole):
    """Both edges in Python, counting how often each hook runs (``calls``); ``fail_at`` (an
    ``action_to_inputs`` call number) makes that call raise, as a user's bug would."""

    stateless_hooks = False  # it counts in the env: the pool keeps it where it is

    def __init__(self, fail_at: int | None = None, **config: Any) -> None:
        self.calls = {"action_to_inputs": 0, "observation": 0}
        self.fail_at = fail_at
        super().__init__(**config)

    def action_to_inputs(self, action: Any) -> list[float]:
        self.calls["action_to_inputs"] += 1
        if self.calls["action_to_inputs"] == self.fail_at:
            raise RuntimeError(f"action_to_inputs failed at call {self.fail_at}")
        return super().action_to_inputs(action)

    def observation(self) -> np.ndarray:
        self.calls["observation"] += 1
        return super().observation()


class DictProbe(GearboxProbe):
    """The probe's own ``Dict`` action space (one entry per input; the force a float32 ``Box``)
    mapped in Python: the gear shifted, the force halved; its observation derived as `GearboxProbe`'s."""

    def make_action_space(self) -> spaces.Space:
        own = FMUEnv.make_action_space(self)
        return spaces.Dict({**own.spaces, "force": spaces.Box(-10.0, 10.0, (), np.float32)})

    def action_to_inputs(self, action: Any) -> dict[str, Any]:
        return {**action, "gear": (int(action["gear"]) + 1) % 5, "force": 0.5 * float(action["force"])}


class CountingProbe(GearboxProbe):
    """`GearboxProbe` counting how often each of its hooks runs (``calls``)."""

    stateless_hooks = False

    def __init__(self, path: Path, **config: Any) -> None:
        self.calls = {"action_to_inputs": 0, "observation": 0}
        super().__init__(path, **config)

    def action_to_inputs(self, action: Any) -> dict[str, Any]:
        self.calls["action_to_inputs"] += 1
        return super().action_to_inputs(action)

    def observation(self) -> np.ndarray:
        self.calls["observation"] += 1
        return super().observation()


class FailingRewardCartPole(BothCartPoleEndings):
    """Both edges and the endings in Python; with ``fail``, its reward raises at its third step."""

    stateless_hooks = False

    def __init__(self, fail: bool = False, **config: Any) -> None:
        self.fail, self.rewards = fail, 0
        super().__init__(**config)

    def compute_reward(self, observation: Any, action: Any, terminated: bool) -> float:
        self.rewards += 1
        if self.fail and self.rewards == 3:
            raise RuntimeError("compute_reward failed at its third call")
        return super().compute_reward(observation, action, terminated)
