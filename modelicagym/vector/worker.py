"""The worker process: creates a contiguous slice of the envs and steps them on command.

Life of a worker:

1. create its envs (calling the env fns here, never in the parent: FMU instances hold ctypes handles
   that cannot be pickled), check they share their spaces, and send a ``ready`` message describing
   them;
2. receive the layout of the shared memory and its file descriptor, map it, answer ``ok``;
3. loop: wait for ``go``, run the command (step / reset / a message), write results into shared
   memory, post ``done`` and send a reply on the pipe only if there is one (see ``protocol``).

SIGINT is ignored: on Ctrl-C the parent, not every worker, decides what happens (it stops the pool).
The worker exits when told to close, or when it notices its parent has died.
"""

from __future__ import annotations

import dataclasses
import logging
import multiprocessing
import os
import signal
from collections.abc import Callable
from multiprocessing.connection import Connection
from multiprocessing.reduction import ForkingPickler, recv_handle
from time import perf_counter_ns
from typing import Any

import gymnasium as gym
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import CloudpickleWrapper

from modelicagym.vector.buffers import SharedBuffers
from modelicagym.vector.errors import RemoteError, SpaceMismatchError
from modelicagym.vector.protocol import (
    LIVENESS_INTERVAL,
    Command,
    EnvDescription,
    Kind,
    Message,
    Reply,
    WorkerConfig,
)
from modelicagym.vector.sync import Signal

__all__ = ["run_worker"]

logger = logging.getLogger(__name__)

_StepResult = tuple[Any, float, bool, bool, dict[str, Any]]


