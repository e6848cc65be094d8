"""``modelicagym try MY.fmu`` (or a task file, or a JSON config): the config run for an episode of
seeded random actions, a PNG of actions and observations over time, and one line per fact (every
variable left out of the plot, every action range assumed); failures are one line."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from extras import imported, requires

from modelicagym.cli import main
from modelicagym.env.strip_chart import MAX_PANELS, Series, panels_of
from modelicagym.try_fmu import TryResult

pytestmark = pytest.mark.timeout(300)


def read_png(path: Path) -> np.ndarray:
    return imported("matplotlib.image").imread(path)


def run_try(capsys: pytest.CaptureFixture, *args: str) -> tuple[int, list[str], str]:
    status = main(["try", *args])
    out, err = capsys.readouterr()
    return status, out.splitlines(), err


@requires("plots")
@pytest.mark.parametrize("fmu", ["probe-fmi2", "probe-fmi3", "cartpole"])
def test_try_plots_an_episode_of_random_actions(fmu, family_fmu, cartpole_fmu, tmp_path, capsys, monkeypatch):
    path = cartpole_fmu(2) if fmu == "cartpole" else family_fmu("probe", int(fmu[-1]))
    monkeypatch.chdir(tmp_path)
    status, lines, _ = run_try(capsys, str(path), "--steps", "30")
    plot = tmp_path / f"{path.stem}-try.png"  # the default --out
    assert status == 0
    end = "1.5 s" if fmu == "cartpole" else "3 s"  # time steps of 0.05 s and 0.1 s
    assert lines[0].endswith(f"30 steps of random actions (seed 0), t = 0 s to {end}")
    assert lines[1] == "the episode ended: truncated after 30 steps (max_episode_steps)"
    assert lines[2].startswith("plot of ") and lines[2].endswith(f"over time: {plot.name}")
    image = read_png(plot)
    assert image.ndim == 3 and image.shape[0] > 100 and image.shape[1] > 100
    assert image.std() > 0.05  # lines and labels, not a blank page


@requires("plots")
def test_the_same_seed_gives_the_same_plot_and_another_seed_another(family_fmu, tmp_path, capsys):
    fmu = str(family_fmu("probe", 2))
    for name, seed in (("a", "1"), ("b", "1"), ("c", "2")):
        assert run_try(capsys, fmu, "--steps", "20", "--seed", seed, "--out", str(tmp_path / f"{name}.png"))[0] == 0
    a, b, c = (read_png(tmp_path / f"{name}.png") for name in "abc")
    np.testing.assert_array_equal(a, b)
    assert a.shape == c.shape and not np.array_equal(a, c)


@requires("plots")
def test_config_file_and_settings_change_the_suggested_config(family_fmu, tmp_path, capsys):
    config = tmp_path / "probe.json"
    config.write_text(json.dumps({"max_episode_steps": 12, "inputs": ["force"], "outputs": ["position", "speed"]}))
    status, lines, _ = run_try(capsys, str(family_fmu("probe", 2)), "--config", str(config), "--set", "time_step=0.5",
                               "--set", "parameters.gain=2.0", "--out", str(tmp_path / "p.png"))
    assert status == 0
    assert lines[0].endswith("12 steps of random actions (seed 0), t = 0 s to 6 s")
    assert lines[2].startswith("plot of 1 action and 2 observations over time: ")


@requires("plots")
def test_an_fmu_error_is_reported_and_the_episode_still_plotted(family_fmu, tmp_path, capsys):
    out = tmp_path / "fault.png"
    status, lines, _ = run_try(capsys, str(family_fmu("probe", 2)), "--set", "parameters.fault=2",
                               "--set", "parameters.fault_after=5", "--out", str(out))
    assert status == 1
    assert lines[1] == "the episode ended: truncated: the FMU reported an error"
    assert lines[2].startswith("FMU error at t = 0.5 s: ") and "injected fault" in lines[2]
    assert read_png(out).ndim == 3


@requires("plots")
def test_a_model_that_ends_the_simulation_is_said_so(family_fmu, tmp_path, capsys):
    status, lines, _ = run_try(capsys, str(family_fmu("probe", 2)), "--set", "parameters.fault=1",
                               "--set", "parameters.fault_after=5", "--out", str(tmp_path / "end.png"))
    assert status == 0
    assert lines[1] == "the episode ended: terminated: the FMU ended the simulation"


@pytest.mark.parametrize(
    "args, message",
    [
        (["{missing}"], "error: FMU not found: "),
        (["{probe}", "--set", "steps"], "error: --set expects key=value (e.g. max_episode_steps=200), got 'steps'"),
        (["{probe}", "--set", "max_episode_step=10"], "error: unknown FMUEnv config key 'max_episode_step'"),
        (["{probe}", "--set", "max_episode_steps=null"], "error: the config sets no max_episode_steps: give the "
                                                          "number of steps to run (--steps N)"),
        (["{probe}", "--config", "{not_json}"], "error: {not_json}: not JSON"),
    ],
    ids=["missing FMU", "setting without =", "unknown key", "no episode length", "config not JSON"],
)
def test_bad_input_is_one_line_and_status_1(args, message, family_fmu, tmp_path, capsys):
    (tmp_path / "config.json").write_text("{inputs: [u]")
    names = {"missing": str(tmp_path / "missing.fmu"), "probe": str(family_fmu("probe", 2)),
             "not_json": str(tmp_path / "config.json")}
    status, lines, err = run_try(capsys, *(arg.format(**names) for arg in args), "--out", str(tmp_path / "x.png"))
    assert status == 1 and lines == []
    assert len(err.strip().splitlines()) == 1 and err.startswith(message.format(**names))
    assert not (tmp_path / "x.png").exists()


@pytest.mark.processes
def test_without_matplotlib_try_says_which_extra_to_install(family_fmu, tmp_path):
    code = textwrap.dedent(f"""
        import sys
        sys.modules["matplotlib"] = None  # as if the plots extra were not installed
        from modelicagym.cli import main
        sys.exit(main(["try", {str(family_fmu("probe", 2))!r}, "--out", {str(tmp_path / "x.png")!r}]))
    """)
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert result.returncode == 1
    assert result.stdout == ""
    assert result.stderr.strip() == ("error: the strip chart (render_mode='rgb_array', modelicagym try) needs "
                                     "matplotlib: pip install 'modelicagym[plots]'")
    assert not (tmp_path / "x.png").exists()


CONSUMER_TASK = """
import numpy as np

