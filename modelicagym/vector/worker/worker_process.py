"""The worker process: creates a contiguous slice of the envs and steps them on command.

Life of a worker:

1. create its envs (calling the env fns here, never in the parent: FMU instances hold ctypes handles
   that cannot be pickled), check they share their spaces, and send a ``ready`` message describing
   them;
2. receive the layout of the shared memory and its file descriptor, map it, answer ``ok``;
3. loop: wait for ``go``, run the command (step / reset / a message), write results into shared
   memory, answer (count the step's barrier down and post ``done``: ``AnswerSignal``) and send a
   reply on the pipe only if there is one (see ``protocol``).
   A worker whose envs step natively waits and steps in C
   (:class:`~modelicagym.vector.worker.native_server.NativeServer`) and comes back to Python only for
   what Python must do.

SIGINT is ignored: on Ctrl-C the parent, not every worker, decides what happens (it stops the pool).
The worker exits when told to close, or when its parent dies: its command loop notices between
commands, and a watchdog thread (:func:`exit_with_parent`) ends the process even while an env is
stuck inside a C call (ctypes releases the GIL) or a Python loop.
"""

from __future__ import annotations

import logging
import multiprocessing
import os
import signal
import threading
from multiprocessing.connection import Connection, wait
from multiprocessing.reduction import ForkingPickler, recv_handle

import gymnasium as gym
from gymnasium.vector.utils import CloudpickleWrapper

from modelicagym.native.abi import SERVE_PYTHON_STEP, SERVE_TIMEOUT
from modelicagym.vector.errors import PoolMemoryError, RemoteError
from modelicagym.vector.slice.creation import EnvCreator, close_envs
from modelicagym.vector.slice.env_slice import EnvSlice, describe_envs
from modelicagym.vector.wire.buffers import SharedBuffers
from modelicagym.vector.wire.protocol import LIVENESS_INTERVAL, Command, Kind, Message, Reply, WorkerConfig
from modelicagym.vector.wire.sync import AnswerSignal, GoSignal, SemaphoreSignal, pool_native_library
from modelicagym.vector.worker.native_server import NativeServer

__all__ = ["run_worker"]

logger = logging.getLogger(__name__)

#: the exit code of a worker whose parent died (its watchdog ended it)
PARENT_DIED_EXIT_CODE = 70


def run_worker(
    worker_index: int,
    env_fns: CloudpickleWrapper,
    first_env: int,
    conn: Connection,
    go: SemaphoreSignal | None,
    done: SemaphoreSignal | None,
    config: WorkerConfig,
    stand_in: bool = False,
) -> None:
    """Entry point of a worker process (the ``target`` of its ``multiprocessing.Process``);
    ``stand_in``: it steps the envs marked ``in_caller``, as the calling process would."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    keep_to(config.cpus)
    exit_with_parent()
    envs: list[gym.Env] = []
    try:
        share = len(env_fns.fn) / config.num_envs if config.num_envs else 1.0
        creator = EnvCreator(first_env, f"worker {worker_index}", share)
        try:
            envs = creator.create(env_fns.fn)
            description = describe_envs(envs, first_env, config.observation_mode)
        except PoolMemoryError as exc:
            conn.send(Message(Kind.ERROR, RemoteError.capture(exc, None)))
            return
        except BaseException as exc:  # SystemExit too: the caller learns why, not only an exit code
            failed = first_env + creator.created if creator.created < len(env_fns.fn) else None
            conn.send(Message(Kind.ERROR, RemoteError.capture(exc, failed)))
            return
        conn.send(Message(Kind.READY, description))
        envs_slice = EnvSlice(envs, first_env, worker_index, config.autoreset_mode, caller=stand_in)
        worker = Worker(worker_index, envs_slice, conn, go, done, config)
        worker.attach()
        worker.serve()
    except (EOFError, BrokenPipeError, ConnectionResetError):
        logger.debug("worker %d: pipe to the parent closed, exiting", worker_index)
    finally:
        close_envs(envs)


def keep_to(cpus: tuple[int, ...] | None) -> None:
    """Keep this process on the pool's CPUs (`modelicagym.vector.layout.affinity`), before it starts
    any thread, so that its threads keep to them too (``None``: it runs where its parent may)."""
    if cpus is None:
        return
    try:
        os.sched_setaffinity(0, cpus)
    except OSError as error:  # a CPU gone offline since the pool chose it
        logger.info("a worker stays where its parent may run, not on CPUs %s: %s", cpus, error)


def exit_with_parent() -> None:
    """End this process as soon as the process that started it dies, whatever the main thread is
    doing: a daemon thread waits on the parent's sentinel (with ``forkserver`` and ``spawn`` too,
    where the operating system's parent is the fork server) and calls ``os._exit``."""
    parent = multiprocessing.parent_process()
    if parent is None:
        return

    def watch() -> None:
        wait([parent.sentinel])
        os._exit(PARENT_DIED_EXIT_CODE)

    threading.Thread(target=watch, name="modelicagym-parent-watch", daemon=True).start()


