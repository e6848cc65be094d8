"""Running a model with no agent (modelicagym/simulation.py, ``modelicagym simulate``): an SSP
system with a held input gives the trajectory of the co-simulation written out by hand over FMPy
(tests/system_cases.py); a nested SSP driven by a CSV table, written to CSV from the command line,
holds the values its gains give by hand."""

from __future__ import annotations

import csv
import sys

import numpy as np
import pytest
from bench_runs import run
from help_texts import SCREEN, help_text
from ssp_cases import bindings, component, connect, connectors, system, write_ssp_folder
from system_cases import OUTPUTS, SSP_PARAMETERS, hand_loop, write_ssp

import modelicagym
from modelicagym.cli import build_parser, main
from modelicagym.errors import ArgumentError
from modelicagym.fmu.errors import VariableError
from modelicagym.simulation import simulate


def test_a_system_runs_to_its_stop_time_as_the_hand_written_loop(family_fmu, tmp_path):
    motor, inertia = family_fmu("motor", 2), family_fmu("inertia", 3)
    ssp = write_ssp(tmp_path / "drive.ssp", motor, inertia)
    trajectory = modelicagym.simulate(ssp, 0.4, inputs={"motor.u": 0.3}, outputs=OUTPUTS, time_step=0.01)
    assert trajectory.dtype.names == ("time", *OUTPUTS) and len(trajectory) == 41
    np.testing.assert_allclose(trajectory["time"], np.arange(41) * 0.01, rtol=0, atol=1e-15)
    reference = hand_loop(motor, inertia, np.full(40, 0.3), "gauss-seidel", SSP_PARAMETERS)
    rows = np.array([list(row)[1:] for row in trajectory.tolist()])
    # from the first step on the same; at the start the motor's command already holds 0.3, where the
    # loop's holds 0 until its first step: tau_set = k (u - w / w_max) is 0.8 * 0.3 higher
    np.testing.assert_array_equal(rows[1:], reference[1:])
    tau_set = OUTPUTS.index("motor.tau_set")
    np.testing.assert_array_equal(np.delete(rows[0], tau_set), np.delete(reference[0], tau_set))
    assert rows[0][tau_set] == pytest.approx(reference[0][tau_set] + 0.8 * 0.3, rel=1e-12)


def test_every_scalar_variable_is_recorded_by_default(family_fmu):
    trajectory = simulate(family_fmu("gain", 2), 0.02, inputs={"u": 2.0}, parameters={"k": 3.0, "b": 0.5})
    assert trajectory.dtype.names == ("time", "u", "y", "k", "b")
    assert trajectory["y"].tolist() == [6.5, 6.5, 6.5]


def deep_gains(folder, gain):
    """u -> (gain of k 4, b 1) -> y doubled, inside sub-system ``sub``."""
    inner = system("sub", [component("g", "gain", bindings({"k": 4.0, "b": 1.0}))],
                   [connect(".u", "g.u"), connect("g.y", ".y", factor=2.0)], connectors(u="input", y="output"))
    top = system("top", [inner], [connect(".u", "sub.u"), connect("sub.y", ".y")], connectors(u="input", y="output"))
    return write_ssp_folder(folder, top, {"gain": gain})


def test_the_command_writes_a_table_driven_run_to_csv(family_fmu, tmp_path, capsys):
    folder = deep_gains(tmp_path / "gains", family_fmu("gain", 2))
    table = tmp_path / "ramp.csv"
    table.write_text("time,u\n0,0\n0.5,5\n1,5\n")
    out = tmp_path / "run.csv"
    assert main(["simulate", str(folder), "--stop-time", "0.8", "--time-step", "0.1", "--inputs", str(table),
                 "--outputs", "y", "sub.g.u", "sub.g.y", "--out", str(out)]) == 0
    assert f"9 rows from t=0 to t=0.8, 3 variables: {out}" in capsys.readouterr().out
    with out.open() as file:
        rows = list(csv.reader(file))
    assert rows[0] == ["time", "y", "sub.g.u", "sub.g.y"]
    for k, row in enumerate(rows[1:]):
        t = float(row[0])
        assert t == pytest.approx(0.1 * k, abs=1e-12)
        u = min(10.0 * max(t - 0.1, 0.0), 5.0) if k else 0.0  # each step holds the table's value at its start
        assert [float(v) for v in row[1:]] == pytest.approx([2 * (4 * u + 1), u, 4 * u + 1], rel=1e-12, abs=1e-12)


