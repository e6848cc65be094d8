"""``modelicagym sample NAME`` / `modelicagym.samples.write_sample`: each sample, written into an empty
folder, runs as written (its task file loaded as ``modelicagym try`` and ``train_own_fmu.py`` load it);
the drive's task draws a setpoint and a load per episode, and its PI baseline tracks them; the system's
SSP is the system its task file connects; and nothing a user has is overwritten unasked."""

from __future__ import annotations

import fnmatch
import zipfile
from pathlib import Path

import numpy as np
import pytest

from modelicagym import FMUEnv
from modelicagym.cli import main
from modelicagym.errors import ArgumentError
from modelicagym.fmu.build import build_source_fmu
from modelicagym.samples import SAMPLES, SampleExistsError, write_sample
from modelicagym.samples.writer import SAMPLES_DIR
from modelicagym.system.ssp import read_ssp
from modelicagym.task import load_task, read_task_file

pytestmark = pytest.mark.timeout(300)

WRITES = {
    "heater": ["heater.fmu", "heater_task.py"],
    "drive": ["drive.fmu", "drive_task.py"],
    "system": ["motor.fmu", "inertia.fmu", "load.csv", "drive.ssp", "system_task.py"],
    "loop": ["controller.fmu", "plant.fmu", "loop_task.py"],
}


@pytest.mark.parametrize("name", list(WRITES))
def test_a_sample_runs_as_written_from_an_empty_folder(tmp_path, name):
    written = write_sample(name, tmp_path)
    assert written == [tmp_path / file for file in WRITES[name]] and sorted(tmp_path.iterdir()) == sorted(written)
    config = load_task(tmp_path / f"{name}_task.py")
    with FMUEnv(config) as env:
        observation, _ = env.reset(seed=0)
        assert env.observation_space.contains(observation)
        env.action_space.seed(0)
        for _ in range(5):
            observation, reward, terminated, truncated, _ = env.step(env.action_space.sample())
            assert np.all(np.isfinite(observation)) and np.isfinite(reward) and not terminated and not truncated


def test_the_loop_sample_runs_its_loop_with_a_delay_it_names(tmp_path):
    write_sample("loop", tmp_path)
    with FMUEnv(load_task(tmp_path / "loop_task.py")) as env:
        assert env.metadata["loops"] == ["loop controller.y -> plant.u, plant.y -> controller.u: gauss-seidel reads "
                                         "plant.y -> controller.u from the previous step (controller steps first in "
                                         "the loop)"]
        env.reset(seed=0)
        for _ in range(200):
            observation, *_ = env.step(np.array([0.5]))
    assert observation[1] == pytest.approx(0.5, abs=1e-3)  # the loop's plant output settles on the setpoint


def test_the_drive_s_task_draws_a_setpoint_and_a_load_per_episode_and_its_pi_tracks_it(tmp_path):
    write_sample("drive", tmp_path)
    task = read_task_file(tmp_path / "drive_task.py")
    low, high = -2.0, 2.0  # M_A's range, as the FMU declares it
    env = FMUEnv(task.config)
    try:
        assert env.action_space.low.tolist() == [low] and env.action_space.high.tolist() == [high]
        assert env.observation_names == ["wA", "wB", "setpoint:wA", "error:wA", "error_integral:wA", "M_B"]
        assert env.observation_space.low[2:].tolist() == [50.0, -np.inf, -np.inf, -1.0]
        assert env.observation_space.high[2:].tolist() == [200.0, np.inf, np.inf, 0.0]
        draws = set()
        for seed in range(4):
            observation, _ = env.reset(seed=seed)
            setpoint, load = env.episode_setpoints["wA"], env.episode_parameters["M_B"]
            assert 50.0 <= setpoint <= 200.0 and -1.0 <= load <= 0.0
            assert observation.tolist() == [0.0, 0.0, setpoint, -setpoint, 0.0, load]
            draws.add((setpoint, load))
            task.baseline.reset()
            speeds, torques, rewards = [], [], []
            for _ in range(task.config["max_episode_steps"]):
                torque = task.baseline.act(observation)
                observation, reward, terminated, truncated, _ = env.step(torque)
                speeds.append(observation[0])
                torques.append(torque[0])
                rewards.append(reward)
            assert truncated and not terminated
            assert rewards == pytest.approx([-abs(setpoint - w) / 10.0 for w in speeds])
            # full torque while far below the setpoint, then the speed held at it and the load balanced
            assert torques[0] == high
            reach = setpoint * 0.015 / (high + load)  # the whole drive's inertia at full torque less the load
            settled = np.array(speeds[int(reach / 0.25) + 6:])
            assert np.abs(settled - setpoint).max() < 0.5, (seed, setpoint, load, settled)
            assert torques[-1] == pytest.approx(-load, abs=0.01)  # found by the integral: the PI does not see it
        assert len(draws) == 4  # drawn again at every reset
    finally:
        env.close()


def test_the_drive_steps_alike_in_fmi_2_and_3_co_simulation_and_model_exchange():
    config = {**load_task(SAMPLES_DIR / "drive" / "drive_task.py"), "fixed_inputs": {"M_B": -0.5}}
    torques = np.random.default_rng(0).uniform(-2.0, 2.0, (30, 1))
    runs = {}
    for version in (2, 3):
        for mode in ("cs", "me"):
            with FMUEnv({**config, "fmu": str(build_source_fmu(SAMPLES_DIR / "drive", version)), "mode": mode}) as env:
                runs[version, mode] = np.array([env.reset(seed=0)[0]] + [env.step(u)[0] for u in torques])
    np.testing.assert_array_equal(runs[2, "cs"], runs[3, "cs"])
    np.testing.assert_array_equal(runs[2, "me"], runs[3, "me"])
    np.testing.assert_allclose(runs[2, "cs"], runs[2, "me"], rtol=1e-4, atol=1e-3)
    assert np.abs(runs[2, "cs"]).max() > 10.0  # it turned


