"""Time tables as components: a CSV or MAT file of exogenous inputs (weather, a flight profile, a
load schedule) whose columns are outputs, connected like an FMU's.

A table's first column (CSV) or its ``time`` variable (MAT) is time, strictly increasing; every
other column is an output named by its header (CSV) or variable name (MAT; a single 2-D matrix has
its columns named ``y1``, ``y2``, ...). Values between two rows are interpolated linearly (as
``numpy.interp``); before the first row and after the last the end values are held. A table's one parameter, ``time_offset`` (default 0),
shifts it: at system time ``t`` it gives its value at ``t + time_offset``, so each episode may
start at another time of the table (``parameters={"weather.time_offset": lambda rng: ...}``, or a
reset's ``options={"parameters": {...}}``).
"""

from __future__ import annotations

import csv
import time as _time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from modelicagym.errors import ConfigError, DataError, NotFoundError
from modelicagym.fmu.clock import OnClock, StepClock
from modelicagym.fmu.errors import StateMismatchError
from modelicagym.fmu.variables import Variable
from modelicagym.system.buffers import Values

#: the file types a table component may be read from
TABLE_SUFFIXES = (".csv", ".mat")
#: the parameter that shifts a table in time
TIME_OFFSET = "time_offset"


@dataclass(frozen=True)
class TableData:
    """A table as read: its times and one column of values per output name."""

    path: Path
    times: np.ndarray
    columns: dict[str, np.ndarray]

    def variables(self) -> list[Variable]:
        """The table's variables as an FMU's: one Float64 output per column, and ``time_offset``."""
        outputs = [Variable(name, k, "Float64", "float", "output", "continuous", "calculated",
                            start=float(values[0]), description=f"column {name!r} of {self.path.name}")
                   for k, (name, values) in enumerate(self.columns.items())]
        offset = Variable(TIME_OFFSET, len(outputs), "Float64", "float", "parameter", "fixed", "exact", start=0.0,
                          unit="s", description=f"the time of {self.path.name} at the system's start time")
        return [*outputs, offset]


def read_table(path: str | Path) -> TableData:
    """Read a CSV or MAT time table (see the module docstring); a one-line `DataError` naming the
    file for anything else."""
    path = Path(path).expanduser()
    if not path.is_file():
        raise NotFoundError(f"table not found: {path} (resolved to {path.resolve()})")
    if path.suffix.lower() == ".csv":
        times, columns = _read_csv(path)
    elif path.suffix.lower() == ".mat":
        times, columns = _read_mat(path)
    else:
        raise ConfigError(f"{path}: a table is a {' or '.join(TABLE_SUFFIXES)} file")
    if times.size < 1 or not columns:
        raise DataError(f"{path}: a table needs a time column, at least one value column and one row")
    if not np.all(np.isfinite(times)) or np.any(np.diff(times) <= 0):
        row = int(np.argmax(~np.isfinite(times))) if not np.all(np.isfinite(times)) else int(np.argmax(np.diff(times) <= 0)) + 1
        raise DataError(f"{path}: time must be finite and strictly increasing; row {row + 1} breaks it")
    return TableData(path, times, columns)


def _read_csv(path: Path) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    with open(path, newline="") as file:
        rows = [row for row in csv.reader(file) if row and not row[0].lstrip().startswith("#")]
    if len(rows) < 2:
        raise DataError(f"{path}: a CSV table needs a header row (time, then a name per column) and a row of values")
    header = [name.strip() for name in rows[0]]
    try:
        data = np.array([[float(cell) for cell in row] for row in rows[1:]], dtype=np.float64)
    except ValueError as error:
        raise DataError(f"{path}: not a number: {error}") from None
    if data.ndim != 2 or data.shape[1] != len(header):
        raise DataError(f"{path}: every row needs {len(header)} values, as the header names")
    return data[:, 0], {name: data[:, k] for k, name in enumerate(header) if k > 0}


