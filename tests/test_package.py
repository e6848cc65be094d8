"""The package's identity: one version (pyproject.toml's), printed by ``modelicagym --version``,
and the release files that name it (CHANGELOG.md, CITATION.cff) and its licence (LICENSE).

That the installed package's version is pyproject's, read from the wheel built from this tree, is
tests/test_wheel.py's job; here the package reads its version back from its installed metadata.
"""

from __future__ import annotations

import re
from importlib.metadata import version
from pathlib import Path

import pytest

import modelicagym
from modelicagym.cli import main

ROOT = Path(__file__).resolve().parent.parent


def pyproject_field(name: str) -> str:
    """A one-line ``name = "..."`` field of pyproject.toml's [project] table."""
    project = (ROOT / "pyproject.toml").read_text(encoding="utf-8").partition("[project]")[2].partition("\n[")[0]
    return re.search(rf'^{name} = "([^"]+)"$', project, re.MULTILINE).group(1)


def test_the_package_and_its_command_give_the_installed_version(capsys: pytest.CaptureFixture[str]) -> None:
    assert modelicagym.__version__ == version("modelicagym")
    with pytest.raises(SystemExit) as done:
        main(["--version"])
    assert done.value.code == 0
    assert capsys.readouterr().out == f"modelicagym {version('modelicagym')}\n"


def test_the_changelog_and_the_citation_name_pyprojects_version() -> None:
    """A version bump in pyproject.toml needs its changelog section and the citation's version."""
    current = pyproject_field("version")
    changelog = (ROOT / "CHANGELOG.md").read_text(encoding="utf-8")
    sections = re.findall(r"^## \[([^\]]+)\]", changelog, re.MULTILINE)
    assert sections[:2] == ["Unreleased", current], sections
    assert re.search(rf"^## \[{re.escape(current)}\] - \d{{4}}-\d\d-\d\d$", changelog, re.MULTILINE)
    citation = (ROOT / "CITATION.cff").read_text(encoding="utf-8")
    assert re.search(rf'^version: "{re.escape(current)}"$', citation, re.MULTILINE)
    assert re.search(r'^  doi: "10\.1145/3365984\.3365985"$', citation, re.MULTILINE)  # the paper


def test_the_licence_file_is_the_licence_pyproject_declares() -> None:
    assert pyproject_field("license") == "MIT"
    licence = (ROOT / "LICENSE").read_text(encoding="utf-8")
    assert licence.startswith("MIT License\n") and "the modelicagym authors" in licence
