"""``python -m benchmarks --help`` as a maintainer reads it, from a clone: every benchmark of
modelicagym's own parts listed, none of them among a user's ``modelicagym bench``, every ``--help``
on one screen."""

from __future__ import annotations

import pytest
from help_texts import SCREEN, help_text, listed_commands

from benchmarks import BENCHMARKS
from benchmarks.__main__ import build_parser
from modelicagym.cli import BENCHMARKS as USER_BENCHMARKS


def test_the_help_lists_every_benchmark_and_none_of_a_users(monkeypatch: pytest.MonkeyPatch) -> None:
    listed = listed_commands(help_text(build_parser(), monkeypatch=monkeypatch))
    assert listed == [name for name, _, _ in BENCHMARKS]
    assert not set(listed) & {name for name, _, _ in USER_BENCHMARKS}


@pytest.mark.parametrize("names", [()] + [(name,) for name, _, _ in BENCHMARKS])
def test_every_help_fits_a_screen_and_names_no_work_item(names: tuple[str, ...],
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    text = help_text(build_parser(), *names, monkeypatch=monkeypatch)
    assert len(text.splitlines()) <= SCREEN, text
    assert "issue" not in text.lower(), text
