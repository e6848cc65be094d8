"""FMU log messages into Python `logging`, instead of stdout.

An FMU reports through a logger callback. FMI 2.0's callback is variadic, which ctypes cannot
receive, so fmpy's native proxy formats the message first; that proxy keeps one process-wide
target, so a single callback per FMI version serves every instance here and routes each message
by the environment pointer the instance was created with. FMI 1.0's callback has the same
signature but passes the instance (component) pointer where FMI 2.0 passes the environment: an
FMI 1.0 instance is routed by its component once instantiated (`FMULog.route_component`), and
while it is being instantiated by `FMULog.instantiating`. Each instance keeps its last messages
so that an FMI error can be reported with the FMU's own explanation.
"""

from __future__ import annotations

import itertools
import logging
from collections import deque
from collections.abc import Iterator
from contextlib import contextmanager
from ctypes import c_void_p

from fmpy.fmi2 import fmi2CallbackLoggerTYPE
from fmpy.fmi3 import fmi3LogMessageCallback

from modelicagym.fmu.errors import WARNING, status_name

_LEVELS = (logging.DEBUG, logging.WARNING, logging.WARNING, logging.ERROR, logging.CRITICAL, logging.INFO)

_routes: dict[int, FMULog] = {}
_keys = itertools.count(1)
_instantiating: list[FMULog] = []


class FMULog:
    """The log of one FMU instance: forwards to ``logging`` and remembers recent messages."""

    def __init__(self, fmu_name: str, instance_name: str, keep: int = 20):
        self.logger = logging.getLogger(f"modelicagym.fmu.{fmu_name}")
        self.instance_name = instance_name
        self.recent: deque[str] = deque(maxlen=keep)
        self.key = next(_keys)
        self._components: list[int] = []
        _routes[self.key] = self

    @property
    def environment(self) -> c_void_p:
        """The pointer handed to the FMU at instantiation; it comes back with every message."""
        return c_void_p(self.key)

    def emit(self, status: int, category: str, message: str) -> None:
        level = _LEVELS[status] if 0 <= status < len(_LEVELS) else logging.ERROR
        if status >= WARNING:
            self.recent.append(f"[{status_name(status)}] {message}")
        self.logger.log(level, "%s [%s] %s", self.instance_name, category, message)

    def take_recent(self) -> list[str]:
        """The messages logged with a non-OK status since the last call, oldest first."""
        messages = list(self.recent)
        self.recent.clear()
        return messages

    def route_component(self, component: int | None) -> None:
        """Route messages whose first argument is ``component`` here (FMI 1.0 loggers get the
        instance pointer); `unroute_components` before the instance is freed."""
        if component:
            _routes[component] = self
            self._components.append(component)

    def unroute_components(self) -> None:
        for component in self._components:
            if _routes.get(component) is self:
                del _routes[component]
        self._components.clear()

    @contextmanager
    def instantiating(self) -> Iterator[None]:
        """Messages of instances not yet routed go here meanwhile (FMI 1.0 instantiation)."""
        _instantiating.append(self)
        try:
            yield
        finally:
            _instantiating.remove(self)

    def close(self) -> None:
        self.unroute_components()
        _routes.pop(self.key, None)


def _decode(text: bytes | None) -> str:
    return text.decode("utf-8", errors="replace") if text else ""


def _route(environment: int | None, status: int, category: bytes | None, message: bytes | None) -> None:
    log = _routes.get(environment or 0)
    if log is None and _instantiating:
        log = _instantiating[-1]
    if log is None:
        logging.getLogger("modelicagym.fmu").log(
            _LEVELS[status] if 0 <= status < len(_LEVELS) else logging.ERROR, "%s", _decode(message)
        )
    else:
        log.emit(status, _decode(category), _decode(message))


def _fmi2_logger(environment: int | None, instance_name: bytes, status: int, category: bytes, message: bytes) -> None:
    """FMI 2.0's logger (environment first) and FMI 1.0's (component first): same C signature."""
    _route(environment, status, category, message)


def _fmi3_logger(environment: int | None, status: int, category: bytes, message: bytes) -> None:
    _route(environment, status, category, message)


FMI2_LOGGER = fmi2CallbackLoggerTYPE(_fmi2_logger)
#: FMI 1.0's logger type is FMI 2.0's (ctypes caches function types by signature).
FMI1_LOGGER = FMI2_LOGGER
FMI3_LOGGER = fmi3LogMessageCallback(_fmi3_logger)

