"""A pool whose envs would not fit in memory is refused while its first envs are created, with
the counts and sizes, instead of driving the machine into swap; nothing is left behind."""

from __future__ import annotations

from functools import partial

import gymnasium as gym
import numpy as np
import pytest
from gymnasium import spaces
from vector_leaks import Snapshot

from modelicagym.vector import PoolMemoryError, PoolVectorEnv
from modelicagym.vector.slice.creation import FIRST_MEASURE, available_memory, create_envs

pytestmark = [
    pytest.mark.timeout(120),
    pytest.mark.usefixtures("pool_services"),
    pytest.mark.skipif(available_memory() is None, reason="the machine's available memory is read from /proc/meminfo"),
]

#: what each env holds: the pools below need more than the machine has, while their first envs are few
ENV_BYTES = 64 * 2**20


class HeavyEnv(gym.Env):
    """An env holding ``ENV_BYTES`` of (touched) memory."""

    observation_space = spaces.Box(-1.0, 1.0, (1,))
    action_space = spaces.Discrete(2)

    def __init__(self) -> None:
        self.weights = np.ones(ENV_BYTES // 8)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        return np.zeros(1, dtype=np.float32), {}

    def step(self, action):
        return np.zeros(1, dtype=np.float32), 0.0, False, False, {}


def too_many() -> int:
    """Enough HeavyEnvs to need twice the memory available now."""
    return 2 * available_memory() // ENV_BYTES


def test_create_envs_stops_early_and_closes_what_it_created() -> None:
    closed = []

    class Closing(HeavyEnv):
        def close(self) -> None:
            closed.append(self)

    n = too_many()
    with pytest.raises(PoolMemoryError) as info:
        create_envs([Closing] * n, 10, "the calling process")
    message = str(info.value)
    assert f"the calling process created {len(closed)} of its {n} envs (from env 10 on)" in message
    assert "available" in message and "fewer envs" in message
    assert FIRST_MEASURE < len(closed) <= 4 * FIRST_MEASURE


def test_envs_that_fit_are_all_created() -> None:
    envs = create_envs([partial(spaces.Discrete, 3)] * 600, 0, "the calling process")
    assert len(envs) == 600


@pytest.mark.parametrize("num_workers", [0, 2])
def test_a_pool_that_would_not_fit_is_refused_with_nothing_left_behind(num_workers: int) -> None:
    before = Snapshot.take()
    with pytest.raises(PoolMemoryError, match=r"created \d+ of its \d+ envs .* each took ~65\d\d\d KiB.*more than its share"):
        PoolVectorEnv([HeavyEnv] * too_many(), num_workers=num_workers)
    before.assert_restored()
