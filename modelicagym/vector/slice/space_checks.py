"""Whether the envs of a pool agree on their spaces, by ``AsyncVectorEnv``'s ``observation_mode``.

``"same"``: every env has the same observation space (the batch is ``batch_space`` of it).
``"different"`` (and a custom ``(single, batched)`` pair): observation spaces may differ in their
parameters (e.g. bounds) but share shape and dtype, so one shared-memory layout holds them all.
Action spaces are always the same. Messages are Gymnasium's, with the env indices added.
"""

from __future__ import annotations

from collections.abc import Sequence

from gymnasium import Space

from modelicagym.vector.errors import SpaceMismatchError

__all__ = ["OBSERVATION_MODES", "check_action_spaces", "check_observation_spaces"]

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
