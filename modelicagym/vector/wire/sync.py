"""The wake-up signals between the parent and a worker: spin briefly, then sleep.

Two implementations of one interface (``post()``, ``wait(spin_time, timeout) -> bool``):

- :class:`FutexSignal` (Linux, the default): a word in the pool's shared memory, polled and slept
  on in C by our native library (``modelicagym/native/csrc/signal.c``); a round trip through
  ctypes costs about 0.9 µs while the waiter spins. The worker's C step loop waits on the same word.
  A wait polls only while polling pays: it sleeps at once when the machine is crowded (more
  runnable threads than cores, by the kernel's CPU pressure) or when its previous wait outlasted
  the spin time (``signal.h`` states the policy; docs/design.md, "Waiting", gives the measurements).
  In a pool, a worker's ``go`` is a :class:`GoSignal` and its ``done`` an :class:`AnswerSignal` on
  its side: the step's barrier (``slice.h``) wakes all the workers and learns that all are done in
  a constant number of system calls.
- :class:`SemaphoreSignal`: a process-shared semaphore, for where the native library cannot be
  built (no C compiler) or there are no futexes; it predicts when a post comes (below).

Measured on the 2-core target machine for the semaphore (median round trip: the parent wakes one
/ two workers and waits for both):

=======================================  ==================  =================
primitive                                idle machine        other jobs running
=======================================  ==================  =================
pipe (``send_bytes``/``recv_bytes``)     53 / 49 µs          16 / 36 µs
semaphore, blocking                      59 / 42 µs          5.5 / 12 µs
semaphore polled with ``sched_yield``    1.5 / 4.5 µs        4.3 / 6.8 µs
for up to 100 µs, then blocking
=======================================  ==================  =================

Blocking is slow on an idle machine because the woken CPU must leave a sleep state. Pure spinning
without yielding collapses to milliseconds once there are more spinners than cores, so every spin
iteration yields; and the spin is bounded (and adaptive, see :class:`Signal`) so an idle pool
sleeps instead of burning a core.
"""

from __future__ import annotations

import ctypes
import functools
import logging
import sys
from multiprocessing.context import BaseContext
from os import sched_yield
from time import perf_counter

__all__ = ["AnswerSignal", "FutexSignal", "GoSignal", "SemaphoreSignal", "pool_native_library"]

logger = logging.getLogger(__name__)


#: waits that lasted longer than this (seconds) are not predicted: the next wait blocks at once
NAP_LIMIT = 10e-3


class SemaphoreSignal:
    """A counting signal (a process-shared semaphore) whose waiter spins before it blocks.

    Posts are never lost: every :meth:`post` is matched by exactly one successful :meth:`wait`, so
    the spin phase cannot race with the blocking phase.

    The spin is placed where the post is expected: a waiter predicts that a wait lasts 90% of the
    shorter of its previous two. If that is longer than the spin window, it first blocks (a timed
    wait, which a post ends at once) until ``spin_time`` before the predicted post, then polls for up to
    ``spin_time``, then blocks. So a step of hundreds of microseconds leaves the core to whoever
    does the work, yet its end is usually caught by polling rather than by a blocking wake-up (tens
    of microseconds). After a wait longer than :data:`NAP_LIMIT` (an idle pool, an agent that
    thinks between steps) the next wait blocks at once and burns nothing; one shorter wait
    switches prediction back on. Each process adapts to what it waits for (the parent to the
    workers' step time, a worker to the parent's time between steps).

    The semaphore is passed to the worker as a process argument; :meth:`close` drops it so that
    (with ``forkserver``/``spawn``, where it is a named POSIX semaphore) its name is unlinked at
    once, even if a traceback still references this object.
    """

    def __init__(self, ctx: BaseContext) -> None:
        self._sem = ctx.Semaphore(0)
        self._last = self._prev = 0.0

    def __getstate__(self) -> dict:
        return {"_sem": self._sem}

    def __setstate__(self, state: dict) -> None:
        self._sem = state["_sem"]
        self._last = self._prev = 0.0

    def post(self) -> None:
        """Wake the waiter (or let its next :meth:`wait` return at once)."""
        self._sem.release()

    def wait(self, spin_time: float, timeout: float | None) -> bool:
        """Wait for a post: block until ``spin_time`` before the predicted post (if previous waits
        were that long), poll for up to ``spin_time``, then block for the rest of ``timeout``.

        Returns ``True`` if a post was consumed, ``False`` if ``timeout`` expired (``None`` blocks
        until a post arrives).
        """
        sem = self._sem
        if sem.acquire(False):
            self._prev, self._last = self._last, 0.0
            return True
        start = perf_counter()
        last = self._last
        if spin_time > 0.0 and last < NAP_LIMIT:
            nap = 0.9 * min(last, self._prev) - spin_time
            self._prev = last
            if nap > 0.0:
                if timeout is not None and nap > timeout:
                    nap = timeout
                if sem.acquire(True, nap):
                    self._last = perf_counter() - start
                    return True
            end = perf_counter() + spin_time
            while True:
                sched_yield()
                if sem.acquire(False):
                    self._last = perf_counter() - start
                    return True
                if perf_counter() >= end:
                    break
        if timeout is not None:
            timeout = max(start + timeout - perf_counter(), 0.0)
        if not sem.acquire(True, timeout):
            return False
        self._last = perf_counter() - start
        return True

    def close(self) -> None:
        """Release the semaphore; the signal is unusable afterwards."""
        self._sem = None


