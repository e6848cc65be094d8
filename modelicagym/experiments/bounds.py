"""The longest episode any agent could achieve, by exhaustive search over action sequences.

For a deterministic env that always starts from the same state (the cart-pole env: fixed
``theta_0``, no noise), the best possible episode length is a maximum over the finite tree of
action sequences, pruned where an episode terminates. When that tree dies out within a few steps
(too weak a force, too heavy a pole, too long a time step), the search is cheap and gives an exact
bound: an agent that "fails to learn" there may simply have nothing left to learn. When some
sequence survives longer, the tree explodes and the search gives up (``None``).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

import gymnasium
from gymnasium import spaces

from modelicagym.errors import ArgumentTypeError
from modelicagym.experiments.config import SweepConfig

__all__ = ["DEFAULT_BUDGET", "MakeEnv", "longest_episode", "sweep_bounds"]

logger = logging.getLogger(__name__)

#: ``make(env_id, **options) -> gymnasium.Env``
MakeEnv = Callable[..., gymnasium.Env]

#: Env steps one setting's search may take (a few seconds at most).
DEFAULT_BUDGET = 50_000


def _terminates(env: gymnasium.Env, actions: tuple[int, ...], seed: int) -> bool:
    """Replay ``actions`` from the start; whether the last one terminates the episode."""
    env.reset(seed=seed)
    for action in actions:
        _, _, terminated, _, _ = env.step(action)
        if terminated:
            return True
    return False


def longest_episode(env: gymnasium.Env, *, budget: int = DEFAULT_BUDGET, seed: int = 0) -> int | None:
    """Length of the longest episode over all action sequences, or ``None`` if not found within
    ``budget`` env steps. ``env`` must be deterministic with a ``Discrete`` action space."""
    if not isinstance(env.action_space, spaces.Discrete):
        raise ArgumentTypeError(f"exhaustive search needs a Discrete action space, got {env.action_space!r}")
    actions = range(int(env.action_space.n))
    alive: list[tuple[int, ...]] = [()]  # action sequences of the current length still running
    length, used = 0, 0
    while alive:
        length += 1
        used += len(alive) * len(actions) * length
        if used > budget:
            return None
        alive = [seq + (a,) for seq in alive for a in actions if not _terminates(env, seq + (a,), seed)]
    return length


def sweep_bounds(
    config: SweepConfig, *, make: MakeEnv | None = None, budget: int = DEFAULT_BUDGET
) -> dict[str, int | None]:
    """:func:`longest_episode` for every setting of ``config`` (without its step limit)."""
    if make is None:
        import modelicagym

        make = modelicagym.make
    bounds: dict[str, int | None] = {}
    for setting in config.settings:
        options: dict[str, Any] = config.options_for(setting)
        options.pop("max_episode_steps", None)
        env = make(config.env, **options)
        try:
            bounds[setting.label] = longest_episode(env, budget=budget)
        finally:
            env.close()
        logger.info("sweep %r, %s: longest possible episode %s", config.name, setting.label, bounds[setting.label])
    return bounds
