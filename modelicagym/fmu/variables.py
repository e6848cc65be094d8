"""Model variables as the runtime and the environment see them.

fmpy parses ``modelDescription.xml``; this module turns each of its variables into a small,
typed, FMI-version-neutral record: what kind of value it holds, its shape (FMI 3.0 arrays), its
bounds (inherited from a declared type where the variable leaves them out) and whether it can be
set before initialization, during initialization, or only as an input while running.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

FLOAT_TYPES = {"Real", "Float64", "Float32"}
INTEGER_TYPES = {"Integer", "Int8", "UInt8", "Int16", "UInt16", "Int32", "UInt32", "Int64", "UInt64"}

# Bounds of the FMI 3.0 integer types, used where a variable declares no min/max.
_INTEGER_LIMITS = {
    "Integer": (-(2**31), 2**31 - 1),
    **{f"Int{b}": (-(2 ** (b - 1)), 2 ** (b - 1) - 1) for b in (8, 16, 32, 64)},
    **{f"UInt{b}": (0, 2**b - 1) for b in (8, 16, 32, 64)},
}


@dataclass(frozen=True)
class Variable:
    """One model variable.

    ``kind`` is what the value means for an RL space: ``"float"``, ``"integer"``, ``"enumeration"``,
    ``"boolean"``, ``"string"``, ``"binary"`` or ``"clock"``; ``fmi_type`` is the type the FMI
    functions use (``"Real"``, ``"Float32"``, ``"Int16"``, ...).
    """

    name: str
    value_reference: int
    fmi_type: str
    kind: str
    causality: str
    variability: str
    initial: str | None = None
    shape: tuple[int, ...] = ()
    start: Any = None
    min: float | None = None
    max: float | None = None
    nominal: float | None = None
    unit: str | None = None
    display_unit: str | None = None
    description: str | None = None
    enumeration_items: tuple[tuple[str, int], ...] = field(default=(), repr=False)

    @property
    def size(self) -> int:
        """Number of scalar values (1 for a scalar, the product of the shape for an array)."""
        return math.prod(self.shape)

    @property
    def is_input(self) -> bool:
        return self.causality == "input"

    @property
    def is_tunable_parameter(self) -> bool:
        """A parameter a master may change between steps (FMI ``variability="tunable"``)."""
        return self.causality == "parameter" and self.variability == "tunable"

    @property
    def is_output(self) -> bool:
        return self.causality == "output"

    @property
    def is_parameter(self) -> bool:
        return self.causality in ("parameter", "structuralParameter")

    @property
    def settable_before_initialization(self) -> bool:
        """Whether ``fmiSet*`` is allowed between instantiation and initialization mode."""
        if self.variability == "constant":
            return False
        return self.causality == "input" or self.initial in ("exact", "approx")

    @property
    def settable_in_initialization(self) -> bool:
        """Whether ``fmiSet*`` is allowed in initialization mode (FMI 2.0 table 2 / FMI 3.0 table 18:
        inputs and variables with ``initial="exact"``; calculated parameters never)."""
        if self.variability == "constant":
            return False
        return self.causality == "input" or self.initial == "exact"

    @property
    def settable(self) -> bool:
        """Whether the variable can be given a value at all (parameter, start value or input)."""
        return self.settable_before_initialization or self.settable_in_initialization

    def bounds(self) -> tuple[float, float]:
        """Declared ``(min, max)``, falling back to the type's limits (or +-inf for floats)."""
        if self.kind == "boolean":
            return 0.0, 1.0
        if self.kind == "enumeration" and self.enumeration_items:
            values = [v for _, v in self.enumeration_items]
            low, high = min(values), max(values)
        elif self.kind == "integer":
            low, high = _INTEGER_LIMITS.get(self.fmi_type, (-(2**31), 2**31 - 1))
        else:
            low, high = -np.inf, np.inf
        return (low if self.min is None else self.min), (high if self.max is None else self.max)


def _first(*values: Any) -> Any:
    return next((v for v in values if v is not None), None)


def _to_float(value: Any) -> float | None:
    return None if value is None else float(value)


def _kind(fmi_type: str) -> str:
    if fmi_type in FLOAT_TYPES:
        return "float"
    if fmi_type in INTEGER_TYPES:
        return "integer"
    return fmi_type.lower()


def parse_start(kind: str, text: Any) -> Any:
    """A start value from its XML text (arrays are whitespace-separated) to Python values."""
    if text is None or kind in ("string", "binary", "clock"):
        return text
    parts = str(text).split()
    if kind == "boolean":
        values: list[Any] = [p.lower() in ("true", "1") for p in parts]
    elif kind == "float":
        values = [float(p) for p in parts]
    else:
        values = [int(float(p)) for p in parts]
    return values[0] if len(values) == 1 else values


def _fmi1_initial(causality: str, start: Any) -> str | None:
    """FMI 1.0 has no ``initial``: what FMI 2.0 would say. Parameters (FMI 1.0 variability
    "parameter", which fmpy reads as causality "parameter") and other variables with a start value
    may be set before ``fmiInitialize`` (exact / a guess); inputs need no ``initial``."""
    if causality == "input":
        return None
    if start is None:
        return "calculated"
    return "exact" if causality == "parameter" else "approx"


def from_fmpy(v: Any, fmi_version: int = 2) -> Variable:
    """Convert an fmpy ``ModelVariable`` (FMI 1.0, 2.0 or 3.0) into a `Variable`."""
    declared = v.declaredType
    kind = _kind(v.type)
    items: tuple[tuple[str, int], ...] = ()
    if kind == "enumeration" and declared is not None:
        items = tuple((item.name, int(item.value)) for item in declared.items)
    return Variable(
        name=v.name,
        value_reference=int(v.valueReference),
        fmi_type=v.type,
        kind=kind,
        causality=v.causality or "local",
        variability=v.variability or ("continuous" if kind == "float" else "discrete"),
        initial=_fmi1_initial(v.causality, v.start) if fmi_version == 1 and v.initial is None else v.initial,
        shape=tuple(int(n) for n in (v.shape or ())),
        start=parse_start(kind, v.start),
        min=_to_float(_first(v.min, getattr(declared, "min", None))),
        max=_to_float(_first(v.max, getattr(declared, "max", None))),
        nominal=_to_float(_first(v.nominal, getattr(declared, "nominal", None))),
        unit=_first(v.unit, getattr(declared, "unit", None)),
        display_unit=_first(v.displayUnit, getattr(declared, "displayUnit", None)),
        description=v.description,
        enumeration_items=items,
    )
