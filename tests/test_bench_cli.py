"""``modelicagym bench --help`` as a user reads it: the benchmarks a user runs first, those of
modelicagym's own parts grouped under ``bench internals``, and every ``--help`` on one screen."""

from __future__ import annotations

import argparse

import pytest

from modelicagym.bench import INTERNAL_BENCHMARKS, USER_BENCHMARKS
from modelicagym.cli import build_parser

#: lines a help text may take: one terminal screen
SCREEN = 50


def subparser(parser: argparse.ArgumentParser, *names: str) -> argparse.ArgumentParser:
    for name in names:
        action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
        parser = action.choices[name]
    return parser


def help_text(*names: str, monkeypatch: pytest.MonkeyPatch) -> str:
    monkeypatch.setenv("COLUMNS", "100")
    return subparser(build_parser(), *names).format_help()


def test_bench_help_lists_what_a_user_runs_first_and_the_internals_after(monkeypatch: pytest.MonkeyPatch) -> None:
    text = help_text("bench", monkeypatch=monkeypatch)
    listed = [line.split()[0] for line in text.split("BENCHMARK\n", 1)[1].splitlines() if line.startswith("    ")
              and not line.startswith("      ")]
    assert listed == [name for name, _, _ in USER_BENCHMARKS] + ["internals"]
    assert [name for name, _, _ in USER_BENCHMARKS][:5] == ["fmu", "step-paths", "throughput", "shared", "training"]
    internals = help_text("bench", "internals", monkeypatch=monkeypatch)
    for name, _, summary in INTERNAL_BENCHMARKS:
        assert name in internals and name not in listed


@pytest.mark.parametrize("names", [("bench",), ("bench", "internals")]
                         + [("bench", name) for name, _, _ in USER_BENCHMARKS]
                         + [("bench", "internals", name) for name, _, _ in INTERNAL_BENCHMARKS])
def test_every_bench_help_fits_a_screen_and_names_no_work_item(names: tuple[str, ...],
                                                               monkeypatch: pytest.MonkeyPatch) -> None:
    text = help_text(*names, monkeypatch=monkeypatch)
    assert len(text.splitlines()) <= SCREEN, text
    assert "issue" not in text.lower(), text
