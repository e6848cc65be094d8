"""The documentation site and the README, as a reader meets them.

``mkdocs build --strict`` (mkdocs.yml) fails on a broken link, a missing anchor or a reference
mkdocstrings cannot resolve; the built site must hold a page per guide and an API entry for every
public name. The README stays short, points into the site, and keeps the CI's test command.
"""

from __future__ import annotations

import html
import importlib
import os
import re
import runpy
import subprocess
import sys
from pathlib import Path

import pytest
from extras import requires

ROOT = Path(__file__).resolve().parent.parent
#: the guides a reader finds in the navigation, by their source in docs/
GUIDES = ("index", "getting-started", "own-fmu", "env", "systems", "pool", "training", "train-own-fmu", "ray", "cli", "speed",
          "faq", "glossary", "paper", "reproduction", "cartpole-solver", "design", "development/benchmark-log",
          "development/testing", "development/bench-internals", "reproduction-notes")
#: the bundled environments, each with a page and a GIF of an episode (docs/make_env_gifs.py)
ENVIRONMENTS = ("cartpole", "cartpole-continuous", "pendulum")
GIF_BYTES = 300_000
#: API page -> modules whose public names (``__all__``) it documents
API_PAGES = {
    "modelicagym": ("modelicagym",),
    "env": ("modelicagym.env",),
    "vector": ("modelicagym.vector",),
    "system": ("modelicagym.system",),
    "sb3": ("modelicagym.sb3",),
    "distributed": ("modelicagym.distributed",),
    "errors": ("modelicagym.errors", "modelicagym.fmu.errors"),
}
#: a name of the project's internal work items, which user-facing text never shows
WORK_ITEM = re.compile(r"\bissues? #?\d+", re.IGNORECASE)
README_LINES = 300


def public_names(module: str) -> list[str]:
    names = importlib.import_module(module).__all__
    return [name for name in names if not (module == "modelicagym" and name == "errors")]  # a module: its own page


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("site")
    result = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(out)],
                            cwd=ROOT, capture_output=True, text=True, timeout=300, check=False,
                            env={**_environ(), "NO_MKDOCS_2_WARNING": "1"})
    assert result.returncode == 0, f"mkdocs build --strict failed:\n{result.stdout}\n{result.stderr}"
    return out


def _environ() -> dict[str, str]:
    """This process's environment, with this checkout first on the import path (mkdocstrings
    documents the code here, not an installed copy)."""
    return {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}


def page(site: Path, name: str) -> str:
    path = site / "index.html" if name == "index" else site / name / "index.html"
    assert path.exists(), f"no page {name} in the built site"
    return path.read_text(encoding="utf-8")


def text(html_source: str) -> str:
    return html.unescape(re.sub(r"<[^>]+>", " ", html_source))


@requires("docs")
@pytest.mark.processes
def test_the_site_has_a_page_per_guide_and_search(site: Path) -> None:
    for guide in GUIDES:
        source = page(site, guide)
        assert "<h1" in source, guide
    assert (site / "search" / "search_index.json").exists()
    assert (site / "images" / "heater-try.png").exists()


@requires("docs")
@pytest.mark.processes
def test_each_bundled_environment_has_a_page_with_its_gif(site: Path) -> None:
    index = page(site, "environments")
    for env in ENVIRONMENTS:
        source = page(site, f"environments/{env}")
        assert f'src="../../images/{env}.gif"' in source, env
        assert f'href="{env}/"' in index, env
        for section in ("Action space", "Observation space", "Reward", "Episode end", "Parameters"):
            assert f">{section}<" in source, (env, section)
        gif = site / "images" / f"{env}.gif"
        assert gif.read_bytes()[:6] == b"GIF89a" and gif.stat().st_size < GIF_BYTES, env


@requires("plots")
def test_the_gif_script_renders_an_episode_of_each_environment(tmp_path: Path) -> None:
    """docs/make_env_gifs.py, which made the committed GIFs, still runs and keeps them small."""
    script = runpy.run_path(str(ROOT / "docs" / "make_env_gifs.py"))
    assert set(script["POLICIES"]) == set(ENVIRONMENTS)
    for env in ENVIRONMENTS:
        frames = script["episode_frames"](env)
        assert len(frames) > 20, env  # the controller keeps each episode going
        path = tmp_path / f"{env}.gif"
        frames[0].save(path, save_all=True, append_images=frames[1:], duration=100, loop=0, optimize=True)
        assert path.stat().st_size < GIF_BYTES, env


@requires("docs")
@pytest.mark.processes
@pytest.mark.parametrize("api_page", list(API_PAGES))
def test_the_api_reference_has_an_entry_per_public_name(site: Path, api_page: str) -> None:
    source = page(site, f"api/{api_page}")
    for module in API_PAGES[api_page]:
        for name in public_names(module):
            assert f'id="{module}.{name}"' in source, f"no API entry for {module}.{name} in api/{api_page}"


@requires("docs")
@pytest.mark.processes
def test_every_page_shows_pyprojects_version_and_the_licence(site: Path) -> None:
    version = re.search(r'^version = "([^"]+)"$', (ROOT / "pyproject.toml").read_text(encoding="utf-8"), re.MULTILINE)
    for guide in ("index", "getting-started", "api/modelicagym"):
        assert f"modelicagym {version.group(1)} · MIT License" in text(page(site, guide)), guide


@requires("docs")
@pytest.mark.processes
def test_no_page_names_a_work_item(site: Path) -> None:
    for path in site.rglob("*.html"):
        found = WORK_ITEM.search(text(path.read_text(encoding="utf-8")))
        assert found is None, f"{path.relative_to(site)} says {found.group()!r}"


def test_the_readme_is_short_and_points_into_the_site() -> None:
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(readme.splitlines()) <= README_LINES
    assert WORK_ITEM.search(readme) is None
    assert "<!-- ci: test command -->" in readme
    assert "mkdocs serve" in readme
    for target in re.findall(r"\]\((docs/[^)#]+)", readme):
        assert (ROOT / target).exists(), f"the README links to {target}, which is not there"


def test_the_ci_test_command_installs_the_docs_tools() -> None:
    """.ci/run reads the line two lines after the marker; the `test` extra brings the docs tools."""
    lines = (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
    command = lines[lines.index("<!-- ci: test command -->") + 2]
    assert '-e ".[test]"' in command and "pytest" in command
    pyproject = (ROOT / "pyproject.toml").read_text(encoding="utf-8")
    test_extra = re.search(r"^test = \[(.*)\]$", pyproject, re.MULTILINE).group(1)
    assert "docs" in re.search(r"modelicagym\[([^\]]*)\]", test_extra).group(1).split(",")
