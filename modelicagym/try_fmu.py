"""``modelicagym try``: see an FMU respond to random actions before training on it.

`try_fmu` makes an `FMUEnv` from the config ``modelicagym info`` prints
(`modelicagym.info.suggest`; a JSON file and ``key=value`` settings may change it), with
its strip chart on (`modelicagym.env.strip_chart`), runs one episode of actions sampled from the
action space (the reset and the samples seeded, so a run repeats), and saves the chart of actions
and observations over time as a PNG. `TryResult` says what happened, one fact a line.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from modelicagym.env import FMUEnv
from modelicagym.errors import ConfigError, DataError
from modelicagym.fmu import UnsupportedFeatureError, open_fmu
from modelicagym.info import suggest

__all__ = ["TryResult", "parse_setting", "try_config", "try_fmu"]


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

    def lines(self) -> list[str]:
        """One line per fact, as the command prints them."""
        lines = [
            f"{self.model}: {self.steps} steps of random actions (seed {self.seed}), "
            f"t = {self.start_time:g} s to {self.end_time:g} s",
            f"the episode ended: {self.ending}",
        ]
        if self.fmu_error is not None:
            lines.append(f"FMU error at t = {self.end_time:g} s: {self.fmu_error}")
        lines.append(f"plot of {_count(self.n_actions, 'action')} and {_count(self.n_observations, 'observation')} "
                     f"over time: {self.plot}")
        return lines


def _count(n: int, thing: str) -> str:
    return f"{n} {thing}" if n == 1 else f"{n} {thing}s"


def parse_setting(text: str) -> tuple[str, Any]:
    """``key=value`` -> ``(key, value)``; the value is read as JSON (``5``, ``null``, ``["u"]``),
    else kept as a string. ``parameters.k=2`` sets one parameter."""
    key, sep, value = text.partition("=")
    if not sep or not key.strip():
        raise ConfigError(f"--set expects key=value (e.g. max_episode_steps=200), got {text!r}")
    try:
        return key.strip(), json.loads(value)
    except json.JSONDecodeError:
        return key.strip(), value


def try_config(fmu: str | Path, *, config_file: str | Path | None = None, settings: Sequence[str] = (),
               validate: bool = True) -> dict[str, Any]:
    """The config a ``try`` run uses: ``info``'s suggestion for ``fmu``, updated by the JSON object
    in ``config_file`` (its keys replace the suggestion's) and then by ``settings`` (``key=value``)."""
    suggestion = suggest(open_fmu(fmu, validate=validate), validate=validate)
    if suggestion.config is None:
        raise UnsupportedFeatureError(suggestion.refusal)
    config = suggestion.config
    if config_file is not None:
        config.update(_read_config(Path(config_file)))
    for key, value in map(parse_setting, settings):
        head, _, name = key.partition(".")
        if head == "parameters" and name:
            config["parameters"] = {**(config.get("parameters") or {}), name: value}
        else:
            config[key] = value
    return config


def _read_config(path: Path) -> Mapping[str, Any]:
    try:
        config = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as error:
        raise DataError(f"{path}: not JSON ({error})") from error
    if not isinstance(config, dict):
        raise DataError(f"{path}: a config is a JSON object of FMUEnv keys, not {type(config).__name__}")
    return config


def try_fmu(config: Mapping[str, Any], *, out: str | Path, steps: int | None = None, seed: int = 0) -> TryResult:
    """Run one episode of ``config`` (an `FMUEnv` config) with random actions and save its strip
    chart at ``out`` (PNG). ``steps`` caps the episode (else the config's ``max_episode_steps``)."""
    limit = steps if steps is not None else config.get("max_episode_steps")
    if limit is None:
        raise ConfigError("the config sets no max_episode_steps: give the number of steps to run (--steps N)")
    env = FMUEnv({**config, "max_episode_steps": limit}, render_mode="rgb_array")
    try:
        env.reset(seed=seed)
        env.action_space.seed(seed)
        terminated = truncated = False
        info: dict[str, Any] = {}
        while not (terminated or truncated):
            _, _, terminated, truncated, info = env.step(env.action_space.sample())
        chart = env.strip_chart
        plot = chart.save(out)
        roles = [s.role for s in chart.series]
        return TryResult(
            model=env.description.model_name, seed=seed, steps=env.elapsed_steps, start_time=float(chart.times[0]),
            end_time=env.time, ending=_ending(terminated, info, limit), plot=plot,
            n_actions=roles.count("action"), n_observations=roles.count("observation"),
            fmu_error=info.get("fmu_error"),
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
