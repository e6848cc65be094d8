"""A native slice whose envs compute their inputs or observations in Python: one C call for the
FMUs, and only the Python edges per env around it.

An env on the native step path may compute its input values from the action in Python (an
overridden ``action_to_inputs``) or its observation from the outputs (an overridden
``observation``): its ``python_edges`` (`modelicagym.env.native_step`). A slice of such envs steps
as the per-env path (``env.step``) would, hook call for hook call:

1. **inputs** (``python_inputs``): for each env this party steps now (active in the step mask, its
   ``in_caller`` this party's, and not reset instead in ``NEXT_STEP``), its action is read from
   shared memory as ``SyncVectorEnv`` hands it over, checked as ``env.step`` checks it, and
   ``action_to_inputs(action)`` is written into its FMU's input buffers; C then steps it with no
   action move (``mg_env.python_inputs``). Every action is checked before any hook runs (first the
   slice's rows at once in C, ``mg_first_range_outside``, as a native slice checks its actions'
   bounds; where that cannot tell, each action as ``env.step`` checks it): an action
   outside the space steps the whole slice on the per-env path instead, which raises ``env.step``'s
   error at that env after stepping those before it. An env that moved here to be reset before its
   step (``RESET_THEN_STEP``) is reset by ``env.reset()`` first, as the per-env path does.
2. **the C call(s)**: ``mg_step_batch``, or, when the observation or the endings are Python's,
   ``mg_step_open`` (no autoreset before Python has seen the step) and ``mg_end_steps``.
3. **observations** (``python_observation``): C writes none of these envs' observation rows (they
   hold the user's observation space); Python writes ``observation()`` into the rows of the envs
   C stepped, before their endings are computed (`SliceEndings.end_open`), and, in ``SAME_STEP``,
   into the final-observation rows of those whose step ended; after the autoreset, the rows of the
   envs C reset. What C leaves to Python (an FMU error, a reset only Python can do, an info) is
   finished by the slice as for any native slice.

Rewards, terminations (bounds are on outputs), truncations, flags and timing stay C's.
"""

from __future__ import annotations

import ctypes
import math
from collections.abc import Callable
from time import perf_counter_ns
from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode

from modelicagym.action_checks import element_bounds
from modelicagym.native.abi import NO_RESET, RESET_THEN_STEP, Flags, MgRange
from modelicagym.vector.slice.native_slice import NEEDS_PYTHON, NativeBatch
from modelicagym.vector.slice.slice_endings import SliceEndings
from modelicagym.vector.wire.buffers import SharedBuffers

__all__ = ["SliceEdges"]

_BAD_ACTION, _RESET_DONE, _NEEDS_PYTHON = int(Flags.BAD_ACTION), int(Flags.RESET_DONE), int(NEEDS_PYTHON)
_ARRAY_SPACES = (spaces.Box, spaces.Discrete, spaces.MultiDiscrete, spaces.MultiBinary)


def _bounds(space: spaces.Space) -> tuple[np.ndarray, np.ndarray] | None:
    """Each element's lowest and highest valid value for an array ``space`` (else ``None``)."""
    if type(space) not in _ARRAY_SPACES:
        return None
    if type(space) is spaces.Discrete:
        return np.array([space.start]), np.array([space.start + space.n - 1])
    return element_bounds(space)


def _python_range(view: np.ndarray, low: np.ndarray, high: np.ndarray) -> Callable[[], bool] | None:
    """The range check of ``view`` in Python, for other dtypes (a few values: Python compares them
    exactly, faster than numpy reduces them): one range for every element, finite for floats;
    else ``None``."""
    if low.min() != low.max() or high.min() != high.max() or not view.flags.c_contiguous:
        return None
    lowest, highest = low.min().item(), high.max().item()
    if view.dtype.kind == "f" and not (math.isfinite(lowest) and math.isfinite(highest)):
        return None  # NaN and infinities fail finite bounds
    flat = view.reshape(-1)
    return lambda: all(lowest <= value <= highest for value in flat.tolist())


