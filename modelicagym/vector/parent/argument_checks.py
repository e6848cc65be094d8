"""Checks of what a call of the vector API passes: seeds, reset options and mask, env ids, values.

Runs in the calling process, at each call, before any worker is woken, so a refused call leaves
the pool as it was. The messages are ``AsyncVectorEnv``'s where it has one. The pool's
configuration is checked in `~modelicagym.vector.parent.config_checks`; actions in
`~modelicagym.vector.parent.action_writer` (with `modelicagym.action_checks`); whether a call may
start at all in `~modelicagym.vector.parent.call_state_checks`.
"""

from __future__ import annotations

from numbers import Integral
from typing import Any

import numpy as np

from modelicagym.errors import ArgumentError, ArgumentTypeError

__all__ = ["check_env_ids", "check_reset_mask", "check_reset_options", "seeds_per_env", "values_per_env"]


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
