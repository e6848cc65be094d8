"""``PoolVectorEnv``: a multi-process vector env, a drop-in for ``gymnasium.vector.AsyncVectorEnv``."""

from __future__ import annotations

import logging
import math
import multiprocessing
import os
import time
import weakref
from multiprocessing.reduction import ForkingPickler
from collections.abc import Callable, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.error import AlreadyPendingCallError, ClosedEnvironmentError, NoAsyncCallError
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.async_vector_env import AsyncState
from gymnasium.vector.utils import batch_space

from modelicagym.vector.buffers import BufferSpec, SharedBuffers
from modelicagym.vector.errors import PoolError
from modelicagym.vector.handle import DONE, WorkerHandle
from modelicagym.vector.protocol import LIVENESS_INTERVAL, Command, EnvDescription, Message, Reply, WorkerConfig
from modelicagym.vector.timing import StepTiming, TimingRecorder

__all__ = ["PoolVectorEnv", "RESTART_INFO_KEY", "plan_workers"]

logger = logging.getLogger(__name__)

#: info key set (to the reason, a string) on envs truncated because their worker was restarted
RESTART_INFO_KEY = "pool_restart"

#: seconds a waiting party spins before it blocks (see ``modelicagym.vector.sync``)
DEFAULT_SPIN_TIME = 100e-6

#: seconds ``close()`` waits for the workers to close their envs when no timeout is given
DEFAULT_CLOSE_TIMEOUT = 30.0

_RESERVED_CALLS = frozenset({"reset", "step", "close"})

#: ``(env index, info)`` pairs, in env order, to merge into the vector infos
_Entries = list[tuple[int, dict[str, Any]]]
#: a command for one worker: its handle, the ``Command`` code and the message that goes with it
_Command = tuple[WorkerHandle, int, Message | None]


def plan_workers(num_envs: int, num_workers: int | None, max_envs_per_worker: int | None) -> list[range]:
    """Split ``num_envs`` envs into contiguous slices, one per worker.

    ``num_workers`` defaults to the number of usable cores, never more than ``num_envs``; with
    ``max_envs_per_worker`` the number of workers grows to ``ceil(num_envs / max_envs_per_worker)``
    if needed (an explicit ``num_workers`` that is too small for it is an error). The first
    ``num_envs % workers`` slices hold one env more than the others.
    """
    if num_envs < 1:
        raise ValueError(f"a pool needs at least one env, got {num_envs}")
    if max_envs_per_worker is not None and max_envs_per_worker < 1:
        raise ValueError(f"max_envs_per_worker must be >= 1, got {max_envs_per_worker}")
    needed = 1 if max_envs_per_worker is None else math.ceil(num_envs / max_envs_per_worker)
    if num_workers is None:
        workers = max(min(_usable_cores(), num_envs), needed)
    else:
        if num_workers < 1:
            raise ValueError(f"num_workers must be >= 1, got {num_workers}")
        if num_workers < needed:
            raise ValueError(
                f"num_workers={num_workers} cannot hold {num_envs} envs with at most "
                f"{max_envs_per_worker} env(s) per worker; use at least {needed} workers"
            )
        workers = min(num_workers, num_envs)
    base, extra = divmod(num_envs, workers)
    slices, start = [], 0
    for k in range(workers):
        stop = start + base + (k < extra)
        slices.append(range(start, stop))
        start = stop
    return slices


def _usable_cores() -> int:
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def default_start_method() -> str:
    """``forkserver`` where available, else ``spawn`` (see :class:`PoolVectorEnv`)."""
    return "forkserver" if "forkserver" in multiprocessing.get_all_start_methods() else "spawn"


class _Resources:
    """What must be released when the pool goes away, however it goes (close, error, GC, exit).

    Kept apart from the pool so that a ``weakref.finalize`` can release it without keeping the
    pool alive.
    """

    def __init__(self) -> None:
        self.handles: list[WorkerHandle] = []
        self.fd: int | None = None

    def release(self) -> None:
        for handle in self.handles:
            handle.release()
        if self.fd is not None:
            os.close(self.fd)
            self.fd = None


