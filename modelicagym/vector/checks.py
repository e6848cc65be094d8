"""Checks of the arguments of the vector API, with the messages ``AsyncVectorEnv`` gives.

Everything a caller passes is checked here, in the parent, before any worker is woken.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from modelicagym.errors import ArgumentError, ArgumentTypeError

__all__ = ["check_reset_mask", "seeds_per_env", "values_per_env"]


def seeds_per_env(seed: int | list[int | None] | None, num_envs: int) -> list[int | None]:
    """One seed per env: ``None`` for all, ``seed + i`` for env ``i``, or the list as given."""
    if seed is None:
        return [None] * num_envs
    if isinstance(seed, int):
        return [seed + i for i in range(num_envs)]
    if len(seed) != num_envs:
        raise ArgumentError(
            f"If seeds are passed as a list the length must match num_envs={num_envs} but got length={len(seed)}."
        )
    return list(seed)


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
