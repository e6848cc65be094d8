"""The parent's handle on one worker process: start it, talk to it, notice its death, stop it."""

from __future__ import annotations

import enum
import logging
import sys
import tempfile
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from multiprocessing.connection import Connection, wait
from multiprocessing.context import BaseContext
from multiprocessing.reduction import send_handle

import gymnasium as gym
import numpy as np
from gymnasium.vector.utils import CloudpickleWrapper, clear_mpi_env_vars

from modelicagym.errors import ConfigError
from modelicagym.vector.errors import PoolError, WorkerDiedError, WorkerTimeoutError, describe_exitcode, env_range
from modelicagym.vector.wire.protocol import LIVENESS_INTERVAL, STARTUP_STAGES, Message, Reply, WorkerConfig
from modelicagym.vector.wire.sync import FutexSignal, SemaphoreSignal
from modelicagym.vector.worker.worker_process import run_worker

__all__ = ["WaitStatus", "WorkerHandle"]

logger = logging.getLogger(__name__)

#: seconds a worker gets to exit after SIGTERM before it is sent SIGKILL
_TERMINATE_GRACE = 1.0


class WaitStatus(enum.Enum):
    """How a wait for a worker's ``done`` signal ended."""

    DONE = "done"
    DIED = "died"
    TIMED_OUT = "timed out"


