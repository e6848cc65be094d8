"""An overridden ``observation`` or ``action_to_inputs`` keeps the FMU's step in C: Python computes
the inputs before the C step and the observation after it, with the Python path's results to the
last bit — every FMI version, co-simulation and model exchange (whose solver restarts only when the
input bytes change), integer and boolean inputs, with and without a reward written in Python, and
an FMU error mid-step. What needs Python for the whole step stays there."""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from gymnasium import spaces
from python_edges import CARTPOLES, BothCartPole, GearboxProbe, GearboxProbeEndings, ThreeForceCartPoleEndings

from modelicagym import FMUEnv
from modelicagym.bench.throughput import c_loop
from modelicagym.errors import ConfigError
from modelicagym.models.cartpole import OUTPUTS, cartpole_fmu
from modelicagym.models.cartpole.env import CartPoleEnv


def assert_same_result(a: Any, b: Any, where: str) -> None:
    """Equal bit for bit, of the same types and dtypes."""
    assert type(a) is type(b), f"{where}: {type(a)} vs {type(b)}"
    if isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and a.tobytes() == b.tobytes(), f"{where}: {a!r} vs {b!r}"
    else:
        assert a == b, f"{where}: {a!r} vs {b!r}"


def assert_same_episodes(native: FMUEnv, python: FMUEnv, actions: list[Any]) -> int:
    """Step both with ``actions``, resetting both when an episode ends; returns the episodes ended."""
    assert native.step_path == "native" and native.python_edges, native.step_path_reason
    assert python.step_path == "python"
    assert_same_result(native.reset(seed=0)[0], python.reset(seed=0)[0], "reset")
    episodes = 0
    for k, action in enumerate(actions):
        a, b = native.step(action), python.step(action)
        for name, x, y in zip(("observation", "reward", "terminated", "truncated", "info"), a, b):
            assert_same_result(x, y, f"{name} of step {k}")
        assert native.fmu.inputs.snapshot() == python.fmu.inputs.snapshot(), f"inputs of step {k}"
        assert (native.elapsed_steps, native.fmu.time) == (python.elapsed_steps, python.fmu.time)
        if a[2] or a[3]:
            episodes += 1
            assert_same_result(native.reset()[0], python.reset()[0], f"reset after step {k}")
    return episodes


def held_actions(space: spaces.Discrete, n: int, seed: int = 1) -> list[int]:
    """``n`` actions in runs of 1 to 4 equal ones: inputs that change between steps and inputs that do not."""
    rng = np.random.default_rng(seed)
    return np.repeat(rng.integers(space.n, size=n), rng.integers(1, 5, size=n))[:n].tolist()


@pytest.mark.parametrize("mode", ["cs", "me"])
@pytest.mark.parametrize("fmi_version", [1, 2, 3])
@pytest.mark.parametrize("kind", CARTPOLES)
def test_the_cartpole_steps_in_c_with_its_edges_in_python_as_the_python_path(kind: str, fmi_version: int,
                                                                              mode: str) -> None:
    """In model exchange CVode's numbers differ after a restart, so equal observations pin the
    solver's restart rule: it restarts only when the inputs Python wrote differ from the last step's."""
    cls, edges = CARTPOLES[kind]
    options = {"fmi_version": fmi_version, "mode": mode, "max_episode_steps": 25}
    native, python = cls(**options), cls(step_path="python", **options)
    for edge in edges:
        assert f"the {edge} (" in native.step_path_reason and f"the {edge} (" in native.python_edges
    assert native.native_step.python_inputs == ("inputs" in edges)
    assert assert_same_episodes(native, python, held_actions(native.action_space, 400)) > 10


@pytest.mark.parametrize("cls", [GearboxProbe, GearboxProbeEndings])
def test_integer_and_boolean_inputs_from_a_dict_of_some_inputs(family_fmu: Callable[[str, int], Path],
                                                               fmi_version: int, cls: type) -> None:
    path = family_fmu("probe", fmi_version)
    native, python = cls(path), cls(path, step_path="python")
    assert assert_same_episodes(native, python, held_actions(native.action_space, 200)) > 10
    assert native.fmu.inputs.views["mode"] == 1 and native.fmu.inputs.views["boost"] == 0, "inputs left out stay"


