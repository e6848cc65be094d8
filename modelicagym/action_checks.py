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

__all__ = ["CHECKED_SPACES", "action_checker", "action_clipper", "action_problem", "check_action", "describe_action",
           "element_bounds"]

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
    """A fast `check_action` for one space: common valid actions pass in well under a microsecond
    (a Dict's in about a microsecond per entry)."""
    fast = _fast_check(space)
    if fast is None:
        return partial(check_action, space)

    def check(action: Any) -> None:
        if not fast(action):
            check_action(space, action)

    return check


def _fast_check(space: spaces.Space) -> Callable[[Any], bool] | None:
    """A predicate true for the common valid actions of ``space`` (false: ask `check_action`, which
    accepts the others and names what is wrong), or ``None`` when the space has none."""
    if type(space) is spaces.Discrete:
        low, high = int(space.start), int(space.start + space.n)
        return lambda action: (type(action) is int or isinstance(action, np.integer)) and low <= action < high
    if type(space) in (spaces.Box, spaces.MultiDiscrete, spaces.MultiBinary) and 0 < int(np.prod(space.shape)) <= 16:
        lows, highs = element_bounds(space)
        bounds = list(zip(lows.tolist(), highs.tolist()))
        shape, kinds = space.shape, ("fiu" if type(space) is spaces.Box else "iub")

        def is_array(action: Any) -> bool:
            return isinstance(action, (np.ndarray, np.generic)) and action.shape == shape and action.dtype.kind in kinds

        if shape == ():  # a Dict's entry for one scalar variable: often a numpy scalar
            ((low, high),) = bounds
            scalars = (np.floating, np.integer) if type(space) is spaces.Box else (np.integer, np.bool_)

            def check_scalar(action: Any) -> bool:
                if not (isinstance(action, scalars) or (type(action) is np.ndarray and is_array(action))):
                    return False
                value = action.item()
                return low <= value <= high and isfinite(value)

            return check_scalar

        return lambda action: is_array(action) and all(
            low <= value <= high and isfinite(value) for value, (low, high) in zip(action.ravel().tolist(), bounds))
    if type(space) is spaces.Dict:
        entries = [(key, _fast_check(sub)) for key, sub in space.items()]
        if any(check is None for _, check in entries):
            return None
        keys = set(space.keys())
        return lambda action: (type(action) is dict and action.keys() == keys
                               and all(check(action[key]) for key, check in entries))
    return None


def element_bounds(space: spaces.Space) -> tuple[np.ndarray, np.ndarray]:
    """Each element's lowest and highest valid value (a Box's bounds, a MultiDiscrete's range, 0/1)."""
    if type(space) is spaces.Box:
        return np.ravel(space.low), np.ravel(space.high)
    if type(space) is spaces.MultiDiscrete:
        return np.ravel(space.start), np.ravel(space.start + space.nvec - 1)
    return np.zeros(int(np.prod(space.shape)), np.int64), np.ones(int(np.prod(space.shape)), np.int64)


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


def action_clipper(space: spaces.Space) -> Callable[[Any], Any]:
    """For ``action_out_of_bounds="clip"``: a function returning the action, clipped into the
    bounds of a ``Box`` when it is outside them (a valid action is returned as it is), and raising
    what `check_action` raises for anything else (NaN, a wrong shape, another space's value)."""
    check = action_checker(space)
    fast = _fast_check(space)
    if type(space) is not spaces.Box:
        return lambda action: check(action) or action

    def clip(action: Any) -> Any:
        if fast is not None and fast(action):
            return action
        clipped = np.clip(np.asarray(action), space.low, space.high) if np.shape(action) == space.shape else action
        check(clipped)
        return clipped

    return clip
