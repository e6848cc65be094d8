"""Model exchange with discrete inputs on the native step path: FMI lets an importer set Integer,
Enumeration, Boolean and discrete Real inputs (FMI 3.0: Int64, UInt8, ...) in event mode only, so
every step of such an env enters event mode, sets them and settles the event iteration; C does it
with the Python path's FMU calls in the Python path's order. The test FMU (``me_discrete``, the
Shifter of ``tests/fmus/me_discrete``) switches its derivative's sign and its state events with
those inputs, ends the simulation when ``stop`` is set, and fails an event update in ``jam_gear``.
Each case steps natively and gives the Python path's observations, rewards, endings and infos bit
for bit, across native resets; a pool of them steps in one C call per slice and gives what
`SyncVectorEnv` over Python-path envs gives."""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from fmu_family import FMUS_DIR
from gymnasium.vector import AutoresetMode, SyncVectorEnv
from vector_rollouts import assert_same, rollout

import modelicagym
from modelicagym import FMUEnv
from modelicagym.fmu.build import build_source_fmu

OUTPUTS = ["x", "crossings", "ticks", "updates", "shifts"]
SOLVERS = {"cvode": {}, "euler": {"solver_step": 0.01}, "rk4": {"solver_step": 0.025}}
VERSIONS = (1, 2, 3)


@pytest.fixture(scope="module")
def shifter(family_fmu: Callable[[str, int], Path]) -> Callable[[int], Path]:
    """The Shifter FMU of an FMI version (FMI 1.0: its model-exchange build)."""
    return lambda version: build_source_fmu(FMUS_DIR / "me_discrete", 1, "me") if version == 1 else family_fmu(
        "me_discrete", version)


def inputs_of(version: int) -> list[str]:
    return ["gear", "direction", "stop", "level"] + (["bias", "weight"] if version == 3 else [])


def config(path: Path, version: int, solver: str = "cvode", **options: Any) -> dict[str, Any]:
    return {"fmu": path, "inputs": inputs_of(version), "outputs": OUTPUTS, "time_step": 0.1,
            "max_episode_steps": 23, "mode": "me", "solver": solver, **SOLVERS[solver], **options}


def both_paths(cfg: dict[str, Any]) -> tuple[FMUEnv, FMUEnv]:
    native, python = FMUEnv(**cfg), FMUEnv(**cfg, step_path="python")
    assert native.step_path == "native", native.step_path_reason
    assert native.fmu.mode == "me" and native.fmu.event_mode_inputs
    return native, python


def scripted_actions(version: int, n: int, stop_at: tuple[int, ...] = ()) -> list[dict[str, Any]]:
    """``n`` actions: runs of repeated inputs (the event changes nothing) between changes of every
    input; ``stop`` only at the steps ``stop_at``."""
    rng = np.random.default_rng(5)
    actions, action = [], None
    for k in range(n):
        if action is None or k % 3 == 0:
            action = {"gear": int(rng.integers(0, 4)), "direction": int(rng.integers(1, 3)),
                      "level": np.array(rng.uniform(-1, 1))}
            if version == 3:
                action.update(bias=int(rng.integers(-3, 4)), weight=np.array(rng.integers(0, 5)))
        actions.append({**action, "stop": int(k in stop_at)})
    return actions


def assert_same_steps(native: FMUEnv, python: FMUEnv, actions: list[Any]) -> list[tuple]:
    """Step both with ``actions``, resetting both after an episode ends; every result bit for bit.
    Returns the native results."""
    results = []
    a, b = native.reset(seed=0), python.reset(seed=0)
    assert_same(a, b, "reset")
    for k, action in enumerate(actions):
        a, b = native.step(action), python.step(action)
        assert_same(a, b, f"step {k}")
        results.append(a)
        if a[2] or a[3]:
            assert_same(native.reset(), python.reset(), f"reset after step {k}")
    return results


@pytest.mark.parametrize("solver", SOLVERS)
@pytest.mark.parametrize("version", VERSIONS)
def test_discrete_inputs_in_model_exchange_step_natively_as_in_python(shifter: Callable[[int], Path], version: int,
                                                                      solver: str) -> None:
    native, python = both_paths(config(shifter(version), version, solver))
    python_resets = []
    fmu_reset = native.fmu.reset
    native.fmu.reset = lambda *args: python_resets.append(args) or fmu_reset(*args)  # counts, changes nothing
    results = assert_same_steps(native, python, scripted_actions(version, 120, stop_at=(30, 31, 77)))
    last = results[-1][0]
    assert last["shifts"] > 0 and last["ticks"] > 0 and last["crossings"] > 0, last  # the inputs made events
    ended = [(terminated, truncated, info) for _, _, terminated, truncated, info in results if terminated or truncated]
    assert (True, False, {"fmu_terminated": True}) in ended and (False, True, {}) in ended
    if version > 1:  # FMI 1.0 has no snapshots: all its resets are Python's
        assert len(python_resets) <= 2 < len(ended), f"{len(python_resets)} of {len(ended) + 1} resets in Python"
    native.close(), python.close()


