"""The package as a user installs it: the sdist and the wheel built from this tree, the wheel
installed in a fresh virtual environment outside the checkout, its commands run from an empty folder.

Nothing is downloaded: the build runs without isolation, with this environment's setuptools, and
the fresh environment gets the wheel with ``--no-deps --no-index`` and finds the dependencies
through a ``.pth`` line naming this environment's site-packages. That line adds a folder to the
import path after the fresh environment's own site-packages, and processes no ``.pth`` file in
it, so this checkout's editable install stays out: ``modelicagym`` comes from the wheel, and
the test checks that it does. The FMUs and the native library are built from the wheel's own C
sources, into a cache of the test's own.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
import tarfile
import zipfile
from dataclasses import dataclass
from fnmatch import fnmatch
from pathlib import Path

import pytest
from extras import requires

pytestmark = [pytest.mark.processes, requires("plots")]  # builds, installs and runs commands; report's figures

ROOT = Path(__file__).resolve().parent.parent
#: the smallest run of the main job: one sweep, 3 episodes per (setting, repeat), no bounds search
SMALL_REPRODUCE = ["--sweeps", "force", "--episodes-scale", "0.03", "--bounds-budget", "0", "--no-progress"]
#: the tools the checks need, besides setuptools (the `test` extra has them)
TOOLS = ("build", "twine", "check_wheel_contents")


def source_files(root: Path) -> list[str]:
    """The files of the source tree: what .gitignore does not ignore, without hidden entries
    (.git, .venv, .ci) — what ``git ls-files`` lists in a clean clone, without asking git."""
    ignore = root / ".gitignore"
    lines = ignore.read_text(encoding="utf-8").splitlines() if ignore.exists() else []
    patterns = [line.strip().rstrip("/") for line in lines if line.strip() and not line.startswith("#")]

    def kept(name: str) -> bool:
        return not name.startswith(".") and not any(fnmatch(name, pattern) for pattern in patterns)

    files = []
    for folder, folders, names in os.walk(root):
        folders[:] = sorted(name for name in folders if kept(name))
        files += [Path(folder, name).relative_to(root).as_posix() for name in names if kept(name)]
    return sorted(files)


def snapshot(root: Path) -> dict[str, tuple[int, int]]:
    """Size and modification time of every source file: what ``git status`` would see change."""
    return {name: ((stat := (root / name).stat()).st_size, stat.st_mtime_ns) for name in source_files(root)}


def run(args: list[str | Path], cwd: Path, env: dict[str, str] | None = None, timeout: float = 300) -> str:
    """Run a command, fail with its output if it fails; its stdout."""
    done = subprocess.run([str(a) for a in args], cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout,
                          check=False)
    command = " ".join(str(a) for a in args)
    assert done.returncode == 0, f"{command} exited {done.returncode}:\n{done.stdout[-4000:]}\n{done.stderr[-4000:]}"
    return done.stdout


@dataclass
class Installed:
    """The built distributions, and the fresh environment holding the wheel."""

    sdist: Path
    wheel: Path
    version: str
    venv: Path
    env: dict[str, str]

    @property
    def python(self) -> Path:
        return self.venv / "bin" / "python"

    @property
    def command(self) -> Path:
        return self.venv / "bin" / "modelicagym"


@pytest.fixture(scope="module")
def installed(tmp_path_factory: pytest.TempPathFactory) -> Installed:
    for tool in TOOLS:
        pytest.importorskip(tool, reason=f"the test extra is not installed (no {tool}): pip install -e '.[test]'")
    base = tmp_path_factory.mktemp("wheel")
    source, dist, venv = base / "source", base / "dist", base / "venv"
    for name in source_files(ROOT):  # a copy, so the build writes nothing into the checkout
        (source / name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(ROOT / name, source / name)
    # the sdist, then the wheel built from the unpacked sdist: the wheel can hold only what the sdist carries
    run([sys.executable, "-m", "build", "--no-isolation", "--outdir", dist, source], cwd=base)
    (sdist,), (wheel,) = dist.glob("*.tar.gz"), dist.glob("*.whl")

    run([sys.executable, "-m", "venv", "--without-pip", venv], cwd=base)
    run([sys.executable, "-m", "pip", "--python", venv / "bin" / "python", "install", "--quiet", "--no-deps",
         "--no-index", "--no-cache-dir", "--disable-pip-version-check", wheel], cwd=base)
    purelib = run([venv / "bin" / "python", "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                  cwd=base).strip()
    here = sysconfig.get_paths()
    Path(purelib, "test-environment.pth").write_text(f"{here['purelib']}\n{here['platlib']}\n", encoding="utf-8")
    cmake = Path(sys.executable).parent / "cmake"  # fmpy's dependency, installed beside its python as pip does
    if cmake.exists():
        (venv / "bin" / "cmake").symlink_to(cmake)
    env = {key: value for key, value in os.environ.items() if key not in ("PYTHONPATH", "PYTHONHOME")}
    env.update(MODELICAGYM_CACHE=str(base / "cache"), PATH=os.pathsep.join([str(venv / "bin"), env.get("PATH", "")]))
    version = wheel.name.split("-")[1]
    return Installed(sdist=sdist, wheel=wheel, version=version, venv=venv, env=env)


def test_the_sdist_carries_the_source_tree_and_the_wheel_the_package(installed: Installed) -> None:
    """Every file of the source tree is in the sdist (so a build from it, and its tests, lack
    nothing), every file of the package (its C sources and model files too) is in the wheel,
    and both pass twine's and check-wheel-contents' checks."""
    files = source_files(ROOT)
    with tarfile.open(installed.sdist) as sdist:
        prefix = f"modelicagym-{installed.version}/"
        in_sdist = {member.name.removeprefix(prefix) for member in sdist.getmembers() if member.isfile()}
    missing = [name for name in files if name not in in_sdist]
    assert not missing, f"missing from the sdist (MANIFEST.in): {missing[:20]}"
    in_wheel = set(zipfile.ZipFile(installed.wheel).namelist())
    package = [name for name in files if name.startswith("modelicagym/")]
    missing = [name for name in package if name not in in_wheel]
    assert not missing, f"missing from the wheel (pyproject.toml's package-data): {missing[:20]}"
    assert f"modelicagym-{installed.version}.dist-info/licenses/LICENSE" in in_wheel
    run([sys.executable, "-m", "twine", "check", "--strict", installed.sdist, installed.wheel], cwd=ROOT)
    run([sys.executable, "-m", "check_wheel_contents", installed.wheel], cwd=ROOT)


def test_the_installed_wheel_runs_the_commands_from_an_empty_folder(installed: Installed, tmp_path: Path) -> None:
    """From an empty folder: --version, the main job (small) and its report, make and make_vec,
    then info, try and bench fmu on the cart-pole FMU. Everything they write is in that folder (and
    the test's cache); the checkout is left as it was; the package imported is the wheel's."""
    before = snapshot(ROOT)
    work = tmp_path / "work"
    work.mkdir()

    def modelicagym(*args: str) -> str:
        return run([installed.command, *args], cwd=work, env=installed.env)

    def python(code: str) -> str:
        return run([installed.python, "-c", code], cwd=work, env=installed.env)

    assert modelicagym("--version") == f"modelicagym {installed.version}\n"
    where, version = python("import modelicagym; print(modelicagym.__file__); print(modelicagym.__version__)").split()
    assert Path(where).is_relative_to(installed.venv) and version == installed.version, (where, version)

    printed = modelicagym("reproduce", "--out", "results", *SMALL_REPRODUCE)
    assert "modelicagym report --results results" in printed
    assert modelicagym("report", "--results", "results") == f"report: {Path('results', 'report.md')}\n"
    assert "![force](figures/force.png)" in (work / "results" / "report.md").read_text(encoding="utf-8")

    stepped = python(
        "import modelicagym\n"
        "env = modelicagym.make('cartpole')\n"
        "env.reset(seed=0)\n"
        "print(env.step(1)[1])\n"
        "envs = modelicagym.make_vec('cartpole', n=2)\n"
        "envs.reset(seed=0)\n"
        "print(envs.step(envs.action_space.sample())[1].tolist())\n"
        "envs.close()\n"
    )
    assert stepped.splitlines() == ["1.0", "[1.0, 1.0]"], stepped

    fmu = python("from modelicagym.models.cartpole import cartpole_fmu; print(cartpole_fmu())").strip()
    assert Path(fmu).is_relative_to(installed.env["MODELICAGYM_CACHE"])
    assert "config = {" in modelicagym("info", fmu)
    assert "try.png" in modelicagym("try", fmu, "--steps", "20", "--out", "try.png")
    modelicagym("bench", "fmu", fmu, "--n", "2", "--repeats", "1", "--seconds", "0.05",
                "--set", "action_bounds.f=[-10, 10]")

    written = sorted(path.relative_to(work).as_posix() for path in work.rglob("*") if path.is_file())
    assert {name.split("/")[0] for name in written} == {"results", "try.png", "bench-results"}, written
    assert "results/report.md" in written and "results/figures/force.png" in written
    assert snapshot(ROOT) == before, "the commands changed the checkout"
