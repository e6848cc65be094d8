"""Sending commands to the workers and gathering their answers over shared memory.

A :class:`Dispatcher` is the parent's side of the protocol (see :mod:`~modelicagym.vector.protocol`):
it writes command codes into the workers' slots, wakes them, sends the messages that go with rare
commands, and waits for every worker it woke. When the calling process steps a slice of the envs
itself (``caller_steps``), that slice is one more party to every command: the dispatcher runs it
in-process after waking the workers and before waiting for them, so the caller works while they do. It knows which workers it is waiting for, but nothing
of the Gymnasium API or of what a failure means for the pool: those are the pool's and
:mod:`~modelicagym.vector.recovery`'s business.
"""

from __future__ import annotations

import logging
import time
from multiprocessing.reduction import ForkingPickler
from typing import Any

import numpy as np

from modelicagym.native.abi import COLLECT_DONE, COLLECT_LOCAL_PYTHON, MgWaiter
from modelicagym.vector.native_slice import NativeCollector
from modelicagym.vector.buffers import SharedBuffers
from modelicagym.vector.creation import close_envs
from modelicagym.vector.env_slice import EnvSlice
from modelicagym.vector.errors import PoolError
from modelicagym.vector.handle import WorkerHandle
from modelicagym.vector.protocol import (
    LIVENESS_INTERVAL,
    Command,
    Kind,
    Message,
    Outcome,
    PendingCommand,
    Reply,
    WaitStatus,
)
from modelicagym.vector.sync import FutexSignal

__all__ = ["Dispatcher"]

logger = logging.getLogger(__name__)


