"""CVode over an FMU's continuous states, for the Python model-exchange loop.

It calls the binaries the C loop calls (the SUNDIALS 7 libraries fmpy ships), set up the same way,
so a solver gives the same numbers on either path:

* ``method="adams"``: Adams-Moulton with a fixed-point iteration, which needs no Jacobian and suits
  the non-stiff models most RL environments are;
* ``method="bdf"``: BDF with Newton's method and a dense linear solver, as fmpy's ``CVodeSolver``.

Absolute tolerances are the states' nominal values times the relative tolerance, as in fmpy.
(fmpy's own ``CVodeSolver`` offers BDF only and frees none of its vectors, hence this module.)
"""

from __future__ import annotations

import ctypes
import functools
from collections.abc import Callable
from ctypes import POINTER, c_double, c_int, c_int64, c_long, c_void_p
from typing import Any

#: the most internal steps CVode may take towards one target
MAX_NUM_STEPS = 100_000

_ADAMS, _BDF, _NORMAL = 1, 2, 1
_RHS = ctypes.CFUNCTYPE(c_int, c_double, c_void_p, c_void_p, c_void_p)
_ROOTS = ctypes.CFUNCTYPE(c_int, c_double, c_void_p, POINTER(c_double), c_void_p)
_ERRORS = ctypes.CFUNCTYPE(None, c_int, ctypes.c_char_p, ctypes.c_char_p, ctypes.c_char_p, c_int, c_void_p, c_void_p)

#: function -> (library, result type, argument types); fresh prototypes, so fmpy's own are untouched
_SIGNATURES: dict[str, tuple[str, Any, tuple[Any, ...]]] = {
    "SUNContext_Create": ("sundials_core", c_int, (c_int, POINTER(c_void_p))),
    "SUNContext_Free": ("sundials_core", c_int, (POINTER(c_void_p),)),
    "SUNContext_ClearErrHandlers": ("sundials_core", c_int, (c_void_p,)),
    "SUNContext_PushErrHandler": ("sundials_core", c_int, (c_void_p, _ERRORS, c_void_p)),
    "N_VNew_Serial": ("sundials_nvecserial", c_void_p, (c_int64, c_void_p)),
    "N_VDestroy": ("sundials_core", None, (c_void_p,)),
    "N_VGetArrayPointer": ("sundials_core", POINTER(c_double), (c_void_p,)),
    "SUNDenseMatrix": ("sundials_sunmatrixdense", c_void_p, (c_int64, c_int64, c_void_p)),
    "SUNMatDestroy": ("sundials_core", None, (c_void_p,)),
    "SUNLinSol_Dense": ("sundials_sunlinsoldense", c_void_p, (c_void_p, c_void_p, c_void_p)),
    "SUNLinSolFree": ("sundials_core", c_int, (c_void_p,)),
    "SUNNonlinSol_FixedPoint": ("sundials_cvode", c_void_p, (c_void_p, c_int, c_void_p)),
    "SUNNonlinSolFree": ("sundials_core", c_int, (c_void_p,)),
    "CVodeCreate": ("sundials_cvode", c_void_p, (c_int, c_void_p)),
    "CVodeInit": ("sundials_cvode", c_int, (c_void_p, _RHS, c_double, c_void_p)),
    "CVodeReInit": ("sundials_cvode", c_int, (c_void_p, c_double, c_void_p)),
    "CVodeSVtolerances": ("sundials_cvode", c_int, (c_void_p, c_double, c_void_p)),
    "CVodeRootInit": ("sundials_cvode", c_int, (c_void_p, c_int, _ROOTS)),
    "CVodeSetLinearSolver": ("sundials_cvode", c_int, (c_void_p, c_void_p, c_void_p)),
    "CVodeSetNonlinearSolver": ("sundials_cvode", c_int, (c_void_p, c_void_p)),
    "CVodeSetMaxNumSteps": ("sundials_cvode", c_int, (c_void_p, c_long)),
    "CVodeSetNoInactiveRootWarn": ("sundials_cvode", c_int, (c_void_p,)),
    "CVode": ("sundials_cvode", c_int, (c_void_p, c_double, c_void_p, POINTER(c_double), c_int)),
    "CVodeGetRootInfo": ("sundials_cvode", c_int, (c_void_p, POINTER(c_int))),
    "CVodeGetNumNonlinSolvConvFails": ("sundials_cvode", c_int, (c_void_p, POINTER(c_long))),
    "CVodeFree": ("sundials_cvode", None, (POINTER(c_void_p),)),
}


