"""The checks of what a pool is given, each before anything runs, so that a refused call or
configuration leaves the pool (or nothing) as it was. The messages are ``AsyncVectorEnv``'s where it
has one.

- *the pool's configuration* (its own options, ``AsyncVectorEnv``'s, the env fns): once, when the
  pool is constructed, before any worker process starts; an env's own config is checked in
  `modelicagym.env.config_checks`;
- *what a call passes* (seeds, reset options and mask, env ids, values): at each call, in the
  calling process, before any worker is woken; actions are checked in
  `~modelicagym.vector.dispatch.action_writer` (with `modelicagym.action_checks`);
- *whether a call may start at all* (:func:`public_call`): one thread at a time, with the interrupt
  policy, the pool open, and the asynchronous call state (``AsyncVectorEnv``'s: a ``*_wait`` needs
  its ``*_async``, nothing else may start while one is pending), with Gymnasium's errors;
- *whether the envs agree on their spaces*, by ``AsyncVectorEnv``'s ``observation_mode``: ``"same"``,
  every env has the same observation space (the batch is ``batch_space`` of it); ``"different"`` (and
  a custom ``(single, batched)`` pair), observation spaces may differ in their parameters (e.g.
  bounds) but share shape and dtype, so one shared-memory layout holds them all. Action spaces are
  always the same. Checked where the envs are created (a worker, or the calling process) and where
  the parent gathers what the workers said; the messages are Gymnasium's, with the env indices added.
"""

from __future__ import annotations

import functools
import inspect
import math
import multiprocessing
import threading
from collections.abc import Callable, Sequence
from numbers import Integral, Real
from typing import Any

import cloudpickle
import numpy as np
from gymnasium import Space
from gymnasium.vector.async_vector_env import AsyncState

from modelicagym.errors import ArgumentError, ArgumentTypeError, ConfigError, ConfigTypeError
from modelicagym.vector.errors import (
    ConcurrentUseError,
    NoPendingCallError,
    PendingCallError,
    PoolClosedError,
    SpaceMismatchError,
)

__all__ = [
    "OBSERVATION_MODES",
    "check_action_spaces",
    "check_async_vector_env_options",
    "check_batch_size",
    "check_env_fns",
    "check_env_ids",
    "check_idle",
    "check_max_concurrency",
    "check_observation_spaces",
    "check_open",
    "check_pool_options",
    "check_reset_mask",
    "check_reset_options",
    "check_waiting",
    "public_call",
    "seeds_per_env",
    "values_per_env",
]


# ------------------------------ the spaces the envs say they have
#: the ``observation_mode`` strings; a pair of spaces is the custom mode
OBSERVATION_MODES = ("same", "different")


def _agree(mode: str, a: Space, b: Space) -> bool:
    if mode == "same":
        return a == b
    return a.shape == b.shape and getattr(a, "dtype", None) == getattr(b, "dtype", None)


def check_observation_spaces(mode: str, spaces: Sequence[Space], indices: Sequence[int]) -> None:
    """Raise `SpaceMismatchError` unless ``spaces`` (of envs ``indices``) agree under ``mode``."""
    for index, space in zip(indices[1:], spaces[1:]):
        if _agree(mode, spaces[0], space):
            continue
        where = f"Env {index} has {space}, env {indices[0]} has {spaces[0]}."
        if mode == "same":
            raise SpaceMismatchError(
                "AsyncVectorEnv(..., observation_mode='same') however the sub-environments observation spaces are "
                f"not equivalent. {where} If this is intentional, use `observation_mode='different'` instead."
            )
        raise SpaceMismatchError(
            "AsyncVectorEnv(..., observation_mode='different' or custom space) however the sub-environment's "
            f"observation spaces do not share a common shape and dtype. {where}"
        )


def check_action_spaces(spaces: Sequence[Space], indices: Sequence[int]) -> None:
    """Raise `SpaceMismatchError` unless every env (of ``indices``) has the same action space."""
    for index, space in zip(indices[1:], spaces[1:]):
        if space != spaces[0]:
            raise SpaceMismatchError(
                "Some AsyncVectorEnv sub-environments action spaces are not equivalent "
                f"(env {index} has {space}, env {indices[0]} has {spaces[0]}). "
                "All sub-environments of a pool must have the same action space."
            )



# ------------------------------ the pool's configuration, once
def _positive_or_none(name: str, value: Any, allow_zero: bool = False) -> None:
    if value is None:
        return
    if isinstance(value, bool) or not isinstance(value, Real):
        raise ConfigTypeError(f"{name} must be a number of seconds or None, got {value!r} ({type(value).__name__})")
    if not math.isfinite(value) or value < 0 or (value == 0 and not allow_zero):
        raise ConfigError(f"{name} must be a finite number of seconds {'>=' if allow_zero else '>'} 0, got {value!r}")


def _count_or_none(name: str, value: Any, least: int = 1) -> None:
    if value is None:
        return
    if isinstance(value, bool) or not isinstance(value, Integral):
        raise ConfigTypeError(f"{name} must be an integer or None, got {value!r} ({type(value).__name__})")
    if value < least:
        raise ConfigError(f"{name} must be >= {least}, got {value}")


