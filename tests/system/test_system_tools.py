"""`modelicagym info` and `modelicagym try` on an SSP system, as on one FMU: info's config works as
pasted (once the range of a load nothing declares is given), try plots an episode."""

from __future__ import annotations

import textwrap

import pytest
from extras import requires
from gymnasium.utils.env_checker import check_env
from system_cases import write_ssp

from modelicagym import cli

CONFIG_START = "    from modelicagym import FMUEnv"


@pytest.fixture
def ssp(family_fmu, tmp_path):
    return write_ssp(tmp_path / "drive.ssp", family_fmu("motor", 2), family_fmu("inertia", 3))


def test_info_describes_a_system_and_its_config_works_as_pasted(ssp, capsys):
    assert cli.main(["info", str(ssp)]) == 0
    out = capsys.readouterr().out
    assert out.startswith("drive.ssp: system 'drive' of 2 components")
    assert "  motor: motor.fmu, model 'Motor', FMI 2.0, co-simulation; saved states: yes" in out
    assert "  plant.w -> motor.w  (converted: x 9.54929658551 + 0)" in out
    assert "stepping order (Gauss-Seidel): motor, plant" in out
    code = textwrap.dedent(out[out.index(CONFIG_START):])
    assert "'plant.J': 0.02" in code  # the SSP's parameter set, not the FMU's start value
    code = code.replace("'plant.tau_load': None", "'plant.tau_load': (-0.1, 0.1)")
    namespace: dict = {}
    exec(code, namespace)
    env = namespace["env"]
    check_env(env.unwrapped, skip_render_check=True)
    env.close()


@requires("plots")
def test_try_plots_an_episode_of_a_system(ssp, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["try", str(ssp), "--steps", "20"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == "drive: 20 steps of random actions (seed 0), t = 0 s to 0.2 s"
    assert (tmp_path / "drive-try.png").is_file()


def test_a_task_files_system_paths_are_relative_to_its_folder(family_fmu, tmp_path):
    from modelicagym.task import load_task

    folder = tmp_path / "task"
    folder.mkdir()
    (folder / "load.csv").write_text("time,torque\n0,0\n1,0.1\n")
    motor = family_fmu("motor", 2)
    (folder / "task.py").write_text(f"config = {{'fmus': {{'motor': {str(motor)!r}, 'load': 'load.csv', "
                                    f"'plant': {{'fmu': 'plant.fmu', 'mode': 'me'}}}}}}\n")
    fmus = load_task(folder / "task.py")["fmus"]
    assert fmus == {"motor": str(motor), "load": str(folder / "load.csv"),
                    "plant": {"fmu": str(folder / "plant.fmu"), "mode": "me"}}


def test_bench_compares_a_systems_step_with_its_fmus_stepped_alone(ssp):
    from modelicagym.bench.own_fmu import single_loop
    from modelicagym.bench.system_alone import alone_configs, measure, report_lines
    from modelicagym.system import open_system

    config = {"fmu": str(ssp), "inputs": ["motor.u"], "outputs": ["plant.w"], "time_step": 0.01, "substeps": 2,
              "max_episode_steps": 50}
    system = open_system(ssp)
    configs = alone_configs(config, system)
    assert configs["motor"]["inputs"] == ["w", "u"] and configs["motor"]["parameters"] == {"k": 0.8}
    assert configs["plant"]["action_bounds"] == {"tau": (0.0, 0.0)} and configs["plant"]["time_step"] == 0.005
    result = measure(config, system, repeats=1, seconds=0.02, loop=single_loop, progress=lambda what: None)
    assert set(result["us_per_step"]) == {"system", "motor", "plant"} and result["substeps"] == 2
    assert set(result["step_paths"].values()) == {"native"}
    lines = report_lines(result)
    assert lines[-2].startswith("  sum of the FMUs alone x 2 substeps: ") and lines[-1].startswith("  the system: ")
