"""Try an FMU's binary in a short-lived child process before its first load on this machine.

A third-party FMU can take down the process that loads it: a licensed FMU without its licence
logs "license file was not found" and segfaults inside ``fmi2Instantiate``; others call
``exit()`` or hang. So the first time a binary (by content: the shared library's SHA-256, and the
mode) is loaded on a machine, `check_first_load` runs `modelicagym.fmu.trial_child` in a child
process: load the library, instantiate, enter and exit initialization mode with the default
values, free. The child reports each FMI call before making it and each message the FMU logs, so
a crash, an ``exit()`` or a hang there becomes a one-line `LoadTrialError` naming the FMU, the
call and the FMU's last log lines, and the caller's process lives on.

The verdict is kept in the cache (``load-trials/<sha256>-<mode>.json``), so later loads in any
process read one small file, and a verdict known in this process costs nothing. Concurrent first
loads (a pool's workers) take the verdict's lock: one runs the trial, the others read its verdict.
A failed verdict is tried again when the FMU file changes (or when a hang was judged with a
shorter timeout than the one now set). A clean refusal in the child (a missing system library, a
failing ``fmi2Instantiate``) is not a verdict: the caller's own load raises it as usual. One in
initialization (with the default values; the caller may set others) is, as the binary survived
what the trial can tell.

The models shipped in ``modelicagym/models``, built from our own sources, skip the trial, and so
does every FMU on Windows (the trial needs POSIX process groups and ``select`` on a pipe).
"""

from __future__ import annotations

import json
import logging
import os
import select
import signal
import site
import subprocess
import sys
import tempfile
import time
from contextlib import ExitStack
from dataclasses import asdict, dataclass, field
from datetime import datetime, timezone
from pathlib import Path

from modelicagym.cache import FOLDER_MANIFEST, cache_dir, file_digest, locked
from modelicagym.disk import atomic_write
from modelicagym.errors import ConfigError
from modelicagym.fmu.build import bundled_fmus
from modelicagym.fmu.description import FMUDescription
from modelicagym.fmu.errors import LoadTrialError

__all__ = ["DEFAULT_TIMEOUT", "TIMEOUT_VARIABLE", "check_first_load", "mark_safe_here", "trial_timeout"]

logger = logging.getLogger(__name__)

TIMEOUT_VARIABLE = "MODELICAGYM_LOAD_TRIAL_TIMEOUT"
#: seconds one FMI call of the trial may take: generous, as some FMUs initialize for minutes
DEFAULT_TIMEOUT = 300.0
#: seconds the child may take to start Python and import the runtime, before its first FMI call
_STARTUP_SECONDS = 60.0
#: seconds after which a call still running in the trial is said (once), so that it is not taken for a hang
_NOTE_SECONDS = 10.0
#: seconds a child that closed its report pipe may take to exit
_EXIT_SECONDS = 10.0
_LOG_LINES = 3
_OUTPUT_LINES = 3
#: how much of what the child printed is read back (an FMU may print without end)
_OUTPUT_TAIL_BYTES = 1 << 16

#: the libraries known in this process to load safely, with their mode
_safe: set[tuple[Path, str]] = set()


def trial_timeout() -> float:
    """Seconds one FMI call may take in the trial: ``$MODELICAGYM_LOAD_TRIAL_TIMEOUT``, else 300."""
    value = os.environ.get(TIMEOUT_VARIABLE)
    if value is None:
        return DEFAULT_TIMEOUT
    try:
        seconds = float(value)
    except ValueError:
        seconds = float("nan")
    if not seconds > 0:
        raise ConfigError(f"${TIMEOUT_VARIABLE}={value!r} is not a positive number of seconds")
    return seconds


