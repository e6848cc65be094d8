"""Tests of what needs an optional extra (pyproject's ``[project.optional-dependencies]``) skip,
saying which, when it is not installed; the core tests run without any.

``@requires("plots")`` marks a test (or ``pytestmark = requires("plots")`` a module);
``ray = imported("ray")`` imports a module at a test module's top, or skips the module.
"""

from __future__ import annotations

import importlib.util
from types import ModuleType

import pytest

#: each extra's modules a test may need (pyproject.toml's optional dependencies, by import name)
EXTRAS = {
    "plots": ("matplotlib",),
    "progress": ("tqdm",),
    "notebook": ("nbclient", "nbformat", "ipykernel"),
    "ray": ("ray",),
    "rl": ("stable_baselines3", "torch"),
    "docs": ("mkdocs", "material", "mkdocstrings", "ruff"),
}
#: how to install an extra, when ``pip install 'modelicagym[extra]'`` is not the whole story
_INSTALL = {"rl": "pip install torch==2.13.0 (a CPU build), then pip install 'modelicagym[rl]'"}


def _missing(module: str) -> bool:
    return importlib.util.find_spec(module) is None


def _reason(extra: str, module: str) -> str:
    install = _INSTALL.get(extra, f"pip install 'modelicagym[{extra}]'")
    return f"the {extra} extra is not installed (no {module}): {install}"


def _extra_of(module: str) -> str:
    top = module.partition(".")[0]
    for extra, modules in EXTRAS.items():
        if top in modules:
            return extra
    raise KeyError(f"{module} belongs to no extra of EXTRAS (tests/extras.py)")


def requires(*extras: str) -> pytest.MarkDecorator:
    """A mark that skips the test unless every module of ``extras`` is installed."""
    missing = [(extra, module) for extra in extras for module in EXTRAS[extra] if _missing(module)]
    return pytest.mark.skipif(bool(missing), reason=_reason(*missing[0]) if missing else "")


def imported(module: str) -> ModuleType:
    """``module`` (of an extra), imported; skips the calling test or test module without it."""
    return pytest.importorskip(module, reason=_reason(_extra_of(module), module))