class FutexSignal:
    """A signal in shared memory (``mg_signal`` of ``native/csrc/signal.h``), waited on in C.

    ``address`` is where the 8-byte struct lives in this process's mapping of the pool's shared
    memory (zeroed memory is an unposted signal). :attr:`waiter` is this process's adaptive state
    for its waits on the signal (and what they did: polled, slept, slept at once), shared with the
    native loops that wait on the same signal.
    """

    __slots__ = ("_address", "_post", "_wait", "waiter", "_waiter_ref")

    def __init__(self, library: ctypes.CDLL, address: int) -> None:
        from modelicagym.native.abi import MgWaiter

        self._address = address
        self._post = library.mg_signal_post
        self._wait = library.mg_signal_wait
        self.waiter = MgWaiter()
        self._waiter_ref = ctypes.byref(self.waiter)

    @property
    def address(self) -> int:
        """The address of the signal in this process (for the native step loop)."""
        return self._address

    def post(self) -> None:
        """Wake the waiter (or let its next :meth:`wait` return at once)."""
        self._post(self._address)

    def wait(self, spin_time: float, timeout: float | None) -> bool:
        """Poll for up to ``spin_time`` seconds (when polling pays), then sleep for the rest of
        ``timeout`` (``None``: until posted); ``True`` if a post was consumed."""
        timeout_ns = -1 if timeout is None else int(timeout * 1e9)
        return bool(self._wait(self._address, int(spin_time * 1e9), timeout_ns, self._waiter_ref))

    def close(self) -> None:
        """Nothing to release: the memory belongs to the pool."""


class GoSignal(FutexSignal):
    """A worker's ``go`` in a pool: its waiter sleeps on the step's barrier's bell, on the worker's
    own bit (``mg_go_wait``), so that a step wakes every sleeping worker in one system call
    (``mg_post_step``, ``csrc/slice.h``); :meth:`post` wakes this worker alone (``mg_go_post``).
    Both processes build it on the same ``barrier`` (its address in each) and ``slot``."""

    __slots__ = ("_barrier", "_post_one", "_slot", "_wait_bell")

    def __init__(self, library: ctypes.CDLL, address: int, barrier: int, slot: int) -> None:
        super().__init__(library, address)
        self._barrier, self._slot = barrier, slot
        self._post_one, self._wait_bell = library.mg_go_post, library.mg_go_wait

    def post(self) -> None:
        self._post_one(self._address, self._barrier, self._slot)

    def wait(self, spin_time: float, timeout: float | None) -> bool:
        timeout_ns = -1 if timeout is None else int(timeout * 1e9)
        return bool(self._wait_bell(self._address, self._barrier, self._slot, int(spin_time * 1e9), timeout_ns,
                                    self._waiter_ref))


class AnswerSignal(FutexSignal):
    """A worker's ``done`` on the worker's side: a post is ``mg_answer``, which first counts the
    step's barrier down (``csrc/slice.h``), so the parent waits once for all the workers of a step."""

    __slots__ = ("_answer", "_barrier")

    def __init__(self, library: ctypes.CDLL, address: int, barrier: int) -> None:
        super().__init__(library, address)
        self._barrier, self._answer = barrier, library.mg_answer

    def post(self) -> None:
        self._answer(self._barrier, self._address)


@functools.cache
def pool_native_library() -> ctypes.CDLL | None:
    """The whole native library (``load_library``), for the pool's signals, layout and C loops alike,
    when shared-memory signals can be used here; else ``None`` (said once): the pool then signals
    through semaphores and keeps a fixed layout."""
    if not sys.platform.startswith("linux"):
        logger.info("no futexes on %s: the pool signals through semaphores", sys.platform)
        return None
    from modelicagym.native.library import NativeBuildError, load_library

    try:
        return load_library()
    except NativeBuildError as error:
        logger.warning("the pool signals through semaphores (slower): %s", error)
        return None