config = {
    'fmu': 'consumer.fmu',
    'inputs': ['valve'],
    'outputs': ['T_room', 'T_return', 'm_flow', 'Q_flow'],
    'fixed_inputs': {'p_supply': 3e5, 'p_return': 1.2e5, 'T_supply': 279.15, 'Q_gain': 2000.0,
                     'T_amb': lambda rng: rng.uniform(293.15, 308.15)},
    'action_bounds': {'valve': (0.0, 1.0)},
    'time_step': 30.0,
    'max_episode_steps': 20,
}


def reward(env, observation, action, terminated):
    return -abs(observation[0] - 295.15)


config['reward'] = reward
"""


@requires("plots")
def test_try_runs_a_task_file_with_its_fmu_beside_it(family_fmu, tmp_path, capsys, monkeypatch):
    """A task file (Python, with lambdas and a reward), run from another folder: its fmu path is
    relative to the task file's folder."""
    task_folder = tmp_path / "task"
    task_folder.mkdir()
    (task_folder / "consumer.fmu").write_bytes(family_fmu("consumer", 2).read_bytes())
    (task_folder / "consumer_task.py").write_text(CONSUMER_TASK)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    status, lines, _ = run_try(capsys, "../task/consumer_task.py")
    assert status == 0
    assert lines[0] == "CoolingConsumer: 20 steps of random actions (seed 0), t = 0 s to 600 s"
    assert lines[2] == "plot of 1 action and 4 observations over time: consumer_task-try.png"
    assert len(lines) == 3  # no range assumed, nothing left out of the plot
    assert read_png(elsewhere / "consumer_task-try.png").ndim == 3


@requires("plots")
def test_try_runs_a_json_config_and_names_the_ranges_it_assumed(family_fmu, tmp_path, capsys):
    (tmp_path / "consumer.fmu").write_bytes(family_fmu("consumer", 3).read_bytes())
    config = tmp_path / "consumer.json"
    config.write_text(json.dumps({"fmu": "consumer.fmu", "inputs": ["valve", "Q_gain"], "outputs": ["T_room"],
                                  "action_bounds": {"valve": None, "Q_gain": [0, 5000]}, "time_step": 10.0,
                                  "max_episode_steps": 5}))
    status, lines, _ = run_try(capsys, str(config), "--out", str(tmp_path / "c.png"))
    assert status == 0
    assert lines[-1] == ("tried in (-1.0, 1.0), as nothing in the FMU says its range: valve; give action_bounds "
                         "before training (--set action_bounds.valve='[low, high]' here, or in the task file)")
    status, lines, _ = run_try(capsys, str(config), "--set", "action_bounds.valve=[0, 1]",
                               "--set", "fixed_inputs.T_amb=300", "--out", str(tmp_path / "c.png"))
    assert status == 0 and len(lines) == 3


