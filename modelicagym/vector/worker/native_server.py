"""A worker's wait for its next command, and its plain native steps, in C (``mg_serve``).

A worker whose envs step natively waits for its next command in C and answers plain native steps
without returning to Python at all; the calling process's side is
`modelicagym.vector.dispatch.native_collector`.
"""

from __future__ import annotations

import ctypes
from typing import Any

import numpy as np

from modelicagym.native.abi import MgServer, MgWaiter
from modelicagym.vector.slice.native_slice import NativeBatch

__all__ = ["NativeServer"]


class NativeServer:
    """``mg_serve``: a worker's wait for its next command, and its plain native steps, in C.

    Args:
        batch: the worker's native slice (one with ``python_phases`` steps with Python around
            its C calls: every command returns to Python).
        go, done: addresses of the worker's signals in shared memory.
        barrier: address of the step's barrier (``mg_barrier``) in shared memory.
        slot: the worker's index (its bit of the barrier's bell).
        command, reply: the worker's command and reply slots (one-element views).
        step_code: the command code of a step.
        spin_ns: the pool's shared poll time (a one-element int64 view of ``SharedBuffers.spin_ns``):
            nanoseconds to poll at most before sleeping, read at every wait.
        timeout: seconds to wait before returning `SERVE_TIMEOUT`.
        waiter: the adaptive state of the worker's waits (its ``go`` signal's).
    """

    def __init__(
        self,
        batch: NativeBatch,
        go: int,
        done: int,
        barrier: int,
        slot: int,
        command: np.ndarray,
        reply: np.ndarray,
        step_code: int,
        spin_ns: np.ndarray,
        timeout: float,
        waiter: MgWaiter,
    ) -> None:
        self.batch = batch
        self._waiter = waiter
        self.state = server = MgServer()
        server.batch = None if batch.python_phases else ctypes.addressof(batch.state)
        server.go, server.done, server.barrier, server.slot = go, done, barrier, slot
        server.command, server.reply = command.ctypes.data, reply.ctypes.data
        server.step_code = step_code
        server.waiter = ctypes.addressof(waiter)
        server.spin_ns, server.timeout_ns = spin_ns.ctypes.data, int(timeout * 1e9)
        self._serve = batch.library.mg_serve
        self._ref = ctypes.byref(server)

    def next_command(self) -> Any:
        """Serve steps until a command needs Python: its code, `SERVE_PYTHON_STEP` or `SERVE_TIMEOUT`."""
        return self._serve(self._ref)
