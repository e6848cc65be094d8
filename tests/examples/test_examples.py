"""The example scripts, run as a reader runs them (a fresh process, small arguments): they finish
and produce what they say. Examples nobody runs rot; these cannot."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest
from extras import imported, requires

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def run_example(name: str, *args: str, env: dict[str, str] | None = None, timeout: float = 300) -> str:
    """Run ``examples/name`` with ``args``; its output (it must exit 0)."""
    result = subprocess.run([sys.executable, str(EXAMPLES / name), *args], capture_output=True, text=True,
                            timeout=timeout, env=env)
    assert result.returncode == 0, f"{name} failed:\n{result.stdout}\n{result.stderr}"
    return result.stdout


def test_rollout_runs_episodes_with_both_policies():
    out = run_example("rollout.py", "--episodes", "2", "--max-steps", "50")
    assert "native step path" in out
    assert "random: 2 episodes" in out and "lean controller: 2 episodes" in out


def test_a_trained_agent_drives_the_batch_rollout(tmp_path):
    agent, trajectories = tmp_path / "agent.npz", tmp_path / "rollout.npz"
    out = run_example("train_qlearning.py", "--episodes", "20", "--repeats", "2", "--out", str(agent))
    assert f"saved the agent to {agent}" in out
    out = run_example("batch_rollout.py", "--episodes", "6", "--envs", "2", "--max-steps", "50",
                      "--q-table", str(agent), "--out", str(trajectories))
    assert out.startswith("6 episodes") or "\n6 episodes" in out
    with np.load(trajectories) as data:
        assert data["observation"].shape == (len(data["reward"]), 4)
        assert len(set(zip(data["env"].tolist(), data["episode"].tolist()))) >= 6


def test_ray_rollouts_sample_on_a_local_ray():
    imported("ray")
    import ray_cluster

    before = ray_cluster.ray_processes()
    # the environment ray_cluster set up: a session token, Ray on 127.0.0.1
    out = run_example("ray_rollouts.py", "--envs", "3", "--steps", "40", "--rounds", "3", "--max-steps", "30",
                      env=dict(os.environ))
    assert re.search(r"3 envs in \d actor\(s\): envs 0-\d on 1 CPU\(s\)", out), out
    assert out.count("env steps in") == 3
    assert "episode length: mean 30.0, max 30 (truncated at 30)" in out
    left = [p for p in ray_cluster.wait_until_gone(None) if p not in before]
    assert not left, f"Ray processes left behind: {left}"


@requires("rl", "plots")
@pytest.mark.parametrize("env", ["cartpole", "cartpole-continuous", "pendulum"])
def test_sb3_ppo_trains_evaluates_and_plots(tmp_path, env):
    # a temporary folder of its own, short: the pool's fork server puts a Unix socket in it
    plot, tmp = tmp_path / "curve.png", Path(tempfile.mkdtemp(prefix="mg-", dir="/tmp"))
    try:
        out = run_example("sb3_ppo.py", "--env", env, "--envs", "4", "--steps", "4096", "--max-episode-steps", "100",
                          "--eval-episodes", "2", "--plot", str(plot), env={**os.environ, "TMPDIR": str(tmp)})
        assert not list(tmp.glob("SB3-*")), "SB3's logger made a folder in the temporary folder"
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    assert re.search(r"^\s+\d+ steps .* steps/s\s+mean return .* mean length", out, re.MULTILINE), out
    assert "evaluation: 2 episodes" in out
    assert plot.stat().st_size > 0


@requires("rl", "plots")
def test_sb3_sac_trains_evaluates_plots_and_saves_on_the_pool(tmp_path):
    from stable_baselines3 import SAC

    plot, saved = tmp_path / "curve.png", tmp_path / "sac.zip"
    out = run_example("sb3_sac.py", "--envs", "2", "--steps", "1200", "--max-episode-steps", "50",
                      "--eval-episodes", "2", "--plot", str(plot), "--save", str(saved))
    assert "pendulum, SAC, seed 0: 2 envs" in out and "'gradient_steps': 2" in out
    assert "not solved within 1200 steps" in out or "solved:" in out
    assert "evaluation: 2 episodes" in out
    assert plot.stat().st_size > 0
    assert SAC.load(saved, device="cpu").num_timesteps == 1200


@requires("plots")
@pytest.mark.parametrize("env", ["cartpole", "cartpole-continuous", "pendulum"])
def test_one_file_ppo_trains_and_plots(tmp_path, env):
    imported("torch")
    plot = tmp_path / "curve.png"
    out = run_example("ppo.py", "--env", env, "--num-envs", "4", "--total-steps", "4096", "--max-episode-steps", "100",
                      "--plot", str(plot))
    assert re.search(r"^\s+\d+ steps .* steps/s\s+mean return .* mean length", out, re.MULTILINE), out
    assert "trained for 4096 steps" in out or "solved:" in out
    assert plot.stat().st_size > 0


def test_one_file_ppo_resumed_from_its_checkpoint_ends_as_an_uninterrupted_run(tmp_path):
    imported("torch")
    common = ("ppo.py", "--num-envs", "4", "--total-steps", "3072", "--max-episode-steps", "60",
              "--plot", str(tmp_path / "curve.png"))
    checkpoint = str(tmp_path / "run.pt")
    uninterrupted = run_example(*common)
    first = run_example(*common, "--checkpoint", checkpoint, "--stop-after", "9")
    resumed = run_example(*common, "--checkpoint", checkpoint)
    assert "stopped after update 9" in first and "resumed from" in resumed
    fingerprint = re.compile(r"^network fingerprint: \w+$", re.MULTILINE)
    assert fingerprint.findall(resumed) == fingerprint.findall(uninterrupted) != fingerprint.findall(first)


@requires("rl")
def test_system_sac_trains_on_a_pool_of_connected_fmus():
    out = run_example("system_sac.py", "--envs", "2", "--steps", "600", "--max-episode-steps", "50")
    assert "2 envs of a system of 3 components" in out
    assert "step path: native (the system (3 components and its connections) steps in C;" in out
    assert "trained 600 steps" in out
    assert re.search(r"mean speed error: trained policy \d+\.\d+ rad/s, a fixed command of 0.1 \d+\.\d+ rad/s", out)
