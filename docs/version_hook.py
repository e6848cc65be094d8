"""A MkDocs hook: the site's footer shows the package's version, read from ``pyproject.toml``.

``pyproject.toml``'s ``version`` is the one source of the version (the package reads it back from
its installed metadata); the site is built from a clone, where that file is, so the footer shows
the version of the package built from the same tree.
"""

from __future__ import annotations

from importlib.metadata import version as installed_version
from pathlib import Path
from typing import Any

PYPROJECT = Path(__file__).resolve().parent.parent / "pyproject.toml"


def project_version() -> str:
    """``pyproject.toml``'s version; on Python 3.10, without ``tomllib``, the installed clone's
    metadata, made from that same file (``pip install -e ".[docs]"``)."""
    try:
        import tomllib
    except ModuleNotFoundError:
        return installed_version("modelicagym")
    with PYPROJECT.open("rb") as f:
        return tomllib.load(f)["project"]["version"]


def on_config(config: Any) -> Any:
    """Put ``modelicagym <version>``, the licence and the authors into the footer."""
    config["copyright"] = f"modelicagym {project_version()} · MIT License · © the modelicagym authors"
    return config