@requires("plots")
def test_try_on_an_fmu_whose_command_has_no_range_says_what_it_assumed(family_fmu, tmp_path, capsys):
    status, lines, _ = run_try(capsys, str(family_fmu("consumer", 2)), "--steps", "5", "--out", str(tmp_path / "c.png"))
    assert status == 0
    assert lines[-1].startswith("tried in (-1.0, 1.0), as nothing in the FMU says its range: valve;")


def test_a_task_file_whose_fmu_sits_in_the_current_folder_is_told_where_paths_start(family_fmu, tmp_path, capsys,
                                                                                    monkeypatch):
    (tmp_path / "consumer.fmu").write_bytes(family_fmu("consumer", 2).read_bytes())
    (tmp_path / "tasks").mkdir()
    (tmp_path / "tasks" / "consumer_task.py").write_text(CONSUMER_TASK)
    monkeypatch.chdir(tmp_path)
    status, lines, err = run_try(capsys, "tasks/consumer_task.py")
    assert status == 1 and lines == []
    assert err.strip() == ("error: tasks/consumer_task.py: its fmu 'consumer.fmu' is relative to the file's folder, "
                           "and there is no tasks/consumer.fmu (it is in the current folder: write '../consumer.fmu' "
                           "or an absolute path)")


def test_the_result_names_every_variable_left_out_of_the_plot(tmp_path):
    series = [Series(f"y{k}", f"unit{k}", "observation", "float") for k in range(13)]
    panels, left_out = panels_of(series)
    assert len(panels) == MAX_PANELS and [series[i].name for i in left_out] == ["y10", "y11", "y12"]
    result = TryResult("M", 0, 1, 0.0, 1.0, "truncated", tmp_path / "x.png", 0, 13,
                       left_out=tuple(series[i].name for i in left_out))
    assert result.lines()[-1] == ("not drawn (the chart holds 10 panels): y10, y11, y12; choose what to see with "
                                  "--set outputs='[...]' or --set inputs='[...]'")


@requires("plots")
def test_try_runs_the_task_files_baseline_and_draws_the_setpoint_and_the_load(tmp_path, capsys, monkeypatch):
    from modelicagym import FMUEnv
    from modelicagym.samples import write_sample
    from modelicagym.task import read_task_file

    write_sample("drive", tmp_path)
    monkeypatch.chdir(tmp_path)
    status, lines, _ = run_try(capsys, "drive_task.py", "--policy", "baseline", "--out", "pi.png")
    assert status == 0 and lines[0] == "TwoMassDrive: 40 steps of the task's baseline (seed 0), t = 0 s to 10 s"
    task = read_task_file("drive_task.py")
    env = FMUEnv(task.config, render_mode="rgb_array")
    observation, _ = env.reset(seed=0)
    task.baseline.reset()
    for _ in range(40):
        observation, *_ = env.step(task.baseline.act(observation))
    chart = env.strip_chart
    names = [s.name for s in chart.series]
    assert names == ["M_A", "wA", "wB", "setpoint of wA", "M_B"]
    assert chart.values[-1, 3] == env.episode_setpoints["wA"] == observation[2]
    assert abs(observation[0] - observation[2]) < 1.0  # the PI reached its setpoint
    assert chart.values[0, 4] == env.episode_parameters["M_B"]
    env.close()
    assert lines[2] == "plot of 1 action and 2 observations over time: pi.png"
    status, lines, _ = run_try(capsys, "drive_task.py")  # random actions: another picture
    assert lines[0].startswith("TwoMassDrive: 40 steps of random actions")
    assert not np.array_equal(read_png(tmp_path / "pi.png"), read_png(tmp_path / "drive_task-try.png"))


def test_try_policy_baseline_needs_a_baseline(tmp_path, capsys, monkeypatch):
    from modelicagym.samples import write_sample

    write_sample("drive", tmp_path)
    (tmp_path / "task.py").write_text((tmp_path / "drive_task.py").read_text().split("class baseline")[0])
    monkeypatch.chdir(tmp_path)
    status, lines, err = run_try(capsys, "task.py", "--policy", "baseline")
    assert status == 1 and "task.py defines no baseline" in err and err.count("\n") == 1
