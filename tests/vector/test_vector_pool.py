"""PoolVectorEnv behaves like gymnasium's vector envs: results, API, errors, wrappers, spaces."""

from __future__ import annotations

import dataclasses
import doctest
import multiprocessing
import os
import pickle
import subprocess
import sys
from functools import partial
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.error import AlreadyPendingCallError, ClosedEnvironmentError, NoAsyncCallError
from gymnasium.vector import AutoresetMode, SyncVectorEnv
from gymnasium.wrappers.vector import NormalizeObservation, RecordEpisodeStatistics
from vector_envs import SPACES, CountEnv, FaultyEnv, SpacedEnv, TrivialEnv, count_fns
from vector_rollouts import assert_same, rollout

import modelicagym.vector.pool
from modelicagym.vector import PoolVectorEnv, StepTiming, plan_workers

pytestmark = pytest.mark.timeout(120)


@pytest.mark.parametrize("mode", list(AutoresetMode))
def test_identical_to_sync_in_every_autoreset_mode(mode: AutoresetMode) -> None:
    fns = count_fns(5)
    sync = SyncVectorEnv(fns, autoreset_mode=mode)
    with PoolVectorEnv(fns, num_workers=2, autoreset_mode=mode) as pool:
        expected, actual = rollout(sync, 300), rollout(pool, 300)
    sync.close()
    ended = sum(int((r[2] | r[3]).sum()) for r in expected if len(r) == 5)
    assert ended > 50, "episodes must end often, at different times"
    assert_same(expected, actual)


def test_identical_to_sync_on_cartpole() -> None:
    fns = [partial(gym.make, "CartPole-v1")] * 4
    sync = SyncVectorEnv(fns)
    with PoolVectorEnv(fns, num_workers=2, start_method="fork") as pool:
        expected, actual = rollout(sync, 300), rollout(pool, 300)
        assert pool.spec.id == "CartPole-v1"
        assert repr(pool) == "PoolVectorEnv(CartPole-v1, num_envs=4)"
    sync.close()
    assert_same(expected, actual)


@pytest.mark.parametrize("start_method", ["fork", "forkserver", "spawn"])
def test_start_methods(start_method: str) -> None:
    fns = count_fns(3)
    sync = SyncVectorEnv(fns)
    with PoolVectorEnv(fns, num_workers=2, start_method=start_method) as pool:
        assert_same(rollout(sync, 30), rollout(pool, 30))
    sync.close()


@pytest.mark.parametrize(
    "obs, act",
    [(obs, "discrete") for obs in SPACES] + [("box", act) for act in SPACES if act != "box"],
)
def test_spaces(obs: str, act: str) -> None:
    fns = count_fns(3, obs=obs, act=act)
    sync = SyncVectorEnv(fns)
    with PoolVectorEnv(fns, num_workers=2, start_method="fork") as pool:
        assert pool.single_observation_space == SPACES[obs]
        assert pool.single_action_space == SPACES[act]
        assert pool.observation_space == sync.observation_space
        assert pool.action_space == sync.action_space
        assert_same(rollout(sync, 40), rollout(pool, 40))
    sync.close()


def test_attributes_come_from_worker_zero() -> None:
    with PoolVectorEnv(count_fns(3, render_mode="rgb_array"), num_workers=2) as pool:
        assert pool.num_envs == 3 and pool.num_workers == 2
        assert pool.metadata["autoreset_mode"] is AutoresetMode.NEXT_STEP
        assert pool.metadata["render_fps"] == 30
        assert CountEnv.metadata.get("autoreset_mode") is None, "the env's metadata must not be modified"
        assert pool.render_mode == "rgb_array"
        assert pool.spec is None
        pool.reset(seed=0)
        frames = pool.render()
        assert len(frames) == 3 and frames[0].shape == (2, 2, 3)


def test_seeding_rules() -> None:
    with PoolVectorEnv(count_fns(4), num_workers=2) as pool:
        pool.reset(seed=10)
        assert pool.np_random_seed == (10, 11, 12, 13)
        pool.reset(seed=[5, None, 7, 8])
        seeds = pool.np_random_seed
        assert seeds[0] == 5 and seeds[2:] == (7, 8)
        with pytest.raises(ValueError, match="length must match"):
            pool.reset(seed=[1, 2])


def test_reset_options_and_mask() -> None:
    with PoolVectorEnv(count_fns(4), num_workers=2, autoreset_mode=AutoresetMode.DISABLED) as pool:
        obs, infos = pool.reset(seed=1, options={"level": 3})
        np.testing.assert_array_equal(infos["options"]["level"], [3, 3, 3, 3])
        mask = np.array([False, True, False, True])
        options = {"reset_mask": mask}
        new_obs, infos = pool.reset(options=options)
        assert "reset_mask" in options, "the caller's options must not be modified"
        np.testing.assert_array_equal(infos["_length"], mask)
        np.testing.assert_array_equal(new_obs[~mask], obs[~mask])
        with pytest.raises(TypeError):
            pool.reset(options={"reset_mask": [True] * 4})
        with pytest.raises(ValueError):
            pool.reset(options={"reset_mask": np.zeros(4, dtype=bool)})
        with pytest.raises(ValueError):
            pool.reset(options={"reset_mask": np.ones(3, dtype=bool)})


