"""``modelicagym try``: see an FMU respond to random actions before training on it.

`try_fmu` makes an `FMUEnv` from any config a user can train (`prepare`): the one ``modelicagym
info`` prints for an FMU (`modelicagym.info.suggest`), a JSON config file, or a task file (Python,
with its lambdas and reward: `modelicagym.task`); a JSON file and ``key=value`` settings may change
it. With its strip chart on (`modelicagym.env.strip_chart`), it runs one episode of actions sampled
from the action space (the reset and the samples seeded, so a run repeats), or chosen by the task
file's ``baseline`` controller, and saves the chart of actions and observations over time (with
the task's setpoints and held inputs) as a PNG. `TryResult` says what happened, one fact a line,
naming every variable the chart leaves out and every action range it had to assume.

An action whose range nothing in the FMU says (a placeholder, None, in ``action_bounds``) is tried
in `TRY_BOUNDS`, and the result says so: a first look should not need an edit, a training does.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from modelicagym.env import FMUEnv
from modelicagym.env.strip_chart import MAX_PANELS
from modelicagym.errors import ConfigError
from modelicagym.fmu import UnsupportedFeatureError
from modelicagym.info import suggest
from modelicagym.system import open_model
from modelicagym.task import Controller, load_config_file, read_task_file

__all__ = ["TRY_BOUNDS", "TryConfig", "TryResult", "parse_setting", "prepare", "try_config", "try_fmu"]

#: the range a ``try`` run gives an action whose range nothing in the FMU says
TRY_BOUNDS = (-1.0, 1.0)
#: config keys that map names to values: ``--set KEY.NAME=VALUE`` sets one entry
_MAPPING_KEYS = ("parameters", "fixed_inputs", "action_bounds", "setpoints")


@dataclass(frozen=True)
class TryResult:
    """What one ``try`` run did."""

    model: str
    seed: int
    steps: int
    start_time: float
    end_time: float
    ending: str  # why the episode ended, in words
    plot: Path
    n_actions: int  # lines drawn for actions (array elements count one each)
    n_observations: int
    fmu_error: str | None = None
    assumed: tuple[str, ...] = ()  # actions tried in TRY_BOUNDS, their range unknown
    left_out: tuple[str, ...] = ()  # variables the chart does not draw
    loops: tuple[str, ...] = ()  # a system's loops of direct feedthrough, where each is read from the previous step
    policy: str = "random actions"  # or "the task's baseline"

    def lines(self) -> list[str]:
        """One line per fact, as the command prints them."""
        lines = [
            (f"{self.model}: {self.steps} steps of {self.policy} (seed {self.seed}), "
            f"t = {self.start_time:g} s to {self.end_time:g} s"),
            f"the episode ended: {self.ending}",
        ]
        if self.fmu_error is not None:
            lines.append(f"FMU error at t = {self.end_time:g} s: {self.fmu_error}")
        lines += self.loops
        lines.append(f"plot of {_count(self.n_actions, 'action')} and {_count(self.n_observations, 'observation')} "
                     f"over time: {self.plot}")
        if self.left_out:
            lines.append(f"not drawn (the chart holds {MAX_PANELS} panels): {', '.join(self.left_out)}; choose what "
                         "to see with --set outputs='[...]' or --set inputs='[...]'")
        if self.assumed:
            their = "its" if len(self.assumed) == 1 else "their"
            lines.append(f"tried in {TRY_BOUNDS}, as nothing in the FMU says {their} range: "
                         f"{', '.join(self.assumed)}; give action_bounds before training "
                         f"(--set action_bounds.{self.assumed[0]}='[low, high]' here, or in the task file)")
        return lines


def _count(n: int, thing: str) -> str:
    return f"{n} {thing}" if n == 1 else f"{n} {thing}s"


@dataclass(frozen=True)
class TryConfig:
    """The config a ``try`` run uses, and the actions it gave `TRY_BOUNDS` (their bounds were placeholders)."""

    config: dict[str, Any]
    assumed: tuple[str, ...] = ()
    baseline: Controller | None = None  # the task file's controller, if it defines one


def parse_setting(text: str) -> tuple[str, Any]:
    """``key=value`` -> ``(key, value)``; the value is read as JSON (``5``, ``null``, ``["u"]``),
    else kept as a string. ``parameters.k=2`` sets one parameter (``fixed_inputs.NAME``,
    ``action_bounds.NAME`` one entry of those)."""
    key, sep, value = text.partition("=")
    if not sep or not key.strip():
        raise ConfigError(f"--set expects key=value (e.g. max_episode_steps=200), got {text!r}")
    try:
        return key.strip(), json.loads(value)
    except json.JSONDecodeError:
        return key.strip(), value


def _base_config(target: Path, validate: bool) -> tuple[dict[str, Any], Controller | None]:
    """The config ``target`` stands for: a task file's (``.py``, with its baseline), a config
    file's (``.json``), else the one ``info`` suggests for the FMU."""
    if target.suffix == ".py":
        task = read_task_file(target)
        return task.config, task.baseline
    if target.suffix == ".json":
        return load_config_file(target), None
    suggestion = suggest(open_model(target, validate=validate), validate=validate)
    if suggestion.config is None:
        raise UnsupportedFeatureError(suggestion.refusal)
    return suggestion.config, None


