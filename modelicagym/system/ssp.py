"""Read an SSP system (the FMI standard for systems, "System Structure and Parameterization"): an
``.ssp`` archive, or a folder, holding ``SystemStructure.ssd`` and the FMUs it names (usually under
``resources/``), with its parameter sets (``.ssv``, or inline ``ssv:ParameterSet``) and parameter
mappings (``.ssm``) applied, a value given in a unit (``ssv:Real unit``, defined in the set's
``ssv:Units`` or the FMU's) converted to its variable's.

A system that nests systems is read as one flat system: a component inside sub-system ``sub`` is
named ``sub.component`` (``sub.inner.component`` one level further), its variables
``sub.component.variable``. A connection to a sub-system's connector is followed through to the
component behind it, at any depth, the linear transformations along the way composed. The
top-level system's own connectors are the system's inputs and outputs (`SystemConnector`); an
input reached only through connectors that nothing feeds stays unconnected (an action, if chosen).

Parameter bindings apply at every level; where several give the same variable a value, the binding
of the higher level (the enclosing system) wins over a lower level's (a sub-system's, a
component's own), the rule OMSimulator follows (its test suite expects the system's value); within one level the
later binding wins. A value given to a connector (OMSimulator's system parameters) goes to every
component variable the connector feeds, and wins over a value bound to the variable itself (the
connection sets it); one that feeds nothing is reported (`SystemSpec.notes`), and so are the
parameters of a set that name nothing in the system (a product database's export holds more).
Every connector's value is kept (`SystemSpec.connector_values`). A mapping row with an empty source
(OMSimulator's templates) maps nothing.

Tools write a connection either way round: where the kinds of the system connectors at its ends
say the value flows from end to start, it is read so, and a connection between components is
marked to be turned round where its start is an input and its end an output (`ConnectionSpec.either_way`).

A defect of the SSD, an SSV or an SSM is a `DataError` naming the file, the element and its line.
"""

from __future__ import annotations

import difflib
import logging
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

from lxml import etree

from modelicagym.errors import DataError
from modelicagym.fmu.description import extract_archive
from modelicagym.fmu.errors import FMUNotFoundError
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
#: the kinds of a system's connector (SSP 1.0 section 5.3.2)
CONNECTOR_KINDS = ("input", "output", "inout", "parameter", "calculatedParameter", "structuralParameter",
                   "constant", "local")
#: the kinds of connector whose value enters its system from outside (an output's, a calculated parameter's, leaves)
_INWARD = ("input", "parameter", "structuralParameter", "constant")
_OUTWARD = ("output", "calculatedParameter")
#: the attributes the standard gives the elements read here (besides id and description, and any
#: attribute of another namespace): one it does not know is a defect of the file, refused
_ATTRIBUTES = {
    "Component": ("name", "type", "source", "implementation"),
    "System": ("name",),
    "Connector": ("name", "kind"),
    "Connection": ("startElement", "startConnector", "endElement", "endConnector", "suppressUnitConversion"),
    "ParameterBinding": ("type", "source", "sourceBase", "prefix"),
    "ParameterMapping": ("type", "source", "sourceBase"),
    "MappingEntry": ("source", "target", "suppressUnitConversion"),
    "Parameter": ("name",),
}


@dataclass
class SystemConnector:
    """A connector of the top-level system: an ``input`` feeds ``targets`` (component variables,
    each with the linear transformation along the way, None: units convert), an ``output`` reads
    ``source``; ``value``: what the system's parameter sets give it (None: nothing)."""

    name: str
    kind: str
    targets: list[tuple[str, Conversion | None]] = field(default_factory=list)
    source: tuple[str, Conversion | None] | None = None
    value: Any = None


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
    #: the stop time its default experiment declares (None: none)
    stop_time: float | None = None
    #: the unit a parameter set gives a value in, where it gives one (converted to the variable's)
    parameter_units: dict[str, Unit] = field(default_factory=dict)
    #: the connections Gauss-Seidel reads from the previous step, as the config names them (`modelicagym.system.loops`)
    loop_breaks: list[Any] = field(default_factory=list)
    #: the top-level system's own inputs and outputs, by name
    connectors: dict[str, SystemConnector] = field(default_factory=dict)
    #: what was read but has no effect (a parameter that feeds nothing), one line each
    notes: list[str] = field(default_factory=list)
    #: the value of each system connector the parameter sets reach, at any depth, by its full name:
    #: its own binding's, or what a connector bound at a higher level feeds it (as a variable's)
    connector_values: dict[str, Any] = field(default_factory=dict)


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
    ssd = _parse(root / SSD_NAME, SSD_NAME, path, "ssd:SystemStructureDescription")
    system = ssd.find("ssd:System", NS)
    if system is None:
        raise DataError(f"{path}: {SSD_NAME} declares no ssd:System")
    reader = _Reader(root, path)
    reader.system(system, "", 0)
    spec = reader.spec(system.get("name") or path.stem)
    experiment = ssd.find("ssd:DefaultExperiment", NS)
    if experiment is not None and experiment.get("startTime") is not None:
        spec.start_time = reader.number(experiment, "startTime", SSD_NAME)
    if experiment is not None and experiment.get("stopTime") is not None:
        spec.stop_time = reader.number(experiment, "stopTime", SSD_NAME)
    return spec