class Dispatcher:
    """Wakes workers with commands and collects what they answer.

    Args:
        handles: the workers, indexed like the shared ``command`` slots.
        local: the slice of envs the calling process steps itself, or ``None``.
        buffers: the pool's shared memory.
        spin_time: seconds a wait polls before it blocks (see :mod:`~modelicagym.vector.sync`).
        step_timeout: default timeout of a gather; ``None`` waits as long as the workers live.
        stepping: per worker, uint8: it steps at least one env (`modelicagym.vector.placement`);
            a step wakes only those. Call :meth:`stepping_changed` after it changes.
    """

    def __init__(
        self,
        handles: list[WorkerHandle],
        local: EnvSlice | None,
        buffers: SharedBuffers,
        spin_time: float,
        step_timeout: float | None,
        stepping: np.ndarray,
    ) -> None:
        self.handles = handles
        self.stepping = stepping
        self.local = local
        self.buffers = buffers
        self.spin_time = spin_time
        self.step_timeout = step_timeout
        self.pending: list[PendingCommand] = []
        #: every party in slot order: the workers, then the local slice
        self._parties = [*handles, local] if local is not None else list(handles)
        self._step_all: list[PendingCommand] = []
        self._stepping_handles: list[WorkerHandle] = []
        self.stepping_changed()
        #: the command slots hold STEP for every worker (so a step need not write them again)
        self._slots_say_step = False
        self._replies = memoryview(buffers.reply)
        self._local_command: PendingCommand | None = None
        self._local_reply: Message | None = None
        #: the adaptive state of the native collection's waits (see ``FutexSignal``)
        self.waiter = MgWaiter()
        self._collector = self._native_collector()

    def _native_collector(self) -> NativeCollector | None:
        """The native step's collection (``mg_collect``) when the signals live in shared memory
        and the caller's slice, if any, steps natively; else ``None`` (the Python path)."""
        if not all(isinstance(handle.done, FutexSignal) for handle in self.handles):
            return None
        if self.local is not None and self.local.native is None:
            return None
        if not self.handles and self.local is None:
            return None
        timeout = LIVENESS_INTERVAL if self.step_timeout is None else min(self.step_timeout, LIVENESS_INTERVAL)
        return NativeCollector(
            None if self.local is None else self.local.native,
            [handle.done.address for handle in self.handles],
            self.buffers.reply[: len(self.handles)],
            self.stepping,
            self.spin_time,
            timeout,
            self.waiter,
        )

    def stepping_changed(self) -> None:
        """Take in which workers step envs now (``stepping``): a step wakes only those."""
        self._stepping_handles = [handle for handle in self.handles if self.stepping[handle.index]]
        parties = [*self._stepping_handles, self.local] if self.local is not None else self._stepping_handles
        self._step_all = [PendingCommand(party, Command.STEP) for party in parties]

    def take_collect_times(self) -> tuple[int, int, int] | None:
        """Native collections since the last take, and their nanoseconds on the local slice, then
        waiting for the workers; ``None`` on the Python path."""
        return None if self._collector is None else self._collector.take_times()

    def release(self) -> None:
        """Forget the pending commands and the shared memory, close the local envs (the pool stopped)."""
        self.pending = []
        self._local_command = self._local_reply = None
        self.buffers = self._replies = self._collector = None
        if self.local is not None:
            close_envs(self.local.envs)
            self.local.detach()

    def step_all(self) -> None:
        """The hot path of :meth:`dispatch`: every worker steps; no messages, no allocation
        (except for actions with no shared-memory layout, sent in a ``STEP`` message)."""
        actions = self.buffers.actions
        if actions.pickled:
            self.dispatch([
                PendingCommand(party, Command.MESSAGE, Message(Kind.STEP, actions.values(party.env_indices)))
                for party in self._parties
            ])
            return
        if not self._slots_say_step:
            self.buffers.command[:] = Command.STEP
            self._slots_say_step = True
        for handle in self._stepping_handles:
            handle.go.post()
        self.pending = self._step_all
        if self.local is not None:
            self._local_command = self._step_all[-1]

    def reset(self, seeds: list[int | None], options: dict[str, Any] | None, mask: np.ndarray) -> None:
        """Reset the envs selected by ``mask`` (workers with none selected are not woken).

        Without seeds or options this needs no message: a ``RESET`` command code says it all.
        """
        self.buffers.reset_mask[:] = mask
        plain = all(s is None for s in seeds) and not options
        code = Command.RESET if options is None else Command.RESET_EMPTY_OPTIONS
        commands = []
        for handle in self._parties:
            indices = handle.env_indices
            if not mask[indices.start : indices.stop].any():
                continue
            if plain:
                commands.append(PendingCommand(handle, code))
            else:
                message = Message(Kind.RESET, (seeds[indices.start : indices.stop], options))
                commands.append(PendingCommand(handle, Command.MESSAGE, message))
        self.dispatch(commands)

    def call(self, name: str, args: tuple[Any, ...], kwargs: dict[str, Any]) -> None:
        """Call method ``name`` (or read attribute ``name``) of every env."""
        self._message_all(lambda handle: Message(Kind.CALL, (name, args, kwargs)))

    def set_attr(self, name: str, values: list[Any]) -> None:
        """Set attribute ``name`` of every env to its value in ``values``."""
        self._message_all(
            lambda h: Message(Kind.SET_ATTR, (name, values[h.env_indices.start : h.env_indices.stop]))
        )

    def close(self) -> list[WorkerHandle]:
        """Tell every living worker to close its envs and exit; returns those workers (to join)."""
        alive = [handle for handle in self.handles if handle.is_alive()]
        self.dispatch([PendingCommand(handle, Command.MESSAGE, Message(Kind.CLOSE)) for handle in alive])
        self.pending = []
        return alive

    def _message_all(self, message_for: Any) -> None:
        self.dispatch([PendingCommand(h, Command.MESSAGE, message_for(h)) for h in self._parties])

    def dispatch(self, commands: list[PendingCommand]) -> None:
        """Wake the workers with their commands, then send the messages that go with them.

        Messages are pickled before anything else happens, so an unpicklable argument raises here
        with no worker woken. Waking before sending means a large message can never fill the pipe
        while its reader sleeps. A worker that died meanwhile makes the send fail; that is reported
        by :meth:`gather`.
        """
        payloads: dict[int, bytes] = {}
        for command in commands:
            if command.message is not None and id(command.message) not in payloads:
                payloads[id(command.message)] = bytes(ForkingPickler.dumps(command.message))
        slots = self.buffers.command
        self._slots_say_step = False
        for command in commands:
            handle, code, message = command
            if handle is self.local:
                self._local_command = command
                continue
            slots[handle.index] = code
            handle.go.post()
            if message is not None:
                try:
                    handle.conn.send_bytes(payloads[id(message)])
                except OSError:
                    logger.debug("worker %d: pipe broken while sending %s", handle.index, message.kind.value)
        self.pending = commands

    def all_done(self, timeout: float | None) -> bool:
        """The hot path of :meth:`gather`: ``True`` if every pending worker posted ``done`` within
        one spin-then-block wait and none has a reply on its pipe; the batch is then complete.

        Otherwise (``False``) nothing is lost: the workers already seen done are left to
        :meth:`gather`, which sees them done at once and handles replies, deaths and timeouts.
        """
        pending = self.pending
        if self._collector is not None and pending is self._step_all and timeout == self.step_timeout:
            return self._collect()
        block = LIVENESS_INTERVAL if timeout is None else min(timeout, LIVENESS_INTERVAL)
        spin_time = self.spin_time
        self._run_local()
        for k, command in enumerate(pending):
            if command.handle is self.local:
                continue
            if not command.handle.done.wait(spin_time, block):
                self._repost(pending[:k])
                return False
        if any(self._replies) or self._local_reply is not None:
            self._repost(pending)
            return False
        self.pending = []
        return True

    def _collect(self) -> bool:
        """:meth:`all_done` for a plain step, in one native call (see ``mg_collect``)."""
        self._local_command = None
        status = self._collector.collect()
        if status == COLLECT_DONE:
            self.pending = []
            return True
        if status == COLLECT_LOCAL_PYTHON:
            self._local_reply = self.local.finish_native_step()
        return False

    def _repost(self, seen_done: list[PendingCommand]) -> None:
        """Post ``done`` again for workers whose ``done`` a wait has consumed."""
        for command in seen_done:
            if command.handle is not self.local:
                command.handle.done.post()

    def _run_local(self) -> None:
        """Run the local slice's pending command, once; its reply waits for :meth:`gather`."""
        command, self._local_command = self._local_command, None
        if command is None:
            return
        if command.code == Command.STEP:
            self._local_reply = self.local.step()
        else:
            self._local_reply = self.local.run(command.code, command.message)

    def call_results(self, outcomes: list[Outcome], doing: str) -> list[Any]:
        """The results of ``call`` (or ``set_attr``) in env order, from outcomes without failures;
        raises the first env's exception (the original one when it could be pickled). Where an
        env has two copies (an adaptive layout), the result is that of the copy stepped now."""
        in_caller = self.buffers.in_caller
        results: dict[int, Any] = {}
        for outcome in outcomes:
            message = outcome.message
            if message is None:
                continue
            if message.kind is Kind.CALL_ERROR:
                remote = message.data
                original = remote.original()
                raise original if original is not None else remote.to_env_error(outcome.handle.index, doing)
            here = outcome.handle is self.local
            for index, value in zip(outcome.handle.env_indices, message.data):
                if bool(in_caller[index]) == here:
                    results[index] = value
        return [results[index] for index in sorted(results)]

    def gather(self, timeout: float | None, doing: str) -> list[Outcome]:
        """Wait for every pending worker; per worker its reply message and/or its failure.

        ``timeout`` (seconds, for all workers together) defaults to ``step_timeout``; ``doing``
        names what the workers were asked to do, for error messages. A worker whose env failed
        (an ``ERROR`` reply) has that failure as an :class:`~modelicagym.vector.errors.EnvError`.
        """
        if timeout is None:
            timeout = self.step_timeout
        deadline = None if timeout is None else time.monotonic() + timeout
        self._run_local()
        pending, self.pending = self.pending, []
        outcomes = []
        for command in pending:
            handle = command.handle
            if handle is self.local:
                message, self._local_reply = self._local_reply, None
                failure, process = None, "the calling process"
            else:
                message, failure = self._answer_of(handle, deadline, doing)
                process = None
            if message is not None and message.kind is Kind.ERROR:
                failure = message.data.to_env_error(handle.index, doing, process)
            elif message is not None and message.kind is Kind.OBSERVATIONS:
                message = self._take_observations(message)
            outcomes.append(Outcome(handle, message, failure))
        return outcomes

    def _take_observations(self, message: Message) -> Message | None:
        """Store the observations an ``OBSERVATIONS`` reply carries; the ``INFOS`` reply left."""
        first, observations, infos = message.data
        self.buffers.observations.store(first, observations)
        return Message(Kind.INFOS, infos) if infos else None

    def _answer_of(
        self, handle: WorkerHandle, deadline: float | None, doing: str
    ) -> tuple[Message | None, PoolError | None]:
        """Wait for one worker's ``done``, then read its reply if it has one; or its failure."""
        status = handle.wait_done(self.spin_time, deadline)
        env_index = int(self.buffers.current_env[handle.index])
        if status is not WaitStatus.DONE:
            return None, handle.failure(status, env_index, doing)
        if self.buffers.reply[handle.index] != Reply.MESSAGE:
            return None, None
        try:
            return handle.receive(deadline, env_index, doing), None
        except PoolError as error:
            return None, error
