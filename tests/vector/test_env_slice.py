"""`EnvSlice` knows nothing of processes: given envs and the pool's buffers in this process, its
step, reset, call and set_attr do what a `SyncVectorEnv` of the same envs does, in each autoreset
mode, on the Python path and on the native one, and an env's failure is a reply naming the env."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from env_slices import env_slice
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, SyncVectorEnv
from vector_envs import CountEnv, FaultyEnv

import modelicagym
from modelicagym.vector.slice.env_slice import EnvSlice
from modelicagym.vector.wire.buffers import SharedBuffers
from modelicagym.vector.wire.protocol import Kind

MODES = [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP]


def reset(part: EnvSlice, buffers: SharedBuffers, seeds: list[int]) -> tuple[np.ndarray, Any]:
    buffers.reset_mask[:] = True
    reply = part.reset(seeds, None)
    return buffers.observations.read_batch(copy_out=True), reply


def step(part: EnvSlice, buffers: SharedBuffers, actions: np.ndarray) -> tuple[Any, ...]:
    buffers.actions.write_batch(actions)
    reply = part.step()
    assert reply is None or reply.kind is Kind.INFOS, reply
    infos = dict(reply.data) if reply else {}
    return (buffers.observations.read_batch(copy_out=True), buffers.rewards.copy(), buffers.terminations.copy(),
            buffers.truncations.copy(), infos)


def compare_with_sync(fns: list[Callable[[], gym.Env]], mode: AutoresetMode, steps: int, path: str) -> None:
    sync = SyncVectorEnv(fns, autoreset_mode=mode)
    seeds = list(range(10, 10 + len(fns)))
    rng = np.random.default_rng(0)
    with env_slice(fns, mode) as (part, buffers):
        assert part.step_path == path, part.step_path_reason
        observations, _ = reset(part, buffers, seeds)
        expected, _ = sync.reset(seed=seeds)
        np.testing.assert_array_equal(observations, expected)
        ends = 0
        for _ in range(steps):
            actions = np.stack([sync.single_action_space.sample() for _ in fns])
            if sync.single_action_space.dtype.kind == "f":
                actions = rng.uniform(-1, 1, actions.shape).astype(actions.dtype)
            observation, reward, terminated, truncated, infos = step(part, buffers, actions)
            want = sync.step(actions)
            for got, wanted in zip((observation, reward, terminated, truncated), want[:4]):
                np.testing.assert_array_equal(got, wanted)
            ended = np.flatnonzero(terminated | truncated)
            ends += len(ended)
            if mode is AutoresetMode.SAME_STEP:
                for index in ended:
                    final = infos[index]["final_obs"] if path == "python" else buffers.final_observations.read(index)
                    np.testing.assert_array_equal(final, want[4]["final_obs"][index])
    sync.close()
    assert ends > 0, "no episode ended: autoreset was not exercised"


@pytest.mark.parametrize("mode", MODES, ids=lambda m: m.value)
def test_the_python_path_steps_as_sync_vector_env(mode: AutoresetMode) -> None:
    compare_with_sync([lambda: CountEnv(max_len=6)] * 3, mode, steps=40, path="python")


@pytest.mark.parametrize("mode", MODES, ids=lambda m: m.value)
def test_the_native_path_steps_as_sync_vector_env(mode: AutoresetMode) -> None:
    fns = [lambda: modelicagym.make("cartpole", max_episode_steps=30)] * 2
    compare_with_sync(fns, mode, steps=120, path="native")


def test_only_the_envs_of_the_step_mask_and_this_party_are_stepped() -> None:
    with env_slice([CountEnv] * 3, AutoresetMode.NEXT_STEP) as (part, buffers):
        reset(part, buffers, [1, 2, 3])
        buffers.step_mask[:] = (1, 0, 1)
        buffers.in_caller[:] = (0, 0, 1)  # env 2 is the calling process's: not this worker's
        step(part, buffers, np.zeros(3, dtype=np.int64))
        assert [env.steps for env in part.envs] == [1, 0, 0]


def test_an_envs_failure_is_a_reply_naming_it_and_calls_reach_every_env() -> None:
    fns = [CountEnv, lambda: FaultyEnv(fault="raise", at_step=2)]
    with env_slice(fns, AutoresetMode.NEXT_STEP) as (part, buffers):
        reset(part, buffers, [1, 2])
        step(part, buffers, np.zeros(2, dtype=np.int64))
        buffers.actions.write_batch(np.zeros(2, dtype=np.int64))
        reply = part.step()
        assert reply.kind is Kind.ERROR and reply.data.env_index == 1
        assert part.call(("double", (21,), {})).data == [42, 42]
        assert part.set_attr(("label", ["a", "b"])) is None
        assert part.call(("label", (), {})).data == ["a", "b"]
        failed = part.call(("fail", (), {}))
        assert failed.kind is Kind.CALL_ERROR and failed.data.env_index == 0


class KeepsActions(gym.Env):
    """Keeps every action it is given (a ``Box(shape=(2,))``), and then changes it in place."""

    observation_space = spaces.Box(-1.0, 1.0, shape=(1,), dtype=np.float32)
    action_space = spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)

    def __init__(self) -> None:
        self.kept: list[np.ndarray] = []

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict]:
        return np.zeros(1, dtype=np.float32), {}

    def step(self, action: np.ndarray) -> tuple[Any, float, bool, bool, dict]:
        self.kept.append(action)
        kept = action.copy()
        action += 1.0
        return np.zeros(1, dtype=np.float32), float(kept.sum()), False, False, {}


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_each_env_gets_its_own_copy_of_its_action_in_the_dtype_of_the_batch(dtype: type) -> None:
    """An env may keep its action, or change it: later steps do not change what it kept, and what
    it changes reaches neither the shared actions nor another env."""
    batches = [np.array([[0.5, -0.25], [0.125, 1.0]], dtype=dtype) * scale for scale in (1, -1, 0.5)]
    with env_slice([KeepsActions] * 2, AutoresetMode.NEXT_STEP) as (part, buffers):
        reset(part, buffers, [1, 2])
        buffers.action_dtype[0] = 0 if dtype is np.float64 else ord(np.dtype(dtype).char)  # as the parent says it
        for batch in batches:
            _, rewards, *_ = step(part, buffers, batch)
            np.testing.assert_array_equal(rewards, batch.sum(axis=1, dtype=np.float64).astype(np.float32))
            np.testing.assert_array_equal(buffers.actions.read_batch(copy_out=False), batch)
        for offset, env in enumerate(part.envs):
            assert [action.dtype for action in env.kept] == [np.dtype(dtype)] * len(batches)
            np.testing.assert_array_equal(np.stack(env.kept), [batch[offset] + 1.0 for batch in batches])
