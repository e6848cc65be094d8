"""Checks of an `FMUEnvConfig`'s values, each failure a `ConfigError` that names the key.

Every number is finite, in range and of the right type (``time_step="0.05"`` gets a message about
its type, not a failed comparison); termination bounds and ``action_bounds`` are ``(low, high)``
pairs with ``low <= high`` (finite for ``action_bounds``, whose names must be inputs); once the FMU
is known, every parameter value fits its variable (a list for a scalar, a string for a number, are
errors at construction, not at the first reset).
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Mapping
from numbers import Integral, Real
from typing import Any

import numpy as np

from modelicagym.errors import ConfigError, ConfigTypeError

__all__ = ["check_action_bound_names", "check_action_bounds", "check_batch_hooks", "check_fixed_input_names",
           "check_fixed_inputs", "check_numbers", "check_parameter", "check_termination"]


def _real(key: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, Real):
        raise ConfigTypeError(f"{key} must be a number, got {value!r} ({type(value).__name__})")
    if not math.isfinite(value):
        raise ConfigError(f"{key} must be finite, got {value!r}")
    return float(value)


def check_numbers(config: Any) -> None:
    """The numeric keys of ``config`` (an `FMUEnvConfig`), in place where a value is normalised."""
    for key in ("time_step", "tolerance", "solver_step"):
        value = getattr(config, key)
        if value is not None and not _real(key, value) > 0:
            raise ConfigError(f"{key} must be positive, got {value!r}")
    if config.start_time is not None:
        _real("start_time", config.start_time)
    for key in ("positive_reward", "negative_reward"):
        _real(key, getattr(config, key))
    steps = config.max_episode_steps
    if steps is not None:
        if isinstance(steps, bool) or not isinstance(steps, Integral):
            raise ConfigTypeError(f"max_episode_steps must be an integer, got {steps!r} ({type(steps).__name__})")
        if steps < 1:
            raise ConfigError(f"max_episode_steps must be at least 1, got {steps}")


def check_termination(termination: Any) -> None:
    """``None``, a callable, or ``{output: (low, high)}`` with finite-or-infinite numbers, low <= high."""
    if termination is None or callable(termination):
        return
    if not isinstance(termination, Mapping):
        raise ConfigTypeError(f"termination must be {{output: (low, high)}} or a callable, got {termination!r}")
    _check_intervals(termination, "termination bound", finite=False)


def check_batch_hooks(config: Any) -> None:
    """``batch_reward`` / ``batch_termination`` are callables, each given instead of its per-env
    key (``reward`` / ``termination``), not beside it."""
    for key, per_env in (("batch_reward", "reward"), ("batch_termination", "termination")):
        hook = getattr(config, key)
        if hook is None:
            continue
        if not callable(hook):
            raise ConfigTypeError(f"{key} must be a callable on arrays, got {hook!r} ({type(hook).__name__})")
        if getattr(config, per_env) is not None:
            raise ConfigError(f"both {per_env!r} and {key!r} are given: give one ({key} is {per_env} on arrays)")
    if config.reward is not None and not callable(config.reward):
        raise ConfigTypeError(f"reward must be a callable, got {config.reward!r} ({type(config.reward).__name__})")


def check_action_bounds(action_bounds: Any) -> None:
    """``None`` or ``{input: (low, high)}`` with finite numbers, low <= high (the names are checked
    against the inputs once the FMU is known: `check_action_bound_names`)."""
    if action_bounds is None:
        return
    if not isinstance(action_bounds, Mapping):
        raise ConfigTypeError(f"action_bounds must be {{input: (low, high)}}, got {action_bounds!r}")
    unset = [name for name, bounds in action_bounds.items() if bounds is None]
    if unset:
        raise ConfigError(f"action_bounds of {', '.join(map(repr, unset))} {'is' if len(unset) == 1 else 'are'} still "
                          "None, the placeholder `modelicagym info` writes where nothing in the FMU says an input's "
                          "range: give each a (low, high) pair (from the model's documentation, or what `modelicagym "
                          "try` shows), or hold the input with 'fixed_inputs'")
    _check_intervals(action_bounds, "action_bounds", finite=True)


def check_action_bound_names(fmu: str, action_bounds: Mapping[str, Any], inputs: list[str]) -> None:
    """Every name in ``action_bounds`` is one of the config's ``inputs`` (else close matches are suggested)."""
    for name in action_bounds:
        if name not in inputs:
            close = difflib.get_close_matches(name, inputs, n=3, cutoff=0.6)
            hint = f" Did you mean {', '.join(repr(c) for c in close)}?" if close else ""
            raise ConfigError(f"{fmu}: action_bounds names {name!r}, which is not in 'inputs'.{hint} "
                              f"Inputs: {', '.join(inputs) or 'none'}")


