"""A pool of envs whose inputs or observation are Python's around a native FMU step (an overridden
``action_to_inputs`` / ``observation``) steps each slice natively: one C call for its FMUs, the
Python edges per env around it (`modelicagym.vector.slice.slice_edges`), with the results of
`SyncVectorEnv` over the same envs on the Python path, to the last bit, and its hooks called as
often: the calling process's slice and workers', every autoreset mode, co-simulation and model
exchange, FMI 2.0 and 3.0, with and without Python endings, FMU errors mid-episode, a bad action
and a hook that raises."""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from env_slices import env_slice
from gymnasium.vector import AutoresetMode, SyncVectorEnv
from python_edges import (
    CARTPOLES,
    BothCartPole,
    CountingBothCartPole,
    CountingProbe,
    DictProbe,
    FailingRewardCartPole,
    GearboxProbe,
    GearboxProbeEndings,
)
from vector_rollouts import assert_same, flipping, rollout, rollout_recording_layouts

from modelicagym.vector import PoolVectorEnv
from modelicagym.vector.errors import PoolError
from modelicagym.vector.layout import placement
from modelicagym.vector.slice.native_slice import batch_path_reason
from modelicagym.vector.wire.protocol import Kind

pytestmark = pytest.mark.timeout(180)

MODES = [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP, AutoresetMode.DISABLED]


def assert_pool_equals_sync(native: list[Callable], python: list[Callable], mode: AutoresetMode,
                            steps: int = 120, **pool_options: Any) -> list:
    """The pool over ``native`` (every slice native, with its Python edges) gives what SyncVectorEnv
    over ``python`` gives; returns the latter's results."""
    sync = SyncVectorEnv(python, autoreset_mode=mode)
    with PoolVectorEnv(native, autoreset_mode=mode, **pool_options, cores=2) as pool:
        for path, reason in pool.step_paths:
            assert path == "native" and "in Python" in reason, reason
        expected, actual = rollout(sync, steps), rollout(pool, steps)
    sync.close()
    assert sum(int((result[2] | result[3]).sum()) for result in expected[1:] if len(result) == 5) > 8, \
        "too few episodes ended"
    assert_same(expected, actual)
    return expected


#: kind, FMI version, FMU mode, envs, pool options: each edge, alone and with Python endings, over
#: both FMI versions and modes, a default layout (the calling process steps a slice, adaptive)
#: and one with every env in workers
CARTPOLE_CASES = [
    ("observation", 2, "cs", 4, {}),
    ("inputs", 3, "me", 8, {}),
    ("both", 3, "cs", 8, {"caller_steps": False}),
    ("observation+endings", 3, "me", 4, {"caller_steps": False}),
    ("inputs+endings", 2, "cs", 4, {}),
    ("both+endings", 2, "me", 8, {}),
]


@pytest.mark.parametrize("mode", MODES, ids=lambda m: m.value)
@pytest.mark.parametrize("kind, fmi_version, fmu_mode, n, options", CARTPOLE_CASES,
                         ids=[f"{c[0]}-fmi{c[1]}-{c[2]}-n{c[3]}{'-workers' if c[4] else ''}" for c in CARTPOLE_CASES])
def test_a_pool_of_cartpoles_with_python_edges_steps_natively_as_sync_vector_env(
        kind: str, fmi_version: int, fmu_mode: str, n: int, options: dict, mode: AutoresetMode) -> None:
    cls, _ = CARTPOLES[kind]
    config = {"fmi_version": fmi_version, "mode": fmu_mode}
    native = [partial(cls, max_episode_steps=5 + 3 * i, **config) for i in range(n)]
    python = [partial(cls, max_episode_steps=5 + 3 * i, step_path="python", **config) for i in range(n)]
    assert_pool_equals_sync(native, python, mode, **options)


@pytest.mark.parametrize("mode", MODES, ids=lambda m: m.value)
@pytest.mark.parametrize("cls, n, options", [(GearboxProbeEndings, 4, {}), (GearboxProbe, 8, {"caller_steps": True}),
                                             (DictProbe, 4, {"caller_steps": True}), (GearboxProbe, 8, {"num_workers": 0})],
                         ids=["endings-n4-workers", "n8-caller", "dict-actions-n4-caller", "n8-every-env-at-home"])
