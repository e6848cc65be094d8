"""Driving one env through an episode: the observations it returns, for comparing episodes."""

from __future__ import annotations

from typing import Any, Iterable

import gymnasium as gym


def observations(env: gym.Env, actions: Iterable[Any], **reset: Any) -> list:
    """Observations of one episode: ``env.reset(**reset)``, then one step per action (stops when it ends)."""
    observation, _ = env.reset(**reset)
    trajectory = [observation]
    for action in actions:
        observation, _, terminated, truncated, _ = env.step(action)
        trajectory.append(observation)
        if terminated or truncated:
            break
    return trajectory
