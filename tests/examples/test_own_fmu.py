"""docs/train-own-fmu.md, as a user follows it: write the sample heater (``modelicagym sample heater``: the
FMU and its task file), read the config ``modelicagym info`` prints, train with ``examples/train_own_fmu.py``
on the task file, and use what it saves. And the task file's reward and termination
do what it says, on a single env and on the pool."""

from __future__ import annotations

import ast
import csv
import hashlib
import importlib.util
import json
import math
import os
import pickle
import runpy
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest

import modelicagym
from modelicagym import FMUEnv
from modelicagym.samples.writer import SAMPLES_DIR

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
TASK = SAMPLES_DIR / "heater" / "heater_task.py"

needs_sb3 = pytest.mark.skipif(
    importlib.util.find_spec("stable_baselines3") is None,
    reason="the rl extra is not installed: pip install torch==2.13.0, then pip install 'modelicagym[rl]'",
)


def run(*command: str, cwd: Path, ok: bool = True, temp: Path | None = None) -> subprocess.CompletedProcess:
    """Run ``command`` (``python`` is this interpreter) in ``cwd``, with ``temp`` as its temporary
    folder if given; it must exit 0 when ``ok``."""
    env = None if temp is None else {**os.environ, "TMPDIR": str(temp)}
    result = subprocess.run([sys.executable, *command], cwd=cwd, capture_output=True, text=True, timeout=300,
                            check=False, env=env)
    if ok:
        assert result.returncode == 0, f"{command} failed:\n{result.stdout}\n{result.stderr}"
    return result


def task_config(fmu: Path, **parameters: float) -> dict:
    """The task file's config, on ``fmu``, with some parameters fixed."""
    config = dict(runpy.run_path(str(TASK))["config"])
    config["fmu"] = str(fmu)
    config["parameters"] = {**config["parameters"], **parameters}
    return config


def printed_config_of(info_output: str) -> dict:
    """The ``config = {...}`` that ``modelicagym info`` printed."""
    start = info_output.index("config = {") + len("config = ")
    end = info_output.index("\n    }", start) + len("\n    }")
    return ast.literal_eval(info_output[start:end].strip())