@functools.cache
def _sundials() -> Any:
    """The functions of `_SIGNATURES`, as attributes of one namespace."""
    from fmpy.sundials import libraries

    functions = {name: ctypes.CFUNCTYPE(restype, *argtypes)((name, getattr(libraries, library)))
                 for name, (library, restype, argtypes) in _SIGNATURES.items()}
    return type("Sundials", (), functions)


class CVodeSolver:
    """One CVode integrator over an FMU's continuous states, with root finding on its event indicators.

    The callables are the FMU's ``(pointer, n)`` calls (`FMIBinding.continuous_state_functions`).
    `step` raises ``RuntimeError`` with CVode's message when the solver fails, and the error of
    the FMU's call when one of them failed inside the right-hand side or root function.
    """

    def __init__(
        self,
        nx: int,
        nz: int,
        get_x: Callable[..., int],
        set_x: Callable[..., int],
        get_dx: Callable[..., int],
        get_z: Callable[..., int],
        get_nominals: Callable[..., int],
        set_time: Callable[[float], int],
        start_time: float,
        tolerance: float,
        method: str = "bdf",
    ):
        self.sun = sun = _sundials()
        if method not in ("adams", "bdf"):
            raise ValueError(f"method must be 'adams' or 'bdf', got {method!r}")
        self.nx, self.nz, self.method = nx, nz, method
        self._get_x, self._set_x, self._get_dx, self._get_z, self._set_time = get_x, set_x, get_dx, get_z, set_time
        self.error: str | None = None
        self.failure: Exception | None = None
        self.roots = (c_int * max(nz, 1))()
        self._context = c_void_p()
        self._cvode = self._y = self._abstol = self._matrix = self._linear_solver = self._nonlinear_solver = None
        # the callbacks live as long as the solver: CVode holds their addresses
        self._callbacks = (_RHS(self._rhs), _ROOTS(self._roots_at), _ERRORS(self._on_error))
        n = max(nx, 1)  # a model without states: CVode integrates one dummy state
        if sun.SUNContext_Create(0, ctypes.byref(self._context)):
            raise RuntimeError("SUNContext_Create failed")
        sun.SUNContext_ClearErrHandlers(self._context)  # no printing to stderr: the message goes into the error
        sun.SUNContext_PushErrHandler(self._context, self._callbacks[2], None)
        self._y, self._abstol = sun.N_VNew_Serial(n, self._context), sun.N_VNew_Serial(n, self._context)
        self._cvode = sun.CVodeCreate(_ADAMS if method == "adams" else _BDF, self._context)
        self._y_data = sun.N_VGetArrayPointer(self._y)
        self._read_states()
        abstol = sun.N_VGetArrayPointer(self._abstol)
        if nx == 0:
            abstol[0] = 1.0
        else:
            get_nominals(abstol, nx)
        for k in range(n):
            abstol[k] *= tolerance
        if (sun.CVodeInit(self._cvode, self._callbacks[0], start_time, self._y)
                or sun.CVodeSVtolerances(self._cvode, tolerance, self._abstol)
                or sun.CVodeRootInit(self._cvode, nz, self._callbacks[1])
                or self._attach_solvers(n)
                or sun.CVodeSetMaxNumSteps(self._cvode, MAX_NUM_STEPS)
                or sun.CVodeSetNoInactiveRootWarn(self._cvode)):
            self.close()
            raise RuntimeError(f"setting up CVode failed: {self.error}")

    def _attach_solvers(self, n: int) -> int:
        sun = self.sun
        if self.method == "adams":
            self._nonlinear_solver = sun.SUNNonlinSol_FixedPoint(self._y, 0, self._context)
            return sun.CVodeSetNonlinearSolver(self._cvode, self._nonlinear_solver)
        self._matrix = sun.SUNDenseMatrix(n, n, self._context)
        self._linear_solver = sun.SUNLinSol_Dense(self._y, self._matrix, self._context)
        return sun.CVodeSetLinearSolver(self._cvode, self._linear_solver, self._matrix)

    def _set_time_and_states(self, t: float, y: int) -> None:
        self._set_time(t)
        if self.nx > 0:
            self._set_x(self.sun.N_VGetArrayPointer(y), self.nx)

    def _rhs(self, t: float, y: int, ydot: int, user_data: Any) -> int:
        dx = self.sun.N_VGetArrayPointer(ydot)
        try:
            self._set_time_and_states(t, y)
            if self.nx == 0:
                dx[0] = 0.0
            else:
                self._get_dx(dx, self.nx)
        except Exception as error:  # CVode cannot carry it: `step` raises it once CVode has stopped
            self.failure = error
            return -1
        return 0

    def _roots_at(self, t: float, y: int, z: Any, user_data: Any) -> int:
        try:
            self._set_time_and_states(t, y)
            self._get_z(z, self.nz)
        except Exception as error:
            self.failure = error
            return -1
        return 0

    def _on_error(self, line: int, function: bytes, file: bytes, message: bytes, code: int, *_: Any) -> None:
        self.error = f"CVode error (code {code}) in {(function or b'?').decode()}: {(message or b'').decode()}"

    def _read_states(self) -> None:
        if self.nx == 0:
            self._y_data[0] = 1.0
        else:
            self._get_x(self._y_data, self.nx)

    def reset(self, time: float) -> None:
        """Restart at ``time`` from the FMU's states (after an input change or an event)."""
        self._read_states()
        self.sun.CVodeReInit(self._cvode, time, self._y)

    def step(self, time: float, target: float) -> tuple[bool, Any, float]:
        """Integrate towards ``target``, stopping early at an event-indicator root; writes the states
        reached to the FMU. Returns (a state event was found, the roots found, the time reached)."""
        sun, reached = self.sun, c_double(time)
        self.failure = None
        flag = sun.CVode(self._cvode, target, self._y, ctypes.byref(reached), _NORMAL)
        if flag < 0:
            if self.failure is not None:  # a call of the right-hand side or root function
                raise self.failure
            raise RuntimeError(self.error or f"CVode returned {flag}")
        if self.nx > 0:
            self._set_x(self._y_data, self.nx)
        if flag > 0 and self.nz > 0:
            sun.CVodeGetRootInfo(self._cvode, self.roots)
        return flag > 0, self.roots, reached.value

    def convergence_failures(self) -> int:
        """Nonlinear-solver convergence failures since the last restart."""
        failures = c_long()
        self.sun.CVodeGetNumNonlinSolvConvFails(self._cvode, ctypes.byref(failures))
        return failures.value

    def close(self) -> None:
        """Free CVode's memory (safe to call twice)."""
        sun = self.sun
        if self._cvode:
            sun.CVodeFree(ctypes.byref(c_void_p(self._cvode)))
        if self._linear_solver:
            sun.SUNLinSolFree(self._linear_solver)
        if self._nonlinear_solver:
            sun.SUNNonlinSolFree(self._nonlinear_solver)
        if self._matrix:
            sun.SUNMatDestroy(self._matrix)
        for vector in (self._y, self._abstol):
            if vector:
                sun.N_VDestroy(vector)
        if self._context:
            sun.SUNContext_Free(ctypes.byref(self._context))
        self._cvode = self._y = self._abstol = self._matrix = self._linear_solver = self._nonlinear_solver = None

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:  # never raise from a finalizer
            pass
