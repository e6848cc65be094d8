"""Every code block on the user pages runs as written, in the order a reader meets it.

The README and each user page of the site (`USER_PAGES`) are read with Sybil: its Python code
blocks run one after another in one namespace a page, as a reader's session would, and its
``bash`` blocks run in a shell, one after another as in a reader's terminal (a ``cd`` holds for
the blocks after it). A page runs in an empty folder of its own, like a newcomer's (``modelicagym
sample heater`` on the page writes the FMU it goes on to use), where ``.venv`` is the environment
running the tests and ``examples/`` the checkout's scripts, so the README's ``.venv/bin/python
examples/rollout.py`` runs as written; the folder sits beside the checkout's ``examples/`` and
``tests/``, as a folder made inside a clone does. What must not run here says so on the
page, in a comment the reader does not see: ``<!-- skip: next "why" -->`` before the block (an
install line, which `tests/test_wheel.py` runs in a fresh venv; a server that never ends). A block
that takes minutes as written runs smaller, saying how: ``<!-- smaller: "50_000", "2_048" -->``
before it replaces that text of the next block (which must hold it) for the test's run.

Every Markdown page of the site is either a user page or a maintainers' page (`MAINTAINER_PAGES`),
so a new page cannot escape the check by being forgotten.
"""

from __future__ import annotations

import ast
import importlib
import os
import shlex
import subprocess
import sys
import unittest
from collections.abc import Iterator
from pathlib import Path

import gymnasium
import pytest
from extras import requires
from sybil import Document, Example, Lexeme, Region, Sybil
from sybil.evaluators.skip import Skipper
from sybil.parsers.markdown import CodeBlockParser, PythonCodeBlockParser, SkipParser
from sybil.parsers.markdown.lexers import DirectiveInHTMLCommentLexer

ROOT = Path(__file__).resolve().parents[2]
#: the pages written for users, whose every code block runs
USER_PAGES = (
    "README.md",
    "docs/index.md",
    "docs/getting-started.md",
    "docs/own-fmu.md",
    "docs/env.md",
    "docs/systems.md",
    "docs/pool.md",
    "docs/training.md",
    "docs/train-own-fmu.md",
    "docs/cli.md",
    "docs/speed.md",
    "docs/faq.md",
    "docs/glossary.md",
    "docs/paper.md",
    "docs/ray.md",
    "docs/environments/index.md",
    "docs/environments/cartpole.md",
    "docs/environments/cartpole-continuous.md",
    "docs/environments/pendulum.md",
)
#: pages for the people changing modelicagym, or generated: their blocks are not run
MAINTAINER_PAGES = (
    "docs/design.md",
    "docs/development/*.md",
    "docs/reproduction.md",
    "docs/reproduction-notes.md",
    "docs/cartpole-solver.md",
    "docs/api/*.md",
)
#: the longest a page's shell block may run (a sweep of the paper's study, a short training)
SHELL_TIMEOUT_S = 600


def run_shell(example: Example) -> None:
    """Run a ``bash`` block where the reader's shell is (a ``cd`` in one block holds for the next
    blocks, Python's too); a failing command fails the page, showing its output."""
    environment = {**os.environ, "PATH": os.pathsep.join([str(Path(sys.executable).parent), os.environ["PATH"]])}
    where = Path(example.namespace["__shell_folder_file__"])  # the folder the block ends in, for the next
    script = f"{example.parsed}\npwd > {shlex.quote(str(where))}\n"
    result = subprocess.run(["bash", "-euo", "pipefail", "-c", script], cwd=Path.cwd(), env=environment,
                            capture_output=True, text=True, timeout=SHELL_TIMEOUT_S, check=False)
    if result.returncode != 0:
        raise AssertionError(f"{example.path}, line {example.line}: exit status {result.returncode} from\n"
                             f"{example.parsed}\n--- output ---\n{result.stdout[-3000:]}{result.stderr[-3000:]}")
    os.chdir(where.read_text(encoding="utf-8").strip())