class PoolVectorEnv(VectorEnv):
    """Runs ``num_envs`` environments in a few worker processes, each stepping a contiguous slice.

    A drop-in for :class:`gymnasium.vector.AsyncVectorEnv` (same API, same results, same errors),
    built for speed and for envs that are expensive to create and may crash:

    - observations, actions, rewards, terminations and truncations live in shared memory; workers
      write straight into their slice, nothing is pickled on a normal step, and infos travel over a
      pipe only when they are non-empty;
    - the parent and the workers wake each other through semaphores polled with
      ``os.sched_yield()`` for ``spin_time`` seconds before blocking: a step round trip costs a
      few microseconds, and an idle pool sleeps;
    - a worker that dies (segfault), hangs past ``step_timeout``, or whose env raises, is reported
      with the env index and the exit signal or the original traceback -- and, with
      ``restart_dead_workers=True``, restarted while the pool goes on;
    - spaces, metadata, ``render_mode`` and ``spec`` come from worker 0: no env is ever created in
      the parent (FMU instances hold ctypes handles that can neither be pickled nor shared).

    The step and autoreset contract is Gymnasium's (https://farama.org/Vector-Autoreset-Mode),
    identical step by step to :class:`gymnasium.vector.SyncVectorEnv` over the same env fns and seeds:

    - ``NEXT_STEP`` (default): an env that ended in step ``t`` is reset in step ``t + 1``; that
      step ignores its action and returns the reset observation, reward 0 and both flags false.
    - ``SAME_STEP``: an env that ended is reset in the same step; the step returns the reset
      observation and puts the last one in ``infos["final_obs"]`` and its info in
      ``infos["final_info"]``.
    - ``DISABLED``: nothing is reset automatically; reset ended envs with
      ``reset(options={"reset_mask": mask})``.

    When a worker is restarted (``restart_dead_workers=True``), each of its envs is recreated and
    reports ``truncated=True``, ``terminated=False``, reward 0 for that step, with the reason in
    ``infos["pool_restart"]``. Then, as for any truncation: in ``NEXT_STEP`` the next step resets
    it (the observation returned with the truncation is its last one from before the failure); in
    ``SAME_STEP`` it is reset at once (``final_obs`` is that last observation); in ``DISABLED`` you
    reset it. A failure that is not recovered stops the whole pool (all workers, all shared
    memory) before the error is raised; further calls raise ``ClosedEnvironmentError``.

    Start method: ``forkserver`` by default on Linux (``spawn`` where it is missing). Workers are
    forked from a small, single-threaded server process rather than from the caller, because the
    caller typically runs threads (PyTorch/BLAS pools, loggers) that make ``fork`` unsafe, and
    workers are restarted mid-run when such threads certainly exist; workers also inherit nothing
    else from the caller (no FMU libraries it may have loaded, no other pools' pipes). The cost is
    paid once per worker start (about 0.2 s on the target machine, small next to creating an FMU
    env) and env fns must be picklable by ``cloudpickle`` (lambdas and closures are). As with
    every non-fork start method, a script must guard its entry point with
    ``if __name__ == "__main__":``. ``start_method="fork"`` starts fastest and suits tests and
    thread-free callers.

    Example:
        >>> import gymnasium as gym
        >>> from modelicagym.vector import PoolVectorEnv
        >>> envs = PoolVectorEnv([lambda: gym.make("CartPole-v1") for _ in range(4)], num_workers=2)
        >>> envs
        PoolVectorEnv(CartPole-v1, num_envs=4)
        >>> observations, infos = envs.reset(seed=42)
        >>> observations.shape
        (4, 4)
        >>> _ = envs.action_space.seed(42)
        >>> observations, rewards, terminations, truncations, infos = envs.step(envs.action_space.sample())
        >>> rewards
        array([1., 1., 1., 1.])
        >>> terminations, truncations
        (array([False, False, False, False]), array([False, False, False, False]))
        >>> envs.set_timing(True)
        >>> _ = envs.step(envs.action_space.sample())
        >>> envs.timing().steps
        1
        >>> envs.close()
    """

    def __init__(
        self,
        env_fns: Sequence[Callable[[], gym.Env]],
        *,
        num_workers: int | None = None,
        start_method: str | None = None,
        autoreset_mode: str | AutoresetMode = AutoresetMode.NEXT_STEP,
        step_timeout: float | None = None,
        restart_dead_workers: bool = False,
        max_envs_per_worker: int | None = None,
        measure_timing: bool = False,
        copy: bool = True,
        spin_time: float = DEFAULT_SPIN_TIME,
        startup_timeout: float | None = None,
    ) -> None:
        """Start the workers, create the envs in them and set up shared memory.

        Args:
            env_fns: functions creating the envs, sent to the workers with cloudpickle. If one has
                an attribute ``max_envs_per_process`` (e.g. 1 for an FMU that can be instantiated
                only once per process), it caps the envs per worker like ``max_envs_per_worker``.
            num_workers: worker processes; default one per usable core, never more than envs.
            start_method: ``multiprocessing`` start method; default ``forkserver`` (see above).
            autoreset_mode: ``AutoresetMode`` (or its value), default ``NEXT_STEP``.
            step_timeout: seconds any call into the envs (step, reset, call, set_attr) may take
                before its worker is declared hung and killed; ``None`` waits forever, but a dead
                worker is still noticed within 50 ms.
            restart_dead_workers: restart a worker whose process died, hung or whose env raised,
                recreate its envs and report them truncated (see above) instead of raising.
            max_envs_per_worker: at most this many envs in one worker process.
            measure_timing: measure where step time goes from the start (see :meth:`timing`).
            copy: return copies of the observations (else views of shared memory, overwritten by
                the next step).
            spin_time: seconds a waiting party polls before it blocks.
            startup_timeout: seconds a worker may take to create its envs (``None``: no limit).
        """
        self.env_fns = list(env_fns)
        self.num_envs = len(self.env_fns)
        self.autoreset_mode = (
            autoreset_mode if isinstance(autoreset_mode, AutoresetMode) else AutoresetMode(autoreset_mode)
        )
        self.step_timeout = step_timeout
        self.restart_dead_workers = restart_dead_workers
        self.startup_timeout = startup_timeout
        self.copy = copy
        self._spin_time = spin_time
        caps = [max_envs_per_worker] + [getattr(fn, "max_envs_per_process", None) for fn in self.env_fns]
        caps = [cap for cap in caps if cap is not None]
        slices = plan_workers(self.num_envs, num_workers, min(caps) if caps else None)
        self.num_workers = len(slices)
        self.start_method = start_method or default_start_method()
        ctx = multiprocessing.get_context(self.start_method)

        self._state = AsyncState.DEFAULT
        self._pending: list[_Command] = []
        self._timing = TimingRecorder()
        self._timing_enabled = False
        self._step_started_ns = 0
        self._resources = _Resources()
        self._finalizer = weakref.finalize(self, self._resources.release)
        config = WorkerConfig(self.autoreset_mode, spin_time)
        self._handles = [
            WorkerHandle(k, indices, self.env_fns[indices.start : indices.stop], ctx, config)
            for k, indices in enumerate(slices)
        ]
        self._resources.handles = self._handles
        self._step_commands: list[_Command] = [(handle, Command.STEP, None) for handle in self._handles]
        try:
            self._start(self._handles)
        except BaseException:
            self._finalizer()
            self.closed = True
            raise
        self.set_timing(measure_timing)

    # ------------------------------------------------------------------ start and restart

    def _start(self, handles: list[WorkerHandle]) -> None:
        """Start workers, learn the spaces from worker 0, create shared memory and hand it out."""
        for handle in handles:
            handle.start()
        deadline = None if self.startup_timeout is None else time.monotonic() + self.startup_timeout
        descriptions = [self._await_ready(handle, deadline) for handle in handles]
        first = descriptions[0]
        self.metadata = dict(first.metadata)
        self.metadata["autoreset_mode"] = self.autoreset_mode
        self.render_mode = first.render_mode
        self.spec = first.spec
        self.single_observation_space = first.observation_space
        self.single_action_space = first.action_space
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        for handle, description in zip(handles, descriptions, strict=True):
            self._check_spaces(handle, description)
        spec = BufferSpec(self.single_observation_space, self.single_action_space, self.num_envs, self.num_workers)
        self._buffers, self._resources.fd = SharedBuffers.create(spec)
        for handle in handles:
            self._hand_out_buffers(handle, deadline, needs_reset=False)

    def _await_ready(self, handle: WorkerHandle, deadline: float | None) -> EnvDescription:
        message = handle.receive(deadline, None, "creation")
        if message.kind == "error":
            raise message.data.to_env_error(handle.index, "env creation")
        return message.data

    def _check_spaces(self, handle: WorkerHandle, description: EnvDescription) -> None:
        if description.observation_space != self.single_observation_space:
            raise RuntimeError(
                f"envs {handle.describe_envs()} have observation space {description.observation_space}, "
                f"env 0 has {self.single_observation_space}: all envs must have the same spaces"
            )
        if description.action_space != self.single_action_space:
            raise RuntimeError(
                f"envs {handle.describe_envs()} have action space {description.action_space}, "
                f"env 0 has {self.single_action_space}: all envs must have the same spaces"
            )

    def _hand_out_buffers(self, handle: WorkerHandle, deadline: float | None, needs_reset: bool) -> None:
        handle.send(Message("buffers", (self._buffers.spec, needs_reset)))
        handle.send_fd(self._resources.fd)
        message = handle.receive(deadline, None, "start-up")
        if message.kind == "error":
            raise message.data.to_env_error(handle.index, "start-up")

    def _restart(self, handle: WorkerHandle, failure: PoolError) -> str:
        """Replace a failed worker by a fresh one with fresh envs; returns the reason, for infos."""
        reason = str(failure)
        logger.warning("restarting worker %d: %s", handle.index, reason)
        handle.release()
        handle.start()
        deadline = None if self.startup_timeout is None else time.monotonic() + self.startup_timeout
        self._check_spaces(handle, self._await_ready(handle, deadline))
        self._hand_out_buffers(handle, deadline, needs_reset=self.autoreset_mode is AutoresetMode.NEXT_STEP)
        return reason

    # ------------------------------------------------------------------ dispatch and gather

    def _dispatch(self, commands: list[_Command], state: AsyncState) -> None:
        """Wake the workers with their commands, then send the messages that go with them.

        Messages are pickled before anything else happens, so an unpicklable argument raises here
        with no worker woken. Waking before sending means a large message can never fill the pipe
        while its reader sleeps. A worker that died meanwhile makes the send fail; that is reported
        by :meth:`_gather`.
        """
        payloads: dict[int, bytes] = {}
        for _, _, message in commands:
            if message is not None and id(message) not in payloads:
                payloads[id(message)] = bytes(ForkingPickler.dumps(message))
        command = self._buffers.command
        for handle, code, message in commands:
            command[handle.index] = code
            handle.go.post()
            if message is not None:
                try:
                    handle.conn.send_bytes(payloads[id(message)])
                except OSError:
                    logger.debug("worker %d: pipe broken while sending %s", handle.index, message.kind)
        self._pending = commands
        self._state = state

    def _wait_all_done(self, timeout: float | None) -> bool:
        """The hot path of ``_gather``: ``True`` if every pending worker posted ``done`` within
        one spin-then-block wait and none has a reply on its pipe; the batch is then complete.

        Otherwise (``False``) nothing is lost: the workers already seen done are left to
        :meth:`_gather`, which sees them done at once and handles replies, deaths and timeouts.
        """
        block = LIVENESS_INTERVAL if timeout is None else min(timeout, LIVENESS_INTERVAL)
        spin_time, pending = self._spin_time, self._pending
        try:
            for k, (handle, _, _) in enumerate(pending):
                if not handle.done.wait(spin_time, block):
                    self._requeue(pending, k)
                    return False
        except BaseException:
            self._abort()
            raise
        if self._buffers.reply.any():
            self._requeue(pending, len(pending))
            return False
        self._pending = []
        self._state = AsyncState.DEFAULT
        return True

    def _requeue(self, pending: list[_Command], done: int) -> None:
        """Post ``done`` again for the first ``done`` pending workers (their wait was consumed)."""
        for handle, _, _ in pending[:done]:
            handle.done.post()

    def _gather(self, timeout: float | None, doing: str) -> list[tuple[WorkerHandle, Message | None, PoolError | None]]:
        """Wait for every pending worker; per worker its reply message and/or its failure.

        On any other exception (e.g. ``KeyboardInterrupt``) while waiting, the pool is stopped
        before the exception propagates: a half-finished batch cannot be resumed.
        """
        if timeout is None:
            timeout = self.step_timeout
        deadline = None if timeout is None else time.monotonic() + timeout
        pending, self._pending = self._pending, []
        self._state = AsyncState.DEFAULT
        current_env, reply = self._buffers.current_env, self._buffers.reply
        results = []
        try:
            for handle, _, _ in pending:
                status = handle.wait_done(self._spin_time, deadline)
                failure = None if status == DONE else handle.failure(status, int(current_env[handle.index]), doing)
                message = None
                if failure is None and reply[handle.index] == Reply.MESSAGE:
                    try:
                        message = handle.receive(deadline, int(current_env[handle.index]), doing)
                    except PoolError as error:
                        failure = error
                if message is not None and message.kind == "error":
                    failure = message.data.to_env_error(handle.index, doing)
                results.append((handle, message, failure))
        except BaseException:
            self._abort()
            raise
        return results

    def _recover(self, handle: WorkerHandle, failure: PoolError) -> str:
        """Restart ``handle`` if allowed, else stop the pool and raise ``failure``."""
        if not self.restart_dead_workers:
            self._abort()
            raise failure
        try:
            return self._restart(handle, failure)
        except BaseException:
            self._abort()
            raise

    def _abort(self) -> None:
        """Stop every worker and free everything, without waiting for the envs to close.

        The parent's mapping of the shared memory goes with the last reference to it: at once,
        unless the caller still holds observations returned with ``copy=False``.
        """
        self._pending = []
        self._state = AsyncState.DEFAULT
        self._finalizer()
        self._buffers = None
        self.closed = True

    def _assert_is_running(self) -> None:
        if self.closed:
            raise ClosedEnvironmentError(f"Trying to operate on `{type(self).__name__}`, after a call to `close()`.")

    def _assert_idle(self, call: str) -> None:
        if self._state != AsyncState.DEFAULT:
            raise AlreadyPendingCallError(
                f"Calling `{call}` while waiting for a pending call to `{self._state.value}` to complete.",
                str(self._state.value),
            )

    def _assert_waiting(self, state: AsyncState, call: str, prior: str) -> None:
        if self._state != state:
            raise NoAsyncCallError(f"Calling `{call}` without any prior call to `{prior}`.", state.value)

    def _merge_infos(self, entries: _Entries) -> dict[str, Any]:
        infos: dict[str, Any] = {}
        for index, info in entries:
            infos = self._add_info(infos, info, index)
        return infos

    # ------------------------------------------------------------------ reset

    def reset(
        self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        """Reset all envs (or those in ``options["reset_mask"]``); see ``AsyncVectorEnv.reset``.

        Args:
            seed: ``None`` (random seeds), an int (env ``i`` gets ``seed + i``) or one seed per env.
            options: passed to every env's ``reset``; a boolean array ``"reset_mask"`` of shape
                ``(num_envs,)`` selects the envs to reset (the others keep their observation).

        Returns:
            The batch of observations and the merged infos of the reset envs.
        """
        self.reset_async(seed=seed, options=options)
        return self.reset_wait()

    def reset_async(self, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None) -> None:
        """Start resetting; collect the result with :meth:`reset_wait`."""
        self._assert_is_running()
        if seed is None:
            seed = [None] * self.num_envs
        elif isinstance(seed, int):
            seed = [seed + i for i in range(self.num_envs)]
        if len(seed) != self.num_envs:
            raise ValueError(
                f"If seeds are passed as a list the length must match num_envs={self.num_envs} but got length={len(seed)}."
            )
        self._assert_idle("reset_async")
        mask = np.ones(self.num_envs, dtype=np.bool_)
        if options is not None and "reset_mask" in options:
            options = dict(options)
            mask = _check_reset_mask(options.pop("reset_mask"), self.num_envs)
        self._buffers.reset_mask[:] = mask
        fast = all(s is None for s in seed) and not options
        code = Command.RESET if options is None else Command.RESET_EMPTY_OPTIONS
        commands = []
        for handle in self._handles:
            indices = handle.env_indices
            if not mask[indices.start : indices.stop].any():
                continue
            if fast:
                commands.append((handle, code, None))
            else:
                message = Message("reset", (seed[indices.start : indices.stop], options))
                commands.append((handle, Command.MESSAGE, message))
        self._dispatch(commands, AsyncState.WAITING_RESET)

    def reset_wait(self, timeout: float | None = None) -> tuple[Any, dict[str, Any]]:
        """Wait for :meth:`reset_async`; ``timeout`` defaults to ``step_timeout``."""
        self._assert_is_running()
        self._assert_waiting(AsyncState.WAITING_RESET, "reset_wait", "reset_async")
        commands = self._pending
        entries: _Entries = []
        for (handle, message, failure), command in zip(self._gather(timeout, "reset"), commands, strict=True):
            if failure is not None:
                entries += self._retry_reset(handle, failure, command)
            elif message is not None:
                entries += message.data
        return self._buffers.observations.read_batch(self.copy), self._merge_infos(entries)

    def _retry_reset(self, handle: WorkerHandle, failure: PoolError, command: _Command) -> _Entries:
        """Restart a worker that failed a reset and reset its new envs the same way, once."""
        reason = self._recover(handle, failure)
        _, code, message = command
        self._dispatch([(handle, code, message)], AsyncState.WAITING_RESET)
        [(_, reply, second)] = self._gather(None, "reset")
        if second is not None:
            self._abort()
            raise second from failure
        entries = dict(reply.data) if reply is not None else {}
        mask = self._buffers.reset_mask
        return [(i, {**entries.get(i, {}), RESTART_INFO_KEY: reason}) for i in handle.env_indices if mask[i]]

    # ------------------------------------------------------------------ step

    def step(self, actions: Any) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Step every env with its action; returns batched ``(obs, rewards, terminations,
        truncations, infos)`` as :class:`~gymnasium.vector.SyncVectorEnv` does."""
        self.step_async(actions)
        return self.step_wait()

    def step_async(self, actions: Any) -> None:
        """Write the actions to shared memory and wake the workers; see :meth:`step_wait`."""
        self._assert_is_running()
        self._assert_idle("step_async")
        if self._timing_enabled:
            self._step_started_ns = time.perf_counter_ns()
        buffers = self._buffers
        buffers.actions.write_batch(actions)
        # the hot path of ``_dispatch``: no messages, every worker steps
        buffers.command[:] = Command.STEP
        for handle in self._handles:
            handle.go.post()
        self._pending = self._step_commands
        self._state = AsyncState.WAITING_STEP

    def step_wait(self, timeout: float | None = None) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Wait for the step started by :meth:`step_async`; ``timeout`` defaults to ``step_timeout``."""
        self._assert_is_running()
        self._assert_waiting(AsyncState.WAITING_STEP, "step_wait", "step_async")
        buffers = self._buffers
        entries: _Entries = []
        restarted = False
        if timeout is None:
            timeout = self.step_timeout
        started = None if timeout is None else time.monotonic()
        if not self._wait_all_done(timeout):
            if started is not None:
                timeout = max(timeout - (time.monotonic() - started), 0.0)
            for handle, message, failure in self._gather(timeout, "step"):
                if failure is not None:
                    entries += self._restart_after_step(handle, failure)
                    restarted = True
                elif message is not None:
                    entries += message.data
        if self._timing_enabled and not restarted:
            timing = buffers.timing
            self._timing.add(
                time.perf_counter_ns() - self._step_started_ns,
                timing[:, SharedBuffers.ENV_NS],
                timing[:, SharedBuffers.FMU_NS],
            )
        return (
            buffers.observations.read_batch(self.copy),
            buffers.rewards.copy(),
            buffers.terminations.copy(),
            buffers.truncations.copy(),
            self._merge_infos(entries),
        )

    def _restart_after_step(self, handle: WorkerHandle, failure: PoolError) -> _Entries:
        """Restart a worker that failed a step; its envs report a truncation (class docstring)."""
        buffers = self._buffers
        indices = handle.env_indices
        last_observations = [buffers.observations.read(i) for i in indices]
        reason = self._recover(handle, failure)
        buffers.rewards[indices.start : indices.stop] = 0.0
        buffers.terminations[indices.start : indices.stop] = False
        buffers.truncations[indices.start : indices.stop] = True
        if self.autoreset_mode is not AutoresetMode.SAME_STEP:
            return [(i, {RESTART_INFO_KEY: reason}) for i in indices]
        buffers.reset_mask[indices.start : indices.stop] = True
        self._dispatch([(handle, Command.RESET, None)], AsyncState.WAITING_STEP)
        [(_, reply, second)] = self._gather(None, "reset after restart")
        if second is not None:
            self._abort()
            raise second from failure
        reset_infos = dict(reply.data) if reply is not None else {}
        return [
            (
                i,
                {
                    "final_obs": last,
                    "final_info": {RESTART_INFO_KEY: reason},
                    **reset_infos.get(i, {}),
                    RESTART_INFO_KEY: reason,
                },
            )
            for i, last in zip(indices, last_observations, strict=True)
        ]

    # ------------------------------------------------------------------ call, attributes, render

    def call(self, name: str, *args: Any, **kwargs: Any) -> tuple[Any, ...]:
        """Call method ``name`` of every env (or read attribute ``name``); one result per env."""
        self.call_async(name, *args, **kwargs)
        return self.call_wait()

    def call_async(self, name: str, *args: Any, **kwargs: Any) -> None:
        """Start :meth:`call`; collect the results with :meth:`call_wait`."""
        self._assert_is_running()
        self._assert_idle("call_async")
        if name in _RESERVED_CALLS:
            raise ValueError(f"Trying to call function `{name}` with `call`, use `{name}` directly instead.")
        message = Message("call", (name, args, kwargs))
        self._dispatch([(handle, Command.MESSAGE, message) for handle in self._handles], AsyncState.WAITING_CALL)

    def call_wait(self, timeout: float | None = None) -> tuple[Any, ...]:
        """Wait for :meth:`call_async`; ``timeout`` defaults to ``step_timeout``."""
        self._assert_is_running()
        self._assert_waiting(AsyncState.WAITING_CALL, "call_wait", "call_async")
        return tuple(self._collect_calls(timeout, "call"))

    def get_attr(self, name: str) -> tuple[Any, ...]:
        """Attribute ``name`` of every env (through wrappers, like ``env.get_wrapper_attr``)."""
        return self.call(name)

    def set_attr(self, name: str, values: list[Any] | tuple[Any, ...] | Any) -> None:
        """Set attribute ``name`` of every env: a list/tuple gives one value per env, anything
        else is set on all of them."""
        self._assert_is_running()
        if not isinstance(values, (list, tuple)):
            values = [values] * self.num_envs
        if len(values) != self.num_envs:
            raise ValueError(
                "Values must be a list or tuple with length equal to the number of environments. "
                f"Got `{len(values)}` values for {self.num_envs} environments."
            )
        self._assert_idle("set_attr")
        self._dispatch(
            [
                (h, Command.MESSAGE, Message("set_attr", (name, list(values[h.env_indices.start : h.env_indices.stop]))))
                for h in self._handles
            ],
            AsyncState.WAITING_CALL,
        )
        self._collect_calls(None, "set_attr")

    def render(self) -> tuple[Any, ...] | None:
        """The rendered frames of the envs (``render_mode`` applies)."""
        return self.call("render")

    def _collect_calls(self, timeout: float | None, doing: str) -> list[Any]:
        """Results of a pending call/set_attr, in env order; raises the first env's exception.

        A worker that died or hung is restarted (if allowed) so the pool stays usable, and the
        failure is raised either way: the call has no result for its envs.
        """
        results: list[Any] = []
        call_errors = []
        for handle, message, failure in self._gather(timeout, doing):
            if failure is not None:
                self._recover(handle, failure)
                raise failure
            if message is None:
                continue
            if message.kind == "call_error":
                call_errors.append((handle.index, message.data))
            elif message.kind == "results":
                results += message.data
        if call_errors:
            worker_index, remote = call_errors[0]
            original = remote.original()
            raise original if original is not None else remote.to_env_error(worker_index, doing)
        return results

    @property
    def np_random_seed(self) -> tuple[int, ...]:
        """The ``np_random_seed`` of every env."""
        return self.get_attr("np_random_seed")

    @property
    def np_random(self) -> tuple[np.random.Generator, ...]:
        """The ``np_random`` generator of every env."""
        return self.get_attr("np_random")

    # ------------------------------------------------------------------ timing

    def set_timing(self, enabled: bool) -> None:
        """Switch step-time measurement on or off (and forget what was measured so far).

        When off, the only cost is one flag check per worker and step.
        """
        self._assert_is_running()
        self._assert_idle("set_timing")
        self._timing_enabled = bool(enabled)
        self._buffers.timing_enabled[0] = self._timing_enabled
        self._timing.clear()

    def timing(self, reset: bool = False) -> StepTiming:
        """Where step time went, as means per batch step since timing was switched on.

        See :mod:`modelicagym.vector.timing` for the exact definitions; ``reset`` starts a new
        measurement after reading this one.
        """
        summary = self._timing.summary()
        if reset:
            self._timing.clear()
        return summary

    # ------------------------------------------------------------------ close

    def close_extras(self, timeout: float | None = None, terminate: bool = False) -> None:
        """Close the envs in their workers, stop the workers and free the shared memory.

        Args:
            timeout: seconds to wait, in all, for a pending call and then for the workers to close
                their envs and exit; ``None`` means ``step_timeout``, or ``DEFAULT_CLOSE_TIMEOUT``
                if that is ``None`` too. Workers still running after that are terminated.
            terminate: terminate the workers at once, without closing the envs.
        """
        if not self._finalizer.alive:
            return
        if timeout is None:
            timeout = DEFAULT_CLOSE_TIMEOUT if self.step_timeout is None else self.step_timeout
        deadline = time.monotonic() + timeout
        if self._state != AsyncState.DEFAULT and not terminate:
            logger.warning("closing %s while a call to `%s` is pending; waiting for it", self, self._state.value)
            failures = [failure for _, _, failure in self._gather(timeout, self._state.value)]
            terminate = any(failure is not None for failure in failures)
        if not terminate:
            self._dispatch(
                [(h, Command.MESSAGE, Message("close")) for h in self._handles if h.is_alive()], AsyncState.DEFAULT
            )
            self._pending = []
            for handle in self._handles:
                if handle.is_alive():
                    handle.join(max(deadline - time.monotonic(), 0.0))
        self._abort()

    def __enter__(self) -> PoolVectorEnv:
        return self

    def __exit__(self, *args: Any) -> None:
        self.close()


def _check_reset_mask(reset_mask: Any, num_envs: int) -> np.ndarray:
    """Validate ``options["reset_mask"]`` exactly as ``AsyncVectorEnv`` does."""
    if not isinstance(reset_mask, np.ndarray):
        raise TypeError(f"`options['reset_mask']` must be a numpy array, got {type(reset_mask)}")
    if reset_mask.shape != (num_envs,):
        raise ValueError(f"`options['reset_mask']` must have shape `({num_envs},)`, got {reset_mask.shape}")
    if reset_mask.dtype != np.bool_:
        raise TypeError(f"`options['reset_mask']` must have `dtype=np.bool_`, got {reset_mask.dtype}")
    if not np.any(reset_mask):
        raise ValueError(
            f"`options['reset_mask']` must contain a boolean array with at least one True value, got reset_mask={reset_mask}"
        )
    return reset_mask