def check_fixed_inputs(config: Any) -> None:
    """``fixed_inputs`` is ``{input: value}`` whose names are in neither ``inputs`` (an input is
    driven by the action or held, not both) nor ``parameters`` (one value per variable)."""
    fixed = config.fixed_inputs
    if not isinstance(fixed, Mapping):
        raise ConfigTypeError(f"fixed_inputs must be {{input: value}}, got {fixed!r} ({type(fixed).__name__})")
    for key, what in (("inputs", "driven by the action"), ("parameters", "set as a parameter")):
        both = [name for name in fixed if name in getattr(config, key)]
        if both:
            raise ConfigError(f"{', '.join(map(repr, both))} {'is' if len(both) == 1 else 'are'} in both {key!r} ({what}) and 'fixed_inputs' (held at a "
                              f"value): keep {'it' if len(both) == 1 else 'each'} in one of them")


def check_fixed_input_names(fmu: str, fixed_inputs: Mapping[str, Any], variables: Mapping[str, Any],
                            inputs: list[Any]) -> list[Any]:
    """The variables ``fixed_inputs`` names, each checked to be one of the FMU's ``inputs`` (an
    unknown name gets close matches; a parameter is sent to ``parameters``)."""
    names = [v.name for v in inputs]
    checked = []
    for name in fixed_inputs:
        variable = variables.get(name)
        if variable is None:
            close = difflib.get_close_matches(name, names, n=3, cutoff=0.6)
            hint = f" Did you mean {', '.join(repr(c) for c in close)}?" if close else ""
            raise ConfigError(f"{fmu}: fixed_inputs names {name!r}, which is not an input of this FMU.{hint} "
                              f"Inputs: {', '.join(names) or 'none'}")
        if not variable.is_input:
            fix = "put it in 'parameters'" if variable.is_parameter else "only inputs are held"
            raise ConfigError(f"{fmu}: fixed_inputs names {name!r}, which is not an input (causality "
                              f"{variable.causality!r}): {fix}")
        checked.append(variable)
    return checked


def _check_intervals(intervals: Mapping[str, Any], what: str, finite: bool) -> None:
    """Each value of ``intervals`` is a ``(low, high)`` pair of numbers, low <= high, not NaN (nor
    infinite when ``finite``)."""
    for name, bounds in intervals.items():
        where = f"{what} on {name!r}"
        if isinstance(bounds, (str, bytes)) or not hasattr(bounds, "__len__") or len(bounds) != 2:
            raise ConfigError(f"{where} must be a (low, high) pair, got {bounds!r}")
        low, high = bounds
        for value in (low, high):
            if isinstance(value, bool) or not isinstance(value, Real):
                raise ConfigTypeError(f"{where} must be numbers, got {bounds!r}")
            if math.isnan(value):
                raise ConfigError(f"{where} contains NaN: {bounds!r}")
            if finite and math.isinf(value):
                raise ConfigError(f"{where} must be finite, got {bounds!r}")
        if low > high:
            raise ConfigError(f"{where} has low > high: {bounds!r}")


#: the Python types a parameter value of each variable kind may have
_KINDS: dict[str, tuple[type, ...]] = {
    "float": (Real,),
    "integer": (Integral,),
    "enumeration": (Integral,),
    "boolean": (bool, np.bool_, Integral),
    "string": (str,),
}


def check_parameter(fmu: str, variable: Any, value: Any, role: str = "parameter") -> None:
    """A fixed (non-callable) value of a parameter (or of a held input: ``role``) fits ``variable``
    (an `fmu.variables.Variable`)."""
    if callable(value):
        return
    where = f"{fmu}: {role} {variable.name!r} ({variable.fmi_type}{list(variable.shape) if variable.shape else ''})"
    allowed = _KINDS.get(variable.kind)
    kind = f"{'an' if variable.kind[0] in 'aeiou' else 'a'} {variable.kind}"
    if variable.shape:
        array = np.asarray(value)
        if array.size != variable.size:
            raise ConfigError(f"{where} needs {variable.size} values, got {value!r}")
        items = array.ravel().tolist()
    elif isinstance(value, (list, tuple, np.ndarray)) and not (isinstance(value, np.ndarray) and value.shape == ()):
        raise ConfigError(f"{where} is a scalar, got {value!r}")
    else:
        items = [value.item() if isinstance(value, np.generic) or isinstance(value, np.ndarray) else value]
    for item in items:
        if allowed is None:
            return
        if variable.kind != "boolean" and isinstance(item, bool):
            raise ConfigTypeError(f"{where} needs {kind} value, got {value!r}")
        if not isinstance(item, allowed):
            raise ConfigTypeError(f"{where} needs {kind} value, got {value!r} ({type(item).__name__})")
        if variable.kind == "float" and not math.isfinite(item):
            raise ConfigError(f"{where} must be finite, got {value!r}")
