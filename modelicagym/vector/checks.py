"""Checks of the arguments of the vector API, with the messages ``AsyncVectorEnv`` gives.

Everything a caller passes is checked here, in the parent, before any worker is woken.
"""

from __future__ import annotations

import math
import multiprocessing
from numbers import Integral, Real
from typing import Any

import cloudpickle
import numpy as np
from gymnasium import Space

from modelicagym.errors import ArgumentError, ArgumentTypeError, ConfigError, ConfigTypeError
from modelicagym.vector.space_checks import OBSERVATION_MODES

__all__ = ["check_async_vector_env_options", "check_env_fns", "check_pool_options", "check_reset_mask", "seeds_per_env", "values_per_env"]


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
    """``batch_size`` (envs per `recv`, see `modelicagym.vector.partial_batches`), ``num_envs`` if ``None``."""
    if batch_size is None:
        return num_envs
    if isinstance(batch_size, bool) or not isinstance(batch_size, Integral):
        raise ConfigTypeError(f"batch_size must be an int, not {type(batch_size).__name__}")
    if not 1 <= batch_size <= num_envs:
        raise ConfigError(f"batch_size must lie in [1, num_envs={num_envs}], got {batch_size}")
    if caller_steps:
        raise ConfigError("batch_size and caller_steps=True: partial batches need every env in a worker")
    return int(batch_size)


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


def select_infos(infos: dict[str, Any], env_ids: np.ndarray) -> dict[str, Any]:
    """The vector infos of envs ``env_ids`` only (every batched array indexed by them)."""
    return {key: select_infos(value, env_ids) if isinstance(value, dict) else value[env_ids]
            for key, value in infos.items()}


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