def prepare(target: str | Path, *, config_file: str | Path | None = None, settings: Sequence[str] = (),
            validate: bool = True) -> TryConfig:
    """The config a ``try`` run uses: ``target``'s (an FMU, a JSON config or a Python task file),
    updated by the JSON object in ``config_file`` (its keys replace the config's) and then by
    ``settings`` (``key=value``); placeholder action bounds become `TRY_BOUNDS`, named in the result."""
    base, baseline = _base_config(Path(target), validate)
    config = dict(base)
    if not validate:
        config["validate"] = False
    if config_file is not None:
        config.update(load_config_file(config_file))
    for key, value in map(parse_setting, settings):
        head, _, name = key.partition(".")
        if head in _MAPPING_KEYS and name:
            config[head] = {**(config.get(head) or {}), name: value}
        else:
            config[key] = value
    bounds = config.get("action_bounds")
    assumed = tuple(name for name, pair in (bounds or {}).items() if pair is None) if isinstance(bounds, Mapping) else ()
    if assumed:
        config["action_bounds"] = {**bounds, **dict.fromkeys(assumed, TRY_BOUNDS)}
    return TryConfig(config, assumed, baseline)


def try_config(fmu: str | Path, *, config_file: str | Path | None = None, settings: Sequence[str] = (),
               validate: bool = True) -> dict[str, Any]:
    """`prepare`'s config alone (the benchmarks run an FMU's ``try`` config as it is)."""
    return prepare(fmu, config_file=config_file, settings=settings, validate=validate).config


def try_fmu(config: Mapping[str, Any], *, out: str | Path, steps: int | None = None, seed: int = 0,
            assumed: Sequence[str] = (), baseline: Controller | None = None) -> TryResult:
    """Run one episode of ``config`` (an `FMUEnv` config) with random actions, or the actions of
    ``baseline`` (a task file's controller), and save its strip chart at ``out`` (PNG). ``steps``
    caps the episode (else the config's ``max_episode_steps``); ``assumed`` (`TryConfig.assumed`)
    is passed on to the result."""
    limit = steps if steps is not None else config.get("max_episode_steps")
    if limit is None:
        raise ConfigError("the config sets no max_episode_steps: give the number of steps to run (--steps N)")
    env = FMUEnv({**config, "max_episode_steps": limit}, render_mode="rgb_array")
    try:
        observation, _ = env.reset(seed=seed)
        env.action_space.seed(seed)
        if baseline is not None:
            baseline.reset()
        terminated = truncated = False
        info: dict[str, Any] = {}
        while not (terminated or truncated):
            action = env.action_space.sample() if baseline is None else baseline.act(observation)
            observation, _, terminated, truncated, info = env.step(action)
        chart = env.strip_chart
        plot = chart.save(out)
        roles = [s.role for s in chart.series]
        return TryResult(
            model=env.description.model_name, seed=seed, steps=env.elapsed_steps,
            policy="random actions" if baseline is None else "the task's baseline", start_time=float(chart.times[0]),
            end_time=env.time, ending=_ending(terminated, info, limit), plot=plot,
            n_actions=roles.count("action"), n_observations=roles.count("observation"),
            fmu_error=info.get("fmu_error"), assumed=tuple(assumed), left_out=tuple(chart.left_out),
            loops=tuple(env.metadata.get("loops", ())),
        )
    finally:
        env.close()


def _ending(terminated: bool, info: Mapping[str, Any], limit: int) -> str:
    if "fmu_error" in info:
        return "truncated: the FMU reported an error"
    if info.get("fmu_terminated"):
        return "terminated: the FMU ended the simulation"
    if terminated:
        return "terminated: an output left its termination bounds"
    return f"truncated after {limit} steps (max_episode_steps)"
