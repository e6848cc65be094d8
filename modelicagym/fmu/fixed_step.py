"""Fixed-step schemes over an FMU's continuous states, for the Python model-exchange loop.

* `ForwardEuler`: fmpy's forward Euler, step for step;
* `RungeKutta4`: the classical Runge-Kutta method, written as the FMU framework's own
  (``models/csrc/fmu_solver.c``): model exchange at a co-simulation FMU's internal step gives
  its numbers.

Neither locates events: a state event happens at the end of the step whose event indicators
changed sign, as in fmpy. ``native/csrc/integrator.c`` runs the same arithmetic in the same
order, so both paths give the same numbers to the last bit.
"""

from __future__ import annotations

from collections.abc import Callable
from ctypes import c_double
from typing import Any

__all__ = ["FixedStepSolver", "ForwardEuler", "RungeKutta4"]


class FixedStepSolver:
    """One step from ``time`` to ``target``, then the event indicators compared with the step's start.

    The callables are the FMU's ``(pointer, n)`` calls and ``set_time(t)``
    (`FMIBinding.continuous_state_functions`), which raise on a failing status.
    """

    #: state-sized work arrays a step needs besides ``x`` and ``dx``
    WORK_ARRAYS = 0

    def __init__(self, nx: int, nz: int, get_x: Callable[..., int], set_x: Callable[..., int],
                 get_dx: Callable[..., int], get_z: Callable[..., int], set_time: Callable[[float], int]):
        self.nx, self.nz = nx, nz
        self._get_x, self._set_x, self._get_dx, self._get_z, self._set_time = get_x, set_x, get_dx, get_z, set_time
        self.x, self.dx = (c_double * max(nx, 1))(), (c_double * max(nx, 1))()
        self.z = (c_double * max(nz, 1))()
        self.work = [(c_double * max(nx, 1))() for _ in range(self.WORK_ARRAYS)]
        self.roots = [0] * nz
        get_z(self.z, nz)

    def _advance(self, time: float, target: float) -> None:
        """Move the FMU's states from ``time`` to ``target``."""
        raise NotImplementedError

    def step(self, time: float, target: float) -> tuple[bool, list[int], float]:
        """Integrate to ``target``; returns (a state event happened, the roots, ``target``)."""
        self._advance(time, target)
        previous = self.z[:self.nz]
        self._get_z(self.z, self.nz)
        z = self.z
        self.roots = [-1 if p < 0 and z[k] >= 0 else 1 if p > 0 and z[k] <= 0 else 0 for k, p in enumerate(previous)]
        return any(self.roots), self.roots, target

    def reset(self, time: float) -> None:
        """A fixed-step scheme keeps no history: nothing to restart."""


class ForwardEuler(FixedStepSolver):
    """x(t + h) = x(t) + h f(t, x(t))."""

    def _advance(self, time: float, target: float) -> None:
        x, dx, nx = self.x, self.dx, self.nx
        self._get_x(x, nx)
        self._get_dx(dx, nx)
        h = target - time
        for k in range(nx):
            x[k] += h * dx[k]
        self._set_x(x, nx)


class RungeKutta4(FixedStepSolver):
    """The classical fourth-order Runge-Kutta step."""

    WORK_ARRAYS = 4  # k2, k3, k4, and the states of a stage

    def _derivatives_at(self, t: float, x: Any, k: Any) -> None:
        self._set_time(t)
        self._set_x(x, self.nx)
        self._get_dx(k, self.nx)

    def _advance(self, time: float, target: float) -> None:
        x0, k1, nx = self.x, self.dx, self.nx
        k2, k3, k4, xt = self.work
        h = target - time
        middle = time + 0.5 * h
        self._get_x(x0, nx)
        self._get_dx(k1, nx)
        for k in range(nx):
            xt[k] = x0[k] + 0.5 * h * k1[k]
        self._derivatives_at(middle, xt, k2)
        for k in range(nx):
            xt[k] = x0[k] + 0.5 * h * k2[k]
        self._derivatives_at(middle, xt, k3)
        for k in range(nx):
            xt[k] = x0[k] + h * k3[k]
        self._derivatives_at(target, xt, k4)
        for k in range(nx):
            xt[k] = x0[k] + h / 6.0 * (k1[k] + 2.0 * k2[k] + 2.0 * k3[k] + k4[k])
        self._set_x(xt, nx)
