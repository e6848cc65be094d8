"""The pool checks a batch of actions in the parent, before any worker can see it.

An action that the single env would refuse (wrong shape, a float where an integer belongs, NaN,
out of range) is refused by the pool with the single env's message (`modelicagym.action_checks`) and
the env's index, and the pool stays usable: no worker is woken. The common spaces cost two
small steps on the hot path: the batch is copied into the shared action array (whose workers
are asleep) and range-checked there by one native call (``mg_first_outside_*``, ~0.3 µs where
numpy needs ~3 µs for a small batch); with every env in the calling process that check is part of
the step's own C call (``mg_step_batch_in_range``, which checks the whole batch before it steps any
env). A ``Dict`` of array spaces is checked key by key on the
whole batch (`DictBatch`: one native call range-checks every key it can, numpy or Python the
others; ~1.5 µs for five keys, where checking each env's dict in Python cost ~4 µs an env); a batch it does not
accept goes through the element-by-element check, which accepts or refuses it with the single
env's message. Other spaces are checked element by element; spaces `modelicagym.action_checks`
does not know are left to the envs.

In ``NEXT_STEP`` autoreset mode an env that ended resets on its next step and ignores the action
it is given, as ``SyncVectorEnv`` does; such an action is not checked either (only the batch's
shape is), so a policy may hand anything to an env that is resetting.
"""

from __future__ import annotations

import ctypes
from collections.abc import Callable
from math import isfinite
from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.vector.utils import batch_space, iterate

from modelicagym.action_checks import CHECKED_SPACES, action_checker, check_action, element_bounds
from modelicagym.errors import ActionError, ActionTypeError
from modelicagym.native.abi import RESET_THEN_REPORT, MgRange
from modelicagym.vector.wire.buffers import PickledBatch, SharedBatch

__all__ = ["ActionWriter", "DictBatch"]

#: the spaces whose batch is one array (a Dict's entry of such a space has one row per env)
ARRAY_SPACES = (spaces.Box, spaces.Discrete, spaces.MultiDiscrete, spaces.MultiBinary)
#: up to this many envs a Dict entry's scalar values are range-checked in Python, above by numpy
SMALL_BATCH = 32


