"""The native step path of a single FMUEnv: taken when the config defines the whole step, said why
not otherwise, and step for step the same results as the Python path."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from step_paths import assert_same_steps, probe_env

import modelicagym
from modelicagym import FMUEnv
from modelicagym.errors import ConfigError
from modelicagym.fmu.instance import RUNGS


@pytest.mark.parametrize("reset_rung", RUNGS)
def test_cartpole_native_steps_equal_python_steps(fmi_version: int, reset_rung: str) -> None:
    options = dict(fmi_version=fmi_version, reset_rung=reset_rung, max_episode_steps=12)
    native = modelicagym.make("cartpole", **options)
    python = modelicagym.make("cartpole", step_path="python", **options)
    assert native.unwrapped.step_path == "native" and python.unwrapped.step_path == "python"
    actions = np.random.default_rng(1).integers(2, size=400).tolist()
    assert assert_same_steps(native, python, actions) > 20


def test_a_reset_with_the_configs_parameters_restores_the_snapshot_in_c(monkeypatch: pytest.MonkeyPatch) -> None:
    env = modelicagym.make("cartpole", mode="me", max_episode_steps=5)
    first, _ = env.reset(seed=0)
    env.step(1)
    env.reset()  # the snapshot rung is verified against a fresh instance here
    python_resets = []
    monkeypatch.setattr(env.fmu, "reset", lambda values: python_resets.append(values))
    for _ in range(3):
        env.step(0)
        observation, _ = env.reset()
        assert np.array_equal(observation, first) and env.fmu.time == 0.0 and env.elapsed_steps == 0
    assert python_resets == [] and env.episode_parameters == dict(env.config.parameters)
    env.reset(options={"parameters": {"force": 3.0}})  # other parameters: the Python reset ladder
    assert python_resets == [{**env.config.parameters, "force": 3.0}]


def test_box_actions_native_equal_python(family_fmu: Callable[[str, int], Path], fmi_version: int) -> None:
    path = family_fmu("probe", fmi_version)
    native, python = probe_env(path, max_episode_steps=30), probe_env(path, step_path="python")
    python.max_episode_steps = 30
    assert native.step_path == "native"
    actions = list(np.random.default_rng(2).uniform(-10, 10, size=(200, 1)))
    assert assert_same_steps(native, python, actions) > 2


def test_fmu_error_on_the_native_path_truncates_like_the_python_path(
    family_fmu: Callable[[str, int], Path], fmi_version: int
) -> None:
    parameters = {"fault": 2, "fault_after": 3}
    native = probe_env(family_fmu("probe", fmi_version), parameters=parameters)
    python = probe_env(family_fmu("probe", fmi_version), parameters=parameters, step_path="python")
    native.reset(seed=0)
    python.reset(seed=0)
    results = [(native.step(np.array([1.0])), python.step(np.array([1.0]))) for _ in range(4)]
    for a, b in results:
        assert np.array_equal(a[0], b[0]) and a[1:] == b[1:]
    observation, reward, terminated, truncated, info = results[-1][0]
    assert truncated and not terminated and reward == 0.0 and "injected fault" in info["fmu_error"]
    assert native.reset()[0][1] == 0.0, "the next reset recovers (re-instantiates the FMU)"
    assert native.step(np.array([1.0]))[3] is False


def test_model_ending_the_simulation_terminates_on_both_paths(family_fmu: Callable[[str, int], Path]) -> None:
    parameters = {"fault": 1, "fault_after": 2}
    native = probe_env(family_fmu("probe", 2), parameters=parameters)
    python = probe_env(family_fmu("probe", 2), parameters=parameters, step_path="python")
    native.reset(seed=0)
    python.reset(seed=0)
    for _ in range(3):
        a, b = native.step(np.array([0.5])), python.step(np.array([0.5]))
        assert np.array_equal(a[0], b[0]) and a[1:] == b[1:]
    assert a[2] and a[4] == {"fmu_terminated": True}


def test_actions_outside_the_space_are_refused_on_the_native_path(family_fmu: Callable[[str, int], Path]) -> None:
    env = probe_env(family_fmu("probe", 2))
    env.reset(seed=0)
    for action in (np.array([11.0]), np.array([np.nan])):
        with pytest.raises(ValueError):
            env.step(action)
    cartpole = modelicagym.make("cartpole")
    cartpole.reset(seed=0)
    with pytest.raises(ValueError):
        cartpole.step(2)


@pytest.mark.parametrize(
    "make, reason",
    [
        (lambda: modelicagym.make("cartpole", step_path="python"), "step_path='python'"),
    ],
)
def test_envs_the_config_does_not_define_take_the_python_path_and_say_why(make: Any, reason: str) -> None:
    env = make().unwrapped
    assert env.step_path == "python"
    assert reason in env.step_path_reason


def test_the_native_env_passes_gymnasiums_checker() -> None:
    env = modelicagym.make("cartpole")
    assert env.unwrapped.step_path == "native"
    check_env(env.unwrapped, skip_render_check=True)


@pytest.mark.parametrize(
    "options",
    [{"step_path": "fast"}, {"action_table": []}, {"action_table": [[1.0], [1.0, 2.0]]}],
)
def test_bad_native_options_are_config_errors(family_fmu: Callable[[str, int], Path], options: dict) -> None:
    with pytest.raises(ConfigError):
        probe_env(family_fmu("probe", 2), **options)


def test_action_table_sets_a_discrete_action_space(family_fmu: Callable[[str, int], Path]) -> None:
    env = FMUEnv(fmu=family_fmu("probe", 2), inputs=["force"], outputs=["position"], action_table=[[-2.0], [0.0], [2.0]],
                 parameters={"gear": 0, "enable": True}, time_step=1.0)
    assert env.action_space.n == 3 and env.step_path == "native"
    env.reset(seed=0)
    env.step(2)
    assert env.fmu.inputs.views["force"] == 2.0