def test_call_get_attr_set_attr() -> None:
    with PoolVectorEnv(count_fns(3), num_workers=2) as pool:
        assert pool.get_attr("max_len") == (4, 7, 10)
        assert pool.call("double", 21) == (42, 42, 42)
        pool.set_attr("label", ["a", "b", "c"])
        assert pool.get_attr("label") == ("a", "b", "c")
        pool.set_attr("label", "same")
        assert pool.get_attr("label") == ("same",) * 3
        with pytest.raises(ValueError, match="length equal"):
            pool.set_attr("label", ["a"])
        with pytest.raises(KeyError, match="requested failure"):
            pool.call("fail")
        with pytest.raises(AttributeError):
            pool.get_attr("no_such_attribute")
        with pytest.raises(ValueError, match="use `step` directly"):
            pool.call("step", 0)
        pool.call_async("double", 1)
        assert pool.call_wait(timeout=5) == (2, 2, 2)
        pool.reset(seed=0)
        pool.step(pool.action_space.sample())


def test_unpicklable_arguments_and_results_keep_the_pool_usable() -> None:
    with PoolVectorEnv(count_fns(2), num_workers=2) as pool:
        with pytest.raises((AttributeError, TypeError, pickle.PicklingError)):
            pool.reset(options={"callback": lambda: 0})
        pool.reset(seed=0)
        with pytest.raises(TypeError, match="pickle"):
            pool.call("generator")
        pool.step(pool.action_space.sample())
        assert pool.get_attr("max_len") == (4, 7)


def test_misuse_raises_the_errors_async_vector_env_raises() -> None:
    pool = PoolVectorEnv(count_fns(2), num_workers=2)
    pool.reset(seed=0)
    actions = pool.action_space.sample()
    with pytest.raises(NoAsyncCallError):
        pool.step_wait()
    with pytest.raises(NoAsyncCallError):
        pool.reset_wait()
    with pytest.raises(NoAsyncCallError):
        pool.call_wait()
    pool.step_async(actions)
    with pytest.raises(AlreadyPendingCallError):
        pool.step_async(actions)
    with pytest.raises(AlreadyPendingCallError):
        pool.reset_async()
    with pytest.raises(AlreadyPendingCallError):
        pool.call_async("double", 1)
    with pytest.raises(AlreadyPendingCallError):
        pool.set_attr("label", "x")
    pool.step_wait()
    pool.reset_async(seed=1)
    with pytest.raises(AlreadyPendingCallError):
        pool.step_async(actions)
    pool.reset_wait()
    pool.close()
    pool.close()
    for call in (lambda: pool.step(actions), pool.reset, lambda: pool.get_attr("max_len")):
        with pytest.raises(ClosedEnvironmentError):
            call()


def test_close_with_a_pending_call_waits_for_it() -> None:
    pool = PoolVectorEnv(count_fns(2, cost=0.05), num_workers=2)
    pool.reset(seed=0)
    pool.step_async(pool.action_space.sample())
    pool.close()
    assert pool.closed


def test_step_wait_timeout_is_a_multiprocessing_timeout_error() -> None:
    fns = [partial(FaultyEnv, "hang"), partial(CountEnv)]
    pool = PoolVectorEnv(fns, num_workers=2)
    pool.reset(seed=0)
    pool.step(np.array([0, 0]))
    pool.step_async(np.array([0, 0]))
    with pytest.raises(multiprocessing.TimeoutError, match="env 0"):
        pool.step_wait(timeout=0.3)
    assert pool.closed


def test_vector_wrappers() -> None:
    """RecordEpisodeStatistics and NormalizeObservation give the same results as over SyncVectorEnv."""

    def run(envs: gym.vector.VectorEnv) -> tuple[list, list]:
        stats = RecordEpisodeStatistics(envs)
        wrapped = NormalizeObservation(stats)
        observations, episodes = [wrapped.reset(seed=0)[0]], []
        wrapped.action_space.seed(0)
        for _ in range(100):
            obs, _, _, _, infos = wrapped.step(wrapped.action_space.sample())
            observations.append(obs)
            if "episode" in infos:
                mask = infos["_episode"]
                episodes.append((mask, infos["episode"]["r"][mask], infos["episode"]["l"][mask]))
        assert len(stats.return_queue) == sum(int(mask.sum()) for mask, _, _ in episodes)
        return observations, episodes

    fns = count_fns(4)
    sync = SyncVectorEnv(fns)
    expected = run(sync)
    sync.close()
    with PoolVectorEnv(fns, num_workers=2) as pool:
        actual = run(pool)
    assert len(expected[1]) > 10
    assert_same(expected, actual)


