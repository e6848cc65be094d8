"""The documentation site and the README, as a reader meets them.

``mkdocs build --strict`` (mkdocs.yml) fails on a broken link, a missing anchor or a reference
mkdocstrings cannot resolve; the built site must hold a page per guide and one API entry for every
public object, the front doors (``make``, ``make_vec``, ``FMUEnv``, the pool) first, their parameters
in tables, their signatures one parameter a line and their references links. The README stays
short, points into the site, and keeps the CI's test command.
"""

from __future__ import annotations

import html
import importlib
import inspect
import os
import re
import runpy
import subprocess
import sys
import types
from collections import Counter
from pathlib import Path

import pytest
from extras import requires

import modelicagym

ROOT = Path(__file__).resolve().parent.parent
#: the guides a reader finds in the navigation, by their source in docs/
GUIDES = ("index", "getting-started", "own-fmu", "env", "systems", "pool", "training", "train-own-fmu", "ray", "cli", "speed",
          "faq", "glossary", "paper", "reproduction", "cartpole-solver", "design", "development/benchmark-log",
          "development/testing", "development/bench-internals", "reproduction-notes")
#: the bundled environments, each with a page and a GIF of an episode (docs/make_env_gifs.py)
ENVIRONMENTS = ("cartpole", "cartpole-continuous", "pendulum")
GIF_BYTES = 300_000
#: the API pages, in the navigation's order: the front doors first
API_PAGES = ("modelicagym", "env", "vector", "sb3", "system", "distributed", "errors")
#: the modules whose public names (``__all__``) the API pages document between them
PUBLIC_MODULES = ("modelicagym", "modelicagym.env", "modelicagym.vector", "modelicagym.system", "modelicagym.sb3",
                  "modelicagym.distributed", "modelicagym.errors", "modelicagym.fmu.errors")
#: API page -> the entries it opens with, in order
FRONT_DOORS = {
    "modelicagym": ("modelicagym.make", "modelicagym.make_vec"),
    "env": ("modelicagym.FMUEnv", "modelicagym.FMUEnv.reset", "modelicagym.FMUEnv.step"),
    "vector": ("modelicagym.vector.PoolVectorEnv", "modelicagym.vector.PoolVectorEnv.reset",
               "modelicagym.vector.PoolVectorEnv.step"),
    "sb3": ("modelicagym.sb3.SB3VecEnv",),
    "errors": ("modelicagym.ModelicaGymError",),
}
#: FMUEnv's members that serve the pool and the step path, not a user: not in the reference
FMUENV_INTERNALS = ("initializations", "fault_label", "reset_is_deterministic", "per_env_hooks", "native_step",
                    "python_observation", "fmu_failure", "native_step_failure", "check_action", "fmu_time_ns")
#: an entry of the API reference (an object's heading)
ENTRY = re.compile(r'<h[1-6] id="([^"]+)" class="doc doc-heading"')
#: a name of the project's internal work items, which user-facing text never shows
WORK_ITEM = re.compile(r"\bissues? #?\d+", re.IGNORECASE)
README_LINES = 300


def public_objects() -> list[list[str]]:
    """Each public object (modules aside) as the list of its public paths: ``modelicagym.FMUEnv``
    and ``modelicagym.env.FMUEnv`` are one object."""
    paths: dict[int, list[str]] = {}
    for module in PUBLIC_MODULES:
        for name in importlib.import_module(module).__all__:
            value = getattr(importlib.import_module(module), name)
            if not isinstance(value, types.ModuleType):
                paths.setdefault(id(value), []).append(f"{module}.{name}")
    return list(paths.values())


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


def entries(site: Path, api_page: str) -> list[str]:
    return ENTRY.findall(page(site, f"api/{api_page}"))


def entry(site: Path, api_page: str, name: str) -> str:
    """The HTML of entry ``name`` on ``api_page``, up to the next entry."""
    source = page(site, f"api/{api_page}")
    start = source.index(f'id="{name}" class="doc doc-heading"')
    found = ENTRY.search(source, start + len(name))
    return source[start:found.start() if found else len(source)]


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
def test_every_public_object_has_one_entry(site: Path) -> None:
    documented = Counter(name for api_page in API_PAGES for name in entries(site, api_page))
    assert [name for name, count in documented.items() if count > 1] == []
    for paths in public_objects():
        found = [path for path in paths if path in documented]
        assert len(found) == 1, f"{' = '.join(paths)} has {len(found)} entries in the API reference: {found}"


@requires("docs")
@pytest.mark.processes
def test_the_api_reference_leads_with_the_front_doors(site: Path) -> None:
    navigation = re.findall(r'href="api/(\w+)/"', page(site, "index"))
    assert list(dict.fromkeys(navigation)) == list(API_PAGES)
    for api_page, first in FRONT_DOORS.items():
        assert tuple(entries(site, api_page)[:len(first)]) == first, api_page
    shown = set(entries(site, "env"))
    assert [name for name in FMUENV_INTERNALS if f"modelicagym.FMUEnv.{name}" in shown] == []


@requires("docs")
@pytest.mark.processes
@pytest.mark.parametrize("function", ["make", "make_vec"])
def test_the_front_doors_have_a_table_of_their_parameters(site: Path, function: str) -> None:
    html_source = entry(site, "modelicagym", f"modelicagym.{function}")
    table = html_source[html_source.index("Parameters:"):]
    table = table[:table.index("</table>")]
    for parameter in inspect.signature(getattr(modelicagym, function)).parameters.values():
        name = f"**{parameter.name}" if parameter.kind is parameter.VAR_KEYWORD else parameter.name
        row = re.search(rf"<code>{re.escape(name)}</code>.*?</tr>", table, re.DOTALL)
        assert row is not None, f"{function}: no row for {name}"
        cells = [text(cell).strip() for cell in re.findall(r"<td[^>]*>(.*?)</td>", row.group(), re.DOTALL)]
        assert len(cells) == 3 and cells[1], f"{function}: {name} has no meaning in its row: {cells}"


@requires("docs")
@pytest.mark.processes
def test_signatures_are_formatted_and_references_are_links(site: Path) -> None:
    make_vec = entry(site, "modelicagym", "modelicagym.make_vec")
    signature = re.search(r'<div class="doc-signature highlight">(.*?)</div>', make_vec, re.DOTALL).group(1)
    signature = html.unescape(re.sub(r"<[^>]+>", "", signature))
    assert "\n    n: int,\n" in signature, signature  # one parameter a line
    assert 'href="../vector/#modelicagym.vector.PoolVectorEnv"' in make_vec  # `~modelicagym.vector.PoolVectorEnv`
    assert 'href="../env/#modelicagym.FMUEnv"' in make_vec  # `FMUEnv`, resolved where make_vec is defined
    assert '<a href="https://farama.org/Vector-Autoreset-Mode"' in page(site, "api/vector")  # a bare URL


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
