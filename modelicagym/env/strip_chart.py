"""The strip chart of an episode: an FMU's actions and observations over time, as an image.

Any `FMUEnv` made with ``render_mode="rgb_array"`` draws this (unless its class draws its own
picture, as the cart-pole does), so Gymnasium's ``RecordVideo`` works for any FMU; ``modelicagym
try`` saves the same chart as a PNG. A `StripChart` keeps, from the reset and after every step, the
time and the values in the FMU's input buffer (the actions as the FMU received them: a Discrete
action's row of ``action_table``, not its index) and output buffer (what observations are made
of), and, given them, a task's setpoints (each a dashed line over its output) and held inputs (a panel
each), and draws them: one panel per variable, named with its unit, time on the x axis; with more
than `MAX_PANELS` variables, one panel per role and unit holding up to `LINES_PER_PANEL` of them.

The drawing is matplotlib's (the ``plots`` extra, imported only when a chart is asked for): the
chart is worth its labels (names, units, tick values on a time axis), and labels need a font
renderer, which numpy alone does not have. Without matplotlib, asking for a chart is one
`ExtraNotInstalledError` line that says what to install.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from modelicagym.disk import atomic_write
from modelicagym.errors import ExtraNotInstalledError
from modelicagym.fmu import FMUInstance
from modelicagym.fmu.buffers import ValueBuffer
from modelicagym.fmu.variables import Variable

__all__ = ["LINES_PER_PANEL", "MAX_PANELS", "Series", "StripChart", "panels_of", "require_matplotlib"]

#: at most this many panels; more variables than this are grouped by role and unit
MAX_PANELS = 10
#: at most this many lines in a grouped panel
LINES_PER_PANEL = 6
# the frame, in pixels: 16 divides its sides (video codecs want that); margins fixed, not computed
# per frame by a layout engine (which costs more than the drawing)
_WIDTH, _PANEL_HEIGHT, _GAP, _DPI = 640, 100, 24, 80
_LEFT, _RIGHT, _TOP, _BOTTOM = 72, 14, 48, 44
#: the title names the variables left out when their names fit in this many characters
_NOTE_CHARS = 40
_COLOURS = {"action": "tab:orange", "observation": "tab:blue", "held input": "tab:gray"}
_PLOTTED_KINDS = ("float", "integer", "boolean", "enumeration")


def require_matplotlib() -> Any:
    """matplotlib's ``Figure`` and Agg canvas classes; an `ExtraNotInstalledError` without it."""
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError as error:
        raise ExtraNotInstalledError(
            "the strip chart (render_mode='rgb_array', modelicagym try) needs matplotlib: "
            "pip install 'modelicagym[plots]'"
        ) from error
    return Figure, FigureCanvasAgg


@dataclass(frozen=True)
class Series:
    """One line of the chart: a scalar variable, or one element of an array variable."""

    name: str
    unit: str
    role: str  # "action", "observation", "held input" or "setpoint"
    kind: str  # the variable's: "float", "integer", "boolean" or "enumeration"
    stepwise: bool = False  # held between recorded instants (an action, a discrete output): drawn as steps
    follows: str | None = None  # a setpoint's output: drawn dashed in that output's panel, not in one of its own

    @property
    def label(self) -> str:
        return f"{self.name} [{self.unit}]" if self.unit else self.name


def _series(v: Variable, role: str) -> list[Series]:
    """The lines of one variable: itself, or each element of an array (row-major, as its buffer)."""
    names = [v.name] if not v.shape else [f"{v.name}[{','.join(map(str, i))}]" for i in np.ndindex(*v.shape)]
    stepwise = role == "action" or v.variability != "continuous"
    return [Series(name, v.unit or "", role, v.kind, stepwise) for name in names]


