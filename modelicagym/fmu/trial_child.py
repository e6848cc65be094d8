"""The child process of the load trial (`modelicagym.fmu.trial`): load an FMU's binary,
instantiate, initialize with the default values, free — and say everything as it happens.

Run as ``python -m modelicagym.fmu.trial_child <report fd> <extracted FMU folder> <mode>``. Each
line written to the report pipe is one of ``call <FMI function>`` (written before the call is
made, so the parent knows where the process died), ``log <message>`` (each message the FMU logs),
``instantiated`` (an instance was made), ``refused <error>`` (a clean error, which the caller's
own load will raise) and ``done``. The child ends when its parent closes its stdin (or dies), and
leaves by ``os._exit`` so that no exit handler of the FMU runs.
"""

from __future__ import annotations

import logging
import os
import sys
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

from modelicagym.fmu import trial
from modelicagym.fmu.binding import FMIBinding
from modelicagym.fmu.description import open_fmu
from modelicagym.fmu.fmi1 import FMI1Binding
from modelicagym.fmu.fmi2 import FMI2Binding
from modelicagym.fmu.fmi3 import FMI3Binding

_BINDINGS: dict[int, type[FMIBinding]] = {1: FMI1Binding, 2: FMI2Binding, 3: FMI3Binding}


class _Reporter(logging.Handler):
    """Writes report lines to the pipe at once (a crash may follow), and the FMU's log messages."""

    def __init__(self, fd: int) -> None:
        super().__init__(logging.DEBUG)
        self.fd = fd

    def line(self, kind: str, text: str = "") -> None:
        os.write(self.fd, f"{kind} {' '.join(text.split())}\n".encode("utf-8", errors="replace"))

    def emit(self, record: logging.LogRecord) -> None:
        self.line("log", record.getMessage())


class _Announced(dict):
    """A binding's function table whose functions report their name before each call."""

    def __init__(self, table: dict[str, Any], announce: Callable[[str], None]) -> None:
        super().__init__()
        self._table = table
        self._announce = announce

    def __missing__(self, name: str) -> Callable[..., Any]:
        function = self._table[name]

        def announced(*args: Any) -> Any:
            self._announce(name)
            return function(*args)

        self[name] = announced
        return announced


def _exit_with_parent() -> None:
    """End this process when the parent closes its end of stdin or dies (a daemon thread: ctypes
    releases the GIL during the FMU's calls, so it runs while one hangs)."""

    def watch() -> None:
        sys.stdin.buffer.read()
        os._exit(1)

    threading.Thread(target=watch, daemon=True).start()


def _report_messages(model_name: str, reporter: _Reporter) -> None:
    """Send every message the FMU logs to the report: those of its instances (`FMULog`'s logger)
    and those no instance claims (the runtime's own ``modelicagym.fmu`` logger)."""
    loggers = (logging.getLogger(f"modelicagym.fmu.{model_name}"), logging.getLogger("modelicagym.fmu"))
    names = {logger.name for logger in loggers}
    reporter.addFilter(lambda record: record.name in names)  # not the runtime's own modules' messages
    for logger in loggers:
        logger.addHandler(reporter)
        logger.setLevel(logging.DEBUG)
        logger.propagate = False


def try_fmu(unzip_dir: Path, mode: str, reporter: _Reporter) -> None:
    """Load, instantiate, initialize with the default values and free the FMU in ``unzip_dir``."""
    description = open_fmu(unzip_dir, validate=False)
    library = description.library_path(mode)
    trial.mark_safe_here(library, mode)  # this process is the trial
    _report_messages(description.model_name, reporter)
    reporter.line("call", f"loading {library.name} (dlopen)")
    binding = _BINDINGS[description.fmi_version](description, mode)
    binding.raw = _Announced(binding.raw, lambda name: reporter.line("call", name))
    binding.instantiate()
    reporter.line("instantiated")
    binding.enter_initialization(description.default_experiment.start_time, None, None)
    binding.exit_initialization()
    binding.free_instance()


def main(argv: list[str]) -> None:
    reporter = _Reporter(int(argv[0]))
    os.set_inheritable(reporter.fd, False)  # nothing the FMU starts keeps the report open
    _exit_with_parent()
    try:
        try_fmu(Path(argv[1]), argv[2], reporter)
    except Exception as error:  # a clean refusal, which the caller's own load will raise
        reporter.line("refused", f"{type(error).__name__}: {error}")
    else:
        reporter.line("done")
    os._exit(0)


if __name__ == "__main__":
    main(sys.argv[1:])
