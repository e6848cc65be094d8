"""The connection graph of a system, checked once: every end exists and is an output feeding an
input, types agree, units convert, each input has at most one source; and the order the
Gauss-Seidel master steps the components in. A cycle of connections is fine: each step uses the
values the master has, new or one step old (`modelicagym.system.loops` for cycles of direct
feedthrough).
"""

from __future__ import annotations

import difflib
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, replace

from modelicagym.errors import ConfigError
from modelicagym.fmu.errors import VariableError
from modelicagym.system.components import Component
from modelicagym.system.units import Conversion, conversion, declared_unit


@dataclass(frozen=True)
class ConnectionSpec:
    """A connection as written: ``"component.variable"`` at each end, and an explicit linear
    transformation (SSP's ``LinearTransformation``: then no unit conversion) or None."""

    source: str
    target: str
    transformation: Conversion | None = None
    #: whether the variables' causalities say which way it flows (an SSP's connection, which tools
    #: write either way round): an input at the start and an output at the end then flows from the output
    either_way: bool = False

    @property
    def label(self) -> str:
        return f"{self.source} -> {self.target}"


@dataclass(frozen=True)
class Link:
    """A checked connection: ``target.target_variable = scale * source.source_variable + shift``."""

    source: str
    source_variable: str
    target: str
    target_variable: str
    conversion: Conversion

    @property
    def label(self) -> str:
        return f"{self.source}.{self.source_variable} -> {self.target}.{self.target_variable}"


def split_name(name: str, components: Mapping[str, Component], where: str) -> tuple[Component, str]:
    """``"component.variable"`` as its component and the variable's name inside it; a `ConfigError`
    naming ``where``, with close matches, for an unknown component."""
    if not isinstance(name, str) or "." not in name:
        raise ConfigError(f"{where}: {name!r} is not 'component.variable'; components: {', '.join(components)}")
    head, local = component_of(name, components)
    component = components.get(head)
    if component is None:
        close = difflib.get_close_matches(head, list(components), n=3, cutoff=0.6)
        hint = f" Did you mean {', '.join(repr(c) for c in close)}?" if close else ""
        raise ConfigError(f"{where}: no component named {head!r}.{hint} Components: {', '.join(components)}")
    return component, local


def component_of(name: str, components: Collection[str]) -> tuple[str, str]:
    """``"component.variable"`` split after the longest name of ``components`` it starts with (the
    components of a nested SSP system are named ``system.component``, and a variable's own name may
    hold dots); after the first dot where none matches."""
    head = max((c for c in components if name.startswith(c + ".")), key=len, default=None)
    if head is None:
        head, _, local = name.partition(".")
        return head, local
    return head, name[len(head) + 1:]


def check_connections(components: Mapping[str, Component], connections: Sequence[ConnectionSpec],
                      system: str) -> list[Link]:
    """The connections checked (see the module docstring), each failure one line naming it."""
    links: list[Link] = []
    fed: dict[tuple[str, str], str] = {}
    for connection in connections:
        where = f"{system}: connection {connection.label}"
        source, source_name = split_name(connection.source, components, where)
        target, target_name = split_name(connection.target, components, where)
        try:
            out = source.variable(source_name, "output", source.outputs)
            into = target.variable(target_name, "input", target.inputs)
        except VariableError as error:
            raise VariableError(f"{where}: {error}") from None
        if connection.either_way and out.is_input and into.is_output:
            connection = replace(connection, source=connection.target, target=connection.source)
            source, source_name, out, target, target_name, into = target, target_name, into, source, source_name, out
        if not out.is_output:
            raise ConfigError(f"{where}: {connection.source!r} is not an output (causality {out.causality!r}); "
                              f"outputs of {source.name}: {', '.join(v.name for v in source.outputs) or 'none'}")
        if not into.is_input:
            raise ConfigError(f"{where}: {connection.target!r} is not an input (causality {into.causality!r}); "
                              f"inputs of {target.name}: {', '.join(v.name for v in target.inputs) or 'none'}")
        if not _kinds_connect(out.kind, into.kind) or out.shape != into.shape:
            raise ConfigError(f"{where}: type mismatch: a {out.fmi_type}{list(out.shape) if out.shape else ''} "
                              f"output into a {into.fmi_type}{list(into.shape) if into.shape else ''} input")
        key = (target.name, target_name)
        if key in fed:
            raise ConfigError(f"{where}: {connection.target!r} is already fed by {fed[key]!r}: an input has one source")
        fed[key] = connection.source
        if connection.transformation is not None:
            convert = connection.transformation
        else:
            convert = conversion(declared_unit(out.unit, source.units), declared_unit(into.unit, target.units), where)
        if not convert.identity and out.kind != "float":
            raise ConfigError(f"{where}: a unit conversion on a {out.fmi_type} value; only floats convert")
        links.append(Link(source.name, source_name, target.name, target_name, convert))
    return links


#: the kinds of value a connection may join besides equal ones: SSP 1.0 (section 5.3.2.3) lets an
#: Integer feed an Enumeration and back (the enumeration's value is its integer)
_CONNECTING_KINDS = {("integer", "enumeration"), ("enumeration", "integer")}


def _kinds_connect(source: str, target: str) -> bool:
    return source == target or (source, target) in _CONNECTING_KINDS


def stepping_order(components: Sequence[str], links: Sequence[Link], breaks: Sequence[Link] = ()) -> list[str]:
    """The order Gauss-Seidel steps the components in: each after the components that feed it
    (sources first, a table before what it drives), a connection of ``breaks`` aside. Where a cycle
    leaves none ready, the component declared first among those that wait for nothing outside
    their cycle goes first (its connections from the cycle are then read from the previous step)."""
    feeds = {name: {link.source for link in links if link.target == name and link.source != name
                    and link not in breaks} for name in components}
    order: list[str] = []
    while len(order) < len(components):
        left = [name for name in components if name not in order]
        ready = [name for name in left if feeds[name] <= set(order)]
        order.append(ready[0] if ready else _first_of_cycle(left, feeds))
    return order


def _first_of_cycle(left: list[str], feeds: dict[str, set[str]]) -> str:
    """The first of ``left`` whose cycle waits for nothing else of ``left``: every component of
    ``left`` upstream of it is also downstream of it."""
    upstream = {}
    for name in left:
        seen, todo = set(), [name]
        while todo:
            for source in feeds[todo.pop()] & set(left):
                if source not in seen:
                    seen.add(source)
                    todo.append(source)
        upstream[name] = seen
    return next(name for name in left if all(name in upstream[source] for source in upstream[name]))
