"""Sending commands to the pool's parties and gathering their answers over shared memory.

A :class:`Dispatcher` is the parent's side of the protocol (see :mod:`~modelicagym.vector.wire.protocol`):
it posts command codes to every party (:mod:`~modelicagym.vector.parent.party`: the worker processes, and
the calling process's own slice when ``caller_steps``), sends the messages that go with rare
commands, lets the calling process run its share while the workers run theirs, and waits for every
party it woke. It knows which parties it is waiting for, but nothing of the Gymnasium API or of what
a failure means for the pool: those are the pool's and :mod:`~modelicagym.vector.parent.recovery`'s
business.
"""

from __future__ import annotations

import time
from multiprocessing.reduction import ForkingPickler
from typing import Any

import numpy as np

from modelicagym.native.abi import COLLECT_DONE, COLLECT_LOCAL_PYTHON, MgWaiter
from modelicagym.vector.parent.party import CallerParty, Outcome, Party, PendingCommand
from modelicagym.vector.parent.worker_handle import WorkerHandle
from modelicagym.vector.slice.creation import close_envs
from modelicagym.vector.slice.env_slice import EnvSlice
from modelicagym.vector.slice.native_slice import NativeCollector
from modelicagym.vector.wire.buffers import SharedBuffers
from modelicagym.vector.wire.protocol import LIVENESS_INTERVAL, Command, Kind, Message
from modelicagym.vector.wire.sync import FutexSignal

__all__ = ["Dispatcher"]


