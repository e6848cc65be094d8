"""The connection graph of a system, checked once: every end exists and is an output feeding an
input, types agree, units convert, each input has at most one source, no algebraic loop; and the
order the Gauss-Seidel master steps the components in.

An algebraic loop is a cycle of connections in which each output depends directly on the input
before it (the FMUs' ModelStructure dependencies): its values at a communication point would need
an iteration fixed-step co-simulation does not do, so it is refused, naming the connections. A
cycle through an output without direct feedthrough (a state) is fine: each step uses the values
the master has, new or one step old.
"""

from __future__ import annotations

import difflib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

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
    head, local = name.split(".", 1)
    component = components.get(head)
    if component is None:
        close = difflib.get_close_matches(head, list(components), n=3, cutoff=0.6)
        hint = f" Did you mean {', '.join(repr(c) for c in close)}?" if close else ""
        raise ConfigError(f"{where}: no component named {head!r}.{hint} Components: {', '.join(components)}")
    return component, local


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
        if not out.is_output:
            raise ConfigError(f"{where}: {connection.source!r} is not an output (causality {out.causality!r}); "
                              f"outputs of {source.name}: {', '.join(v.name for v in source.outputs) or 'none'}")
        if not into.is_input:
            raise ConfigError(f"{where}: {connection.target!r} is not an input (causality {into.causality!r}); "
                              f"inputs of {target.name}: {', '.join(v.name for v in target.inputs) or 'none'}")
        if out.kind != into.kind or out.shape != into.shape:
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
    loop = algebraic_loop(components, links)
    if loop:
        raise ConfigError(f"{system}: algebraic loop through {' and '.join(link.label for link in loop)}: each "
                          "output there depends directly on the input before it, which fixed-step co-simulation "
                          "cannot solve; remove one of these connections or feed it from an output without direct "
                          "feedthrough")
    return links


def algebraic_loop(components: Mapping[str, Component], links: Sequence[Link]) -> list[Link]:
    """The links of a cycle of direct dependencies (see the module docstring), or an empty list."""
    # from each link, the links its target's component starts from outputs that depend on that input
    after: dict[Link, list[Link]] = {}
    for link in links:
        component = components[link.target]
        after[link] = [nxt for nxt in links if nxt.source == link.target
                       and link.target_variable in component.depends_on(nxt.source_variable)]
    state: dict[Link, int] = {}  # 1: on the path, 2: done
    path: list[Link] = []

    def visit(link: Link) -> list[Link]:
        state[link] = 1
        path.append(link)
        for nxt in after[link]:
            if state.get(nxt) == 1:
                return path[path.index(nxt):]
            if nxt not in state:
                found = visit(nxt)
                if found:
                    return found
        path.pop()
        state[link] = 2
        return []

    for link in links:
        if link not in state:
            found = visit(link)
            if found:
                return found
    return []


def stepping_order(components: Sequence[str], links: Sequence[Link]) -> list[str]:
    """The order Gauss-Seidel steps the components in: each after the components that feed it
    (sources first, a table before what it drives); within a cycle (through a state, so no
    algebraic loop), the component declared first goes first."""
    feeds = {name: {link.source for link in links if link.target == name and link.source != name}
             for name in components}
    order: list[str] = []
    while len(order) < len(components):
        left = [name for name in components if name not in order]
        ready = [name for name in left if feeds[name] <= set(order)]
        order.append(ready[0] if ready else left[0])
    return order
