"""A system driven by a source without inputs, as a test bench's SSP is (OMSimulator's DC motor: a
stimulus FMU's voltage step and load feed the motor, nothing is left to drive): ``info`` acts on
the source's levels, at the SSP's values; ``try --step`` steps one; ``info --task`` drafts a task
that runs and trains as written. The Stimulus FMU (a step and a constant set by parameters) feeds
the Tank (``tests/fmus/unbounded``: a lag to the ambient pressure, whose doStep fails outside
2e4..5e5 Pa), with the SSP's height far from the FMU's start (101325 against 1)."""

from __future__ import annotations

import os
import zipfile
from pathlib import Path

import numpy as np
import pytest
from ssp_cases import bindings, component, connect, connectors, system, write_ssp_folder

from modelicagym import FMUEnv
from modelicagym.cli import main
from modelicagym.errors import ConfigError
from modelicagym.info import suggest
from modelicagym.step_response import step_response
from modelicagym.system import open_system
from modelicagym.task import read_task_file
from modelicagym.task_draft import draft_task, write_task
from modelicagym.try_fmu import prepare, try_fmu

AMBIENT = 101325.0  # Pa: the SSP's height of the step, the stimulus FMU's own start being 1


@pytest.fixture
def bench(family_fmu, tmp_path):
    """The stimulus feeding the tank; the system's own output is the tank's pressure."""
    def make(height: float = AMBIENT, name: str = "bench") -> Path:
        top = system("bench", [component("stimuli", "stimulus", bindings({"height": height})),
                               component("vessel", "unbounded")],
                     [connect("stimuli.y", "vessel.p_amb"), connect("vessel.p", ".p")], connectors(p="output"))
        return write_ssp_folder(tmp_path / name, top, {"stimulus": family_fmu("stimulus", 2),
                                                       "unbounded": family_fmu("unbounded", 2)})
    return make


def _episode_returns(env: FMUEnv, act, seeds, start=lambda: None) -> list[float]:
    """Each episode's return, ``act(observation)`` choosing the actions (``start()`` after each reset)."""
    returns = []
    for seed in seeds:
        observation, _ = env.reset(seed=seed)
        start()
        total, done = 0.0, False
        while not done:
            observation, reward, terminated, truncated, info = env.step(act(observation))
            assert "fmu_error" not in info
            total, done = total + reward, terminated or truncated
        returns.append(total)
    return returns


def test_info_acts_on_the_level_of_the_source_at_the_ssps_value_and_try_runs_it(bench, tmp_path):
    folder = bench()
    suggestion = suggest(open_system(folder))
    config = suggestion.config
    assert config["inputs"] == ["stimuli.height"]  # not its offset (0) nor its start time (in s)
    assert config["outputs"] == ["p"]  # the system's own output
    assert config["action_bounds"] == {"stimuli.height": (AMBIENT / 2, AMBIENT * 1.5)}  # around the SSP's value
    assert "stimuli.height" not in config["parameters"] and config["parameters"]["stimuli.offset"] == 0.0
    assert "no inputs: stimuli (no inputs of its own) feeds the others" in suggestion.notes[0]
    prepared = prepare(folder)
    result = try_fmu(prepared.config, out=tmp_path / "try.png", steps=50)
    assert result.fmu_error is None and result.steps == 50 and not prepared.assumed
    # the bounds the FMU's own start gives (0.5..1.5 Pa) drive the tank out of its range at once
    start_bounds = {**prepared.config, "action_bounds": {"stimuli.height": (0.5, 1.5)}}
    assert "ambient pressure" in try_fmu(start_bounds, out=tmp_path / "start.png", steps=50).fmu_error


def test_a_source_whose_levels_nothing_bounds_leaves_them_to_fill_in(bench):
    config = suggest(open_system(bench(height=0.0))).config  # a level of 0: no start, nominal or unit to scale
    assert config["inputs"] == ["stimuli.height"] and config["action_bounds"] == {"stimuli.height": None}


def test_try_step_steps_a_systems_tunable_parameter(bench):
    config = suggest(open_system(bench())).config
    response = step_response(config, "stimuli.height")
    assert (response.start_value, response.step_value) == (AMBIENT, AMBIENT * 1.5)
    (pressure,) = response.outputs
    assert pressure.behaviour == "settles" and pressure.change == pytest.approx(AMBIENT / 2, rel=1e-3)
    assert 3.0 < pressure.settling_time < 5.0  # a lag of 1 s into a band of 2%: 3.9 s