class _RowsInside:
    """Whether every action in a slice's rows of shared memory lies within the action space's
    bounds (what a native slice checks in C): the int64 and float64 arrays in one C call
    (``mg_first_range_outside``), the other arrays' few values in Python."""

    def __init__(self, library: ctypes.CDLL, ranges: list[tuple[MgRange, tuple[np.ndarray, ...]]],
                 python_checks: list[Callable[[], bool]]) -> None:
        self._table = (MgRange * max(len(ranges), 1))(*(range_ for range_, _ in ranges))
        self._bounds = [bounds for _, bounds in ranges]  # what the table points into lives as long as it
        self._first_outside = library.mg_first_range_outside
        self._args = (ctypes.addressof(self._table), len(ranges))
        self._python_checks = python_checks

    @classmethod
    def of(cls, library: ctypes.CDLL, space: spaces.Space, actions: Any, rows: slice) -> _RowsInside | None:
        """The check of ``rows`` of the shared ``actions`` (an array, or a Dict's arrays), or
        ``None`` when some part of ``space`` cannot be checked so."""
        if not isinstance(actions, (np.ndarray, dict)):
            return None
        parts = ([(actions[key][rows], sub) for key, sub in space.items()] if isinstance(space, spaces.Dict)
                 else [(actions[rows], space)])
        ranges, python_checks = [], []
        for view, sub in parts:
            bounds = _bounds(sub)
            if bounds is None:
                return None
            c_range = MgRange.over(view, *bounds)
            check = None if c_range is not None else _python_range(view, *bounds)
            if c_range is None and check is None:
                return None
            if c_range is not None:
                ranges.append(c_range)
            else:
                python_checks.append(check)
        return cls(library, ranges, python_checks)

    def __call__(self) -> bool:
        return self._first_outside(*self._args) < 0 and all(check() for check in self._python_checks)


