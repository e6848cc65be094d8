"""Run an FMU, an SSP system or a task file to a stop time with no agent: the first thing to do with
a new model, to see what every variable does.

Inputs are held at a value, or follow the columns of a time table (a CSV with a ``time`` column,
read and interpolated as a system's tables are: linearly, the end values held outside its range),
each taking at every communication step its value at the step's start. The trajectory is every
scalar variable (or the chosen ones) at the start time and after each step: a numpy structured
array with a ``time`` field, written to CSV by `write_csv` and drawn by `plot`. ``modelicagym
simulate`` is the same from the command line.
"""

from __future__ import annotations

import csv
import logging
import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from modelicagym.errors import ArgumentError, ConfigError
from modelicagym.fmu.buffers import start_at
from modelicagym.fmu.errors import VariableError
from modelicagym.system import SystemInstance, new_instance, open_model
from modelicagym.system.table import read_table
from modelicagym.task import load_config_file, load_task

logger = logging.getLogger(__name__)

__all__ = ["model_config", "plot", "simulate", "write_csv"]

#: the config keys that say what runs and how (a task file's others, its agent's inputs, outputs,
#: reward and bounds, have no part in a run without an agent)
_MODEL_KEYS = ("fmu", "fmus", "connections", "master", "loop_breaks", "substeps", "parameters", "fixed_inputs",
               "time_step", "start_time", "mode", "solver", "tolerance", "solver_step", "validate", "logging_on")
#: the most variables `plot` draws, one panel each
MAX_PLOTTED = 12


def model_config(target: str | os.PathLike[str] | Mapping[str, Any]) -> dict[str, Any]:
    """The model part of what ``target`` names: a config mapping, a task file (``.py``), a JSON
    config (``.json``), or an FMU or SSP system (its path)."""
    if isinstance(target, Mapping):
        config = dict(target)
    elif Path(target).suffix == ".py":
        config = load_task(target)
    elif Path(target).suffix == ".json":
        config = load_config_file(target)
    else:
        config = {"fmu": str(target)}
    return {key: value for key, value in config.items() if key in _MODEL_KEYS}


def simulate(target: str | os.PathLike[str] | Mapping[str, Any], stop_time: float | None = None, *,
             inputs: Mapping[str, Any] | None = None, table: str | os.PathLike[str] | None = None,
             outputs: Sequence[str] | None = None, parameters: Mapping[str, Any] | None = None,
             time_step: float | None = None, seed: int = 0) -> np.ndarray:
    """Run ``target`` (see `model_config`) from its start time to ``stop_time`` (default: the
    model's default experiment's) at ``time_step`` (default: the config's, else the model's) and
    return the trajectory: a structured array, one row per communication point (the start
    included), fields ``time`` and each of ``outputs`` (default: every scalar variable).

    ``inputs``: ``{name: value}`` held for the whole run; ``table``: a CSV whose columns (after
    ``time``) drive the inputs they name; ``parameters``: values set at the start, over the
    config's (a function of the generator seeded with ``seed`` draws one, as in an env)."""
    config = model_config(target)
    description = open_model(config.get("fmu"), fmus=config.get("fmus"), connections=config.get("connections", ()),
                             loop_breaks=config.get("loop_breaks", ()), validate=config.get("validate", True))
    held = {**dict(config.get("fixed_inputs") or {}), **dict(inputs or {})}
    data = read_table(table) if table is not None else None
    columns = dict(data.columns) if data is not None else {}
    both = sorted(set(held) & set(columns))
    if both:
        raise ArgumentError(f"{', '.join(both)}: given a value and a column of {table}; give one")
    driven = [*held, *columns]
    for name in held:
        description.input_variable(name)  # an unknown or connected input: its own clear error
    for name in columns:
        try:
            description.input_variable(name)
        except (ConfigError, VariableError) as error:
            raise type(error)(f"{table}: column {name!r} drives no input: {error}") from None
    names = list(outputs) if outputs else _scalar_variables(description)
    if "time" in names:
        raise ArgumentError("'time' is the trajectory's first field already: leave it out of the outputs")
    for name in names:
        description.observable_variable(name)
    dt = float(time_step or config.get("time_step") or description.default_experiment.step_size or 0.0)
    if not dt > 0:
        raise ConfigError(f"{description.name} declares no default step size: give a time step")
    rng = np.random.default_rng(seed)
    values = {name: value(rng) if callable(value) else value
              for name, value in {**dict(config.get("parameters") or {}), **dict(parameters or {})}.items()}
    instance = new_instance(description, master=config.get("master", "gauss-seidel"),
                            substeps=config.get("substeps", 1), mode=config.get("mode"), inputs=driven, outputs=names,
                            start_time=config.get("start_time"), solver=config.get("solver", "cvode"),
                            tolerance=config.get("tolerance"), solver_step=config.get("solver_step"),
                            validate=config.get("validate", True), logging_on=config.get("logging_on", False),
                            step_size=dt)
    try:
        start = instance.start_time
        stop = description.default_experiment.stop_time if stop_time is None else float(stop_time)
        if stop is None:
            raise ArgumentError(f"{description.name} declares no stop time: give one")
        if stop < start:
            raise ArgumentError(f"stop time {stop} is before the start time {start}")

        def drive(t: float) -> dict[str, Any]:
            return {**held, **{name: float(np.interp(t, data.times, column)) for name, column in columns.items()}}

        if isinstance(instance, SystemInstance):
            instance.start_inputs_at(drive(start))
        else:
            start_at(instance.inputs, drive(start))
        instance.reset(values)
        rows = [_row(instance, names, start)]
        steps = math.ceil((stop - start) / dt - 1e-9)
        for k in range(steps):
            for name, value in drive(start + k * dt).items():
                instance.inputs.views[name][...] = value
            ended = instance.step(dt)
            rows.append(_row(instance, names, start + (k + 1) * dt))
            if ended:
                logger.info("%s ended the simulation at t=%g", description.name, start + (k + 1) * dt)
                break
    finally:
        instance.close()
    dtype = [("time", np.float64)] + [(name, instance.outputs.views[name].dtype) for name in names]
    return np.array(rows, dtype=dtype)


