"""The pool's one dispatcher: ``send`` commands to its parties, ``recv`` what they answer.

A :class:`Dispatcher` is the calling process's side of the protocol (see
:mod:`~modelicagym.vector.wire.protocol`). Its primitives are EnvPool's: :meth:`~Dispatcher.send`
posts commands to some parties (:mod:`~modelicagym.vector.dispatch.party`: the worker processes, and the
calling process's own slice when ``caller_steps``) and returns at once; :meth:`~Dispatcher.recv`
waits for every party sent to, :meth:`~Dispatcher.recv_any` for the first ones done (partial
batches). A whole-batch step is ``send_step`` + :meth:`~Dispatcher.run_own_slice` + ``recv``, a
partial batch ``send`` + ``recv_any``: one path, whichever the batch. The calling process's own
slice runs only when :meth:`~Dispatcher.run_own_slice` is called, never as a side effect of a wait.

With ``max_concurrency``, at most that many parties run a step or reset at once (each party runs
its envs one after the other, so at most that many envs do): the others' commands are held here
and posted as the first ones' answers come in.

It knows which parties it is waiting for, but nothing of the Gymnasium API or of what a failure
means for the pool: those are the pool's and :mod:`~modelicagym.vector.dispatch.recovery`'s business.
"""

from __future__ import annotations

import os
import time
from collections import deque
from collections.abc import Callable
from multiprocessing.reduction import ForkingPickler
from typing import Any

import numpy as np

from modelicagym.native.abi import COLLECT_DONE, MgRange, MgWaiter
from modelicagym.vector.dispatch.deadline import Deadline
from modelicagym.vector.dispatch.native_collector import NativeCollector
from modelicagym.vector.dispatch.party import CallerParty, Outcome, Party, PendingCommand
from modelicagym.vector.dispatch.worker_handle import WaitStatus, WorkerHandle
from modelicagym.vector.layout.machine_load import MachineWatch, machine_crowded
from modelicagym.vector.reset_options import options_for
from modelicagym.vector.slice.creation import close_envs
from modelicagym.vector.slice.env_slice import EnvSlice
from modelicagym.vector.wire.buffers import SharedBuffers
from modelicagym.vector.wire.protocol import LIVENESS_INTERVAL, Command, Kind, Message
from modelicagym.vector.wire.sync import FutexSignal

__all__ = ["Dispatcher"]

#: how long :meth:`Dispatcher.recv_any` blocks on one busy party before it looks at the others again (seconds)
_POLL_BLOCK = 0.0002

#: the commands that run envs' ``step`` or ``reset`` (``max_concurrency`` limits those, as ``AsyncVectorEnv`` does)
_ENV_RUNNING_CODES = frozenset({Command.STEP, Command.RESET, Command.RESET_EMPTY_OPTIONS})
_ENV_RUNNING_KINDS = frozenset({Kind.STEP, Kind.RESET})


