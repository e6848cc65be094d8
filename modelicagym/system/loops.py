"""A system's loops of direct feedthrough, where each is read from the previous communication step,
and the guard that stops one growing without bound.

A loop (an algebraic loop) is a cycle of connections in which each output depends directly on the
input before it (the FMUs' ModelStructure dependencies; an output that declares none is taken to
depend on every input, as FMI says). Fixed-step co-simulation runs one with a one-step delay, as
co-simulation engines do:

* ``"jacobi"``: every connection is read from the previous communication step, so every connection
  of a loop is: the loop is a one-step delay by construction;
* ``"gauss-seidel"``: the components step in `stepping_order`; a connection whose source steps
  after its target (or is its target) is read from the previous step. Where a loop leaves no
  component ready, the component declared first among those nothing outside the loop still waits
  for steps first (its connections from the loop are delayed), unless the config's ``loop_breaks``
  names the connections to delay.

A loop read from the previous step is a discrete recurrence: with a loop gain above one it grows
without bound. `LoopGuard` checks the value each delayed connection of a loop carries after every
communication step and stops with a `LoopDivergedError` when one is not finite or its magnitude
exceeds `LOOP_BOUND`.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from modelicagym.errors import ConfigError, LoopDivergedError
from modelicagym.system.components import Component
from modelicagym.system.graph import Link

#: the largest magnitude a loop's delayed value may reach: beyond it (or not finite) the loop diverged
LOOP_BOUND = 1e100


@dataclass(frozen=True)
class Loop:
    """One loop: its connections (in the system's order), the connections Gauss-Seidel reads from
    the previous step, whether ``loop_breaks`` chose them, and the outputs in it that declare no
    dependencies (FMI then takes them to depend on every input)."""

    links: tuple[Link, ...]
    broken: tuple[Link, ...]
    named: bool
    undeclared: tuple[str, ...]

    @property
    def label(self) -> str:
        return ", ".join(link.label for link in self.links)

    def delayed(self, master: str) -> tuple[Link, ...]:
        """The connections of the loop read from the previous communication step under ``master``."""
        return self.links if master == "jacobi" else self.broken

    def describe(self, master: str) -> str:
        """One line: the loop, which connections carry the delay under ``master``, and why."""
        if master == "jacobi":
            how = "jacobi reads every connection of it from the previous step"
        else:
            why = "named in loop_breaks" if self.named else f"{self.broken[0].target} steps first in the loop"
            how = f"gauss-seidel reads {', '.join(link.label for link in self.broken)} from the previous step ({why})"
        line = f"loop {self.label}: {how}"
        if self.undeclared:
            one = len(self.undeclared) == 1
            line += (f"; {', '.join(self.undeclared)} declare{'s' if one else ''} no dependencies, so FMI takes "
                     f"{'it' if one else 'them'} to depend on every input, which closes this loop")
        return line


def _feedthrough(components: Mapping[str, Component], links: Sequence[Link]) -> dict[Link, list[Link]]:
    """From each link, the links that start from an output of its target that depends directly on its input."""
    return {link: [nxt for nxt in links if nxt.source == link.target
                   and link.target_variable in components[link.target].depends_on(nxt.source_variable)]
            for link in links}


def _strongly_connected(nodes: Sequence, after: Mapping) -> list[list]:
    """The strongly connected groups of ``nodes`` under ``after`` (Tarjan's algorithm, iterative)."""
    index: dict = {}
    low: dict = {}
    stack: list = []
    on_stack: set = set()
    groups: list[list] = []
    for root in nodes:
        if root in index:
            continue
        work = [(root, iter(after[root]))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is None:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    group = []
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        group.append(member)
                        if member == node:
                            break
                    groups.append(group)
            elif child not in index:
                index[child] = low[child] = len(index)
                stack.append(child)
                on_stack.add(child)
                work.append((child, iter(after[child])))
            elif child in on_stack:
                low[node] = min(low[node], index[child])
    return groups


def find_loops(components: Mapping[str, Component], links: Sequence[Link], order: Sequence[str],
               breaks: Sequence[Link]) -> list[Loop]:
    """The loops of direct feedthrough among ``links`` (module docstring), each with the connections
    the Gauss-Seidel ``order`` reads from the previous step; ``breaks``: those ``loop_breaks`` named."""
    after = _feedthrough(components, links)
    position = {name: k for k, name in enumerate(order)}
    loops = []
    for group in _strongly_connected(list(links), after):
        if len(group) == 1 and group[0] not in after[group[0]]:
            continue
        members = tuple(link for link in links if link in group)
        broken = tuple(link for link in members if position[link.source] >= position[link.target])
        undeclared = tuple(dict.fromkeys(f"{link.source}.{link.source_variable}" for link in members
                                         if not components[link.source].declares_dependencies(link.source_variable)))
        loops.append(Loop(members, broken, any(link in breaks for link in broken), undeclared))
    return loops


def named_breaks(names: Sequence[object], links: Sequence[Link], system: str) -> list[Link]:
    """The connections ``loop_breaks`` names (``"a.y -> b.u"`` or ``("a.y", "b.u")``), each a
    connection of the system on a cycle; a `ConfigError` with close matches otherwise."""
    if isinstance(names, (str, bytes)) or not isinstance(names, Sequence):
        raise ConfigError(f"{system}: loop_breaks is a list of connections ('a.y -> b.u'), got {names!r}")
    by_label = {link.label: link for link in links}
    chosen = []
    for name in names:
        pair = [part.strip() for part in name.split("->")] if isinstance(name, str) else name
        if isinstance(pair, (str, bytes)) or not isinstance(pair, Sequence) or len(pair) != 2:
            raise ConfigError(f"{system}: loop_breaks: {name!r} is not a connection 'component.output -> "
                              "component.input'")
        label = f"{pair[0]} -> {pair[1]}"
        link = by_label.get(label)
        if link is None:
            close = difflib.get_close_matches(label, list(by_label), n=3, cutoff=0.6)
            hint = f" Did you mean {', '.join(repr(c) for c in close)}?" if close else ""
            raise ConfigError(f"{system}: loop_breaks: {label!r} is not a connection of the system.{hint} "
                              f"Connections: {', '.join(by_label) or 'none'}")
        if not _on_cycle(link, links):
            raise ConfigError(f"{system}: loop_breaks: {label} is on no loop (nothing leads from "
                              f"{link.target} back to {link.source}): there is nothing to break")
        chosen.append(link)
    return chosen


def _on_cycle(link: Link, links: Sequence[Link]) -> bool:
    """Whether connections lead from ``link``'s target back to its source."""
    reached, todo = {link.target}, [link.target]
    while todo:
        name = todo.pop()
        for nxt in links:
            if nxt.source == name and nxt.target not in reached:
                reached.add(nxt.target)
                todo.append(nxt.target)
    return link.source in reached


def check_breaks_hold(breaks: Sequence[Link], order: Sequence[str], system: str) -> None:
    """Refuse a named break the Gauss-Seidel ``order`` does not read from the previous step (its
    source steps first for another cycle's sake)."""
    position = {name: k for k, name in enumerate(order)}
    for link in breaks:
        if position[link.source] < position[link.target]:
            raise ConfigError(f"{system}: loop_breaks: {link.label} cannot be read from the previous step: "
                              f"{link.source} still steps before {link.target} (stepping order {', '.join(order)}) "
                              f"for another connection or loop; break the loop at a connection into {link.source} "
                              "instead, or name the others too")


class LoopGuard:
    """The check after every communication step (module docstring): ``values[k]`` is the array the
    ``k``-th guarded connection's source writes, ``links[k]`` that connection, ``loops[k]`` its loop."""

    def __init__(self, system: str, master: str, entries: Sequence[tuple[Loop, Link, object]]):
        self.system, self.master = system, master
        self.loops = [loop for loop, _, _ in entries]
        self.links = [link for _, link, _ in entries]
        self.values = [values for _, _, values in entries]

    def first_failure(self) -> int | None:
        """The index of the first guarded value beyond `LOOP_BOUND` or not finite, or None."""
        for k, values in enumerate(self.values):
            if not (abs(values) <= LOOP_BOUND).all():
                return k
        return None

    def error(self, k: int, time: float) -> LoopDivergedError:
        """The error for guarded connection ``k`` found diverged at ``time``."""
        loop, link, values = self.loops[k], self.links[k], self.values[k]
        value = next(v for v in values.ravel() if not abs(v) <= LOOP_BOUND)
        what = f"beyond {LOOP_BOUND:g}" if math.isfinite(value) else "not finite"
        change = ("or use master='gauss-seidel', which delays one connection of the loop instead of all"
                  if self.master == "jacobi" else "or break the loop at another connection (loop_breaks)")
        return LoopDivergedError(
            f"{self.system}: the loop {loop.label} diverged under {self.master}: {link.label} carried {value:g} "
            f"from the previous step at t = {time:g}, {what}. Read with a one-step delay, a loop grows without "
            "bound when its gain (the product of the gains around it) exceeds one: lower that gain, make the time "
            f"step smaller where the loop runs through dynamics, {change}")
