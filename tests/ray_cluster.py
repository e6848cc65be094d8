"""Real Ray for the Ray tests: a local instance bound to 127.0.0.1, with token authentication.

Importing this module skips the importing test module when Ray is not installed. Ray's token
authentication stays on: one random token for the test session, in ``$RAY_AUTH_TOKEN`` (where Ray
looks first), so nothing is written to ``~/.ray``. ``RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0`` keeps a
single-node Ray on the loopback address (Ray reads it when imported, hence here); the two-node
test's ``ray start`` processes run without it, since Ray refuses to join nodes with it.
"""

from __future__ import annotations

import os
import secrets
import shutil
import sys
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager

import pytest
from extras import imported

os.environ.setdefault("RAY_AUTH_MODE", "token")
os.environ.setdefault("RAY_AUTH_TOKEN", secrets.token_hex(32))
os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")
os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")

ray = imported("ray")
psutil = pytest.importorskip("psutil")

#: what the processes of a Ray instance are called (or run)
RAY_PROCESS_MARKS = ("gcs_server", "raylet", "default_worker.py", "ray::", "dashboard", "log_monitor.py",
                     "monitor.py", "ray.util.client.server", "runtime_env_agent")


def ray_processes(temp_dir: str | None = None) -> list[str]:
    """Command lines of running Ray processes (of the instance using ``temp_dir``, if given)."""
    found = []
    for process in psutil.process_iter(["cmdline", "name"]):
        try:
            line = " ".join(process.info["cmdline"] or [process.info["name"] or ""])
        except (psutil.NoSuchProcess, psutil.AccessDenied):
            continue
        if process.pid != os.getpid() and any(mark in line for mark in RAY_PROCESS_MARKS):
            if temp_dir is None or temp_dir in line or line.startswith("ray::"):
                found.append(f"{process.pid}: {line[:160]}")
    return found


def wait_until_gone(temp_dir: str | None, seconds: float = 20.0) -> list[str]:
    """Ray processes still alive after up to ``seconds`` (an empty list: none left)."""
    deadline = time.monotonic() + seconds
    while (left := ray_processes(temp_dir)) and time.monotonic() < deadline:
        time.sleep(0.2)
    return left


def driver_env() -> dict[str, str]:
    """The environment for processes that start or join a Ray cluster (the token included)."""
    env = dict(os.environ)
    env.pop("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", None)
    return env


@contextmanager
def local_ray(test_module: str, num_cpus: int = 2) -> Iterator[str]:
    """``ray.init(num_cpus=...)`` on 127.0.0.1 for the block; yields its temp dir and checks on
    the way out that every Ray process is gone. Functions of ``test_module`` (a module name) travel
    to Ray's workers by value, as a script's do: the workers cannot import test modules."""
    ray.cloudpickle.register_pickle_by_value(sys.modules[test_module])
    temp_dir = tempfile.mkdtemp(prefix="mgray-", dir="/tmp")  # short: Ray's socket paths are limited
    ray.init(num_cpus=num_cpus, include_dashboard=False, _node_ip_address="127.0.0.1", _temp_dir=temp_dir,
             logging_level="WARNING", configure_logging=False)
    try:
        yield temp_dir
    finally:
        ray.shutdown()
        left = wait_until_gone(temp_dir)
        shutil.rmtree(temp_dir, ignore_errors=True)
        assert not left, f"Ray processes left behind: {left}"