class Dispatcher:
    """Sends commands to the pool's parties and receives what they answer.

    Args:
        handles: the workers, indexed like the shared ``command`` slots.
        local: the slice of envs the calling process steps itself, or ``None``.
        buffers: the pool's shared memory.
        spin_time: seconds a wait of a step polls at most before it blocks (see
            :mod:`~modelicagym.vector.wire.sync`; `go_poll_time` for the workers' waits and
            `collect_poll_time` for the calling process's).
        step_timeout: default timeout of a ``recv``; ``None`` waits as long as the workers live.
        stepping: per worker, uint8: it steps at least one env (`modelicagym.vector.layout.placement`);
            a step wakes only those. Call :meth:`stepping_changed` after it changes.
        max_concurrency: at most this many parties run a step or reset at once (``None``: all).
        cores: the usable cores the pool plans for (`modelicagym.cores.usable_cores`).
    """

    def __init__(
        self,
        handles: list[WorkerHandle],
        local: EnvSlice | None,
        buffers: SharedBuffers,
        spin_time: float,
        step_timeout: float | None,
        stepping: np.ndarray,
        max_concurrency: int | None = None,
        cores: int = 1,
    ) -> None:
        self.handles = handles
        self.stepping = stepping
        self.local = local
        self.buffers = buffers
        self.spin_time = spin_time
        self.cores = cores
        self.step_timeout = step_timeout
        self.max_concurrency = max_concurrency
        #: commands sent and not yet received (posted, or held for ``max_concurrency``), in send order
        self.pending: list[PendingCommand] = []
        #: commands held until fewer than ``max_concurrency`` parties run envs, with their pickled messages
        self._held: deque[tuple[PendingCommand, bytes | None]] = deque()
        #: posted env-running commands not yet received (what ``max_concurrency`` bounds)
        self._running = 0
        #: per party index, when its command was posted (``time.monotonic()``; for :meth:`recv_any`)
        self._posted_at: dict[int, float] = {}
        #: the calling process's slice as a party, or ``None``
        self.caller = None if local is None else CallerParty(local, buffers)
        #: with a stand-in worker (every env isolated), its polling waits for a quiet machine
        self._machine = MachineWatch() if any(handle.home for handle in handles) else None
        self._machine_quiet = False
        #: every party in slot order: the workers, then the calling process
        self._parties: list[Party] = [*handles, self.caller] if self.caller is not None else list(handles)
        self._step_all: list[PendingCommand] = []
        self._stepping_parties: list[Party] = []
        #: how long the calling process polls for the workers of a step (its waiter polls only
        #: while the workers' posts come within that time)
        self._collect_spin_ns = np.array([round(spin_time * 1e9)], dtype=np.int64)
        self._home_step: Callable[[], int] | None = None  # set below, once the slice's step is known
        self.stepping_changed()
        #: the command slots hold STEP for every worker (so a step need not write them again)
        self._slots_say_step = False
        #: the command out is a whole batch's step (:meth:`send_step`): ``recv`` tries its hot path
        self._step_sent = False
        self._replies = memoryview(buffers.reply)
        #: the adaptive state of the native collection's waits (see ``FutexSignal``)
        self.waiter = MgWaiter()
        self._collector = self._native_collector()
        #: how the calling process's slice runs a step: in one C call if it is native with no endings
        #: of its own in Python (`CallerParty.run_native_step`), else as any command
        self._own_step = self._own_step_anywhere = None if self.caller is None else (
            self.caller.run_native_step if local.native is not None and local.endings is None else self.caller.run)
        #: the CPU the calling thread steps its slice on (``None``: where it runs; `step_own_slice_on`)
        self._own_cpu: int | None = None
        #: a step that wakes no worker can be one C call (`step_at_home`): the slice's native step
        self._home_step = (local.native.step if self.caller is not None
                           and self._own_step_anywhere == self.caller.run_native_step
                           and not buffers.actions.pickled and max_concurrency is None else None)
        #: the same, after the batch's range check where the pool leaves it to C (`check_range_at_home`)
        self._home_step_in_range = self._home_step
        self.stepping_changed()
        #: nanoseconds the calling process stepped its slice, and steps that woke no worker (so no
        #: native collection), since the last `take_collect_times`
        self._own_ns = self._own_calls = 0

    def _native_collector(self) -> NativeCollector | None:
        """The native post to and wait for a step's workers (``mg_post_step``, ``mg_collect``: the
        step's barrier) when their signals live in shared memory (with no workers: when the calling
        process's slice is native, so the library is loaded; the wait is then one call that finds
        nothing to wait for); else ``None`` (the Python posts and waits)."""
        if not all(isinstance(handle.done, FutexSignal) for handle in self.handles):
            return None
        if not self.handles and (self.local is None or self.local.native is None):
            return None
        timeout = LIVENESS_INTERVAL if self.step_timeout is None else min(self.step_timeout, LIVENESS_INTERVAL)
        return NativeCollector(
            [handle.go.address for handle in self.handles], [handle.done.address for handle in self.handles],
            self.buffers.barrier_address, self.buffers.reply[: len(self.handles)], self.stepping,
            self._collect_spin_ns, timeout, self.waiter,
        )

    def stepping_changed(self) -> None:
        """Take in which workers step envs now (``stepping``): a step wakes only those (and the
        calling process, which always takes part)."""
        self._stepping_parties = [party for party in self._parties if party.home or self.stepping[party.index]]
        self._step_all = [PendingCommand(party, Command.STEP) for party in self._stepping_parties]
        #: a step wakes at least one worker
        self._workers_step = any(party is not self.caller for party in self._stepping_parties)
        #: a whole batch's step wakes no worker and the calling process steps its envs in one C
        #: call: :meth:`step_at_home` is then the whole of send, run and recv
        self.steps_at_home = self._home_step is not None and not self._workers_step
        self._set_go_spin()

    def watch_machine(self) -> None:
        """Let an isolated pool's workers poll only on a quiet machine
        (`~modelicagym.vector.layout.machine_load`); cheap enough to call after every step."""
        if self._machine is not None and self._machine.quiet() != self._machine_quiet:
            self._machine_quiet = not self._machine_quiet
            self._set_go_spin()

    def _set_go_spin(self) -> None:
        """Write how long the workers poll for their next command (`go_poll_time`), and how long
        the calling process polls for their answers (`collect_poll_time`)."""
        workers, cores = sum(party is not self.caller for party in self._stepping_parties), self.cores
        stand_in = self._machine is not None
        may_poll = not stand_in or self._machine_quiet
        spin_time = go_poll_time(self.spin_time, workers, cores, quiet_stand_in=stand_in) if may_poll else 0.0
        self.buffers.go_spin_ns[0] = round(spin_time * 1e9)
        self._collect_spin_ns[0] = round(collect_poll_time(self.spin_time, workers, cores) * 1e9)

    @property
    def in_flight(self) -> bool:
        """Whether a command was sent and not all its answers received (a half-done command)."""
        return bool(self.pending)

    def take_collect_times(self) -> tuple[int, int, int] | None:
        """Native collections since the last take, and their nanoseconds on the local slice (in
        :meth:`run_own_slice`), then waiting for the workers; ``None`` on the Python path."""
        if self._collector is None:
            return None
        calls, wait_ns = self._collector.take_times()
        own_ns, own_calls, self._own_ns, self._own_calls = self._own_ns, self._own_calls, 0, 0
        return calls + own_calls, own_ns, wait_ns

    def release(self) -> None:
        """Forget the pending commands and the shared memory, close the local envs (the pool stopped)."""
        self.pending = []
        self._held.clear()
        self._running = 0
        if self.buffers is None:
            return
        self.buffers = self._replies = self._collector = None
        if self.caller is not None:
            self.caller.close()
            close_envs(self.local.envs)
            self.local.detach()

    # ------------------------------------------------------------------ send

    def send_step(self) -> None:
        """Every stepping party steps with the actions in shared memory: the hot path of
        :meth:`send`, with no messages and no allocation (except for actions with no shared-memory
        layout, sent in a ``STEP`` message, or when ``max_concurrency`` holds parties back)."""
        actions = self.buffers.actions
        if actions.pickled:
            self.send([
                PendingCommand(party, Command.MESSAGE, Message(Kind.STEP, actions.values(party.env_indices)))
                for party in self._parties
            ])
        else:
            if not self._slots_say_step:
                self.buffers.command[:] = Command.STEP
                self._slots_say_step = True
            if self.max_concurrency is not None and len(self._stepping_parties) > self.max_concurrency:
                self.send(self._step_all, slots_hold_code=True)
            else:
                self.pending = self._step_all  # before posting: a Ctrl-C half-way still shows the command out
                self._post_step()
        self._step_sent = True

    def _post_step(self) -> None:
        """Post ``STEP`` (already in the command slots) to every stepping party: the workers in one
        C call (the step's barrier) when their signals are native, else one by one."""
        if self._collector is None:
            for party in self._stepping_parties:
                party.post(Command.STEP, None, None, None)
            return
        if self.caller is not None:
            self.caller.post(Command.STEP, None, None, None)
        if self._workers_step:
            self._collector.post()

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
        self.send(commands)

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
        self.send([PendingCommand(handle, Command.MESSAGE, Message(Kind.CLOSE)) for handle in alive])
        self.pending = []
        return alive

    def _message_all(self, message_for: Any) -> None:
        self.send([PendingCommand(party, Command.MESSAGE, message_for(party)) for party in self._parties])

    def send(self, commands: list[PendingCommand], slots_hold_code: bool = False) -> None:
        """Post each party its command (and message), or hold it while ``max_concurrency``
        parties run envs; returns at once.

        Messages are pickled before anything else happens, so an unpicklable argument raises here
        with no worker woken. A worker that died meanwhile is reported by the ``recv``. With
        ``slots_hold_code`` the shared command slots already hold every command's code.
        """
        payloads: dict[int, bytes] = {}
        for command in commands:
            if command.message is not None and id(command.message) not in payloads:
                payloads[id(command.message)] = bytes(ForkingPickler.dumps(command.message))
        if self.max_concurrency is not None:  # the calling process's own command first: it is never held
            commands = sorted(commands, key=lambda command: not command.party.home)
        if not slots_hold_code:
            self._slots_say_step = False
        self._step_sent = False
        self.pending = [*self.pending, *commands]
        now = time.monotonic()
        for command in commands:
            payload = None if command.message is None else payloads[id(command.message)]
            if self.max_concurrency is not None and _runs_envs(command):
                if self._running >= self.max_concurrency:
                    self._held.append((command, payload))
                    continue
                self._running += 1
            self._post(command, payload, now, slots_hold_code)

    def _post(self, command: PendingCommand, payload: bytes | None, now: float, slots_hold_code: bool) -> None:
        party = command.party
        self._posted_at[party.index] = now
        party.post(command.code, command.message, payload, None if slots_hold_code else self.buffers.command)

    def _answered(self, command: PendingCommand) -> None:
        """``command``'s party answered: with ``max_concurrency``, post the next held command."""
        if self.max_concurrency is None or not _runs_envs(command):
            return
        self._running -= 1
        if self._held:
            held, payload = self._held.popleft()
            self._running += 1
            self._post(held, payload, time.monotonic(), self._slots_say_step and held.code == Command.STEP)

    def _is_held(self, command: PendingCommand) -> bool:
        return any(held is command for held, _ in self._held)

    # ------------------------------------------------------------------ the calling process's share

    def run_own_slice(self) -> None:
        """The calling process runs its own slice's command (step, reset, call) now, while the
        workers run theirs; its answer waits for ``recv``. Nothing to do without ``caller_steps``."""
        caller = self.caller
        if caller is None:
            return
        if self.pending is not self._step_all:
            caller.run()
        elif self._collector is None:
            self._own_step()
        else:  # a step the native collection accounts (`take_collect_times`)
            started = time.perf_counter_ns()
            self._own_step()
            self._own_ns += time.perf_counter_ns() - started

    def step_own_slice_on(self, cpu: int | None) -> None:
        """From now on the calling thread steps its slice on CPU ``cpu`` (``None``: where it runs),
        its affinity mask given back as each step of the slice ends, so that nothing else it runs,
        and no thread it starts, keeps to that CPU (`modelicagym.vector.layout.affinity.PartiesApart`)."""
        if cpu == self._own_cpu or self._own_step_anywhere is None:
            return
        self._own_cpu, step = cpu, self._own_step_anywhere
        if cpu is None:
            self._own_step = step
            return
        mask, on_cpu = os.sched_getaffinity(0), (cpu,)

        def step_on_cpu() -> None:
            try:
                os.sched_setaffinity(0, on_cpu)
            except OSError:  # the CPU went offline, or a cgroup took it: the slice steps where it runs
                step()
                return
            try:
                step()
            finally:
                os.sched_setaffinity(0, mask)

        self._own_step = step_on_cpu

    def check_range_at_home(self, actions: MgRange | None) -> bool:
        """Let :meth:`step_at_home` range-check the batch's actions (``actions``, the action
        writer's `~ActionWriter.native_range`) in its C call; whether it will (``False`` where the
        slice cannot step at home, or C cannot check the actions)."""
        if self._home_step is None or actions is None:
            return False
        self._home_step_in_range = self.local.native.stepper_in_range(actions)
        return True

    def step_at_home(self, check_range: bool = True) -> bool | None:
        """The step of a batch whose stepping envs are all the calling process's (`steps_at_home`):
        its slice steps now, with the actions in shared memory, after their range check if
        :meth:`check_range_at_home` set one and ``check_range``. ``True``: the step is complete,
        nothing left to Python. ``False``: Python has finished what the native step left to it, and
        the step is out as after :meth:`send_step` and :meth:`run_own_slice`: :meth:`recv` takes its
        reply (infos, an env's error). ``None``: an action is outside its space, nothing stepped."""
        step = self._home_step_in_range if check_range else self._home_step
        started = time.perf_counter_ns()
        left = step()
        self._own_ns += time.perf_counter_ns() - started
        if left < 0:
            return None
        if left == 0:
            self._own_calls += 1
            return True
        self.pending, self._step_sent = self._step_all, True
        self.caller.finish_native_step()
        return False

    # ------------------------------------------------------------------ recv

    def recv(self, timeout: float | None, doing: str) -> list[Outcome]:
        """Wait for every party sent to; the outcome of each that answered with a message or
        failed (parties done with nothing to say are left out: on the hot path, all of them).

        ``timeout`` (seconds, for all parties together) defaults to ``step_timeout``; ``doing``
        names what the parties were asked to do, for error messages. A party whose env failed
        (an ``ERROR`` reply) has that failure as an :class:`~modelicagym.vector.errors.EnvError`.
        """
        if self._step_sent and timeout is None and not self._held and self._done_quietly():
            self.pending = []
            return []
        deadline = Deadline.after(self.step_timeout if timeout is None else timeout)
        outcomes = []
        buffers = self.buffers
        for command in list(self.pending):
            message, failure = command.party.answer(deadline.at, doing, buffers.reply, buffers.current_env)
            self._answered(command)
            outcome = self._outcome(command, message, failure, doing)
            if outcome.message is not None or outcome.failure is not None:
                outcomes.append(outcome)
        self.pending = []
        return outcomes

    def _done_quietly(self) -> bool:
        """The hot path of :meth:`recv`: ``True`` if every pending party is done within one
        spin-then-block wait with nothing to say (no reply on its pipe); the command is then
        complete. Otherwise (``False``) nothing is lost: the parties already seen done are left
        to the slow path, which sees them done at once and handles replies, deaths and timeouts."""
        self._step_sent = False
        pending, caller = self.pending, self.caller
        if pending is self._step_all:
            if caller is not None and self._replies[caller.index]:
                return False
            if not self._workers_step:  # every env is the calling process's: no one to wait for
                self._own_calls += 1
                return True
            if self._collector is not None:
                return self._collector.collect() == COLLECT_DONE
        block = LIVENESS_INTERVAL if self.step_timeout is None else min(self.step_timeout, LIVENESS_INTERVAL)
        spin_time = self.spin_time
        for k, command in enumerate(pending):
            if not command.party.poll_done(spin_time, block):
                self._repost(pending[:k])
                return False
        if any(self._replies):
            self._repost(pending)
            return False
        return True

    @staticmethod
    def _repost(seen_done: list[PendingCommand]) -> None:
        """Undo what successful waits consumed, so that the slow path sees those parties done."""
        for command in seen_done:
            command.party.repost()

    def recv_any(self, doing: str) -> list[Outcome]:
        """Wait until at least one posted party is done; the outcomes of every party done by then
        (silent ones too: the caller learns which are done), the others stay pending. A party that
        died, or overran ``step_timeout`` since its command was posted, answers with its failure."""
        posted = [command for command in self.pending if not self._is_held(command)]
        spin_until = time.monotonic() + (0.0 if machine_crowded() else self.spin_time)
        while True:
            done = self._take_done(posted, 0.0, doing)
            if done or time.monotonic() >= spin_until:
                break
        while not done:
            done = self._take_done(posted, _POLL_BLOCK / len(posted), doing)
            if not done:
                done = [outcome for command in posted if (outcome := self._overdue(command, doing)) is not None]
        taken = {id(outcome.command) for outcome in done}
        self.pending = [command for command in self.pending if id(command) not in taken]
        for outcome in done:
            self._answered(outcome.command)
        return done

    def _take_done(self, posted: list[PendingCommand], block: float, doing: str) -> list[Outcome]:
        """The outcomes of the parties of ``posted`` that are done (blocking up to ``block`` on each)."""
        return [self._read(command, doing) for command in posted if command.party.poll_done(0.0, block)]

    def _read(self, command: PendingCommand, doing: str) -> Outcome:
        """The outcome of a party seen done."""
        buffers = self.buffers
        message, failure = command.party.read_reply(None, doing, buffers.reply, buffers.current_env)
        return self._outcome(command, message, failure, doing)

    def _overdue(self, command: PendingCommand, doing: str) -> Outcome | None:
        """``command``'s outcome if its worker died or overran ``step_timeout`` (its failure, or
        its answer if it finished meanwhile); else ``None``."""
        party = command.party
        running = time.monotonic() - self._posted_at[party.index]
        overran = self.step_timeout is not None and running > self.step_timeout
        if not overran and (running <= LIVENESS_INTERVAL or party.is_alive()):
            return None
        if party.poll_done(0.0, 0.0):
            return self._read(command, doing)
        status = WaitStatus.TIMED_OUT if overran else WaitStatus.DIED
        return Outcome(command, None, party.failure(status, int(self.buffers.current_env[party.index]), doing))

    def _outcome(self, command: PendingCommand, message: Message | None, failure: Any, doing: str) -> Outcome:
        """A party's answer as an :class:`Outcome`: an ``ERROR`` reply becomes its failure, an
        ``OBSERVATIONS`` reply is stored (its infos left as the message)."""
        party = command.party
        if message is not None and message.kind is Kind.ERROR:
            failure = message.data.to_env_error(party.index, doing, party.where)
            message = None
        elif message is not None and message.kind is Kind.OBSERVATIONS:
            message = self._take_observations(message)
        return Outcome(command, message, failure)

    def _take_observations(self, message: Message) -> Message | None:
        """Store the observations an ``OBSERVATIONS`` reply carries; the ``INFOS`` reply left."""
        first, observations, infos = message.data
        self.buffers.observations.store(first, observations)
        return Message(Kind.INFOS, infos) if infos else None

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
            party = outcome.command.party
            if message.kind is Kind.CALL_ERROR:
                remote = message.data
                original = None if named else remote.original()
                raise original if original is not None else remote.to_env_error(
                    party.index, doing, party.where)
            for index, value in zip(party.env_indices, message.data):
                if bool(in_caller[index]) == party.home:
                    results[index] = value
        return [results[index] for index in sorted(results)]


