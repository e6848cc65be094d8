"""``modelicagym try TARGET --step INPUT``: how fast an FMU responds, to choose the time step and
the episode length from what it does rather than by guessing.

For each chosen input, `step_response` runs the config twice from the same start: once with the
input held at its start value, once with it stepped (at the start) to another value, every other
input held as the config holds it (the action's other inputs at their start values). The
difference of the two runs is the response to the step alone, even for an FMU that does not start
at rest. Each output's response is one of (`BEHAVIOURS`):

* **settles**: it enters, for good, a band of 2% of its largest excursion around its final value,
  in the first half of the run; its settling time is when;
* **integrates**: it ramps: its rate of change settles (as above) to a rate that is not zero, after
  a transient of its own (e.g. an angle integrating a speed that settles) or from the start to the
  last digits (a pure integrator; a slow lag's rate, steady only to a few digits on a short run, is
  no ramp); its ramp rate is that rate;
* **oscillates**: in the second half of the run it swings around its mean at least
  `OSCILLATION_CROSSINGS` times without dying out;
* **does not move** (beyond the rounding of the held run's values);
* else it has **not settled** within the run.

The horizon starts at the config's episode and grows tenfold while an output has not settled (at
most `MAX_GROWTHS` times): an output that integrates or oscillates does not stretch it, but for one
more tenfold run that checks its ramp rate holds (a lag far slower than the run also looks like a
ramp on it: its rate then falls, and the horizon grows on until it settles). An output
that settles within a few points of that run (or within its first step, as long as those points are
coarser than a tenth of the config's time step) is timed again on a shorter one. `suggest_timing`
turns the settling times of the outputs that settle into a time step (a tenth of the fastest) and an
episode (twice the slowest).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from modelicagym.disk import atomic_write
from modelicagym.env import FMUEnv
from modelicagym.env.strip_chart import MAX_PANELS, require_matplotlib
from modelicagym.errors import ConfigError
from modelicagym.fmu import FMUDescription
from modelicagym.info import as_declared, infer_bounds
from modelicagym.system import SystemDescription, open_model

__all__ = ["BEHAVIOURS", "MAX_GROWTHS", "OutputResponse", "StepResponse", "parse_step", "plot_step_responses",
           "step_plot_paths", "step_response", "suggest_timing", "timing"]

#: the horizon grows tenfold at most this many times while an output has not settled
MAX_GROWTHS = 6
#: points of each run (the communication step is the horizon over this)
POINTS = 400
#: the settling band: this fraction of the response's largest excursion
BAND = 0.02
#: an episode longer than this many steps is pointed out in the suggestion
LONG_EPISODE = 1000
#: a settling time within this many points of its run is measured again on a finer one
FINE = 20
#: what an output's response does
BEHAVIOURS = ("settles", "integrates", "oscillates", "does not move", "not settled")
#: a ramp's rate steady from the start to this relative precision is a pure integrator's
RAMP_DIGITS = 1e-6
#: an output swinging around its mean this many times in the second half of a run, not dying out, oscillates
OSCILLATION_CROSSINGS = 4
#: config keys a step response leaves out: they shape the action, the reward or the episode's end
_DROPPED = ("action_bounds", "action_space", "observation_space", "action_table", "reward", "termination",
            "batch_reward", "batch_termination", "start_states", "setpoints", "observe", "action_out_of_bounds")


@dataclass(frozen=True)
class OutputResponse:
    """One output's response to one step: its change at the end, what it does (one of
    `BEHAVIOURS`), when it settled (None: it did not, within the horizon; ``responds`` False: it
    did not move) and, for one that integrates, its ramp rate (its unit per second)."""

    name: str
    unit: str
    change: float
    settling_time: float | None
    responds: bool
    behaviour: str = "settles"
    rate: float | None = None

    def line(self, horizon: float) -> str:
        label = f"{self.name} [{self.unit}]" if self.unit else self.name
        if not self.responds:
            return f"  {label}: does not move"
        if self.behaviour == "integrates":
            per = f" {self.unit}/s" if self.unit else " per s"
            return f"  {label}: integrates, ramps at {self.rate:+.4g}{per} (no settling time)"
        if self.behaviour == "oscillates":
            return f"  {label}: oscillates, {self.change:+.4g} at the end of {horizon:g} s (no settling time)"
        if self.settling_time is None:
            return f"  {label}: {self.change:+.4g}, not settled in {horizon:g} s"
        if self.settling_time == 0.0:
            return f"  {label}: {self.change:+.4g}, at once (within the first step: no lag)"
        return f"  {label}: {self.change:+.4g}, settles (2%) in {self.settling_time:.3g} s"


@dataclass(frozen=True)
class StepResponse:
    """The response of a config's outputs to a step of one input."""

    input: str
    start_value: float
    step_value: float
    times: np.ndarray  # from the step, s
    responses: np.ndarray  # stepped run minus held run, one column per output
    outputs: list[OutputResponse]

    @property
    def horizon(self) -> float:
        return float(self.times[-1])

    def lines(self) -> list[str]:
        """What the command prints for this step: one line, then one per output."""
        return [f"step of {self.input} from {self.start_value:g} to {self.step_value:g}, {self.horizon:g} s:",
                *(o.line(self.horizon) for o in self.outputs)]


