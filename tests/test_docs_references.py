"""The API reference's docstrings as Markdown (docs/griffe_roles.py): references become links to
the entries they name, resolved in the docstring's scope; literals and code stay as written."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

import pytest
from extras import requires

pytestmark = requires("docs")

ROOT = Path(__file__).resolve().parent.parent
KNOWN = {"FMUEnv": "modelicagym.env.fmu_env.FMUEnv", "modelicagym.vector.PoolVectorEnv": "modelicagym.vector.PoolVectorEnv"}


@pytest.fixture(scope="module")
def roles() -> ModuleType:
    spec = importlib.util.spec_from_file_location("griffe_roles", ROOT / "docs" / "griffe_roles.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def link(target: str, title: str) -> str:
    return f'<autoref identifier="{target}" optional><code>{title}</code></autoref>'


def test_a_reference_is_a_link_to_what_it_names(roles: ModuleType) -> None:
    markdown = roles.plain("An `FMUEnv` in :class:`~modelicagym.vector.PoolVectorEnv`.", KNOWN.get)
    assert markdown == f"An {link(KNOWN['FMUEnv'], 'FMUEnv')} in {link('modelicagym.vector.PoolVectorEnv', 'PoolVectorEnv')}."


def test_what_names_nothing_known_and_literals_stay_code(roles: ModuleType) -> None:
    assert roles.plain("`nowhere()` and ``FMUEnv`` and ``x = 1``", KNOWN.get) == "`nowhere()` and `FMUEnv` and `x = 1`"


def test_code_blocks_keep_their_text(roles: ModuleType) -> None:
    markdown = roles.plain("Run it.\n\nExample::\n\n    env = `FMUEnv`\n\n>>> ``FMUEnv``\n", KNOWN.get)
    assert "```python\nenv = `FMUEnv`\n```" in markdown
    assert "```pycon\n>>> ``FMUEnv``\n```" in markdown
    assert "<autoref" not in markdown


@pytest.mark.processes  # griffe asks git about the package's folder
def test_names_resolve_in_the_docstrings_scope(roles: ModuleType) -> None:
    """A method's docstring names its class's methods and its module's imports as Python would."""
    griffe = pytest.importorskip("griffe")
    package = griffe.load("modelicagym", search_paths=[str(ROOT)], resolve_aliases=False)
    step = package["env.fmu_env.FMUEnv.step"]
    resolve = roles.resolver(step)
    assert resolve("is_terminal") == "modelicagym.env.fmu_env.FMUEnv.is_terminal"
    assert resolve("FMUEnvConfig") == "modelicagym.env.config.FMUEnvConfig"
    assert resolve("FMUEnvConfig.from_mapping") == "modelicagym.env.config.FMUEnvConfig.from_mapping"
    assert resolve("gymnasium.Env") == "gymnasium.Env"  # not ours: a link only if the reference documents it
    assert resolve("no_such_name") is None
