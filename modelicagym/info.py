"""``modelicagym info``: what a new user needs to know to wrap an unknown FMU.

Prints the FMI version, interface types, platforms, capabilities, the inputs, outputs and
parameters with their types, units, ranges and start values, the default experiment, and a
ready-to-paste `FMUEnv` config (`suggest` chooses it) that works as pasted, once any range
the FMU gives no clue of is filled in:

* actions: the inputs; without inputs, the tunable parameters (FMI lets a master change them
  between steps). With `MANY_INPUTS` inputs or more, those without a unit (commands, most likely)
  are the actions and those with one (a pressure, a temperature: the conditions the model runs in,
  most likely) go into ``fixed_inputs``, held at their start values; the report says which went where;
* a system's (`SystemDescription`): the actions are its own input connectors, else its components'
  inputs nothing feeds, else (a test bench whose stimuli drive everything) the levels of the signals
  its sources feed (`_source_levels`); the observations are its own output connectors where it has some;
* observations: the outputs; without outputs, the continuous states, else the local variables;
* parameters at their start values, except FMI 3.0 structural parameters (settable only in
  configuration mode: they stay at their start values unless the user adds them);
* finite ``action_bounds`` for a float action that declares no min or max, inferred from the model
  description (`infer_bounds`: related declared ranges, then what its unit says, then its start)
  and marked as inferred in a comment, so random exploration stays near the model's range (an
  ambient pressure starting at 101325 Pa is not sampled around 0, a temperature in K never below
  0). Where nothing in the FMU says anything about the range, the bounds are ``None``: a
  placeholder `FMUEnv` refuses until the user gives them. A range made up from nothing would run,
  and train a policy on inputs the plant never sees without a word; a refusal costs one edit, and
  ``modelicagym try`` still shows the FMU with an assumed range, saying so.

An FMU that cannot be an environment (nothing to act on, nothing to observe, neither co-simulation
nor model exchange) gets one line saying why instead of a config.
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from dataclasses import dataclass, field, replace
from typing import Any

from modelicagym.fmu import FMUDescription, open_fmu
from modelicagym.fmu.errors import FMUValidationError, InvalidFMUError
from modelicagym.fmu.variables import Variable
from modelicagym.system import SystemDescription, is_system, open_system

_MODE_NAMES = {"cs": "co-simulation", "me": "model exchange"}
_NOT_IN_SPACES = ("binary", "clock", "string")  # no action or observation space for these
#: at most this many local variables are suggested as observations (exports have thousands)
MAX_LOCALS = 16
#: units that say nothing about a variable's range
_NEUTRAL_UNITS = ("", "1")
#: from this many inputs on, the suggestion acts on the commands and holds the others (`_split_inputs`)
MANY_INPUTS = 4


@dataclass(frozen=True)
class InferredBounds:
    """Bounds ``info`` chose for an action without declared ones, and where they come from.

    ``low`` and ``high`` are None when nothing in the FMU says anything about the range (no
    declared bound, no related range, no unit it knows, no start or nominal to scale by): the
    config then holds a placeholder that `FMUEnv` refuses until it is edited, not a blind guess.
    ``center`` is the value the range is built around (a start, or a unit's typical value when the
    start cannot be one): the value ``info`` holds the input at when it goes into ``fixed_inputs``.
    """

    low: float | None
    high: float | None
    reason: str
    center: float | None = None

    @property
    def placeholder(self) -> bool:
        """Whether these are no bounds at all, for the user to fill in."""
        return self.low is None


@dataclass(frozen=True)
class _Quantity:
    """What a unit says about a variable's range: a physical floor, a typical value (for a start
    that cannot be one), and how far from its start an input plausibly goes."""

    name: str
    floor: float
    typical: float
    spread: float  # half the range: kelvin for a temperature (additive), a fraction of the start otherwise
    additive: bool


#: units whose values have a floor and a typical size (absolute temperatures, absolute pressures);
#: a quantity naming a difference (``TemperatureDifference``, ``PressureDifference``) is not one of them
_QUANTITIES = {
    "K": _Quantity("temperature", 0.0, 293.15, 20.0, additive=True),
    "degC": _Quantity("temperature", -273.15, 20.0, 20.0, additive=True),
    "Pa": _Quantity("pressure", 0.0, 101325.0, 0.5, additive=False),
    "kPa": _Quantity("pressure", 0.0, 101.325, 0.5, additive=False),
    "bar": _Quantity("pressure", 0.0, 1.01325, 0.5, additive=False),
}


@dataclass
class Suggestion:
    """The config ``info`` suggests, or the one line saying why there is none.

    ``notes`` say which variables were chosen and why, where the choice is not the obvious one;
    ``inferred`` holds the action bounds that the FMU does not declare; ``held`` says, per fixed
    input, where its value comes from.
    """

    config: dict[str, Any] | None
    refusal: str | None = None
    notes: list[str] = field(default_factory=list)
    inferred: dict[str, InferredBounds] = field(default_factory=dict)
    held: dict[str, str] = field(default_factory=dict)

    @property
    def placeholders(self) -> list[str]:
        """The actions whose bounds are left for the user to fill in (None in ``action_bounds``)."""
        return [name for name, bounds in self.inferred.items() if bounds.placeholder]


def _usable(variables: Iterable[Variable]) -> list[Variable]:
    return [v for v in variables if v.kind not in _NOT_IN_SPACES]


def _names(variables: Iterable[Variable]) -> str:
    return ", ".join(v.name for v in variables)


def _source_levels(d: SystemDescription) -> list[Variable]:
    """What drives a system without inputs: its sources, components with no input of their own whose
    outputs feed the others (a test bench's stimuli: a voltage step, a constant load). For each
    signal a source feeds, its level: the source's tunable float parameter in that signal's unit
    with the largest magnitude the SSP gives it (a step's height, not its offset or start time)."""
    levels: dict[str, Variable] = {}
    for link in d.links:
        source = d.components[link.source]
        if source.description is None or _usable(source.inputs):
            continue
        unit = source.variables[link.source_variable].unit or ""
        candidates = [d.variables[f"{source.name}.{v.name}"] for v in source.description.parameters
                      if v.is_tunable_parameter and v.kind == "float" and (v.unit or "") == unit]
        candidates = [v for v in candidates if _scalar(v.start) is not None]
        if candidates:
            level = max(candidates, key=lambda v: abs(v.start))
            levels.setdefault(level.name, level)
    return list(levels.values())


def _actions(d: FMUDescription | SystemDescription) -> tuple[list[Variable], str | None]:
    """The variables to act on, and a note when they are not the inputs. A system's are its inputs:
    the SSP's own input connectors where it declares some, else its components' inputs nothing
    feeds; never all its components' tunable parameters (a system has dozens; name those you mean).
    A system with no input at all acts on the levels of the signals its sources feed (`_source_levels`)."""
    inputs = _usable(d.inputs)
    if isinstance(d, SystemDescription):
        own = [v for v in inputs if v.name in d.connectors]
        if own or inputs:
            return own or inputs, None
        levels = _source_levels(d)
        if not levels:
            return [], None
        sources = sorted({d.split(v.name)[0] for v in levels})
        return levels, (f"no inputs: {', '.join(sources)} (no inputs of {'its' if len(sources) == 1 else 'their'} "
                        f"own) {'feeds' if len(sources) == 1 else 'feed'} the others, so the actions are the levels "
                        f"of the signals: {_names(levels)} (a tunable parameter in the unit of the signal it sets, "
                        "the largest in magnitude); name other tunable parameters in 'inputs' to act on them instead")
    if inputs:
        return inputs, None
    tunable = _usable(v for v in d.parameters if v.is_tunable_parameter)
    if tunable:
        return tunable, (f"no inputs: the actions are its tunable parameters ({_names(tunable)}), which FMI lets "
                         "a master change between steps")
    return [], None


def _observations(d: FMUDescription | SystemDescription) -> tuple[list[Variable], str | None]:
    """The variables to observe, and a note when they are not the outputs. A system's are its own
    output connectors where the SSP declares some (what its author chose to show), else every
    component's outputs."""
    outputs = _usable(d.outputs)
    if isinstance(d, SystemDescription):
        own = [v for v in outputs if v.name in d.connectors]
        if own and len(own) < len(outputs):
            return own, (f"observing the system's own outputs ({_names(own)}); its components' outputs "
                         f"({len(outputs) - len(own)} more) can be added to 'outputs'")
    if outputs:
        return outputs, None
    states = _usable(d.state_variables)
    if states:
        return states, (f"no outputs: observing its continuous states ({_names(states)}), as its model structure "
                        "declares them")
    local = _usable(v for v in d.variables.values() if v.causality == "local")
    if local:
        chosen = local[:MAX_LOCALS]
        which = "its local variables"
        if len(local) > len(chosen):
            which = f"the first {len(chosen)} of its {len(local)} local variables"
        return chosen, f"no outputs and no continuous states declared: observing {which} ({_names(chosen)})"
    return [], None


def _split_inputs(actions: list[Variable]) -> tuple[list[Variable], list[Variable], str | None]:
    """With `MANY_INPUTS` inputs or more: the inputs to act on (those without a unit: commands,
    most likely), the ones to hold (with a unit: the conditions the model runs in, most likely),
    and the note that says so; all acted on (with a note) when the units do not tell them apart."""
    if len(actions) < MANY_INPUTS or not actions[0].is_input:
        return actions, [], None
    commands = [v for v in actions if (v.unit or "") in _NEUTRAL_UNITS]
    held = [v for v in actions if (v.unit or "") not in _NEUTRAL_UNITS]
    if not commands or not held:
        return actions, [], (f"{len(actions)} inputs, all in the action (their units do not tell commands from "
                             "conditions): an agent learns faster on the few it controls; move the others to "
                             "'fixed_inputs' ({name: value}, or a function of the env's generator drawn every episode)")
    return commands, held, (
        f"{len(actions)} inputs: acting on {_names(commands)} (no unit: commands, most likely); holding "
        f"{_names(held)} in 'fixed_inputs' (with units: conditions it runs in, most likely). Move a name between "
        "'inputs' and 'fixed_inputs' to choose; a fixed input may be a function of the env's generator, drawn "
        "every episode")


def as_declared(v: Variable, d: FMUDescription | SystemDescription) -> tuple[Variable, FMUDescription]:
    """``v`` as the FMU declaring it names it, and that FMU's description (a system's variable is
    its component's)."""
    if isinstance(d, SystemDescription):
        component, local = d.locate(d.feeds(v.name)[0][0] if v.name in d.connectors else v.name)
        return replace(local, start=v.start), component.description  # the start the SSP gives it
    return v, d


def _held_value(v: Variable, d: FMUDescription) -> tuple[Any, str]:
    """The value to hold input ``v`` at, and the comment that says where it comes from (and the
    range to give it in ``action_bounds`` should it become an action)."""
    if v.kind != "float" or (v.min is not None and v.max is not None):
        return v.start, "its start"
    bounds = infer_bounds(v, d)
    if bounds.placeholder or bounds.center is None:
        return v.start, f"its start; {bounds.reason}"
    source = "its start"
    quantity = _quantity(v, d)
    if bounds.center != _scalar(v.start) and quantity is not None:
        source = f"a typical {quantity.name} (its start {v.start:g} {v.unit} cannot be one)"
    return bounds.center, f"{source}; as an action: ({bounds.low!r}, {bounds.high!r})"


def _scalar(value: Any) -> float | None:
    return float(value) if isinstance(value, (int, float)) and not isinstance(value, bool) else None


def _related_range(v: Variable, d: FMUDescription) -> tuple[float | None, float | None, str] | None:
    """The declared range of the variables related to ``v`` (same declared type, else quantity,
    else unit) that contains ``v``'s start, with the relation; None if none declares one."""
    raw = {variable.name: variable for variable in d.raw.modelVariables}
    mine = raw[v.name]
    declared = getattr(mine.declaredType, "name", None)
    quantity = mine.quantity or getattr(mine.declaredType, "quantity", None)
    relations = (
        ("declared type", declared, lambda r: getattr(r.declaredType, "name", None)),
        ("quantity", quantity, lambda r: r.quantity or getattr(r.declaredType, "quantity", None)),
        ("unit", v.unit if v.unit not in _NEUTRAL_UNITS else None, lambda r: d.variables[r.name].unit),
    )
    start = _scalar(v.start)
    for relation, value, of in relations:
        if value is None:
            continue
        related = [d.variables[r.name] for r in d.raw.modelVariables if r.name != v.name and of(r) == value]
        lows = [r.min for r in related if r.min is not None]
        highs = [r.max for r in related if r.max is not None]
        if not lows and not highs:
            continue
        low, high = (min(lows) if lows else None), (max(highs) if highs else None)
        if start is not None and ((low is not None and start < low) or (high is not None and start > high)):
            continue  # a range the variable's own start lies outside says nothing about it
        names = _names(r for r in related if r.min is not None or r.max is not None)
        return low, high, f"the declared range of {names} (same {relation} {value})"
    return None


def _quantity(v: Variable, d: FMUDescription) -> _Quantity | None:
    """What ``v``'s unit says about its range (`_QUANTITIES`), unless its quantity is a difference."""
    raw = next(r for r in d.raw.modelVariables if r.name == v.name)
    quantity = raw.quantity or getattr(raw.declaredType, "quantity", None) or ""
    return None if "difference" in quantity.lower() else _QUANTITIES.get(v.unit or "")


def _unit_range(v: Variable, q: _Quantity, start: float | None) -> tuple[float, float, float, str]:
    """``(low, high, center, reason)`` for ``v`` from what its unit says: around its start when the
    start can be a value of it (above the floor), else around the unit's typical value."""
    unit = v.unit
    if start is not None and start > q.floor:
        center, around = start, f"its start {start:g} {unit}"
    else:
        said = "no start" if start is None else f"its start {start:g} {unit} cannot be a {q.name}"
        center, around = q.typical, f"{q.typical:g} {unit} ({said}: a typical {q.name} assumed)"
    half = q.spread if q.additive else abs(center) * q.spread
    spread = f"+-{q.spread:g} {unit}" if q.additive else f"+-{q.spread:.0%}"
    low = max(center - half, q.floor)
    floor = f", not below {q.floor:g} {unit}" if low == q.floor else ""
    return low, center + half, center, f"a {q.name} in {unit} around {around}, {spread}{floor}"


def infer_bounds(v: Variable, d: FMUDescription) -> InferredBounds:
    """Finite bounds for float variable ``v``, which lacks a declared min or max: its declared
    bound, then the declared range of related variables, then what its unit says (a temperature in
    K around its start +-20 K, a pressure around its start +-50%, never below 0), then its start
    +-50% (or +-nominal); the start always inside when it can be a value. With none of these, a
    placeholder (``low`` and ``high`` None): a guess would be blind."""
    low, high = v.min, v.max
    reasons = []
    if low is not None or high is not None:
        reasons.append(f"its declared {'min' if low is not None else 'max'}")
    related = _related_range(v, d)
    if related is not None:
        filled = (related[0] if low is None else low), (related[1] if high is None else high)
        if filled != (low, high) and (None in filled or filled[0] <= filled[1]):
            low, high = filled
            reasons.append(related[2])
    start = _scalar(v.start)
    center = start
    quantity = _quantity(v, d)
    if low is None or high is None:
        if quantity is not None:
            unit_low, unit_high, center, why = _unit_range(v, quantity, start)
            if low is None:
                low = unit_low if high is None else min(unit_low, high)
            if high is None:
                high = max(unit_high, low)
            reasons.append(why)
        elif start or v.nominal:
            half, why = (abs(start) / 2, f"its start {start:g} (+-50%)") if start else (
                abs(v.nominal), f"its nominal {v.nominal:g}")
            center = start or 0.0
            if low is None:
                low = min(center - half, high - half) if high is not None else center - half
            if high is None:
                high = max(center + half, low + half)
            reasons.append(why)
        else:
            unit = "no unit" if v.unit in (None, *_NEUTRAL_UNITS) else f"unit {v.unit}"
            said = "; ".join([*reasons, f"start {'none' if v.start is None else repr(v.start)}, no nominal, {unit}"])
            return InferredBounds(None, None, f"nothing in the FMU says its range ({said})", center)
    if quantity is not None and start is not None and start <= quantity.floor:
        start = None  # 0 K or 0 Pa: an exporter's default, not a value the model runs at
    if start is not None:
        low, high = min(low, start), max(high, start)
    return InferredBounds(float(low), float(high), "; ".join(reasons), center)


def suggest(description: FMUDescription, validate: bool = True) -> Suggestion:
    """The `FMUEnv` config ``info`` prints for ``description``, or why there is none.

    ``validate=False`` (the FMU was read without schema validation) goes into the config, so that
    it works as pasted.
    """
    d = description
    system = isinstance(d, SystemDescription)
    if system:
        unrunnable = [c for c in d.components.values() if c.description is not None and not c.description.modes]
        if unrunnable:
            return suggest(unrunnable[0].description, validate)
    elif not d.modes:
        scheduled = " (it offers scheduled execution only)" if getattr(d.raw, "scheduledExecution", None) else ""
        return Suggestion(None, f"{d.name} supports neither co-simulation nor model exchange{scheduled}: "
                                "modelicagym cannot run it, so there is no config")
    actions, action_note = _actions(d)
    if not actions and system:
        return Suggestion(None, f"{d.name} has no inputs (no input connectors of its own, no component input that "
                                "nothing feeds), which is what an FMUEnv's actions drive: name the tunable "
                                "parameters to act on in 'inputs'")
    if not actions:
        return Suggestion(None, f"{d.name} has nothing to act on: no inputs and no tunable parameters, which is "
                                "what an FMUEnv's actions drive, so there is no config")
    observations, observation_note = _observations(d)
    if not observations:
        return Suggestion(None, f"{d.name} has nothing to observe: no outputs, no continuous states and no local "
                                "variables of a number type, so there is no config")
    notes = [note for note in (action_note, observation_note) if note]
    structural = [v for v in d.parameters if v.causality == "structuralParameter"]
    if structural:
        notes.append(f"structural parameters ({_names(structural)}) stay at their start values: FMI lets them change "
                     "only in configuration mode, where the env sets them if you add them to 'parameters'")
    actions, held, split_note = _split_inputs(actions)
    if split_note:
        notes.insert(0, split_note)
    acted = {v.name for v in actions}
    if system:  # an action that is a system's input sets what it feeds
        acted |= {target for name in list(acted) for target, _ in d.feeds(name)}
    inferred = {v.name: infer_bounds(*as_declared(v, d)) for v in actions
                if v.kind == "float" and (v.min is None or v.max is None)}
    fixed = {v.name: _held_value(*as_declared(v, d)) for v in held}
    step = d.default_experiment.step_size
    parameters = {v.name: v.start for v in d.parameters
                  if v.start is not None and v.kind not in _NOT_IN_SPACES and v.causality != "structuralParameter"}
    if system:  # the SSP's parameter sets, as the system applies them
        parameters.update(d.parameter_values)
        notes.append(f"a system of {len(d.components)} components, stepped by Gauss-Seidel in the order "
                     f"{', '.join(d.order)} ('master': 'jacobi' for Jacobi); its parameters hold the SSP's values")
    config: dict[str, Any] = {
        "fmu": str(d.path),
        "inputs": [v.name for v in actions],
        "outputs": [v.name for v in observations],
        "parameters": {name: value for name, value in parameters.items() if name not in acted},
    }
    if fixed:
        config["fixed_inputs"] = {name: value for name, (value, _) in fixed.items()}
    if inferred:
        config["action_bounds"] = {name: None if b.placeholder else (b.low, b.high) for name, b in inferred.items()}
    config.update({"time_step": step if step else 0.1, **({} if system else {"mode": d.default_mode()}),
                   "max_episode_steps": 500})
    if not validate:
        config["validate"] = False
    return Suggestion(config, None, notes, inferred, {name: comment for name, (_, comment) in fixed.items()})


# -- the report --------------------------------------------------------------------------------------

#: the printed config keeps a list or dict on one line up to this width
_WIDTH = 96


def _collection(items: list[str], opening: str, closing: str, indent: str, comments: list[str] | None = None) -> str:
    """``items`` (already repr'd) on one line when they fit, else wrapped at `_WIDTH` (one item
    a line when they carry comments)."""
    one_line = opening + ", ".join(items) + closing
    if comments is None and len(indent) + len(one_line) <= _WIDTH:
        return one_line
    inner = indent + "    "
    if comments is not None:
        rows = [f"{inner}{item},  # {comment}" for item, comment in zip(items, comments)]
    else:
        rows = [inner]
        for item in items:
            if len(rows[-1]) + len(item) + 2 > _WIDTH and rows[-1] != inner:
                rows.append(inner)
            rows[-1] += ("" if rows[-1] == inner else " ") + item + ","
    return "\n".join([opening, *rows, indent + closing])


def format_config(suggestion: Suggestion) -> list[str]:
    """The config as lines of Python that make the env (``config = {...}``, ``FMUEnv(**config)``),
    the inferred action bounds commented as such."""
    assert suggestion.config is not None
    indent = "    "
    lines = ["from modelicagym import FMUEnv", "", "config = {"]
    for key, value in suggestion.config.items():
        if key == "action_bounds":
            items = [f"{name!r}: {None if bounds is None else tuple(bounds)!r}" for name, bounds in value.items()]
            comments = [f"TO FILL IN with (low, high): {suggestion.inferred[name].reason}" if bounds is None
                        else f"inferred from {suggestion.inferred[name].reason}: edit to the model's range"
                        for name, bounds in value.items()]
            text = _collection(items, "{", "}", indent, comments)
        elif key == "fixed_inputs":
            items = [f"{name!r}: {held!r}" for name, held in value.items()]
            text = _collection(items, "{", "}", indent, [suggestion.held[name] for name in value])
        elif isinstance(value, dict):
            text = _collection([f"{k!r}: {v!r}" for k, v in value.items()], "{", "}", indent)
        elif isinstance(value, list):
            text = _collection([repr(v) for v in value], "[", "]", indent)
        else:
            text = repr(value)
        lines += f"{indent}{key!r}: {text},".split("\n")
    lines += ["}", "env = FMUEnv(**config)"]
    return lines


def _range(v: Variable) -> str:
    if v.kind == "enumeration" and v.enumeration_items:
        return ", ".join(f"{name}={value}" for name, value in v.enumeration_items)
    if v.min is None and v.max is None:
        return ""
    low = "-inf" if v.min is None else f"{v.min:g}"
    high = "inf" if v.max is None else f"{v.max:g}"
    return f"[{low}, {high}]"


def _table(variables: list[Variable]) -> list[str]:
    if not variables:
        return ["    (none)"]
    rows = [("name", "type", "shape", "unit", "range", "start", "variability", "description")]
    for v in variables:
        variability = v.variability + (", structural" if v.causality == "structuralParameter" else "")
        rows.append((
            v.name, v.fmi_type, "x".join(map(str, v.shape)) or "-", v.unit or "", _range(v),
            "" if v.start is None else str(v.start), variability, v.description or "",
        ))
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    return ["    " + "  ".join(cell.ljust(w) for cell, w in zip(row, widths)).rstrip() for row in rows]


def saved_states_line(description: FMUDescription) -> str:
    """One line: whether an env can save and load this FMU's state as a value (``get_state``), per mode."""
    refusals = {mode: description.serialize_refusal(mode) for mode in description.modes}
    if all(r is None for r in refusals.values()):
        return "saved states (env.unwrapped.get_state() / set_state): yes"
    if all(r is not None for r in refusals.values()):
        return "saved states: no (" + next(iter(refusals.values())).split(": ", 1)[1] + ")"
    can = ", ".join(_MODE_NAMES[m] for m, r in refusals.items() if r is None)
    return f"saved states (env.unwrapped.get_state() / set_state): in {can} only"


def format_info(description: FMUDescription, validate: bool = True) -> str:
    """The report ``modelicagym info`` prints: what the FMU declares, then the config to start
    from (or the one line saying why there is none)."""
    d = description
    experiment = d.default_experiment
    modes = ", ".join(f"{_MODE_NAMES[m]} ({m!r})" for m in d.modes) or "none"
    capabilities = []
    for mode in d.modes:
        capabilities.append(
            f"  {_MODE_NAMES[mode]}: state snapshots {'yes' if d.can_snapshot(mode) else 'no'}, "
            f"one instance per process {'yes' if d.once_per_process(mode) else 'no'}, "
            f"model identifier {d.interface(mode).modelIdentifier}"
        )
    capabilities.append("  " + saved_states_line(d))
    if any(d.once_per_process(mode) for mode in d.modes):
        capabilities.append(
            "  one instance per process: each further instance alive in a process loads a private copy of "
            "the binary (its own globals), so a pool packs these envs like any other; "
            "\"instances_per_process\": \"one\" keeps one env per process instead")

    this_platform = "yes" if d.platform_dir in d.platforms else "NO"
    lines = [
        f"{d.name}: model {d.model_name!r}, FMI {d.raw.fmiVersion}, generated by {d.raw.generationTool or 'unknown tool'}",
        f"interface types: {modes}",
        f"platforms: {', '.join(d.platforms) or 'none'} (this machine needs {d.platform_dir}: {this_platform})"
        + ("; C sources included" if d.has_sources else ""),
        "capabilities:",
        *capabilities,
        f"continuous states: {d.number_of_states}, event indicators: {d.number_of_event_indicators}",
        (f"default experiment: start {experiment.start_time:g} s, stop {experiment.stop_time} s, "
        f"step {experiment.step_size} s, tolerance {experiment.tolerance}"),
        "",
        "inputs:",
        *_table(d.inputs),
        "",
        "outputs:",
        *_table(d.outputs),
        "",
        "parameters:",
        *_table(d.parameters),
        "",
    ]
    suggestion = suggest(d, validate)
    if suggestion.config is None:
        return "\n".join([*lines, f"no config: {suggestion.refusal}"])
    lines.append("a config to start from (Python):")
    lines += [f"  - {note}" for note in suggestion.notes]
    guessed = [name for name in suggestion.inferred if name not in suggestion.placeholders]
    if guessed:
        lines.append(f"  - action bounds inferred for {', '.join(guessed)} (no declared min or max): "
                     "see the comments in action_bounds")
    if suggestion.placeholders:
        names = suggestion.placeholders
        their = "its" if len(names) == 1 else "their"
        lines.append(f"  - action bounds to fill in for {', '.join(names)}: nothing in the FMU says {their} range, so "
                     f"action_bounds holds None there, which the env refuses until you give (low, high): a guess would "
                     "be explored silently (`modelicagym try` assumes (-1, 1) for a first look)")
    step, steps = suggestion.config["time_step"], suggestion.config["max_episode_steps"]
    lines.append(f"  - time_step {step:g} s (the default experiment's, or 0.1 s), {steps} steps an episode "
                 f"({step * steps:g} s): `modelicagym try {d.path.name} --step INPUT` shows how fast the outputs "
                 "respond, to choose both")
    lines.append("")
    lines += ["    " + line if line else "" for line in format_config(suggestion)]
    return "\n".join(lines)


def _component_line(component: Any) -> str:
    if component.table is not None:
        table = component.table
        return (f"  {component.name}: table {component.source.name}, {table.times.size} rows from {table.times[0]:g} "
                f"to {table.times[-1]:g} s, columns {', '.join(table.columns)} (linear, ends held)")
    d = component.description
    mode = component.mode or d.default_mode()
    saved = saved_states_line(d).replace(" (env.unwrapped.get_state() / set_state)", "")
    return f"  {component.name}: {d.name}, model {d.model_name!r}, FMI {d.raw.fmiVersion}, {_MODE_NAMES[mode]}; {saved}"


def _loop_lines(system: SystemDescription) -> list[str]:
    """The system's loops of direct feedthrough, one line each: where Gauss-Seidel reads it from the
    previous step (and that Jacobi reads all of it so)."""
    if not system.loops:
        return ["loops of direct feedthrough: none"]
    return [("loops of direct feedthrough (each read with a one-step delay; 'master': 'jacobi' reads every "
            "connection of a loop from the previous step):"), *[f"  {line}" for line in system.loop_lines("gauss-seidel")]]


def format_system_info(system: SystemDescription, validate: bool = True) -> str:
    """The report ``modelicagym info`` prints for a system: its components, connections (with
    their unit conversions), stepping order, loops, variables, and the config to start from."""
    lines = [f"{system.name}: system {system.model_name!r} of {len(system.components)} components", "components:",
             *[_component_line(c) for c in system.components.values()], "connections:"]
    for link in system.links:
        conversion = link.conversion
        converted = "" if conversion.identity else f"  (converted: x {conversion.scale:.12g} + {conversion.shift:.12g})"
        lines.append(f"  {link.label}{converted}")
    if not system.links:
        lines.append("    (none)")
    lines.append(f"stepping order (Gauss-Seidel): {', '.join(system.order)}")
    lines += _loop_lines(system)
    lines += ["", "inputs (the system's own, and components' inputs nothing feeds):", *_table(system.inputs), "",
              "outputs:", *_table(system.outputs), "", "parameters:", *_table(system.parameters), ""]
    if system.notes:
        lines += ["read without effect:", *[f"  {note}" for note in system.notes], ""]
    suggestion = suggest(system, validate)
    if suggestion.config is None:
        return "\n".join([*lines, f"no config: {suggestion.refusal}"])
    lines.append("a config to start from (Python):")
    lines += [f"  - {note}" for note in suggestion.notes]
    if suggestion.placeholders:
        lines.append(f"  - action bounds to fill in for {', '.join(suggestion.placeholders)}: see action_bounds")
    lines.append("")
    lines += ["    " + line if line else "" for line in format_config(suggestion)]
    return "\n".join(lines)


def describe_fmu(path: str | os.PathLike[str], validate: bool = True) -> str:
    """``modelicagym info PATH``: the report (for an FMU, or an SSP system), or an
    `InvalidFMUError` in one line when a model description fails validation (naming the rules, the
    variables and how to go on)."""
    if is_system(path):
        return format_system_info(open_system(path, validate=validate), validate)
    try:
        description = open_fmu(path, validate=validate)
    except FMUValidationError as error:
        if not error.skippable:
            raise InvalidFMUError(f"{error.summary} (--no-validate would not help: fmpy cannot read it without "
                                  "validation either)") from error
        raise InvalidFMUError(f"{error.summary}; to go on anyway: modelicagym info {path} --no-validate (the config it "
                          "prints then has validate=False)") from error
    return format_info(description, validate)
