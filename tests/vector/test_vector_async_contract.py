"""What code written for ``gymnasium.vector.AsyncVectorEnv`` relies on: its constructor's keyword
arguments and its warnings (the rest of the contract is tested against SyncVectorEnv elsewhere)."""

from __future__ import annotations

import logging
import multiprocessing
from functools import partial

import numpy as np
import pytest
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, SyncVectorEnv
from vector_envs import ActionRecorder, BoundedEnv, CountEnv, GrowingEnv, WordEnv
from vector_rollouts import assert_same, rollout

from modelicagym.errors import ConfigError
from modelicagym.vector import EnvError, PoolVectorEnv, SpaceMismatchError


def test_async_vector_env_keyword_arguments_are_accepted() -> None:
    with PoolVectorEnv([CountEnv] * 2, context="forkserver", shared_memory=True, copy=True, daemon=True,
                       observation_mode="same", autoreset_mode="NextStep") as pool:
        assert pool.start_method == "forkserver"
        pool.reset(seed=0)
        pool.step(np.zeros(2, dtype=np.int64))


@pytest.mark.parametrize(
    "options, match",
    [
        ({"worker": lambda *args: None}, "a custom worker function is not supported"),
        ({"observation_mode": "weird"}, "Invalid `observation_mode`"),
        ({"daemon": False}, "daemon=False is not supported"),
        ({"context": "spawn", "start_method": "fork"}, "disagree"),
    ],
)
def test_what_the_pool_does_not_support_is_said_at_once(options: dict, match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        PoolVectorEnv([CountEnv] * 2, **options)


@pytest.mark.parametrize("terminate", [False, True])
def test_closing_with_a_pending_call_warns_as_async_vector_env_does(terminate: bool) -> None:
    pool = PoolVectorEnv([CountEnv] * 2, num_workers=2)
    pool.reset(seed=0)
    pool.step_async(np.zeros(2, dtype=np.int64))
    with pytest.warns(UserWarning, match="Calling `close` while waiting for a pending call to `step` to complete"):
        pool.close(terminate=terminate)
    assert pool.closed


class Refusing(CountEnv):
    def reset(self, *, seed=None, options=None):
        raise KeyError("no such scenario")


class CustomError(Exception):
    def __init__(self, code: int) -> None:
        super().__init__(f"code {code}")
        self.code = code


class Failing(CountEnv):
    def step(self, action):
        raise CustomError(7)


def test_an_envs_exception_keeps_its_type() -> None:
    with PoolVectorEnv([CountEnv, Refusing], caller_steps=True) as pool:
        with pytest.raises(KeyError) as info:
            pool.reset(seed=0)
    assert isinstance(info.value, EnvError) and info.value.env_index == 1
    assert "no such scenario" in str(info.value)
    pool = PoolVectorEnv([CountEnv, Failing], num_workers=2)
    pool.reset(seed=0)
    with pytest.raises(CustomError) as info:
        pool.step(np.zeros(2, dtype=np.int64))
    assert isinstance(info.value, EnvError) and "code 7" in str(info.value)
    assert info.value.original.code == 7


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_each_env_receives_its_action_as_sync_vector_env_hands_it(dtype: type) -> None:
    """A ``Box(shape=(), dtype=float32)`` action reaches the env as a numpy scalar of the dtype the
    batch was given in, as ``iterate`` gives it (an env may ``time.sleep(action)``: not a float32)."""
    actions = np.array([0.1, 0.25], dtype=dtype)
    received = []
    for envs in (SyncVectorEnv([ActionRecorder] * 2), PoolVectorEnv([ActionRecorder] * 2, num_workers=2)):
        envs.reset(seed=0)
        envs.step(actions)
        received.append(envs.get_attr("last_action"))
        envs.close()
    assert [(type(a), a) for a in received[0]] == [(type(a), a) for a in received[1]]
    assert type(received[1][0]) is dtype


def bounded_fns() -> list:
    return [partial(BoundedEnv, high) for high in (1.0, 2.0, 3.0)]


def test_observation_mode_same_refuses_differing_spaces_with_gymnasiums_message() -> None:
    with pytest.raises(SpaceMismatchError, match="use `observation_mode='different'` instead"):
        PoolVectorEnv(bounded_fns(), num_workers=2)


@pytest.mark.parametrize("layout", [{"num_workers": 2}, {"caller_steps": True}])
def test_observation_mode_different_batches_the_differing_spaces(layout: dict) -> None:
    sync = SyncVectorEnv(bounded_fns(), observation_mode="different")
    with PoolVectorEnv(bounded_fns(), observation_mode="different", **layout) as pool:
        assert pool.observation_space == sync.observation_space
        assert_same(rollout(sync, 30), rollout(pool, 30))
    sync.close()


def test_observation_mode_custom_spaces() -> None:
    single = spaces.Box(-5.0, 5.0, shape=(3,), dtype=np.float32)
    batched = spaces.Box(-5.0, 5.0, shape=(3, 3), dtype=np.float32)
    with PoolVectorEnv(bounded_fns(), observation_mode=(batched, single), num_workers=2) as pool:
        assert (pool.observation_space, pool.single_observation_space) == (batched, single)
        observations, _ = pool.reset(seed=0)
        assert observations.shape == (3, 3)


@pytest.mark.parametrize("autoreset_mode", list(AutoresetMode))
@pytest.mark.parametrize("layout", [{"num_workers": 2}, {"num_workers": 1, "caller_steps": True}])
def test_custom_spaces_travel_pickled_with_the_same_results(layout: dict, autoreset_mode: AutoresetMode) -> None:
    """Spaces with no shared-memory layout work as in ``AsyncVectorEnv(shared_memory=False)``."""
    fns = [partial(WordEnv, length) for length in (4, 6, 9)]
    sync = SyncVectorEnv(fns, autoreset_mode=autoreset_mode)
    with PoolVectorEnv(fns, autoreset_mode=autoreset_mode, **layout) as pool:
        assert pool.observation_space == sync.observation_space
        assert_same(rollout(sync, 40), rollout(pool, 40))
    sync.close()


def test_spaces_of_dynamic_shape_travel_pickled_with_the_same_results() -> None:
    sync = SyncVectorEnv([GrowingEnv] * 3)
    with PoolVectorEnv([GrowingEnv] * 3, num_workers=2, shared_memory=True) as pool:
        assert_same(rollout(sync, 12), rollout(pool, 12))
    sync.close()


def test_custom_spaces_are_said_once_and_env_errors_still_name_the_env(caplog: pytest.LogCaptureFixture) -> None:
    with caplog.at_level(logging.WARNING, logger="modelicagym.vector"):
        pool = PoolVectorEnv([WordEnv] * 2, num_workers=2)
    said = [record.getMessage() for record in caplog.records if "no shared-memory layout" in record.getMessage()]
    assert len(said) == 2 and "observation space" in said[0] and "action space" in said[1]
    with pool:
        pool.reset(seed=1)
        pool.step(("ab", "b"))
        with pytest.raises(ValueError, match="not a word over 'ab'") as info:
            pool.step(("a", "c"))
        assert isinstance(info.value, EnvError) and info.value.env_index == 1


class Slow(CountEnv):
    """Resets, and works when called, in ``cost`` seconds of busy CPU, as its steps take."""

    def reset(self, *, seed=None, options=None):
        self._spend()
        return super().reset(seed=seed, options=options)

    def work(self) -> None:
        self._spend()


@pytest.mark.parametrize("wait", ["step_wait", "reset_wait", "call_wait"])
def test_a_timeout_given_to_a_wait_bounds_the_callers_own_envs_too(wait: str) -> None:
    """The calling process runs env 1 itself (0.3 s a call): a 0.1 s timeout raises a
    TimeoutError, as AsyncVectorEnv's does, and the pool stays usable."""
    fns = [Slow, partial(Slow, cost=0.3)]
    with PoolVectorEnv(fns, num_workers=1, caller_steps=True, adapt_layout=False) as pool:
        pool.reset(seed=0)
        start = {"step_wait": partial(pool.step_async, np.zeros(2, dtype=np.int64)),
                 "reset_wait": partial(pool.reset_async, seed=1), "call_wait": partial(pool.call_async, "work")}
        start[wait]()
        with pytest.raises(multiprocessing.TimeoutError, match=f"`{wait}` has timed out after 0.1 second"):
            getattr(pool, wait)(timeout=0.1)
        start[wait]()
        getattr(pool, wait)(timeout=30.0)
        observations, rewards, *_ = pool.step(np.zeros(2, dtype=np.int64))
        assert observations.shape[0] == 2
