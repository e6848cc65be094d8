"""Tracking tasks written in a config: setpoints, and what the policy sees beyond the outputs.

Two config keys, no subclass:

* ``setpoints={output: signal}``: the value each output should follow. A signal is a number
  (constant), a callable ``f(np_random)`` drawn at every reset (a number, or a schedule), a
  schedule ``[(time, value), ...]`` (linear between its points; a step is two points at the same
  time, the later one counting from that time on; before the first point its value, after the
  last the last value), the path of a CSV table of ``time,value`` rows (a header line is
  allowed), or, in a JSON config, ``{"uniform": [low, high]}``. Times are the simulation's (as
  ``env.time``). `uniform` draws like a lambda and tells the observation space its range.
* ``observe=[entry, ...]``: what the observation holds after the outputs, in this order:
  ``"setpoint"`` (one value per setpoint), ``"error"`` (output minus setpoint),
  ``"error_integral"`` (the error integrated over the episode: the sum of ``error * time_step``
  over the steps so far, zero at the reset), ``"previous_action"`` (the action of the last step,
  zeros, or the nearest bound, at the reset), or the name of a held input (``fixed_inputs``). A
  ``"setpoint:NAME"`` (``error:``, ``error_integral:``) takes one setpoint only.

`Tracking` is one env's part of it: the episode's setpoint signals (drawn at its reset), the
previous action and the error's running sum. `FMUEnv` draws them at every reset, folds the step's
action and error in before each step (`Tracking.before_step`, on every step path, the pool's
included) and appends `Tracking.values` to the outputs; its saved states carry them.
"""

from __future__ import annotations

import csv
import difflib
import math
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces

from modelicagym.errors import ConfigError, ConfigTypeError, DataError

__all__ = ["OBSERVE_KINDS", "Schedule", "Tracking", "Uniform", "check_observe", "check_setpoints", "json_draws",
           "uniform"]

#: the entries of ``observe`` that are not a held input's name
OBSERVE_KINDS = ("setpoint", "error", "error_integral", "previous_action")


@dataclass(frozen=True)
class Uniform:
    """A value drawn uniformly in ``[low, high]`` at every reset, wherever a callable of the env's
    random generator is accepted (``parameters``, ``fixed_inputs``, ``setpoints``); unlike a
    lambda, it tells the observation space its range."""

    low: float
    high: float

    def __call__(self, rng: np.random.Generator) -> float:
        return float(rng.uniform(self.low, self.high))

    @property
    def bounds(self) -> tuple[float, float]:
        return self.low, self.high


def json_draws(values: Mapping[str, Any]) -> dict[str, Any]:
    """``values`` (``parameters`` or ``fixed_inputs``) with each ``{"uniform": [low, high]}`` (a JSON
    config's way to write a draw) made a `Uniform`."""
    return {name: uniform(*value["uniform"]) if isinstance(value, Mapping) and set(value) == {"uniform"} else value
            for name, value in values.items()}


def uniform(low: float, high: float) -> Uniform:
    """A draw in ``[low, high]`` at every reset, its range known to the observation space."""
    for value in (low, high):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ConfigError(f"uniform({low!r}, {high!r}) needs two finite numbers")
    if low > high:
        raise ConfigError(f"uniform({low!r}, {high!r}) has low > high")
    return Uniform(float(low), float(high))