@dataclass
class _Edge:
    start: str
    end: str
    transformation: Conversion | None
    where: str


@dataclass
class _Binding:
    """A value a parameter set gives ``name`` (a component variable or a connector, by its full
    name), bound at ``depth`` (0: the top-level system)."""

    depth: int
    name: str
    value: Any
    unit: Unit | None
    where: str


class _Reader:
    """The nested systems of one SSD, read into one flat system (see the module docstring)."""

    def __init__(self, root: Path, where: Path):
        self.root, self.where = root, where
        self.components: dict[str, Any] = {}
        self.connectors: dict[str, str] = {}  # a system's connector, by its full name -> its kind
        self.edges: list[_Edge] = []
        self.bindings: list[_Binding] = []
        self.connector_values: dict[str, Any] = {}

    # -- reading ---------------------------------------------------------------------------------

    def error(self, element: Any, message: str, file: str = SSD_NAME) -> DataError:
        """A `DataError` naming the file, ``element`` (its tag, name and line) and ``message``."""
        tag = etree.QName(element).localname if isinstance(element.tag, str) else "element"
        name = f" {element.get('name')!r}" if element.get("name") is not None else ""
        return DataError(f"{self.where}: {file}, line {element.sourceline}: {tag}{name}: {message}")

    def known(self, element: Any, file: str = SSD_NAME) -> Any:
        """``element``, checked to carry only the attributes the standard gives it (`_ATTRIBUTES`)."""
        allowed = _ATTRIBUTES[etree.QName(element).localname]
        for attribute in element.attrib:
            if not attribute.startswith("{") and attribute not in (*allowed, "id", "description"):
                raise self.error(element, f"unknown attribute {attribute!r}{_close(attribute, allowed)} "
                                          f"(the standard gives it {', '.join(allowed)}, id and description)", file)
        return element

    def document(self, reference: Any, root: str) -> tuple[str, Any]:
        """The file ``reference`` names in its ``source`` (an .ssv or .ssm), whose root element must be ``root``."""
        source = reference.get("source")
        file = self.root / source
        if not file.is_file():
            raise FMUNotFoundError(f"{self.where}: {SSD_NAME}, line {reference.sourceline}: "
                                   f"{etree.QName(reference).localname}: its source {source!r} is not in the SSP "
                                   f"(resolved to {file})")
        return source, _parse(file, source, self.where, root)

    def required(self, element: Any, attribute: str, file: str = SSD_NAME) -> str:
        value = element.get(attribute)
        if not value:
            raise self.error(element, f"has no {attribute!r}", file)
        return value

    def number(self, element: Any, attribute: str, file: str, default: float | None = None) -> float:
        text = element.get(attribute)
        if text is None and default is not None:
            return default
        try:
            return float(text)
        except (TypeError, ValueError):
            raise self.error(element, f"{attribute}={text!r} is not a number", file) from None

    def transformation(self, element: Any, file: str = SSD_NAME) -> Conversion | None:
        linear = element.find("ssc:LinearTransformation", NS)
        if linear is None:
            return None
        return Conversion(self.number(linear, "factor", file, 1.0), self.number(linear, "offset", file, 0.0))

    def system(self, element: Any, prefix: str, depth: int) -> None:
        """Read system ``element``, whose components are named ``prefix`` + name."""
        for connector in map(self.known, element.iterfind("ssd:Connectors/ssd:Connector", NS)):
            kind = connector.get("kind")
            if kind not in CONNECTOR_KINDS:
                raise self.error(connector, f"kind {kind!r} is none of {', '.join(CONNECTOR_KINDS)}")
            self.connectors[prefix + self.required(connector, "name")] = kind
        elements: dict[str, str] = {}
        for child in element.iterfind("ssd:Elements/*", NS):
            if not isinstance(child.tag, str):
                continue  # a comment
            tag, name = etree.QName(child).localname, self.required(child, "name")
            if tag in _ATTRIBUTES:
                self.known(child)
            if name in elements:
                raise self.error(child, f"a second element of that name in system {element.get('name')!r}")
            elements[name] = tag
            if tag == "System":
                self.system(child, f"{prefix}{name}.", depth + 1)
            elif tag == "Component":
                self.component(child, prefix + name, depth + 1)
            else:
                raise self.error(child, "not supported (only components and systems are)")
        self.bind(element, prefix, depth)
        for connection in map(self.known, element.iterfind("ssd:Connections/ssd:Connection", NS)):
            (start, start_gives), (end, end_gives) = (self.end(connection, side, prefix, elements)
                                                      for side in ("start", "end"))
            where = f"{SSD_NAME}, line {connection.sourceline}"
            if (start_gives is False or end_gives is True) and start_gives is not True and end_gives is not False:
                # written end to start, as OMSimulator may write it: the connectors' kinds say which way it flows
                logger.debug("%s: %s: %s -> %s flows the other way", self.where, where, start, end)
                start, end = end, start
            self.edges.append(_Edge(start, end, self.transformation(connection), where))

    def component(self, element: Any, name: str, depth: int) -> None:
        source = self.required(element, "source")
        implementation = element.get("implementation")
        if implementation not in _IMPLEMENTATIONS:
            raise self.error(element, f"unknown implementation {implementation!r}; one of "
                                      f"{', '.join(k for k in _IMPLEMENTATIONS if k)}")
        mode = _IMPLEMENTATIONS[implementation]
        location = str(self.root / source)
        self.components[name] = {"fmu": location, "mode": mode} if mode else location
        self.bind(element, f"{name}.", depth)

    def end(self, connection: Any, side: str, prefix: str, elements: dict[str, str]) -> tuple[str, bool | None]:
        """The full name of a connection's ``side`` end (a component's variable or a system's
        connector) and whether the value comes from there (True) or goes there (False), where the
        kind of a system's connector says it (None: a component's variable, an inout connector)."""
        element, connector = connection.get(f"{side}Element"), self.required(connection, f"{side}Connector")
        system = f" {prefix[:-1]!r}" if prefix else ""
        if not element:
            name = prefix + connector
            if name not in self.connectors:
                own = [c[len(prefix):] for c in self.connectors if c.startswith(prefix) and "." not in c[len(prefix):]]
                raise self.error(connection, f"{side}Connector {connector!r} is no connector of the system{system}"
                                             f"{_close(connector, own)}")
            return name, _gives(self.connectors[name], inside=True)
        if element not in elements:
            raise self.error(connection, f"{side}Element {element!r} is no element of the system{system}"
                                         f"{_close(element, elements)}")
        name = f"{prefix}{element}.{connector}"
        if elements[element] != "System":
            return name, None
        if name not in self.connectors:
            raise self.error(connection, f"{side}Connector {connector!r} is no connector of the system "
                                         f"{prefix + element!r}")
        return name, _gives(self.connectors[name], inside=False)

    def bind(self, element: Any, scope: str, depth: int) -> None:
        """Record the values of ``element``'s bindings, named ``scope`` + prefix + name, mappings applied."""
        for binding in map(self.known, element.iterfind("ssd:ParameterBindings/ssd:ParameterBinding", NS)):
            prefix = binding.get("prefix") or ""
            sets = [self.document(binding, "ssv:ParameterSet")] if binding.get("source") else []
            sets += [(SSD_NAME, inline) for inline in binding.iterfind("ssd:ParameterValues/ssv:ParameterSet", NS)]
            mapping = self.mapping(binding)
            for file, parameter_set in sets:
                defined = {self.required(unit, "name", file): self.unit(unit, file)
                           for unit in parameter_set.iterfind("ssv:Units/ssc:Unit", NS)}
                for parameter in parameter_set.iterfind("ssv:Parameters/ssv:Parameter", NS):
                    self.known(parameter, file)
                    name, value = self.required(parameter, "name", file), self.value(parameter, file)
                    real = parameter.find("ssv:Real", NS)
                    unit = None
                    if real is not None and real.get("unit"):
                        unit = defined.get(real.get("unit")) or Unit(real.get("unit"), None)
                    for target, transformation in mapping.get(name, [(name, None)]):
                        mapped = value if transformation is None else \
                            transformation.scale * value + transformation.shift
                        self.bindings.append(_Binding(depth, scope + prefix + target, mapped,
                                                      unit if transformation is None else None,
                                                      f"{file}, line {parameter.sourceline}"))

    def mapping(self, binding: Any) -> dict[str, list[tuple[str, Conversion | None]]]:
        """A binding's parameter mapping: each source name -> every target it sets."""
        mapping: dict[str, list[tuple[str, Conversion | None]]] = {}
        for reference in map(self.known, binding.iterfind("ssd:ParameterMapping", NS)):
            if reference.get("source"):
                file, document = self.document(reference, "ssm:ParameterMapping")
            else:
                file, document = SSD_NAME, reference.find("ssm:ParameterMapping", NS)
                if document is None:
                    raise self.error(reference, "has neither a source nor an inline ssm:ParameterMapping")
            for entry in document.iterfind("ssm:MappingEntry", NS):
                self.known(entry, file)
                target = self.required(entry, "target", file)
                if entry.get("source") == "":
                    # a template's row (OMSimulator exports every parameter so, to be filled in): maps nothing
                    logger.debug("%s: %s, line %s: %s is mapped from no source", self.where, file,
                                 entry.sourceline, target)
                    continue
                source = self.required(entry, "source", file)
                mapping.setdefault(source, []).append((target, self.transformation(entry, file)))
        return mapping

    def value(self, parameter: Any, file: str) -> Any:
        """A parameter's value from its ``ssv:Real`` / ``Integer`` / ``Boolean`` / ``String`` element."""
        for kind, parse in (("Real", float), ("Integer", int), ("Boolean", _boolean), ("String", str)):
            element = parameter.find(f"ssv:{kind}", NS)
            if element is not None:
                try:
                    return parse(element.get("value"))
                except (TypeError, ValueError):
                    raise self.error(parameter, f"{element.get('value')!r} is not a {kind}", file) from None
        raise self.error(parameter, "has no Real, Integer, Boolean or String value", file)

    def unit(self, element: Any, file: str) -> Unit:
        """An ``ssc:Unit`` with its ``ssc:BaseUnit``, as an FMU's unit definition."""
        base = element.find("ssc:BaseUnit", NS)
        attributes = {} if base is None else base.attrib
        try:
            return Unit(element.get("name"), tuple(int(attributes.get(b, 0)) for b in BASE_UNITS),
                        float(attributes.get("factor", 1.0)), float(attributes.get("offset", 0.0)))
        except ValueError as error:
            raise self.error(base, f"not a unit definition: {error}", file) from None

    # -- flattening ------------------------------------------------------------------------------

    @cached_property
    def feeding(self) -> dict[str, _Edge]:
        """The connection into each system connector; a `DataError` for a connector fed twice."""
        feeding: dict[str, _Edge] = {}
        for edge in self.edges:
            if edge.end in self.connectors and edge.end in feeding:
                raise DataError(f"{self.where}: {edge.where}: the connector {edge.end!r} is already fed by "
                                f"{feeding[edge.end].start!r} ({feeding[edge.end].where}): a connector has one source")
            feeding[edge.end] = edge
        return feeding

    def source(self, name: str) -> tuple[str, Conversion | None]:
        """What feeds ``name`` in the end, through systems' connectors: a component's variable, a
        top-level connector, or a connector nothing feeds; with the transformations composed."""
        feeding = self.feeding
        seen, transformation = {name}, None
        while name in self.connectors and name in feeding:
            edge = feeding[name]
            transformation = _compose(edge.transformation, transformation)
            name = edge.start
            if name in seen:
                raise DataError(f"{self.where}: {edge.where}: the connectors {', '.join(sorted(seen))} feed each other")
            seen.add(name)
        return name, transformation

    def targets(self, name: str, seen: frozenset[str] = frozenset(),
                through: bool = False) -> list[tuple[str, Conversion | None]]:
        """The component variables connector ``name`` feeds, through systems' connectors (and,
        ``through``, those connectors too)."""
        found = []
        for edge in self.edges:
            if edge.start != name or edge.end in seen:
                continue
            if edge.end in self.connectors:
                found += [(edge.end, edge.transformation)] if through else []
                found += [(target, _compose(edge.transformation, transformation))
                          for target, transformation in self.targets(edge.end, seen | {name}, through)]
            else:
                found.append((edge.end, edge.transformation))
        return found

    def spec(self, name: str) -> SystemSpec:
        connectors = {c: SystemConnector(c, kind) for c, kind in self.connectors.items() if "." not in c}
        connections = []
        for edge in self.edges:
            if edge.end in self.connectors:
                continue
            start, transformation = self.source(edge.start)
            transformation = _compose(transformation, edge.transformation)
            if start in connectors:
                connectors[start].targets.append((edge.end, transformation))
            elif start in self.connectors:
                logger.debug("%s: %s: nothing feeds %s: %s stays unconnected", self.where, edge.where, start, edge.end)
            else:
                connections.append(ConnectionSpec(start, edge.end, transformation, either_way=True))
        for connector in connectors.values():
            source = self.source(connector.name)
            if source[0] != connector.name and source[0] not in self.connectors:
                connector.source = source
        notes: list[str] = []
        parameters, units = self.parameters(connectors, notes)
        return SystemSpec(name, self.components, connections, parameters, parameter_units=units, connectors=connectors,
                          notes=notes, connector_values=self.connector_values)

    @cached_property
    def prefixes(self) -> tuple[str, ...]:
        """``component.`` of every component: how a variable's full name starts."""
        return tuple(f"{name}." for name in self.components)

    def parameters(self, connectors: dict[str, SystemConnector],
                   notes: list[str]) -> tuple[dict[str, Any], dict[str, Unit]]:
        """Every binding's value by the component variable it sets (see the module docstring for
        which wins), and every connector's value into `connector_values`."""
        values: dict[str, Any] = {}
        units: dict[str, Unit] = {}
        elsewhere: dict[str, list[str]] = {}  # a set's file -> its parameters that name no element of the system
        # a value through a connection from a system's connector holds whatever is bound to the
        # variable itself: those bindings go last; within each kind, the higher level's, then the later, win
        for binding in sorted(self.bindings, key=lambda b: (b.name in self.connectors, -b.depth)):
            if binding.name not in self.connectors and not any(map(binding.name.startswith, self.prefixes)):
                elsewhere.setdefault(binding.where.split(", line ")[0], []).append(binding.name)
                continue
            if binding.name not in self.connectors:
                values[binding.name] = binding.value
                _set_unit(units, binding.name, binding.unit)
                continue
            if binding.name in connectors:
                connectors[binding.name].value = binding.value
            self.connector_values[binding.name] = binding.value
            targets = self.targets(binding.name, through=True)
            if all(target in self.connectors for target, _ in targets):
                note = f"parameter {binding.name!r} ({binding.where}) feeds no component: it has no effect"
                logger.warning("%s: %s", self.where, note)
                notes.append(note)
            for target, transformation in targets:
                value = binding.value if transformation is None else \
                    transformation.scale * binding.value + transformation.shift
                if target in self.connectors:
                    self.connector_values[target] = value
                else:
                    values[target] = value
                    _set_unit(units, target, binding.unit if transformation is None else None)
        for file, names in elsewhere.items():
            # a set written for more than this system (a product database's export, as embrace's): the rest is not ours
            note = (f"{len(names)} parameter{'s' if len(names) > 1 else ''} of {file} name no component or connector "
                    f"of the system ({', '.join(map(repr, names[:3]))}{', ...' if len(names) > 3 else ''}): "
                    f"{'they have' if len(names) > 1 else 'it has'} no effect")
            logger.warning("%s: %s", self.where, note)
            notes.append(note)
        return values, units


