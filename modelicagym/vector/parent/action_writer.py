"""The pool checks a batch of actions in the parent, before any worker can see it.

An action that the single env would refuse (wrong shape, a float where an integer belongs, NaN,
out of range) is refused by the pool with the single env's message (`modelicagym.action_checks`) and
the env's index, and the pool stays usable: no worker is woken. The common spaces cost two
small steps on the hot path: the batch is copied into the shared action array (whose workers
are asleep) and range-checked there by one native call (``mg_first_outside_*``, ~0.3 µs where
numpy needs ~3 µs for a small batch). Other spaces are checked element by element; spaces
`modelicagym.action_checks` does not know are left to the envs.

In ``NEXT_STEP`` autoreset mode an env that ended resets on its next step and ignores the action
it is given, as ``SyncVectorEnv`` does; such an action is not checked either (only the batch's
shape is), so a policy may hand anything to an env that is resetting.
"""

from __future__ import annotations

import ctypes
from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.vector.utils import batch_space, iterate

from modelicagym.action_checks import CHECKED_SPACES, action_checker, check_action
from modelicagym.errors import ActionError, ActionTypeError
from modelicagym.native.abi import RESET_THEN_REPORT
from modelicagym.vector.wire.buffers import PickledBatch, SharedBatch

__all__ = ["ActionWriter"]


class ActionWriter:
    """Writes a checked batch of actions into the pool's shared action array.

    Args:
        shared: the shared actions (of the pool's ``single_action_space``, one per env).
        given_dtype: the shared one-element array that tells the envs the dtype of the batch given.
        library: our native library, or ``None`` (numpy then does the range checks).
        needs_reset: in ``NEXT_STEP`` autoreset mode, the pool's shared ``needs_reset`` array: an
            env marked ``RESET_THEN_REPORT`` ignores its next action, which is then not checked.
    """

    def __init__(
        self,
        shared: SharedBatch | PickledBatch,
        space: spaces.Space,
        given_dtype: np.ndarray,
        library: ctypes.CDLL | None,
        needs_reset: np.ndarray | None = None,
    ) -> None:
        self.space = space
        self._check = action_checker(space)  # check_action, with a fast path for common valid actions
        self._needs_reset = needs_reset
        self._all_envs = np.arange(shared.n)
        self.shared = shared
        self.num_envs = shared.n
        self._given_dtype = given_dtype
        self._batched = batch_space(space, shared.n)
        self._target = target = None if shared.pickled else shared.read_batch(copy_out=False)
        self._range_check = None
        if type(space) is spaces.Discrete and isinstance(target, np.ndarray):
            self._bounds = (int(space.start), int(space.start + space.n - 1))
            if library is not None and target.dtype == np.int64:
                args = (target.ctypes.data, shared.n, *self._bounds)
                self._range_check = lambda: library.mg_first_outside_int64(*args)
        elif type(space) is spaces.Box and isinstance(target, np.ndarray) and target.dtype == np.float64:
            width = int(np.prod(space.shape))
            self._bounds = tuple(
                np.ascontiguousarray(np.broadcast_to(bound, space.shape), dtype=np.float64).ravel()
                for bound in (space.low, space.high)
            )
            if library is not None:
                args = (target.ctypes.data, shared.n, width, self._bounds[0].ctypes.data, self._bounds[1].ctypes.data)
                self._range_check = lambda: library.mg_first_outside_float64(*args)
        else:
            self._bounds = None
        self._fast = self._bounds is not None
        self._shape = (shared.n, *space.shape) if self._fast else None
        self._dtype = target.dtype if self._fast else None
        if self._range_check is None and self._fast:
            self._range_check = lambda: self._first_used_outside(self._target, self._all_envs)

    def write(self, actions: Any) -> None:
        """Check ``actions`` and write them; raise `ActionError` (naming the env) if an env would
        refuse its action. Nothing any worker reads has changed when it raises. Each env gets its
        action in the dtype of the batch given (an array), as ``SyncVectorEnv`` hands it over."""
        if self._fast and type(actions) is np.ndarray and actions.shape == self._shape and self._takes(actions.dtype):
            self._target[...] = actions
            bad = self._range_check()
            if bad >= 0 and not self._is_used(bad):
                bad = self._first_used_outside(self._target, self._all_envs)
            if bad >= 0:
                raise self._refusal(actions[bad], bad)
            self._given_dtype[0] = self._dtype_code(actions)
            return
        self._check_each(actions)
        self.shared.write_batch(actions if self._dtype is None else np.asarray(actions).astype(self._dtype))
        self._given_dtype[0] = self._dtype_code(actions)

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


def _is_scalar(actions: Any) -> bool:
    """Whether ``actions`` is a single value where a batch was expected (a tuple or dict of batches is not)."""
    if isinstance(actions, (tuple, list, dict)):
        return False
    return np.ndim(actions) == 0