def test_info_task_drafts_a_task_that_runs_as_written_and_whose_baseline_beats_random_actions(bench, tmp_path,
                                                                                              capsys):
    folder = bench()
    task = tmp_path / "tasks" / "bench_task.py"
    task.parent.mkdir()
    assert main(["info", str(folder), "--task", str(task)]) == 0
    out = capsys.readouterr().out
    assert f"wrote {task}" in out and "p follows a setpoint drawn at every reset in " in out
    assert "acted on through stimuli.height (50662.5..151988)" in out
    read = read_task_file(task)
    config = read.config
    assert Path(config["fmu"]).resolve() == folder  # written relative to the task's folder, read back from anywhere
    assert (config["time_step"], config["max_episode_steps"]) == (0.2, 40)  # a tenth, and twice, its 3.9 s
    env = FMUEnv(config)
    setpoint = config["setpoints"]["p"]
    assert (setpoint.low, setpoint.high) == pytest.approx((AMBIENT / 2, AMBIENT * 1.5), rel=1e-3)
    seeds = range(3)
    planned = _episode_returns(env, read.baseline.act, seeds, read.baseline.reset)
    env.action_space.seed(0)
    random = _episode_returns(env, lambda _: env.action_space.sample(), seeds)
    env.close()
    assert np.mean(planned) > np.mean(random)
    assert max(planned) < 0.0  # the error's magnitude is paid every step
    with pytest.raises(ConfigError, match="bench_task.py exists"):
        write_task(folder, task)


def test_a_task_is_not_drafted_on_a_range_nothing_says(bench, tmp_path):
    with pytest.raises(ConfigError, match="nothing says the range of stimuli.height, so a task cannot be drafted"):
        draft_task(bench(height=0.0), tmp_path / "task.py")


@pytest.mark.skipif(not os.environ.get("MODELICAGYM_OMSIMULATOR_TESTSUITE"),
                    reason="OMSimulator's testsuite folder is not here (set MODELICAGYM_OMSIMULATOR_TESTSUITE to it)")
def test_omsimulators_dc_motor_goes_from_info_to_a_task_with_no_edit(tmp_path, capsys):
    resources = Path(os.environ["MODELICAGYM_OMSIMULATOR_TESTSUITE"]) / "tests" / "resources" / "dcmotor"
    archive = tmp_path / "dcmotor.ssp"
    with zipfile.ZipFile(archive, "w") as ssp:  # packed as its CMakeLists packs it
        for path in sorted(resources.rglob("*")):
            if path.is_file():
                ssp.write(path, path.relative_to(resources).as_posix())
    task = tmp_path / "dcmotor_task.py"
    assert main(["info", str(archive), "--task", str(task)]) == 0
    assert "wB follows a setpoint" in capsys.readouterr().out
    read = read_task_file(task)
    assert read.config["inputs"] == ["stimuli_model.Voltage_step.height"]
    env = FMUEnv(read.config)
    planned = _episode_returns(env, read.baseline.act, range(3), read.baseline.reset)
    env.action_space.seed(0)
    random = _episode_returns(env, lambda _: env.action_space.sample(), range(3))
    env.close()
    assert np.mean(planned) > np.mean(random)


def test_try_step_holds_a_systems_other_input_connectors(family_fmu, tmp_path):
    top = system("top", [component("a", "gain"), component("b", "gain")],
                 [connect(".u", "a.u", factor=2.0), connect(".v", "b.u"), connect("a.y", ".y"), connect("b.y", ".z")],
                 connectors(u="input", v="input", y="output", z="output"), bindings({"v": 3.0}))
    folder = write_ssp_folder(tmp_path / "two", top, {"gain": family_fmu("gain", 2)})
    config = suggest(open_system(folder)).config
    assert config["inputs"] == ["u", "v"] and config["outputs"] == ["y", "z"]
    response = step_response(config, "u", 1.5)
    y, z = response.outputs
    assert (y.change, y.settling_time) == (3.0, 0.0)  # 2 u, within the first step
    assert not z.responds  # v held at the SSP's 3 in both runs
