"""The pool's folders say which process runs a line, so what a module may import follows its folder.

``vector/wire/`` (what both sides share) imports no folder; ``vector/slice/`` (a batch of envs, stepped
in a worker or in the calling process) imports the wire; ``vector/worker/`` (a worker process's loop)
a slice and the wire; ``vector/layout/`` (where each env is stepped, and the machine's load) a slice
and the wire; ``vector/dispatch/`` (the calling process's commands to its parties, the workers'
handles, the pool's assembly) any of those. The top's modules (``errors``, ``env_contract``,
``timing``, ``saved_states``, ``reset_options``, ``checks``) are values and checks every folder may use
and import no folder; only ``pool.py``, ``__init__.py`` and ``api.py`` (the names the rest of the
package uses) stand above the folders. Nothing in ``vector/`` imports ``fmu/``, ``env/`` or
``models/``, and nothing outside it (the package's other modules, the maintainers' ``benchmarks/``)
imports more of the pool than ``modelicagym.vector`` and ``modelicagym.vector.api``. The imports are
read from the source (docs/design.md, "The pool's folders"); nothing is run.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import modelicagym.vector

VECTOR = Path(modelicagym.vector.__file__).parent
SIDES = ("wire", "slice", "worker", "layout", "dispatch")
#: what each folder may import besides itself and the top's values and checks
MAY_IMPORT = {"wire": set(), "slice": {"wire"}, "worker": {"slice", "wire"}, "layout": {"slice", "wire"},
              "dispatch": {"layout", "worker", "slice", "wire"}}
API = {"pool", "__init__", "api"}
#: what a module outside the pool may import of it
PUBLIC = {"modelicagym.vector", "modelicagym.vector.api"}
#: the modules outside the pool: the package's others, and a clone's maintainers' benchmarks
OUTSIDE = [path for folder in (VECTOR.parent, VECTOR.parents[1] / "benchmarks") if folder.is_dir()
           for path in sorted(folder.rglob("*.py")) if VECTOR not in path.parents]


def where(module: str) -> str:
    """``modelicagym.vector.dispatch.dispatcher`` -> ``parent``; a top-level module -> ``top:<name>``."""
    parts = module.split(".")[2:]
    if parts and parts[0] in SIDES:
        return parts[0]
    return "top:" + (parts[0] if parts else "__init__")


def modules() -> list[tuple[str, Path]]:
    found = []
    for path in sorted(VECTOR.rglob("*.py")):
        dotted = ".".join(path.relative_to(VECTOR.parents[1]).with_suffix("").parts)
        found.append((dotted.removesuffix(".__init__"), path))
    return found


def imported(path: Path) -> set[str]:
    """The modules of the package that ``path`` imports (``from X import name`` counted as X)."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module:
            names.add(node.module)
        elif isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
    return {name for name in names if name.startswith("modelicagym")}


def test_every_module_of_the_pool_is_in_a_side_or_the_public_api() -> None:
    top = {where(module) for module, path in modules() if path.parent == VECTOR}
    names = ("__init__", "api", "pool", "errors", "env_contract", "timing", "saved_states", "reset_options", "checks")
    assert top == {f"top:{name}" for name in names}


@pytest.mark.parametrize("module,path", modules(), ids=[module for module, _ in modules()])
def test_a_module_imports_only_what_its_side_may(module: str, path: Path) -> None:
    side = where(module)
    wrong = []
    for target in imported(path):
        if target.split(".")[1:2] in (["fmu"], ["env"], ["models"]):
            wrong.append(target)
        if not target.startswith("modelicagym.vector"):
            continue
        to = where(target)
        if to == side or side.removeprefix("top:") in API:
            continue
        if to.startswith("top:") and to.removeprefix("top:") not in API:
            continue  # the public values every side may use
        if side.startswith("top:") or to not in MAY_IMPORT[side]:
            wrong.append(target)
    assert not wrong, f"{module} ({side}) imports {sorted(wrong)}"


@pytest.mark.parametrize("path", OUTSIDE, ids=[str(path.relative_to(VECTOR.parents[1])) for path in OUTSIDE])
def test_a_module_outside_the_pool_imports_only_its_exported_names(path: Path) -> None:
    private = sorted(target for target in imported(path) if target.startswith("modelicagym.vector") and target not in PUBLIC)
    assert not private, f"{path} imports the pool's private modules {private}: export what it needs in vector/api.py"
