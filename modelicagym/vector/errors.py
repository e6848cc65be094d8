"""Exceptions raised by the pool, and the picklable record of an exception raised in a worker.

Every class here is a :class:`~modelicagym.errors.ModelicaGymError`. Misuse of the pool raises
subclasses of Gymnasium's own errors (``AlreadyPendingCallError``, ``NoAsyncCallError``,
``ClosedEnvironmentError``), so code written for :class:`gymnasium.vector.AsyncVectorEnv` catches
them as before. Failures of the environments or of their worker processes raise a
:class:`PoolError` that names the env index, and the worker's exit code / signal or the original
traceback.
"""

from __future__ import annotations

import functools
import multiprocessing
import pickle
import signal
import traceback
from dataclasses import dataclass

from gymnasium.error import AlreadyPendingCallError, ClosedEnvironmentError, NoAsyncCallError

from modelicagym.errors import ModelicaGymError

__all__ = [
    "CallerTimeoutError",
    "ConcurrentUseError",
    "EnvError",
    "NoPendingCallError",
    "PendingCallError",
    "PoolClosedError",
    "PoolError",
    "PoolMemoryError",
    "RemoteError",
    "RemoteTraceback",
    "SpaceMismatchError",
    "WorkerDiedError",
    "WorkerTimeoutError",
]


class RemoteTraceback(Exception):
    """Carries the formatted traceback of a worker-side exception; shown as the ``__cause__``."""

    def __init__(self, text: str) -> None:
        super().__init__(text)
        self.text = text

    def __str__(self) -> str:
        return self.text


class PendingCallError(ModelicaGymError, AlreadyPendingCallError):
    """A call was made while another one (e.g. ``step_async``) is still waiting to be collected."""


class NoPendingCallError(ModelicaGymError, NoAsyncCallError):
    """A ``*_wait`` was called without the ``*_async`` call it collects."""


class ConcurrentUseError(ModelicaGymError, RuntimeError):
    """A second thread called into a pool while another thread was inside a call to it; the pool
    is left as the first thread has it."""


class PoolClosedError(ModelicaGymError, ClosedEnvironmentError):
    """The pool was used after ``close()`` (or after a failure that stopped it)."""


class PoolMemoryError(ModelicaGymError, MemoryError):
    """The envs of a pool would not fit in the memory the machine has available (measured as
    they are created: `modelicagym.vector.slice.creation`)."""


class SpaceMismatchError(ModelicaGymError, RuntimeError):
    """The envs of one pool do not all have the same observation and action spaces."""


class PoolError(ModelicaGymError, RuntimeError):
    """A sub-environment or its worker process failed.

    Attributes:
        env_index: index of the sub-environment that failed (``None`` if it cannot be told).
        worker_index: index of the worker process that ran it.
    """

    def __init__(self, message: str, env_index: int | None, worker_index: int) -> None:
        super().__init__(message)
        self.env_index = env_index
        self.worker_index = worker_index


class EnvError(PoolError):
    """A sub-environment raised an exception in ``reset``/``step`` (or while being created).

    Where the original exception could be pickled, the error raised is also an instance of its
    type (``except ValueError`` catches an env's ``ValueError``, as with ``SyncVectorEnv``).

    Attributes:
        original: the exception object raised in the worker, if it could be pickled, else ``None``.
        remote_traceback: the worker-side traceback, formatted.
    """

    def __init__(
        self,
        message: str,
        env_index: int | None,
        worker_index: int,
        original: BaseException | None,
        remote_traceback: str,
    ) -> None:
        super().__init__(message, env_index, worker_index)
        self.original = original
        self.remote_traceback = remote_traceback


