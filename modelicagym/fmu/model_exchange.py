"""Advance a model-exchange FMU from t to t + dt, with a real solver and event handling.

A model-exchange FMU only evaluates derivatives; the importer integrates. This follows the loop
of ``fmpy.simulation.simulateME``: integrate with CVode (variable step, root finding on the event
indicators; `modelicagym.fmu.cvode`) or a fixed-step scheme (forward Euler, classical Runge-Kutta;
`modelicagym.fmu.fixed_step`), stop at time events (``nextEventTime``), state events (event-indicator
roots) and step events (``fmiCompletedIntegratorStep``), run the event iteration, and carry on.

Inputs are piecewise constant between calls, so CVode restarts after new input values (a multistep
solver must not carry history across an input jump), and after events; otherwise it goes on.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from modelicagym.errors import ConfigError
from modelicagym.fmu.binding import FMIBinding
from modelicagym.fmu.cvode import CVodeSolver
from modelicagym.fmu.errors import FMUError
from modelicagym.fmu.fixed_step import ForwardEuler, RungeKutta4

SOLVERS = ("cvode", "cvode-bdf", "euler", "rk4")
#: solver name -> its fixed-step scheme (these need a ``step_size``)
FIXED_STEP_SOLVERS = {"euler": ForwardEuler, "rk4": RungeKutta4}
#: ``solver="cvode"``: this many fixed-point convergence failures between two restarts mark the
#: model stiff. A non-stiff model has none (the cart-pole: 0 in 300 steps), a stiff one has them at
#: once (eigenvalue -1e4, steps of 0.01 s: 15-30 per step). ``native/csrc/integrator.c`` agrees.
STIFF_CONVERGENCE_FAILURES = 10


def _close(a: float, b: float) -> bool:
    return math.isclose(a, b, rel_tol=1e-12, abs_tol=1e-12)


class ModelExchangeIntegrator:
    """Integrates one model-exchange instance between communication points.

    ``solver="cvode"`` (default) runs CVode's Adams method until the model proves stiff, then BDF
    (from the next `advance` on); ``"cvode-bdf"`` runs BDF throughout, as fmpy does; both with
    relative tolerance ``tolerance``. ``solver="euler"`` (forward Euler) and ``"rk4"`` (classical
    Runge-Kutta) take fixed steps of ``step_size``.
    The native integrator (`modelicagym.fmu.native_integrator`) runs the same algorithms in C.
    """

    def __init__(
        self,
        binding: FMIBinding,
        n_states: int,
        n_indicators: int,
        needs_completed_integrator_step: bool,
        solver: str = "cvode",
        tolerance: float = 1e-10,
        step_size: float | None = None,
    ):
        if solver not in SOLVERS:
            raise ConfigError(f"solver must be one of {SOLVERS}, got {solver!r}")
        if solver in FIXED_STEP_SOLVERS and not step_size:
            raise ConfigError(f"solver={solver!r} needs a step_size (the fixed integration step)")
        self.binding = binding
        self.n_states = n_states
        self.n_indicators = n_indicators
        self.needs_completed_integrator_step = needs_completed_integrator_step
        self.solver_name = solver
        self.tolerance = tolerance
        self.step_size = step_size
        self.next_event_time: float | None = None
        self.stiff = False
        #: CVode may go on where the last advance left off: nothing changed the model since. The
        #: caller clears it when it writes new input values; `event` and failures clear it too.
        self.continuous = False
        self._solver: Any = None

    def start(self, time: float) -> bool:
        """After ``exitInitializationMode``: settle the initial events and set up the solver.

        Returns True if the model asked to terminate already.
        """
        if self._event_iteration():
            return True
        self.binding.enter_continuous_time_mode()
        self._make_solver(time)
        return False

    def restart(self, time: float, next_event_time: float | None) -> None:
        """After the FMU's state was restored from a snapshot taken right after `start`;
        ``next_event_time`` is the one `start` left (the FMU announces it only in event mode)."""
        self.next_event_time = next_event_time
        self._make_solver(time)

    @property
    def method(self) -> str | None:
        """CVode's method, ``"adams"`` or ``"bdf"``; ``None`` for Euler."""
        if self.solver_name in FIXED_STEP_SOLVERS:
            return None
        return "adams" if self.solver_name == "cvode" and not self.stiff else "bdf"

    def _make_solver(self, time: float) -> None:
        self.close()
        f = self.binding.continuous_state_functions()
        self._set_time = f["set_time"]
        args = dict(nx=self.n_states, nz=self.n_indicators, get_x=f["get_x"], set_x=f["set_x"],
                    get_dx=f["get_dx"], get_z=f["get_z"])
        if self.method is None:
            self._solver = FIXED_STEP_SOLVERS[self.solver_name](set_time=self._set_time, **args)
        else:
            self._solver = CVodeSolver(get_nominals=f["get_nominals"], set_time=self._set_time, start_time=time,
                                       tolerance=self.tolerance, method=self.method, **args)
            self.continuous = True

    def advance(self, time: float, stop: float) -> bool:
        """Integrate from ``time`` to ``stop``; returns True if the model asked to terminate."""
        if self.method is not None and self._solver.method != self.method:
            self._make_solver(time)  # the model proved stiff: BDF from here on
        elif not self.continuous:
            self._solver.reset(time)
        self.continuous = False
        solver = self._solver
        while time < stop and not _close(time, stop):
            target = stop
            if self.next_event_time is not None and time < self.next_event_time < target:
                target = self.next_event_time
            if self.step_size and time + self.step_size < target and not _close(time + self.step_size, target):
                target = time + self.step_size  # a step that lands within rounding of the target takes the target
            try:
                state_event, _, time = solver.step(time, target)
            except RuntimeError as error:
                raise FMUError(f"{self.binding.fmu_name}: the {self.solver_name} solver failed at t={time}: {error}") from error
            if self.method == "adams" and solver.convergence_failures() >= STIFF_CONVERGENCE_FAILURES:
                self.stiff = True
            self._set_time(time)
            step_event = False
            if self.needs_completed_integrator_step:
                step_event, terminate = self.binding.completed_integrator_step()
                if terminate:
                    return True
            time_event = self.next_event_time is not None and _close(time, self.next_event_time)
            if state_event or step_event or time_event:
                self.binding.enter_event_mode()
                if self._event_iteration():
                    return True
                self.binding.enter_continuous_time_mode()
                solver.reset(time)
        self.continuous = self.method is not None
        return False

    def event(self, time: float, apply: Callable[[], None]) -> bool:
        """Enter event mode at ``time``, call ``apply()`` (which sets discrete inputs or tunable
        parameters: FMI allows those in event mode only), settle the event iteration and return to
        continuous-time mode. Returns True if the model asked to terminate."""
        self.continuous = False
        self._set_time(time)
        self.binding.enter_event_mode()
        apply()
        if self._event_iteration():
            return True
        self.binding.enter_continuous_time_mode()
        return False

    def close(self) -> None:
        """Release the solver."""
        if isinstance(self._solver, CVodeSolver):
            self._solver.close()
        self._solver = None

    def _event_iteration(self) -> bool:
        """Update discrete states until they settle; True if the model asked to terminate."""
        needs_update = True
        while needs_update:
            needs_update, terminate, _, self.next_event_time = self.binding.update_discrete_states()
            if terminate:
                return True
        return False