class ActionWriter:
    """Writes a checked batch of actions into the pool's shared action array.

    Args:
        shared: the shared actions (of the pool's ``single_action_space``, one per env).
        given_dtype: the shared one-element array that tells the envs the dtype of the batch given.
        library: our native library, or ``None`` (numpy then does the range checks).
        needs_reset: in ``NEXT_STEP`` autoreset mode, the pool's shared ``needs_reset`` array: an
            env marked ``RESET_THEN_REPORT`` ignores its next action, which is then not checked.
        clip: the envs clip a Box action outside its bounds (``action_out_of_bounds="clip"``):
            so does the batch, before it is checked.
    """

    def __init__(
        self,
        shared: SharedBatch | PickledBatch,
        space: spaces.Space,
        given_dtype: np.ndarray,
        library: ctypes.CDLL | None,
        needs_reset: np.ndarray | None = None,
        clip: bool = False,
    ) -> None:
        self.space = space
        #: a Box's actions outside its bounds are clipped into them, not refused (NaN still is)
        self._clip = clip and type(space) is spaces.Box
        self._check = action_checker(space)  # check_action, with a fast path for common valid actions
        self._needs_reset = needs_reset
        self._all_envs = np.arange(shared.n)
        self.shared = shared
        self.num_envs = shared.n
        self._given_dtype = given_dtype
        self._batched = batch_space(space, shared.n)
        self._target = target = None if shared.pickled else shared.read_batch(copy_out=False)
        self._range_check = None
        #: the range check of the whole batch as one ``mg_range`` (``None`` where C cannot do it):
        #: a step's C call may do it for :meth:`write` (``range_checked_by_step``)
        self.native_range: MgRange | None = None
        if type(space) is spaces.Discrete and isinstance(target, np.ndarray):
            self._bounds = (int(space.start), int(space.start + space.n - 1))
            if library is not None and target.dtype == np.int64:
                args = (target.ctypes.data, shared.n, *self._bounds)
                self._range_check = lambda: library.mg_first_outside_int64(*args)
                self.native_range = MgRange(values=target.ctypes.data, n=shared.n, width=1, is_float=0,
                                            low_int=self._bounds[0], high_int=self._bounds[1])
        elif type(space) is spaces.Box and isinstance(target, np.ndarray) and target.dtype == np.float64:
            width = int(np.prod(space.shape))
            self._bounds = tuple(
                np.ascontiguousarray(np.broadcast_to(bound, space.shape), dtype=np.float64).ravel()
                for bound in (space.low, space.high)
            )
            if library is not None:
                args = (target.ctypes.data, shared.n, width, self._bounds[0].ctypes.data, self._bounds[1].ctypes.data)
                self._range_check = lambda: library.mg_first_outside_float64(*args)
                self.native_range = MgRange(values=target.ctypes.data, n=shared.n, width=width, is_float=1,
                                            low=self._bounds[0].ctypes.data, high=self._bounds[1].ctypes.data)
        else:
            self._bounds = None
        self._dict = DictBatch.of(space, target, library)
        self._fast = self._bounds is not None
        self._shape = (shared.n, *space.shape) if self._fast else None
        self._dtype = target.dtype if self._fast else None
        #: the batch's bounds, for clipping it in shared memory
        self._bounds_of_batch = (self._batched.low, self._batched.high) if self._clip else None
        if self._range_check is None and self._fast:
            self._range_check = lambda: self._first_used_outside(self._target, self._all_envs)

    def write(self, actions: Any, range_checked_by_step: bool = False) -> None:
        """Check ``actions`` and write them; raise `ActionError` (naming the env) if an env would
        refuse its action. Nothing any worker reads has changed when it raises. Each env gets its
        action in the dtype of the batch given (an array), as ``SyncVectorEnv`` hands it over.

        ``range_checked_by_step``: the step's C call checks `native_range` before it steps any env
        (and on a value outside, the caller calls :meth:`refuse_outside`), so an array of the
        batch's shape is written unchecked: one native call less on the hot path."""
        if self._fast and type(actions) is np.ndarray and actions.shape == self._shape and (
                (same := actions.dtype == self._dtype) or self._takes(actions.dtype)):
            self._target[...] = actions
            if not range_checked_by_step and self._range_check() >= 0:
                self.refuse_outside(actions)
            self._given_dtype[0] = 0 if same else ord(actions.dtype.char)
            return
        if self._dict is not None and self._dict.write(actions):
            self._given_dtype[0] = 0
            return
        if self._clip and not _is_scalar(actions) and np.shape(actions) == self._batched.shape:
            actions = np.clip(np.asarray(actions), self._batched.low, self._batched.high)
        self._check_each(actions)
        self.shared.write_batch(actions if self._dtype is None else np.asarray(actions).astype(self._dtype))
        self._given_dtype[0] = self._dtype_code(actions)

    def refuse_outside(self, actions: Any) -> None:
        """Some action written (``actions``) is outside the space: clip the batch into a ``Box``
        that clips, else raise the refusal of the first env that steps with one (an env left out
        of the step, or resetting, may hold any action)."""
        bad = self._range_check()
        if self._clip:
            np.clip(self._target, *self._bounds_of_batch, out=self._target)
            bad = self._range_check()
        if bad >= 0 and not self._is_used(bad):
            bad = self._first_used_outside(self._target, self._all_envs)
        if bad >= 0:
            raise self._refusal(actions[bad], bad)

    def _takes(self, dtype: np.dtype) -> bool:
        """Whether an array of ``dtype`` fits the shared actions unchanged (the fast path)."""
        return dtype == self._dtype or (dtype.kind == self._dtype.kind and np.can_cast(dtype, self._dtype, "safe"))

    def _dtype_code(self, actions: Any) -> int:
        """What `SharedBuffers.action_dtype` says for ``actions``: the array's dtype when it differs
        from the stored one; 0 (as stored: float64 for a float ``Box``, closest to the Python floats
        ``SyncVectorEnv`` hands over from a list) otherwise."""
        if self._fast and type(actions) is np.ndarray and actions.dtype != self._dtype and self._takes(actions.dtype):
            return ord(actions.dtype.char)
        return 0

    def _check_each(self, actions: Any) -> None:
        """The slow path: every env's action through `check_action`."""
        if _is_scalar(actions):
            raise ActionTypeError(f"Unable to iterate over the following elements: {actions!r} (expected a batch of "
                                  f"{self.num_envs} actions of {self.space})")
        if not isinstance(self.space, CHECKED_SPACES):
            return
        if self._fast and np.shape(actions) != self._shape:
            raise ActionError(f"expected a batch of {self.num_envs} actions of {self.space} (shape {self._shape}), "
                              f"got shape {np.shape(actions)}")
        if isinstance(self.space, spaces.Dict):
            given = set(actions) if isinstance(actions, dict) else set()
            missing, extra = sorted(set(self.space.keys()) - given), sorted(given - set(self.space.keys()))
            if missing or extra or not isinstance(actions, dict):
                raise ActionError(f"a batch of actions of {self.space} is a dict of batches with keys "
                                  f"{sorted(self.space.keys())}; missing: {missing}, unknown: {extra}")
            for key, sub in self.space.items():
                if isinstance(sub, ARRAY_SPACES) and np.shape(actions[key])[:1] != (self.num_envs,):
                    raise ActionError(f"a batch of actions of {self.space}: {key!r} has shape "
                                      f"{np.shape(actions[key])}, expected one entry per env ({self.num_envs})")
        for index, action in enumerate(iterate(self._batched, actions)):
            if not self._is_used(index):
                continue
            try:
                self._check(action)
            except ActionError as error:
                raise ActionError(f"env {index}: {error}") from None

    def write_rows(self, actions: Any, env_ids: np.ndarray) -> None:
        """Check and write the actions of envs ``env_ids`` only, one per id (the others keep
        theirs); refused as by :meth:`write`, with nothing written."""
        if len(actions) != len(env_ids):
            raise ActionError(f"expected {len(env_ids)} actions, one per env id, got {len(actions)}")
        if self._fast and type(actions) is np.ndarray and self._takes(actions.dtype):
            if actions.shape[1:] == self._shape[1:]:
                k = self._first_used_outside(actions, env_ids)
                if k >= 0:
                    raise self._refusal(actions[k], int(env_ids[k]))
                self._target[env_ids] = actions
                self._given_dtype[0] = self._dtype_code(actions)
                return
        for env, action in zip(env_ids.tolist(), actions):
            if not self._is_used(env):
                continue
            try:
                check_action(self.space, action)
            except ActionError as error:
                raise ActionError(f"env {env}: {error}") from None
        for env, action in zip(env_ids.tolist(), actions):
            self.shared.write(env, action)
        self._given_dtype[0] = self._dtype_code(actions)

    def _is_used(self, env: int) -> bool:
        """Whether env ``env`` will act on its action (not an env resetting in ``NEXT_STEP`` mode)."""
        return self._needs_reset is None or self._needs_reset[env] != RESET_THEN_REPORT

    def _first_used_outside(self, actions: np.ndarray, env_ids: np.ndarray) -> int:
        """The position in ``actions`` (the actions of envs ``env_ids``) of the first one out of
        range that its env will use, or -1."""
        if not actions.size:
            return -1
        rows = actions.reshape(len(env_ids), -1)
        low, high = self._bounds
        refused = ~((rows >= low) & (rows <= high)).all(axis=1)
        if self._needs_reset is not None:
            refused &= self._needs_reset[env_ids] != RESET_THEN_REPORT
        outside = np.flatnonzero(refused)
        return int(outside[0]) if outside.size else -1

    def _refusal(self, action: Any, index: int) -> ActionError:
        """The error for env ``index``'s refused ``action``, with the single env's message."""
        try:
            check_action(self.space, action)
        except ActionError as error:
            return ActionError(f"env {index}: {error}")
        return ActionError(f"env {index}: invalid action {action!r} for {self.space}")