def _read_mat(path: Path) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    from scipy.io import loadmat

    contents = {k: np.asarray(v) for k, v in loadmat(str(path)).items() if not k.startswith("__")}
    if "time" in contents:
        times = contents.pop("time").ravel().astype(np.float64)
        columns = {k: v.ravel().astype(np.float64) for k, v in contents.items() if v.size == times.size}
        return times, columns
    matrices = [v for v in contents.values() if v.ndim == 2 and v.shape[1] >= 2]
    if len(matrices) != 1:
        raise DataError(f"{path}: a MAT table holds a 'time' vector and a vector per column, or one matrix "
                        f"whose first column is time; it holds {', '.join(contents) or 'nothing'}")
    data = matrices[0].astype(np.float64)
    return data[:, 0], {f"y{k}": data[:, k] for k in range(1, data.shape[1])}


class TableInstance:
    """A table stepped as a component: ``outputs.views[column]`` holds its value at the current time
    (plus ``time_offset``); ``step(dt)`` moves it on. What the master needs of a component, no more.
    Its clock and offset live where the native step path reads and writes them (``clock``, a C
    struct; ``offset_value``, one double); ``matrix`` holds its outputs' columns, one row each."""

    time = OnClock()
    start_time = OnClock()
    steps = OnClock()
    fmu_time_ns = OnClock()
    origin = OnClock()
    dt = OnClock()

    def __init__(self, data: TableData, name: str, outputs: list[str], start_time: float):
        self.data, self.name = data, name
        self.clock = StepClock()
        self.offset_value = np.zeros(1)
        self.output_variables = [v for v in data.variables() if v.name in outputs]
        self.outputs = Values(self.output_variables)
        self.inputs = Values([])
        self.matrix = np.array([data.columns[v.name] for v in self.output_variables], dtype=np.float64).reshape(
            len(self.output_variables), data.times.size)
        self._columns = [(self.outputs.views[v.name], row) for v, row in zip(self.output_variables, self.matrix)]
        self.start_time = start_time
        self.time, self.origin, self.dt, self.steps, self.offset = start_time, start_time, 0.0, 0, 0.0
        self.fmu_time_ns = 0
        self.initialized, self.initializations, self.terminated = False, 0, False
        self.event_mode_inputs = False

    @property
    def offset(self) -> float:
        """The table's time at the system's start time, this episode (``time_offset``)."""
        return float(self.offset_value[0])

    @offset.setter
    def offset(self, value: float) -> None:
        self.offset_value[0] = value

    def reset(self, values: dict[str, Any] | None = None) -> None:
        offset = (values or {}).get(TIME_OFFSET, 0.0)
        self.offset, self.time, self.origin, self.dt, self.steps = float(offset), self.start_time, self.start_time, 0.0, 0
        self.initialized = True
        self.initializations += 1
        self.read_outputs()

    def start_from(self, state: tuple, values: dict[str, Any] | None = None) -> None:
        """A table has no initialization to skip: a reset."""
        self.reset(values)

    def step(self, dt: float) -> bool:
        if dt != self.dt:
            self.origin, self.dt, self.steps = self.time, dt, 0
        self.steps += 1
        self.time = self.origin + self.steps * dt  # as an FMU's clock: no drift
        self.read_outputs()
        return False

    def read_outputs(self) -> None:
        started = _time.perf_counter_ns()
        t = self.time + self.offset
        for view, values in self._columns:
            view[...] = np.interp(t, self.data.times, values)
        self.fmu_time_ns += _time.perf_counter_ns() - started

    def save_state(self) -> tuple:
        """The table's clock and offset: all there is to its state."""
        return (self.time, self.origin, self.dt, self.steps, self.offset)

    def check_state(self, state: Any) -> None:
        if not (isinstance(state, tuple) and len(state) == 5):
            raise StateMismatchError(f"table {self.name!r}: not a table's saved state: {state!r}")

    def load_state(self, state: tuple, values: dict[str, Any] | None = None) -> None:
        self.check_state(state)
        self.time, self.origin, self.dt, self.steps, self.offset = state
        self.initialized = True
        self.read_outputs()

    def get_values(self, names: list[str]) -> dict[str, Any]:
        """The columns ``names`` now, and ``time_offset``."""
        t = self.time + self.offset
        return {name: self.offset if name == TIME_OFFSET else float(np.interp(t, self.data.times, self.data.columns[name]))
                for name in names}

    def close(self) -> None:
        """Nothing to free."""
