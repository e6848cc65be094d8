"""The pool's worker processes as a set: start them, learn the envs' spaces, share memory, restart one.

A :class:`WorkerSet` owns everything that must be released when the pool goes away however it
goes (close, error, garbage collection, interpreter exit): the worker processes with their pipes
and signals, and the shared memory's file descriptor. A ``weakref.finalize`` releases them, so a
pool that is never closed leaks nothing either.
"""

from __future__ import annotations

import logging
import os
import time
import weakref
from collections.abc import Callable, Sequence
from multiprocessing.context import BaseContext

import gymnasium as gym
from gymnasium import Space

from modelicagym.vector.checks import check_action_spaces, check_observation_spaces
from modelicagym.vector.dispatch.worker_handle import WorkerHandle
from modelicagym.vector.slice.env_slice import EnvSlice, describe_envs
from modelicagym.vector.wire.buffers import BufferSpec, SharedBuffers
from modelicagym.vector.wire.protocol import CREATION, START_UP, EnvDescription, Kind, Message, StepPath, WorkerConfig
from modelicagym.vector.wire.sync import FutexSignal, GoSignal, pool_native_library

__all__ = ["WorkerSet"]

logger = logging.getLogger(__name__)


class _Resources:
    """What must be released when the pool goes away; kept apart from the :class:`WorkerSet` so that
    a ``weakref.finalize`` can release it without keeping anything alive."""

    def __init__(self, handles: list[WorkerHandle]) -> None:
        self.handles = handles
        self.fd: int | None = None

    def release(self) -> None:
        for handle in self.handles:
            handle.release()
        if self.fd is not None:
            os.close(self.fd)
            self.fd = None


