"""``modelicagym info``: what a new user needs to know to wrap an unknown FMU.

Prints the FMI version, interface types, platforms, capabilities, the inputs, outputs and
parameters with their types, units, ranges and start values, the default experiment, and a
ready-to-paste `FMUEnv` config that works as pasted (`suggest` chooses it):

* actions: the inputs; without inputs, the tunable parameters (FMI lets a master change them
  between steps);
* observations: the outputs; without outputs, the continuous states, else the local variables;
* parameters at their start values, except FMI 3.0 structural parameters (settable only in
  configuration mode: they stay at their start values unless the user adds them);
* finite ``action_bounds`` for a float action that declares no min or max, inferred from the model
  description and marked as inferred in a comment, so random exploration stays near the model's
  range (an ambient pressure starting at 101325 Pa is not sampled around 0).

An FMU that cannot be an environment (nothing to act on, nothing to observe, neither co-simulation
nor model exchange) gets one line saying why instead of a config.
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from modelicagym.fmu import FMUDescription, open_fmu
from modelicagym.fmu.errors import FMUValidationError, InvalidFMUError
from modelicagym.fmu.variables import Variable

_MODE_NAMES = {"cs": "co-simulation", "me": "model exchange"}
_NOT_IN_SPACES = ("binary", "clock", "string")  # no action or observation space for these
#: at most this many local variables are suggested as observations (exports have thousands)
MAX_LOCALS = 16
#: units that say nothing about a variable's range
_NEUTRAL_UNITS = ("", "1")


@dataclass(frozen=True)
class InferredBounds:
    """Bounds ``info`` chose for an action without declared ones, and where they come from."""

    low: float
    high: float
    reason: str


@dataclass
class Suggestion:
    """The config ``info`` suggests, or the one line saying why there is none.

    ``notes`` say which variables were chosen and why, where the choice is not the obvious one;
    ``inferred`` holds the action bounds that the FMU does not declare.
    """

    config: dict[str, Any] | None
    refusal: str | None = None
    notes: list[str] = field(default_factory=list)
    inferred: dict[str, InferredBounds] = field(default_factory=dict)


def _usable(variables: Iterable[Variable]) -> list[Variable]:
    return [v for v in variables if v.kind not in _NOT_IN_SPACES]


def _names(variables: Iterable[Variable]) -> str:
    return ", ".join(v.name for v in variables)


def _actions(d: FMUDescription) -> tuple[list[Variable], str | None]:
    """The variables to act on, and a note when they are not the inputs."""
    inputs = _usable(d.inputs)
    if inputs:
        return inputs, None
    tunable = _usable(v for v in d.parameters if v.is_tunable_parameter)
    if tunable:
        return tunable, (f"no inputs: the actions are its tunable parameters ({_names(tunable)}), which FMI lets "
                         "a master change between steps")
    return [], None


def _observations(d: FMUDescription) -> tuple[list[Variable], str | None]:
    """The variables to observe, and a note when they are not the outputs."""
    outputs = _usable(d.outputs)
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


def infer_bounds(v: Variable, d: FMUDescription) -> InferredBounds:
    """Finite bounds for float variable ``v``, which lacks a declared min or max: its declared
    bound, then the declared range of related variables, then its start +-50% (or +-nominal, or
    +-1 around 0); the start always inside."""
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
    if low is None or high is None:
        if start:
            half, why = abs(start) / 2, f"its start {start:g} (+-50%)"
        elif v.nominal:
            half, why = abs(v.nominal), f"its nominal {v.nominal:g}"
        else:
            half, why = 1.0, "+-1 (it declares no start or nominal to scale by)"
        center = start or 0.0
        if low is None:
            low = min(center - half, high - half) if high is not None else center - half
        if high is None:
            high = max(center + half, low + half)
        reasons.append(why)
    if start is not None:
        low, high = min(low, start), max(high, start)
    return InferredBounds(float(low), float(high), "; ".join(reasons))


def suggest(description: FMUDescription, validate: bool = True) -> Suggestion:
    """The `FMUEnv` config ``info`` prints for ``description``, or why there is none.

    ``validate=False`` (the FMU was read without schema validation) goes into the config, so that
    it works as pasted.
    """
    d = description
    if not d.modes:
        scheduled = " (it offers scheduled execution only)" if getattr(d.raw, "scheduledExecution", None) else ""
        return Suggestion(None, f"{d.name} supports neither co-simulation nor model exchange{scheduled}: "
                                "modelicagym cannot run it, so there is no config")
    actions, action_note = _actions(d)
    if not actions:
        return Suggestion(None, f"{d.name} has nothing to act on: no inputs and no tunable parameters, which is "
                                "what an FMUEnv's actions drive, so there is no config")
    observations, observation_note = _observations(d)
    if not observations:
        return Suggestion(None, f"{d.name} has nothing to observe: no outputs, no continuous states and no local "
                                "variables of a number type, so there is no config")
    notes = [note for note in (action_note, observation_note) if note]
    acted = {v.name for v in actions}
    structural = [v for v in d.parameters if v.causality == "structuralParameter"]
    if structural:
        notes.append(f"structural parameters ({_names(structural)}) stay at their start values: FMI lets them change "
                     "only in configuration mode, where the env sets them if you add them to 'parameters'")
    inferred = {v.name: infer_bounds(v, d) for v in actions if v.kind == "float" and (v.min is None or v.max is None)}
    step = d.default_experiment.step_size
    config: dict[str, Any] = {
        "fmu": str(d.path),
        "inputs": [v.name for v in actions],
        "outputs": [v.name for v in observations],
        "parameters": {
            v.name: v.start for v in d.parameters
            if v.start is not None and v.kind not in _NOT_IN_SPACES and v.causality != "structuralParameter"
            and v.name not in acted
        },
    }
    if inferred:
        config["action_bounds"] = {name: (b.low, b.high) for name, b in inferred.items()}
    config.update({"time_step": step if step else 0.1, "mode": d.default_mode(), "max_episode_steps": 500})
    if not validate:
        config["validate"] = False
    return Suggestion(config, None, notes, inferred)


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
            items = [f"{name!r}: ({low!r}, {high!r})" for name, (low, high) in value.items()]
            comments = [f"inferred from {suggestion.inferred[name].reason}: edit to the model's range"
                        for name in value]
            text = _collection(items, "{", "}", indent, comments)
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
        f"default experiment: start {experiment.start_time:g} s, stop {experiment.stop_time} s, "
        f"step {experiment.step_size} s, tolerance {experiment.tolerance}",
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
    if suggestion.inferred:
        lines.append(f"  - action bounds inferred for {', '.join(suggestion.inferred)} (no declared min or max): "
                     "see the comments in action_bounds")
    lines.append("")
    lines += ["    " + line if line else "" for line in format_config(suggestion)]
    return "\n".join(lines)


def describe_fmu(path: str | os.PathLike[str], validate: bool = True) -> str:
    """``modelicagym info PATH``: the report, or an `InvalidFMUError` in one line when the model
    description fails validation (naming the rules, the variables and how to go on)."""
    try:
        description = open_fmu(path, validate=validate)
    except FMUValidationError as error:
        if not error.skippable:
            raise InvalidFMUError(f"{error.summary} (--no-validate would not help: fmpy cannot read it without "
                                  "validation either)") from error
        raise InvalidFMUError(f"{error.summary}; to go on anyway: modelicagym info {path} --no-validate (the config it "
                          "prints then has validate=False)") from error
    return format_info(description, validate)
