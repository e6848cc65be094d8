"""A pool's envs' states at once (`VectorState`), for a checkpoint a run resumes from exactly.

``pool.get_states()`` asks every env for its state (``env.get_state()``, the env contract's
`StatefulEnv`) and keeps beside them which envs the pool will reset at their next step (the
``NEXT_STEP`` autoreset); ``pool.set_states(...)`` puts both back, in this pool or a new one of the
same envs (any layout), all or nothing: every env checks its state (``env.check_state``) before
any loads one. Nothing here knows what an env's state holds.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from modelicagym.errors import ArgumentError, ArgumentTypeError

__all__ = ["VectorState", "split_states"]


@dataclass(frozen=True, eq=False)
class VectorState:
    """Every env's state (``states[i]``, as its ``get_state()`` gave it) and the pool's per-env
    ``needs_reset`` flags; picklable when the states are."""

    states: tuple[Any, ...]
    needs_reset: tuple[int, ...]

    def __len__(self) -> int:
        return len(self.states)


def split_states(states: VectorState | Sequence[Any], num_envs: int) -> tuple[list[Any], np.ndarray | None]:
    """The per-env states of ``states`` (a `VectorState`, or one state per env) and the
    ``needs_reset`` flags to restore (``None`` for a plain sequence: left as they are)."""
    if isinstance(states, VectorState):
        env_states, needs_reset = list(states.states), np.asarray(states.needs_reset, dtype=np.uint8)
        if needs_reset.shape != (len(env_states),):
            raise ArgumentError(f"set_states got a VectorState of {len(env_states)} states and "
                                f"{needs_reset.size} needs_reset flags")
    elif isinstance(states, Sequence) and not isinstance(states, (str, bytes, bytearray)):
        env_states, needs_reset = list(states), None
    else:
        hint = " (unpickle a saved checkpoint first)" if isinstance(states, (bytes, bytearray)) else ""
        raise ArgumentTypeError(f"set_states takes pool.get_states()'s VectorState or one state per env, "
                                f"got {type(states).__name__}{hint}")
    if len(env_states) != num_envs:
        raise ArgumentError(f"set_states got {len(env_states)} states for {num_envs} envs")
    return env_states, needs_reset