def parse_step(text: str) -> tuple[str, float | None]:
    """``INPUT`` or ``INPUT=VALUE`` (the value to step to) -> ``(input, value or None)``."""
    name, sep, value = text.partition("=")
    if not sep:
        return name.strip(), None
    try:
        return name.strip(), float(value)
    except ValueError:
        raise ConfigError(f"--step expects INPUT or INPUT=VALUE (a number), got {text!r}") from None


def _model(config: Mapping[str, Any]) -> FMUDescription | SystemDescription:
    """What ``config`` runs: its FMU, or its system (an SSP, or ``fmus`` and ``connections``)."""
    return open_model(config.get("fmu"), fmus=config.get("fmus"), connections=config.get("connections") or (),
                      loop_breaks=config.get("loop_breaks") or (), validate=config.get("validate", True))


def _run_config(config: Mapping[str, Any], name: str, horizon: float) -> dict[str, Any]:
    """``config`` acting on ``name`` alone for ``POINTS`` steps over ``horizon`` seconds, the
    action's other inputs (and tunable parameters) held at their start values."""
    description = _model(config)
    fixed = {k: v for k, v in (config.get("fixed_inputs") or {}).items() if k != name}
    parameters = dict(config.get("parameters") or {})
    for other in config.get("inputs") or ():
        if other != name:
            variable = description.variables[other]
            (fixed if variable.is_input else parameters)[other] = variable.start
    run = {k: v for k, v in config.items() if k not in _DROPPED}
    return {**run, "inputs": [name], "fixed_inputs": fixed, "parameters": parameters, "time_step": horizon / POINTS,
            "max_episode_steps": POINTS}


def _values(config: Mapping[str, Any], name: str, value: float | None, seed: int) -> tuple[float, float]:
    """The start value of input ``name`` and the value to step it to (``value``, else the end of its
    range farther from its start: the config's action bounds, its declared ones or info's)."""
    description = _model(config)
    variable = description.variables.get(name)
    if variable is None or not (variable.is_input or variable.is_tunable_parameter):
        description.variable(name, description.inputs, "input")  # an unknown name: close matches
        raise ConfigError(f"{description.name}: --step {name}: not an input or a tunable parameter (causality "
                          f"{variable.causality!r}, variability {variable.variability!r}); inputs: "
                          f"{', '.join(v.name for v in description.inputs)}")
    held = (config.get("fixed_inputs") or {}).get(name, variable.start)
    start = float(held(np.random.default_rng(seed)) if callable(held) else held)
    if value is not None:
        return start, value
    bounds = (config.get("action_bounds") or {}).get(name)
    if bounds is None and variable.min is not None and variable.max is not None:
        bounds = (variable.min, variable.max)
    if bounds is None and variable.kind == "float":
        inferred = infer_bounds(*as_declared(variable, description))
        bounds = None if inferred.placeholder else (inferred.low, inferred.high)
    if bounds is None:
        raise ConfigError(f"{description.name}: nothing says the range of {name!r}: give the value to step it to "
                          f"(--step {name}=VALUE)")
    low, high = map(float, bounds)
    return start, (high if high - start >= start - low else low)