def _runs_envs(command: PendingCommand) -> bool:
    """Whether ``command`` runs envs' ``step`` or ``reset`` (what ``max_concurrency`` limits)."""
    if command.code == Command.MESSAGE:
        return command.message.kind in _ENV_RUNNING_KINDS
    return command.code in _ENV_RUNNING_CODES


#: the longest the calling process polls for workers that fill the cores (seconds; see `collect_poll_time`)
CROWDED_COLLECT_SPIN = 50e-6


def collect_poll_time(spin_time: float, stepping_workers: int, cores: int) -> float:
    """Seconds the calling process polls for the workers' answers to a step before it sleeps:
    ``spin_time`` while the stepping workers leave it a core; where they fill the cores, at most
    `CROWDED_COLLECT_SPIN`, and on one core not at all.

    Its waiter polls again as soon as a post comes within that time, and sleeps at once after
    one that does not. Where the workers fill the cores, a poll takes a core from one of them, so
    it pays only for short batches: a batch of 8 Feedthrough envs on the Python step path in two
    workers (~80 µs each) ran at 0.44x one env with the calling process polling for up to 100 µs,
    0.68-0.84x with 50 µs, where light batches (a wake-up and a few µs of work) kept their figures.
    On one core the poll holds the core the worker needs to finish (8 light envs in a stand-in,
    pinned to one CPU: 0.74x one env polling, 1.13x asleep), and inside a 1-CPU quota it is CPU
    time charged to the quota while the worker steps (0.76x against 1.21x, halt polling on).
    """
    if stepping_workers < cores:
        return spin_time
    return min(spin_time, CROWDED_COLLECT_SPIN) if cores > 1 else 0.0