def check_pool_options(
    num_workers: Any,
    max_envs_per_worker: Any,
    step_timeout: Any,
    startup_timeout: Any,
    spin_time: Any,
    start_method: Any,
    flags: dict[str, Any],
) -> None:
    """The pool's own options: counts, durations (finite, positive), choices and flags."""
    _count_or_none("num_workers", num_workers, least=0)
    _count_or_none("max_envs_per_worker", max_envs_per_worker)
    _positive_or_none("step_timeout", step_timeout)
    _positive_or_none("startup_timeout", startup_timeout)
    _positive_or_none("spin_time", spin_time, allow_zero=True)
    if spin_time is None:
        raise ConfigTypeError("spin_time must be a number of seconds, got None")
    methods = multiprocessing.get_all_start_methods()
    if start_method is not None and start_method not in methods:
        raise ConfigError(f"start_method must be one of {methods} or None, got {start_method!r}")
    for name, value in flags.items():
        if value is not None and not isinstance(value, (bool, np.bool_)):
            raise ConfigTypeError(f"{name} must be True or False, got {value!r}")


def check_batch_size(batch_size: Any, num_envs: int, caller_steps: Any) -> int:
    """``batch_size`` (envs per `recv`, see `modelicagym.vector.dispatch.partial_batches`), ``num_envs`` if ``None``."""
    if batch_size is None:
        return num_envs
    if isinstance(batch_size, bool) or not isinstance(batch_size, Integral):
        raise ConfigTypeError(f"batch_size must be an int, not {type(batch_size).__name__}")
    if not 1 <= batch_size <= num_envs:
        raise ConfigError(f"batch_size must lie in [1, num_envs={num_envs}], got {batch_size}")
    if caller_steps:
        raise ConfigError("batch_size and caller_steps=True: partial batches need every env in a worker")
    return int(batch_size)


def check_env_fns(env_fns: list[Any]) -> None:
    """Every env fn is a callable that can be sent to a worker process (with cloudpickle)."""
    if not env_fns:
        raise ConfigError("a pool needs at least one env fn")
    for index, fn in enumerate(env_fns):
        if not callable(fn):
            raise ConfigTypeError(f"env fn {index} is not callable: {fn!r}")
        try:
            cloudpickle.dumps(fn)
        except Exception as error:
            raise ConfigError(
                f"env fn {index} ({fn!r}) cannot be sent to a worker process: cloudpickle says "
                f"{type(error).__name__}: {error}. Create what it captures (open files, locks, live FMU "
                "instances) inside the fn instead."
            ) from error


def check_async_vector_env_options(
    start_method: str | None, context: str | None, daemon: Any, observation_mode: Any, worker: Any
) -> str | None:
    """``AsyncVectorEnv``'s own options, as the pool takes them; returns the start method."""
    if context is not None and start_method is not None and context != start_method:
        raise ConfigError(f"context={context!r} and start_method={start_method!r} disagree: give one of them")
    if daemon is not True:
        raise ConfigError("daemon=False is not supported: the pool's workers are daemons, stopped with the pool")
    if isinstance(observation_mode, tuple) and len(observation_mode) == 2:
        if not all(isinstance(space, Space) for space in observation_mode):
            raise ConfigTypeError(f"Expected both elements of observation_mode to be Spaces, got "
                                  f"{type(observation_mode[0])} and {type(observation_mode[1])}")
    elif observation_mode not in OBSERVATION_MODES:
        raise ConfigError(f"Invalid `observation_mode`, expected: 'same' or 'different' or tuple of single and "
                          f"batch observation space, actual got {observation_mode}")
    if worker is not None:
        raise ConfigError("a custom worker function is not supported: the pool's workers run modelicagym's own "
                          "command loop (use AsyncVectorEnv for a custom worker)")
    return start_method or context


def check_max_concurrency(max_concurrency: Any) -> int | None:
    """``max_concurrency`` as ``AsyncVectorEnv`` takes it (same checks, same messages): ``None``
    or a positive integer."""
    if max_concurrency is not None:
        if not isinstance(max_concurrency, (int, np.integer)):
            raise ConfigTypeError(f"`max_concurrency` must be an integer or None, got {type(max_concurrency)}.")
        if max_concurrency < 1:
            raise ConfigError(f"`max_concurrency` must be a positive or None, got {max_concurrency}.")
        return int(max_concurrency)
    return None



