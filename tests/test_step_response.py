"""``modelicagym try TARGET --step INPUT``: each input stepped from its start value, the outputs'
responses and settling times, and a time step and an episode length suggested from them; on the
cooling consumer (``tests/fmus/consumer``: a valve lagging its command by 10 s, a room of time
constants from minutes to hours) and the heater (``modelicagym/samples/heater``: one lag of 600 s)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from extras import requires

from modelicagym.cli import main
from modelicagym.errors import ConfigError
from modelicagym.fmu.errors import VariableError
from modelicagym.samples.writer import SAMPLES_DIR
from modelicagym.step_response import step_response, suggest_timing

pytestmark = pytest.mark.timeout(300)

CONDITIONS = {"p_supply": 3e5, "p_return": 1.2e5, "T_supply": 279.15, "T_amb": 303.15, "Q_gain": 2000.0}
#: a first-order lag enters a 2% band around its end after ln(50) time constants
LAG_SETTLES = math.log(50.0)


def consumer(path) -> dict:
    return {"fmu": path, "inputs": ["valve"], "outputs": ["T_room", "T_return", "m_flow", "Q_flow"],
            "fixed_inputs": CONDITIONS, "action_bounds": {"valve": (0.0, 1.0)}, "time_step": 0.002,
            "max_episode_steps": 500}  # the export's default experiment: 1 s, far shorter than the model responds


def test_a_step_finds_each_output_s_settling_time(family_fmu, fmi_version):
    config = consumer(family_fmu("consumer", fmi_version))
    valve = step_response(config, "valve")
    assert (valve.start_value, valve.step_value) == (0.0, 1.0)  # from its start to the far end of its range
    outputs = {o.name: o for o in valve.outputs}
    flow = outputs["m_flow"]
    assert flow.change == pytest.approx(2e-3 * math.sqrt(1.8e5), rel=1e-6)
    assert flow.settling_time == pytest.approx(LAG_SETTLES * 10.0, rel=0.05)  # the valve's 10 s lag
    assert outputs["T_room"].responds and outputs["T_room"].settling_time > 10 * flow.settling_time
    assert valve.horizon >= 2 * outputs["T_room"].settling_time  # grown from the 1 s episode until it settled

    outside = step_response(config, "T_amb", 313.15)  # valve closed: the room alone, C / G = 2500 s
    outputs = {o.name: o for o in outside.outputs}
    assert outputs["T_room"].change == pytest.approx(10.0, rel=0.01)
    assert outputs["T_room"].settling_time == pytest.approx(LAG_SETTLES * 2500.0, rel=0.05)
    assert not outputs["m_flow"].responds and not outputs["Q_flow"].responds

    line = suggest_timing([valve, outside])
    assert line.startswith("suggested: time_step 2 s (a tenth of the fastest settling, m_flow's ")


def test_a_task_file_s_heater_suggests_its_timing(family_fmu, tmp_path, capsys):
    (tmp_path / "heater.fmu").write_bytes(family_fmu("own_heater", 2).read_bytes())
    task = tmp_path / "heater_task.py"
    task.write_text((SAMPLES_DIR / "heater" / "heater_task.py").read_text())
    status = main(["try", str(task), "--step", "u", "--out", str(tmp_path / "step.png")])
    lines = capsys.readouterr().out.splitlines()
    assert status == 0
    assert lines[0] == "step of u from 0 to 1, 36000 s:"  # the task's hour was too short: grown tenfold
    temperature = lines[1]
    settling = float(temperature.rsplit(" in ", 1)[1].removesuffix(" s"))
    assert temperature.startswith("  T [degC]: +30, settles (2%) in ") and settling == pytest.approx(
        LAG_SETTLES * 600.0, rel=0.05)  # 3 kW over 100 W/K, the room's 600 s
    assert lines[2] == "  P [W]: +3000, at once (within the first step: no lag)"
    assert lines[3].startswith("suggested: time_step 200 s (a tenth of the fastest settling, T's ")
    assert (tmp_path / "step.png").stat().st_size > 0


@requires("plots")
def test_the_command_says_which_range_it_assumed_for_the_step(family_fmu, tmp_path, capsys):
    status = main(["try", str(family_fmu("consumer", 2)), "--step", "valve", "--out", str(tmp_path / "s.png")])
    lines = capsys.readouterr().out.splitlines()
    assert status == 0 and lines[0] == "step of valve from 0 to 1, 100000 s:"
    assert lines[-1] == ("stepped to the end of (-1.0, 1.0), assumed as nothing in the FMU says the range: valve "
                         "(--step NAME=VALUE steps to a value)")


@pytest.mark.parametrize("step, error, message", [
    ("T_ambient", VariableError, "T_amb"),
    ("UA", ConfigError, "--step UA: not an input or a tunable parameter \\(causality 'parameter', variability 'fixed'\\)"),
    ("valve=open", ConfigError, "--step expects INPUT or INPUT=VALUE \\(a number\\), got 'valve=open'"),
])
def test_a_bad_step_is_one_line(family_fmu, tmp_path, capsys, step, error, message):
    status = main(["try", str(family_fmu("consumer", 2)), "--step", step, "--out", str(tmp_path / "s.png")])
    _, err = capsys.readouterr()
    assert status == 1 and err.startswith("error: ") and err.count("\n") == 1
    with pytest.raises(error, match=message):
        main(["try", str(family_fmu("consumer", 2)), "--step", step, "--debug"])
    assert not (tmp_path / "s.png").exists()


def inertia(path, **options) -> dict:
    """The shaft (``tests/fmus/inertia``): its speed w lags the torque by J/d = 10 s, its angle phi
    integrates w, its acceleration a dies out as w settles."""
    return {"fmu": path, "inputs": ["tau"], "outputs": ["w", "phi", "a"], "action_bounds": {"tau": (-1.0, 1.0)},
            "time_step": 0.5, "max_episode_steps": 20, **options}


@pytest.mark.parametrize("time_step", [0.5, 50.0])  # an episode of 10 s, then one of 10,000 s
def test_an_integrating_output_is_said_so_and_stretches_nothing(family_fmu, time_step):
    response = step_response(inertia(str(family_fmu("inertia", 3)), time_step=time_step), "tau")
    outputs = {o.name: o for o in response.outputs}
    assert outputs["w"].behaviour == "settles" and outputs["w"].change == pytest.approx(1000.0, rel=1e-3)
    assert outputs["w"].settling_time == pytest.approx(LAG_SETTLES * 10.0, rel=0.05)  # not "at once" on a coarse grid
    assert outputs["phi"].behaviour == "integrates" and outputs["phi"].settling_time is None
    assert outputs["phi"].rate == pytest.approx(1000.0, rel=0.01)  # rad/s: phi ramps at w's final speed
    # grown until w settled (100 s), then one tenfold run more that checks phi's ramp rate holds: no further
    assert response.horizon == 10 * max(100.0, 20 * time_step)
    line = suggest_timing([response])
    assert line.startswith("suggested: time_step 2 s (a tenth of the fastest settling, ")
    assert "phi" not in line


def test_an_oscillating_output_is_said_so(family_fmu):
    """A load torque swinging as a sine (a schedule would do; here the held run keeps the shaft at
    rest and the torque steps): the speed settles, so this checks the classifier on a sine directly."""
    from modelicagym.step_response import _behaviour

    times = np.linspace(0.0, 100.0, 401)
    assert _behaviour(times, np.sin(times), np.zeros_like(times))[0] == "oscillates"
    assert _behaviour(times, np.exp(-times / 5.0) * np.sin(times), np.zeros_like(times))[0] == "settles"
    assert _behaviour(times, 3.0 * times, np.zeros_like(times)) == ("integrates", None, pytest.approx(3.0))
    assert _behaviour(times, np.zeros_like(times), np.ones_like(times))[0] == "does not move"


@requires("plots")
def test_each_input_gets_its_own_plot(family_fmu, tmp_path, capsys, monkeypatch):
    path = family_fmu("inertia", 3)
    task = tmp_path / "shaft_task.py"
    task.write_text(f"config = {inertia(str(path))!r}\nconfig['fixed_inputs'] = {{'tau_load': 0.0}}\n")
    monkeypatch.chdir(tmp_path)
    assert main(["try", "shaft_task.py", "--step", "tau", "--step", "tau_load=-0.5"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert "  phi [rad]: integrates, ramps at +1000 rad/s (no settling time)" in lines
    assert "  phi [rad]: integrates, ramps at -500 rad/s (no settling time)" in lines
    assert lines[-2:] == ["plot of the response to tau over time: shaft_task-step-tau.png",
                          "plot of the response to tau_load over time: shaft_task-step-tau_load.png"]
    assert (tmp_path / "shaft_task-step-tau.png").stat().st_size > 0
