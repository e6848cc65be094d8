"""A benchmark run as its user runs it, in a fresh process: ``modelicagym bench NAME`` for a user's
benchmark, ``python -m benchmarks NAME`` for one of modelicagym's own parts (from a clone: the
repository's root is put first on the child's ``PYTHONPATH``, wherever it runs)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

REPOSITORY = Path(__file__).resolve().parents[1]


def user_bench(name: str) -> list[str]:
    """The command line of ``modelicagym bench NAME``."""
    return [sys.executable, "-m", "modelicagym.cli", "bench", name]


def own_bench(name: str) -> list[str]:
    """The command line of ``python -m benchmarks NAME``."""
    return [sys.executable, "-m", "benchmarks", name]


def run(command: list[str], **kwargs) -> subprocess.CompletedProcess:
    """``command`` run to its end with the clone importable, its output captured as text."""
    path = os.pathsep.join(filter(None, (str(REPOSITORY), os.environ.get("PYTHONPATH"))))
    return subprocess.run(command, capture_output=True, text=True, env={**os.environ, "PYTHONPATH": path}, **kwargs)


def run_bench(command: list[str], args: list[str], json_path: Path) -> str:
    """The benchmark's output, its JSON written to ``json_path``; it must exit with status 0."""
    result = run([*command, *args, "--json", str(json_path)], timeout=600)
    assert result.returncode == 0, f"{' '.join(command[2:])} failed:\n{result.stdout}\n{result.stderr}"
    return result.stdout
