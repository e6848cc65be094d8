"""The guard behind the fast subset (``tests/process_guard.py``): it sees a process started in any
way, names the command and the test's line, and lets a build into the developer's cache pass."""

from __future__ import annotations

import multiprocessing
import os
import subprocess
from pathlib import Path

import pytest
from process_guard import ProcessGuard

from modelicagym.native import library

pytestmark = pytest.mark.processes


@pytest.fixture
def guard(monkeypatch: pytest.MonkeyPatch) -> ProcessGuard:
    """A guard of its own, watching this test only (the session's guard goes on too)."""
    guard = ProcessGuard()
    guard.install(monkeypatch.setattr)
    guard.begin("this test")
    return guard


def test_every_way_to_start_a_process_is_seen(guard: ProcessGuard) -> None:
    subprocess.run(["true"], check=True)
    assert os.system("true") == 0
    child = multiprocessing.get_context("fork").Process(target=int)
    child.start()
    child.join()
    starts = guard.end()
    assert starts[0].startswith("Popen._execute_child (true), from test_process_guard.py:")
    assert starts[1].startswith("os.system, from test_process_guard.py:")
    assert [s.partition(",")[0] for s in starts[2:]] == ["BaseProcess.start", "os.fork"]


def test_a_build_into_the_developers_cache_passes_and_anything_else_is_seen(guard: ProcessGuard,
                                                                           tmp_path: Path) -> None:
    guard.cache = str(tmp_path)
    sources = library._c_files(library._sources())
    library._build(library._compiler(), tmp_path / "lib.so", sources, "the native library")  # into "the cache"
    subprocess.run(["ls", str(tmp_path)], check=True, stdout=subprocess.DEVNULL)  # the test's own, on the cache
    assert [s.partition(",")[0] for s in guard.end()] == [f"Popen._execute_child (ls {tmp_path})"]
