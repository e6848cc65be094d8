"""Read an SSP system (the FMI standard for systems, "System Structure and Parameterization"): an
``.ssp`` archive, or a folder, holding ``SystemStructure.ssd`` and the FMUs it names (usually under
``resources/``), with its parameter sets (``.ssv``, or inline ``ssv:ParameterSet``) and parameter
mappings (``.ssm``) applied, a value given in a unit (``ssv:Real unit``, defined in the set's
``ssv:Units`` or the FMU's) converted to its variable's.

What is read: the components of the top-level system (FMUs, with their ``implementation`` as the
mode, and tables: a ``.csv`` or ``.mat`` source), its connections between components (with an
``ssc:LinearTransformation``), the parameter bindings of the system and of each component (a
binding's ``prefix``; a mapping renames a parameter set's names, with its own linear
transformation), and ``DefaultExperiment``'s start time. Connections to the system's own
connectors leave the component's end unconnected (an input then becomes an action), except that a
value the system's parameter sets give such a connector (OMSimulator's system parameters) goes to
every component variable it feeds. Nested
systems and signal dictionaries are refused in one line.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from lxml import etree

from modelicagym.errors import ConfigError, DataError
from modelicagym.fmu.description import extract_archive
from modelicagym.fmu.errors import FMUNotFoundError, InvalidFMUError
from modelicagym.system.graph import ConnectionSpec
from modelicagym.system.units import BASE_UNITS, Conversion, Unit

logger = logging.getLogger(__name__)

SSD_NAME = "SystemStructure.ssd"
NS = {
    "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon",
    "ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
    "ssm": "http://ssp-standard.org/SSP1/SystemStructureParameterMapping",
    "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues",
}
#: SSD ``implementation`` -> the mode a component runs in (``Any``: its default)
_IMPLEMENTATIONS = {"CoSimulation": "cs", "ModelExchange": "me", "Any": None, None: None}


@dataclass
class SystemSpec:
    """A system as written, before anything is opened: its components (name -> path, or
    ``{"fmu": path, "mode": ...}``), connections, parameter values by ``component.variable``
    and the start time it declares (None: none)."""

    name: str
    components: dict[str, Any]
    connections: list[ConnectionSpec]
    parameters: dict[str, Any] = field(default_factory=dict)
    start_time: float | None = None
    #: the unit a parameter set gives a value in, where it gives one (converted to the variable's)
    parameter_units: dict[str, Unit] = field(default_factory=dict)
    #: the connections Gauss-Seidel reads from the previous step, as the config names them (`modelicagym.system.loops`)
    loop_breaks: list[Any] = field(default_factory=list)


def is_ssp(path: str | Path) -> bool:
    """Whether ``path`` is an SSP archive or a folder holding ``SystemStructure.ssd``."""
    path = Path(path).expanduser()
    return path.suffix.lower() == ".ssp" or (path.is_dir() and (path / SSD_NAME).is_file()) or path.name == SSD_NAME


def read_ssp(path: str | Path) -> SystemSpec:
    """The system an ``.ssp`` archive or folder declares (see the module docstring)."""
    path = Path(path).expanduser()
    if not path.exists():
        raise FMUNotFoundError(f"SSP system not found: {path} (resolved to {path.resolve()})")
    root = path.parent if path.name == SSD_NAME else path if path.is_dir() else extract_archive(
        path, SSD_NAME, "an SSP archive")
    ssd = _parse(root / SSD_NAME, path)
    system = ssd.find("ssd:System", NS)
    if system is None:
        raise InvalidFMUError(f"{path}: {SSD_NAME} declares no ssd:System")
    name = system.get("name") or path.stem
    if system.find("ssd:Elements/ssd:System", NS) is not None:
        raise ConfigError(f"{path}: system {name!r} nests systems; flatten it into one system of components")
    components: dict[str, Any] = {}
    units: dict[str, Unit] = {}
    parameters = _bindings(system, root, path, "", units)
    for element in system.iterfind("ssd:Elements/ssd:Component", NS):
        component = element.get("name")
        source = element.get("source")
        if not source:
            raise InvalidFMUError(f"{path}: component {component!r} has no source")
        implementation = element.get("implementation")
        if implementation not in _IMPLEMENTATIONS:
            raise InvalidFMUError(f"{path}: component {component!r}: unknown implementation {implementation!r}; "
                                  f"one of {', '.join(k for k in _IMPLEMENTATIONS if k)}")
        mode = _IMPLEMENTATIONS[implementation]
        location = str(root / source)
        components[component] = {"fmu": location, "mode": mode} if mode else location
        parameters.update(_bindings(element, root, path, f"{component}.", units))
    connections = []
    fed: dict[str, list[tuple[str, Conversion | None]]] = {}  # a system connector -> the components' ends it feeds
    for element in system.iterfind("ssd:Connections/ssd:Connection", NS):
        start, end = element.get("startElement"), element.get("endElement")
        if start is None and end is not None:
            fed.setdefault(element.get("startConnector"), []).append(
                (f"{end}.{element.get('endConnector')}", _transformation(element)))
        if start is None or end is None:
            logger.debug("%s: connection of %s.%s to %s.%s touches the system's own connectors: its component end "
                         "stays unconnected", path, start, element.get("startConnector"), end,
                         element.get("endConnector"))
            continue
        connections.append(ConnectionSpec(f"{start}.{element.get('startConnector')}",
                                          f"{end}.{element.get('endConnector')}", _transformation(element)))
    for connector in [name for name in parameters if name in fed]:  # a system parameter: the value of what it feeds
        value = parameters.pop(connector)
        unit = units.pop(connector, None)
        for target, transformation in fed[connector]:
            parameters[target] = value if transformation is None else transformation.scale * value + transformation.shift
            if unit is not None and transformation is None:
                units[target] = unit
    experiment = ssd.find("ssd:DefaultExperiment", NS)
    start_time = experiment.get("startTime") if experiment is not None else None
    return SystemSpec(name, components, connections, parameters, None if start_time is None else float(start_time),
                      units)


def _parse(file: Path, where: Path) -> Any:
    if not file.is_file():
        raise FMUNotFoundError(f"{where}: {file.name} not found (resolved to {file})")
    try:
        return etree.parse(str(file)).getroot()
    except etree.XMLSyntaxError as error:
        raise InvalidFMUError(f"{where}: cannot read {file.name}: {error}") from None


def _transformation(element: Any) -> Conversion | None:
    linear = element.find("ssc:LinearTransformation", NS)
    if linear is None:
        return None
    return Conversion(float(linear.get("factor", 1.0)), float(linear.get("offset", 0.0)))


def _bindings(element: Any, root: Path, where: Path, scope: str, units: dict[str, Unit]) -> dict[str, Any]:
    """The parameter values of ``element``'s bindings, named ``scope`` + prefix + name (a
    component's bindings name its variables), mappings applied; into ``units``, the unit of each
    value that names one (defined by its parameter set's ``ssv:Units``, else by name only)."""
    values: dict[str, Any] = {}
    for binding in element.iterfind("ssd:ParameterBindings/ssd:ParameterBinding", NS):
        prefix = binding.get("prefix") or ""
        sets = [_parse(root / binding.get("source"), where)] if binding.get("source") else []
        sets += list(binding.iterfind("ssd:ParameterValues/ssv:ParameterSet", NS))
        mapping: dict[str, tuple[str, Conversion | None]] = {}
        for reference in binding.iterfind("ssd:ParameterMapping", NS):
            inline = reference.find("ssm:ParameterMapping", NS)
            document = _parse(root / reference.get("source"), where) if reference.get("source") else inline
            for entry in document.iterfind("ssm:MappingEntry", NS) if document is not None else ():
                mapping[entry.get("source")] = (entry.get("target"), _transformation(entry))
        for parameter_set in sets:
            defined = {unit.get("name"): _unit(unit) for unit in parameter_set.iterfind("ssv:Units/ssc:Unit", NS)}
            for parameter in parameter_set.iterfind("ssv:Parameters/ssv:Parameter", NS):
                name, value = parameter.get("name"), _value(parameter, where)
                target, transformation = mapping.get(name, (name, None))
                if transformation is not None:
                    value = transformation.scale * value + transformation.shift
                values[scope + prefix + target] = value
                unit = parameter.find("ssv:Real", NS)
                if unit is not None and unit.get("unit") and transformation is None:
                    units[scope + prefix + target] = defined.get(unit.get("unit")) or Unit(unit.get("unit"), None)
    return values


def _unit(element: Any) -> Unit:
    """An ``ssc:Unit`` with its ``ssc:BaseUnit``, as an FMU's unit definition."""
    base = element.find("ssc:BaseUnit", NS)
    attributes = {} if base is None else base.attrib
    return Unit(element.get("name"), tuple(int(attributes.get(b, 0)) for b in BASE_UNITS),
                float(attributes.get("factor", 1.0)), float(attributes.get("offset", 0.0)))


def _value(parameter: Any, where: Path) -> Any:
    """A parameter's value from its ``ssv:Real`` / ``Integer`` / ``Boolean`` / ``String`` element."""
    for kind, parse in (("Real", float), ("Integer", int), ("Boolean", lambda text: text.lower() in ("true", "1")),
                        ("String", str)):
        element = parameter.find(f"ssv:{kind}", NS)
        if element is not None:
            try:
                return parse(element.get("value"))
            except (TypeError, ValueError):
                raise DataError(f"{where}: parameter {parameter.get('name')!r}: {element.get('value')!r} is not "
                                f"a {kind}") from None
    raise DataError(f"{where}: parameter {parameter.get('name')!r} has no Real, Integer, Boolean or String value")