def test_a_pool_of_typed_probes_with_fmu_errors_steps_natively_as_sync_vector_env(
        family_fmu: Callable[[str, int], Path], fmi_version: int, mode: AutoresetMode, cls: type, n: int,
        options: dict) -> None:
    """The probe is a user's FMU (workers' slices by default; ``caller_steps=True`` adds the
    calling process's; ``num_workers=0``: every step is one C call in the calling process, and
    Python finishes the envs whose FMU failed); env i's doStep fails after 3 + i % 4 steps of an episode."""
    path = family_fmu("probe", fmi_version)

    def fns(**config: object) -> list[Callable]:
        return [partial(cls, path, parameters={"fault": 2, "fault_after": 3 + i % 4}, **config) for i in range(n)]

    expected = assert_pool_equals_sync(fns(), fns(step_path="python"), mode, steps=60, **options)
    infos = [result[4] for result in expected[1:] if len(result) == 5]
    assert any("fmu_error" in info or "fmu_error" in info.get("final_info", {}) for info in infos), "no FMU error"


@pytest.mark.parametrize("mode", MODES, ids=lambda m: m.value)
@pytest.mark.parametrize("kind", ["both", "observation"])
def test_envs_with_python_edges_move_between_processes_and_keep_sync_results(
        monkeypatch: pytest.MonkeyPatch, kind: str, mode: AutoresetMode) -> None:
    """The adaptive layout moves them at episode boundaries (``SAME_STEP``: reset before their
    next step, inputs written after it) between their worker and the calling process's copies."""
    monkeypatch.setattr(placement, "PART_BATCHES", 1)
    cls, _ = CARTPOLES[kind]
    native = [partial(cls, max_episode_steps=5 + 3 * i) for i in range(6)]
    python = [partial(cls, max_episode_steps=5 + 3 * i, step_path="python") for i in range(6)]
    sync = SyncVectorEnv(python, autoreset_mode=mode)
    with PoolVectorEnv(native, autoreset_mode=mode, cores=2) as pool:
        assert pool.layout.adaptive and {path for path, _ in pool.step_paths} == {"native"}, pool.layout
        policy = flipping(pool, every=7)
        actual, in_caller = rollout_recording_layouts(pool, 200)
    expected, _ = rollout_recording_layouts(sync, 200)
    sync.close()
    assert_same(expected, actual)
    assert policy.switches >= 20 and min(in_caller) == 3 and max(in_caller) == 6, in_caller


@pytest.mark.parametrize("mode", MODES, ids=lambda m: m.value)
def test_probes_with_python_edges_moving_to_the_stand_in_worker_keep_sync_results(
        monkeypatch: pytest.MonkeyPatch, family_fmu: Callable[[str, int], Path], mode: AutoresetMode) -> None:
    """A user's FMU: a worker stands in for the calling process with a copy of every env."""
    monkeypatch.setattr(placement, "PART_BATCHES", 1)
    path = family_fmu("probe", 3)
    native = [partial(GearboxProbe, path, max_episode_steps=5 + 2 * i) for i in range(6)]
    python = [partial(GearboxProbe, path, max_episode_steps=5 + 2 * i, step_path="python") for i in range(6)]
    sync = SyncVectorEnv(python, autoreset_mode=mode)
    with PoolVectorEnv(native, autoreset_mode=mode, cores=2) as pool:
        assert pool.layout.adaptive and pool.layout.envs_in_stand_in == 3, pool.layout
        assert {path for path, _ in pool.step_paths} == {"native"}, pool.step_paths
        policy = flipping(pool, every=7)
        actual, in_stand_in = rollout_recording_layouts(pool, 200)
    expected, _ = rollout_recording_layouts(sync, 200)
    sync.close()
    assert_same(expected, actual)
    assert policy.switches >= 20 and max(in_stand_in) == 6, in_stand_in


@pytest.mark.parametrize("mode", MODES, ids=lambda m: m.value)
def test_the_hooks_run_as_often_as_in_sync_vector_env(mode: AutoresetMode) -> None:
    """None for an env whose step is its reset (``NEXT_STEP``), one ``observation()`` per step or reset."""
    native = [partial(CountingBothCartPole, max_episode_steps=4 + 3 * i) for i in range(4)]
    python = [partial(CountingBothCartPole, max_episode_steps=4 + 3 * i, step_path="python") for i in range(4)]
    sync = SyncVectorEnv(python, autoreset_mode=mode)
    with PoolVectorEnv(native, autoreset_mode=mode, adapt_layout=False, cores=2) as pool:
        assert {path for path, _ in pool.step_paths} == {"native"}, pool.step_paths
        assert_same(rollout(sync, 60), rollout(pool, 60))
        counted = pool.get_attr("calls")
    expected = sync.get_attr("calls")
    sync.close()
    assert counted == expected
    if mode is AutoresetMode.NEXT_STEP:  # some steps were resets, with no action_to_inputs
        assert expected[0]["action_to_inputs"] < 60