class SmallerParser:
    """``<!-- smaller: "OLD", "NEW" -->``: the next code block runs with OLD replaced by NEW."""

    lexer = DirectiveInHTMLCommentLexer(directive="smaller")

    def __call__(self, document: Document) -> Iterator[Region]:
        for lexed in self.lexer(document):
            old, new = ast.literal_eval(f"({lexed.lexemes['arguments']})")
            yield Region(lexed.start, lexed.end, (old, new), self.evaluate)

    @staticmethod
    def evaluate(example: Example) -> None:
        example.namespace.setdefault("__smaller__", []).append(example.parsed)


def smaller(example: Example) -> None:
    """Apply the ``smaller`` replacements waiting for this code block."""
    for old, new in example.namespace.pop("__smaller__", []):
        assert old in example.parsed, f"{example.path}, line {example.line}: 'smaller' finds no {old!r} in this block"
        source = example.parsed
        example.parsed = Lexeme(source.replace(old, new), offset=source.offset, line_offset=source.line_offset)


SYBIL = Sybil(parsers=[PythonCodeBlockParser(), CodeBlockParser(language="bash", evaluator=run_shell), SkipParser(),
                       SmallerParser()])


def _close_envs(namespace: dict[str, object]) -> None:
    """Close what a page left open (a reader's session ends; the test's must not leak workers)."""
    for value in namespace.values():
        if isinstance(value, (gymnasium.Env, gymnasium.vector.VectorEnv)):
            value.close()


def importable(module: str) -> bool:
    """Whether ``module`` imports here: for ``skip: next if(not importable("ray.rllib"), "why")``, where a page
    shows a library that is none of modelicagym's extras."""
    try:
        importlib.import_module(module)
    except ImportError:
        return False
    return True


@pytest.fixture
def page_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """An empty folder a page runs in, as a newcomer's: in a stand-in for a clone (its examples and
    tests beside it, so ``../examples/train_own_fmu.py`` runs as from a folder inside the clone), with
    the clone's examples and this environment as ``.venv`` in it too (the README's commands, run from
    the clone's root)."""
    for name in ("examples", "tests"):
        (tmp_path / name).symlink_to(ROOT / name, target_is_directory=True)
    folder = tmp_path / "work"
    folder.mkdir()
    (folder / ".venv").symlink_to(sys.prefix, target_is_directory=True)
    (folder / "examples").symlink_to(ROOT / "examples", target_is_directory=True)
    monkeypatch.chdir(folder)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    yield folder


@requires("plots")
@pytest.mark.parametrize("page", USER_PAGES)
def test_page_examples_run(page: str, page_folder: Path) -> None:
    document = SYBIL.parse(ROOT / page)
    document.namespace["__shell_folder_file__"] = str(page_folder.parent / "shell-folder")
    document.namespace["importable"] = importable
    try:
        for example in document:
            evaluator = example.region.evaluator
            if isinstance(evaluator, Skipper):
                action, reason = example.parsed
                assert action == "end" or reason, f"{page}, line {example.line}: a skip says why (skip: next \"why\")"
            elif evaluator is not SmallerParser.evaluate:
                smaller(example)
            try:
                example.evaluate()
            except unittest.SkipTest:
                continue
    finally:
        _close_envs(document.namespace)


def test_every_page_is_a_user_or_a_maintainers_page() -> None:
    pages = {str(path.relative_to(ROOT)) for path in (ROOT / "docs").rglob("*.md")}
    listed = {page for page in USER_PAGES if page.startswith("docs/")}
    for pattern in MAINTAINER_PAGES:
        listed |= {str(path.relative_to(ROOT)) for path in ROOT.glob(pattern)}
    assert pages - listed == set(), "a page of the site is in neither USER_PAGES nor MAINTAINER_PAGES"
