"""The pool refuses, in the parent, every action the single env would refuse: with the single env's
message and the env index, and the pool stays usable."""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from gymnasium import spaces
from gymnasium.vector import SyncVectorEnv
from step_paths import probe_env
from vector_envs import CountEnv
from vector_rollouts import assert_same

import modelicagym
from modelicagym.errors import ActionError
from modelicagym.vector import PoolVectorEnv

pytestmark = pytest.mark.timeout(120)

#: where the envs step: the calling process and workers, workers only, every env at home (a step
#: is then one C call, which range-checks the batch before it steps any env)
LAYOUTS = {"caller steps": {"caller_steps": True}, "workers": {"caller_steps": False, "num_workers": 2},
           "at home": {"num_workers": 0}}


def single_env_message(action: Any) -> str:
    env = modelicagym.make("cartpole")
    env.reset(seed=0)
    with pytest.raises(ActionError) as info:
        env.step(action)
    return str(info.value)


@pytest.mark.parametrize("layout", LAYOUTS)
@pytest.mark.parametrize(
    "actions, env_index, single",
    [
        (np.array([0.0, 1.2]), 1, np.float64(1.2)),
        (np.array([np.nan, 0.0]), 0, np.float64(np.nan)),
        (np.array([1, 5]), 1, np.int64(5)),
        (np.array([-1, 0]), 0, np.int64(-1)),
    ],
)
def test_refused_with_the_single_envs_message_and_the_env_index(
    layout: str, actions: np.ndarray, env_index: int, single: Any
) -> None:
    fns = [partial(modelicagym.make, "cartpole")] * 2
    with PoolVectorEnv(fns, **LAYOUTS[layout]) as pool, modelicagym.make_vec("cartpole", n=2) as twin:
        assert_same(pool.reset(seed=0), twin.reset(seed=0))
        with pytest.raises(ActionError) as info:
            pool.step(actions)
        assert str(info.value) == f"env {env_index}: {single_env_message(single)}"
        # still usable, and no env stepped on the refused batch
        assert_same(pool.step(np.array([1, 0])), twin.step(np.array([1, 0])))


WRONG_BATCH = "expected a batch of 2 actions"
SCALAR = "Unable to iterate over the following elements"  # Gymnasium's TypeError for a scalar


@pytest.mark.parametrize("actions, error, match", [
    (np.array([1, 0, 1]), ActionError, WRONG_BATCH),
    (np.array([[1], [0]]), ActionError, WRONG_BATCH),
    (1, TypeError, SCALAR),
    (np.int64(1), TypeError, SCALAR),
    (np.array(1), TypeError, SCALAR),
])
def test_a_batch_of_the_wrong_shape_or_a_scalar_is_refused_and_the_pool_stays_usable(
    actions: Any, error: type, match: str
) -> None:
    with modelicagym.make_vec("cartpole", n=2) as pool:
        pool.reset(seed=0)
        with pytest.raises(error, match=match):
            pool.step(actions)
        pool.step(np.array([0, 1]))


def test_integral_floats_and_lists_are_taken_as_the_single_env_takes_them() -> None:
    with modelicagym.make_vec("cartpole", n=2) as pool, modelicagym.make_vec("cartpole", n=2) as other:
        pool.reset(seed=0)
        other.reset(seed=0)
        for actions in ([1, 0], np.array([1.0, 0.0]), (0, 1)):
            assert_same(pool.step(actions), other.step(np.asarray(actions, dtype=np.int64)))


@pytest.mark.parametrize("layout", ["caller steps", "at home"])
def test_box_actions_are_checked_for_bounds_and_nan(family_fmu: Callable[[str, int], Path], layout: str) -> None:
    fns = [partial(probe_env, family_fmu("probe", 2))] * 3
    sync = SyncVectorEnv(fns)
    with PoolVectorEnv(fns, **LAYOUTS[layout]) as pool:
        assert_same(pool.reset(seed=0), sync.reset(seed=0))
        for actions, index in ((np.array([[0.0], [11.0], [0.0]]), 1), (np.array([[0.0], [0.0], [np.nan]]), 2)):
            with pytest.raises(ActionError, match=rf"env {index}: invalid action .*the action space is Box"):
                pool.step(actions)
        good = np.full((3, 1), 2.0)
        assert_same(pool.step(good), sync.step(good))
    sync.close()