class Schedule:
    """A reference signal over time: linear between its points ``(time, value)``, held before the
    first and after the last; two points at one time make a step (the later one counts from then)."""

    def __init__(self, points: Sequence[Sequence[float]], where: str = "schedule") -> None:
        try:
            table = np.array(points, dtype=np.float64)
        except (TypeError, ValueError) as error:
            raise ConfigError(f"{where} must be (time, value) pairs of numbers, got {points!r}") from error
        if table.ndim != 2 or table.shape[1] != 2 or len(table) == 0:
            raise ConfigError(f"{where} must be a non-empty list of (time, value) pairs, got {points!r}")
        if not np.all(np.isfinite(table)):
            raise ConfigError(f"{where} holds a NaN or an infinity: {points!r}")
        if np.any(np.diff(table[:, 0]) < 0):
            raise ConfigError(f"{where}'s times must not decrease, got {table[:, 0].tolist()}")
        self.times, self.values = table[:, 0].copy(), table[:, 1].copy()

    @classmethod
    def from_csv(cls, path: str | os.PathLike[str]) -> Schedule:
        """The schedule in a CSV file of ``time,value`` rows (a first line that is not numbers is a header)."""
        path = Path(path)
        if not path.is_file():
            raise ConfigError(f"setpoint table not found: {path} (resolved to {path.resolve()})")
        with path.open(newline="", encoding="utf-8") as file:
            rows = [row for row in csv.reader(file) if row and any(cell.strip() for cell in row)]
        if rows:
            try:
                [float(cell) for cell in rows[0]]
            except ValueError:
                rows = rows[1:]
        bad = next((k for k, row in enumerate(rows) if len(row) != 2), None)
        if bad is not None:
            raise DataError(f"{path}: every row is time,value; a row has {len(rows[bad])} cells: {rows[bad]!r}")
        try:
            points = [(float(t), float(v)) for t, v in rows]
        except ValueError as error:
            raise DataError(f"{path}: not a table of numbers ({error})") from error
        return cls(points, where=str(path))

    def at(self, time: float) -> float:
        """The value at ``time``."""
        times, values = self.times, self.values
        k = int(np.searchsorted(times, time, side="right")) - 1
        if k < 0:
            return float(values[0])
        if k >= len(times) - 1:
            return float(values[-1])
        t0, t1 = times[k], times[k + 1]
        return float(values[k] + (values[k + 1] - values[k]) * (time - t0) / (t1 - t0))

    @property
    def bounds(self) -> tuple[float, float]:
        return float(self.values.min()), float(self.values.max())

    def __eq__(self, other: object) -> bool:
        return (isinstance(other, Schedule) and np.array_equal(self.times, other.times)
                and np.array_equal(self.values, other.values))

    def __repr__(self) -> str:
        return f"Schedule({list(zip(self.times.tolist(), self.values.tolist()))})"


#: a setpoint as one episode has it: a number or a schedule
Signal = float | Schedule


def _signal(value: Any, where: str) -> Signal | Callable[..., Any]:
    """A setpoint as the config gives it, normalised: a number, a `Schedule`, or a callable drawn per episode."""
    if callable(value):
        return value
    if isinstance(value, bool):
        raise ConfigTypeError(f"{where} must be a number, a schedule or a callable, got {value!r}")
    if isinstance(value, (int, float, np.number)):
        if not math.isfinite(value):
            raise ConfigError(f"{where} must be finite, got {value!r}")
        return float(value)
    if isinstance(value, (str, os.PathLike)):
        return Schedule.from_csv(value)
    if isinstance(value, Mapping):
        if set(value) == {"uniform"}:
            low, high = value["uniform"]
            return uniform(low, high)
        if set(value) == {"schedule"}:
            return Schedule(value["schedule"], where)
        raise ConfigError(f"{where} as a dict is {{'uniform': [low, high]}} or {{'schedule': [[t, v], ...]}}, "
                          f"got {value!r}")
    if isinstance(value, Schedule):
        return value
    if isinstance(value, Sequence):
        return Schedule(value, where)
    raise ConfigTypeError(f"{where} must be a number, a schedule [(t, value), ...], a CSV path or a callable of "
                          f"the random generator, got {value!r} ({type(value).__name__})")


def check_setpoints(setpoints: Any) -> dict[str, Any]:
    """``setpoints`` as ``{output: number | Schedule | callable}``, each checked (names are checked
    against the outputs once the FMU is known: `Tracking`)."""
    if not isinstance(setpoints, Mapping):
        raise ConfigTypeError(f"setpoints must be {{output: value}}, got {setpoints!r} ({type(setpoints).__name__})")
    return {name: _signal(value, f"setpoint of {name!r}") for name, value in setpoints.items()}


def check_observe(observe: Any) -> list[str]:
    """``observe`` as a list of entry names (their meaning is checked by `Tracking`)."""
    if isinstance(observe, str):
        observe = [observe]
    if not isinstance(observe, Sequence) or not all(isinstance(entry, str) for entry in observe):
        raise ConfigTypeError(f"observe must be a list of names (e.g. ['setpoint', 'error_integral', "
                              f"'previous_action', 'a held input']), got {observe!r}")
    return list(observe)


def _drawn(signal: Any, rng: np.random.Generator, name: str) -> Signal:
    """One episode's setpoint: the signal, or what its callable draws (a number or a schedule)."""
    if not callable(signal):
        return signal
    value = _signal(signal(rng), f"setpoint of {name!r} (drawn)")
    if callable(value):
        raise ConfigError(f"the setpoint of {name!r} drew a callable; a draw gives a number or a schedule")
    return value


