"""The calling process's side of a pool step in C: the workers woken and awaited in one call each.

``mg_post_step`` wakes every stepping worker in one call, and after the calling process stepped its
own slice ``mg_collect`` waits for all of them in one call (the step's barrier, ``csrc/slice.h``).
A worker's side is `modelicagym.vector.worker.native_server`.
"""

from __future__ import annotations

import ctypes

import numpy as np

from modelicagym.native.abi import MgCollector, MgWaiter
from modelicagym.native.library import load_library

__all__ = ["NativeCollector"]


class NativeCollector:
    """The calling process's side of a pool step in C: ``mg_post_step`` wakes every stepping worker,
    ``mg_collect`` waits until all have answered, each one call whatever the number of workers
    (the step's barrier, ``csrc/slice.h``).

    Args:
        go, done: addresses of the workers' ``go`` and ``done`` signals, in worker order.
        barrier: address of the step's barrier (``mg_barrier``) in shared memory.
        replies: the workers' reply slots (worker ``k`` at index ``k``).
        stepping: per worker, uint8: it steps (only those are woken and waited for).
        spin_ns, timeout: as for `modelicagym.vector.worker.native_server.NativeServer`.
        waiter: the adaptive state of the parent's waits for the workers.
    """

    def __init__(
        self,
        go: list[int],
        done: list[int],
        barrier: int,
        replies: np.ndarray,
        stepping: np.ndarray,
        spin_ns: np.ndarray,
        timeout: float,
        waiter: MgWaiter,
    ) -> None:
        self.library = load_library()
        self.stepping = stepping
        self.waiter = waiter
        self._go = (ctypes.c_void_p * max(len(go), 1))(*go)
        self._done = (ctypes.c_void_p * max(len(done), 1))(*done)
        self._replies = replies
        self.state = collector = MgCollector()
        collector.n_workers = len(done)
        collector.go, collector.done = ctypes.addressof(self._go), ctypes.addressof(self._done)
        collector.barrier = barrier
        collector.replies = replies.ctypes.data
        collector.stepping = stepping.ctypes.data
        collector.spin_ns, collector.timeout_ns = spin_ns.ctypes.data, int(timeout * 1e9)
        collector.waiter = ctypes.addressof(waiter)
        self._post, self._collect = self.library.mg_post_step, self.library.mg_collect
        self._ref = ctypes.byref(collector)

    def post(self) -> None:
        """Wake every stepping worker for a step (their command slots say ``STEP``)."""
        self._post(self._ref)

    def collect(self) -> int:
        """`COLLECT_DONE` or `COLLECT_SLOW` (see ``mg_collect``)."""
        return self._collect(self._ref)

    def take_times(self) -> tuple[int, int]:
        """Calls of :meth:`collect` since the last take, and the nanoseconds they spent waiting for
        the workers; the sums start again from zero."""
        state = self.state
        taken = state.calls, state.wait_ns
        state.calls = state.wait_ns = 0
        return taken
