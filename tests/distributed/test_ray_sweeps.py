"""Sweeps on a real local Ray (2 CPUs, 127.0.0.1, token authentication on): the same files and
episodes as a local run, ``--resume``, a group whose process dies is retried, one that fails
writes nothing."""

from __future__ import annotations

import dataclasses
import json
import os
from pathlib import Path

import numpy as np
import pytest
from ray_cluster import local_ray
from sweep_checks import assert_same_sweep_files, small

import modelicagym
from modelicagym.distributed import SweepGroupError
from modelicagym.experiments import RayRunner, read_sweep, run_sweeps
from modelicagym.experiments.cli import main as experiments_main


@pytest.fixture(scope="module", autouse=True)
def ray_instance():
    with local_ray(__name__, num_cpus=2) as temp_dir:
        yield temp_dir


def test_a_sweep_on_ray_writes_what_a_local_run_writes(tmp_path):
    config = small()
    run_sweeps([config], tmp_path / "local", progress=False, bounds_budget=200)
    [result] = run_sweeps([config], tmp_path / "ray", progress=False, bounds_budget=200, runner=RayRunner(groups=4))
    assert result.timing["num_workers"] == 4
    assert_same_sweep_files(tmp_path / "local", tmp_path / "ray", config.name)
    np.testing.assert_array_equal(read_sweep(tmp_path / "ray", config.name).lengths, result.lengths)


def test_reproduce_cli_with_ray_resumes_like_a_local_run(tmp_path, capsys):
    config_file = tmp_path / "sweep.json"
    config_file.write_text(json.dumps(small("cli", episodes=3).to_dict()))
    args = ["reproduce", "--config", str(config_file), "--out", str(tmp_path / "out"), "--no-progress",
            "--bounds-budget", "0", "--ray"]
    assert experiments_main(args) == 0
    marker = (tmp_path / "out" / "cli" / "run.json").stat().st_mtime_ns
    assert experiments_main([*args, "--resume"]) == 0
    assert (tmp_path / "out" / "cli" / "run.json").stat().st_mtime_ns == marker
    assert "cli" in capsys.readouterr().out


class DiesOnce:
    """``make_vec`` that kills its own Ray worker process the first time it runs for env 0's group."""

    def __init__(self, marker: Path) -> None:
        self.marker = str(marker)

    def __call__(self, env_id, n, *, options_per_env=None, **options):
        if options_per_env[0] == {"force": 5.0} and not os.path.exists(self.marker):
            Path(self.marker).write_text(str(os.getpid()))
            os._exit(1)
        return modelicagym.make_vec(env_id, n, options_per_env=options_per_env, backend="sync", **options)


def test_a_group_whose_process_dies_is_retried_with_the_same_episodes(tmp_path):
    config = small("retried", episodes=3)
    run_sweeps([config], tmp_path / "local", progress=False, bounds_budget=0)
    marker = tmp_path / "died"
    run_sweeps([config], tmp_path / "ray", progress=False, bounds_budget=0, runner=RayRunner(groups=3),
               make_vec=DiesOnce(marker))
    assert marker.exists(), "the first attempt died"
    assert_same_sweep_files(tmp_path / "local", tmp_path / "ray", config.name)


class AlwaysRaises:
    def __call__(self, env_id, n, *, options_per_env=None, **options):
        if options_per_env[-1] == {"force": 17.0} and options["max_episode_steps"] == 59:
            raise RuntimeError("this group cannot start")
        return modelicagym.make_vec(env_id, n, options_per_env=options_per_env, backend="sync", **options)


def test_a_failing_group_stops_the_sweep_and_writes_nothing(tmp_path):
    with pytest.raises(SweepGroupError, match=r"sweep 'broken', envs 4-5 raised RuntimeError: .*this group cannot "
                                              r"start; nothing of this sweep was written") as caught:
        broken = dataclasses.replace(small("broken", 2), base_options={"max_episode_steps": 59})
        run_sweeps([small("fine", 2), broken], tmp_path, progress=False, bounds_budget=0, runner=RayRunner(groups=3),
                   make_vec=AlwaysRaises())
    assert caught.value.env_indices == (4, 5)
    assert (tmp_path / "fine" / "run.json").exists()
    assert not (tmp_path / "broken").exists()
    assert "broken" not in (tmp_path / "episodes.csv").read_text()
