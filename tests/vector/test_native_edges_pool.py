"""A pool of envs whose inputs or observation are Python's around a native FMU step (an overridden
``action_to_inputs`` / ``observation``) steps each of them through ``env.step`` — its FMU still in
C — with the results of `SyncVectorEnv` over the same envs on the Python path, to the last bit:
the calling process's slice and workers', both autoreset modes, FMU errors mid-episode."""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from pathlib import Path

import pytest
from gymnasium.vector import AutoresetMode, SyncVectorEnv
from python_edges import CARTPOLES, GearboxProbeEndings
from vector_rollouts import assert_same, rollout

from modelicagym.vector import PoolVectorEnv
from modelicagym.vector.slice.native_slice import batch_path_reason

pytestmark = pytest.mark.timeout(180)

MODES = [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP]


def assert_pool_equals_sync(native: list[Callable], python: list[Callable], mode: AutoresetMode,
                            steps: int = 120) -> list:
    """The default pool over ``native`` gives what SyncVectorEnv over ``python`` gives; returns the latter's results."""
    sync = SyncVectorEnv(python, autoreset_mode=mode)
    with PoolVectorEnv(native, autoreset_mode=mode) as pool:
        for path, reason in pool.step_paths:
            assert path == "python" and "in Python around its FMU's C step" in reason, reason
        expected, actual = rollout(sync, steps), rollout(pool, steps)
    sync.close()
    assert sum(int((result[2] | result[3]).sum()) for result in expected[1:]) > 8, "too few episodes ended"
    assert_same(expected, actual)
    return expected


@pytest.mark.parametrize("mode", MODES, ids=lambda m: m.value)
@pytest.mark.parametrize("kind, fmu_mode", [("observation", "cs"), ("inputs+endings", "me"), ("both", "cs"),
                                            ("both+endings", "me")])
def test_a_pool_of_cartpoles_with_python_edges_steps_as_sync_vector_env(kind: str, fmu_mode: str,
                                                                        mode: AutoresetMode) -> None:
    cls, _ = CARTPOLES[kind]
    native = [partial(cls, mode=fmu_mode, max_episode_steps=5 + 4 * i) for i in range(4)]
    python = [partial(cls, mode=fmu_mode, max_episode_steps=5 + 4 * i, step_path="python") for i in range(4)]
    assert_pool_equals_sync(native, python, mode)


@pytest.mark.parametrize("mode", MODES, ids=lambda m: m.value)
def test_a_pool_of_typed_probes_with_fmu_errors_steps_as_sync_vector_env(family_fmu: Callable[[str, int], Path],
                                                                         fmi_version: int, mode: AutoresetMode) -> None:
    """Workers' slices (the probe is a user's FMU); env i's doStep fails after 3 + i steps of an episode."""
    path = family_fmu("probe", fmi_version)

    def fns(**config: object) -> list[Callable]:
        return [partial(GearboxProbeEndings, path, parameters={"fault": 2, "fault_after": 3 + i}, **config)
                for i in range(4)]

    expected = assert_pool_equals_sync(fns(), fns(step_path="python"), mode, steps=60)
    infos = [result[4] for result in expected[1:]]
    assert any("fmu_error" in info or "fmu_error" in info.get("final_info", {}) for info in infos), "no FMU error"


def test_the_native_slice_says_why_it_does_not_take_them() -> None:
    cls, _ = CARTPOLES["inputs"]
    envs = [cls(), cls()]
    reason = batch_path_reason(envs)
    assert reason == ("env 0 of the slice computes the inputs (action_to_inputs is overridden by ThreeForceCartPole) "
                      "in Python around its FMU's C step, and a native slice moves the action and observation "
                      "spaces' rows in C: each env steps through env.step")
    for env in envs:
        env.close()
