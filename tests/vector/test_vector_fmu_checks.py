"""The pool keeps the FMU runtime's promises on its native slices, in the calling process and in
workers: a reset rung whose snapshot or ``fmiReset`` leaks hidden state is caught at its first use
(the pool's envs reproduce envs that re-instantiate for every episode), and an FMU caught in an
error loop truncates its env's episode with the reason in the infos."""

from __future__ import annotations

from functools import partial
from typing import Any

import numpy as np
import pytest
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, SyncVectorEnv
from vector_rollouts import assert_same, rollout

from modelicagym import FMUEnv
from modelicagym.vector import PoolVectorEnv

pytestmark = pytest.mark.timeout(180)

LAYOUTS = {"caller and worker": {"caller_steps": True, "num_workers": 1}, "workers only": {"num_workers": 2}}


def leaky_fns(path, reference: bool) -> list:
    """Two leaky envs (episodes of 6 and 25 steps: shorter and longer than the checked steps); the
    reference ones re-instantiate for every episode on the Python path, which is exact by definition."""
    exact = {"reset_rung": "reinstantiate", "step_path": "python"} if reference else {}
    return [partial(FMUEnv, fmu=path, inputs=["u"], outputs=["x"], max_episode_steps=steps, **exact)
            for steps in (6, 25)]


@pytest.mark.parametrize("layout", LAYOUTS)
@pytest.mark.parametrize("mode", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP])
@pytest.mark.parametrize("name", ["leaky_snapshot", "leaky_reset", "leaky_both"])
def test_a_leaky_rung_is_caught_in_the_pools_native_slices(family_fmu, name, mode, layout):
    path = family_fmu(name, 2)
    sync = SyncVectorEnv(leaky_fns(path, reference=True), autoreset_mode=mode)
    expected = rollout(sync, 80)
    sync.close()
    with PoolVectorEnv(leaky_fns(path, reference=False), autoreset_mode=mode, **LAYOUTS[layout]) as pool:
        assert {path for path, _ in pool.step_paths} == {"native"}, pool.step_paths
        actual = rollout(pool, 80)
    assert_same(expected, actual)


def noisy_env(path, **config: Any) -> FMUEnv:
    box = spaces.Box(-1000.0, 1000.0, (1,), np.float64)  # wider than the model can take
    return FMUEnv(fmu=path, inputs=["u"], outputs=["x"], action_space=box, logging_on=True, **config)


@pytest.mark.parametrize("layout", LAYOUTS)
def test_an_error_loop_truncates_its_env_in_a_pool(family_fmu, layout):
    path = family_fmu("noisy", 2)
    with PoolVectorEnv([partial(noisy_env, path) for _ in range(2)], **LAYOUTS[layout]) as pool:
        assert {path for path, _ in pool.step_paths} == {"native"}, pool.step_paths
        pool.reset(seed=0)
        for _ in range(3):
            *_, truncated, infos = pool.step(np.array([[1.0], [1.0]]))
            assert not truncated.any() and "fmu_error" not in infos
        *_, truncated, infos = pool.step(np.array([[1.0], [500.0]]))
        assert truncated.tolist() == [False, True]
        assert infos["_fmu_error"].tolist() == [False, True]
        assert "error loop" in infos["fmu_error"][1]
        pool.step(np.array([[1.0], [1.0]]))  # next step: its reset (next-step autoreset)
        *_, truncated, infos = pool.step(np.array([[1.0], [1.0]]))
        assert not truncated.any() and "fmu_error" not in infos
