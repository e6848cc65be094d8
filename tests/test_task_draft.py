"""``modelicagym info FMU --task FILE`` on the sample heater, whose equations give every number the
drafted task should hold: ``C der(T) = P_max u - G (T - T_amb)``, so the room's temperature settles
at ``T_amb + u P_max / G`` (5 to 35 degC for u in 0..1: a gain of 30 K) with a time constant of
``C / G = 600 s``."""

from __future__ import annotations

import runpy
from pathlib import Path

import pytest

from modelicagym import FMUEnv
from modelicagym.task import read_task_file
from modelicagym.task_draft import draft_task, write_task


@pytest.fixture
def heater(family_fmu, tmp_path) -> Path:
    path = tmp_path / "heater.fmu"
    path.write_bytes(family_fmu("own_heater", 2).read_bytes())
    return path


def test_the_drafted_task_holds_what_the_heaters_equations_say(heater, tmp_path):
    draft = draft_task(heater, tmp_path / "heater_drafted.py")
    assert draft.tracked == "T"  # not P, which follows the command within a step
    assert draft.lines[0] == ("T follows a setpoint drawn at every reset in 5.00335..34.9933 degC, acted on through u "
                              "(0..1)")
    task = tmp_path / "heater_drafted.py"
    task.write_text(draft.text)
    namespace = runpy.run_path(str(task))  # as a task file is read
    assert namespace["GAIN"] == pytest.approx(30.0, rel=1e-3)
    assert namespace["TAU"] == pytest.approx(600.0, rel=0.05)  # a quarter of the 2% settling time
    assert namespace["config"]["time_step"] == 200.0 and namespace["config"]["max_episode_steps"] == 24


def test_the_drafted_baseline_holds_the_setpoint_at_the_episodes_end(heater, tmp_path):
    task = tmp_path / "heater_drafted.py"
    write_task(heater, task)
    read = read_task_file(task)
    env = FMUEnv(read.config)
    assert env.observation_names[2:] == ["setpoint:T", "error:T", "error_integral:T"]  # the columns the file reads
    for seed in range(3):
        observation, _ = env.reset(seed=seed)
        read.baseline.reset()
        for _ in range(read.config["max_episode_steps"]):
            observation, *_ = env.step(read.baseline.act(observation))
        temperature, setpoint = observation[0], observation[2]
        assert abs(temperature - setpoint) < 0.01 * 30.0  # within 1% of the range after two settling times
    env.close()