class Worker:
    """Runs the commands of the parent on this process's envs (see the module docstring)."""

    def __init__(
        self,
        index: int,
        envs: EnvSlice,
        conn: Connection,
        go: SemaphoreSignal | None,
        done: SemaphoreSignal | None,
        config: WorkerConfig,
    ) -> None:
        self._index = index
        self._envs = envs
        self._conn = conn
        self._go = go
        self._done = done
        self._config = config
        self._buffers: SharedBuffers | None = None
        self._server: NativeServer | None = None
        self._parent = multiprocessing.parent_process()
        self._parent_pid = os.getppid()

    def attach(self) -> None:
        """Receive and map the shared memory, then confirm."""
        spec, needs_reset = self._conn.recv().data
        fd = recv_handle(self._conn)
        try:
            self._buffers = SharedBuffers.attach(spec, fd)
        finally:
            os.close(fd)
        self._envs.attach(self._buffers, needs_reset)
        if self._config.shared_signals:
            library, buffers, index = pool_native_library(), self._buffers, self._index
            self._go = GoSignal(library, buffers.signal_address(index, SharedBuffers.GO), buffers.barrier_address, index)
            self._done = AnswerSignal(library, buffers.signal_address(index, SharedBuffers.DONE), buffers.barrier_address)
            if self._envs.native is not None:
                slot = slice(index, index + 1)
                self._server = NativeServer(
                    self._envs.native, self._go.address, self._done.address, buffers.barrier_address, index,
                    buffers.command[slot], buffers.reply[slot], Command.STEP, buffers.go_spin_ns, LIVENESS_INTERVAL,
                    self._go.waiter,
                )
        self._conn.send(Message(Kind.OK))

    def serve(self) -> None:
        """Run commands until told to close (the envs are closed on the way out) or the parent dies."""
        while (code := self._next_command()) is not None:
            if code == SERVE_PYTHON_STEP:
                self._answer(self._envs.finish_native_step())
                continue
            message = self._conn.recv() if code == Command.MESSAGE else None
            if message is not None and message.kind is Kind.CLOSE:
                self._answer(None)
                return
            self._answer(self._envs.run(code, message))

    def _next_command(self) -> int | None:
        """The next command code (or `SERVE_PYTHON_STEP`); ``None`` if the parent died meanwhile."""
        if self._server is None:
            return int(self._buffers.command[self._index]) if self._wait_for_command() else None
        while (code := self._server.next_command()) == SERVE_TIMEOUT:
            if not self._parent_alive():
                logger.debug("worker %d: parent died, exiting", self._index)
                return None
        return code

    def _wait_for_command(self) -> bool:
        """Wait for ``go``; ``False`` if the parent died meanwhile."""
        if self._go.wait(self._buffers.go_spin_ns[0] * 1e-9, LIVENESS_INTERVAL):
            return True
        while not self._go.wait(0.0, LIVENESS_INTERVAL):
            if not self._parent_alive():
                logger.debug("worker %d: parent died, exiting", self._index)
                return False
        return True

    def _parent_alive(self) -> bool:
        # getppid notices at once when a fork-started worker is orphaned; the parent sentinel
        # covers forkserver/spawn, whose parent process is not the pool's process.
        if os.getppid() != self._parent_pid:
            return False
        return self._parent is None or self._parent.is_alive()

    def _answer(self, reply: Message | None) -> None:
        """Answer (``done``, through the step's barrier); then send the reply, pickled first so a pickling error becomes the reply
        (a ``call_error`` for results of ``call``, which leaves the env usable; else an ``error``)."""
        if reply is None:
            self._buffers.reply[self._index] = Reply.NONE
            self._done.post()
            return
        try:
            data = ForkingPickler.dumps(reply)
        except Exception as exc:
            kind = Kind.CALL_ERROR if reply.kind is Kind.RESULTS else Kind.ERROR
            data = ForkingPickler.dumps(Message(kind, RemoteError.capture(exc, None)))
        self._buffers.reply[self._index] = Reply.MESSAGE
        self._done.post()
        self._conn.send_bytes(data)