def test_an_action_outside_the_space_fails_as_on_the_per_env_path() -> None:
    """The pool refuses it with the same error, whichever path its slices take, and steps on."""
    errors = []
    for step_path in ("auto", "python"):
        with PoolVectorEnv([partial(BothCartPole, step_path=step_path) for _ in range(4)], cores=2) as pool:
            pool.reset(seed=0)
            with pytest.raises((ValueError, PoolError)) as error:
                pool.step(np.array([0, 1, 3, 2]))
            errors.append(str(error.value))
            pool.reset(seed=0)
            pool.step(np.array([0, 1, 2, 2]))
    assert errors[0] == errors[1], errors


@pytest.mark.parametrize("mode", MODES, ids=lambda m: m.value)
@pytest.mark.parametrize("variant, fault", [("probe", 1), ("probe", 2), ("probe_late", 0)],
                         ids=["the model ends", "doStep fails", "resets only Python can do"])
def test_what_c_leaves_to_python_runs_the_hooks_as_often_as_in_sync_vector_env(
        family_fmu: Callable[[str, int], Path], mode: AutoresetMode, variant: str, fault: int) -> None:
    """What C leaves to Python (an FMU error, the model's end: an info, a reset with no snapshot
    to restore) is finished with the observation Python wrote, not a second call of the hook."""
    path = family_fmu(variant, 2)
    fns = [partial(CountingProbe, path, parameters={"fault": fault, "fault_after": 3 + i}) for i in range(4)]
    python = [partial(CountingProbe, path, parameters={"fault": fault, "fault_after": 3 + i}, step_path="python")
              for i in range(4)]
    sync = SyncVectorEnv(python, autoreset_mode=mode)
    with PoolVectorEnv(fns, autoreset_mode=mode, adapt_layout=False, caller_steps=True, cores=2) as pool:
        assert {path for path, _ in pool.step_paths} == {"native"}, pool.step_paths
        expected, actual = rollout(sync, 50), rollout(pool, 50)
        counted = pool.get_attr("calls")
    sync.close()
    assert_same(expected, actual)
    assert counted == sync.get_attr("calls")
    if fault:
        infos = [result[4] for result in expected[1:] if len(result) == 5]
        key = "fmu_terminated" if fault == 1 else "fmu_error"
        assert any(key in info or key in info.get("final_info", {}) for info in infos), f"no {key}"


@pytest.mark.parametrize("mode", MODES, ids=lambda m: m.value)
def test_a_slice_given_an_action_outside_the_space_steps_as_the_per_env_path(mode: AutoresetMode) -> None:
    """Past the pool's own check (a slice reads the actions from shared memory): the envs before
    the bad action step, hooks and all, and the reply names it with ``env.step``'s error."""
    results = []
    for step_path in ("auto", "python"):
        with env_slice([partial(CountingBothCartPole, step_path=step_path)] * 4, mode) as (part, buffers):
            assert part.step_path == ("native" if step_path == "auto" else "python"), part.step_path_reason
            buffers.reset_mask[:] = True
            part.reset([0, 1, 2, 3], None)
            buffers.step_mask[:] = True
            buffers.actions.write_batch(np.array([0, 2, 7, 1]))
            reply = part.step()
            assert reply.kind is Kind.ERROR
            error = reply.data
            results.append(((error.env_index, error.type_name, error.message),
                            buffers.observations.read_batch(copy_out=True)[:2], [env.calls for env in part.envs]))
    message = "invalid action np.int64(7): out of range [0, 2]; the action space is Discrete(3)"
    assert results[0][0] == (2, "ActionError", message)
    assert_same(results[0], results[1])


def test_a_dict_action_outside_the_space_fails_as_on_the_per_env_path(family_fmu: Callable[[str, int], Path]) -> None:
    path = family_fmu("probe", 2)
    errors = []
    for step_path in ("auto", "python"):
        with env_slice([partial(DictProbe, path, step_path=step_path)] * 3, AutoresetMode.NEXT_STEP) as (part, buffers):
            assert part.step_path == ("native" if step_path == "auto" else "python"), part.step_path_reason
            buffers.reset_mask[:] = True
            part.reset([0, 1, 2], None)
            buffers.step_mask[:] = True
            actions = {"boost": np.array([0, 1, 0]), "enable": np.array([1, 1, 0]), "force": np.array([1.0, 2.0, 20.0], np.float32),
                       "gear": np.array([0, 4, 2]), "mode": np.array([1, 3, 2])}
            buffers.actions.write_batch(actions)
            reply = part.step()
            assert reply.kind is Kind.ERROR
            errors.append((reply.data.env_index, reply.data.type_name, reply.data.message,
                           buffers.observations.read_batch(copy_out=True)[:2]))
    assert errors[0][:2] == (2, "ActionError") and "force" in errors[0][2], errors[0]
    assert_same(errors[0], errors[1])


