"""Checks of a pool's configuration: its own options, ``AsyncVectorEnv``'s, and the env fns.

Runs in the calling process, once, when the pool is constructed: before any worker process starts.
The messages are ``AsyncVectorEnv``'s where it has one. What a call passes later is checked in
`~modelicagym.vector.parent.argument_checks`; an env's own config in `modelicagym.env.config_checks`.
"""

from __future__ import annotations

import math
import multiprocessing
from numbers import Integral, Real
from typing import Any

import cloudpickle
import numpy as np
from gymnasium import Space

from modelicagym.errors import ConfigError, ConfigTypeError
from modelicagym.vector.slice.space_checks import OBSERVATION_MODES

__all__ = ["check_async_vector_env_options", "check_batch_size", "check_env_fns", "check_pool_options"]


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
    """``batch_size`` (envs per `recv`, see `modelicagym.vector.parent.partial_batches`), ``num_envs`` if ``None``."""
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
