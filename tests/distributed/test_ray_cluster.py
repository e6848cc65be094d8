"""A two-node Ray cluster on this machine, started with Ray's command line (one CPU per node,
token authentication on): ``modelicagym reproduce --ray ADDRESS`` runs a sweep across both nodes
and writes what a local run writes; ``ray stop --force`` leaves no Ray process behind."""

from __future__ import annotations

import json
import shutil
import socket
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest
from ray_cluster import driver_env, ray_processes, wait_until_gone
from sweep_checks import assert_same_sweep_files, small

from modelicagym.experiments import run_sweeps

BIN = Path(sys.executable).parent


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def ray_cli(*args: str, check: bool = True) -> subprocess.CompletedProcess:
    return subprocess.run([str(BIN / "ray"), *args], env=driver_env(), capture_output=True, text=True, timeout=120,
                          check=check)


@pytest.fixture(scope="module")
def cluster():
    """``ray start --head`` and a second ``ray start --address=...`` node; ``ray stop --force`` after."""
    assert not ray_processes(), "a Ray instance is already running on this machine"
    port = free_port()
    temp_dir = tempfile.mkdtemp(prefix="mgray-", dir="/tmp")
    try:
        ray_cli("start", "--head", f"--port={port}", "--node-ip-address=127.0.0.1", "--num-cpus=1",
                "--include-dashboard=false", f"--temp-dir={temp_dir}", "--disable-usage-stats")
        ray_cli("start", f"--address=127.0.0.1:{port}", "--node-ip-address=127.0.0.1", "--num-cpus=1",
                "--disable-usage-stats")
        yield f"127.0.0.1:{port}"
    finally:
        ray_cli("stop", "--force", check=False)
        left = wait_until_gone(None)
        shutil.rmtree(temp_dir, ignore_errors=True)
        assert not left, f"Ray processes left behind: {left}"


def test_a_sweep_across_two_nodes_writes_what_a_local_run_writes(cluster, tmp_path):
    config = small("two_nodes", episodes=4)
    config_file = tmp_path / "sweep.json"
    config_file.write_text(json.dumps(config.to_dict()))
    status = subprocess.run(
        [str(BIN / "modelicagym"), "reproduce", "--config", str(config_file), "--out", str(tmp_path / "ray"),
         "--no-progress", "--bounds-budget", "100", "--ray", cluster, "--ray-groups", "2"],
        env=driver_env(), capture_output=True, text=True, timeout=300,
    )
    assert status.returncode == 0, status.stderr[-3000:]
    assert "2 node(s)" in status.stderr, status.stderr[-3000:]
    run_sweeps([config], tmp_path / "local", progress=False, bounds_budget=100)
    assert_same_sweep_files(tmp_path / "local", tmp_path / "ray", config.name)