def _episode(config: dict[str, Any], value: float, seed: int) -> tuple[np.ndarray, np.ndarray, list[tuple[str, str]]]:
    """One run holding the acted input at ``value``: the times, the outputs' values (one column
    each), and the outputs' names and units."""
    env = FMUEnv(config, render_mode="rgb_array")
    try:
        env.reset(seed=seed)
        action = np.full(env.action_space.shape, value, dtype=env.action_space.dtype)
        for _ in range(POINTS):
            *_, terminated, _, info = env.step(action)
            if "fmu_error" in info or terminated:
                raise ConfigError(f"{env.description.name}: the step response stopped at t = {env.time:g} s: "
                                  f"{info.get('fmu_error') or 'the FMU ended the simulation'}")
        chart = env.strip_chart
        columns = [k for k, s in enumerate(chart.series) if s.role == "observation"]
        names = [(chart.series[k].name, chart.series[k].unit) for k in columns]
        return chart.times - chart.times[0], chart.values[:, columns], names
    finally:
        env.close()


#: an output's behaviour, settling time and ramp rate (`_behaviour`)
Found = tuple[str, float | None, float | None]


def _settled_at(times: np.ndarray, values: np.ndarray) -> float | None:
    """When ``values`` (from ``times[0]``) enter, for good, a band of `BAND` of their largest
    excursion around their final value: ``times[0]`` if they start inside it, None if not in the
    first half of the run."""
    peak = float(np.max(np.abs(values)))
    outside = np.flatnonzero(np.abs(values - values[-1]) > BAND * peak)
    settled = float(times[outside[-1] + 1]) if outside.size else float(times[0])
    return settled if settled <= times[-1] / 2 else None