# ------------------------------ what a call passes, at each call
def seeds_per_env(seed: int | list[int | None] | None, num_envs: int) -> list[int | None]:
    """One seed per env: ``None`` for all, ``seed + i`` for env ``i``, or the list as given; a
    negative seed is refused here, before any env sees it (numpy's seeds are non-negative)."""
    if seed is None:
        return [None] * num_envs
    if isinstance(seed, Integral) and not isinstance(seed, bool):
        seeds: list[int | None] = [int(seed) + i for i in range(num_envs)]
    elif not isinstance(seed, (list, tuple)) or not all(
        s is None or (isinstance(s, Integral) and not isinstance(s, bool)) for s in seed
    ):
        raise ArgumentTypeError(f"seed must be None, an int or a list of ints (or None) per env, got {seed!r}")
    elif len(seed) != num_envs:
        raise ArgumentError(
            f"If seeds are passed as a list the length must match num_envs={num_envs} but got length={len(seed)}."
        )
    else:
        seeds = [None if s is None else int(s) for s in seed]
    negative = next((k for k, s in enumerate(seeds) if s is not None and s < 0), None)
    if negative is not None:
        raise ArgumentError(f"seeds must be >= 0 (numpy's are), got {seeds[negative]} for env {negative}")
    return seeds


def check_reset_options(options: Any) -> None:
    """``reset``'s ``options``: ``None`` or a dict, refused before any env sees them."""
    if options is not None and not isinstance(options, dict):
        raise ArgumentTypeError(f"options must be None or a dict, got {type(options).__name__} {options!r}")


def values_per_env(values: list[Any] | tuple[Any, ...] | Any, num_envs: int) -> list[Any]:
    """One value per env for ``set_attr``: a list/tuple as given, anything else for every env."""
    if not isinstance(values, (list, tuple)):
        return [values] * num_envs
    if len(values) != num_envs:
        raise ArgumentError(
            "Values must be a list or tuple with length equal to the number of environments. "
            f"Got `{len(values)}` values for {num_envs} environments."
        )
    return list(values)


def check_reset_mask(reset_mask: Any, num_envs: int) -> np.ndarray:
    """Validate ``options["reset_mask"]`` exactly as ``AsyncVectorEnv`` does."""
    if not isinstance(reset_mask, np.ndarray):
        raise ArgumentTypeError(f"`options['reset_mask']` must be a numpy array, got {type(reset_mask)}")
    if reset_mask.shape != (num_envs,):
        raise ArgumentError(f"`options['reset_mask']` must have shape `({num_envs},)`, got {reset_mask.shape}")
    if reset_mask.dtype != np.bool_:
        raise ArgumentTypeError(f"`options['reset_mask']` must have `dtype=np.bool_`, got {reset_mask.dtype}")
    if not np.any(reset_mask):
        raise ArgumentError(
            f"`options['reset_mask']` must contain a boolean array with at least one True value, got reset_mask={reset_mask}"
        )
    return reset_mask


def check_env_ids(env_ids: Any, num_envs: int) -> np.ndarray:
    """``env_ids`` (indices, or a boolean mask over all envs) as an int64 array of distinct env
    indices in increasing order for a mask, else an `ArgumentError` saying why."""
    ids = np.asarray(env_ids)
    if ids.dtype == np.bool_ and ids.shape == (num_envs,):
        return np.flatnonzero(ids)
    if ids.ndim != 1 or (ids.size and ids.dtype.kind not in "iu"):
        raise ArgumentError(f"env_ids must be a 1-d array of env indices, got {env_ids!r}")
    ids = ids.astype(np.int64)
    if ids.size and (ids.min() < 0 or ids.max() >= num_envs):
        raise ArgumentError(f"env_ids must lie in [0, {num_envs - 1}], got {ids.tolist()}")
    seen = np.zeros(num_envs, dtype=np.bool_)
    seen[ids] = True
    if int(seen.sum()) != ids.size:
        raise ArgumentError(f"env_ids must not repeat an env, got {ids.tolist()}")
    return ids



# ------------------------------ whether a call may start
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

    A public call never calls another (they share private helpers), so claims do not nest. A call
    whose one argument is ``actions`` (``step``, ``step_async``: the hot path) gets a wrapper of
    that signature, ~150 ns faster than one that forwards ``*args, **kwargs``."""
    name = method.__name__
    if list(inspect.signature(method).parameters) == ["self", "actions"]:

        @functools.wraps(method)
        def guarded_step(self: Any, actions: Any) -> Any:
            _claim(self, name)
            try:
                return method(self, actions)
            except (KeyboardInterrupt, SystemExit):
                self._interrupted()
                raise
            finally:
                self._user.pop("thread", None)

        return guarded_step

    @functools.wraps(method)
    def guarded(self: Any, *args: Any, **kwargs: Any) -> Any:
        _claim(self, name)
        try:
            return method(self, *args, **kwargs)
        except (KeyboardInterrupt, SystemExit):
            self._interrupted()
            raise
        finally:
            self._user.pop("thread", None)

    return guarded


def _claim(pool: Any, call: str) -> None:
    """Claim ``pool`` for this thread, or raise `ConcurrentUseError` if another thread holds it (`public_call`)."""
    me = threading.get_ident()
    if pool._user.setdefault("thread", me) != me:
        raise ConcurrentUseError(
            f"`{call}` was called from a second thread while another thread is inside a call to this pool; "
            "a pool is used from one thread at a time (give each thread its own pool, or a lock)"
        )


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