def _scalar_variables(description: Any) -> list[str]:
    """Every variable a run can record: scalar, observable, not time itself (an FMU's independent
    variable, which the first field already is)."""
    names = []
    for variable in description.variables.values():
        if variable.shape or variable.causality == "independent":
            continue
        try:
            description.observable_variable(variable.name)
        except VariableError:
            continue
        names.append(variable.name)
    return names


def _row(instance: Any, names: Sequence[str], time: float) -> tuple:
    views = instance.outputs.views
    return (time, *(views[name].item() for name in names))


def write_csv(trajectory: np.ndarray, path: str | os.PathLike[str]) -> Path:
    """``trajectory`` as CSV: a header of its fields, then a row per time (floats in full precision,
    booleans as 0 and 1)."""
    path = Path(path)
    with path.open("w", newline="", encoding="utf-8") as file:
        writer = csv.writer(file)
        writer.writerow(trajectory.dtype.names)
        for row in trajectory.tolist():
            writer.writerow([int(v) if isinstance(v, bool) else repr(v) if isinstance(v, float) else v for v in row])
    return path


def plot(trajectory: np.ndarray, path: str | os.PathLike[str]) -> tuple[Path, list[str]]:
    """A PNG of ``trajectory``, one panel per variable over time (the first `MAX_PLOTTED`); returns
    the file and the variables left out."""
    from modelicagym.env.strip_chart import require_matplotlib

    figure_class, canvas_class = require_matplotlib()
    names = [name for name in trajectory.dtype.names if name != "time"]
    drawn, left_out = names[:MAX_PLOTTED], names[MAX_PLOTTED:]
    figure = figure_class(figsize=(8, 1.6 * max(len(drawn), 1) + 0.6))
    canvas_class(figure)
    axes = figure.subplots(max(len(drawn), 1), 1, sharex=True, squeeze=False)[:, 0]
    for ax, name in zip(axes, drawn):
        ax.plot(trajectory["time"], trajectory[name], linewidth=1.2)
        ax.set_ylabel(name, rotation=0, ha="right", fontsize=8)
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time")
    figure.tight_layout()
    path = Path(path)
    figure.savefig(path, dpi=100)
    return path, left_out
