"""Task files and config files: what a user writes to train on an FMU, read the same way by
``modelicagym try`` and ``examples/train_own_fmu.py``.

A task file is Python that defines ``config``, an `FMUEnv` config (the one ``modelicagym info``
prints, pasted, plus a reward, a termination, lambdas); a config file is the same as a JSON object.
A relative ``fmu`` path in either (and a system's relative ``fmus`` paths) is relative to the file's folder, not to the folder the command
runs in: a task kept beside its FMU works from anywhere.
"""

from __future__ import annotations

import json
import os
import runpy
from pathlib import Path
from typing import Any

from modelicagym.errors import ConfigError, DataError, NotFoundError

__all__ = ["load_config_file", "load_task", "relative_to"]


def relative_to(config: dict[str, Any], path: Path) -> dict[str, Any]:
    """``config`` with a relative ``fmu`` (and each relative path of a system's ``fmus``) made
    relative to the folder of the file ``path`` it was read from."""
    config = dict(config)
    if "fmu" in config:
        config["fmu"] = _resolved(config["fmu"], path, "fmu")
    fmus = config.get("fmus")
    if isinstance(fmus, dict):
        config["fmus"] = {name: {**source, "fmu": _resolved(source.get("fmu"), path, f"fmus[{name!r}]")}
                          if isinstance(source, dict) else _resolved(source, path, f"fmus[{name!r}]")
                          for name, source in fmus.items()}
    return config


def _resolved(fmu: Any, path: Path, key: str) -> Any:
    """``fmu`` relative to the folder of ``path`` when it is a relative path; else as it is."""
    if not isinstance(fmu, (str, os.PathLike)) or Path(fmu).expanduser().is_absolute():
        return fmu
    resolved = path.parent / fmu
    if not resolved.exists() and Path(fmu).exists():
        raise NotFoundError(f"{path}: its {key} {str(fmu)!r} is relative to the file's folder, and there is no "
                            f"{resolved} (it is in the current folder: write {os.path.relpath(fmu, path.parent)!r} "
                            "or an absolute path)")
    return str(resolved)


def _existing(path: str | os.PathLike[str]) -> Path:
    path = Path(path)
    if not path.is_file():
        raise NotFoundError(f"task file not found: {path} (resolved to {path.resolve()})")
    return path


def load_task(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The ``config`` dict the task file ``path`` defines (the file is run as a script), its
    ``fmu`` relative to the file's folder."""
    path = _existing(path)
    config = runpy.run_path(str(path)).get("config")
    if not isinstance(config, dict):
        raise ConfigError(f"{path}: a task file defines config = {{...}}, the FMUEnv config "
                          "`modelicagym info MY.fmu` prints (plus the task's reward and termination)")
    return relative_to(config, path)


def load_config_file(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The JSON object of FMUEnv keys in ``path``, its ``fmu`` (if any) relative to the file's folder."""
    path = _existing(path)
    try:
        config = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as error:
        raise DataError(f"{path}: not JSON ({error})") from error
    if not isinstance(config, dict):
        raise DataError(f"{path}: a config is a JSON object of FMUEnv keys, not {type(config).__name__}")
    return relative_to(config, path)