def run_worker(
    worker_index: int,
    env_fns: CloudpickleWrapper,
    first_env: int,
    conn: Connection,
    go: Signal,
    done: Signal,
    config: WorkerConfig,
) -> None:
    """Entry point of a worker process (the ``target`` of its ``multiprocessing.Process``)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    envs: list[gym.Env] = []
    try:
        try:
            for fn in env_fns.fn:
                envs.append(fn())
            description = _describe(envs, first_env)
        except Exception as exc:
            failed = first_env + len(envs) if len(envs) < len(env_fns.fn) else None
            conn.send(Message(Kind.ERROR, RemoteError.capture(exc, failed)))
            return
        conn.send(Message(Kind.READY, description))
        worker = Worker(worker_index, envs, first_env, conn, go, done, config)
        worker.attach()
        worker.serve()
    except (EOFError, BrokenPipeError, ConnectionResetError):
        logger.debug("worker %d: pipe to the parent closed, exiting", worker_index)
    finally:
        _close_envs(envs)


def _describe(envs: list[gym.Env], first_env: int) -> EnvDescription:
    """What the parent needs to know about the envs; raises if they disagree on their spaces."""
    first = envs[0]
    for offset, env in enumerate(envs[1:], start=1):
        if env.observation_space != first.observation_space or env.action_space != first.action_space:
            raise SpaceMismatchError(
                f"env {first_env + offset} has spaces ({env.observation_space}, {env.action_space}), "
                f"env {first_env} has ({first.observation_space}, {first.action_space}): "
                "all envs of a pool must have the same observation and action spaces"
            )
    description = EnvDescription(
        first.observation_space, first.action_space, dict(first.metadata), first.render_mode, first.spec
    )
    try:
        ForkingPickler.dumps(description.spec)
    except Exception:
        description = dataclasses.replace(description, spec=None)
    return description


def _close_envs(envs: list[gym.Env]) -> None:
    for env in envs:
        try:
            env.close()
        except Exception:
            logger.exception("closing an env failed")


class Worker:
    """Runs the commands of the parent on this process's envs (see the module docstring)."""

    def __init__(
        self,
        index: int,
        envs: list[gym.Env],
        first_env: int,
        conn: Connection,
        go: Signal,
        done: Signal,
        config: WorkerConfig,
    ) -> None:
        self._index = index
        self._envs = envs
        self._first = first_env
        self._conn = conn
        self._go = go
        self._done = done
        self._spin_time = config.spin_time
        self._next_step = config.autoreset_mode is AutoresetMode.NEXT_STEP
        self._same_step = config.autoreset_mode is AutoresetMode.SAME_STEP
        self._needs_reset = [False] * len(envs)
        self._fmu_envs = [env.unwrapped if hasattr(env.unwrapped, "fmu_time_ns") else None for env in envs]
        self._buffers: SharedBuffers | None = None
        self._parent = multiprocessing.parent_process()
        self._parent_pid = os.getppid()
        self._handlers: dict[Kind, Callable[[Any], Message | None]] = {
            Kind.RESET: lambda data: self._reset(*data),
            Kind.CALL: self._call,
            Kind.SET_ATTR: self._set_attr,
        }

    def attach(self) -> None:
        """Receive and map the shared memory, then confirm."""
        spec, needs_reset = self._conn.recv().data
        fd = recv_handle(self._conn)
        try:
            self._buffers = SharedBuffers.attach(spec, fd)
        finally:
            os.close(fd)
        self._needs_reset = [needs_reset] * len(self._envs)
        self._conn.send(Message(Kind.OK))

    def serve(self) -> None:
        """Run commands until told to close (the envs are closed on the way out) or the parent dies."""
        command = self._buffers.command
        while self._wait_for_command():
            code = int(command[self._index])
            if code == Command.STEP:
                reply = self._step()
            elif code == Command.RESET:
                reply = self._reset(None, None)
            elif code == Command.RESET_EMPTY_OPTIONS:
                reply = self._reset(None, {})
            else:
                message = self._conn.recv()
                if message.kind is Kind.CLOSE:
                    self._answer(None)
                    return
                reply = self._handlers[message.kind](message.data)
            self._answer(reply)

    def _wait_for_command(self) -> bool:
        """Wait for ``go``; ``False`` if the parent died meanwhile."""
        if self._go.wait(self._spin_time, LIVENESS_INTERVAL):
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
        """Post ``done``; then send the reply, pickled first so a pickling error becomes the reply
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

    def _step(self) -> Message | None:
        buffers = self._buffers
        actions, observations = buffers.actions, buffers.observations
        rewards, terminations, truncations = buffers.rewards, buffers.terminations, buffers.truncations
        current_env = buffers.current_env
        timed = bool(buffers.timing_enabled[0])
        env_ns = fmu_ns = 0
        infos = []
        for offset, env in enumerate(self._envs):
            index = self._first + offset
            current_env[self._index] = index
            action = actions.read(index)
            if timed:
                fmu_env = self._fmu_envs[offset]
                fmu_start = 0 if fmu_env is None else fmu_env.fmu_time_ns
                start = perf_counter_ns()
            try:
                observation, reward, terminated, truncated, info = self._step_env(offset, env, action)
            except Exception as exc:
                return Message(Kind.ERROR, RemoteError.capture(exc, index))
            if timed:
                env_ns += perf_counter_ns() - start
                if fmu_env is not None:
                    fmu_ns += fmu_env.fmu_time_ns - fmu_start
            observations.write(index, observation)
            rewards[index] = reward
            terminations[index] = terminated
            truncations[index] = truncated
            if info:
                infos.append((index, info))
        if timed:
            buffers.timing[self._index] = (env_ns, fmu_ns)
        return Message(Kind.INFOS, infos) if infos else None

    def _step_env(self, offset: int, env: gym.Env, action: Any) -> _StepResult:
        """One env's part of a vector step, with the autoreset of the pool's mode."""
        if self._next_step:
            if self._needs_reset[offset]:
                observation, info = env.reset()
                result = (observation, 0.0, False, False, info)
            else:
                result = env.step(action)
            self._needs_reset[offset] = bool(result[2] or result[3])
            return result
        observation, reward, terminated, truncated, info = env.step(action)
        if self._same_step and (terminated or truncated):
            reset_observation, reset_info = env.reset()
            info = {"final_obs": observation, "final_info": info, **reset_info}
            observation = reset_observation
        return observation, reward, terminated, truncated, info

    def _reset(self, seeds: list[int | None] | None, options: dict[str, Any] | None) -> Message | None:
        """Reset the envs selected by the shared reset mask."""
        buffers = self._buffers
        mask, observations = buffers.reset_mask, buffers.observations
        infos = []
        for offset, env in enumerate(self._envs):
            index = self._first + offset
            if not mask[index]:
                continue
            buffers.current_env[self._index] = index
            try:
                observation, info = env.reset(seed=None if seeds is None else seeds[offset], options=options)
            except Exception as exc:
                return Message(Kind.ERROR, RemoteError.capture(exc, index))
            observations.write(index, observation)
            self._needs_reset[offset] = False
            if info:
                infos.append((index, info))
        return Message(Kind.INFOS, infos) if infos else None

    def _call(self, data: tuple[str, tuple[Any, ...], dict[str, Any]]) -> Message:
        name, args, kwargs = data
        results = []
        for offset, env in enumerate(self._envs):
            self._buffers.current_env[self._index] = self._first + offset
            try:
                attr = env.get_wrapper_attr(name)
                results.append(attr(*args, **kwargs) if callable(attr) else attr)
            except Exception as exc:
                return Message(Kind.CALL_ERROR, RemoteError.capture(exc, self._first + offset))
        return Message(Kind.RESULTS, results)

    def _set_attr(self, data: tuple[str, list[Any]]) -> Message | None:
        name, values = data
        for offset, (env, value) in enumerate(zip(self._envs, values, strict=True)):
            self._buffers.current_env[self._index] = self._first + offset
            try:
                env.set_wrapper_attr(name, value)
            except Exception as exc:
                return Message(Kind.CALL_ERROR, RemoteError.capture(exc, self._first + offset))
        return None