class SliceEdges:
    """Steps a native slice whose envs' inputs or observations are Python's (see the module docstring).

    Args:
        envs: the slice's envs (unwrapped, on the native path, all with the same ``python_edges``
            sides: `modelicagym.vector.slice.native_slice.batch_path_reason`).
        native: their `NativeBatch`, made with their ``python_inputs`` / ``python_observation``.
        buffers: the pool's shared buffers.
        first: the pool index of ``envs[0]``.
        slot: the slice's slot (its row of ``timing``).
        autoreset_mode: the pool's.
        endings: the slice's Python endings, if its envs' rewards or terminations are Python's.
        actions: the actions of envs ``begin..stop-1`` as ``SyncVectorEnv`` hands them over
            (`EnvSlice`'s reader).
    """

    def __init__(self, envs: list[Any], native: NativeBatch, buffers: SharedBuffers, first: int, slot: int,
                 autoreset_mode: AutoresetMode, endings: SliceEndings | None,
                 actions: Callable[[int, int], Any]) -> None:
        self.envs, self.native, self.first, self.endings = envs, native, first, endings
        #: the pool index of the env whose hook runs (to name it if the hook raises)
        self.current_env = first
        self._actions = actions
        self._inputs, self._observation = native.python_inputs, native.python_observation
        self._next_step = autoreset_mode is AutoresetMode.NEXT_STEP
        self._same_step = autoreset_mode is AutoresetMode.SAME_STEP
        rows = slice(first, first + len(envs))
        self._mask, self._in_caller, self._needs_reset = (
            buffers.step_mask[rows], buffers.in_caller[rows], buffers.needs_reset[rows])
        self._terminations, self._truncations = buffers.terminations[rows], buffers.truncations[rows]
        self._caller = int(native.state.caller)
        self._checks = [env.check_action for env in envs]
        #: the slice's actions all inside their bounds, in one C call (``None``: C cannot tell)
        shared = self._inputs and not buffers.actions.pickled  # views of shared memory, read by C at every step
        self._rows_inside = _RowsInside.of(native.library, envs[0].action_space,
                                           buffers.actions.read_batch(copy_out=False), rows) if shared else None
        self._writes = [env.native_step.write_inputs for env in envs] if self._inputs else []
        self._observe = [env.observation for env in envs]
        #: the offsets of every env of the slice (the common case of a step: all opened)
        self._every = list(range(len(envs)))
        self._observations = buffers.observations.targets()
        self._finals = buffers.final_observations.targets()
        self._timing, self._timing_enabled = buffers.timing[slot], buffers.timing_enabled

    def step(self) -> int | None:
        """One step of the slice; returns how many envs Python must still finish (see
        `NativeBatch.step`), or ``None`` when an action is outside the action space: then nothing
        was stepped and the caller steps the slice on the per-env path."""
        native = self.native
        timed = bool(self._timing_enabled[0])
        python_ns = 0
        if self._inputs:
            started = perf_counter_ns() if timed else 0
            if not self._write_inputs():
                return None
            python_ns = perf_counter_ns() - started if timed else 0
        if not native.split:
            for_python = native.step()
        else:
            opened = native.step_open()
            started = perf_counter_ns() if timed else 0
            opens = self._every if opened == len(self.envs) else [
                offset for offset, is_open in enumerate(native.open.tolist()) if is_open]
            observed = self._observe_rows(opens) if self._observation else []
            python_ns += perf_counter_ns() - started if timed else 0
            if opened and self.endings is not None:
                try:
                    self.endings.end_open(opened)
                except BaseException:
                    self.current_env = self.endings.current_env  # the env whose endings raised
                    raise
            started = perf_counter_ns() if timed else 0
            if self._same_step and observed:
                self._observe_finals(opens, observed)
            python_ns += perf_counter_ns() - started if timed else 0
            for_python = native.end_steps()
            started = perf_counter_ns() if timed else 0
            if self._observation:
                self._observe_rows(self._reset_by_c())
            python_ns += perf_counter_ns() - started if timed else 0
        if timed:
            self._timing[SharedBuffers.ENV_NS] += python_ns
        return for_python

    def _stepped(self) -> list[int]:
        """Offsets of the envs this step's C call steps here, not reset instead (``NEXT_STEP``)."""
        caller, next_step = self._caller, self._next_step
        rows = zip(self._mask.tolist(), self._in_caller.tolist(), self._needs_reset.tolist())
        return [offset for offset, (active, in_caller, mark) in enumerate(rows)
                if active and in_caller == caller and not (next_step and mark)]

    def _write_inputs(self) -> bool:
        """Write the inputs of the envs this step steps here; ``False`` (nothing written, no hook
        called) if an action is outside the space."""
        offsets = self._stepped()
        if not offsets:
            return True
        actions = self._actions(self.first, self.first + len(self.envs))
        checks, writes, envs, needs_reset = self._checks, self._writes, self.envs, self._needs_reset
        if self._rows_inside is None or not self._rows_inside():
            try:
                for offset in offsets:
                    checks[offset](actions[offset])
            except Exception:  # noqa: BLE001 - whatever it is, the per-env path raises it, at that env
                return False
        offset = offsets[0]
        try:
            for offset in offsets:
                if needs_reset[offset] == RESET_THEN_STEP:  # moved here: reset, then step (as Autoreset)
                    envs[offset].reset()
                    needs_reset[offset] = NO_RESET
                writes[offset](actions[offset])
        except BaseException:
            self.current_env = self.first + offset
            raise
        return True

    def _observe_rows(self, offsets: list[int]) -> list[Any]:
        """Write ``observation()`` of the envs at ``offsets`` into their observation rows; returns them."""
        observe, rows, first = self._observe, self._observations, self.first
        observed = []
        offset = 0
        try:
            for offset in offsets:
                observed.append(observation := observe[offset]())
                rows[first + offset] = observation
        except BaseException:
            self.current_env = first + offset
            raise
        return observed

    def _observe_finals(self, opens: list[int], observed: list[Any]) -> None:
        """``SAME_STEP``: the final observation of each env whose step ended (``observed``: what
        `_observe_rows` wrote for ``opens``), before C resets it."""
        finals, first = self._finals, self.first
        ended = (self._terminations | self._truncations).tolist()
        for offset, observation in zip(opens, observed):
            if ended[offset]:
                finals[first + offset] = observation

    def _reset_by_c(self) -> list[int]:
        """Offsets of the envs C reset in this step with nothing left to Python (their observation
        is Python's to write), up to an env whose action stopped the batch (flags after it are stale)."""
        reset = []
        for offset, flags in enumerate(self.native.flags.tolist()):
            if flags & _BAD_ACTION:
                break
            if flags & _RESET_DONE and not flags & _NEEDS_PYTHON:
                reset.append(offset)
        return reset
