"""Every numeric FMI type on the native step path: integer, enumeration, boolean, Float32, the sized
integers and FMI 3.0 arrays as inputs and outputs, tunable parameters as actions, FMI 1.0
co-simulation and model exchange; each steps in C with the Python path's results bit for bit (observations of the same
dtypes), and a pool of them steps natively too."""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from fmu_family import BALL_DIR, BALL_OUTPUTS
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, SyncVectorEnv
from vector_rollouts import assert_same, rollout

import modelicagym
from modelicagym import FMUEnv
from modelicagym.fmu import FMUInstance
from modelicagym.fmu.build import build_source_fmu
from modelicagym.vector import PoolVectorEnv

#: (inputs, outputs) per case; FMI 3.0 cases use the variables only the FMI 3.0 probe has
CASES = {
    "integer+enumeration": (["gear", "mode"], ["speed", "mode_out", "steps"]),
    "boolean": (["enable", "boost"], ["moving"]),
    "integer as Discrete": (["gear"], ["position", "speed"]),
    "enumeration as Discrete": (["mode"], ["mode_out"]),
    "every type as a Dict": (["gear", "mode", "enable", "boost", "force"],
                             ["position", "clock", "speed", "mode_out", "moving", "steps"]),
    "tunable parameter": (["force", "gain"], ["position", "clock"]),
}
CASES3 = {
    "Float64 array": (["u"], ["y"]),
    "Int8 to UInt16, arrays of booleans": (["trim"], ["level", "positive"]),
    "UInt64 and Int64": (["tag", "gear"], ["tag_out", "ticks"]),
    "Float32": (["force"], ["thrust"]),
    "every type as a Dict": (["gear", "mode", "enable", "boost", "force", "u", "trim", "tag"],
                             ["position", "clock", "speed", "mode_out", "moving", "steps", "y", "positive", "ticks",
                              "thrust", "level", "tag_out"]),
}


def assert_same_value(a: Any, b: Any, where: str) -> None:
    """Equal bit for bit, and of the same type and dtype (dicts key by key)."""
    assert type(a) is type(b), f"{where}: {type(a)} vs {type(b)}"
    if isinstance(a, dict):
        assert list(a) == list(b), where
        for key in a:
            assert_same_value(a[key], b[key], f"{where}[{key!r}]")
        return
    assert np.asarray(a).dtype == np.asarray(b).dtype, f"{where}: {np.asarray(a).dtype} vs {np.asarray(b).dtype}"
    assert np.asarray(a).tobytes() == np.asarray(b).tobytes(), f"{where}: {a!r} vs {b!r}"


def actions_for(space: spaces.Space, n: int, seed: int = 3) -> list[Any]:
    """``n`` actions of ``space`` (UInt64 values above 2**63 included, to cross the sign bit)."""
    space.seed(seed)
    rng = np.random.default_rng(seed)

    def one(sub: spaces.Space) -> Any:
        if isinstance(sub, spaces.Box) and sub.dtype == np.uint64:
            return rng.integers(0, 2**64 - 1, size=sub.shape, dtype=np.uint64, endpoint=True)
        if isinstance(sub, spaces.Dict):
            return {key: one(s) for key, s in sub.items()}
        return sub.sample()

    return [one(space) for _ in range(n)]


def both_paths(make: Callable[..., FMUEnv]) -> tuple[FMUEnv, FMUEnv]:
    native, python = make(), make(step_path="python")
    assert native.step_path == "native", native.step_path_reason
    assert python.step_path == "python"
    return native, python


def assert_same_episodes(native: FMUEnv, python: FMUEnv, steps: int = 60) -> None:
    assert_same_value(native.reset(seed=0)[0], python.reset(seed=0)[0], "reset")
    for k, action in enumerate(actions_for(native.action_space, steps)):
        a, b = native.step(action), python.step(action)
        assert_same_value(a[0], b[0], f"observation of step {k}")
        assert a[1:] == b[1:], f"step {k}: {a[1:]} vs {b[1:]}"
        assert native.fmu.inputs.snapshot() == python.fmu.inputs.snapshot(), f"inputs set in step {k}"
        if a[2] or a[3]:
            assert_same_value(native.reset()[0], python.reset()[0], f"reset after step {k}")


def probe(path: Path, inputs: list[str], outputs: list[str], **config: Any) -> FMUEnv:
    config = {"time_step": 0.1, "max_episode_steps": 17, **config}
    return FMUEnv(fmu=path, inputs=inputs, outputs=outputs, parameters={"gear": 2} if "gear" not in inputs else {},
                  **config)


@pytest.mark.parametrize("case", CASES)
def test_fmi2_and_fmi3_types_step_natively_as_in_python(family_fmu: Callable[[str, int], Path], fmi_version: int,
                                                         case: str) -> None:
    inputs, outputs = CASES[case]
    assert_same_episodes(*both_paths(partial(probe, family_fmu("probe", fmi_version), inputs, outputs)))


@pytest.mark.parametrize("case", CASES3)
def test_fmi3_sized_types_and_arrays_step_natively_as_in_python(family_fmu: Callable[[str, int], Path],
                                                               case: str) -> None:
    inputs, outputs = CASES3[case]
    assert_same_episodes(*both_paths(partial(probe, family_fmu("probe", 3), inputs, outputs)))


def test_bounds_on_integer_outputs_terminate_as_in_python(family_fmu: Callable[[str, int], Path],
                                                          fmi_version: int) -> None:
    make = partial(probe, family_fmu("probe", fmi_version), ["gear"], ["speed", "steps"],
                   termination={"steps": (0, 5)})
    native, python = both_paths(make)
    assert_same_episodes(native, python, steps=30)
    native.reset(seed=0)
    assert [native.step(1)[2] for _ in range(6)] == [False] * 5 + [True]