class DictBatch:
    """The whole-batch check of a ``Dict`` of array spaces (``Discrete``, ``Box``,
    ``MultiDiscrete``, ``MultiBinary``) whose batch lives in shared memory.

    `write` copies each key's array into its shared view, then range-checks every key the native
    library can check (int64 values with one range, float64 values with finite bounds) in one
    call, and the others with numpy or Python. It takes only what the element-by-element check
    accepts as well (an array per key of the stored dtype and the batch's shape, every value in
    range and finite), so it changes no result and no message: anything else, valid or not, is
    left to that check.
    """

    def __init__(self, views: list[tuple[str, np.ndarray]], native: NativeRanges | None,
                 checks: list[Callable[[], bool]]) -> None:
        self._views = views
        self._names = {name for name, _ in views}
        self._native = native
        self._checks = checks

    @classmethod
    def of(cls, space: spaces.Space, target: Any, library: ctypes.CDLL | None) -> DictBatch | None:
        """The check for ``space``'s batch ``target`` (its shared views), or ``None`` if ``space``
        is not a ``Dict`` of array spaces or its batch is not a dict of arrays."""
        if type(space) is not spaces.Dict or not isinstance(target, dict):
            return None
        views, ranges, checks = [], [], []
        for name, sub in space.items():
            view = target.get(name)
            bounds = _leaf_bounds(sub)
            if bounds is None or type(view) is not np.ndarray or not view.flags.c_contiguous:
                return None
            views.append((name, view))
            native_range = MgRange.over(view, *bounds) if library is not None else None
            if native_range is None:
                checks.append(_in_range(view, *bounds))
            else:
                ranges.append(native_range)
        return cls(views, NativeRanges(library, ranges) if ranges else None, checks)

    def write(self, actions: Any) -> bool:
        """Write ``actions`` if every value is an accepted one (``True``); else ``False``, with
        the batch half-written (the caller then writes it again or refuses it; no worker reads
        actions before the batch is posted)."""
        if type(actions) is not dict or actions.keys() != self._names:
            return False
        for name, view in self._views:
            value = actions[name]
            if type(value) is not np.ndarray or value.dtype != view.dtype or value.shape != view.shape:
                return False
            view[...] = value
        if self._native is not None and not self._native.all_inside():
            return False
        return all(check() for check in self._checks)