def go_poll_time(spin_time: float, stepping_workers: int, cores: int, quiet_stand_in: bool = False) -> float:
    """Seconds a worker polls for its next command before it sleeps: ``spin_time`` while the
    calling process and the workers that step fit the cores, else none; with a stand-in on a quiet
    machine (``quiet_stand_in``), while the stepping workers alone fit them.

    The calling process takes part in every step (it steps its slice, or waits for the workers),
    and between two steps it needs a core for its own part. Where the pollers fit, polling saves
    each batch the wake-up of a sleeping worker (~20 µs on this project's VM): 8 light FMUs
    consolidated in one isolated worker ran at 1.5x one env with that worker polling, 0.8x with
    it asleep. Where they do not, the pollers hold the cores the parent needs: on 2 cores under
    load, 100-180 µs a batch of a light env against 16-40 µs with the workers asleep (benchmark-log.md,
    "Your own FMU"). On a quiet machine a woken parent gets a poller's core at once, and workers that
    fill the cores pay when their batches are long: 8 isolated envs of ~70 µs in two workers ran
    at 1.75x one env polling, 1.39x asleep. Light batches lose (two workers polling: 217 µs a batch
    of 8 light envs where one consolidated worker took 60 µs), which a stand-in's adaptive layout
    measures and leaves, so only such a pool's workers fill the cores. On one core no worker
    polls: its poll would hold the core the calling process needs, and inside a 1-CPU quota it is
    CPU time charged to the quota (8 light envs in a stand-in inside a 1-CPU quota on 2 cores, the
    guest's halt polling on: 1.21x one env asleep, 1.12x polling).
    """
    return spin_time if stepping_workers + (not quiet_stand_in) <= cores and cores > 1 else 0.0
