"""A contiguous slice of a pool's envs, run against the shared buffers: the work of a step.

An :class:`EnvSlice` is what a worker process runs (:mod:`~modelicagym.vector.worker.worker_process`), and what
the calling process runs itself when it steps a slice of the envs (``caller_steps``): the envs,
the autoreset of the pool's mode, and where the results go in shared memory. It knows nothing of
processes, pipes or signals; each command returns the reply message the parent gets (``None`` when
there is nothing to say).

A slice of bare `FMUEnv` instances on the native step path steps in one C call
(:class:`~modelicagym.vector.slice.native_slice.NativeBatch`); whatever C leaves to Python (an FMU error, a
reset the reset ladder must do, an info to report) is finished here, on the Python path. Envs
whose reward or termination is written in Python step natively too, their endings computed here
between two C calls (:class:`~modelicagym.vector.slice.slice_endings.SliceEndings`), and so do
envs whose inputs or observations are Python's, those computed here around the C calls
(:class:`~modelicagym.vector.slice.slice_edges.SliceEdges`). The results are the same either way.
``step_path`` and ``step_path_reason`` say which path a slice takes.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable
from itertools import islice
from multiprocessing.reduction import ForkingPickler
from time import perf_counter_ns
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode

from modelicagym.native.abi import RESET_THEN_STEP, Flags
from modelicagym.vector.checks import check_action_spaces, check_observation_spaces
from modelicagym.vector.env_contract import PoolEnv, StepResult, TimedEnv, safe_in_caller
from modelicagym.vector.errors import RemoteError
from modelicagym.vector.reset_options import options_of_env
from modelicagym.vector.slice.autoreset import Autoreset
from modelicagym.vector.slice.creation import create_envs
from modelicagym.vector.slice.native_slice import NativeBatch, batch_path_reason, python_sides
from modelicagym.vector.slice.slice_edges import SliceEdges
from modelicagym.vector.slice.slice_endings import SliceEndings, has_python_endings
from modelicagym.vector.wire.buffers import SharedBuffers
from modelicagym.vector.wire.protocol import Command, EnvDescription, Kind, Message, StepPath, same_step_info

__all__ = ["EnvSlice", "describe_envs"]

logger = logging.getLogger(__name__)


def movable_reason(envs: list[gym.Env], name: str, first: int = 0) -> str | None:
    """Why ``envs`` cannot move between processes at an episode boundary (``None``: they can).
    Either step path moves them (both honour ``in_caller`` and ``RESET_THEN_STEP``); a layout
    that steps copies in the calling process checks for the native path itself."""
    for offset, env in enumerate(envs):
        if not getattr(env, "reset_is_deterministic", False):
            return f"{name.format(first + offset)} does not reset deterministically (random parameters or its own reset)"
        hooks = getattr(env, "per_env_hooks", ())
        if hooks:
            return (f"{name.format(first + offset)} runs Python per env and step ({', '.join(hooks)} of "
                    f"{type(env).__name__}), which may keep state in the env itself (set stateless_hooks = True "
                    "on the class if it keeps none)")
    return None


def native_reason(envs: list[PoolEnv]) -> str:
    """Why a native slice of ``envs`` steps natively: what its envs say when they agree."""
    reasons = {getattr(env, "step_path_reason", "") for env in envs}
    return reasons.pop() if len(reasons) == 1 else "the FMUs step in C; some envs' rewards or terminations in Python"


def describe_envs(envs: list[PoolEnv], first_env: int, observation_mode: str = "same") -> EnvDescription:
    """What the parent needs to know about the envs; raises if they disagree on their spaces
    (under ``observation_mode``, see `modelicagym.vector.checks`)."""
    first = envs[0]
    observation_spaces = [env.observation_space for env in envs]
    indices = range(first_env, first_env + len(envs))
    check_observation_spaces(observation_mode, observation_spaces, indices)
    check_action_spaces([env.action_space for env in envs], indices)
    reason = batch_path_reason(envs)
    step_path = StepPath("python", reason) if reason else StepPath("native", native_reason(envs))
    description = EnvDescription(
        first.observation_space, first.action_space, dict(first.metadata), first.render_mode, first.spec, step_path,
        tuple(observation_spaces), all(safe_in_caller(env) for env in envs),
        movable_reason(envs, "env {}", first_env),
        all(getattr(getattr(env, "unwrapped", env), "clips_actions", False) is True for env in envs),
    )
    try:
        ForkingPickler.dumps(description.spec)
    except Exception:
        description = dataclasses.replace(description, spec=None)
    return description


class EnvSlice:
    """The envs ``first_env, first_env + 1, ...`` of a pool, stepped into shared memory.

    Args:
        envs: the envs, created in this process.
        first_env: the pool index of ``envs[0]``.
        slot: this slice's row in the per-slice shared arrays (``current_env``, ``timing``).
        autoreset_mode: the pool's autoreset mode.
        caller: the calling process runs the slice: a step steps its envs marked in the shared
            ``in_caller`` array (a worker's slice steps those not marked). Resets, calls and
            attributes reach every env of the slice, stepped here or not, so that two copies of
            an env stay interchangeable (see `modelicagym.vector.layout.placement`).
    """

    def __init__(
        self, envs: list[PoolEnv], first_env: int, slot: int, autoreset_mode: AutoresetMode, caller: bool = False
    ) -> None:
        self.envs = envs
        self.first = first_env
        self.slot = slot
        #: as a worker handle's: the slot, and the pool indices of the envs
        self.index = slot
        self.env_indices = range(first_env, first_env + len(envs))
        self.buffers: SharedBuffers | None = None
        self.autoreset_mode = autoreset_mode
        self.caller = caller
        #: per env of the slice, a view of the shared ``needs_reset`` once attached
        self.needs_reset = np.zeros(len(envs), dtype=np.uint8)
        #: the pool's autoreset on the Python path (its C twin steps the native path)
        self.autoreset = Autoreset(autoreset_mode, self.needs_reset)
        reason = batch_path_reason(envs)
        self.step_path = "python" if reason else "native"
        self.step_path_reason = reason or native_reason(envs)
        self.native: NativeBatch | None = None
        #: what Python computes around the native slice's C calls each step: its envs' endings
        #: (`SliceEndings`), and their inputs or observations with them (`SliceEdges`); ``None``
        #: when the C call does the whole step (the calling process's hot path, `dispatch`)
        self.endings: SliceEndings | SliceEdges | None = None
        self._fmu_envs = [env.unwrapped if isinstance(env.unwrapped, TimedEnv) else None for env in envs]
        self.handlers = {
            Kind.STEP: self.step_with,
            Kind.RESET: lambda data: self.reset(*data),
            Kind.CALL: self.call,
            Kind.SET_ATTR: self.set_attr,
            Kind.CALL_EACH: self.call_each,
        }

    @classmethod
    def create(
        cls,
        env_fns: list[Callable[[], gym.Env]],
        indices: range,
        slot: int,
        autoreset_mode: AutoresetMode,
        share: float = 1.0,
    ) -> EnvSlice:
        """Create the envs ``indices`` here (the calling process's slice, ``caller``) with
        `create_envs`, whose memory ``share`` they may take; closes them on failure."""
        envs = create_envs(env_fns[indices.start : indices.stop], indices.start, "the calling process", share)
        return cls(envs, indices.start, slot, autoreset_mode, caller=True)

    def run(self, code: int, message: Message | None) -> Message | None:
        """Run one command of the protocol (a ``Command`` code, and the message of ``MESSAGE``)."""
        if code == Command.STEP:
            return self.step()
        if code == Command.RESET:
            return self.reset(None, None)
        if code == Command.RESET_EMPTY_OPTIONS:
            return self.reset(None, {})
        return self.handlers[message.kind](message.data)

    def attach(self, buffers: SharedBuffers, needs_reset: bool) -> None:
        """Work on ``buffers`` from now on; ``needs_reset``: the envs were never reset."""
        self.buffers = buffers
        rows = slice(self.first, self.first + len(self.envs))
        self.needs_reset = buffers.needs_reset[rows]
        self.needs_reset[:] = needs_reset
        #: the slice's rows of the step masks, and where its observations go (`_step_python`)
        self._step_mask, self._in_caller = buffers.step_mask[rows], buffers.in_caller[rows]
        self._observations = buffers.observations.targets()
        self.autoreset = Autoreset(self.autoreset_mode, self.needs_reset)
        if self.step_path == "native":
            python_endings = has_python_endings(self.envs)
            python_inputs, python_observation = python_sides(self.envs[0])
            self.native = NativeBatch(self.envs, self.first, self.autoreset_mode, buffers, self.slot, self.caller,
                                      python_endings, python_inputs, python_observation)
            if python_endings:
                self.endings = SliceEndings(self.envs, self.native, buffers, self.first, self.slot)
            if python_inputs or python_observation:
                self.endings = SliceEdges(self.envs, self.native, buffers, self.first, self.slot, self.autoreset_mode,
                                          self.endings, self._actions)

    def detach(self) -> None:
        """Stop using the shared buffers (the pool released them)."""
        self.buffers = self.native = self.endings = None
        self._step_mask = self._in_caller = self._observations = None

    def step(self) -> Message | None:
        """Step every env with its action from shared memory, with the pool's autoreset."""
        native = self.native
        if native is None:
            return self._with_observations(self._step_python(0, []))
        if self.endings is None:
            to_finish = native.step()
        else:
            try:
                to_finish = self.endings.step()
            except Exception as exc:  # the envs' reward or termination, inputs or observation
                return Message(Kind.ERROR, RemoteError.capture(exc, self.endings.current_env))
            if to_finish is None:  # an action outside the space: the per-env path raises env.step's error
                return self._step_python(0, [])
        return self.finish_native_step() if to_finish else None

    def step_with(self, actions: list[Any]) -> Message | None:
        """:meth:`step` with the actions of these envs sent on the pipe (no shared-memory layout)."""
        self.buffers.actions.store(self.first, actions)
        return self.step()

    def _with_observations(self, reply: Message | None) -> Message | None:
        """The reply of a step or reset, carrying the observations when they cannot be shared."""
        observations = self.buffers.observations
        if not observations.pickled or (reply is not None and reply.kind is Kind.ERROR):
            return reply
        infos = [] if reply is None else reply.data
        return Message(Kind.OBSERVATIONS, (self.first, observations.values(self.env_indices), infos))

    def _step_python(self, start: int, infos: list[tuple[int, dict[str, Any]]]) -> Message | None:
        """Step the envs from offset ``start`` on, on the Python path. What the batch shares (which
        envs step, their actions and marks) is read once; each env's results are written as soon as
        it has them, so an env that raises leaves those of the envs before it in shared memory."""
        buffers, autoreset, caller, slot, first = self.buffers, self.autoreset, self.caller, self.slot, self.first
        actions = self._actions(first, first + len(self.envs))
        observations = self._observations
        rewards, terminations, truncations, current_env = (
            buffers.rewards, buffers.terminations, buffers.truncations, buffers.current_env)
        timed = buffers.timing_enabled.item()
        env_ns = fmu_ns = 0
        rows = zip(range(len(self.envs)), self._step_mask.tolist(), self._in_caller.tolist(), self.needs_reset.tolist())
        for offset, stepped, in_caller, mark in islice(rows, start, None):
            if not stepped or in_caller != caller:
                continue
            index = first + offset
            current_env[slot] = index
            if timed:
                fmu_env = self._fmu_envs[offset]
                fmu_start = 0 if fmu_env is None else fmu_env.fmu_time_ns
                start_ns = perf_counter_ns()
            try:
                observation, reward, terminated, truncated, info = autoreset.step(
                    offset, self.envs[offset], actions[offset], mark)
                if timed:
                    env_ns += perf_counter_ns() - start_ns
                    if fmu_env is not None:
                        fmu_ns += fmu_env.fmu_time_ns - fmu_start
                observations[index] = observation
                rewards[index] = reward
                terminations[index] = terminated
                truncations[index] = truncated
            except Exception as exc:  # the env's, or a result that does not fit its space
                return Message(Kind.ERROR, RemoteError.capture(exc, index))
            if info:
                infos.append((index, info))
        if timed:
            buffers.timing[slot] = (env_ns, fmu_ns)
        return Message(Kind.INFOS, infos) if infos else None

    def _actions(self, begin: int, stop: int) -> Any:
        """The actions of envs ``begin..stop-1`` (item ``i``: env ``begin + i``'s), in the dtype the
        batch was given in, as SyncVectorEnv hands them over."""
        given = self.buffers.action_dtype.item()
        return self.buffers.actions.read_rows(begin, stop, np.dtype(chr(given)) if given else None)

    def finish_native_step(self) -> Message | None:
        """Finish, on the Python path, what the last native step left to Python (see ``Flags``)."""
        buffers, native = self.buffers, self.native
        infos: list[tuple[int, dict[str, Any]]] = []
        timed = bool(buffers.timing_enabled[0])
        started = perf_counter_ns() if timed else 0
        for offset in native.to_finish().tolist():
            env, index, flags = self.envs[offset], self.first + offset, int(native.flags[offset])
            buffers.current_env[self.slot] = index
            if flags & Flags.BAD_ACTION:
                return self._step_python(offset, infos)
            try:
                observation, reward, terminated, truncated, info = self._finish_env(offset, env, flags, native)
                buffers.observations.write(index, observation)
                buffers.rewards[index] = reward
                buffers.terminations[index] = terminated
                buffers.truncations[index] = truncated
            except Exception as exc:
                return Message(Kind.ERROR, RemoteError.capture(exc, index))
            if info:
                infos.append((index, info))
        if timed:
            buffers.timing[self.slot, SharedBuffers.ENV_NS] += perf_counter_ns() - started
        return Message(Kind.INFOS, infos) if infos else None

    def _finish_env(self, offset: int, env: PoolEnv, flags: int, native: NativeBatch) -> StepResult:
        """One env's result, from what C did (``flags``) and what is left to do: the pool's
        autoreset where C could not finish it (``Autoreset``, the Python twin of C's)."""
        autoreset = self.autoreset
        if flags & Flags.FMU_ERROR:
            return autoreset.after_step(offset, env, env.native_step_failure())
        mark = int(self.needs_reset[offset])
        if mark == RESET_THEN_STEP:  # C could not reset it natively
            index = self.first + offset
            return autoreset.step(offset, env, self._actions(index, index + 1)[0], mark)
        if autoreset.next_step and flags & Flags.PYTHON_RESET:
            return autoreset.step(offset, env, None, mark)
        terminated, truncated, step_info = Flags.ending(flags)
        reward = float(self.buffers.rewards[self.first + offset])
        if not (autoreset.same_step and flags & (Flags.RESET_DONE | Flags.PYTHON_RESET)):
            # a Python observation is in its row already (`SliceEdges`): the hook ran once this step
            observation = (self.buffers.observations.read_observation(self.first + offset) if native.python_observation
                           else env.observation())
            return observation, reward, terminated, truncated, step_info
        final_observation = self.buffers.final_observations.read_observation(self.first + offset)
        if flags & Flags.PYTHON_RESET:  # the step ended; C kept its observation, Python resets
            return autoreset.after_step(offset, env, (final_observation, reward, terminated, truncated, step_info))
        return env.observation(), reward, terminated, truncated, same_step_info(final_observation, step_info, {})

    def reset(self, seeds: list[int | None] | None, options: dict[str, Any] | None) -> Message | None:
        """Reset the envs selected by the shared reset mask."""
        buffers = self.buffers
        mask, observations = buffers.reset_mask, buffers.observations
        infos = []
        for offset, env in enumerate(self.envs):
            index = self.first + offset
            if not mask[index]:
                continue
            buffers.current_env[self.slot] = index
            try:
                observation, info = env.reset(seed=None if seeds is None else seeds[offset],
                                              options=options_of_env(options, offset))
                observations.write(index, observation)
            except Exception as exc:
                return Message(Kind.ERROR, RemoteError.capture(exc, index))
            self.needs_reset[offset] = False
            if info:
                infos.append((index, info))
        return self._with_observations(Message(Kind.INFOS, infos) if infos else None)

    def call(self, data: tuple[str, tuple[Any, ...], dict[str, Any]]) -> Message:
        name, args, kwargs = data
        results = []
        for offset, env in enumerate(self.envs):
            self.buffers.current_env[self.slot] = self.first + offset
            try:
                attr = env.get_wrapper_attr(name)
                results.append(attr(*args, **kwargs) if callable(attr) else attr)
            except Exception as exc:
                return Message(Kind.CALL_ERROR, RemoteError.capture(exc, self.first + offset))
        return Message(Kind.RESULTS, results)

    def call_each(self, data: tuple[str, list[tuple[Any, ...] | None]]) -> Message:
        """Call method ``name`` of each env with its own arguments; an env whose arguments are
        ``None`` is not called (its result is ``None``)."""
        name, args = data
        results = []
        for offset, (env, arg) in enumerate(zip(self.envs, args, strict=True)):
            if arg is None:
                results.append(None)
                continue
            self.buffers.current_env[self.slot] = self.first + offset
            try:
                results.append(env.get_wrapper_attr(name)(*arg))
            except Exception as exc:
                return Message(Kind.CALL_ERROR, RemoteError.capture(exc, self.first + offset))
        return Message(Kind.RESULTS, results)

    def set_attr(self, data: tuple[str, list[Any]]) -> Message | None:
        name, values = data
        for offset, (env, value) in enumerate(zip(self.envs, values, strict=True)):
            self.buffers.current_env[self.slot] = self.first + offset
            try:
                env.set_wrapper_attr(name, value)
            except Exception as exc:
                return Message(Kind.CALL_ERROR, RemoteError.capture(exc, self.first + offset))
        return None

