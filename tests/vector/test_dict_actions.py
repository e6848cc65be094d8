"""A batch of ``Dict`` actions (an FMU with inputs of several types) is checked key by key on the
whole batch: every env gets the action ``SyncVectorEnv`` gives it, and a batch the single env would
refuse is refused with the single env's message and the first refusing env's index, as when each
env's dict was checked in turn."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium import spaces
from gymnasium.vector import SyncVectorEnv
from vector_rollouts import assert_same

from modelicagym.action_checks import check_action
from modelicagym.errors import ActionError
from modelicagym.vector import PoolVectorEnv

pytestmark = pytest.mark.timeout(120)

#: every kind of entry a Dict action of an FMU (or any env) has
SPACE = spaces.Dict({
    "flag": spaces.Discrete(2),
    "option": spaces.Discrete(2, start=1),
    "x": spaces.Box(-1.0, 1.0, (), np.float64),
    "y": spaces.Box(-1.0, 1.0, (), np.float32),
    "free": spaces.Box(-np.inf, np.inf, (), np.float64),
    "count": spaces.Box(-5, 5, (), np.int64),
    "big": spaces.Box(0, 2**64 - 1, (), np.uint64),
    "vec": spaces.Box(np.array([-1.0, -2.0, -3.0]), np.array([1.0, 2.0, 3.0]), (3,), np.float64),
    "md": spaces.MultiDiscrete([2, 3]),
    "mb": spaces.MultiBinary(2),
})


class Echo(gym.Env):
    """Observes the action it was given (the same Dict space), so a step shows what reached it."""

    observation_space = SPACE
    action_space = SPACE

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict]:
        super().reset(seed=seed)
        return SPACE.sample(), {}

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict]:
        return {key: np.array(value, dtype=SPACE[key].dtype) for key, value in action.items()}, 0.0, False, False, {}


def with_value(actions: dict[str, np.ndarray], key: str, env: int, value: Any) -> dict[str, np.ndarray]:
    """``actions`` with env ``env``'s entry ``key`` replaced by ``value`` (in the entry's dtype)."""
    changed = {name: array.copy() for name, array in actions.items()}
    changed[key][env] = value
    return changed


def single_env_message(actions: dict[str, np.ndarray], env: int) -> str:
    """What the single env says about env ``env``'s action of the batch."""
    with pytest.raises(ActionError) as info:
        check_action(SPACE, {key: array[env] for key, array in actions.items()})
    return f"env {env}: {info.value}"


@pytest.fixture(params=[3, 40], ids=["n3", "n40"])  # 40: past the entries checked in Python, numpy's
def pools(request: pytest.FixtureRequest) -> Any:
    n = request.param
    sync = SyncVectorEnv([Echo] * n)
    with PoolVectorEnv([Echo] * n, num_workers=0, caller_steps=True) as pool:
        sync.reset(seed=0)
        pool.reset(seed=0)
        yield n, pool, sync
    sync.close()


def test_every_env_gets_its_entry_of_the_batch_as_sync_vector_env_gives_it(pools: Any) -> None:
    _, pool, sync = pools
    pool.action_space.seed(5)
    for _ in range(5):
        actions = pool.action_space.sample()
        observations, *_ = result = pool.step(actions)
        assert_same(result, sync.step(actions))
        for key, array in actions.items():
            assert observations[key].dtype == array.dtype
            assert np.array_equal(observations[key], array)


@pytest.mark.parametrize("key, value", [
    ("flag", 2), ("option", 0), ("option", 3), ("x", 1.5), ("x", np.nan), ("x", -np.inf), ("y", 2.0),
    ("y", np.nan), ("free", np.inf), ("free", np.nan), ("count", 6), ("count", -6), ("vec", [0.0, 2.5, 0.0]),
    ("vec", [0.0, 0.0, np.nan]), ("md", [0, 3]), ("md", [-1, 0]), ("mb", [0, 2]),
])
def test_a_refused_entry_is_named_with_the_single_envs_message_and_its_env(pools: Any, key: str, value: Any) -> None:
    n, pool, sync = pools
    pool.action_space.seed(7)
    good = pool.action_space.sample()
    for env in (0, n - 1):
        bad = with_value(good, key, env, value)
        with pytest.raises(ActionError) as info:
            pool.step(bad)
        assert str(info.value) == single_env_message(bad, env)
    assert_same(pool.step(good), sync.step(good))  # still usable, and nothing of the refused batch stays


def test_batches_in_other_forms_are_taken_as_before(pools: Any) -> None:
    """Other dtypes and lists go through each env's check, which takes what the single env takes."""
    _, pool, sync = pools
    pool.action_space.seed(3)
    actions = pool.action_space.sample()
    for key, form in (("x", lambda a: a.astype(np.float32)), ("count", lambda a: a.astype(np.float64)),
                      ("flag", lambda a: a.tolist()), ("vec", lambda a: a.astype(np.int64))):
        other = {**actions, key: form(actions[key])}
        assert_same(pool.step(other), sync.step(other))


def test_a_batch_with_a_missing_or_unknown_key_or_the_wrong_shape_is_refused(pools: Any) -> None:
    n, pool, sync = pools
    actions = pool.action_space.sample()
    with pytest.raises(ActionError, match=r"missing: \['x'\], unknown: \['z'\]"):
        pool.step({**{key: value for key, value in actions.items() if key != "x"}, "z": actions["x"]})
    with pytest.raises(ActionError, match=rf"'count' has shape \({n - 1},\), expected one entry per env \({n}\)"):
        pool.step({**actions, "count": actions["count"][:-1]})
    assert_same(pool.step(actions), sync.step(actions))