def _set_unit(units: dict[str, Unit], name: str, unit: Unit | None) -> None:
    if unit is None:
        units.pop(name, None)
    else:
        units[name] = unit


def _gives(kind: str, inside: bool) -> bool | None:
    """Whether a system's connector of ``kind`` is where a connection's value comes from, seen from
    ``inside`` its system or from outside it (None: either way, an inout or local connector)."""
    if kind in _INWARD:
        return inside
    if kind in _OUTWARD:
        return not inside
    return None


def _compose(first: Conversion | None, then: Conversion | None) -> Conversion | None:
    """``then`` applied after ``first`` (None: no transformation, the units convert)."""
    if first is None or then is None:
        return then if first is None else first
    return Conversion(then.scale * first.scale, then.scale * first.shift + then.shift)


def _close(name: str, names: Any) -> str:
    close = difflib.get_close_matches(name, list(names), n=3, cutoff=0.6)
    return f". Did you mean {', '.join(repr(c) for c in close)}?" if close else ""


def _boolean(text: str) -> bool:
    if text not in ("true", "false", "1", "0"):
        raise ValueError(text)
    return text in ("true", "1")


def _parse(file: Path, name: str, where: Path, root: str) -> Any:
    """The root element of ``file`` (``name`` in the SSP ``where``), which must be ``root`` (``prefix:Name``)."""
    if not file.is_file():
        raise FMUNotFoundError(f"{where}: {name} not found (resolved to {file})")
    try:
        element = etree.parse(str(file)).getroot()
    except etree.XMLSyntaxError as error:
        raise DataError(f"{where}: {name} is not well-formed XML: {error}") from None
    prefix, local = root.split(":")
    if element.tag != f"{{{NS[prefix]}}}{local}":
        raise DataError(f"{where}: {name}: its root element is {element.tag!r}, not {root} ({NS[prefix]})")
    return element

