"""The parties a pool's commands reach: a worker process, or the calling process's own slice.

The dispatcher (:mod:`~modelicagym.vector.dispatch.dispatcher`, for whole and partial batches alike) talks
to every party through one protocol, :class:`Party`: post a command, wait until it is done, take
its answer. A worker (`~modelicagym.vector.dispatch.worker_handle.WorkerHandle`) gets its command through
its shared slot and its ``go`` signal and runs it in its own process; the calling process's slice
(:class:`CallerParty`) keeps the command until the dispatcher's ``run_own_slice`` runs it, after
waking the workers and before waiting for them, so the caller works while they do. Either answers
the same way: the reply slot says whether a message follows. Waiting never runs anything.
"""

from __future__ import annotations

from typing import NamedTuple, Protocol

import numpy as np

from modelicagym.vector.dispatch.caller_watch import CallerWatch
from modelicagym.vector.errors import PoolError, env_range
from modelicagym.vector.slice.env_slice import EnvSlice
from modelicagym.vector.wire.buffers import SharedBuffers
from modelicagym.vector.wire.protocol import Command, Message, Reply

__all__ = ["CallerParty", "Outcome", "Party", "PendingCommand"]


class Party(Protocol):
    """What the dispatcher needs of a party: its slot, its envs, and the command round trip."""

    #: its slot in the shared ``command``/``reply`` arrays (the calling process's is the last)
    index: int
    #: the contiguous range of env indices it holds
    env_indices: range
    #: it is a home party: the calling process, or the worker standing in for it; it steps the
    #: envs the shared ``in_caller`` array marks
    home: bool
    #: where its envs run, for messages: ``"worker 2"``, ``"the calling process"``...
    where: str

    def post(self, code: int, message: Message | None, payload: bytes | None, slots: np.ndarray | None) -> None:
        """Give it a command: ``code``, with ``message`` (pickled: ``payload``) for ``MESSAGE``;
        ``slots`` is the shared ``command`` array, ``None`` when its slot already holds ``code``."""

    def poll_done(self, spin_time: float, block: float) -> bool:
        """Whether it finished its command, waiting up to ``spin_time`` + ``block`` seconds."""

    def repost(self) -> None:
        """Undo what a successful :meth:`poll_done` consumed, so that :meth:`answer` sees it done."""

    def answer(self, deadline: float | None, doing: str, reply: np.ndarray,
               current_env: np.ndarray) -> tuple[Message | None, PoolError | None]:
        """Wait until it is done (``deadline``: ``time.monotonic()`` or ``None``), then its reply
        message (if its ``reply`` slot says one follows) or its failure; ``doing`` names the
        command and ``current_env`` the env it was at, for messages."""

    def read_reply(self, deadline: float | None, doing: str, reply: np.ndarray,
                   current_env: np.ndarray) -> tuple[Message | None, PoolError | None]:
        """:meth:`answer` once :meth:`poll_done` has seen it done."""


class PendingCommand(NamedTuple):
    """A command posted to one party and not yet answered."""

    party: Party
    code: int
    message: Message | None = None


class Outcome(NamedTuple):
    """How one party answered a :class:`PendingCommand`: its reply message and/or its failure."""

    command: PendingCommand
    message: Message | None
    failure: PoolError | None

    @property
    def party(self) -> Party:
        """The party that answered."""
        return self.command.party


class CallerParty:
    """The slice of envs the calling process steps itself, as a :class:`Party`.

    It cannot die or time out; its command runs in :meth:`run` (the dispatcher's ``run_own_slice``),
    and its reply (a message, if any) waits here for :meth:`answer`, announced in its reply slot
    like a worker's. A command never run (the pool closed first) is dropped.
    """

    home = True
    where = "the calling process"

    def __init__(self, envs: EnvSlice, buffers: SharedBuffers) -> None:
        self.envs = envs
        self.index = envs.index
        self.env_indices = envs.env_indices
        self._reply_slot = buffers.reply
        #: names the env that ends this process, if one does (`modelicagym.vector.dispatch.caller_watch`)
        self.watch = CallerWatch(buffers.current_env[envs.slot : envs.slot + 1], envs.envs, envs.first,
                                 len(buffers.in_caller))
        self._command: tuple[int, Message | None] | None = None
        self._reply: Message | None = None

    def __repr__(self) -> str:
        return f"CallerParty(envs {env_range(self.env_indices)})"

    def post(self, code: int, message: Message | None, payload: bytes | None, slots: np.ndarray | None) -> None:
        self._command = (code, message)

    def run(self) -> None:
        """Run the posted command, once (nothing if none is posted)."""
        command, self._command = self._command, None
        if command is not None:
            code, message = command
            self.watch.enter()
            try:
                self.hold(self.envs.step() if code == Command.STEP else self.envs.run(code, message))
            finally:
                self.watch.leave()

    def run_native_step(self) -> None:
        """Run the posted ``STEP`` of a slice on the native path without endings of its own in
        Python (`EnvSlice.step`'s hot path): one C call, which points the last word at this slice
        itself; Python then finishes only what C left to it."""
        self._command = None
        if self.envs.native.step():
            self.finish_native_step()

    def finish_native_step(self) -> None:
        """Finish in Python what the slice's last native step left to it; the reply waits for
        :meth:`answer`."""
        self.watch.enter()
        try:
            self.hold(self.envs.finish_native_step())
        finally:
            self.watch.leave()

    def hold(self, reply: Message | None) -> None:
        """Keep ``reply`` for :meth:`answer` (e.g. what Python finished of a native step)."""
        self._reply = reply
        self._reply_slot[self.index] = Reply.NONE if reply is None else Reply.MESSAGE

    def poll_done(self, spin_time: float, block: float) -> bool:
        return True

    def repost(self) -> None:
        """Nothing to undo: its reply waits in :meth:`answer`."""

    def answer(self, deadline: float | None, doing: str, reply: np.ndarray,
               current_env: np.ndarray) -> tuple[Message | None, PoolError | None]:
        return self.read_reply(deadline, doing, reply, current_env)

    def read_reply(self, deadline: float | None, doing: str, reply: np.ndarray,
                   current_env: np.ndarray) -> tuple[Message | None, PoolError | None]:
        self._command = None
        message, self._reply = self._reply, None
        self._reply_slot[self.index] = Reply.NONE
        return message, None

    def forget(self) -> None:
        """Drop the posted command and the held reply (the pool stopped)."""
        self._command = self._reply = None

    def close(self) -> None:
        """The pool is closing: nothing of its envs runs here any more."""
        self.forget()
        self.watch.close()
