"""The pool on the native step path: the same results as SyncVectorEnv over the Python path, in
every autoreset mode; faults keep their guarantees; each env says which path it takes and why."""

from __future__ import annotations

import multiprocessing
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from gymnasium.vector import AutoresetMode, SyncVectorEnv
from step_paths import cartpole_fns, probe_env
from vector_rollouts import assert_native_equals_python, assert_same, rollout

import modelicagym
from modelicagym.vector import EnvError, PoolVectorEnv, WorkerDiedError, WorkerTimeoutError
from modelicagym.vector.dispatch.dispatcher import Dispatcher
from modelicagym.vector.dispatch.recovery import RESTART_INFO_KEY

pytestmark = pytest.mark.timeout(180)

LAYOUTS = {"caller steps": {"caller_steps": True}, "workers only": {"num_workers": 2},
           "caller only": {"num_workers": 0}}


@pytest.mark.parametrize("layout", LAYOUTS)
@pytest.mark.parametrize("mode", list(AutoresetMode))
def test_identical_to_sync_over_the_python_path(layout: str, mode: AutoresetMode, fmi_version: int) -> None:
    native, python = cartpole_fns(5, fmi_version=fmi_version)
    assert_native_equals_python(native, python, autoreset_mode=mode, **LAYOUTS[layout])


@pytest.mark.usefixtures("no_leaks")
def test_with_no_workers_the_calling_process_steps_every_env_itself() -> None:
    native, python = cartpole_fns(4)
    with PoolVectorEnv(native, num_workers=0) as pool:
        assert (pool.num_workers, pool.caller_steps) == (0, True)
        assert multiprocessing.active_children() == []
        sync = SyncVectorEnv(python)
        expected, actual = rollout(sync, 60), rollout(pool, 60)
        sync.close()
    assert_same(expected, actual)


@pytest.mark.parametrize("reset_rung", ["reset", "reinstantiate"])
@pytest.mark.parametrize("mode", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP])
def test_resets_python_must_do_are_done_by_python(reset_rung: str, mode: AutoresetMode) -> None:
    """Rungs below the snapshot, and random per-episode parameters, reset on the Python path."""
    for options in ({"reset_rung": reset_rung}, {"m_cart": lambda rng: float(rng.uniform(5, 15))}):
        native, python = cartpole_fns(3, **options)
        assert_native_equals_python(native, python, autoreset_mode=mode, num_workers=1)


@pytest.mark.parametrize("layout", ["caller steps", "caller only"])
@pytest.mark.parametrize("mode", list(AutoresetMode))
@pytest.mark.parametrize("fault", [1, 2])
def test_fmu_errors_and_model_ends_match_sync(monkeypatch: pytest.MonkeyPatch, family_fmu: Callable[[str, int], Path],
                                              mode: AutoresetMode, fault: int, layout: str) -> None:
    """fault 1: the model ends the simulation; 2: doStep returns Error (the episode is truncated).
    With every env at home a step is one C call, and Python finishes the steps it leaves to it."""
    def fns(**path: Any) -> list:
        faulty = {"fault": fault, "fault_after": 3}
        return [partial(probe_env, family_fmu("probe", 2), parameters=faulty if i == 1 else {}, max_episode_steps=8, **path)
                for i in range(3)]

    quiet: list[bool] = []
    step_at_home = Dispatcher.step_at_home
    monkeypatch.setattr(Dispatcher, "step_at_home",
                        lambda self, check_range=True: quiet.append(step_at_home(self, check_range)) or quiet[-1])
    assert_native_equals_python(fns(), fns(step_path="python"), steps=40, autoreset_mode=mode, **LAYOUTS[layout])
    if layout == "caller only":
        assert True in quiet and False in quiet, quiet  # both ways: quiet steps, and Python finishing some


@pytest.mark.usefixtures("no_leaks")
def test_a_crashing_fmu_is_named_and_its_worker_restarted(family_fmu: Callable[[str, int], Path]) -> None:
    fns = [partial(probe_env, family_fmu("probe", 2), parameters={"fault": 3, "fault_after": 4} if i == 2 else {})
           for i in range(4)]
    pool = PoolVectorEnv(fns, num_workers=2, restart_dead_workers=True)
    pool.reset(seed=0)
    restarted = [pool.step(np.ones((4, 1)))[4].get(RESTART_INFO_KEY) for _ in range(5)]
    assert restarted[:4] == [None] * 4
    assert [reason is not None for reason in restarted[4]] == [False, False, True, True]
    assert "SIGSEGV" in restarted[4][2] and "env 2" in restarted[4][2]
    observations, *_ = pool.step(np.ones((4, 1)))
    assert observations.shape == (4, 2)
    pool.close()
    with pytest.raises(WorkerDiedError, match=r"env 2\b"):
        with PoolVectorEnv(fns, num_workers=2) as pool:
            pool.reset(seed=0)
            for _ in range(5):
                pool.step(np.ones((4, 1)))


@pytest.mark.usefixtures("no_leaks")
def test_a_hanging_fmu_times_out_with_its_env_named(family_fmu: Callable[[str, int], Path]) -> None:
    fns = [partial(probe_env, family_fmu("probe", 2), parameters={"fault": 4, "fault_after": 2} if i == 3 else {})
           for i in range(4)]
    pool = PoolVectorEnv(fns, num_workers=2, step_timeout=0.5)
    pool.reset(seed=0)
    assert {path for path, _ in pool.step_paths} == {"native"}
    with pytest.raises(WorkerTimeoutError, match=r"env 3\b"):
        for _ in range(3):
            pool.step(np.ones((4, 1)))
    assert pool.closed


def test_a_slice_with_one_python_env_steps_on_the_python_path_and_says_why() -> None:
    fns = [partial(modelicagym.make, "cartpole"), partial(modelicagym.make, "cartpole", step_path="python")]
    with PoolVectorEnv(fns * 2, num_workers=2, caller_steps=False) as pool:
        paths = pool.step_paths
    assert [path for path, _ in paths] == ["python"] * 4
    assert "step_path='python'" in paths[0].reason
    with PoolVectorEnv(fns[:1] * 4, num_workers=2, caller_steps=False) as pool:
        assert [path for path, _ in pool.step_paths] == ["native"] * 4


def test_an_action_outside_the_space_names_the_env() -> None:
    with PoolVectorEnv([partial(modelicagym.make, "cartpole")] * 4, caller_steps=True) as pool:
        pool.reset(seed=0)
        with pytest.raises((EnvError, ValueError), match=r"env 3\b|3"):
            pool.step(np.array([0, 1, 0, 2]))


def test_timing_on_the_native_path_counts_fmu_time() -> None:
    with PoolVectorEnv([partial(modelicagym.make, "cartpole")] * 4, measure_timing=True) as pool:
        pool.reset(seed=0)
        for _ in range(20):
            pool.step(pool.action_space.sample())
        timing = pool.timing()
    assert timing.steps == 20
    assert timing.fmu_s > 0 and timing.fmu_total_s >= timing.fmu_s
    assert timing.env_python_s >= 0 and timing.pool_overhead_s >= 0
    assert timing.wall_s == pytest.approx(timing.fmu_s + timing.env_python_s + timing.pool_overhead_s)
