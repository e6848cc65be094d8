"""A small sweep and the comparison of two results directories, for the tests of sweeps run elsewhere
(on Ray) against a local run."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from modelicagym.agents import QLearningAgent
from modelicagym.experiments import SweepConfig
from modelicagym.experiments.config import AgentSpec, Setting


def small(name="small", episodes=6):
    return SweepConfig(
        name=name, episodes=episodes, repeats=2, seed=3,
        settings=(Setting("5 N", {"force": 5.0}), Setting("11 N", {"force": 11.0}), Setting("17 N", {"force": 17.0})),
        base_options={"max_episode_steps": 60},
        agent=AgentSpec(intervals=((-2.4, 2.4), (-1.0, 1.0), (1.3614, 1.7802), (-2.0, 2.0))),
    )


def assert_same_sweep_files(local: Path, remote: Path, name: str) -> None:
    for file in ("episodes.csv",):
        assert (local / name / file).read_bytes() == (remote / name / file).read_bytes()
    assert (local / "episodes.csv").read_bytes() == (remote / "episodes.csv").read_bytes()
    ours, theirs = (json.loads((d / name / "run.json").read_text()) for d in (local, remote))
    assert ours.keys() == theirs.keys() and ours["timing"].keys() == theirs["timing"].keys()
    assert ours["config"] == theirs["config"] and ours["bounds"] == theirs["bounds"]
    a, b = (QLearningAgent.load(d / name / "agent.npz") for d in (local, remote))
    np.testing.assert_array_equal(a.q_table, b.q_table)
    np.testing.assert_array_equal(a.epsilon, b.epsilon)
    assert sorted(p.name for p in (local / name).iterdir()) == sorted(p.name for p in (remote / name).iterdir())
