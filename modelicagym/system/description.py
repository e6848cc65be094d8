"""What a system declares, in the shape `FMUEnv` reads an FMU's (`FMUDescription`): its
variables named ``component.variable`` (``system.component.variable`` inside a nested SSP system),
its inputs (the components' inputs nothing feeds, and the SSP system's own input connectors),
outputs (the components', and the system's own output connectors) and parameters, the checked
connections, the order Gauss-Seidel steps in and the loops of direct feedthrough
(`modelicagym.system.loops`).

`open_system` opens one from an SSP archive or folder, or from a config's ``fmus`` and
``connections``; reading it loads no FMU binary.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Mapping, Sequence
from dataclasses import replace
from functools import cached_property
from pathlib import Path
from typing import Any

from modelicagym.errors import ConfigError
from modelicagym.fmu.description import DefaultExperiment
from modelicagym.fmu.errors import VariableError
from modelicagym.fmu.variables import Variable
from modelicagym.system.components import Component, open_component
from modelicagym.system.graph import ConnectionSpec, Link, check_connections, component_of, split_name, stepping_order
from modelicagym.system.loops import Loop, check_breaks_hold, find_loops, named_breaks
from modelicagym.system.ssp import SystemConnector, SystemSpec, read_ssp
from modelicagym.system.units import Conversion, Unit, conversion, declared_unit

logger = logging.getLogger(__name__)

#: the master algorithms: how the components' inputs are updated within a communication step
MASTERS = ("gauss-seidel", "jacobi")


class SystemDescription:
    """A system of components (FMUs and tables) and their connections, checked."""

    def __init__(self, spec: SystemSpec, path: Path | None, validate: bool = True):
        self.path = path
        self.name = path.name if path is not None else f"system({', '.join(spec.components)})"
        self.model_name = spec.name
        self.components: dict[str, Component] = {
            name: open_component(name, source, validate=validate) for name, source in spec.components.items()}
        if not self.components:
            raise ConfigError(f"{self.name}: a system needs at least one component")
        self.links: list[Link] = check_connections(self.components, spec.connections, self.name)
        self.loop_breaks: list[Link] = named_breaks(spec.loop_breaks, self.links, self.name)
        self.order = stepping_order(list(self.components), self.links, self.loop_breaks)
        #: the loops of direct feedthrough, each read with a one-step delay (`modelicagym.system.loops`)
        self.loops: list[Loop] = find_loops(self.components, self.links, self.order, self.loop_breaks)
        check_breaks_hold(self.loop_breaks, self.order, self.name)
        self._fed = {(link.target, link.target_variable): link for link in self.links}
        self.start_time = spec.start_time
        self.stop_time = spec.stop_time
        #: the SSP system's own inputs and outputs (`SystemConnector`), those that reach a component
        self.connectors: dict[str, SystemConnector] = self._usable_connectors(spec)
        self._through = {target for c in self.connectors.values() if c.kind == "input" for target, _ in c.targets}
        #: what the SSP declares without effect (a parameter that feeds nothing), one line each
        self.notes: list[str] = list(spec.notes)
        #: the values the SSP's parameter sets give (in their variables' units), applied under the
        #: env's own at every reset
        self.parameter_values: dict[str, Any] = {}
        for name, value in spec.parameters.items():
            link = self.fed_by(name)
            if link is None:
                self.parameter_values[name] = self._in_own_unit(name, value, spec.parameter_units.get(name))
            else:  # a start value, as tools export one for every input: the connection sets it
                self._note(f"parameter {name!r}: the connection {link.label} feeds it: the value the SSP binds to it "
                           f"has no effect")
        for derived in ("variables", "inputs", "outputs", "parameters"):  # checking the values read them before
            self.__dict__.pop(derived, None)

    def _usable_connectors(self, spec: SystemSpec) -> dict[str, SystemConnector]:
        """The top-level input connectors that feed a component and output connectors fed by one;
        each checked as a connection is (the component's end exists, and is an input or output)."""
        usable = {}
        for connector in spec.connectors.values():
            where = f"{self.name}: system connector {connector.name!r}"
            if connector.kind == "input" and connector.targets:
                for target, _ in connector.targets:
                    component, local = split_name(target, self.components, where)
                    if not component.variable(local, "input", component.inputs).is_input:
                        raise ConfigError(f"{where}: it feeds {target!r}, which is not an input")
                usable[connector.name] = connector
            elif connector.kind == "output" and connector.source is not None:
                component, local = split_name(connector.source[0], self.components, where)
                if not component.variable(local, "output", component.outputs).is_output:
                    raise ConfigError(f"{where}: it reads {connector.source[0]!r}, which is not an output")
                usable[connector.name] = connector
        return usable

    def split(self, name: str) -> tuple[str, str]:
        """``component.variable`` as the component's name and the variable's inside it."""
        return component_of(name, self.components)

    def feeds(self, name: str) -> list[tuple[str, Conversion]]:
        """The component inputs input ``name`` sets, each with its conversion: itself, or what a
        system input connector feeds."""
        connector = self.connectors.get(name)
        if connector is None:
            return [(name, Conversion())]
        return [(target, conversion or Conversion()) for target, conversion in connector.targets]

    def reads(self, name: str) -> tuple[str, Conversion]:
        """The component output that output ``name`` is (itself, or what a system output connector
        reads), with its conversion."""
        connector = self.connectors.get(name)
        if connector is None:
            return name, Conversion()
        source, conversion = connector.source
        return source, conversion or Conversion()

    def _in_own_unit(self, name: str, value: Any, unit: Unit | None) -> Any:
        """``value`` of parameter ``name``, given in ``unit``, in the unit its variable declares. A
        unit defined nowhere (neither the parameter set nor the FMU gives its base units, as in a
        product database's ``[m]``) cannot convert: the value is taken as it is, and reported."""
        variable = self.settable_variable(name)
        component = self.components[self.split(name)[0]]
        declared = declared_unit(variable.unit, component.units)
        if unit is not None and unit.exponents is None and declared is not None and unit.name != declared.name:
            self._note(f"parameter {name!r}: its value's unit {unit.name!r} is defined nowhere (not in its "
                       f"parameter set, not in the FMU): the unit is ignored, the value taken in the variable's "
                       f"unit {declared.name!r}")
            return value
        convert = conversion(unit, declared, f"{self.name}: parameter {name!r}")
        return value if convert.identity else convert.scale * value + convert.shift

    def _note(self, note: str) -> None:
        """Report what the SSP declares without effect (`notes`, and a warning)."""
        logger.warning("%s: %s", self.name, note)
        self.notes.append(note)

    def __repr__(self) -> str:
        return f"SystemDescription({self.name!r}, components={list(self.components)})"

    @cached_property
    def variables(self) -> dict[str, Variable]:
        """Every component's variables, named ``component.variable``, then the system's own
        connectors; a variable the SSP gives a value starts at that value."""
        variables = {f"{c.name}.{v.name}": replace(v, name=f"{c.name}.{v.name}")
                     for c in self.components.values() for v in c.variables.values()}
        for connector in self.connectors.values():
            behind = variables[connector.targets[0][0] if connector.kind == "input" else connector.source[0]]
            variables[connector.name] = replace(behind, name=connector.name, causality=connector.kind,
                                                start=behind.start if connector.value is None else connector.value)
        for name, value in self.parameter_values.items():
            if name in variables and not variables[name].shape:
                variables[name] = replace(variables[name], start=value)
        return variables

    @cached_property
    def inputs(self) -> list[Variable]:
        """The components' inputs nothing feeds, and the system's input connectors: what actions
        (or ``fixed_inputs``) drive."""
        return [self.variables[f"{c.name}.{v.name}"] for c in self.components.values() for v in c.inputs
                if (c.name, v.name) not in self._fed and f"{c.name}.{v.name}" not in self._through] + [
            self.variables[c.name] for c in self.connectors.values() if c.kind == "input"]

    @cached_property
    def outputs(self) -> list[Variable]:
        return [self.variables[f"{c.name}.{v.name}"] for c in self.components.values() for v in c.outputs] + [
            self.variables[c.name] for c in self.connectors.values() if c.kind == "output"]

    @cached_property
    def parameters(self) -> list[Variable]:
        return [v for v in self.variables.values() if v.is_parameter and v.settable]

    @cached_property
    def state_variables(self) -> list[Variable]:
        """The FMUs' continuous states, named ``component.variable``."""
        return [self.variables[f"{c.name}.{v.name}"] for c in self.components.values() if c.description is not None
                for v in c.description.state_variables]

    def locate(self, name: str) -> tuple[Component, Variable]:
        """The component of ``component.variable`` and the variable as the component names it."""
        head, local = self.split(name)
        component = self.components[head]
        return component, component.variables[local]

    @property
    def default_experiment(self) -> DefaultExperiment:
        """The SSP's start and stop time, and the first FMU's step size (the env's default time
        step); the first FMU's start and stop time where the SSP declares none."""
        first = next((c.description for c in self.components.values() if c.description is not None), None)
        declared = first.default_experiment if first is not None else DefaultExperiment()
        start = declared.start_time if self.start_time is None else self.start_time
        stop = declared.stop_time if self.stop_time is None else self.stop_time
        return DefaultExperiment(start, stop, declared.step_size, declared.tolerance)

    def once_per_process(self, mode: str | None = None) -> bool:
        """Whether some FMU of the system may be instantiated only once per process."""
        return any(c.description.once_per_process(c.mode) for c in self.components.values()
                   if c.description is not None)

    def loop_lines(self, master: str) -> list[str]:
        """One line per loop: where ``master`` reads it from the previous step (`Loop.describe`)."""
        return [loop.describe(master) for loop in self.loops]

    def fed_by(self, name: str) -> Link | None:
        """The connection feeding input ``component.variable``, or None."""
        return self._fed.get(self.split(name)) if "." in name else None

    # -- variables by name, checked as an FMU's are ----------------------------------------------

    def _local(self, name: str, role: str, candidates: Sequence[Variable]) -> tuple[Component, Variable]:
        component, local = split_name(name, self.components, f"{self.name}: {role} {name!r}")
        prefix = component.name + "."
        own = [component.variables[v.name[len(prefix):]] for v in candidates if v.name.startswith(prefix)]
        return component, component.variable(local, role, own)

    def variable(self, name: str, candidates: list[Variable] | None = None, role: str = "variable") -> Variable:
        """The variable ``component.variable``, or the system's own connector ``name``; an error with
        close matches when there is none."""
        if name in self.connectors:
            return self.variables[name]
        self._local(name, role, candidates or [])
        return self.variables[name]

    def input_variable(self, name: str) -> Variable:
        """``name`` checked to be driveable by an action: an unconnected input, a tunable parameter
        or the system's input connector."""
        if name in self.connectors:
            if self.connectors[name].kind != "input":
                raise VariableError(f"{self.name}: {name!r} cannot be an action: it is the system's output")
            return self.variables[name]
        if name in self._through:
            feeding = next(c.name for c in self.connectors.values() if name in dict(c.targets))
            raise VariableError(f"{self.name}: {name!r} cannot be an action: the system's input {feeding!r} feeds it")
        component, variable = self._local(name, "input", self.inputs)
        link = self.fed_by(name)
        if link is not None:
            raise VariableError(f"{self.name}: {name!r} cannot be an action: the connection {link.label} feeds it")
        if component.description is not None:
            component.description.input_variable(variable.name)  # its own checks and messages
        elif not variable.is_input:
            raise VariableError(f"{self.name}: {name!r} cannot be an action: a table has outputs only")
        return self.variables[name]

    def observable_variable(self, name: str) -> Variable:
        if name in self.connectors:
            if self.connectors[name].kind != "output":
                fed = ", ".join(target for target, _ in self.connectors[name].targets)
                raise VariableError(f"{self.name}: {name!r} cannot be observed: it is the system's input "
                                    f"(observe what it feeds: {fed})")
            return self.variables[name]
        component, variable = self._local(name, "output", self.outputs)
        if component.description is not None:
            component.description.observable_variable(variable.name)
        elif not variable.is_output:
            raise VariableError(f"{self.name}: {name!r} cannot be observed: a table's outputs are its columns "
                                f"({', '.join(v.name for v in component.outputs)})")
        return self.variables[name]

    def settable_variable(self, name: str) -> Variable:
        """``name`` checked to be settable at a reset: a parameter, an input nothing is connected to,
        or the system's input connector (which sets what it feeds)."""
        if name in self.connectors:
            if self.connectors[name].kind != "input":
                raise VariableError(f"{self.name}: {name!r} cannot be set: it is the system's output")
            return self.variables[name]
        component, variable = self._local(name, "parameter", self.parameters)
        link = self.fed_by(name)
        if link is not None:
            raise VariableError(f"{self.name}: {name!r} cannot be set: the connection {link.label} feeds it")
        if component.description is not None:
            component.description.settable_variable(variable.name)
        elif not variable.is_parameter:
            raise VariableError(f"{self.name}: {name!r} cannot be set: a table's only parameter is time_offset")
        return self.variables[name]


def open_system(fmu: str | os.PathLike[str] | None = None, *, fmus: Mapping[str, Any] | None = None,
                connections: Sequence[Any] = (), loop_breaks: Sequence[Any] = (),
                validate: bool = True) -> SystemDescription:
    """Open a system: an SSP archive or folder (``fmu``), or components and connections from a
    config (``fmus={"plant": "plant.fmu", "load": "load.csv"}``,
    ``connections=[("motor.tau", "plant.tau"), ...]``); ``loop_breaks``: the connections
    Gauss-Seidel reads from the previous step (``["plant.y -> controller.u"]``)."""
    if fmus is not None:
        if fmu is not None:
            raise ConfigError("give 'fmu' (one FMU, or an SSP system) or 'fmus' (components to connect), not both")
        if not isinstance(fmus, Mapping):
            raise ConfigError(f"fmus must be {{name: path}}, got {fmus!r} ({type(fmus).__name__})")
        for name in fmus:
            if not isinstance(name, str) or not name or "." in name:
                raise ConfigError(f"component name {name!r}: a component's name is a non-empty string without '.' "
                                  "(variables are named component.variable)")
        spec = SystemSpec("system", dict(fmus), [_connection(c) for c in connections], loop_breaks=loop_breaks)
        return SystemDescription(spec, None, validate)
    if connections:
        raise ConfigError("'connections' needs 'fmus' (the components they connect)")
    spec = read_ssp(fmu)
    spec.loop_breaks = loop_breaks
    return SystemDescription(spec, Path(fmu).expanduser(), validate)


def _connection(connection: Any) -> ConnectionSpec:
    """A config's connection: ``("a.y", "b.u")`` (or ``"a.y -> b.u"``)."""
    if isinstance(connection, str) and "->" in connection:
        connection = [part.strip() for part in connection.split("->")]
    if isinstance(connection, (str, bytes)) or not hasattr(connection, "__len__") or len(connection) != 2:
        raise ConfigError(f"a connection is a pair ('component.output', 'component.input'), got {connection!r}")
    return ConnectionSpec(*connection)
