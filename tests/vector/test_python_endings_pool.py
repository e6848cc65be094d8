"""A pool of envs whose reward or termination is written in Python steps them natively (the FMUs in
one C call, the endings in one Python call per slice, the autoreset in C) with the results of
`SyncVectorEnv` over the same envs on the Python path, to the last bit, in every autoreset mode."""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode, SyncVectorEnv
from python_endings import KINDS, ArrayCartPole, PerEnvCartPole, endings_fns
from step_paths import probe_env
from vector_rollouts import assert_native_equals_python, assert_same, flipping, rollout, rollout_recording_layouts

from modelicagym.models.pendulum.env import PendulumSwingUpEnv
from modelicagym.vector import EnvError, PoolVectorEnv
from modelicagym.vector.layout import placement
from modelicagym.vector.slice.env_slice import EnvSlice
from modelicagym.vector.wire.buffers import BufferSpec, SharedBuffers
from modelicagym.vector.wire.protocol import Kind

pytestmark = pytest.mark.timeout(180)


def slice_rollout(fns: list[Callable[[], gym.Env]], mode: AutoresetMode, steps: int) -> list:
    """What a worker's `EnvSlice` of ``fns`` writes into shared memory over ``steps`` random steps."""
    envs = [fn() for fn in fns]
    buffers, fd = SharedBuffers.create(BufferSpec(envs[0].observation_space, envs[0].action_space, len(envs), 1))
    part = EnvSlice(envs, first_env=0, slot=0, autoreset_mode=mode)
    part.attach(buffers, needs_reset=True)
    assert part.step_path == "native" and part.endings is not None, part.step_path_reason
    buffers.reset_mask[:] = True
    part.reset(list(range(10, 10 + len(envs))), None)
    records = [buffers.observations.read_batch(copy_out=True)]
    actions = np.random.default_rng(0).integers(2, size=(steps, len(envs)))
    for row in actions:
        buffers.actions.write_batch(row)
        reply = part.step()
        assert reply is None or reply.kind is Kind.INFOS, reply
        ended = buffers.terminations | buffers.truncations
        finals = {i: buffers.final_observations.read(i) for i in np.flatnonzero(buffers.final_ready).tolist()}
        finals.update((i, info["final_obs"]) for i, info in (reply.data if reply else []) if "final_obs" in info)
        final = [finals[i] for i in sorted(finals)]
        buffers.final_ready[:] = 0
        records.append((buffers.observations.read_batch(copy_out=True), buffers.rewards.copy(),
                        buffers.terminations.copy(), buffers.truncations.copy(), final, ended.copy()))
    part.detach()
    for env in envs:
        env.close()
    return records


def sync_rollout(fns: list[Callable[[], gym.Env]], mode: AutoresetMode, steps: int) -> list:
    """The same, from `SyncVectorEnv` (final observations of native resets as the slice keeps them)."""
    sync = SyncVectorEnv(fns, autoreset_mode=mode)
    records = [sync.reset(seed=list(range(10, 10 + len(fns))))[0]]
    actions = np.random.default_rng(0).integers(2, size=(steps, len(fns)))
    for row in actions:
        observations, rewards, terminations, truncations, infos = sync.step(row)
        ended = terminations | truncations
        final = [infos["final_obs"][i] for i in np.flatnonzero(ended)] if mode is AutoresetMode.SAME_STEP else []
        records.append((observations, rewards, terminations, truncations, final, ended))
    sync.close()
    return records


@pytest.mark.parametrize("mode", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP], ids=lambda m: m.value)
@pytest.mark.parametrize("kind", KINDS)
def test_a_slice_ends_its_steps_in_python_as_sync_vector_env(kind: str, mode: AutoresetMode) -> None:
    native, python = endings_fns(kind, 3)
    expected, actual = sync_rollout(python, mode, 120), slice_rollout(native, mode, 120)
    assert sum(int(record[5].sum()) for record in expected[1:]) > 10, "too few episodes ended"
    assert_same(expected, actual)


def test_envs_of_different_endings_in_one_slice_are_ended_each_by_their_own() -> None:
    fns = [endings_fns(kind, 1) for kind in ("arrays, class", "per env, class", "arrays, config")]
    for mode in (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP):
        assert_same(sync_rollout([fn[1][0] for fn in fns], mode, 80), slice_rollout([fn[0][0] for fn in fns], mode, 80))


