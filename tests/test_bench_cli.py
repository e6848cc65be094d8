"""``modelicagym bench --help`` as a user reads it: the benchmarks a user runs, every ``--help`` on
one screen; and a benchmark's module imported only when it runs, never for another command."""

from __future__ import annotations

import json
import sys

import pytest
from bench_runs import run
from help_texts import SCREEN, help_text, listed_commands

from modelicagym.cli import BENCHMARKS, build_parser


def test_bench_help_lists_what_a_user_runs_first(monkeypatch: pytest.MonkeyPatch) -> None:
    listed = listed_commands(help_text(build_parser(), "bench", monkeypatch=monkeypatch))
    assert listed == [name for name, _, _ in BENCHMARKS]
    assert listed[:5] == ["fmu", "step-paths", "throughput", "shared", "training"]


@pytest.mark.parametrize("names", [("bench",)] + [("bench", name) for name, _, _ in BENCHMARKS])
def test_every_bench_help_fits_a_screen_and_names_no_work_item(names: tuple[str, ...],
                                                               monkeypatch: pytest.MonkeyPatch) -> None:
    text = help_text(build_parser(), *names, monkeypatch=monkeypatch)
    assert len(text.splitlines()) <= SCREEN, text
    assert "issue" not in text.lower(), text


#: run in a fresh process: parse a command line, print the modelicagym.bench modules then imported
IMPORTED = """
import json, sys
from modelicagym.cli import build_parser
try:
    build_parser().parse_args(sys.argv[1:])
except SystemExit:  # --help
    pass
print(json.dumps(sorted(m for m in sys.modules if m.startswith("modelicagym.bench"))))
"""


def bench_modules_imported(*argv: str) -> list[str]:
    result = run([sys.executable, "-c", IMPORTED, *argv], timeout=120)
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout.splitlines()[-1])


@pytest.mark.processes
def test_another_command_imports_no_benchmark() -> None:
    assert bench_modules_imported("info", "any.fmu") == []
    assert bench_modules_imported("bench", "--help") == []


@pytest.mark.processes
def test_a_benchmark_imports_its_own_module_only() -> None:
    imported = bench_modules_imported("bench", "step-paths", "--help")
    assert "modelicagym.bench.step_paths" in imported
    assert not {module for _, module, _ in BENCHMARKS if module != "modelicagym.bench.step_paths"} & set(imported)
