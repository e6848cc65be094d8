"""The checks every public call of the pool makes first: one thread at a time (with the interrupt
policy, in the same decorator: :func:`public_call`), the pool open,
and the asynchronous call state (``AsyncVectorEnv``'s: a ``*_wait`` needs its ``*_async``, nothing
else may start while one is pending), with Gymnasium's errors and messages."""

from __future__ import annotations

import functools
import threading
from collections.abc import Callable
from typing import Any

from gymnasium.vector.async_vector_env import AsyncState

from modelicagym.vector.errors import ConcurrentUseError, NoPendingCallError, PendingCallError, PoolClosedError

__all__ = ["check_idle", "check_open", "check_waiting", "public_call"]


def public_call(method: Callable[..., Any]) -> Callable[..., Any]:
    """Decorates each public call of the pool (a plain ``def``, name and docstring kept) with
    what every one of them needs:

    - **One thread at a time**: a second thread that calls while another is inside a call gets
      `ConcurrentUseError` at once (a pool's calls share one state and one set of workers; two
      threads interleaving them hung). The calling thread claims the pool (its ``_user`` dict) with
      one atomic ``dict.setdefault`` (~0.15 us), not a lock: a Ctrl-C that lands between claiming
      and the ``try`` leaves a claim only this same thread holds, which its next call clears, where
      a lock would stay taken.
    - **The interrupt policy**: a ``KeyboardInterrupt`` or ``SystemExit`` that escapes the call
      goes to the pool's ``_interrupted()`` first, which decides what is left of the pool (see
      `PoolVectorEnv._interrupted`), then propagates.

    A public call never calls another (they share private helpers), so claims do not nest."""
    name = method.__name__

    @functools.wraps(method)
    def guarded(self: Any, *args: Any, **kwargs: Any) -> Any:
        me = threading.get_ident()
        if self._user.setdefault("thread", me) != me:
            raise ConcurrentUseError(
                f"`{name}` was called from a second thread while another thread is inside a call to this pool; "
                "a pool is used from one thread at a time (give each thread its own pool, or a lock)"
            )
        try:
            return method(self, *args, **kwargs)
        except (KeyboardInterrupt, SystemExit):
            self._interrupted()
            raise
        finally:
            self._user.pop("thread", None)

    return guarded


def check_open(closed: bool, owner: str) -> None:
    """Raise `PoolClosedError` (Gymnasium's ``ClosedEnvironmentError``) after ``close()``."""
    if closed:
        raise PoolClosedError(f"Trying to operate on `{owner}`, after a call to `close()`.")


def check_idle(state: AsyncState, partial_busy: bool, call: str) -> None:
    """Raise `PendingCallError` unless nothing is pending: no ``*_async`` call, no partial batch
    whose envs ``recv`` has not all returned."""
    if partial_busy:
        raise PendingCallError(f"Calling `{call}` while envs sent with `send` are not all returned by `recv`.", "send")
    if state != AsyncState.DEFAULT:
        raise PendingCallError(
            f"Calling `{call}` while waiting for a pending call to `{state.value}` to complete.", str(state.value)
        )


def check_waiting(state: AsyncState, expected: AsyncState, call: str, prior: str) -> None:
    """Raise `NoPendingCallError` unless the call pending is ``expected`` (``prior`` started it)."""
    if state != expected:
        raise NoPendingCallError(f"Calling `{call}` without any prior call to `{prior}`.", expected.value)
