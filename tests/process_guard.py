"""Which tests start processes: the ``processes`` marker, and the guard that keeps it true.

The fast subset (``pytest -m "not processes"``, docs/development/testing.md) is every test that starts no
process: no pool worker, fork server or resource tracker, no Ray, no load trial in a child, no
subprocess. The guard watches every way a process starts (``os.fork``/``posix_spawn``/``system``,
``subprocess.Popen``, ``multiprocessing``'s ``Process.start`` and its fork-server/resource-tracker
spawns) in every run, the full one too, and fails a test that starts one without the marker. So a
new test lands in the right subset without anyone deciding it, or its run says what it started.

Filling the developer's cache is not counted: the test FMUs and the native step library are
compiled on first use into the content-hashed cache (``modelicagym.fmu.build``,
``modelicagym.native.library``), and a test FMU's binary is tried in a child process on its first
load (`modelicagym.fmu.trial`, its verdict kept there), once per machine, whichever test gets there
first. So the first run on a machine starts those; later runs of the fast subset start nothing. A
test that compiles or tries an FMU outside that cache (a cache of its own) does it every run, and
is counted.
"""

from __future__ import annotations

import multiprocessing.process
import multiprocessing.util
import os
import subprocess
import sys
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

from modelicagym.cache import cache_dir

MARKER = "processes"
#: modules whose process starts fill the cache (a compiler, CMake, a first-load trial), not the test's own work
CACHE_BUILDERS = ("modelicagym.fmu.build", "modelicagym.native.library", "modelicagym.fmu.trial")
#: (owner, attribute) of every function through which this process starts another
STARTS: tuple[tuple[Any, str], ...] = (
    *((os, name) for name in ("fork", "forkpty", "posix_spawn", "posix_spawnp", "system") if hasattr(os, name)),
    (subprocess.Popen, "_execute_child"),
    (multiprocessing.process.BaseProcess, "start"),
    (multiprocessing.util, "spawnv_passfds"),
)


@dataclass
class ProcessGuard:
    """Records the process starts of the test being run (``None`` between tests)."""

    test: str | None = None
    starts: list[str] = field(default_factory=list)
    #: the developer's cache, where a build is a cache fill (as the session starts: tests may point elsewhere)
    cache: str = field(default_factory=lambda: str(cache_dir()))

    def install(self, assign: Callable[[Any, str, Any], None] = setattr) -> None:
        """Wrap every function of `STARTS` (for the whole session; ``assign``: how, e.g. ``monkeypatch.setattr``)."""
        for owner, name in STARTS:
            assign(owner, name, self._watched(getattr(owner, name), f"{getattr(owner, '__name__', owner)}.{name}"))

    def begin(self, test: str) -> None:
        self.test, self.starts = test, []

    def end(self) -> list[str]:
        """The starts recorded since `begin`, each as what started it and where in the tests."""
        starts, self.test, self.starts = self.starts, None, []
        return starts

    def _watched(self, function: Callable[..., Any], name: str) -> Callable[..., Any]:
        def watched(*args: Any, **kwargs: Any) -> Any:
            if self.test is not None and not (_building() and _mentions(args, self.cache)):
                self.starts.append(f"{name}{_command(args)}, from {_test_frame()}")
            return function(*args, **kwargs)

        watched.__wrapped__ = function  # type: ignore[attr-defined]
        return watched


def _building() -> bool:
    """Whether the call comes from a module of `CACHE_BUILDERS`."""
    frame = sys._getframe(2)
    while frame is not None:
        if frame.f_globals.get("__name__") in CACHE_BUILDERS:
            return True
        frame = frame.f_back
    return False


def _mentions(args: tuple[Any, ...], folder: str) -> bool:
    """Whether a path inside ``folder`` is among ``args`` (or the command lists among them)."""
    inside = Path(folder).resolve()
    for arg in args:
        for item in arg if isinstance(arg, (list, tuple)) else (arg,):
            path = Path(item) if isinstance(item, (str, os.PathLike)) else None
            if path is not None and path.is_absolute() and path.resolve().is_relative_to(inside):
                return True
    return False


def _command(args: tuple[Any, ...]) -> str:
    """`` (cmake -S ...)``: the start of the command among ``args``, if one is there."""
    for arg in args:
        if isinstance(arg, (list, tuple)) and arg and all(isinstance(a, (str, os.PathLike)) for a in arg):
            return f" ({' '.join(map(str, arg))[:80]})"
    return ""


def _test_frame() -> str:
    """The innermost line of the call stack in the tests folder (``file:line``), else the innermost line."""
    tests = os.path.dirname(os.path.abspath(__file__))
    stack = [frame for frame in traceback.extract_stack() if frame.filename != os.path.abspath(__file__)]
    for frame in reversed(stack):
        if frame.filename.startswith(tests + os.sep):
            return f"{os.path.relpath(frame.filename, tests)}:{frame.lineno}"
    return f"{stack[-1].filename}:{stack[-1].lineno}" if stack else "?"


def failure_message(test: str, starts: list[str]) -> str:
    """What a test that started processes without the marker is told."""
    listed = "\n".join(f"  {start}" for start in dict.fromkeys(starts))
    return (f"{test} started processes but is not marked '{MARKER}', so the fast subset "
            f"(-m 'not {MARKER}') would run it: mark it @pytest.mark.{MARKER} (or its module with pytestmark), "
            f"or add its folder to PROCESS_FOLDERS in tests/conftest.py. Started:\n{listed}")