def test_an_action_table_over_typed_inputs(family_fmu: Callable[[str, int], Path], fmi_version: int) -> None:
    table = [[0, 1, 0, 0, -2.5], [4, 3, 1, 1, 2.5], [1, 2, 1, 0, 0.0]]
    make = partial(probe, family_fmu("probe", fmi_version), ["gear", "mode", "enable", "boost", "force"],
                   ["position", "speed", "moving"], action_table=table)
    assert_same_episodes(*both_paths(make))


@pytest.mark.parametrize("mode", ["cs", "me"])
def test_fmi1_steps_natively_as_in_python(mode: str) -> None:
    native, python = both_paths(partial(modelicagym.make, "cartpole", fmi_version=1, mode=mode, max_episode_steps=9))
    assert_same_episodes(native.unwrapped, python.unwrapped, steps=80)


def test_fmi1_model_exchange_events_in_c_as_in_python() -> None:
    """The bouncing ball's state events and time event, through fmiEventUpdate in C."""
    path = build_source_fmu(BALL_DIR, 1, "me")

    def run(integrator: str) -> list[bytes]:
        with FMUInstance(path, mode="me", outputs=BALL_OUTPUTS, integrator=integrator) as fmu:
            assert fmu.integrator_path == ("python" if integrator == "python" else "native")
            rows = []
            for _ in range(2):
                fmu.reset({"t_switch": 1.5})
                for _ in range(40):
                    fmu.step(0.05)
                    rows.append(fmu.outputs.snapshot())
            assert fmu.outputs.views["bounces"] == 3 and fmu.outputs.views["t_switched"] == pytest.approx(1.5)
            return rows

    assert run("auto") == run("python")


POOL_CASES = {
    2: [(["gear", "mode"], ["speed", "mode_out"]), (["enable", "boost"], ["moving"]), (["gear"], ["steps"]),
        CASES["every type as a Dict"]],
    3: [(["u"], ["y"]), (["trim"], ["level"]), (["enable", "boost"], ["positive"]), (["tag"], ["tag_out"]),
        (["gear"], ["ticks"]), (["force"], ["thrust"]), CASES3["every type as a Dict"]],
}


@pytest.mark.processes
@pytest.mark.timeout(180)
@pytest.mark.parametrize("mode", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP])
def test_a_pool_of_typed_envs_steps_natively_as_sync_over_python(family_fmu: Callable[[str, int], Path],
                                                                 fmi_version: int, mode: AutoresetMode) -> None:
    for inputs, outputs in POOL_CASES[fmi_version]:
        path = family_fmu("probe", fmi_version)
        native = [partial(probe, path, inputs, outputs, max_episode_steps=5 + 3 * i) for i in range(3)]
        python = [partial(probe, path, inputs, outputs, max_episode_steps=5 + 3 * i, step_path="python")
                  for i in range(3)]
        sync = SyncVectorEnv(python, autoreset_mode=mode)
        with PoolVectorEnv(native, autoreset_mode=mode, num_workers=1, caller_steps=True) as pool:
            assert {path for path, _ in pool.step_paths} == {"native"}, pool.step_paths
            expected, actual = rollout(sync, 40), rollout(pool, 40)
        sync.close()
        assert_same(expected, actual)


@pytest.mark.processes
@pytest.mark.timeout(180)
def test_a_pool_of_typed_envs_on_the_python_path_steps_as_sync(family_fmu: Callable[[str, int], Path],
                                                               fmi_version: int) -> None:
    """A Dict observation written by a slice on the Python path (into its keys' shared views) reads
    back as the env returned it, every type."""
    inputs, outputs = (CASES if fmi_version == 2 else CASES3)["every type as a Dict"]
    python = [partial(probe, family_fmu("probe", fmi_version), inputs, outputs, max_episode_steps=5 + 3 * i,
                      step_path="python") for i in range(3)]
    sync = SyncVectorEnv(python, autoreset_mode=AutoresetMode.NEXT_STEP)
    with PoolVectorEnv(python, num_workers=1, caller_steps=True) as pool:
        assert {path for path, _ in pool.step_paths} == {"python"}
        expected, actual = rollout(sync, 40), rollout(pool, 40)
    sync.close()
    assert_same(expected, actual)


def test_a_float_box_over_typed_inputs_is_cast_as_numpy_casts(family_fmu: Callable[[str, int], Path],
                                                              fmi_version: int) -> None:
    """Fractions into integers truncate, into FMI 2.0's int booleans too, into FMI 3.0's bools: != 0."""
    box = spaces.Box(np.array([0, 1, 0, 0, -10.0]), np.array([4.9, 3.9, 1, 1, 10.0]), dtype=np.float64)
    make = partial(probe, family_fmu("probe", fmi_version), ["gear", "mode", "enable", "boost", "force"],
                   ["position", "speed", "moving"], action_space=box)
    assert_same_episodes(*both_paths(make))


@pytest.mark.processes
def test_a_pool_with_a_float32_dict_entry_says_why_its_slices_step_in_python(
        family_fmu: Callable[[str, int], Path]) -> None:
    box = spaces.Dict({"force": spaces.Box(-10, 10, (), np.float32), "gear": spaces.Discrete(5)})
    fns = [partial(probe, family_fmu("probe", 2), ["gear", "force"], ["position"], action_space=box)] * 2
    with PoolVectorEnv(fns, num_workers=1, caller_steps=True) as pool:
        assert {path for path, _ in pool.step_paths} == {"python"}
        assert "entry 'force' of the action space is a float32 Box over float64 values" in pool.step_paths[0].reason
    assert fns[0]().step_path == "native"  # each env alone steps natively