def test_copy_false_returns_views_of_shared_memory() -> None:
    with PoolVectorEnv([TrivialEnv] * 2, num_workers=2, copy=False) as pool:
        obs, _ = pool.reset()
        obs2, *_ = pool.step(np.array([0, 1]))
        assert np.shares_memory(obs, obs2)


def test_mismatched_spaces_are_refused() -> None:
    with pytest.raises(RuntimeError, match="observation spaces are not equivalent"):
        PoolVectorEnv([CountEnv, SpacedEnv], num_workers=2)
    with pytest.raises(RuntimeError, match="observation spaces are not equivalent.*observation_mode=.different."):
        PoolVectorEnv([CountEnv, SpacedEnv], num_workers=1)


def test_plan_workers() -> None:
    assert plan_workers(5, 2, None) == [range(0, 3), range(3, 5)]
    assert plan_workers(2, 4, None) == [range(0, 1), range(1, 2)]
    assert plan_workers(4, None, 1) == [range(k, k + 1) for k in range(4)]
    assert len(plan_workers(64, None, None)) == len(plan_workers(1000, None, None)) >= 1
    assert plan_workers(1, None, None) == [range(0, 1)]
    with pytest.raises(ValueError, match="at least 3 workers"):
        plan_workers(6, 2, 2)
    with pytest.raises(ValueError):
        plan_workers(0, None, None)


def test_max_envs_per_process_attribute_of_the_env_fn() -> None:
    def make() -> gym.Env:
        return CountEnv()

    make.max_envs_per_process = 1
    with PoolVectorEnv([make] * 3, start_method="fork") as pool:
        assert pool.num_workers == 3
        assert len(set(pool.call("__getattribute__", "np_random"))) == 3


def assert_parts_add_up(timing: StepTiming) -> None:
    """A step's parts are never negative and add up to its wall time; the critical worker's share
    is at most what all workers did (see `modelicagym.vector.timing`)."""
    assert min(value for value in dataclasses.astuple(timing) if not isinstance(value, str)) >= 0
    assert timing.wall_s == pytest.approx(timing.fmu_s + timing.env_python_s + timing.pool_overhead_s)
    assert timing.fmu_s <= timing.fmu_total_s
    assert timing.env_python_s <= timing.env_python_total_s


def test_timing() -> None:
    fns = count_fns(4, cost=0.002, fmu_share=0.5)
    with PoolVectorEnv(fns, num_workers=2) as pool:
        pool.reset(seed=0)
        pool.step(pool.action_space.sample())
        assert pool.timing().steps == 0, "off by default"
        pool.set_timing(True)
        fmu_ns_before = sum(pool.get_attr("fmu_time_ns"))
        for _ in range(10):
            pool.step(pool.action_space.sample())
        fmu_ns = sum(pool.get_attr("fmu_time_ns")) - fmu_ns_before
        timing = pool.timing(reset=True)
        assert pool.timing().steps == 0, "reset=True starts over"
    assert isinstance(timing, StepTiming) and timing.steps == 10
    assert_parts_add_up(timing)
    # every worker's envs spent time, part of it counted by the envs as FMU time: all of it is there
    assert timing.fmu_s > 0 and timing.env_python_s > 0
    assert timing.fmu_total_s == pytest.approx(fmu_ns / 10 / 1e9)


def test_envs_without_fmu_time_count_as_python_time() -> None:
    with PoolVectorEnv(count_fns(2, cost=0.001), num_workers=2, measure_timing=True) as pool:
        pool.reset(seed=0)
        for _ in range(5):
            pool.step(pool.action_space.sample())
        timing = pool.timing()
    assert timing.steps == 5 and timing.fmu_s == 0.0 and timing.fmu_total_s == 0.0
    assert timing.env_python_s > 0.0
    assert_parts_add_up(timing)


def test_docstring_example_runs() -> None:
    results = doctest.testmod(modelicagym.vector.pool, optionflags=doctest.ELLIPSIS)
    assert results.attempted > 0 and results.failed == 0


def test_a_temporary_folder_too_deep_for_the_fork_servers_socket_is_named(tmp_path) -> None:
    """The fork server listens on a Unix socket in a folder of ``TMPDIR``; where that path is longer
    than a socket's may be, the pool says what to change instead of Python's "AF_UNIX path too long"."""
    deep = tmp_path / ("d" * 60) / ("e" * 60)
    deep.mkdir(parents=True)
    script = ("from modelicagym.vector import PoolVectorEnv\n"
              "from vector_envs import CountEnv\n"
              "PoolVectorEnv([CountEnv] * 2, num_workers=1, start_method='forkserver')\n")
    tests = str(Path(__file__).resolve().parents[1])
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120,
                            env={**os.environ, "TMPDIR": str(deep), "PYTHONPATH": tests})
    assert result.returncode == 1
    last = result.stderr.strip().splitlines()[-1]
    assert last.startswith("modelicagym.errors.ConfigError: the fork server's socket"), result.stderr
    assert str(deep) in last and "set TMPDIR to a shorter folder" in last and "start_method='spawn'" in last
