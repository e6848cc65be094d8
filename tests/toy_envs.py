"""Tiny deterministic envs whose best and longest episodes are known by hand: for the agent's and
the experiments' tests."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np


class Walk(gym.Env):
    """A walk on the integers from 0 (never below): action ``a`` moves by ``moves[a]``, each step is
    worth ``reward``, and the episode terminates on reaching position ``goal``."""

    observation_space = gym.spaces.Box(0.0, 10.0, (1,), np.float64)
    action_space = gym.spaces.Discrete(2)

    def __init__(self, moves: tuple[int, int], reward: float, goal: int = 5) -> None:
        self.moves, self.reward, self.goal = moves, reward, goal
        self.position = 0

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict]:
        super().reset(seed=seed)
        self.position = 0
        return np.array([0.0]), {}

    def step(self, action: int) -> tuple[np.ndarray, float, bool, bool, dict]:
        self.position = max(0, self.position + self.moves[action])
        return np.array([float(self.position)]), self.reward, self.position >= self.goal, False, {}


def counter(length: int) -> Walk:
    """Observation = number of steps taken, +1 per step; the episode terminates after ``length`` steps."""
    return Walk(moves=(1, 1), reward=1.0, goal=length)


def chain() -> Walk:
    """Action 1 moves right, 0 moves left; -1 per step: the best policy goes right all the way."""
    return Walk(moves=(-1, 1), reward=-1.0)


def drift() -> Walk:
    """Drifts +1 per step, +2 with action 1: the longest episode (5 steps) always takes action 0."""
    return Walk(moves=(1, 2), reward=1.0)