def _bounds_of(signal: Any) -> tuple[float, float]:
    """The range of a setpoint's values (a draw's as it says, else unbounded)."""
    if isinstance(signal, float):
        return signal, signal
    return tuple(getattr(signal, "bounds", (-math.inf, math.inf)))


def _value(signal: Signal, time: float) -> float:
    return signal if isinstance(signal, float) else signal.at(time)


@dataclass(frozen=True)
class _Entry:
    """One value of the observation after the outputs: its label, what it is, and of what."""

    label: str
    kind: str  # setpoint, error, error_integral, previous_action, held
    name: str | int  # the setpoint's output, the held input, or the action's element
    low: float
    high: float


class Tracking:
    """One env's setpoints and extra observation entries (see the module docstring).

    Args:
        env: the `FMUEnv` (its FMU, spaces and time step are known).
        setpoints: the config's, checked (`check_setpoints`).
        observe: the config's entries (`check_observe`).
    """

    def __init__(self, env: Any, setpoints: Mapping[str, Any], observe: Sequence[str]) -> None:
        self.model = env.description.name
        outputs = {v.name: v for v in env.fmu.output_variables}
        for name in setpoints:
            if name not in outputs:
                close = difflib.get_close_matches(name, list(outputs), n=3)
                hint = f" Did you mean {', '.join(map(repr, close))}?" if close else ""
                raise ConfigError(f"{self.model}: setpoints names {name!r}, which is not in 'outputs'.{hint} "
                                  f"Outputs: {', '.join(outputs)}")
            if outputs[name].kind != "float" or outputs[name].shape:
                raise ConfigError(f"{self.model}: setpoint of {name!r}: a setpoint follows a scalar float output")
        self.setpoints = dict(setpoints)
        self._outputs = {name: env.fmu.outputs.views[name] for name in setpoints}
        self.time_step = env.time_step
        self._action_bounds = _action_bounds(env.action_space, self.model) if "previous_action" in observe else None
        self.entries = [entry for request in observe for entry in self._entries(env, request, outputs)]
        labels = [entry.label for entry in self.entries]
        repeated = sorted({label for label in labels if labels.count(label) > 1})
        if repeated:
            raise ConfigError(f"{self.model}: observe names {', '.join(map(repr, repeated))} more than once")
        #: the previous action or the error integral is observed: each step's action and error are kept
        self.keeps_state = any(entry.kind in ("previous_action", "error_integral") for entry in self.entries)
        #: a reset draws something (a setpoint), or zeros what the episode kept: only Python resets it
        self.needs_python_reset = self.keeps_state or any(callable(s) for s in self.setpoints.values())
        self.episode_setpoints: dict[str, Signal] = {}
        self._sums = self._previous = np.zeros(0)
        self._started = False
        self.restart()
        self.time_of: Callable[[], float] = lambda: env.time

    def _entries(self, env: Any, request: str, outputs: Mapping[str, Any]) -> list[_Entry]:
        """The values one ``observe`` entry adds."""
        kind, _, which = request.partition(":")
        if kind in ("setpoint", "error", "error_integral"):
            if not self.setpoints:
                raise ConfigError(f"{self.model}: observe asks for {request!r}, and 'setpoints' is empty: "
                                  "give setpoints={output: value}")
            names = [which] if which else list(self.setpoints)
            unknown = [name for name in names if name not in self.setpoints]
            if unknown:
                raise ConfigError(f"{self.model}: observe asks for {request!r}, and {unknown[0]!r} has no setpoint. "
                                  f"Setpoints: {', '.join(self.setpoints)}")
            return [self._setpoint_entry(kind, name, outputs[name]) for name in names]
        if kind == "previous_action" and not which:
            low, high = self._action_bounds
            return [_Entry(f"previous_action[{k}]" if len(low) > 1 else "previous_action", kind, k, low[k], high[k])
                    for k in range(len(low))]
        held = env.config.fixed_inputs
        if request in held:
            value = held[request]
            variable = env.description.variable(request)
            if callable(value):
                low, high = getattr(value, "bounds", variable.bounds())
            else:
                low = high = float(np.asarray(value))
            if variable.shape:
                raise ConfigError(f"{self.model}: observe names {request!r}, an array input; only scalar held inputs "
                                  "are observed")
            return [_Entry(request, "held", request, float(low), float(high))]
        choices = [*OBSERVE_KINDS, *held]
        close = difflib.get_close_matches(request, choices, n=3)
        hint = f" Did you mean {', '.join(map(repr, close))}?" if close else ""
        raise ConfigError(f"{self.model}: observe names {request!r}, which is neither {', '.join(OBSERVE_KINDS)} "
                          f"nor a held input (fixed_inputs).{hint} Held inputs: {', '.join(held) or 'none'}")

    def _setpoint_entry(self, kind: str, name: str, output: Any) -> _Entry:
        low, high = _bounds_of(self.setpoints[name])
        if kind == "error":
            out_low, out_high = output.bounds()
            low, high = out_low - high, out_high - low
        elif kind == "error_integral":
            low, high = -math.inf, math.inf
        return _Entry(f"{kind}:{name}", kind, name, low, high)

    # -- the observation -------------------------------------------------------------------------

    @property
    def labels(self) -> list[str]:
        """The names of the values appended to the outputs, in order."""
        return [entry.label for entry in self.entries]

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The lowest and highest value of each appended value."""
        return (np.array([entry.low for entry in self.entries], dtype=np.float64),
                np.array([entry.high for entry in self.entries], dtype=np.float64))

    def setpoint_values(self) -> dict[str, float]:
        """Each setpoint's value now."""
        time = self.time_of()
        return {name: _value(signal, time) for name, signal in self.episode_setpoints.items()}

    def values(self, episode_parameters: Mapping[str, Any]) -> np.ndarray:
        """The appended values now (``episode_parameters``: the held inputs' values this episode)."""
        time = self.time_of()
        errors = {name: float(self._outputs[name]) - _value(signal, time)
                  for name, signal in self.episode_setpoints.items()}
        values = []
        for entry in self.entries:
            kind = entry.kind
            if kind == "setpoint":
                values.append(_value(self.episode_setpoints[entry.name], time))
            elif kind == "error":
                values.append(errors[entry.name])
            elif kind == "error_integral":
                k = list(self.setpoints).index(entry.name)
                values.append(self._sums[k] + (errors[entry.name] * self.time_step if self._started else 0.0))
            elif kind == "previous_action":
                values.append(self._previous[entry.name])
            else:
                values.append(float(np.asarray(episode_parameters[entry.name])))
        return np.array(values, dtype=np.float64)

    # -- the episode -----------------------------------------------------------------------------

    def reset(self, rng: np.random.Generator) -> None:
        """Start an episode: draw its setpoints, zero the error's sum and the previous action."""
        self.episode_setpoints = {name: _drawn(signal, rng, name) for name, signal in self.setpoints.items()}
        self.restart()

    def restart(self) -> None:
        """Zero what the episode kept (the error's sum, the previous action), its setpoints kept."""
        self._sums = np.zeros(len(self.setpoints))
        self._previous = np.zeros(0) if self._action_bounds is None else np.clip(0.0, *self._action_bounds)
        self._started = False

    def before_step(self, action: Any) -> None:
        """Fold in the step about to be taken: the error now (the integral's term of the last step)
        and the action (checked, as applied)."""
        if not self.keeps_state:
            return
        if self._started and len(self._sums):
            time = self.time_of()
            for k, (name, signal) in enumerate(self.episode_setpoints.items()):
                self._sums[k] += (float(self._outputs[name]) - _value(signal, time)) * self.time_step
        self._started = True
        if self._action_bounds is not None:
            self._previous = np.ravel(np.asarray(action, dtype=np.float64)).copy()

    def state(self) -> dict[str, Any]:
        """What a saved state keeps of the episode (a plain dict, picklable)."""
        return {"setpoints": dict(self.episode_setpoints), "sums": self._sums.copy(),
                "previous_action": self._previous.copy(), "started": self._started}

    def restore(self, state: Mapping[str, Any]) -> None:
        """Put back what `state` gave."""
        self.episode_setpoints = dict(state["setpoints"])
        self._sums = np.array(state["sums"], dtype=np.float64)
        self._previous = np.array(state["previous_action"], dtype=np.float64)
        self._started = bool(state["started"])


def _action_bounds(space: spaces.Space, model: str) -> tuple[np.ndarray, np.ndarray]:
    """Each action element's lowest and highest value, for ``previous_action``."""
    if isinstance(space, spaces.Box):
        return np.ravel(space.low).astype(np.float64), np.ravel(space.high).astype(np.float64)
    if isinstance(space, spaces.Discrete):
        return np.array([space.start], np.float64), np.array([space.start + space.n - 1], np.float64)
    raise ConfigError(f"{model}: observe 'previous_action' needs a Box or Discrete action space, not {space}")