@pytest.mark.parametrize("mode", list(AutoresetMode), ids=lambda m: m.value)
@pytest.mark.parametrize("kind", ["per env, class", "arrays, config"])
def test_a_pool_equals_sync_over_the_python_path(kind: str, mode: AutoresetMode) -> None:
    native, python = endings_fns(kind, 5)
    assert_native_equals_python(native, python, autoreset_mode=mode, caller_steps=True, steps=120)


@pytest.mark.parametrize("layout", [{"num_workers": 2}, {"num_workers": 0}], ids=["workers only", "caller only"])
def test_every_layout_ends_the_steps_alike(layout: dict) -> None:
    native, python = endings_fns("arrays, class", 4)
    assert_native_equals_python(native, python, autoreset_mode=AutoresetMode.SAME_STEP, steps=100, **layout)


@pytest.mark.parametrize("mode", list(AutoresetMode), ids=lambda m: m.value)
def test_envs_ending_their_steps_on_arrays_move_between_processes_and_keep_sync_results(
    monkeypatch: pytest.MonkeyPatch, mode: AutoresetMode
) -> None:
    monkeypatch.setattr(placement, "PART_BATCHES", 1)
    native, python = endings_fns("arrays, config", 6)
    sync = SyncVectorEnv(python, autoreset_mode=mode)
    with PoolVectorEnv(native, autoreset_mode=mode, cores=2) as pool:
        assert pool.layout.adaptive, pool.layout
        policy = flipping(pool, every=7)
        actual, in_caller = rollout_recording_layouts(pool, 200)
    expected, _ = rollout_recording_layouts(sync, 200)
    sync.close()
    assert_same(expected, actual)
    assert policy.switches >= 20 and min(in_caller) == 3 and max(in_caller) == 6, in_caller


def probe_rewards(envs: object, observations: np.ndarray, actions: np.ndarray, terminated: np.ndarray) -> np.ndarray:
    return observations[:, 0] * actions[:, 0] - 3.0 * terminated


def probe_termination(envs: object, observations: np.ndarray) -> np.ndarray:
    return np.abs(observations[:, 0]) > 2.0


@pytest.mark.parametrize("mode", list(AutoresetMode), ids=lambda m: m.value)
@pytest.mark.parametrize("fault", [1, 2], ids=["the model ends", "doStep fails"])
def test_fmu_errors_and_model_ends_with_python_endings_match_sync(family_fmu: Callable[[str, int], Path],
                                                                  mode: AutoresetMode, fault: int) -> None:
    def fns(**path: Any) -> list:
        faulty = {"fault": fault, "fault_after": 3}
        return [partial(probe_env, family_fmu("probe", 2), parameters=faulty if i == 1 else {}, max_episode_steps=8,
                        termination=None, batch_reward=probe_rewards, batch_termination=probe_termination, **path)
                for i in range(3)]

    assert_native_equals_python(fns(), fns(step_path="python"), steps=40, autoreset_mode=mode, caller_steps=True)


def test_the_pendulum_pool_steps_natively_as_sync() -> None:
    def fns(**options: object) -> list:
        return [lambda: PendulumSwingUpEnv(max_episode_steps=6, **options) for _ in range(3)]

    with PoolVectorEnv(fns(), caller_steps=True, autoreset_mode=AutoresetMode.SAME_STEP, cores=2) as pool:
        assert {path for path, _ in pool.step_paths} == {"native"}, pool.step_paths
        sync = SyncVectorEnv(fns(step_path="python"), autoreset_mode=AutoresetMode.SAME_STEP)
        assert_same(rollout(sync, 20), rollout(pool, 20))
        sync.close()


def test_a_hook_that_raises_names_an_env_of_its_slice() -> None:
    class Broken(ArrayCartPole):
        @classmethod
        def compute_rewards(cls, envs: object, observations: object, actions: object, terminated: object) -> None:
            raise RuntimeError("no reward today")

    with PoolVectorEnv([Broken] * 2, num_workers=1) as pool:
        pool.reset(seed=0)
        with pytest.raises(EnvError, match="no reward today"):
            pool.step(np.zeros(2, dtype=np.int64))


def test_per_env_endings_keep_an_env_where_it_is_array_endings_may_move() -> None:
    with PoolVectorEnv([PerEnvCartPole] * 2, caller_steps=True, cores=2) as pool:
        assert "runs Python per env and step (compute_reward / is_terminal" in pool.layout.reason
    with PoolVectorEnv([ArrayCartPole] * 2, caller_steps=True, cores=2) as pool:
        assert pool.layout.adaptive, pool.layout
