"""A native slice whose envs end their steps in Python: their FMUs step in C, their rewards and
terminations are computed on arrays, one call per group of envs, in the process that stepped them.

An env on the native step path may write its reward or termination in Python (what it offers is
its ``native_endings``: `modelicagym.env.endings`). A slice of such envs steps in three moves:
``NativeBatch.step_open`` steps every FMU in one C call and decides no ending; then, per group of
envs sharing their endings (their class and config's array hooks: usually one group), one call
computes the rewards and terminations from the slice's rows of the shared observations and
actions; then ``NativeBatch.end_steps`` applies the pool's autoreset in one more C call (in
``SAME_STEP`` the ended envs are reset only now, after Python has seen their final state). What is
left to Python after that (an FMU error, a reset only Python can do, an info) is finished as for
any native slice.
"""

from __future__ import annotations

from time import perf_counter_ns
from typing import Any

import numpy as np

from modelicagym.vector.slice.native_slice import NativeBatch
from modelicagym.vector.wire.buffers import SharedBuffers

__all__ = ["SliceEndings", "has_python_endings"]


def has_python_endings(envs: list[Any]) -> bool:
    """Whether any of ``envs`` (on the native path) ends its steps in Python."""
    return any(getattr(env, "native_endings", None) is not None for env in envs)


class SliceEndings:
    """Steps a native slice whose envs end their steps in Python (see the module docstring).

    Args:
        envs: the slice's envs (unwrapped, on the native path).
        native: their `NativeBatch`, made with ``python_endings=True``.
        buffers: the pool's shared buffers.
        first: the pool index of ``envs[0]``.
        slot: the slice's slot (its row of ``timing`` and ``current_env``).
    """

    def __init__(self, envs: list[Any], native: NativeBatch, buffers: SharedBuffers, first: int, slot: int) -> None:
        self.envs = envs
        self.native = native
        self.first = first
        self.slot = slot
        #: the pool index of the env whose endings are being computed (to name it if they raise)
        self.current_env = first
        self._observations = buffers.observations.read_batch(copy_out=False)
        self._actions = buffers.actions.read_batch(copy_out=False)
        self._rewards, self._terminations = buffers.rewards, buffers.terminations
        self._action_dtype = buffers.action_dtype
        self._timing, self._timing_enabled = buffers.timing[slot], buffers.timing_enabled
        self._current = buffers.current_env
        groups: dict[Any, list[int]] = {}
        for offset, env in enumerate(envs):
            if env.native_endings is not None:
                groups.setdefault(env.native_endings.key, []).append(offset)
        #: per group: its endings, and the offsets of its envs
        self._groups = [(envs[offsets[0]].native_endings, np.array(offsets)) for offsets in groups.values()]
        self._one_group = len(self._groups) == 1 and len(self._groups[0][1]) == len(envs)
        #: every env of the slice: its rows as a slice, not an index array (a copy costs less than a gather)
        self._all = slice(0, len(envs))

    def step(self) -> int:
        """One step of the slice; returns how many envs Python must still finish (see `NativeBatch.step`)."""
        native = self.native
        opened = native.step_open()
        if opened:
            self.end_open(opened)
        return native.end_steps()

    def end_open(self, opened: int) -> None:
        """Write the rewards and terminations of the ``opened`` envs `NativeBatch.step_open` marked
        (their observations are in shared memory)."""
        timed = bool(self._timing_enabled[0])
        started = perf_counter_ns() if timed else 0
        if opened == len(self.envs) and self._one_group:  # the common case: every env, one call
            self._end_group(self._groups[0][0], self._all)
        else:
            self._end(np.flatnonzero(self.native.open))
        if timed:
            self._timing[SharedBuffers.ENV_NS] += perf_counter_ns() - started

    def _end(self, offsets: np.ndarray) -> None:
        """Write the rewards and terminations of the envs at ``offsets`` (stepped by C just now)."""
        if self._one_group:
            self._end_group(self._groups[0][0], offsets)
            return
        for endings, members in self._groups:
            group = offsets[np.isin(offsets, members)]
            if group.size:
                self._end_group(endings, group)

    def _end_group(self, endings: Any, offsets: np.ndarray | slice) -> None:
        """End the steps of the envs at ``offsets`` (an index array, or the slice of them all):
        the hooks get copies of their rows, so nothing they do to them reaches shared memory."""
        if isinstance(offsets, slice):
            rows, envs = slice(self.first, self.first + len(self.envs)), self.envs
            self.current_env = self.first
        else:
            rows, envs = offsets + self.first, [self.envs[offset] for offset in offsets.tolist()]
            self.current_env = int(rows[0])
        self._current[self.slot] = self.current_env
        actions = self._actions[rows]
        given = int(self._action_dtype[0])
        if given:  # as SyncVectorEnv hands each env its action: in the dtype the batch was given in
            actions = actions.astype(np.dtype(chr(given)))
        elif isinstance(rows, slice):
            actions = actions.copy()
        observations, terminated = self._observations[rows], self._terminations[rows]
        if isinstance(rows, slice):
            observations, terminated = observations.copy(), terminated.copy()
        rewards, terminated = endings.finish(envs, observations, actions, terminated)
        self._rewards[rows] = rewards
        self._terminations[rows] = terminated