def test_the_command_draws_a_plot_on_request(family_fmu, tmp_path, capsys):
    pytest.importorskip("matplotlib")
    png = tmp_path / "run.png"
    assert main(["simulate", str(family_fmu("gain", 2)), "--stop-time", "0.1", "--input", "u=1",
                 "--out", str(tmp_path / "run.csv"), "--plot", str(png)]) == 0
    assert png.read_bytes().startswith(b"\x89PNG")
    assert f"plot of the variables over time: {png}" in capsys.readouterr().out


def test_bad_requests_are_refused_in_one_line(family_fmu, tmp_path, capsys):
    gain = family_fmu("gain", 2)
    with pytest.raises(VariableError, match="no input named 'uu'. Did you mean 'u'"):
        simulate(gain, 0.1, inputs={"uu": 1.0})
    table = tmp_path / "u.csv"
    table.write_text("time,u\n0,1\n")
    with pytest.raises(ArgumentError, match="u: given a value and a column of"):
        simulate(gain, 0.1, inputs={"u": 1.0}, table=table)
    with pytest.raises(ArgumentError, match="stop time -1.0 is before the start time 0.0"):
        simulate(gain, -1)
    assert main(["simulate", str(gain), "--input", "u=fast"]) == 1
    assert "--input expects NAME=VALUE with a number, got 'u=fast'" in capsys.readouterr().err


def test_a_shaft_speeds_up_as_its_equation_says(family_fmu):
    # J dw/dt = tau - d w from rest: w = tau / d (1 - exp(-d t / J)); the FMU's own 'time' is left out
    run = simulate(family_fmu("inertia", 3), 1.0, inputs={"tau": 0.1}, parameters={"J": 0.01, "d": 0.001})
    assert "time" not in run.dtype.names[1:] and {"w", "phi", "tau"} <= set(run.dtype.names)
    np.testing.assert_allclose(run["w"], 0.1 / 0.001 * (1 - np.exp(-0.001 * run["time"] / 0.01)), rtol=1e-6, atol=1e-9)


def test_a_table_column_that_drives_no_input_is_named(family_fmu, tmp_path):
    table = tmp_path / "load.csv"
    table.write_text("time,torque\n0,1\n")
    with pytest.raises(VariableError, match=r"load\.csv: column 'torque' drives no input: .*no input named 'torque'"):
        simulate(family_fmu("inertia", 3), 0.1, table=table)


def test_an_fmu_that_fails_validation_runs_with_no_validate(family_fmu, tmp_path, capsys):
    # OMSimulator's embrace: its ECS_SW FMU has an Enumeration of continuous variability
    from fmu_family import rewrite

    variable = '<ScalarVariable name="u"'
    broken = rewrite(family_fmu("gain", 2), tmp_path / "Gain.fmu",
                     edit_description=lambda text: text.replace(variable, variable + ' bogus="1"'))
    command = ["simulate", str(broken), "--stop-time", "0.1", "--time-step", "0.1", "--input", "u=2",
               "--out", str(tmp_path / "run.csv")]
    assert main(command) == 1
    [line] = capsys.readouterr().err.strip().splitlines()
    assert "fails validation (variables concerned: u)" in line and line.endswith("; to go on anyway: add --no-validate")
    assert main([*command, "--no-validate"]) == 0
    assert (tmp_path / "run.csv").read_text().splitlines()[-1].startswith("0.1,")


def test_the_help_fits_a_screen(monkeypatch):
    text = help_text(build_parser(), "simulate", monkeypatch=monkeypatch)
    assert len(text.splitlines()) <= SCREEN and "--inputs TABLE.csv" in text, text


#: run in a fresh process: parse another command, import the package, print the simulation modules imported
IMPORTED = """
import sys
from modelicagym.cli import build_parser
build_parser().parse_args(["info", "any.fmu"])
import modelicagym
print(sorted(m for m in sys.modules if m.startswith("modelicagym.simulation")))
"""


@pytest.mark.processes
def test_neither_another_command_nor_the_package_imports_it():
    imported = run([sys.executable, "-c", IMPORTED], timeout=120)
    assert imported.returncode == 0 and imported.stdout.splitlines()[-1] == "[]", imported.stderr
