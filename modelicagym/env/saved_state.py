"""An env's state as a value (`EnvState`), and start states sampled from a list (`StartStates`).

``env.unwrapped.get_state()`` gives an `EnvState`: the FMU's state (`modelicagym.fmu.saved_state`:
its serialized bytes, the clock, the model-exchange solver's restart information) and what the env
keeps beside it (the steps of the episode so far, the episode's parameters, the state of its random
generator, and a tracking task's setpoints, previous action and error integral). It pickles, so it can be saved beside a model, sent to another process or kept in a
library of start states; ``set_state(state)`` puts it back, and ``reset(options={"state": state})``
starts an episode there (its step count from zero). ``start_states=[...]`` in the config makes every
reset without a state of its own start from one of them, drawn with the env's generator.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from modelicagym.errors import ConfigError
from modelicagym.fmu.saved_state import FMUState

__all__ = ["EnvState", "StartStates", "generator_state", "restored_generator"]


@dataclass(frozen=True, eq=False)
class EnvState:
    """The whole state of an `FMUEnv`: picklable, loadable into any env over the same FMU.

    ``rng`` is the state of the env's ``np_random`` (``None`` if it had none yet).
    """

    fmu: FMUState
    elapsed_steps: int
    episode_parameters: dict[str, Any]
    rng: dict[str, Any] | None
    #: the task's part (`modelicagym.env.tracking`: the episode's setpoints, the previous action,
    #: the error's integral), ``None`` for an env without setpoints or observation entries
    task: dict[str, Any] | None = None

    @property
    def time(self) -> float:
        """The simulation time the state was saved at."""
        return self.fmu.time

    def __repr__(self) -> str:
        return (f"EnvState(t={self.fmu.time}, elapsed_steps={self.elapsed_steps}, "
                f"{len(self.fmu.data):,} bytes of FMU state)")


class StartStates:
    """A list of `EnvState` to start episodes from, e.g. recorded operating points.

    ``StartStates(states).sample(rng)`` draws one uniformly (``weights`` makes it a categorical
    draw); ``options_per_env(n, rng)`` gives a vector env's ``reset`` one state per env. As the
    ``start_states`` config entry, every reset of the env that brings no state of its own draws one.
    """

    def __init__(self, states: Iterable[EnvState], weights: Sequence[float] | None = None) -> None:
        self.states = list(states)
        if not self.states:
            raise ConfigError("start_states is empty: give at least one state (env.unwrapped.get_state())")
        bad = next((s for s in self.states if not isinstance(s, EnvState)), None)
        if bad is not None:
            raise ConfigError(f"start_states holds {type(bad).__name__} {bad!r}, "
                              "not an EnvState from env.unwrapped.get_state()")
        self.weights = None
        if weights is not None:
            w = np.asarray(weights, dtype=np.float64)
            if w.shape != (len(self.states),) or not np.all(np.isfinite(w)) or np.any(w < 0) or w.sum() <= 0:
                raise ConfigError(f"start_states weights must be {len(self.states)} finite non-negative numbers "
                                  f"with a positive sum, got {weights!r}")
            self.weights = w / w.sum()

    def __len__(self) -> int:
        return len(self.states)

    def sample(self, rng: np.random.Generator) -> EnvState:
        """One state, drawn with ``rng``."""
        return self.states[int(rng.choice(len(self.states), p=self.weights))]

    def options_per_env(self, n: int, rng: np.random.Generator) -> list[dict[str, Any]]:
        """``[{"state": s}, ...]`` for ``n`` envs: a vector env's
        ``reset(options={"options_per_env": ...})`` starts env ``i`` from its own draw."""
        return [{"state": self.sample(rng)} for _ in range(n)]


def generator_state(rng: np.random.Generator | None) -> dict[str, Any] | None:
    """The picklable state of ``rng`` (its bit generator's), or ``None``."""
    return None if rng is None else dict(rng.bit_generator.state)


def restored_generator(state: dict[str, Any]) -> np.random.Generator:
    """A generator that continues exactly as the one `generator_state` was taken from."""
    bit_generator = getattr(np.random, state["bit_generator"])()
    bit_generator.state = state
    return np.random.Generator(bit_generator)
