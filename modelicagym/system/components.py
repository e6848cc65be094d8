"""A system's components as the connection graph sees them: an FMU (its description, the mode it
runs in) or a time table, with its variables, units and direct dependencies."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

from modelicagym.errors import ConfigError
from modelicagym.fmu.description import MODES, FMUDescription, open_fmu
from modelicagym.fmu.errors import VariableError, unknown_variable
from modelicagym.fmu.variables import Variable
from modelicagym.system.table import TABLE_SUFFIXES, TableData, read_table
from modelicagym.system.units import Unit, unit_definitions


@dataclass
class Component:
    """One element of a system: ``description`` for an FMU (run in ``mode``, None: its default),
    ``table`` for a time table; ``variables`` by their names inside the component."""

    name: str
    source: Path
    description: FMUDescription | None = None
    table: TableData | None = None
    mode: str | None = None
    variables: dict[str, Variable] = field(default_factory=dict)
    units: dict[str, Unit] = field(default_factory=dict)

    @property
    def kind(self) -> str:
        return "table" if self.table is not None else "FMU"

    @property
    def inputs(self) -> list[Variable]:
        return [v for v in self.variables.values() if v.is_input]

    @property
    def outputs(self) -> list[Variable]:
        return [v for v in self.variables.values() if v.is_output]

    def variable(self, name: str, role: str, candidates: list[Variable]) -> Variable:
        """The component's variable ``name``; a `VariableError` naming the component, with close
        matches and (a few) ``candidates`` listed, when there is none."""
        variable = self.variables.get(name)
        if variable is None:
            error = unknown_variable(name, self.variables, f"component {self.name!r} ({self.source.name})", role)
            names = ", ".join(v.name for v in candidates[:30]) or "none"
            raise VariableError(f"{error} Its {role}s: {names}")
        return variable

    def depends_on(self, output: str) -> set[str]:
        """The inputs ``output`` depends on directly (its ModelStructure dependencies; all inputs
        where the FMU declares none, as FMI says; none for a table)."""
        if self.description is None:
            return set()
        inputs = {v.name for v in self.inputs}
        for unknown in self.description.raw.outputs:
            if unknown.variable.name == output:
                if unknown.dependencies is None:
                    return inputs
                return {v.name for v in unknown.dependencies} & inputs
        return inputs

    def declares_dependencies(self, output: str) -> bool:
        """Whether the FMU declares what ``output`` depends on (FMI 2.0 ``Outputs/Unknown``, FMI 3.0
        ``Output`` with a ``dependencies`` attribute; FMI 1.0 declares none): where it does not,
        `depends_on` takes every input, which may be what closes a loop. A table: True."""
        if self.description is None:
            return True
        return any(unknown.variable.name == output and unknown.dependencies is not None
                   for unknown in self.description.raw.outputs)


def open_component(name: str, source: str | os.PathLike[str] | dict, *, validate: bool = True,
                   mode: str | None = None) -> Component:
    """Open the component ``name``: ``source`` is the path of an FMU (file or folder) or of a
    CSV/MAT table, or ``{"fmu": path, "mode": "cs" | "me"}`` to run an FMU in a mode of its own."""
    if isinstance(source, dict):
        unknown = set(source) - {"fmu", "mode"}
        if unknown or "fmu" not in source:
            raise ConfigError(f"component {name!r}: give a path, or {{'fmu': path, 'mode': 'cs' or 'me'}}; "
                              f"got {source!r}")
        source, mode = source["fmu"], source.get("mode", mode)
    if not isinstance(name, str) or "" in name.split("."):
        raise ConfigError(f"component name {name!r}: a component's name is a non-empty string "
                          "(variables are named component.variable)")
    path = Path(source).expanduser()
    if path.suffix.lower() in TABLE_SUFFIXES:
        table = read_table(path)
        return Component(name, path, table=table, variables={v.name: v for v in table.variables()})
    if mode is not None and mode not in MODES:
        raise ConfigError(f"component {name!r}: mode must be one of {MODES}, got {mode!r}")
    description = open_fmu(path, validate=validate)
    if mode is not None:
        description.interface(mode)  # a clear error for a mode the FMU lacks
    return Component(name, path, description=description, mode=mode, variables=description.variables,
                     units=unit_definitions(description.raw))
