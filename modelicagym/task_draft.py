"""``modelicagym info MODEL --task FILE``: a task file that trains as written, for an FMU or a
system whose config ``info`` can suggest, with no edit by hand.

``info`` knows what a model declares, not what its user wants from it; a task file needs a
reward. `draft_task` writes the task a control engineer would try first on a new plant, from
what the model does, measured:

* **what to act on**: ``info``'s config (`modelicagym.info.suggest`); its action bounds must be
  known (a placeholder, None, is refused here: a task that trains on a made-up range would not say so);
* **the time step and the episode**: the first action stepped from its start to the end of its
  range (`modelicagym.step_response`): a tenth of the fastest settling time, twice the slowest;
* **what to track**: of the outputs that settle after that step (not within its first step: those
  only echo the action), the one whose change stays most of its largest excursion (a speed that
  rises to a new value, rather than a current that jumps and falls back);
* **the setpoint**: drawn at every reset between the values the tracked output settles at with the
  action held at its low and at its high bound (``setpoints`` with `uniform`), so every setpoint is
  reachable; the policy sees the setpoint, the error and the error's integral (``observe``);
* **the reward**: minus the error's magnitude over that range, each step: minus the return over
  ``max_episode_steps`` is the mean error as a fraction of the range;
* **a baseline** to beat: the steady-state action that the two held runs give for the setpoint
  (linear between them) plus a PI on the error, its gains from the step (``Kp = 1 / K``,
  ``Ki = 1 / (K tau)``: the plant's gain K, its time constant tau a quarter of the settling time).

The file says all of this in its comments; every number in it can be edited afterwards.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from modelicagym.env import FMUEnv
from modelicagym.errors import ConfigError
from modelicagym.fmu import FMUDescription, UnsupportedFeatureError
from modelicagym.info import Suggestion, format_config, suggest
from modelicagym.step_response import StepResponse, step_response, timing
from modelicagym.system import SystemDescription, open_model

__all__ = ["TaskDraft", "draft_task", "write_task"]

#: what the drafted task's policy sees after the outputs, in this order
OBSERVE = ["setpoint", "error", "error_integral"]


@dataclass(frozen=True)
class TaskDraft:
    """A drafted task file: its text, and what it chose, in words (one line each)."""

    text: str
    tracked: str
    lines: list[str]


def _tracked(response: StepResponse) -> int:
    """The column of the output to track (see the module docstring); a `ConfigError` when none settles."""
    scores = []
    for k, output in enumerate(response.outputs):
        if output.behaviour == "settles" and output.settling_time:
            peak = float(np.max(np.abs(response.responses[:, k])))
            scores.append((abs(output.change) / peak, output.settling_time, k))
    if not scores:
        raise ConfigError(f"no output settles after a step of {response.input} from {response.start_value:g} to "
                          f"{response.step_value:g}, so there is no setpoint to draft a task around: write the "
                          "task file's reward yourself (`modelicagym try MODEL --step INPUT` shows what each does)")
    return max(scores)[2]


def _held(config: dict[str, Any], action: np.ndarray, name: str) -> float:
    """The value output ``name`` reaches at the end of an episode with ``action`` held."""
    env = FMUEnv(config, render_mode="rgb_array")
    try:
        env.reset(seed=0)
        for _ in range(config["max_episode_steps"]):
            *_, terminated, _, info = env.step(action)
            if "fmu_error" in info or terminated:
                raise ConfigError(f"{env.description.name}: with the action held at {action.tolist()}, the episode "
                                  f"stopped at t = {env.time:g} s: {info.get('fmu_error') or 'it terminated'}")
        chart = env.strip_chart
        return float(chart.values[-1, [s.name for s in chart.series].index(name)])
    finally:
        env.close()


def _float_outputs(description: FMUDescription | SystemDescription, config: dict[str, Any]) -> list[str]:
    """The config's outputs of a float type: an observation of floats alone is one array (a Box),
    which the drafted reward reads by column and SAC takes."""
    return [name for name in config["outputs"] if description.variables[name].kind == "float"]


@dataclass(frozen=True)
class _Measured:
    """What the runs of `_measure` found: the output to track, how it responds, how far the action
    moves it."""

    tracked: str
    unit: str
    settling: float  # s, after a step of the first action
    ends: tuple[float, float]  # the tracked output at the end of an episode, the action held at each bound
    bounds: tuple[float, float]  # the first action's
    held: list[float]  # the other actions, at their start values

    @property
    def gain(self) -> float:
        """The tracked output's change per unit of the action, between the held runs."""
        return (self.ends[1] - self.ends[0]) / (self.bounds[1] - self.bounds[0])

    @property
    def tau(self) -> float:
        """The time constant of a first-order lag settling (2%) as the output does."""
        return self.settling / 4.0