class Dispatcher:
    """Posts commands to the pool's parties and collects what they answer.

    Args:
        handles: the workers, indexed like the shared ``command`` slots.
        local: the slice of envs the calling process steps itself, or ``None``.
        buffers: the pool's shared memory.
        spin_time: seconds a wait polls before it blocks (see :mod:`~modelicagym.vector.wire.sync`).
        step_timeout: default timeout of a gather; ``None`` waits as long as the workers live.
        stepping: per worker, uint8: it steps at least one env (`modelicagym.vector.parent.placement`);
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
        #: the calling process's slice as a party, or ``None``
        self.caller = None if local is None else CallerParty(local, buffers)
        #: every party in slot order: the workers, then the calling process
        self._parties: list[Party] = [*handles, self.caller] if self.caller is not None else list(handles)
        self._step_all: list[PendingCommand] = []
        self._stepping_parties: list[Party] = []
        self.stepping_changed()
        #: the command slots hold STEP for every worker (so a step need not write them again)
        self._slots_say_step = False
        self._replies = memoryview(buffers.reply)
        #: the adaptive state of the native collection's waits (see ``FutexSignal``)
        self.waiter = MgWaiter()
        #: the calling process's native slice ends its steps in Python (`~modelicagym.vector.slice.slice_endings`):
        #: it steps before the native collection, which then only waits for the workers
        self._local_in_python = local is not None and local.endings is not None
        self._collector = self._native_collector()

    def _native_collector(self) -> NativeCollector | None:
        """The native step's collection (``mg_collect``) when the signals live in shared memory
        and the caller's slice, if any, steps natively; else ``None`` (the Python path)."""
        if not all(isinstance(handle.done, FutexSignal) for handle in self.handles):
            return None
        if self.local is not None and self.local.native is None:
            return None
        if not self.handles and (self.local is None or self._local_in_python):
            return None
        timeout = LIVENESS_INTERVAL if self.step_timeout is None else min(self.step_timeout, LIVENESS_INTERVAL)
        return NativeCollector(
            None if self.local is None or self._local_in_python else self.local.native,
            [handle.done.address for handle in self.handles],
            self.buffers.reply[: len(self.handles)],
            self.stepping,
            self.spin_time,
            timeout,
            self.waiter,
        )

    def stepping_changed(self) -> None:
        """Take in which workers step envs now (``stepping``): a step wakes only those (and the
        calling process, which always takes part)."""
        self._stepping_parties = [party for party in self._parties if party.in_caller or self.stepping[party.index]]
        self._step_all = [PendingCommand(party, Command.STEP) for party in self._stepping_parties]

    def take_collect_times(self) -> tuple[int, int, int] | None:
        """Native collections since the last take, and their nanoseconds on the local slice, then
        waiting for the workers; ``None`` on the Python path."""
        return None if self._collector is None else self._collector.take_times()

    def release(self) -> None:
        """Forget the pending commands and the shared memory, close the local envs (the pool stopped)."""
        self.pending = []
        self.buffers = self._replies = self._collector = None
        if self.caller is not None:
            self.caller.close()
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
        for party in self._stepping_parties:
            party.post(Command.STEP, None, None, None)
        self.pending = self._step_all

    def reset(self, seeds: list[int | None], options: dict[str, Any] | None, mask: np.ndarray) -> None:
        """Reset the envs selected by ``mask`` (workers with none selected are not woken).

        Without seeds or options this needs no message: a ``RESET`` command code says it all.
        """
        self.buffers.reset_mask[:] = mask
        plain = all(s is None for s in seeds) and not options
        code = Command.RESET if options is None else Command.RESET_EMPTY_OPTIONS
        commands = []
        for party in self._parties:
            indices = party.env_indices
            if not mask[indices.start : indices.stop].any():
                continue
            if plain:
                commands.append(PendingCommand(party, code))
            else:
                message = Message(Kind.RESET, (seeds[indices.start : indices.stop], options_for(options, indices)))
                commands.append(PendingCommand(party, Command.MESSAGE, message))
        self.dispatch(commands)

    def call_each(self, name: str, args: list[tuple[Any, ...] | None]) -> None:
        """Call method ``name`` of env ``i`` with its own arguments ``args[i]`` (``None``: not called)."""
        self._message_all(
            lambda party: Message(Kind.CALL_EACH, (name, args[party.env_indices.start : party.env_indices.stop]))
        )

    def call(self, name: str, args: tuple[Any, ...], kwargs: dict[str, Any]) -> None:
        """Call method ``name`` (or read attribute ``name``) of every env."""
        self._message_all(lambda party: Message(Kind.CALL, (name, args, kwargs)))

    def set_attr(self, name: str, values: list[Any]) -> None:
        """Set attribute ``name`` of every env to its value in ``values``."""
        self._message_all(
            lambda party: Message(Kind.SET_ATTR, (name, values[party.env_indices.start : party.env_indices.stop]))
        )

    def close(self) -> list[WorkerHandle]:
        """Tell every living worker to close its envs and exit; returns those workers (to join)."""
        alive = [handle for handle in self.handles if handle.is_alive()]
        self.dispatch([PendingCommand(handle, Command.MESSAGE, Message(Kind.CLOSE)) for handle in alive])
        self.pending = []
        return alive

    def _message_all(self, message_for: Any) -> None:
        self.dispatch([PendingCommand(party, Command.MESSAGE, message_for(party)) for party in self._parties])

    def dispatch(self, commands: list[PendingCommand]) -> None:
        """Post each party its command (and message).

        Messages are pickled before anything else happens, so an unpicklable argument raises here
        with no worker woken. A worker that died meanwhile is reported by :meth:`gather`.
        """
        payloads: dict[int, bytes] = {}
        for command in commands:
            if command.message is not None and id(command.message) not in payloads:
                payloads[id(command.message)] = bytes(ForkingPickler.dumps(command.message))
        slots = self.buffers.command
        self._slots_say_step = False
        for party, code, message in commands:
            party.post(code, message, None if message is None else payloads[id(message)], slots)
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
        for command in pending:
            command.party.run()
        for k, command in enumerate(pending):
            if not command.party.poll_done(spin_time, block):
                self._repost(pending[:k])
                return False
        if any(self._replies):
            self._repost(pending)
            return False
        self.pending = []
        return True

    def _collect(self) -> bool:
        """:meth:`all_done` for a plain step, in one native call (see ``mg_collect``): it steps the
        calling process's native slice itself, so that party's posted step is dropped (unless that
        slice ends its steps in Python: it steps here first, and a reply of its own takes the slow path)."""
        if self.caller is not None and self._local_in_python:
            started = time.perf_counter_ns()
            self.caller.run()
            if self._replies[self.caller.index]:
                return False
            self._collector.add_local_time(time.perf_counter_ns() - started)
        elif self.caller is not None:
            self.caller.forget()
        status = self._collector.collect()
        if status == COLLECT_DONE:
            self.pending = []
            return True
        if status == COLLECT_LOCAL_PYTHON:
            self.caller.finish_native_step()
        return False

    @staticmethod
    def _repost(seen_done: list[PendingCommand]) -> None:
        """Undo what successful waits consumed, so that :meth:`gather` sees those parties done."""
        for command in seen_done:
            command.party.repost()

    def call_results(self, outcomes: list[Outcome], doing: str, named: bool = False) -> list[Any]:
        """The results of ``call`` (or ``set_attr``) in env order, from outcomes without failures;
        raises the first env's exception (the original one when it could be pickled; with
        ``named``, an `EnvError` of its type whose message names the env and ``doing``). Where an
        env has two copies (an adaptive layout), the result is that of the copy stepped now."""
        in_caller = self.buffers.in_caller
        results: dict[int, Any] = {}
        for outcome in outcomes:
            message = outcome.message
            if message is None:
                continue
            if message.kind is Kind.CALL_ERROR:
                remote = message.data
                original = None if named else remote.original()
                party = outcome.party
                raise original if original is not None else remote.to_env_error(
                    party.index, doing, party.process if party.in_caller else None)
            here = outcome.party.in_caller
            for index, value in zip(outcome.party.env_indices, message.data):
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
        pending, self.pending = self.pending, []
        for command in pending:
            command.party.run()
        buffers, outcomes = self.buffers, []
        for command in pending:
            party = command.party
            message, failure = party.answer(deadline, doing, buffers.reply, buffers.current_env)
            if message is not None and message.kind is Kind.ERROR:
                failure = message.data.to_env_error(party.index, doing, party.process if party.in_caller else None)
            elif message is not None and message.kind is Kind.OBSERVATIONS:
                message = self._take_observations(message)
            outcomes.append(Outcome(party, message, failure))
        return outcomes

    def _take_observations(self, message: Message) -> Message | None:
        """Store the observations an ``OBSERVATIONS`` reply carries; the ``INFOS`` reply left."""
        first, observations, infos = message.data
        self.buffers.observations.store(first, observations)
        return Message(Kind.INFOS, infos) if infos else None


def options_for(options: dict[str, Any] | None, indices: range) -> dict[str, Any] | None:
    """A party's part of reset ``options``: its envs' entries of ``"options_per_env"`` (one dict per
    env of the pool), so no party is sent the others' (they may hold large states)."""
    if options is None or "options_per_env" not in options:
        return options
    return {**options, "options_per_env": options["options_per_env"][indices.start : indices.stop]}