def test_the_system_s_ssp_is_the_system_its_task_file_connects(tmp_path):
    write_sample("system", tmp_path)
    config = load_task(tmp_path / "system_task.py")
    spec = read_ssp(tmp_path / "drive.ssp")
    assert [(c.source, c.target) for c in spec.connections] == [tuple(pair) for pair in config["connections"]]
    assert list(spec.components) == list(config["fmus"])
    assert spec.components["motor"]["mode"] == "cs" and spec.components["plant"]["mode"] == config["fmus"]["plant"]["mode"]
    assert spec.parameters == {"plant.J": config["parameters"]["plant.J"]}
    with zipfile.ZipFile(tmp_path / "drive.ssp") as ssp:
        for name in ("motor.fmu", "inertia.fmu", "load.csv"):
            assert ssp.read(f"resources/{name}") == (tmp_path / name).read_bytes()

    # the same steps, from the archive and from the task file's components (the table started at 0)
    options = {key: config[key] for key in ("inputs", "outputs", "time_step")}
    parameters = {**config["parameters"], "load.time_offset": 0.0}
    actions = np.random.default_rng(0).uniform(-1.0, 1.0, (20, 1))
    runs = []
    for env in (FMUEnv(fmu=str(tmp_path / "drive.ssp"), **options),
                FMUEnv({**config, "parameters": parameters})):
        with env:
            observations = [env.reset(seed=0)[0]] + [env.step(action)[0] for action in actions]
        runs.append(np.array(observations))
    np.testing.assert_array_equal(runs[0], runs[1])
    assert runs[0][-1, 0] != 0.0  # the shaft turned


def test_writing_a_sample_again_is_harmless_and_a_user_s_file_is_kept(tmp_path):
    first = {path: path.read_bytes() for path in write_sample("system", tmp_path)}
    assert write_sample("system", tmp_path) == list(first)  # the same files, byte for byte: nothing refused
    (tmp_path / "load.csv").write_text("time,torque\n0,1\n")  # the user's own table
    (tmp_path / "motor.fmu").unlink()
    with pytest.raises(SampleExistsError, match=r"load\.csv: already there, with other content.*--force"):
        write_sample("system", tmp_path)
    assert (tmp_path / "load.csv").read_text() == "time,torque\n0,1\n" and not (tmp_path / "motor.fmu").exists()
    assert write_sample("system", tmp_path, force=True) == list(first)
    assert {path: path.read_bytes() for path in first} == first


def test_bad_names_and_folders_are_refused_in_one_line(tmp_path):
    with pytest.raises(ArgumentError, match=r"no sample named 'heatr'\. Did you mean 'heater'\? Samples: heater, "
                                            r"drive, system, loop"):
        write_sample("heatr", tmp_path)
    (tmp_path / "a_file").write_text("")
    with pytest.raises(ArgumentError, match="a_file: not a folder"):
        write_sample("heater", tmp_path / "a_file")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a_file"]


def test_the_command_lists_writes_and_says_what_to_try_next(tmp_path, capsys, monkeypatch):
    assert main(["sample"]) == 0
    listed = capsys.readouterr().out.splitlines()
    assert [line.split()[0] for line in listed] == list(SAMPLES) == list(WRITES)
    assert all(line.endswith(", ".join(WRITES[line.split()[0]])) for line in listed)
    assert main(["sample", "--list"]) == 0 and capsys.readouterr().out.splitlines() == listed

    monkeypatch.chdir(tmp_path)
    assert main(["sample", "heater"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[:3] == ["wrote heater.fmu, heater_task.py", "try next:", "  modelicagym info heater.fmu"]
    assert "  modelicagym try heater_task.py" in out and "  modelicagym bench fmu heater.fmu" in out
    assert main(["sample", "drive", "--out", "sub"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[:3] == ["wrote sub/drive.fmu, sub/drive_task.py", "try next:", "  cd sub"]

    (tmp_path / "heater_task.py").write_text("config = {}\n")
    assert main(["sample", "heater"]) == 1
    assert capsys.readouterr().err == ("error: heater_task.py: already there, with other content; the sample 'heater' "
                                       "leaves it alone (move it away, write the sample elsewhere with --out DIR, or "
                                       "replace it with --force)\n")
    assert main(["sample", "heater", "--force"]) == 0
    assert (tmp_path / "heater_task.py").read_bytes() == (SAMPLES_DIR / "heater" / "heater_task.py").read_bytes()
    assert main(["sample", "motor"]) == 1 and "no sample named 'motor'" in capsys.readouterr().err


def test_the_package_carries_every_file_of_the_samples():
    tomllib = pytest.importorskip("tomllib")
    pyproject = tomllib.loads((Path(__file__).resolve().parents[1] / "pyproject.toml").read_text())
    patterns = pyproject["tool"]["setuptools"]["package-data"]["modelicagym.samples"]
    files = [p.relative_to(SAMPLES_DIR).as_posix() for p in SAMPLES_DIR.rglob("*")
             if p.is_file() and p.parent != SAMPLES_DIR and "__pycache__" not in p.parts]
    assert len(files) >= 19
    assert [f for f in files if not any(fnmatch.fnmatch(f, pattern) for pattern in patterns)] == []