def _measure(description: FMUDescription | SystemDescription, config: dict[str, Any]) -> _Measured:
    """Step the first action, choose the output to track, set ``config``'s time step and episode
    length from the step, and run the action held at each bound (see the module docstring)."""
    acted = config["inputs"][0]
    response = step_response(config, acted)
    column = _tracked(response)
    output = response.outputs[column]
    config["time_step"], config["max_episode_steps"] = timing([response])  # type: ignore[misc]
    env = FMUEnv(config)
    space = env.action_space  # the actions' bounds, as the env gives them
    env.close()
    starts = np.clip([float(description.variables[name].start or 0.0) for name in config["inputs"]],
                     space.low, space.high)
    bounds = (float(space.low[0]), float(space.high[0]))
    ends = []
    for bound in bounds:
        action = starts.copy()
        action[0] = bound
        ends.append(_held(config, action, output.name))
    if ends[0] == ends[1]:
        raise ConfigError(f"{description.name}: {output.name} ends at {ends[0]:g} with {acted} held at either bound: "
                          "there is no range of setpoints to draft a task around")
    return _Measured(output.name, output.unit, float(output.settling_time), (ends[0], ends[1]), bounds,
                     starts[1:].tolist())


def draft_task(model: str | os.PathLike[str], task: str | os.PathLike[str], validate: bool = True) -> TaskDraft:
    """The task file for ``model`` (an FMU or an SSP system) to be written at ``task`` (its ``fmu``
    relative to that file's folder): see the module docstring."""
    description = open_model(model, validate=validate)
    suggestion = suggest(description, validate)
    if suggestion.config is None:
        raise UnsupportedFeatureError(suggestion.refusal)
    if suggestion.placeholders:
        raise ConfigError(f"{description.name}: nothing says the range of {', '.join(suggestion.placeholders)}, so a "
                          "task cannot be drafted that trains as written: paste the config `modelicagym info` "
                          "prints into a task file and give their action_bounds")
    config = {**suggestion.config, "fmu": str(Path(model).resolve())}
    config["outputs"] = _float_outputs(description, config)
    if not config["outputs"]:
        raise ConfigError(f"{description.name}: none of its outputs is a float: there is nothing to track")
    measured = _measure(description, config)
    config["fmu"] = os.path.relpath(config["fmu"], Path(task).resolve().parent)
    drafted = replace(suggestion, config=config)
    m, acted = measured, config["inputs"][0]
    unit = f" {m.unit}" if m.unit else ""
    lines = [(f"{m.tracked} follows a setpoint drawn at every reset in {min(m.ends):.6g}..{max(m.ends):.6g}{unit}, "
              f"acted on through {acted} ({m.bounds[0]:g}..{m.bounds[1]:g})"),
             (f"time_step {config['time_step']:g} s, {config['max_episode_steps']} steps an episode (from "
              f"{m.tracked}'s settling in {m.settling:.3g} s after a step of {acted})"),
             ("reward: minus the error over the setpoints' range, each step; baseline: the steady-state action plus "
              f"a PI (plant gain {m.gain:.4g}, time constant {m.tau:.3g} s)")]
    return TaskDraft(_text(drafted, measured, Path(model).name, Path(task).name), m.tracked, lines)


