"""Preallocated value arrays for a fixed list of variables.

The hot path of a step moves inputs in and outputs out. A `ValueBuffer` owns one ctypes array of
value references and one of values per FMI type, a numpy view on each (so the environment reads
and writes them without copies through ctypes), and get/set calls bound in advance, so that a
read or write allocates nothing and costs one ctypes call per FMI type.
"""

from __future__ import annotations

import ctypes
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from modelicagym.fmu.binding import OK, WARNING, FMIBinding
from modelicagym.fmu.variables import Variable


class ValueBuffer:
    """Values of ``variables``, grouped by FMI type, in preallocated arrays.

    ``views[name]`` is a numpy view on a variable's values (shaped like the variable);
    ``flat`` is a view on all values when they share one FMI type (the common case), else None.
    """

    def __init__(self, binding: FMIBinding, variables: Sequence[Variable]):
        self.binding = binding
        self.variables = list(variables)
        self.views: dict[str, np.ndarray] = {}
        self._groups: list[tuple[str, ctypes.Array, ctypes.Array, int]] = []
        by_type: dict[str, list[Variable]] = {}
        for variable in self.variables:
            by_type.setdefault(variable.fmi_type, []).append(variable)
        for fmi_type, members in by_type.items():
            ctype = binding.value_ctype(fmi_type)
            n_values = sum(v.size for v in members)
            refs = (ctypes.c_uint * len(members))(*(v.value_reference for v in members))
            values = (ctype * n_values)()
            array = np.ctypeslib.as_array(values)
            offset = 0
            for v in members:
                self.views[v.name] = array[offset : offset + v.size].reshape(v.shape)
                offset += v.size
            self._groups.append((fmi_type, refs, values, n_values))
        self.flat: np.ndarray | None = np.ctypeslib.as_array(self._groups[0][2]) if len(self._groups) == 1 else None
        self.read: Callable[[], int] = _no_call
        self.write: Callable[[], int] = _no_call
        self.fill_start_values()

    def fill_start_values(self) -> None:
        """Put each variable's declared start value (or zero) into the buffer."""
        for v in self.variables:
            self.views[v.name][...] = 0 if v.start is None else np.reshape(v.start, v.shape) if v.shape else v.start

    def bind(self) -> None:
        """(Re)bind the get/set calls to the binding's live instance; call after every instantiation.

        ``read()``/``write()`` return the worst FMI status of their calls.
        """
        calls = [self.binding.accessors(t, refs, values, n) for t, refs, values, n in self._groups]
        if not calls:
            self.read = self.write = _no_call
        elif len(calls) == 1:
            self.read, self.write = calls[0]
        else:
            getters, setters = [g for g, _ in calls], [s for _, s in calls]
            self.read = lambda: max(g() for g in getters)
            self.write = lambda: max(s() for s in setters)

    def groups(self) -> list[tuple[str, int, int, int, int, int]]:
        """Per FMI type, in call order, for native callers: ``(fmi_type, refs address, number of
        references, values address, number of values, bytes of values)``."""
        return [(t, ctypes.addressof(refs), len(refs), ctypes.addressof(values), n, ctypes.sizeof(values))
                for t, refs, values, n in self._groups]

    def snapshot(self) -> bytes:
        """The values as they are now, to tell later whether any changed (bit for bit)."""
        return b"".join(bytes(values) for _, _, values, _ in self._groups)

    def load(self, data: bytes) -> None:
        """Put back values `snapshot` returned (to replay recorded inputs)."""
        offset = 0
        for _, _, values, _ in self._groups:
            size = ctypes.sizeof(values)
            ctypes.memmove(values, data[offset : offset + size], size)
            offset += size

    def check(self, status: int, what: str) -> None:
        if status > WARNING:
            names = ", ".join(v.name for v in self.variables)
            raise self.binding.fail(f"{what} ({names})", status)


def _no_call() -> int:
    return OK


def start_at(buffer: Any, values: Mapping[str, Any]) -> None:
    """Start the variables of ``buffer`` (a `ValueBuffer`, or a system's values) that ``values``
    names at those values from now on: at every `fill_start_values`, and so at every reset, on the
    Python and the native path."""
    if any(v.name in values for v in buffer.variables):
        buffer.variables = [replace(v, start=values[v.name]) if v.name in values else v for v in buffer.variables]
        buffer.fill_start_values()