def panels_of(series: Sequence[Series]) -> tuple[list[list[int]], list[int]]:
    """Which series each panel draws (indices into ``series``), and the series that do not fit.

    One panel per series when at most `MAX_PANELS`; else the series grouped by role, unit and kind
    (a count apart from a temperature in kelvin), `LINES_PER_PANEL` to a panel, and the panels past
    `MAX_PANELS` left out. Decided from the variables alone, so every frame has the same panels.
    A setpoint has no panel of its own (it is drawn in its output's).
    """
    own = [i for i, s in enumerate(series) if s.follows is None]
    if len(own) <= MAX_PANELS:
        return [[i] for i in own], []
    groups: dict[tuple[str, str], list[int]] = {}
    for i in own:
        s = series[i]
        groups.setdefault((s.role, s.unit, s.kind), []).append(i)
    panels = [members[k : k + LINES_PER_PANEL] for members in groups.values()
              for k in range(0, len(members), LINES_PER_PANEL)]
    return panels[:MAX_PANELS], [i for panel in panels[MAX_PANELS:] for i in panel]


class StripChart:
    """The actions and observations of one FMU instance over the current episode.

    Call :meth:`restart` after every reset and :meth:`record` after every step (`FMUEnv` does);
    :meth:`draw` returns the chart as an ``H x W x 3`` uint8 image, :meth:`save` writes it as a PNG.
    ``horizon`` (seconds, optional) fixes the time axis to the episode's length, so that frames
    of a video share their axis; without it the axis ends at the last recorded time.
    """

    def __init__(self, fmu: FMUInstance, title: str, horizon: float | None = None, extra: Sequence[Series] = (),
                 read_extra: Callable[[], Sequence[float]] | None = None) -> None:
        self._figure_class, self._canvas_class = require_matplotlib()
        self._fmu = fmu
        self.title = title
        self.horizon = horizon
        sources = [(fmu.inputs, v, "action") for v in fmu.input_variables] + [
            (fmu.outputs, v, "observation") for v in fmu.output_variables]
        plotted = [(buffer, v, role) for buffer, v, role in sources if v.kind in _PLOTTED_KINDS]
        self.series: list[Series] = [s for _, v, role in plotted for s in _series(v, role)] + list(extra)
        self._columns = self._column_slices(plotted)
        #: the values of ``extra`` (setpoints, held inputs) now, and where they go in a row
        self._read_extra, self._extra = read_extra, slice(1 + len(self.series) - len(extra), 1 + len(self.series))
        self._rows = np.zeros((64, 1 + len(self.series)))
        #: the names of the series the chart leaves out (more than `MAX_PANELS` panels would hold)
        self.left_out: list[str] = [self.series[i].name for i in panels_of(self.series)[1]]
        self.length = 0
        self._figure: Any = None

    @staticmethod
    def _column_slices(plotted: list[tuple[ValueBuffer, Variable, str]]) -> list[tuple[np.ndarray, slice]]:
        columns, offset = [], 1
        for buffer, v, _ in plotted:
            columns.append((buffer.views[v.name], slice(offset, offset + v.size)))
            offset += v.size
        return columns

    # -- the history -----------------------------------------------------------------------------

    def restart(self) -> None:
        """Forget the episode so far and record the instant the new one starts at."""
        self.length = 0
        self.record()

    def record(self) -> None:
        """Append the FMU's time, input values and output values as they are now."""
        if self.length == len(self._rows):
            self._rows = np.concatenate([self._rows, np.zeros_like(self._rows)])
        row = self._rows[self.length]
        row[0] = self._fmu.time
        for view, columns in self._columns:
            row[columns] = view.reshape(-1)
        if self._read_extra is not None:
            row[self._extra] = self._read_extra()
        self.length += 1

    @property
    def times(self) -> np.ndarray:
        """The recorded times, from the episode's start (s)."""
        return self._rows[: self.length, 0]

    @property
    def values(self) -> np.ndarray:
        """The recorded values, one column per entry of :attr:`series`."""
        return self._rows[: self.length, 1:]

    # -- the drawing -----------------------------------------------------------------------------

    def draw(self) -> np.ndarray:
        """The chart of the episode so far as an RGB image (``H x W x 3``, uint8)."""
        canvas = self._update()
        canvas.draw()
        return np.ascontiguousarray(np.asarray(canvas.buffer_rgba())[:, :, :3])

    def save(self, path: str | Path) -> Path:
        """Write the chart of the episode so far as a PNG at ``path`` (whole or not at all: a full
        disk is one `DiskFullError` naming it)."""
        canvas = self._update()
        with atomic_write(path, "wb", elsewhere="choose another file (try --out)") as f:
            canvas.print_png(f)
        return Path(path)

    def _update(self) -> Any:
        if self._figure is None:
            self._figure, self._canvas, self._axes, self._lines, self._note = self._build()
        times = self.times
        values = np.where(np.isfinite(self.values), self.values, np.nan)
        for line, column in self._lines:
            line.set_data(times, values[:, column])
        for axes in self._axes:
            axes.relim()
            axes.autoscale_view(scalex=False)
        start = times[0] if self.length else self._fmu.start_time
        end = max(start + (self.horizon or 0.0), times[-1] if self.length else start)
        self._axes[0].set_xlim(start, end if end > start else start + 1.0)
        steps = self.length - 1
        now = f"t = {times[-1]:g} s, {steps} step{'' if steps == 1 else 's'}" if self.length else "not reset yet"
        self._figure.suptitle(f"{self.title}: {now}{self._note}", fontsize=10, y=1 - 8 / self._height, va="top")
        return self._canvas

    def _build(self) -> tuple[Any, Any, list[Any], list[tuple[Any, int]], str]:
        panels, left_out = panels_of(self.series)
        n = max(len(panels), 1)
        height = _TOP + _BOTTOM + _PANEL_HEIGHT * n
        height += -height % 16
        self._height = height
        figure = self._figure_class(figsize=(_WIDTH / _DPI, height / _DPI), dpi=_DPI)
        canvas = self._canvas_class(figure)
        axes_height = (height - _TOP - _BOTTOM - (n - 1) * _GAP) / n
        figure.subplots_adjust(left=_LEFT / _WIDTH, right=1 - _RIGHT / _WIDTH, top=1 - _TOP / height,
                               bottom=_BOTTOM / height, hspace=_GAP / axes_height)
        axes = list(figure.subplots(n, 1, sharex=True, squeeze=False)[:, 0])
        lines = []
        for ax, members in zip(axes, panels):
            grouped = len(members) > 1 or len(self.series) > MAX_PANELS
            colours = itertools.cycle(f"C{i}" for i in range(10))
            for column in members:
                s = self.series[column]
                (line,) = ax.plot([], [], drawstyle="steps-pre" if s.stepwise else "default",
                                  color=next(colours) if grouped else _COLOURS[s.role], label=s.name, linewidth=1.2)
                lines.append((line, column))
            first = self.series[members[0]]
            if grouped:
                kind = "" if first.kind == "float" else f" ({first.kind})"
                unit = f" [{first.unit}]" if first.unit else ""
                ax.set_title(f"{first.role}s{unit}{kind}", loc="right", fontsize=8)
                ax.legend(loc="upper left", fontsize=7, ncols=min(len(members), 3), frameon=False)
            else:
                ax.set_title(f"{first.role}: {first.label}", loc="right", fontsize=8)
            for column, reference in enumerate(self.series):
                if reference.follows is not None and any(self.series[m].name == reference.follows for m in members):
                    (line,) = ax.plot([], [], color="black", linestyle="--", linewidth=1.0, label=reference.name)
                    lines.append((line, column))
                    ax.legend(loc="upper left", fontsize=7, frameon=False)
            ax.tick_params(labelsize=7)
            ax.grid(True, linewidth=0.4, alpha=0.5)
        axes[-1].set_xlabel("time [s]", fontsize=8)
        note = ""
        if left_out:
            names = ", ".join(self.left_out)
            note = f" (not drawn: {names})" if len(names) <= _NOTE_CHARS else f" ({len(left_out)} variables not drawn)"
        return figure, canvas, axes, lines, note