def _text(suggestion: Suggestion, m: _Measured, model: str, task: str) -> str:
    """The task file's Python: ``suggestion``'s config, then the task `_measure` found."""
    config = suggestion.config
    body = format_config(suggestion)[2:-1]  # without the import and the env made from it
    n = len(config["outputs"])
    tracked, (y_low, y_high), (u_low, u_high), acted = m.tracked, m.ends, m.bounds, config["inputs"][0]
    unit_text = f" {m.unit}" if m.unit else ""
    return "\n".join([
        f'"""The task `modelicagym info {model} --task {task}` drafted: {tracked} follows a setpoint.',
        "",
        f"The config is the one `modelicagym info {model}` prints (its float outputs); its time step and episode",
        f"length come from a step of {acted} (`modelicagym try {model} --step {acted}`).",
        f"A setpoint is drawn at every reset between the values {tracked} settles at with the action held at its",
        "bounds; the reward is minus the error over that range, each step; the baseline is the steady-state action",
        "for the setpoint plus a PI on the error. Edit any of it: it is a task file as any other.",
        '"""',
        "",
        "import numpy as np",
        "",
        "from modelicagym.env import uniform",
        "",
        *body,
        "",
        f"LOW, HIGH = {y_low!r}, {y_high!r}  # {tracked}{unit_text}, the action held at {u_low!r} and at {u_high!r}",
        f"config['setpoints'] = {{{tracked!r}: uniform(min(LOW, HIGH), max(LOW, HIGH))}}",
        f"config['observe'] = {OBSERVE!r}  # seen after the {n} outputs, in this order",
        "config['action_out_of_bounds'] = 'clip'",
        f"SETPOINT, ERROR, INTEGRAL = {n}, {n + 1}, {n + 2}  # their columns in an observation (error: output - setpoint)",
        "",
        "",
        "def reward(envs, observations, actions, terminated):  # row k: one env's step",
        "    return -np.abs(observations[:, ERROR]) / abs(HIGH - LOW)",
        "",
        "",
        "config['batch_reward'] = reward",
        "",
        f"GAIN, TAU = {m.gain!r}, {m.tau!r}  # {tracked}'s change per unit of the action, its time constant (s)",
        f"BOUNDS = ({u_low!r}, {u_high!r})",
        f"HELD = {m.held!r}  # the other actions, held at their start values" if m.held else "HELD = []",
        "",
        "",
        "class baseline:",
        "    \"\"\"The steady-state action for the setpoint (linear between the held runs) plus a PI on the error; the",
        "    integral holds while the action is at a bound (no windup).\"\"\"",
        "",
        "    def reset(self):",
        "        self.integral = 0.0",
        "",
        "    def act(self, observation):",
        "        setpoint, error = observation[SETPOINT], -observation[ERROR]  # setpoint - output",
        "        steady = BOUNDS[0] + (setpoint - LOW) / GAIN",
        "        unclipped = steady + (error + self.integral / TAU) / GAIN",
        "        action = float(np.clip(unclipped, *BOUNDS))",
        "        if action == unclipped:",
        "            self.integral += error * config['time_step']",
        "        return np.array([action, *HELD])",
        "",
    ])


def write_task(model: str | os.PathLike[str], task: str | os.PathLike[str], validate: bool = True) -> TaskDraft:
    """Draft the task for ``model`` (`draft_task`) and write it at ``task``, refusing to replace a file."""
    path = Path(task)
    if path.exists():
        raise ConfigError(f"{path} exists: choose another name for the task file, or remove it")
    draft = draft_task(model, path, validate)
    path.write_text(draft.text, encoding="utf-8")
    return draft
