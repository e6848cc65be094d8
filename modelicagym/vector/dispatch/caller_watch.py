"""The calling process's last word when an env it steps itself ends it (``caller_steps=True``).

An FMU that crashes or calls ``exit()`` inside an env the calling process steps takes that process
with it: no exception can be raised, and an ``exit(0)`` would even end the user's program as a
success. The pool cannot prevent that where the user chose it, but it can say what happened: the
native library's handlers (``native/csrc/last_word.h``) print one line naming the env and its FMU
(`modelicagym.vector.env_contract.fault_label`) before the process ends, and turn an ``exit(0)``
into a failing status. They know which env runs from the caller's ``current_env`` slot, which
the C step writes, and from ``mg_caller_slot``, which points at that slot while the calling
process runs an env's code: C sets it around a caller's native batch, :meth:`CallerWatch.enter`
and :meth:`CallerWatch.leave` around everything else the calling process runs in its envs (the Python step path, resets,
``call``). Without the native library there is no last word (Python's ``faulthandler`` only).
"""

from __future__ import annotations

import ctypes
import logging
from collections.abc import Sequence
from typing import Any

from modelicagym.vector.env_contract import fault_label
from modelicagym.vector.wire.sync import pool_native_library

__all__ = ["CallerWatch"]

logger = logging.getLogger(__name__)


class CallerWatch:
    """One pool's registration with the native last word: its caller's slot and its envs' labels.

    Args:
        slot: the caller's ``current_env`` slot (a one-element int64 array in shared memory).
        envs: the calling process's envs, the pool's envs ``first, first + 1, ...``.
        num_envs: the pool's envs.
    """

    def __init__(self, slot: Any, envs: Sequence[Any], first: int, num_envs: int) -> None:
        self._library = pool_native_library()
        self._address = slot.ctypes.data
        self._slot = slot  # keeps the memory mapped while registered
        self._current = None
        if self._library is None:
            return
        labels = [b""] * num_envs
        for offset, env in enumerate(envs):
            labels[first + offset] = fault_label(env).encode(errors="replace")
        array = (ctypes.c_char_p * num_envs)(*labels)
        if self._library.mg_watch_register(self._address, num_envs, array) != 0:
            logger.warning("no memory to name the calling process's envs if one ends the process")
            return
        self._current = ctypes.c_void_p.in_dll(self._library, "mg_caller_slot")

    def enter(self) -> None:
        """The calling process starts running its envs' code (~0.1 us; :meth:`leave` must follow)."""
        if self._current is not None:
            self._current.value = self._address

    def leave(self) -> None:
        """The calling process stops running its envs' code."""
        if self._current is not None:
            self._current.value = None

    def close(self) -> None:
        """Forget the labels (the pool is closing); idempotent."""
        if self._current is not None:
            self._current = None
            self._library.mg_watch_unregister(self._address)