@dataclass
class Verdict:
    """What a trial found, as kept in the cache."""

    outcome: str
    """``"ok"``, ``"crashed"`` (a signal), ``"exited"`` (the process ended) or ``"hung"``."""
    fmu: str
    """The FMU file's identity when tried: a failed verdict holds only while it is the same."""
    function: str = ""
    detail: str = ""
    """The signal's name, the exit code, or the timeout in seconds."""
    messages: list[str] = field(default_factory=list)
    timeout: float = 0.0
    tried_at: str = ""

    def holds_for(self, fmu: str, timeout: float) -> bool:
        """Whether this verdict still answers for the FMU ``fmu`` under ``timeout``."""
        if self.outcome == "ok":
            return True
        return self.fmu == fmu and (self.outcome != "hung" or timeout <= self.timeout)


def check_first_load(description: FMUDescription, mode: str, library: Path) -> None:
    """Make sure ``library`` (``description``'s binary for ``mode``) is safe to load here.

    Nothing to do when its verdict is known; otherwise try it in a child process, under the
    verdict's lock. Raise `LoadTrialError` when the binary crashed, exited or hung there (now or
    in an earlier trial of the same FMU file).
    """
    if (library, mode) in _safe or not hasattr(os, "killpg"):  # POSIX only: process groups, select on a pipe
        return
    path = _verdict_path(description, mode, library)
    verdict = _read(path)
    if verdict is None and Path(description.path).resolve() in bundled_fmus():
        verdict = Verdict("ok", "built from modelicagym's own sources")
    if verdict is None or verdict.outcome != "ok":
        fmu, timeout = _fmu_identity(description), trial_timeout()
        if verdict is None or not verdict.holds_for(fmu, timeout):
            verdict = _tried_under_lock(description, mode, path, fmu, timeout)
    if verdict is None or verdict.outcome == "ok":
        _safe.add((library, mode))
        return
    raise _error(description, verdict, path)


def mark_safe_here(library: Path, mode: str) -> None:
    """Load ``library`` for ``mode`` in this process without a trial (the trial's own child process)."""
    _safe.add((library, mode))


def _tried_under_lock(description: FMUDescription, mode: str, path: Path, fmu: str, timeout: float) -> Verdict | None:
    """The verdict of a trial run now, or of the one a concurrent process just ran. Where the
    cache is read-only the trial runs without keeping its verdict."""
    with ExitStack() as stack:
        try:
            stack.enter_context(locked(path.with_name(path.name + ".lock")))
        except OSError as error:
            logger.warning("%s: the load trial's verdict cannot be kept in %s (%s)", description.name, path.parent,
                           error)
            return _run(description, mode, fmu, timeout)
        verdict = _read(path)
        if verdict is not None and verdict.holds_for(fmu, timeout):
            return verdict
        verdict = _run(description, mode, fmu, timeout)
        if verdict is not None:
            _write(path, verdict, description.name)
        return verdict


# -- the child -----------------------------------------------------------------------------------


def _run(description: FMUDescription, mode: str, fmu: str, timeout: float) -> Verdict | None:
    """Run the trial in a child process; ``None`` when it says nothing about the binary's safety
    (a clean refusal, which the caller's own load will raise, or a child that could not start)."""
    logger.info("%s: first load of this binary here; trying it in a child process", description.name)
    started = time.monotonic()
    report = _watch_child(description, mode, timeout)
    if report is None:
        return None
    logger.info("%s: load trial took %.2f s", description.name, time.monotonic() - started)
    verdict = Verdict("ok", fmu, timeout=timeout, tried_at=datetime.now(timezone.utc).isoformat(timespec="seconds"))
    if report.done:
        return verdict
    if report.refusal is not None and report.instantiated:  # survived instantiation; initialized with other values
        verdict.detail = f"initialization with the default values refused: {report.refusal}"
        return verdict
    if report.refusal is not None:  # may change with the machine (a system library, a licence installed)
        logger.debug("%s: the load trial ended in a clean refusal: %s", description.name, report.refusal)
        return None
    if not report.calls:
        logger.warning("%s: the load trial's child process failed before trying the FMU (exit code %s): %s; loading "
                       "without a trial", description.name, report.exit_code,
                       " | ".join(report.printed[-_OUTPUT_LINES:]))
        return None
    verdict.function = report.calls[-1]
    printed = [f"(printed) {line}" for line in report.printed[-_OUTPUT_LINES:]]
    verdict.messages = report.messages[-_LOG_LINES:] or printed
    if report.hung:
        verdict.outcome, verdict.detail = "hung", f"{timeout:g} s"
    elif report.exit_code < 0:
        verdict.outcome, verdict.detail = "crashed", _signal_name(-report.exit_code)
    else:
        verdict.outcome, verdict.detail = "exited", str(report.exit_code)
    return verdict