class WorkerSet:
    """The worker processes of one pool, each running a contiguous slice of the envs.

    Spaces, metadata, ``render_mode`` and ``spec`` come from worker 0's first env: no env is ever
    created in the parent (FMU instances hold ctypes handles that can be neither pickled nor shared).
    """

    def __init__(
        self,
        env_fns: Sequence[Callable[[], gym.Env]],
        slices: list[range],
        ctx: BaseContext,
        config: WorkerConfig,
        startup_timeout: float | None,
        stand_in: bool = False,
    ) -> None:
        self.handles = [
            WorkerHandle(k, indices, env_fns[indices.start : indices.stop], ctx, config)
            for k, indices in enumerate(slices)
        ]
        if stand_in:  # one more worker, with a copy of every env (`WorkerHandle.home`)
            self.handles.append(WorkerHandle(len(slices), range(len(env_fns)), env_fns, ctx, config, stand_in=True))
        self.num_envs = len(env_fns)
        self._env_fns = env_fns
        self.startup_timeout = startup_timeout
        self._config = config
        self.buffers: SharedBuffers | None = None
        self.description: EnvDescription | None = None
        #: what each worker reported once its envs were created (:meth:`await_created`)
        self.descriptions: list[EnvDescription] = []
        #: per env, the path its slice steps on, and its observation space
        self.step_paths: list[StepPath] = [StepPath("python", "not created yet")] * self.num_envs
        self.observation_spaces: list[Space] = [None] * self.num_envs
        self._resources = _Resources(self.handles)
        self._finalizer = weakref.finalize(self, self._resources.release)

    @property
    def alive(self) -> bool:
        """Whether the workers have not been released yet."""
        return self._finalizer.alive

    def launch(self) -> None:
        """Start every worker process; each begins creating its envs at once."""
        try:
            for handle in self.handles:
                handle.start()
        except BaseException:
            self.release()
            raise

    def await_created(self) -> list[EnvDescription]:
        """Wait until every worker has created its envs; what each reported (kept in
        :attr:`descriptions`). Releases everything if anything fails."""
        try:
            deadline = self._deadline()
            waiting = self.handles[len(self.descriptions):]
            self.descriptions += [self._await_ready(handle, deadline) for handle in waiting]
        except BaseException:
            self.release()
            raise
        return self.descriptions

    def drop_last(self, replacement: range | None = None) -> None:
        """Stop the last worker, whose envs have been created and described but not yet given
        memory: the calling process steps its slice instead, or a plain worker started for the
        envs ``replacement``."""
        handle = self.handles.pop()
        del self.descriptions[len(self.handles):]
        handle.release()
        if replacement is not None:
            fns = self._env_fns[replacement.start : replacement.stop]
            self.handles.append(WorkerHandle(handle.index, replacement, fns, handle.ctx, self._config))
            self.handles[-1].start()

    def unsafe_in_caller(self) -> int | None:
        """The first env of the first worker whose envs are not all safe in the calling process
        (`env_contract.safe_in_caller`), or ``None``."""
        for handle, description in zip(self.handles, self.descriptions):
            if not description.safe_in_caller:
                return handle.env_indices.start
        return None

    def connect(self, local: EnvSlice | None) -> EnvDescription:
        """Wait for the workers' envs, check all envs agree on the spaces, create the shared memory
        and hand it out (to ``local`` too, the slice the calling process steps itself); returns
        the description of the first env (``local``'s when there are no workers). Releases
        everything if anything fails."""
        descriptions = list(self.await_created())
        try:
            deadline = self._deadline()
            if local is not None:
                descriptions.append(describe_envs(local.envs, local.first, self._config.observation_mode))
            self.description = descriptions[0]
            for party, description in zip([*self.handles, local], descriptions):
                self._check_spaces(party, description)
                self.step_paths[party.env_indices.start : party.env_indices.stop] = [description.step_path] * len(
                    party.env_indices)
            slots = len(self.handles) + (local is not None)
            spec = BufferSpec(self.description.observation_space, self.description.action_space, self.num_envs, slots)
            self.buffers, self._resources.fd = SharedBuffers.create(spec)
            _say_what_is_pickled(self.buffers)
            for handle in self.handles:
                self._hand_out_buffers(handle, deadline, needs_reset=False)
            if local is not None:
                local.attach(self.buffers, needs_reset=False)
        except BaseException:
            self.release()
            raise
        return self.description

    def restart(self, handle: WorkerHandle, reason: str, needs_reset: bool) -> None:
        """Replace a failed worker by a fresh one with fresh envs, mapped onto the same memory.

        ``needs_reset`` tells the new worker that its envs have not been reset yet (their next
        step is an autoreset, in ``NEXT_STEP`` mode).
        """
        logger.warning("restarting worker %d: %s", handle.index, reason)
        handle.release()
        handle.start()
        deadline = self._deadline()
        description = self._await_ready(handle, deadline)
        self._check_spaces(handle, description)
        self.step_paths[handle.env_indices.start : handle.env_indices.stop] = [description.step_path] * len(handle.env_indices)
        self._hand_out_buffers(handle, deadline, needs_reset)

    def release(self) -> None:
        """Stop every worker at once and free the pipes, signals and shared memory (idempotent)."""
        self._finalizer()
        self.buffers = None

    def _deadline(self) -> float | None:
        return None if self.startup_timeout is None else time.monotonic() + self.startup_timeout

    def _await_ready(self, handle: WorkerHandle, deadline: float | None) -> EnvDescription:
        message = handle.receive(deadline, None, CREATION)
        if message.kind is Kind.ERROR:
            raise message.data.to_env_error(handle.index, "env creation")
        return message.data

    def _check_spaces(self, handle: WorkerHandle | EnvSlice, description: EnvDescription) -> None:
        """The first env of ``handle``'s slice against env 0 (each slice checked its own envs)."""
        first, start = self.description, handle.env_indices.start
        indices = (0, start)
        check_observation_spaces(self._config.observation_mode, [first.observation_space, description.observation_space], indices)
        check_action_spaces([first.action_space, description.action_space], indices)
        self.observation_spaces[start : start + len(description.observation_spaces)] = description.observation_spaces

    def _hand_out_buffers(self, handle: WorkerHandle, deadline: float | None, needs_reset: bool) -> None:
        if self._config.shared_signals:
            buffers, library = self.buffers, pool_native_library()
            buffers.signals[handle.index] = 0  # a restarted worker starts from unposted signals
            handle.go = GoSignal(library, buffers.signal_address(handle.index, SharedBuffers.GO),
                                 buffers.barrier_address, handle.index)
            handle.done = FutexSignal(library, buffers.signal_address(handle.index, SharedBuffers.DONE))
        handle.send(Message(Kind.BUFFERS, (self.buffers.spec, needs_reset)))
        handle.send_fd(self._resources.fd)
        message = handle.receive(deadline, None, START_UP)
        if message.kind is Kind.ERROR:
            raise message.data.to_env_error(handle.index, START_UP)


def _say_what_is_pickled(buffers: SharedBuffers) -> None:
    """Warn, once per pool, about the spaces whose values travel pickled instead of shared."""
    for name, batch in (("observation", buffers.observations), ("action", buffers.actions)):
        if batch.pickled:
            logger.warning("the %s space %s has no shared-memory layout: its values travel pickled on the "
                           "workers' pipes (slower)", name, batch.space)