def _third_step_errors(fns_for: Callable[[str], list[Callable[[], Any]]]) -> list[str]:
    """The error of the third step of a pool of 4 over ``fns_for(step_path)``, on the native path
    (``"auto"``) then on the Python path (the pool's default layout, fixed)."""
    errors = []
    for step_path in ("auto", "python"):
        with PoolVectorEnv(fns_for(step_path), adapt_layout=False, cores=2) as pool:
            assert pool.step_paths[0][0] == ("native" if step_path == "auto" else "python")
            pool.reset(seed=0)
            pool.step(np.zeros(4, dtype=np.int64))
            pool.step(np.zeros(4, dtype=np.int64))
            with pytest.raises(PoolError) as error:
                pool.step(np.zeros(4, dtype=np.int64))
            errors.append(str(error.value))
    return errors


def test_a_hook_that_raises_names_its_env_as_on_the_per_env_path() -> None:
    errors = _third_step_errors(lambda step_path: [
        partial(CountingBothCartPole, fail_at=3 if i == 2 else None, step_path=step_path) for i in range(4)])
    assert "env 2" in errors[0] and "action_to_inputs failed at call 3" in errors[0], errors[0]
    assert errors[0] == errors[1], errors


def test_an_ending_that_raises_in_a_slice_with_python_edges_is_the_steps_error() -> None:
    """As for any native slice with Python endings, one call computes the rewards of the slice's
    envs (`SliceEndings`), so its error names the first of them (env 0 and 1 are worker 0's);
    the per-env path names env 1 itself."""
    errors = _third_step_errors(lambda step_path: [
        partial(FailingRewardCartPole, fail=i == 1, step_path=step_path) for i in range(4)])
    message = "raised RuntimeError in step: compute_reward failed at its third call"
    assert errors == [f"env 0 (worker 0) {message}", f"env 1 (worker 0) {message}"], errors


def test_a_slice_whose_envs_disagree_on_their_edges_says_so() -> None:
    envs = [CARTPOLES["inputs"][0](), CARTPOLES["both"][0]()]
    assert batch_path_reason(envs[:1]) is None
    assert batch_path_reason(envs) == (
        "env 1 of the slice computes the inputs (action_to_inputs is overridden by BothCartPole) and the observation "
        "(observation is overridden by BothCartPole) in Python around its FMU's C step, env 0 the inputs "
        "(action_to_inputs is overridden by ThreeForceCartPole): a native slice's envs agree on that")
    for env in envs:
        env.close()


def test_timing_of_a_pool_with_python_edges_counts_fmu_time_and_the_python_around_it() -> None:
    with PoolVectorEnv([partial(BothCartPole) for _ in range(4)], measure_timing=True, cores=2) as pool:
        assert {path for path, _ in pool.step_paths} == {"native"}, pool.step_paths
        pool.reset(seed=0)
        for _ in range(20):
            pool.step(pool.action_space.sample())
        timing = pool.timing()
    assert timing.steps == 20
    assert timing.fmu_s > 0 and timing.env_python_s > 0
    assert timing.wall_s == pytest.approx(timing.fmu_s + timing.env_python_s + timing.pool_overhead_s)


class _StatefulFeatureCartPole(BothCartPole):
    """Hooks that could keep state in the env (the class does not say they keep none)."""

    stateless_hooks = False


def test_envs_with_hooks_keep_their_place_unless_their_class_says_the_hooks_keep_no_state(
        family_fmu: Callable[[str, int], Path]) -> None:
    """An overridden ``observation`` / ``action_to_inputs`` runs on the env itself, which may keep
    state between episodes (a running mean, a frame stack): a moved env is a second copy whose state
    would differ, so the pool keeps it where it is; ``stateless_hooks = True`` lets it move."""
    with PoolVectorEnv([_StatefulFeatureCartPole] * 4, caller_steps=True, cores=2) as pool:
        assert not pool.layout.adaptive, pool.layout
        assert "runs Python per env and step (action_to_inputs, observation of _StatefulFeatureCartPole)" in \
            pool.layout.reason, pool.layout.reason
        assert "stateless_hooks = True" in pool.layout.reason
    with PoolVectorEnv([BothCartPole] * 4, caller_steps=True, cores=2) as pool:
        assert pool.layout.adaptive, pool.layout
    path = family_fmu("probe", 3)
    with PoolVectorEnv([partial(CountingProbe, path)] * 4, cores=2) as pool:  # a user's FMU: no stand-in worker either
        assert not pool.layout.adaptive and "runs Python per env and step" in pool.layout.reason, pool.layout