def _watch_child(description: FMUDescription, mode: str, timeout: float) -> _Report | None:
    """Start the child, follow its report, end it; ``None`` if it cannot start."""
    read_fd, write_fd = os.pipe()
    with tempfile.TemporaryFile() as output:
        try:
            process = subprocess.Popen(
                [sys.executable, "-m", "modelicagym.fmu.trial_child", str(write_fd), str(description.unzip_dir), mode],
                stdin=subprocess.PIPE, stdout=output, stderr=subprocess.STDOUT, pass_fds=(write_fd,),
                start_new_session=True, env=_child_environment(),
            )
        except OSError as error:
            os.close(read_fd)
            logger.warning("%s: the load trial's child process cannot start (%s); loading without a trial",
                           description.name, error)
            return None
        finally:
            os.close(write_fd)
        report = _Report()
        try:
            report.hung = not _follow(read_fd, report, timeout, description.name)
        finally:
            os.close(read_fd)
            report.exit_code = _end(process, wait=not report.hung)
        output.seek(max(0, output.seek(0, os.SEEK_END) - _OUTPUT_TAIL_BYTES))
        report.printed = output.read().decode("utf-8", errors="replace").splitlines()
    return report


def _child_environment() -> dict[str, str]:
    """This environment; where this modelicagym comes from a source folder rather than an installed
    package, that folder first on the path, so that the child runs the same code. Without Python's
    fault handler: its traceback of the trial's own frames would push what the FMU printed before
    it crashed out of the report's last lines."""
    environment = dict(os.environ)
    environment.pop("PYTHONFAULTHANDLER", None)
    root = Path(__file__).resolve().parents[2]
    installed = {Path(folder).resolve() for folder in (*site.getsitepackages(), site.getusersitepackages())}
    if root not in installed:
        environment["PYTHONPATH"] = os.pathsep.join(p for p in (str(root), environment.get("PYTHONPATH")) if p)
    return environment


class _Report:
    """What the child said (the calls it entered, the FMU's messages), printed, and how it ended."""

    def __init__(self) -> None:
        self.calls: list[str] = []
        self.messages: list[str] = []
        self.done = False
        self.instantiated = False
        self.refusal: str | None = None
        self.hung = True
        self.exit_code = 0
        """The child's exit code (``-signal`` when a signal ended it)."""
        self.printed: list[str] = []
        """What the child printed (stdout and stderr)."""
        self._partial = b""

    def take(self, chunk: bytes) -> bool:
        """Read a chunk of the child's lines; True when one was a call (its clock starts)."""
        lines = (self._partial + chunk).split(b"\n")
        self._partial = lines.pop()
        called = False
        for line in lines:
            kind, _, text = line.decode("utf-8", errors="replace").partition(" ")
            if kind == "call":
                self.calls.append(text)
                called = True
            elif kind == "log":
                self.messages.append(text)
            elif kind == "done":
                self.done = True
            elif kind == "instantiated":
                self.instantiated = True
            elif kind == "refused":
                self.refusal = text
        return called


def _follow(read_fd: int, report: _Report, timeout: float, fmu_name: str) -> bool:
    """Read the child's report until it closes it; False if a call outlasted ``timeout`` (or the
    child its start-up allowance). A call that takes long is said once, so that a slow first load
    does not look like a hang."""
    deadline = time.monotonic() + _STARTUP_SECONDS
    note = time.monotonic() + _NOTE_SECONDS
    while True:
        now = time.monotonic()
        if now >= deadline:
            return False
        if now >= note:
            if report.calls:
                logger.warning("%s: %s has taken %.0f s so far in the load trial (it gives up after %g s: $%s)",
                               fmu_name, report.calls[-1], now - (deadline - timeout), timeout, TIMEOUT_VARIABLE)
            note = deadline
        if select.select([read_fd], [], [], min(deadline, note) - now)[0]:
            chunk = os.read(read_fd, 65536)
            if not chunk:
                return True
            if report.take(chunk):
                deadline = time.monotonic() + timeout
                note = time.monotonic() + _NOTE_SECONDS