class NativeRanges:
    """Range checks of several shared arrays in one native call (``mg_first_range_outside``)."""

    def __init__(self, library: ctypes.CDLL, ranges: list[tuple[MgRange, tuple[np.ndarray, ...]]]) -> None:
        self._table = (MgRange * len(ranges))(*(range_ for range_, _ in ranges))
        self._bounds = [bounds for _, bounds in ranges]  # the arrays the table points into live as long as it
        self._first_outside = library.mg_first_range_outside
        self._args = (ctypes.addressof(self._table), len(ranges))

    def all_inside(self) -> bool:
        """Whether every value of every array lies in its range."""
        return self._first_outside(*self._args) < 0


def _leaf_bounds(space: spaces.Space) -> tuple[np.ndarray, np.ndarray] | None:
    """Each element's lowest and highest valid value for a ``Dict`` entry the batch check takes
    (integers for ``Discrete``/``MultiDiscrete``/``MultiBinary``, numbers for ``Box``), else ``None``."""
    if type(space) not in ARRAY_SPACES or np.dtype(space.dtype).kind not in ("fiu" if type(space) is spaces.Box else "iu"):
        return None
    if type(space) is spaces.Discrete:
        return np.array([space.start]), np.array([space.start + space.n - 1])
    return element_bounds(space)


def _in_range(view: np.ndarray, low: np.ndarray, high: np.ndarray) -> Callable[[], bool]:
    """Whether every value in ``view`` (n rows) lies within its element's ``[low, high]`` and is
    finite, by numpy (or by Python for a few scalars)."""
    n, width = len(view), int(np.prod(view.shape[1:], dtype=np.int64))
    finite_bounds = bool(np.isfinite(low).all() and np.isfinite(high).all())
    if width == 1 and n <= SMALL_BATCH:  # Python compares a few scalars faster than numpy reduces them
        lowest, highest = low.item(), high.item()
        if finite_bounds:  # NaN and infinities fail the comparison
            return lambda: all(lowest <= value <= highest for value in view.tolist())
        return lambda: all(lowest <= value <= highest and isfinite(value) for value in view.tolist())
    rows = view.reshape(n, width)
    low, high = low.astype(view.dtype), high.astype(view.dtype)
    if view.dtype.kind == "f":
        return lambda: bool(((rows >= low) & (rows <= high)).all() and np.isfinite(rows).all())
    return lambda: bool(((rows >= low) & (rows <= high)).all())


def _is_scalar(actions: Any) -> bool:
    """Whether ``actions`` is a single value where a batch was expected (a tuple or dict of batches is not)."""
    if isinstance(actions, (tuple, list, dict)):
        return False
    return np.ndim(actions) == 0
