"""Gymnasium spaces derived from model variables, and the moves between spaces and FMU buffers.

The rule, stated once:

* a float variable is a ``Box`` (bounds from ``min``/``max``, else unbounded; FMI 3.0 arrays keep
  their shape); an integer or enumeration variable with known bounds is ``Discrete`` (``start`` =
  min), one without is an integer ``Box``; a boolean is ``MultiBinary``;
* scalar variables of one kind merge into one flat space: ``Box(n)`` (also for a single float,
  so an action is always an array), ``MultiDiscrete``, ``MultiBinary(n)``; a single integer or
  boolean stays ``Discrete``;
* anything else (mixed kinds, arrays next to other variables) is a ``Dict`` keyed by variable name.

`Observer` turns an FMU's output buffer into an observation of such a space; `write_values` writes
an action (checked by `modelicagym.action_checks`) into the input buffer.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium import spaces

from modelicagym.errors import ConfigError
from modelicagym.fmu.buffers import ValueBuffer
from modelicagym.fmu.variables import Variable


def _bounded_integer(v: Variable) -> bool:
    return v.kind == "enumeration" or (v.kind == "integer" and v.min is not None and v.max is not None)


def variable_space(v: Variable, dtype: Any = np.float64) -> spaces.Space:
    """The space of one variable's values."""
    low, high = v.bounds()
    if v.kind == "boolean":
        return spaces.MultiBinary(list(v.shape) or 1) if v.shape else spaces.Discrete(2)
    if _bounded_integer(v):
        n = int(high) - int(low) + 1
        if v.shape:
            return spaces.MultiDiscrete(np.full(v.shape, n), start=np.full(v.shape, int(low)))
        return spaces.Discrete(n, start=int(low))
    if v.kind == "integer":  # UInt64 values above 2**63 - 1 need their own dtype
        return spaces.Box(low, high, shape=v.shape, dtype=np.uint64 if v.fmi_type == "UInt64" else np.int64)
    return spaces.Box(np.float32(low) if dtype == np.float32 else low, high, shape=v.shape, dtype=dtype)


def _float_dtype(v: Variable) -> Any:
    return np.float32 if v.fmi_type == "Float32" else np.float64


def space_for(variables: Sequence[Variable]) -> spaces.Space:
    """The space of a list of variables (see the module docstring for the rule)."""
    if not variables:
        raise ConfigError("a space needs at least one variable")
    if len(variables) == 1 and (variables[0].shape or variables[0].kind != "float"):
        return variable_space(variables[0], _float_dtype(variables[0]))
    kinds = {("int" if _bounded_integer(v) else v.kind) for v in variables}
    scalar = all(not v.shape for v in variables)
    if scalar and len(kinds) == 1 and len({_float_dtype(v) for v in variables}) == 1:
        kind = kinds.pop()
        if kind == "float":
            dtype = _float_dtype(variables[0])
            bounds = np.array([v.bounds() for v in variables], dtype=dtype)
            return spaces.Box(bounds[:, 0], bounds[:, 1], dtype=dtype)
        if kind == "int":
            bounds = np.array([v.bounds() for v in variables], dtype=np.int64)
            return spaces.MultiDiscrete(bounds[:, 1] - bounds[:, 0] + 1, start=bounds[:, 0])
        if kind == "boolean":
            return spaces.MultiBinary(len(variables))
    return spaces.Dict({v.name: variable_space(v, _float_dtype(v)) for v in variables})


def _as_space_value(space: spaces.Space, values: np.ndarray) -> Any:
    if isinstance(space, spaces.Discrete):
        return np.int64(values.reshape(-1)[0])
    return np.array(values.reshape(space.shape), dtype=space.dtype)


class Observer:
    """Reads an observation of ``space`` from an output buffer (a fresh copy every call)."""

    def __init__(self, space: spaces.Space, buffer: ValueBuffer):
        self.space = space
        self._views: list[tuple[str, spaces.Space, np.ndarray]] | None = None
        self._flat: np.ndarray | None = None
        self._parts: list[np.ndarray] = []
        if isinstance(space, spaces.Dict):
            self._views = [(name, space[name], buffer.views[name]) for name in space.keys()]
        else:
            self._flat = buffer.flat
            if self._flat is None:  # one flat space over several FMI types (Integer + Enumeration)
                self._parts = [buffer.views[v.name] for v in buffer.variables]
        plain = isinstance(space, spaces.Box) and self._flat is not None and self._flat.dtype == space.dtype
        self._copy = plain and self._flat.shape == space.shape

    def observe(self) -> Any:
        """The current observation."""
        if self._copy:
            return self._flat.copy()
        if self._views is None:
            flat = self._flat if self._flat is not None else np.concatenate([p.ravel() for p in self._parts])
            return _as_space_value(self.space, flat)
        return {name: _as_space_value(sub, np.asarray(view)) for name, sub, view in self._views}


def write_values(buffer: ValueBuffer, values: Any) -> None:
    """Write input ``values``: an array-like in variable order, or a dict by name."""
    if isinstance(values, dict):
        for name, value in values.items():
            buffer.views[name][...] = value
    elif buffer.flat is not None:
        try:
            buffer.flat[:] = values
        except ValueError:  # e.g. an array action of shape (1, n) for n inputs
            buffer.flat[:] = np.ravel(values)
    else:  # one flat action over several FMI types: split it in variable order
        flat, offset = np.ravel(values), 0
        for v in buffer.variables:
            buffer.views[v.name][...] = flat[offset : offset + v.size].reshape(v.shape)
            offset += v.size