def _end(process: subprocess.Popen, wait: bool) -> int:
    """End the child: closing its stdin tells it its parent is done with it; one that closed its
    report (``wait``) may take a moment to exit, any other is killed. Whatever it started (its
    session's process group) is killed too, so that nothing is left behind. Returns its exit code."""
    assert process.stdin is not None
    process.stdin.close()
    try:
        process.wait(_EXIT_SECONDS if wait else 0)
    except subprocess.TimeoutExpired:
        pass
    try:
        os.killpg(process.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass
    return process.wait()


def _signal_name(number: int) -> str:
    try:
        return signal.Signals(number).name
    except ValueError:
        return f"signal {number}"


# -- verdicts ------------------------------------------------------------------------------------


def _verdict_path(description: FMUDescription, mode: str, library: Path) -> Path:
    return cache_dir() / "load-trials" / f"{_library_digest(description, library)[:24]}-{mode}.json"


def _library_digest(description: FMUDescription, library: Path) -> str:
    """The library's SHA-256: from the extraction's manifest (checked when the FMU was opened)
    when the FMU came as a file, else hashed."""
    if Path(description.path).is_file():
        try:
            manifest = json.loads((description.unzip_dir / FOLDER_MANIFEST).read_text(encoding="utf-8"))
            record = manifest["files"][library.relative_to(description.unzip_dir).as_posix()]
            if record["bytes"] == library.stat().st_size:
                return str(record["sha256"])
        except (OSError, ValueError, KeyError, TypeError):
            pass
    return file_digest(library)


def _fmu_identity(description: FMUDescription) -> str:
    """What changes when the FMU does: an FMU file's content key (its extraction's name), an
    extracted folder's files by name, size and modification time."""
    if Path(description.path).is_file():
        return description.unzip_dir.name
    files = sorted(p for p in Path(description.unzip_dir).rglob("*") if p.is_file())
    return repr([(p.relative_to(description.unzip_dir).as_posix(), p.stat().st_size, p.stat().st_mtime_ns)
                 for p in files])


def _read(path: Path) -> Verdict | None:
    try:
        return Verdict(**json.loads(path.read_text(encoding="utf-8")))
    except FileNotFoundError:
        return None
    except (OSError, ValueError, TypeError) as error:
        logger.warning("the load trial's verdict %s is unreadable (%s): trying the FMU again", path, error)
        return None


def _write(path: Path, verdict: Verdict, fmu_name: str) -> None:
    """Keep ``verdict`` (atomically); one that cannot be written (a full disk) holds for this process only."""
    try:
        with atomic_write(path) as f:
            f.write(json.dumps(asdict(verdict), indent=1))
    except OSError as error:
        logger.warning("%s: the load trial's verdict cannot be kept in %s (%s)", fmu_name, path, error)


def _error(description: FMUDescription, verdict: Verdict, path: Path) -> LoadTrialError:
    what = {
        "crashed": f"crashed ({verdict.detail}) in {verdict.function}",
        "exited": f"ended its process with exit({verdict.detail}) in {verdict.function}",
        "hung": f"did not return from {verdict.function} within {verdict.detail} (if it only initializes slowly, "
                f"set ${TIMEOUT_VARIABLE} to more seconds)",
    }[verdict.outcome]
    said = f"; its last log lines: {' | '.join(verdict.messages)}" if verdict.messages else "; it logged nothing"
    return LoadTrialError(
        f"{description.name} {what} when tried in a child process on {verdict.tried_at}{said}. It is not loaded, so "
        f"that it cannot take this process down; the verdict is kept in {path} until the FMU file changes "
        "(delete it to try again)", verdict.function, verdict.messages)

