"""The values a system moves: its action inputs and observed outputs, and a table's columns, in
numpy arrays laid out as `modelicagym.fmu.buffers.ValueBuffer` lays out an FMU's (``views`` by
name, ``flat`` when every variable shares one FMI type), so the env's `Observer` and
`write_values` work on a system as on one FMU."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from modelicagym.fmu.variables import Variable

#: the numpy type of each variable kind's values
_DTYPES = {"float": np.float64, "integer": np.int64, "enumeration": np.int64, "boolean": np.bool_}


class Values:
    """Values of ``variables``: ``views[name]`` (shaped like the variable), ``flat`` (all of them,
    when they share one FMI type) or None."""

    def __init__(self, variables: Sequence[Variable]):
        self.variables = list(variables)
        self.views: dict[str, np.ndarray] = {}
        same_type = len({v.fmi_type for v in self.variables}) == 1
        self.flat: np.ndarray | None = None
        if same_type:
            self.flat = np.zeros(sum(v.size for v in self.variables), _DTYPES.get(self.variables[0].kind, object))
            offset = 0
            for v in self.variables:
                self.views[v.name] = self.flat[offset:offset + v.size].reshape(v.shape)
                offset += v.size
        else:
            for v in self.variables:
                self.views[v.name] = np.zeros(v.shape, _DTYPES.get(v.kind, object))
        self.fill_start_values()

    def fill_start_values(self) -> None:
        """Put each variable's declared start value (or zero) into its view."""
        for v in self.variables:
            self.views[v.name][...] = 0 if v.start is None else np.reshape(v.start, v.shape) if v.shape else v.start

    def snapshot(self) -> bytes:
        """The values as they are now, as bytes (`load` puts them back)."""
        return b"".join(self.views[v.name].tobytes() for v in self.variables)

    def load(self, data: bytes) -> None:
        """Put back values `snapshot` returned."""
        offset = 0
        for v in self.variables:
            view = self.views[v.name]
            view[...] = np.frombuffer(data[offset:offset + view.nbytes], view.dtype).reshape(view.shape)
            offset += view.nbytes
