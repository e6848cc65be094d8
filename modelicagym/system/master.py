"""The master algorithm: a system of components stepped as one instance, in the shape of
`FMUInstance` (``inputs``/``outputs`` buffers, ``reset``, ``step``, saved states), so `FMUEnv`
drives a system as it drives one FMU.

Fixed-step co-simulation, stated once. The env's step ``dt`` is ``substeps`` communication steps
of ``h = dt / substeps``. The action's values go to their components' inputs before the first.
In each communication step from ``t`` to ``t + h``:

* ``"gauss-seidel"`` (default): the components step one after another in `stepping_order`
  (sources first); just before a component steps, each connection into it copies its source's
  output, converted, into the input. A source stepped before it gives its value at ``t + h``, one
  after it (a feedback through a state) its value at ``t``.
* ``"jacobi"``: every connection copies its source's output at ``t`` first; then every component
  steps (in the same order; each sees only values at ``t``).

A loop of direct feedthrough is read with a one-step delay where the master reads its connections
from ``t`` (`modelicagym.system.loops`); after every communication step, `LoopGuard` checks each
value a loop carries from the previous step and raises `LoopDivergedError` when one diverged.

Each FMU steps as it would alone (`FMUInstance.step`: co-simulation's doStep, model exchange's
solver over ``h``; FMI 1.0, 2.0 and 3.0 mixed); a table moves to ``t + h``. After a reset (each
component initialized with its parameters) the connections are copied once in that order, each
component's inputs written and its outputs read again, so the first observation is consistent
with the connections (an FMU whose discrete inputs are set in event mode only takes them at the
first step). The observation is read after the last communication step. The system ends its
episode when one of its FMUs does.

The native step path runs the same algorithm in C (``advance_system`` in
``modelicagym/native/csrc/step.c``, over the moves listed here: ``action_moves``, ``link_moves``,
``output_moves``, ``guard``; `modelicagym.env.native_system`), with the same results bit for bit.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from modelicagym.errors import ConfigError, LoopDivergedError
from modelicagym.fmu.buffers import start_at
from modelicagym.fmu.clock import OnClock, StepClock
from modelicagym.fmu.errors import StateMismatchError
from modelicagym.fmu.instance import FMUInstance
from modelicagym.system.buffers import Values
from modelicagym.system.description import MASTERS, SystemDescription
from modelicagym.system.graph import Link
from modelicagym.system.loops import LoopGuard
from modelicagym.system.saved_state import SystemState
from modelicagym.system.table import TableInstance


def _unique(names: list[str]) -> list[str]:
    return list(dict.fromkeys(names))


class SystemInstance:
    """A live system: one `FMUInstance` per FMU (a `TableInstance` per table), stepped by the
    master algorithm of the module docstring. Its time bookkeeping lives in ``self.clock``, the C
    struct the native step path writes too (`modelicagym.fmu.clock`), as an FMU instance's.

    Parameters:
        description: the system (`open_system`).
        inputs / outputs: ``component.variable`` names bound to ``self.inputs`` / ``self.outputs``.
        start_time: default: the system's (its SSP's, else its first FMU's).
        master: ``"gauss-seidel"`` or ``"jacobi"``.
        substeps: communication steps per ``step``.
        mode: the mode of every FMU whose component names none; None: each FMU's default.
        **options: the rest of `FMUInstance`'s options, for every FMU.
    """

    time = OnClock()
    start_time = OnClock()
    steps = OnClock()
    _origin = OnClock()
    _dt = OnClock()

    def __init__(self, description: SystemDescription, *, inputs: Sequence[str] = (), outputs: Sequence[str] = (),
                 start_time: float | None = None, master: str = "gauss-seidel", substeps: int = 1,
                 mode: str | None = None, step_size: float | None = None, **options: Any):
        if master not in MASTERS:
            raise ConfigError(f"master must be one of {MASTERS}, got {master!r}")
        if isinstance(substeps, bool) or not isinstance(substeps, int) or substeps < 1:
            raise ConfigError(f"substeps must be a positive integer, got {substeps!r}")
        if master == "jacobi" and description.loop_breaks:
            raise ConfigError(f"{description.name}: loop_breaks chooses where Gauss-Seidel reads a loop from the "
                              "previous step; jacobi reads every connection from the previous step: drop loop_breaks "
                              "or use master='gauss-seidel'")
        self.description = description
        self.clock = StepClock()
        self.master, self.substeps = master, substeps
        self.input_variables = [description.input_variable(n) for n in inputs]
        self.output_variables = [description.observable_variable(n) for n in outputs]
        self.start_time = description.default_experiment.start_time if start_time is None else float(start_time)
        wanted_in: dict[str, list[str]] = {name: [] for name in description.components}
        wanted_out: dict[str, list[str]] = {name: [] for name in description.components}
        for link in description.links:
            wanted_out[link.source].append(link.source_variable)
            wanted_in[link.target].append(link.target_variable)
        for variable in self.input_variables:
            for target, _ in description.feeds(variable.name):
                component, local = description.split(target)
                wanted_in[component].append(local)
        for variable in self.output_variables:
            component, local = description.split(description.reads(variable.name)[0])
            wanted_out[component].append(local)
        self.components: dict[str, FMUInstance | TableInstance] = {}
        try:
            for name, component in description.components.items():
                if component.table is not None:
                    self.components[name] = TableInstance(component.table, name, _unique(wanted_out[name]),
                                                          self.start_time)
                else:
                    self.components[name] = FMUInstance(
                        component.description, mode=component.mode or mode, inputs=_unique(wanted_in[name]),
                        outputs=_unique(wanted_out[name]), start_time=self.start_time, instance_name=name,
                        step_size=None if step_size is None else step_size / substeps, **options)
        except BaseException:
            self.close()
            raise
        self.inputs = Values(self.input_variables)
        # an FMU's inputs start at their declared start values; those the SSP gives a value, at that
        self.start_inputs_at({name: description.variables[name].start for name in description.parameter_values
                              if description.variables[name].is_input and not description.variables[name].shape})
        self.outputs = Values(self.output_variables)
        # what a step copies (the native path copies the same, `modelicagym.env.native_system`):
        # the action's values to the components (an input connector's to every input it feeds), the
        # connections (in description.links order), the components' outputs to the system's; each
        # ``(target view, source view, scale, shift)``, and ``action_components``: whose input each action move sets
        feeds = [(v.name, target, convert) for v in self.input_variables
                 for target, convert in description.feeds(v.name)]
        self.action_moves = [(self._view(target, "inputs"), self.inputs.views[name], convert.scale, convert.shift)
                             for name, target, convert in feeds]
        self.action_components = [description.split(target)[0] for _, target, _ in feeds]
        self.output_moves = [(self.outputs.views[v.name], self._view(source, "outputs"), convert.scale, convert.shift)
                             for v in self.output_variables for source, convert in [description.reads(v.name)]]
        self._order = [(self.components[name], self._moves(link for link in description.links if link.target == name))
                       for name in description.order]
        self.link_moves = self._moves(description.links)
        #: the values each loop carries from the previous step, checked after every communication step
        self.guard = LoopGuard(description.name, master, [
            (loop, link, self.components[link.source].outputs.views[link.source_variable])
            for loop in description.loops for link in loop.delayed(master)
            if description.variables[f"{link.source}.{link.source_variable}"].kind == "float"])
        self.time = self.start_time
        self._origin, self._dt, self.steps = self.start_time, 0.0, 0

    def start_inputs_at(self, values: Mapping[str, Any]) -> None:
        """Start the system's inputs ``values`` names at those values in every episode: an input
        connector's, and the inputs of its components it feeds (its transformation applied); a
        component's input, in the component."""
        start_at(self.inputs, values)
        fed: dict[str, dict[str, Any]] = {}
        for name, value in values.items():
            for target, convert in self.description.feeds(name):
                component, local = self.description.split(target)
                fed.setdefault(component, {})[local] = convert.scale * value + convert.shift if not convert.identity \
                    else value
        for component, starts in fed.items():
            start_at(self.components[component].inputs, starts)

    def _view(self, name: str, side: str) -> np.ndarray:
        component, local = self.description.split(name)
        return getattr(self.components[component], side).views[local]

    def _moves(self, links: Iterable[Link]) -> list[tuple[np.ndarray, np.ndarray, float, float]]:
        """``(target view, source view, scale, shift)`` per link."""
        return [(self.components[link.target].inputs.views[link.target_variable],
                 self.components[link.source].outputs.views[link.source_variable],
                 link.conversion.scale, link.conversion.shift) for link in links]

    @staticmethod
    def _copy(moves: list[tuple[np.ndarray, np.ndarray, float, float]]) -> None:
        for target, source, scale, shift in moves:
            if scale == 1.0 and shift == 0.0:
                target[...] = source
            else:
                target[...] = scale * source + shift

    # -- what FMUEnv calls -----------------------------------------------------------------------

    @property
    def fmu_name(self) -> str:
        return self.description.name

    @property
    def fmu_time_ns(self) -> int:
        """Nanoseconds spent in the components' steps, cumulative."""
        return sum(component.fmu_time_ns for component in self.components.values())

    @property
    def initialized(self) -> bool:
        return all(component.initialized for component in self.components.values())

    @property
    def initializations(self) -> int:
        """How many times the components' own initialization ran (the most of any component)."""
        return max(component.initializations for component in self.components.values())

    @property
    def terminated(self) -> bool:
        return any(component.terminated for component in self.components.values())

    #: a system takes its inputs as values between steps, never in an event mode of its own
    event_mode_inputs = False

    def python_step_reason(self) -> str | None:
        """Why this system cannot step in C (`modelicagym.env.native_step`), or None: a model
        exchange component whose solver loop is Python's."""
        for name, component in self.components.items():
            if isinstance(component, FMUInstance) and component.mode == "me" and component.integrator_path != "native":
                return f"component {name!r} is model exchange with its solver loop in Python: " \
                       f"{component.integrator_path_reason}"
        return None

    def step(self, dt: float) -> bool:
        """Advance the system by ``dt`` (see the module docstring); True if an FMU ended the episode.
        An FMU's failure (`FMUCallError`) propagates: the env truncates the episode, and the next
        reset re-instantiates the failed FMU. A diverged loop raises `LoopDivergedError`."""
        if dt != self._dt:
            self._origin, self._dt, self.steps = self.time, dt, 0
        self._copy(self.action_moves)
        h = dt / self.substeps
        gauss_seidel = self.master == "gauss-seidel"
        ended = False
        for _ in range(self.substeps):
            if not gauss_seidel:
                self._copy(self.link_moves)
            for component, moves in self._order:
                if gauss_seidel:
                    self._copy(moves)
                ended = component.step(h) or ended
            failed = self.guard.first_failure()
            if failed is not None:
                raise self.loop_error(failed)
            if ended:
                break
        self.steps += 1
        self.time = self._origin + self.steps * dt
        self._copy(self.output_moves)
        return ended

    def loop_error(self, k: int) -> LoopDivergedError:
        """The `LoopDivergedError` of the guard's connection ``k``, at its source's time."""
        return self.guard.error(k, self.components[self.guard.links[k].source].time)

    def reset(self, values: Mapping[str, Any] | None = None) -> None:
        """Start every component at ``start_time`` with the system's parameter values (its SSP's)
        updated by ``values`` (``component.variable``), then settle the connections once."""
        split = self.split_values(values)
        for name, component in self.components.items():
            component.reset(split[name])
        self._started()

    def start_from(self, state: SystemState, values: Mapping[str, Any] | None = None) -> None:
        """The pool's ``init="once"``: every component starts from its part of ``state`` (saved right
        after another instance's reset with the same ``values``) instead of its initialization."""
        self.check_state(state)
        split = self.split_values(values)
        for name, component in self.components.items():
            component.start_from(state.components[name], split[name])
        self._started()

    def split_values(self, values: Mapping[str, Any] | None) -> dict[str, dict[str, Any]]:
        """``{component: {variable: value}}`` of the SSP's values updated by ``values`` (a value of
        the system's input connector goes to every input it feeds, converted)."""
        split: dict[str, dict[str, Any]] = {name: {} for name in self.components}
        for name, value in {**self.description.parameter_values, **(values or {})}.items():
            self.description.settable_variable(name)
            for target, convert in self.description.feeds(name):
                component, local = self.description.split(target)
                split[component][local] = value if convert.identity else convert.scale * value + convert.shift
        return split

    def _started(self) -> None:
        self.time, self._origin, self._dt, self.steps = self.start_time, self.start_time, 0.0, 0
        self.inputs.fill_start_values()
        for component, moves in self._order:
            self._copy(moves)
            if moves and isinstance(component, FMUInstance) and not component.event_mode_inputs:
                component.inputs.check(component.inputs.write(), "set inputs")
                component.read_outputs()
        self._copy(self.output_moves)

    def read_outputs(self) -> None:
        for component in self.components.values():
            component.read_outputs()
        self._copy(self.output_moves)

    def save_state(self) -> SystemState:
        """Every component's state and the system's clock, as a picklable value (`load_state`)."""
        return SystemState(self.description.name, {name: c.save_state() for name, c in self.components.items()},
                           self.time, self.steps, self._origin, self._dt)

    def check_state(self, state: SystemState) -> None:
        """Refuse, changing nothing, a state `load_state` would refuse."""
        if not isinstance(state, SystemState):
            raise StateMismatchError(f"{self.description.name}: not a system's saved state: {type(state).__name__}")
        state.check_fits(self.description.name, list(self.components))
        for name, component in self.components.items():
            component.check_state(state.components[name])

    def load_state(self, state: SystemState, values: Mapping[str, Any] | None = None) -> None:
        """Put back a state `save_state` gave: every component's, and the system's clock."""
        self.check_state(state)
        split = self.split_values(values)
        for name, component in self.components.items():
            component.load_state(state.components[name], split[name])
        self.time, self.steps, self._origin, self._dt = state.time, state.steps, state.origin, state.dt
        self._copy(self.output_moves)

    def get_values(self, names: Sequence[str]) -> dict[str, Any]:
        """Read ``component.variable`` values by name (slow path, for inspection); a system's output
        connector reads what it connects to, an input connector that is an action holds the action's value."""
        values = {}
        for name in names:
            if name in self.description.connectors and name in self.inputs.views:
                values[name] = self.inputs.views[name].copy() if self.inputs.views[name].shape else \
                    self.inputs.views[name].item()
                continue
            source, convert = self.description.reads(name)
            component, local = self.description.split(source)
            value = self.components[component].get_values([local])[local]
            values[name] = value if convert.identity else convert.scale * value + convert.shift
        return values

    def close(self) -> None:
        """Free every component. Safe to call twice."""
        for component in getattr(self, "components", {}).values():
            component.close()


def new_instance(description: Any, *, master: str = "gauss-seidel", substeps: int = 1,
                 **options: Any) -> FMUInstance | SystemInstance:
    """An instance of ``description``: a `SystemInstance` for a system, else an `FMUInstance`
    (``master`` and ``substeps`` are a system's: one FMU refuses other values than the defaults)."""
    if isinstance(description, SystemDescription):
        return SystemInstance(description, master=master, substeps=substeps, **options)
    if master != "gauss-seidel" or substeps != 1:
        raise ConfigError(f"{description.name}: 'master' and 'substeps' are a system's options (give 'fmus' and "
                          "'connections', or an SSP system), not one FMU's")
    return FMUInstance(description, **options)