@needs_sb3
def test_the_walkthrough_runs_as_written_and_leaves_what_it_says(tmp_path):
    # 1. the sample FMU and its task file, written into a folder of one's own, 2. its config as `info` prints
    # it: the task file's, pasted (the task file kept beside the FMU: its fmu path is relative to its folder)
    run("-m", "modelicagym.cli", "sample", "heater", cwd=tmp_path)
    assert (tmp_path / "heater_task.py").read_text() == TASK.read_text()
    printed = printed_config_of(run("-m", "modelicagym.cli", "info", "heater.fmu", cwd=tmp_path).stdout)
    pasted = runpy.run_path(str(TASK))["config"]
    edited = {"max_episode_steps", "parameters", "batch_reward", "termination"}
    assert {k: v for k, v in pasted.items() if k not in edited} == {k: v for k, v in printed.items() if k not in edited}
    assert {k: v for k, v in pasted["parameters"].items() if k != "T_0"} == {
        k: v for k, v in printed["parameters"].items() if k != "T_0"}

    # 3. train, briefly (SAC starts learning after 500 steps)
    # a short temporary folder: the pool's fork server puts its socket there, and a socket's path is at
    # most 107 bytes (pytest-xdist's tmp_path alone takes 80)
    with tempfile.TemporaryDirectory(prefix="mg-") as short:
        temp = Path(short)
        out = run(str(EXAMPLES / "train_own_fmu.py"), "heater_task.py", "--out", "run", "--steps", "700", "--envs",
                  "2", "--eval-episodes", "2", cwd=tmp_path, temp=temp).stdout
        assert not list(temp.glob("SB3-*")), "SB3's logger made a folder in the temporary folder"
    assert "trained 700 steps" in out and "evaluation on 2 episodes" in out and "no training episode ended" not in out
    folder = tmp_path / "run"
    summary = json.loads((folder / "run.json").read_text())
    assert sorted(p.name for p in folder.iterdir()) == sorted([*summary["files"], "run.json"]), "temporary files left"
    assert set(summary["files"]) == {"policy.zip", "normalize.pkl", "learning_curve.csv", "learning_curve.png",
                                     "evaluation.gif"}
    for name, entry in summary["files"].items():
        data = (folder / name).read_bytes()
        assert (len(data), hashlib.sha256(data).hexdigest()) == (entry["bytes"], entry["sha256"]), name

    # the learning curve: one row per training episode, up to the budget
    with open(folder / "learning_curve.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == summary["training_episodes"] >= 10  # 2 envs, 700 steps, at most 60 steps an episode
    assert all(0 < int(r["env_steps"]) <= 700 and 0 < int(r["episode_length"]) <= 60
               and math.isfinite(float(r["episode_return"])) for r in rows)

    # the GIF: the strip chart of the first evaluation episode, at most 40 frames (--gif-frames), the last
    # step's among them: 60 steps, a frame every 2
    from PIL import Image

    with Image.open(folder / "evaluation.gif") as gif:
        assert gif.n_frames == summary["gif_frames"] == 30 and summary["gif_every"] == 2
        assert gif.size[0] == 640

    # the saved policy loads and acts on the FMU, through the saved normalization
    from stable_baselines3 import SAC

    policy = SAC.load(folder / "policy.zip", device="cpu")
    with open(folder / "normalize.pkl", "rb") as f:
        normalize = pickle.load(f)
    env = FMUEnv(task_config(tmp_path / "heater.fmu"))
    try:
        observation, _ = env.reset(seed=3)
        for _ in range(5):
            action, _ = policy.predict(normalize.normalize_obs(observation), deterministic=True)
            assert action.shape == (1,) and 0.0 <= action[0] <= 1.0
            observation, reward, *_ = env.step(action)
            assert math.isfinite(reward)
    finally:
        env.close()


@needs_sb3
def test_a_run_whose_episodes_never_end_still_draws_its_curve_and_says_why(tmp_path, family_fmu):
    """50 steps on 2 envs of 60-step episodes: no training episode ends. The curve is drawn anyway
    (with the random actions' line and the reason written across it), the reason printed; no GIF
    asked for, none written. The task file is run from another folder: its fmu is beside it."""
    (tmp_path / "heater.fmu").write_bytes(family_fmu("own_heater", 2).read_bytes())
    (tmp_path / "heater_task.py").write_text(TASK.read_text())
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    out = run(str(EXAMPLES / "train_own_fmu.py"), "../heater_task.py", "--out", "run", "--steps", "50", "--envs", "2",
              "--eval-episodes", "1", "--gif-frames", "0", cwd=elsewhere).stdout
    assert ("no training episode ended in 50 steps: an episode lasts up to 60 steps on each of 2 envs, so at least "
            "120 steps are needed; train longer (--steps) or shorten the episodes (max_episode_steps)") in out
    summary = json.loads((elsewhere / "run" / "run.json").read_text())
    assert summary["training_episodes"] == 0 and summary["gif_frames"] == 0
    assert set(summary["files"]) == {"policy.zip", "normalize.pkl", "learning_curve.csv", "learning_curve.png"}


def test_the_gif_takes_at_most_the_frames_asked_for_and_the_last_step():
    spec = importlib.util.spec_from_file_location("train_own_fmu", EXAMPLES / "train_own_fmu.py")
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    for length in (1, 7, 60, 500, 501):
        for frames in (1, 2, 5, 40, 600):
            every = script.gif_every(length, frames)
            drawn = [k for k in range(1, length + 1) if k % every == 0 or k == length]
            assert len(drawn) <= frames and drawn[-1] == length
    assert script.gif_every(500, 0) == 0


def test_the_task_reward_and_termination_are_what_the_task_file_says(family_fmu):
    fmu = family_fmu("own_heater", 2)
    # the room from 15 degC at half power: T -> 5 + 0.5 * 3000 / 100 = 20 degC with a time constant of 600 s
    # (the reward sees the FMU's float64 outputs; the observation is their float32)
    env = FMUEnv(task_config(fmu, T_0=15.0))
    try:
        env.reset(seed=0)
        (temperature, power), reward, terminated, truncated, _ = env.step(np.array([0.5], dtype=np.float32))
    finally:
        env.close()
    exact = 20.0 - 5.0 * math.exp(-60.0 / 600.0)
    assert temperature == pytest.approx(exact, rel=1e-6) and power == 1500.0
    assert reward == pytest.approx(-abs(exact - 21.0) - 0.1 * 0.5**2, rel=1e-9)
    assert not terminated and not truncated

    # at full power from 29 degC (T -> 35 degC) the room passes 30 degC in the second step: -100 then, and the end
    env = FMUEnv(task_config(fmu, T_0=29.0))
    try:
        env.reset(seed=0)
        steps = [env.step(np.array([1.0], dtype=np.float32)) for _ in range(2)]
    finally:
        env.close()
    t1, t2 = (35.0 - 6.0 * math.exp(-k * 60.0 / 600.0) for k in (1, 2))
    assert t1 < 30.0 < t2
    assert [step[0][0] for step in steps] == pytest.approx([t1, t2], rel=1e-6)
    assert [step[2] for step in steps] == [False, True]
    assert [step[1] for step in steps] == pytest.approx([-abs(t1 - 21.0) - 0.1, -abs(t2 - 21.0) - 0.1 - 100.0],
                                                        rel=1e-9)


def test_the_pool_ends_the_task_s_steps_as_a_single_env_does(family_fmu):
    fmu = family_fmu("own_heater", 2)
    actions = np.array([[0.5], [1.0]], dtype=np.float32)
    expected = []
    for action in actions:
        env = FMUEnv(task_config(fmu, T_0=29.0))
        try:
            env.reset(seed=0)
            expected.append([env.step(action)[1:3] for _ in range(2)])
        finally:
            env.close()
    pool = modelicagym.make_vec(task_config(fmu, T_0=29.0), n=2, autoreset_mode="SameStep")
    try:
        pool.reset(seed=0)
        got = [pool.step(actions)[1:3] for _ in range(2)]
    finally:
        pool.close()
    for step in range(2):
        rewards, terminations = got[step]
        assert [float(r) for r in rewards] == [float(expected[k][step][0]) for k in range(2)]
        assert terminations.tolist() == [expected[k][step][1] for k in range(2)]
    assert got[1][1].tolist() == [False, True]  # full power overheats the room in its second step


@needs_sb3
@pytest.mark.parametrize("task, message", [
    ("missing.py", "task file not found: missing.py"),
    ("bad_variable.py", "no output named 'Temp'. This FMU's outputs: T, P"),
    ("bad_path.py", "FMU not found: heatr.fmu"),
    ("no_config.py", "a task file defines config = {...}"),
    ("endless.py", "the config sets no max_episode_steps"),
    ("discrete.py", "SAC acts on float inputs (a Box action space); this FMU's actions are Discrete(2)"),
])
def test_bad_input_is_one_line_and_leaves_no_files(tmp_path, family_fmu, task, message):
    fmu = family_fmu("own_heater", 2)
    text = TASK.read_text().replace("'heater.fmu'", repr(str(fmu)))
    (tmp_path / "bad_variable.py").write_text(text.replace("'outputs': ['T', 'P']", "'outputs': ['Temp', 'P']"))
    (tmp_path / "bad_path.py").write_text(TASK.read_text().replace("'heater.fmu'", "'heatr.fmu'"))
    (tmp_path / "no_config.py").write_text("settings = {}\n")
    (tmp_path / "endless.py").write_text(text.replace("'max_episode_steps': 60", "'max_episode_steps': None"))
    (tmp_path / "discrete.py").write_text(text + "config['action_table'] = [[0.0], [1.0]]\n")
    result = run(str(EXAMPLES / "train_own_fmu.py"), task, "--out", "run", "--steps", "100", cwd=tmp_path, ok=False)
    assert result.returncode == 1
    assert result.stderr.startswith("error: ") and result.stderr.count("\n") == 1 and message in result.stderr
    assert not (tmp_path / "run").exists()


def test_build_of_a_model_folder_refuses_bad_input_in_one_line(tmp_path):
    for args, message in [(("nowhere", "--out", "x.fmu"), "model folder not found: nowhere"),
                          (("--out", "x.fmu"), "--out needs a model folder"),
                          ((str(SAMPLES_DIR / "heater"), "--fmi-version", "2", "3"),
                           "one FMI version at a time")]:
        result = run("-m", "modelicagym.cli", "build", *args, cwd=tmp_path, ok=False)
        assert result.returncode == 1 and result.stderr.startswith("error: ") and message in result.stderr, result.stderr
    assert list(tmp_path.iterdir()) == []


@needs_sb3
def test_ppo_trains_on_the_same_task_file(tmp_path, family_fmu):
    (tmp_path / "heater.fmu").write_bytes(family_fmu("own_heater", 2).read_bytes())
    (tmp_path / "heater_task.py").write_text(TASK.read_text())
    out = run(str(EXAMPLES / "train_own_fmu.py"), "heater_task.py", "--out", "run", "--algo", "ppo", "--steps", "1024",
              "--envs", "2", "--eval-episodes", "1", cwd=tmp_path).stdout
    assert "PPO on 2 envs" in out and "trained 1024 steps" in out
    from stable_baselines3 import PPO

    policy = PPO.load(tmp_path / "run" / "policy.zip", device="cpu")
    summary = json.loads((tmp_path / "run" / "run.json").read_text())
    assert summary["algorithm"] == "ppo" and summary["env_steps"] == 1024 and len(summary["evaluation_returns"]) == 1
    assert policy.action_space.shape == (1,)


CONSUMER_TASK = EXAMPLES / "consumer_task.py"


def test_the_consumer_task_is_info_s_config_edited_where_it_says(family_fmu, capsys):
    """``examples/consumer_task.py``, docs/train-own-fmu.md's FMU with many inputs: ``info``'s config with the
    placeholder filled, a held input drawn per episode and the timing edited; nothing else."""
    from modelicagym import cli

    fmu = family_fmu("consumer", 2)
    assert cli.main(["info", str(fmu)]) == 0
    printed_config = printed_config_of(capsys.readouterr().out)
    task = runpy.run_path(str(CONSUMER_TASK))["config"]
    edited = {"fmu", "fixed_inputs", "action_bounds", "time_step", "max_episode_steps", "batch_reward"}
    assert {k: v for k, v in task.items() if k not in edited} == {
        k: v for k, v in printed_config.items() if k not in edited}
    assert {k: v for k, v in task["fixed_inputs"].items() if k != "T_amb"} == {
        k: v for k, v in printed_config["fixed_inputs"].items() if k != "T_amb"}
    assert printed_config["action_bounds"] == {"valve": None} and task["action_bounds"] == {"valve": (0.0, 1.0)}

    config = {**task, "fmu": fmu, "fixed_inputs": {**task["fixed_inputs"], "T_amb": 303.15}}
    env = FMUEnv(config)
    try:
        env.reset(seed=0)
        observation, reward, *_ = env.step(np.array([0.0]))  # valve shut: no flow, no pumping cost
    finally:
        env.close()
    assert observation[2] == 0.0 and reward == pytest.approx(-abs(float(observation[0]) - 295.15), abs=1e-4)


@needs_sb3
def test_a_setpoint_task_is_evaluated_against_its_baseline_on_the_same_starts(tmp_path):
    """The drive sample's task: a setpoint and a load drawn per episode, seen by the policy; its PI
    baseline is evaluated beside the policy and random actions, one table, the same seeds."""
    from modelicagym.samples import write_sample

    write_sample("drive", tmp_path)
    out = run(str(EXAMPLES / "train_own_fmu.py"), "drive_task.py", "--out", "run", "--steps", "200", "--envs", "2",
              "--eval-episodes", "2", "--gif-frames", "2", cwd=tmp_path).stdout
    lines = out.splitlines()
    table = lines.index("evaluation on 2 episodes (the same seeds, 10000..10001, for each):")
    assert lines[table + 1].split() == ["controller", "mean", "return", "lowest", "highest"]
    assert [line.split()[0] for line in lines[table + 2 : table + 5]] == ["trained", "random", "the"]
    summary = json.loads((tmp_path / "run" / "run.json").read_text())
    from modelicagym.task import read_task_file

    task = read_task_file(tmp_path / "drive_task.py")
    env = FMUEnv(task.config)
    expected = []
    for seed in (10_000, 10_001):
        observation, _ = env.reset(seed=seed)
        task.baseline.reset()
        total, done = 0.0, False
        while not done:
            observation, reward, terminated, truncated, _ = env.step(task.baseline.act(observation))
            total, done = total + reward, terminated or truncated
        expected.append(total)
    env.close()
    assert summary["baseline_returns"] == expected
    assert max(expected) > -100.0 > max(summary["random_returns"])  # the PI tracks; random actions do not