def _oscillates(response: np.ndarray) -> bool:
    """Whether ``response`` swings around its mean `OSCILLATION_CROSSINGS` times in its second half,
    its last quarter's swing at least 90% of its third quarter's (not dying out)."""
    n = len(response)
    half = response[n // 2 :]
    signs = np.sign(half - half.mean())
    crossings = int(np.count_nonzero(signs[1:] * signs[:-1] < 0))
    third, last = response[n // 2 : 3 * n // 4], response[3 * n // 4 :]
    return crossings >= OSCILLATION_CROSSINGS and np.ptp(last) >= 0.9 * np.ptp(third) > 0.0


def _behaviour(times: np.ndarray, response: np.ndarray, held: np.ndarray) -> Found:
    """What ``response`` does (one of `BEHAVIOURS`), when it settled, and its ramp rate if it
    integrates. ``held``: the held run's values, whose rounding a response must exceed to move."""
    peak = float(np.max(np.abs(response)))
    if not peak > 1e-9 * (1.0 + float(np.max(np.abs(held)))):
        return "does not move", None, None
    settled = _settled_at(times[1:], response[1:])  # [0]: before the step acts
    if settled is not None:
        return "settles", (0.0 if settled == times[1] else settled), None  # 0: within the first step (no lag)
    rates = np.diff(response) / np.diff(times)
    final = float(rates[-1])
    rate_settled = _settled_at(times[1:], rates)
    steady = float(np.max(np.abs(rates - final))) <= RAMP_DIGITS * abs(final)
    if abs(final) > BAND * float(np.max(np.abs(rates))) and rate_settled is not None and (
            rate_settled > times[1] or steady):
        return "integrates", None, final
    if _oscillates(response):
        return "oscillates", None, None
    return "not settled", None, None


def _respond(config: Mapping[str, Any], name: str, start: float, target: float, horizon: float,
             seed: int) -> tuple[np.ndarray, np.ndarray, list[tuple[str, str]], list[Found]]:
    """One step over ``horizon``: the times, the responses (stepped run minus held run), the
    outputs' names and units, and each output's behaviour, settling time and ramp rate (`_behaviour`)."""
    run = _run_config(config, name, horizon)
    times, held, names = _episode(run, start, seed)
    _, stepped, _ = _episode(run, target, seed)
    difference = stepped - held
    return times, difference, names, [_behaviour(times, difference[:, k], held[:, k]) for k in range(len(names))]


def step_response(config: Mapping[str, Any], name: str, value: float | None = None, *, seed: int = 0) -> StepResponse:
    """The response of ``config``'s outputs to input ``name`` stepped from its start value to
    ``value`` (else to the end of its range farther from its start); see the module docstring.

    The horizon grows tenfold while a responding output has not settled (one that integrates or
    oscillates does not count); then an output that settled within `FINE` points of that run is
    measured again on a run four times its settling time long (four points of the run, for one that
    settled within its first step, while the points are coarser than a tenth of the config's time
    step), so a fast output is not timed on a slow one's grid."""
    start, target = _values(config, name, value, seed)
    description = _model(config)
    time_step = float(config.get("time_step") or description.default_experiment.step_size or 0.1)
    horizon = time_step * float(config.get("max_episode_steps") or 100)
    ramps: dict[int, float] | None = None  # the ramp rates of the run before, to check they hold
    for growth in range(MAX_GROWTHS + 1):
        times, difference, names, found = _respond(config, name, start, target, horizon, seed)
        rates = {k: rate for k, (behaviour, _, rate) in enumerate(found) if behaviour == "integrates"}
        held = ramps is not None and all(k in ramps and abs(rate - ramps[k]) <= BAND * abs(rate)
                                         for k, rate in rates.items())
        if growth == MAX_GROWTHS or (all(behaviour != "not settled" for behaviour, _, _ in found)
                                     and (not rates or held)):
            break
        ramps = rates
        horizon *= 10.0
    best = [(t, horizon / POINTS) for _, t, _ in found]
    for _ in range(MAX_GROWTHS):
        coarse = [max(t, dt) for t, dt in best
                  if t is not None and (0.0 < t < FINE * dt or (t == 0.0 and dt > time_step / 10))]
        if not coarse:
            break
        fine = 4.0 * min(coarse)
        _, _, _, finer = _respond(config, name, start, target, fine, seed)
        best = [(t, fine / POINTS) if old is not None and behaviour == "settles" and fine / POINTS < dt else (old, dt)
                for (old, dt), (behaviour, t, _) in zip(best, finer)]
    outputs = [OutputResponse(n, u, float(difference[-1, k]), t, behaviour != "does not move", behaviour, rate)
               for k, ((n, u), (t, _), (behaviour, _, rate)) in enumerate(zip(names, best, found))]
    return StepResponse(name, start, target, times, difference, outputs)


def _nice(value: float) -> float:
    """``value`` rounded down to 1, 2 or 5 times a power of ten."""
    power = 10.0 ** math.floor(math.log10(value))
    return max(m for m in (1.0, 2.0, 5.0) if m * power <= value * (1 + 1e-9)) * power


def timing(responses: Sequence[StepResponse]) -> tuple[float, int] | None:
    """``(time_step, max_episode_steps)``: a tenth of the fastest settling time (rounded down to 1, 2
    or 5 times a power of ten) and twice the slowest, from the outputs that settle; None when none does."""
    settled = [o.settling_time for r in responses for o in r.outputs if o.settling_time]
    if not settled:
        return None
    time_step = _nice(min(settled) / 10)
    return time_step, math.ceil(2 * max(settled) / time_step)


def suggest_timing(responses: Sequence[StepResponse]) -> str | None:
    """One line: a time step (a tenth of the fastest settling time, rounded down to 1, 2 or 5
    times a power of ten) and an episode length (twice the slowest), from the settled outputs;
    None when nothing settled."""
    settled = [(o.settling_time, o.name) for r in responses for o in r.outputs if o.settling_time]
    if not settled:
        return None
    (fastest, fast_name), (slowest, slow_name) = min(settled), max(settled)
    time_step, steps = timing(responses)  # type: ignore[misc]
    line = (f"suggested: time_step {time_step:g} s (a tenth of the fastest settling, {fast_name}'s {fastest:.3g} s), "
            f"max_episode_steps {steps} ({2 * slowest:.3g} s: twice the slowest, {slow_name}'s {slowest:.3g} s)")
    if steps > LONG_EPISODE:
        line += (f"; over {LONG_EPISODE} steps, as the outputs settle on far apart time scales: a longer time step "
                 f"does if {fast_name} needs no control within its settling")
    return line


def step_plot_paths(inputs: Sequence[str], out: str | Path | None, stem: str) -> list[Path]:
    """Where each input's plot goes: ``out`` for one input, else ``out`` with ``-INPUT`` before its
    suffix; without ``out``, ``STEM-step-INPUT.png`` (so runs stepping other inputs keep their files)."""
    if out is None:
        return [Path(f"{stem}-step-{name}.png") for name in inputs]
    out = Path(out)
    if len(inputs) == 1:
        return [out]
    return [out.with_name(f"{out.stem}-{name}{out.suffix or '.png'}") for name in inputs]


def plot_step_responses(responses: Sequence[StepResponse], path: str | Path) -> tuple[Path, list[str]]:
    """One panel per output (up to `MAX_PANELS`), each step's response over time with its settling
    time dashed, as a PNG at ``path``; the path and the outputs left out. The command draws each
    input's step in a file of its own (`step_plot_paths`)."""
    figure_class, canvas_class = require_matplotlib()
    outputs = [(o.name, o.unit) for o in responses[0].outputs]
    drawn, left_out = outputs[:MAX_PANELS], [name for name, _ in outputs[MAX_PANELS:]]
    figure = figure_class(figsize=(8, 1.6 * len(drawn) + 0.8), dpi=80, layout="constrained")
    axes = figure.subplots(len(drawn), 1, sharex=False, squeeze=False)[:, 0]
    for k, (ax, (name, unit)) in enumerate(zip(axes, drawn)):
        for i, response in enumerate(responses):
            colour = f"C{i}"
            ax.plot(response.times, response.responses[:, k], color=colour, linewidth=1.2,
                    label=f"{response.input}: {response.start_value:g} -> {response.step_value:g}")
            settling = response.outputs[k].settling_time
            if settling:
                ax.axvline(settling, color=colour, linestyle="--", linewidth=0.8)
        behaviour = responses[0].outputs[k].behaviour if len(responses) == 1 else ""
        title = f"{name} [{unit}]" if unit else name
        ax.set_title(f"{title}: {behaviour}" if behaviour else title, loc="right", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(True, linewidth=0.4, alpha=0.5)
    settled = [o.settling_time for r in responses for o in r.outputs if o.settling_time]
    longest = max(r.horizon for r in responses)
    for ax in axes:  # the settling, not the tenfold horizon that found it, fills the width
        ax.set_xlim(0.0, min(longest, 2.5 * max(settled)) if settled else longest)
    axes[0].legend(loc="best", fontsize=7, frameon=False)
    axes[-1].set_xlabel("time since the step [s] (dashed: settled within 2%)", fontsize=8)
    figure.suptitle("step responses: the stepped run minus the held one", fontsize=10)
    canvas = canvas_class(figure)
    with atomic_write(path, "wb", elsewhere="choose another file (try --out)") as f:
        canvas.print_png(f)
    return Path(path), left_out