@pytest.mark.parametrize("version", VERSIONS)
def test_stop_ends_the_episode_in_the_inputs_event_as_in_python(shifter: Callable[[int], Path], version: int) -> None:
    native, python = both_paths(config(shifter(version), version))
    actions = scripted_actions(version, 9, stop_at=(6,))
    results = assert_same_steps(native, python, actions)
    assert [r[2] for r in results] == [False] * 6 + [True, False, False]
    assert results[6][4] == {"fmu_terminated": True} and results[6][1] == native.negative_reward
    native.close(), python.close()


@pytest.mark.parametrize("version", VERSIONS)
def test_an_event_update_failing_in_the_inputs_event_truncates_as_in_python(shifter: Callable[[int], Path],
                                                                            version: int) -> None:
    """``jam_gear``: the event iteration after the inputs are set fails; the next reset re-instantiates."""
    native, python = both_paths(config(shifter(version), version, parameters={"jam_gear": 2}))
    actions = [{**action, "gear": 2 if k in (5, 19) else action["gear"] % 2}
               for k, action in enumerate(scripted_actions(version, 30))]
    results = assert_same_steps(native, python, actions)
    errors = [info["fmu_error"] for _, _, _, _, info in results if "fmu_error" in info]
    assert len(errors) == 2 and all("returned Error" in e and "gear 2 jams" in e for e in errors), errors
    assert native.step_path == "native"
    native.close(), python.close()


@pytest.mark.parametrize("inputs", [["gear", "mode", "enable", "boost", "force"], ["force", "gain"]],
                         ids=["typed inputs", "a tunable parameter"])
def test_the_probe_in_model_exchange_steps_natively_as_in_python(family_fmu: Callable[[str, int], Path],
                                                                 fmi_version: int, inputs: list[str]) -> None:
    """Integer, enumeration and Boolean inputs, or a tunable parameter as an input: set in event mode."""
    native, python = both_paths({"fmu": family_fmu("probe", fmi_version), "inputs": inputs, "mode": "me",
                                 "outputs": ["position", "speed", "moving"], "time_step": 0.1, "max_episode_steps": 17,
                                 "parameters": {} if "gear" in inputs else {"gear": 2, "enable": True}})
    native.action_space.seed(3)
    assert_same_steps(native, python, [native.action_space.sample() for _ in range(60)])
    native.close(), python.close()


class OutOfRangeDirection(FMUEnv):
    """Writes a direction the FMU's Int64 enumeration cannot hold: setting the inputs fails in event mode."""

    def action_to_inputs(self, action: Any) -> dict[str, Any]:
        return {**action, "direction": 2**40 if action["stop"] else action["direction"], "stop": 0}


def test_inputs_failing_in_event_mode_truncate_as_in_python(shifter: Callable[[int], Path]) -> None:
    cfg = config(shifter(3), 3)
    native, python = OutOfRangeDirection(**cfg), OutOfRangeDirection(**cfg, step_path="python")
    assert native.step_path == "native", native.step_path_reason
    results = assert_same_steps(native, python, scripted_actions(3, 12, stop_at=(4,)))
    assert results[4][3] and "set inputs returned Error" in results[4][4]["fmu_error"], results[4]
    native.close(), python.close()


def pool_config(path: Path, version: int) -> dict[str, Any]:
    """A Discrete action over a table of inputs (one row stops the model, one jams env 3's gear)."""
    rows = [[1, 1, 0, 0.5], [1, 1, 0, 0.5], [3, 2, 0, -0.25], [0, 1, 0, 0.75], [2, 2, 0, 0.0], [1, 2, 1, 0.0]]
    if version == 3:
        rows = [row + [k % 3 - 1, k % 5] for k, row in enumerate(rows)]
    return config(path, version, action_table=rows, max_episode_steps=None)


@pytest.mark.processes
@pytest.mark.timeout(240)
@pytest.mark.parametrize("mode", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP], ids=lambda m: m.value)
@pytest.mark.parametrize("version", (2, 3))
def test_a_pool_of_them_steps_natively_as_sync_vector_env(shifter: Callable[[int], Path], version: int,
                                                          mode: AutoresetMode) -> None:
    cfg = pool_config(shifter(version), version)
    per_env = [{"max_episode_steps": 9 + 4 * i, **({"parameters": {"jam_gear": 2}} if i == 3 else {})}
               for i in range(4)]
    sync = SyncVectorEnv([partial(FMUEnv, **{**cfg, **options}, step_path="python") for options in per_env],
                         autoreset_mode=mode)
    with modelicagym.make_vec(cfg, n=4, options_per_env=per_env, autoreset_mode=mode) as pool:
        assert [path for path, _ in pool.step_paths] == ["native"] * len(pool.step_paths), pool.step_paths
        expected, actual = rollout(sync, 80), rollout(pool, 80)
    sync.close()
    assert_same(expected, actual)
    infos = [result[4] for result in expected[1:]]
    assert any("fmu_error" in info or "fmu_error" in info.get("final_info", {}) for info in infos), "no FMU error"
    assert any("fmu_terminated" in info or "fmu_terminated" in info.get("final_info", {}) for info in infos)