@pytest.mark.parametrize("act, bad, match", [
    ("dict", {"position": np.zeros((2, 2)), "mode": np.array([0, 3])}, "env 1: .*'mode': out of range"),
    ("multidiscrete", np.array([[0, 0], [2, 4]]), "env 1: .*out of range"),
    ("discrete", np.array([-2, 3]), "env 1: .*out of range \\[-2, 2\\]"),
])
def test_other_spaces_are_checked_element_by_element(act: str, bad: Any, match: str) -> None:
    fns = [partial(CountEnv, act=act)] * 2
    sync = SyncVectorEnv(fns)
    with PoolVectorEnv(fns, caller_steps=True) as pool:
        pool.reset(seed=0)
        sync.reset(seed=0)
        with pytest.raises(ActionError, match=match):
            pool.step(bad)
        pool.action_space.seed(1)
        sync.action_space.seed(1)
        actions = pool.action_space.sample()
        assert_same(pool.step(actions)[:4], sync.step(actions)[:4])
    sync.close()


def test_a_dict_batch_names_missing_and_unknown_keys() -> None:
    with PoolVectorEnv([partial(CountEnv, act="dict")] * 2, caller_steps=True) as pool:
        pool.reset(seed=0)
        with pytest.raises(ActionError, match=r"missing: \['mode'\], unknown: \['speed'\]"):
            pool.step({"position": np.zeros((2, 2)), "speed": np.zeros(2)})


class Int32Discrete(CountEnv):
    """Actions from a ``Discrete`` space with a start and a dtype other than int64."""

    def __init__(self) -> None:
        super().__init__()
        self.action_space = spaces.Discrete(4, start=1, dtype=np.int32)


def test_discrete_actions_of_any_dtype_are_range_checked_in_their_dtype() -> None:
    sync = SyncVectorEnv([Int32Discrete] * 3)
    with PoolVectorEnv([Int32Discrete] * 3, num_workers=2) as pool:
        pool.reset(seed=0)
        sync.reset(seed=0)
        good = np.array([1, 4, 2], dtype=np.int32)
        assert_same(pool.step(good)[:4], sync.step(good)[:4])
        with pytest.raises(ActionError, match="env 2: .*out of range \\[1, 4\\]"):
            pool.step(np.array([1, 4, 0], dtype=np.int32))
        assert_same(pool.step(good)[:4], sync.step(good)[:4])
    sync.close()


def actions_ignored_by_resetting_envs(good: Any, bad: Any, ended: np.ndarray) -> Any:
    """``good`` with ``bad`` for the envs that ``ended`` (next-step autoreset ignores their actions)."""
    if isinstance(good, dict):
        return {key: np.where(ended.reshape((-1,) + (1,) * (value.ndim - 1)), bad[key], value)
                for key, value in good.items()}
    return np.where(ended.reshape((-1,) + (1,) * (good.ndim - 1)), bad, good)


@pytest.mark.parametrize("layout", LAYOUTS)
@pytest.mark.parametrize("make, good, bad", [
    (partial(modelicagym.make, "cartpole"), np.array([1, 1, 1]), 7),
    (partial(CountEnv, act="dict"), {"position": np.zeros((3, 2)), "mode": np.array([0, 1, 2])},
     {"position": np.full(2, np.nan), "mode": 9}),
])
def test_next_step_autoreset_ignores_the_action_of_a_resetting_env_unchecked(
    layout: str, make: Callable[[], Any], good: Any, bad: Any
) -> None:
    """As in ``SyncVectorEnv``: the step after an episode ended resets that env and ignores its
    action, whatever it is; the other envs' actions are still checked."""
    sync = SyncVectorEnv([make] * 3)
    with PoolVectorEnv([make] * 3, **LAYOUTS[layout]) as pool:
        assert_same(pool.reset(seed=3), sync.reset(seed=3))
        ended = np.zeros(3, dtype=bool)
        resets = 0
        for _ in range(40):
            actions = actions_ignored_by_resetting_envs(good, bad, ended)
            if ended.any() and not ended.all():
                with pytest.raises(ActionError, match=f"env {int(np.flatnonzero(~ended)[0])}: "):
                    pool.step(actions_ignored_by_resetting_envs(good, bad, np.ones(3, dtype=bool)))
            result = pool.step(actions)
            assert_same(result, sync.step(actions))
            resets += int(ended.sum())
            ended = result[2] | result[3]
        assert resets >= 2
    sync.close()


def test_step_envs_ignores_the_action_of_a_resetting_env_unchecked() -> None:
    with modelicagym.make_vec("cartpole", n=2) as pool:
        pool.reset(seed=0)
        ended = np.zeros(2, dtype=bool)
        while not ended[0]:
            *_, terminations, truncations, _ = pool.step_envs(np.array([1]), np.array([0]))
            ended = terminations | truncations
        observations, *_ = pool.step_envs(np.array([7]), np.array([0]))
        with pytest.raises(ActionError, match="env 0: "):
            pool.step_envs(np.array([7]), np.array([0]))
