"""A command's ``--help`` as its reader sees it: on a terminal 100 columns wide, one screen at most."""

from __future__ import annotations

import argparse

import pytest

#: lines a help text may take: one terminal screen
SCREEN = 50


def subparser(parser: argparse.ArgumentParser, *names: str) -> argparse.ArgumentParser:
    """The parser of the (sub-)subcommand ``names`` of ``parser``."""
    for name in names:
        action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
        parser = action.choices[name]
    return parser


def help_text(parser: argparse.ArgumentParser, *names: str, monkeypatch: pytest.MonkeyPatch) -> str:
    monkeypatch.setenv("COLUMNS", "100")
    return subparser(parser, *names).format_help()


def listed_commands(text: str, metavar: str = "BENCHMARK") -> list[str]:
    """The names a ``--help`` lists under ``metavar``."""
    return [line.split()[0] for line in text.split(f"{metavar}\n", 1)[1].splitlines()
            if line.startswith("    ") and not line.startswith("      ")]
