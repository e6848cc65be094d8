"""Whether an action belongs to an action space, with a message that says why not.

`check_action` names the action, the problem and the space; `action_checker` is its fast form
for one space (a valid action of a common space passes in well under a microsecond). The single
env and the pool (before anything reaches a worker) both use them, so an action is refused with
the same words everywhere.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from math import isfinite
from typing import Any

import numpy as np
from gymnasium import spaces

from modelicagym.errors import ActionError

__all__ = ["CHECKED_SPACES", "action_checker", "action_problem", "check_action", "describe_action"]

#: the spaces `check_action` understands (actions of others are left to the env)
CHECKED_SPACES = (spaces.Discrete, spaces.Box, spaces.MultiDiscrete, spaces.MultiBinary, spaces.Dict)


def describe_action(action: Any) -> str:
    """The action's repr, shortened for a message."""
    text = repr(action)
    return text if len(text) <= 80 else text[:77] + "..."


def check_action(space: spaces.Space, action: Any) -> None:
    """Raise a ValueError naming the action and the space unless ``action`` belongs to ``space``."""
    problem = action_problem(space, action)
    if problem:
        raise ActionError(f"invalid action {describe_action(action)}: {problem}; the action space is {space}")


def action_checker(space: spaces.Space) -> Callable[[Any], None]:
    """A fast `check_action` for one space: common valid actions pass in well under a microsecond."""
    if type(space) is spaces.Discrete:
        low, high = int(space.start), int(space.start + space.n)

        def check_discrete(action: Any) -> None:
            if not (type(action) is int or isinstance(action, np.integer)) or not low <= action < high:
                check_action(space, action)

        return check_discrete
    if type(space) is spaces.Box and len(space.shape) == 1 and space.shape[0] <= 16:
        bounds = list(zip(space.low.tolist(), space.high.tolist()))
        shape = space.shape

        def check_box(action: Any) -> None:
            if type(action) is np.ndarray and action.shape == shape and action.dtype.kind in "fiu":
                for value, (low, high) in zip(action.tolist(), bounds):
                    if not (low <= value <= high and isfinite(value)):
                        break
                else:
                    return
            check_action(space, action)

        return check_box
    return partial(check_action, space)


def action_problem(space: spaces.Space, action: Any) -> str | None:
    """What is wrong with ``action`` for ``space``, or ``None``."""
    if isinstance(space, spaces.Dict):
        if not isinstance(action, dict) or set(action) != set(space.keys()):
            return f"expected a dict with keys {sorted(space.keys())}"
        for name, sub in space.items():
            problem = action_problem(sub, action[name])
            if problem:
                return f"{name!r}: {problem}"
        return None
    if not isinstance(space, CHECKED_SPACES):
        return None
    try:
        array = np.asarray(action)
    except Exception:
        return "not array-like"
    if array.dtype.kind not in "biuf":
        return f"expected numbers, got dtype {array.dtype}"
    if isinstance(space, spaces.Discrete):
        if array.shape != ():
            return f"expected a single integer, got shape {array.shape}"
    elif array.shape != space.shape:
        return f"expected shape {space.shape}, got shape {array.shape}"
    if array.dtype.kind == "f" and not np.all(np.isfinite(array)):
        return "it contains NaN or infinity"
    if not isinstance(space, spaces.Box) and array.dtype.kind == "f" and np.any(array != np.round(array)):
        return "expected integers"
    if isinstance(space, spaces.Discrete):
        if not space.start <= int(array) < space.start + space.n:
            return f"out of range [{space.start}, {space.start + space.n - 1}]"
    elif isinstance(space, spaces.MultiDiscrete):
        if np.any(array < space.start) or np.any(array >= space.start + space.nvec):
            return "out of range"
    elif isinstance(space, spaces.MultiBinary):
        if np.any((array != 0) & (array != 1)):
            return "expected 0 or 1"
    elif isinstance(space, spaces.Box):
        if np.any(array < space.low) or np.any(array > space.high):
            return f"outside the bounds [{space.low}, {space.high}]"
    return None