class WorkerHandle:
    """One worker process running the envs ``env_indices`` (a contiguous range); a
    `~modelicagym.vector.dispatch.party.Party` of the pool's commands.

    The handle outlives its process: :meth:`start` can be called again after :meth:`stop` to
    restart the worker with fresh envs, a fresh pipe and fresh signals.
    """

    process = None

    def __init__(
        self,
        index: int,
        env_indices: range,
        env_fns: Sequence[Callable[[], gym.Env]],
        ctx: BaseContext,
        config: WorkerConfig,
        stand_in: bool = False,
    ) -> None:
        self.index = index
        self.env_indices = env_indices
        #: a home party: the worker stands in for the calling process; it holds a copy of every env
        #: and steps those the shared ``in_caller`` array marks (`modelicagym.vector.layout.placement`)
        self.home = stand_in
        #: where its envs run, for messages
        self.where = f"worker {index}, standing in for the calling process" if stand_in else f"worker {index}"
        self._env_fns = CloudpickleWrapper(list(env_fns))
        self.ctx = ctx
        self._config = config
        self.process = None
        self.conn: Connection | None = None
        self.go: FutexSignal | SemaphoreSignal | None = None
        self.done: FutexSignal | SemaphoreSignal | None = None

    def __repr__(self) -> str:
        pid = None if self.process is None else self.process.pid
        return f"WorkerHandle({self.index}, envs {env_range(self.env_indices)}, pid={pid})"

    def start(self) -> None:
        """Start the worker process; it begins creating its envs at once."""
        parent_conn, child_conn = self.ctx.Pipe()
        if not self._config.shared_signals:
            self.go, self.done = SemaphoreSignal(self.ctx), SemaphoreSignal(self.ctx)
        self.process = self.ctx.Process(
            target=run_worker,
            name=f"modelicagym-pool-worker-{self.index}",
            args=(self.index, self._env_fns, self.env_indices.start, child_conn, self.go, self.done, self._config,
                  self.home),
            daemon=True,
        )
        self.conn = parent_conn
        try:
            with clear_mpi_env_vars(), main_module_hidden():
                self.process.start()
        except OSError as error:
            if "AF_UNIX path too long" not in str(error):
                raise
            raise ConfigError(
                f"the fork server's socket, in a folder of the temporary folder {tempfile.gettempdir()}, has a longer "
                "path than a Unix socket may (107 bytes): set TMPDIR to a shorter folder (e.g. /tmp), or pass "
                "start_method='spawn'"
            ) from error
        child_conn.close()

    def is_alive(self) -> bool:
        return self.process is not None and self.process.is_alive()

    def send(self, message: Message) -> None:
        """Send a pickled message on the pipe."""
        self.conn.send(message)

    def send_fd(self, fd: int) -> None:
        """Pass a file descriptor to the worker (``SCM_RIGHTS`` over the pipe's socket)."""
        send_handle(self.conn, fd, self.process.pid)

    def receive(self, deadline: float | None, env_index: int | None, doing: str) -> Message:
        """The next message from the worker.

        Raises :class:`WorkerDiedError` if the worker dies first, :class:`WorkerTimeoutError` if
        ``deadline`` (a ``time.monotonic()`` value, ``None`` for none) passes first.
        """
        timeout = None if deadline is None else max(deadline - time.monotonic(), 0.0)
        ready = wait([self.conn, self.process.sentinel], timeout)
        if self.conn in ready:
            try:
                return self.conn.recv()
            except (EOFError, OSError):
                pass
        elif not ready:
            raise self.timeout_error(env_index, doing)
        raise self.died_error(env_index, doing)

    def post(self, code: int, message: Message | None, payload: bytes | None, slots: np.ndarray | None) -> None:
        """Write ``code`` into the worker's slot (unless ``slots`` is ``None``: it holds it), wake
        it, then send ``payload`` (the pickled ``message``): waking first means a large message
        can never fill the pipe while its reader sleeps. A worker that died meanwhile makes the
        send fail; :meth:`answer` reports that."""
        if slots is not None:
            slots[self.index] = code
        self.go.post()
        if payload is not None:
            try:
                self.conn.send_bytes(payload)
            except OSError:
                logger.debug("worker %d: pipe broken while sending %s", self.index, message.kind.value)

    def poll_done(self, spin_time: float, block: float) -> bool:
        """Whether the worker posted ``done`` (consuming the post), waiting up to ``spin_time`` + ``block``."""
        return self.done.wait(spin_time, block)

    def repost(self) -> None:
        """Post ``done`` again after :meth:`poll_done` consumed it."""
        self.done.post()

    def answer(self, deadline: float | None, doing: str, reply: np.ndarray,
               current_env: np.ndarray) -> tuple[Message | None, PoolError | None]:
        """Wait for ``done``, then :meth:`read_reply`; or the failure."""
        status = self.wait_done(self._config.spin_time, deadline)
        if status is not WaitStatus.DONE:
            return None, self.failure(status, int(current_env[self.index]), doing)
        return self.read_reply(deadline, doing, reply, current_env)

    def read_reply(self, deadline: float | None, doing: str, reply: np.ndarray,
                   current_env: np.ndarray) -> tuple[Message | None, PoolError | None]:
        """Once the worker is done: its reply message, if its slot says one follows; or the failure."""
        if reply[self.index] != Reply.MESSAGE:
            return None, None
        try:
            return self.receive(deadline, int(current_env[self.index]), doing), None
        except PoolError as error:
            return None, error

    def wait_done(self, spin_time: float, deadline: float | None) -> WaitStatus:
        """Wait until the worker posts ``done``; how the wait ended.

        Spins for up to ``spin_time`` first, then blocks in slices of ``LIVENESS_INTERVAL`` to
        check that the process lives; ``deadline`` is a ``time.monotonic()`` value or ``None``.
        """
        if self.done.wait(spin_time, _slice(deadline)):
            return WaitStatus.DONE
        while True:
            if not self.process.is_alive():
                return WaitStatus.DONE if self.done.wait(0.0, 0.0) else WaitStatus.DIED
            if deadline is not None and time.monotonic() >= deadline:
                return WaitStatus.TIMED_OUT
            if self.done.wait(0.0, _slice(deadline)):
                return WaitStatus.DONE

    def failure(self, status: WaitStatus, env_index: int | None, doing: str) -> PoolError:
        """The error for a :meth:`wait_done` status other than ``DONE``."""
        if status is WaitStatus.DIED:
            return self.died_error(env_index, doing)
        return self.timeout_error(env_index, doing)

    def died_error(self, env_index: int | None, doing: str) -> WorkerDiedError:
        """The error reporting that this worker died while running ``doing`` on ``env_index``."""
        self.process.join(_TERMINATE_GRACE)
        exitcode = self.process.exitcode
        where = f"env {env_index}" if env_index is not None else f"envs {env_range(self.env_indices)}"
        # a worker exits by itself only when told to close: an exit status means the env's code called exit()
        cause = "; code in the env called exit()" if exitcode is not None and exitcode >= 0 else ""
        return WorkerDiedError(
            f"worker {self.index} (pid {self.process.pid}) {describe_exitcode(exitcode)} "
            f"during {doing} of {where}{cause}",
            env_index,
            self.index,
            exitcode,
        )

    def timeout_error(self, env_index: int | None, doing: str) -> WorkerTimeoutError:
        """The error reporting that this worker did not finish ``doing`` in time, with the limit
        and the option that sets it; kills the worker."""
        self.stop()
        where = f"env {env_index}" if env_index is not None else f"envs {env_range(self.env_indices)}"
        option = "startup_timeout" if doing in STARTUP_STAGES else "step_timeout"
        limit = getattr(self._config, option)
        within = "in time" if limit is None else f"within {option}={limit:g} s"
        hint = "" if limit is None else f" (a larger {option}, or None, waits longer)"
        return WorkerTimeoutError(
            f"worker {self.index} did not finish {doing} of {where} {within}; it was killed{hint}",
            env_index,
            self.index,
        )

    def join(self, timeout: float | None) -> bool:
        """Wait for the process to exit by itself; ``True`` if it has."""
        self.process.join(timeout)
        return self.process.exitcode is not None

    def stop(self) -> None:
        """Make sure the process is gone: SIGTERM, then SIGKILL after a grace period."""
        if self.process is None or self.process.pid is None:
            return
        if self.process.is_alive():
            self.process.terminate()
            self.process.join(_TERMINATE_GRACE)
        if self.process.is_alive():
            logger.warning("worker %d (pid %d) ignored SIGTERM; killing it", self.index, self.process.pid)
            self.process.kill()
            self.process.join()

    def release(self) -> None:
        """Stop the process and free the pipe and signals; :meth:`start` may follow."""
        self.stop()
        if self.process is not None:
            self.process.close()
        if self.conn is not None:
            self.conn.close()
        for signal_ in (self.go, self.done):
            if signal_ is not None:
                signal_.close()
        self.process = self.conn = self.go = self.done = None


@contextmanager
def main_module_hidden() -> Iterator[None]:
    """Start processes without the caller's main module.

    ``spawn`` and ``forkserver`` re-run the caller's main script in every new process (as
    ``__mp_main__``) so that functions defined there can be unpickled. The pool never needs that:
    env fns travel with cloudpickle, by value. And it breaks the ways people run Python: a script
    without an ``if __name__ == "__main__":`` guard would start a pool again inside each worker, a
    script read from stdin or typed in a notebook has no file to re-run. So, while a worker starts,
    the main module shows multiprocessing neither a file nor a module spec to re-run.
    """
    main = sys.modules.get("__main__")
    saved = {name: main.__dict__[name] for name in ("__file__", "__spec__") if main and name in main.__dict__}
    try:
        if main is not None:
            main.__dict__.pop("__file__", None)
            main.__spec__ = None
        yield
    finally:
        if main is not None:
            main.__dict__.pop("__spec__", None)
            main.__dict__.update(saved)


def _slice(deadline: float | None) -> float:
    """How long to block before the next liveness check."""
    if deadline is None:
        return LIVENESS_INTERVAL
    return min(max(deadline - time.monotonic(), 0.0), LIVENESS_INTERVAL)