@functools.cache
def _env_error_type(original: type[BaseException]) -> type[EnvError]:
    """`EnvError` that is also an ``original`` (so ``except ValueError`` in user code still catches
    an env's ``ValueError``); plain `EnvError` where the two cannot be combined."""
    if not issubclass(original, Exception) or issubclass(original, EnvError):
        return EnvError
    try:
        return type(
            "EnvError",
            (EnvError, original),
            {"__module__": __name__, "__qualname__": f"EnvError[{original.__qualname__}]",
             "__str__": BaseException.__str__, "__repr__": BaseException.__repr__},
        )
    except TypeError:  # e.g. an instance lay-out conflict between built-in exception types
        return EnvError


class WorkerDiedError(PoolError):
    """A worker process exited unexpectedly (e.g. a segfault in native code).

    Attributes:
        exitcode: the process exit code; negative values are ``-signal`` (``-11`` is SIGSEGV).
    """

    def __init__(
        self, message: str, env_index: int | None, worker_index: int, exitcode: int | None
    ) -> None:
        super().__init__(message, env_index, worker_index)
        self.exitcode = exitcode


class WorkerTimeoutError(PoolError, multiprocessing.TimeoutError):
    """A worker did not answer within the timeout; it was killed.

    It is also a :class:`multiprocessing.TimeoutError`, what ``AsyncVectorEnv`` raises on timeouts.
    """


class CallerTimeoutError(ModelicaGymError, multiprocessing.TimeoutError):
    """The ``timeout`` given to a ``*_wait`` passed while the calling process ran its own envs.

    The call completed and the pool is usable; its results are dropped, as ``AsyncVectorEnv``
    drops them after a timeout. It is a :class:`multiprocessing.TimeoutError`, as there.
    """


def env_range(indices: range) -> str:
    """``"4-7"`` or ``"4"``: a contiguous range of env indices (a party's), for messages."""
    first, last = indices[0], indices[-1]
    return str(first) if first == last else f"{first}-{last}"


def describe_exitcode(exitcode: int | None) -> str:
    """Human-readable description of a process exit code (``-11`` -> ``killed by signal SIGSEGV``)."""
    if exitcode is None:
        return "still running"
    if exitcode < 0:
        try:
            name = signal.Signals(-exitcode).name
        except ValueError:
            name = str(-exitcode)
        return f"killed by signal {name} (exit code {exitcode})"
    return f"exited with code {exitcode}"


@dataclass(frozen=True)
class RemoteError:
    """An exception raised in a worker, captured so it can cross the pipe.

    The exception itself is pickled separately (``payload``) because arbitrary exception types may
    not be picklable; the type name, message and traceback text always are.
    """

    env_index: int | None
    type_name: str
    message: str
    traceback: str
    payload: bytes | None

    @classmethod
    def capture(cls, exc: BaseException, env_index: int | None) -> RemoteError:
        """Record ``exc`` (the exception being handled) raised while running env ``env_index``."""
        try:
            payload: bytes | None = pickle.dumps(exc)
            pickle.loads(payload)
        except Exception:
            payload = None
        return cls(
            env_index=env_index,
            type_name=type(exc).__qualname__,
            message=str(exc),
            traceback="".join(traceback.format_exception(exc)),
            payload=payload,
        )

    def original(self) -> BaseException | None:
        """The original exception object, or ``None`` if it could not be pickled."""
        if self.payload is None:
            return None
        original = pickle.loads(self.payload)
        original.__cause__ = RemoteTraceback(self.traceback)
        return original

    def to_env_error(self, worker_index: int, context: str, process: str | None = None) -> EnvError:
        """The :class:`EnvError` to raise in the parent; ``context`` says what was running, and
        ``process`` where (default ``"worker <worker_index>"``)."""
        where = "an env" if self.env_index is None else f"env {self.env_index}"
        process = process or f"worker {worker_index}"
        original = self.original()
        error_type = EnvError if original is None else _env_error_type(type(original))
        error = error_type(
            f"{where} ({process}) raised {self.type_name} in {context}: {self.message}",
            self.env_index,
            worker_index,
            original,
            self.traceback,
        )
        error.__cause__ = RemoteTraceback(self.traceback)
        return error
