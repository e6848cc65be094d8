"""Unit conversion along a connection, by the units both ends declare.

An FMU's ``UnitDefinitions`` give each unit its SI base units (exponents of kg, m, s, A, K, mol,
cd, rad) and a ``factor`` and ``offset``: ``value_in_base = factor * value + offset`` (FMI 2.0
section 2.2.2, FMI 3.0 section 2.4.3; SSP's ``ssc:Unit`` is the same record). Two units convert
into each other when their exponents agree; degC -> K is factor 1, offset 273.15.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from modelicagym.errors import ConfigError

#: the SI base units of the FMI and SSP unit definitions, in their order
BASE_UNITS = ("kg", "m", "s", "A", "K", "mol", "cd", "rad")


@dataclass(frozen=True)
class Unit:
    """A unit as its definition gives it: base-unit exponents, factor and offset."""

    name: str
    exponents: tuple[int, ...] | None  # None: named, but without a definition
    factor: float = 1.0
    offset: float = 0.0

    def dimension(self) -> str:
        """The base units as text, e.g. ``kg.m2.s-2`` (``1`` for a dimensionless unit)."""
        if self.exponents is None:
            return "undefined"
        parts = [f"{base}{'' if e == 1 else e}" for base, e in zip(BASE_UNITS, self.exponents) if e]
        return ".".join(parts) or "1"


def unit_definitions(model_description: Any) -> dict[str, Unit]:
    """The units an fmpy model description defines with their base units, by name."""
    units = {}
    for unit in model_description.unitDefinitions or ():
        base = unit.baseUnit
        if base is None:
            continue
        units[unit.name] = Unit(unit.name, tuple(int(getattr(base, b, 0) or 0) for b in BASE_UNITS),
                                float(base.factor if base.factor is not None else 1.0),
                                float(base.offset if base.offset is not None else 0.0))
    return units


@dataclass(frozen=True)
class Conversion:
    """``target = scale * source + shift``; the identity when scale is 1 and shift 0."""

    scale: float = 1.0
    shift: float = 0.0

    @property
    def identity(self) -> bool:
        return self.scale == 1.0 and self.shift == 0.0


IDENTITY = Conversion()


def conversion(source: Unit | None, target: Unit | None, where: str) -> Conversion:
    """How a value in ``source`` becomes one in ``target``: the identity when either end declares no
    unit or both the same; a `ConfigError` naming ``where`` (the connection) when their base units
    differ, or when the names differ and one has no definition to convert by."""
    if source is None or target is None or source == target or source.name == target.name:
        return IDENTITY
    if source.exponents is None or target.exponents is None:
        undefined = source if source.exponents is None else target
        raise ConfigError(f"{where}: units {source.name!r} and {target.name!r} differ, and {undefined.name!r} has "
                          "no definition (UnitDefinitions) to convert by")
    if source.exponents != target.exponents:
        raise ConfigError(f"{where}: units do not match: {source.name!r} is {source.dimension()}, "
                          f"{target.name!r} is {target.dimension()}")
    # base = f_s * v + o_s = f_t * w + o_t
    return Conversion(source.factor / target.factor, (source.offset - target.offset) / target.factor)


def declared_unit(name: str | None, definitions: dict[str, Unit]) -> Unit | None:
    """The unit called ``name`` from ``definitions``; a unit named but not defined is kept by name
    only (it converts into a unit of the same name alone)."""
    if name is None:
        return None
    return definitions.get(name) or Unit(name, None)
