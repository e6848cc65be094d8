"""Task files and config files: what a user writes to train on an FMU, read the same way by
``modelicagym try`` and ``examples/train_own_fmu.py``.

A task file is Python that defines ``config``, an `FMUEnv` config (the one ``modelicagym info``
prints, pasted, plus a reward, a termination, lambdas), and may define ``baseline``, a controller to
compare a trained policy with: a function ``baseline(observation) -> action``, or a class (made with
no arguments) or object with ``act(observation) -> action`` and, to start each episode afresh,
``reset()``. A config file is the same config as a JSON object.
In your own code: ``FMUEnv(load_task("my_task.py"))``, or `read_task_file` for the baseline too.
A relative ``fmu`` path in either (and a system's relative ``fmus`` paths) is relative to the file's folder, not to the folder the command
runs in: a task kept beside its FMU works from anywhere.
"""

from __future__ import annotations

import inspect
import json
import os
import runpy
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from modelicagym.errors import ConfigError, DataError, NotFoundError

__all__ = ["Controller", "TaskFile", "load_config_file", "load_task", "read_task_file", "relative_to"]


def relative_to(config: dict[str, Any], path: Path) -> dict[str, Any]:
    """``config`` with a relative ``fmu`` (and each relative path of a system's ``fmus``) made
    relative to the folder of the file ``path`` it was read from."""
    config = dict(config)
    if "fmu" in config:
        config["fmu"] = _resolved(config["fmu"], path, "fmu")
    setpoints = config.get("setpoints")
    if isinstance(setpoints, dict):  # a CSV table's path
        config["setpoints"] = {name: _resolved(value, path, f"setpoints[{name!r}]") if isinstance(value, str) else value
                               for name, value in setpoints.items()}
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


class Controller:
    """A task file's ``baseline``, as one thing to call: :meth:`reset` at every episode's start,
    :meth:`act` at every step."""

    def __init__(self, baseline: Any, where: str) -> None:
        if inspect.isclass(baseline):
            baseline = baseline()
        act = getattr(baseline, "act", None)
        if act is None and callable(baseline):
            act = baseline
        if not callable(act):
            raise ConfigError(f"{where}: baseline must be a function baseline(observation) -> action, or a class or "
                              f"object with act(observation) (and reset()), got {baseline!r}")
        self._act: Callable[[Any], Any] = act
        self._reset: Callable[[], Any] | None = getattr(baseline, "reset", None)

    def reset(self) -> None:
        """Start an episode (the baseline's own ``reset()``, if it has one)."""
        if self._reset is not None:
            self._reset()

    def act(self, observation: Any) -> Any:
        """The action for ``observation``."""
        return self._act(observation)


@dataclass(frozen=True)
class TaskFile:
    """What a task file defines: its ``config`` and its ``baseline`` controller (``None``: none)."""

    config: dict[str, Any]
    baseline: Controller | None


def read_task_file(path: str | os.PathLike[str]) -> TaskFile:
    """The ``config`` (its ``fmu`` relative to the file's folder) and ``baseline`` the task file
    ``path`` defines (the file is run as a script, once)."""
    path = _existing(path)
    names = runpy.run_path(str(path))
    config = names.get("config")
    if not isinstance(config, dict):
        raise ConfigError(f"{path}: a task file defines config = {{...}}, the FMUEnv config "
                          "`modelicagym info MY.fmu` prints (plus the task's reward and termination)")
    baseline = names.get("baseline")
    return TaskFile(relative_to(config, path), None if baseline is None else Controller(baseline, str(path)))


def load_task(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The ``config`` dict the task file ``path`` defines (the file is run as a script), its
    ``fmu`` relative to the file's folder: ``FMUEnv(load_task(path))`` or
    ``modelicagym.make_vec(load_task(path), n=8)``."""
    return read_task_file(path).config


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