def test_an_fmu_error_mid_step_truncates_as_on_the_python_path(family_fmu: Callable[[str, int], Path],
                                                               fmi_version: int) -> None:
    path = family_fmu("probe", fmi_version)
    make = partial(GearboxProbe, path, parameters={"fault": 2, "fault_after": 3})
    native, python = make(), make(step_path="python")
    actions = [7, 8, 9, 7, 8, 9, 1, 2, 3, 4]
    assert assert_same_episodes(native, python, actions) == 2
    native.reset(seed=0)
    results = [native.step(action) for action in actions[:4]]
    assert [r[3] for r in results] == [False, False, False, True]
    _, reward, terminated, _, info = results[-1]
    assert reward == 0.0 and not terminated and "injected fault" in info["fmu_error"]
    assert native.reset()[0][3] == 0.0, "the next reset re-instantiates the FMU"


def test_the_reason_says_what_runs_where() -> None:
    assert ThreeForceCartPoleEndings().step_path_reason == (
        "the FMU steps in C; the inputs (action_to_inputs is overridden by ThreeForceCartPoleEndings) in Python "
        "before it; the reward (compute_reward per env) and the termination (is_terminal per env) in Python after it")
    both = BothCartPole()
    assert both.step_path_reason == (
        "the FMU steps in C; the inputs (action_to_inputs is overridden by BothCartPole) in Python before it; "
        "the observation (observation is overridden by BothCartPole) in Python after it")
    assert both.python_edges == ("the inputs (action_to_inputs is overridden by BothCartPole) and the observation "
                                 "(observation is overridden by BothCartPole)")
    plain = CartPoleEnv()
    assert (plain.step_path_reason, plain.python_edges) == ("the config defines the whole step", None)


def config_cartpole(**config: Any) -> FMUEnv:
    return FMUEnv(fmu=cartpole_fmu(), inputs=["f"], outputs=list(OUTPUTS), time_step=0.05, max_episode_steps=30,
                  termination={"x": (-0.5, 0.5)}, **config)


@pytest.mark.parametrize("config, reason", [
    ({"action_table": [[-9.0], [0.0], [9.0]], "action_space": spaces.Discrete(2)},
     "the inputs (the action space Discrete(2) is not Discrete(3) of 'action_table')"),
    ({"action_table": [[-9.0], [9.0]], "observation_space": spaces.Box(-np.inf, np.inf, (4,), np.float32)},
     "the observation (the observation space Box(-inf, inf, (4,), float32) is not laid out as the outputs' own"),
])
def test_a_config_that_c_cannot_map_keeps_the_fmu_in_c(config: dict, reason: str) -> None:
    native, python = config_cartpole(**config), config_cartpole(step_path="python", **config)
    assert reason in native.step_path_reason
    assert assert_same_episodes(native, python, held_actions(spaces.Discrete(2), 200)) > 5


def test_what_needs_python_for_the_whole_step_stays_there(family_fmu: Callable[[str, int], Path]) -> None:
    class OwnStep(BothCartPole):
        def step(self, action: Any) -> Any:
            return super().step(action)

    assert OwnStep().step_path_reason == "step is overridden by OwnStep"
    assert BothCartPole(step_path="python").step_path == "python"
    charted = GearboxProbe(family_fmu("probe", 2), render_mode="rgb_array")
    assert (charted.step_path, charted.python_edges) == ("python", None)
    assert "strip chart" in charted.step_path_reason


def test_the_c_loop_refuses_an_env_whose_step_needs_python() -> None:
    with pytest.raises(ConfigError, match=r"the C loop needs the whole step in C: .*action_to_inputs is overridden"):
        c_loop(ThreeForceCartPoleEndings())
