"""Model exchange with the solver loop in C (``csrc/integrator.c``): no Python inside a step.

`NativeIntegrator` is a `ModelExchangeIntegrator` whose ``advance`` is one C call: CVode (the
SUNDIALS 7 libraries fmpy ships, the same binaries the Python path drives) or a fixed-step scheme,
with right-hand-side and root functions that call the FMU's own functions, and the event
iteration in C. Initialization events, ``event`` and snapshots stay with the parent class: they
happen once per episode or on a user's call; the native step path sets a step's discrete inputs
in event mode with C's own counterpart of ``event`` (``mg_integrator_enter_event`` /
``mg_integrator_settle_event``).

:func:`python_integrator_reason` says when an instance must keep the Python loop.
"""

from __future__ import annotations

import ctypes
import functools
from typing import Any

import numpy as np

from modelicagym.fmu.binding import FMIBinding
from modelicagym.fmu.errors import FMUError
from modelicagym.fmu.model_exchange import ModelExchangeIntegrator
from modelicagym.native.abi import (
    SUNDIALS_FUNCTIONS,
    CVodeMethod,
    IntegratorCall,
    IntegratorOutcome,
    MgIntegrator,
    MgSundials,
    Solver,
)
from modelicagym.native.library import NativeBuildError, load_library

__all__ = ["NativeIntegrator", "python_integrator_reason"]

#: the fmpy library that exports each of the SUNDIALS functions of ``mg_sundials``
_SUNDIALS_LIBRARIES = {
    "SUNContext_Create": "sundials_core",
    "SUNContext_Free": "sundials_core",
    "SUNContext_ClearErrHandlers": "sundials_core",
    "SUNContext_PushErrHandler": "sundials_core",
    "N_VNew_Serial": "sundials_nvecserial",
    "N_VDestroy": "sundials_core",
    "N_VGetArrayPointer": "sundials_core",
    "SUNDenseMatrix": "sundials_sunmatrixdense",
    "SUNMatDestroy": "sundials_core",
    "SUNLinSol_Dense": "sundials_sunlinsoldense",
    "SUNLinSolFree": "sundials_core",
    "SUNNonlinSol_FixedPoint": "sundials_cvode",
    "SUNNonlinSolFree": "sundials_core",
    **dict.fromkeys((
        "CVodeCreate", "CVodeInit", "CVodeReInit", "CVodeSVtolerances", "CVodeRootInit",
        "CVodeSetLinearSolver", "CVodeSetNonlinearSolver", "CVodeSetMaxNumSteps", "CVodeSetNoInactiveRootWarn",
        "CVodeSetUserData", "CVode", "CVodeGetRootInfo", "CVodeGetNumNonlinSolvConvFails", "CVodeFree",
    ), "sundials_cvode"),
}


#: solver name -> (MG_SOLVER_*, MG_CVODE_*)
_SOLVERS = {"cvode": (Solver.CVODE, CVodeMethod.AUTO), "cvode-bdf": (Solver.CVODE, CVodeMethod.BDF),
            "euler": (Solver.EULER, CVodeMethod.BDF), "rk4": (Solver.RK4, CVodeMethod.BDF)}

#: FMU functions the integrator calls, by field: the suffix per FMI version (1, 2, 3); FMI 1.0 has no
#: event or continuous-time mode to enter (None: C skips the call)
_FUNCTIONS = {
    "set_time": ("SetTime", "SetTime", "SetTime"),
    "set_x": ("SetContinuousStates", "SetContinuousStates", "SetContinuousStates"),
    "get_x": ("GetContinuousStates", "GetContinuousStates", "GetContinuousStates"),
    "get_dx": ("GetDerivatives", "GetDerivatives", "GetContinuousStateDerivatives"),
    "get_z": ("GetEventIndicators", "GetEventIndicators", "GetEventIndicators"),
    "get_nominals": ("GetNominalContinuousStates", "GetNominalsOfContinuousStates", "GetNominalsOfContinuousStates"),
    "completed_integrator_step": ("CompletedIntegratorStep", "CompletedIntegratorStep", "CompletedIntegratorStep"),
    "enter_event_mode": (None, "EnterEventMode", "EnterEventMode"),
    "update_discrete_states": ("EventUpdate", "NewDiscreteStates", "UpdateDiscreteStates"),
    "enter_continuous_time_mode": (None, "EnterContinuousTimeMode", "EnterContinuousTimeMode"),
}
#: ``failed_call`` codes (1, 2, ...) in the order of ``_FUNCTIONS``
_CALLS = list(_FUNCTIONS)


@functools.cache
def sundials() -> MgSundials:
    """The SUNDIALS functions of fmpy's bundled libraries (loaded by fmpy, as the Python path does)."""
    from fmpy.sundials import libraries

    table = MgSundials()
    for name in SUNDIALS_FUNCTIONS:
        library = _SUNDIALS_LIBRARIES[name]
        setattr(table, name, ctypes.cast(getattr(getattr(libraries, library), name), ctypes.c_void_p).value)
    return table


def python_integrator_reason(fmi_version: int, solver: str) -> str | None:
    """Why a model-exchange instance must integrate in Python, or ``None`` when C can."""
    if solver not in _SOLVERS:
        return f"the solver {solver!r} has no native implementation"
    try:
        load_library()
        if solver.startswith("cvode"):
            sundials()
    except NativeBuildError as error:
        return f"the native library is not available: {error}"
    except (ImportError, OSError, AttributeError) as error:
        return f"fmpy's SUNDIALS libraries cannot be loaded: {error}"
    return None


class _StateFlag:
    """A flag of `ModelExchangeIntegrator` kept in the ``mg_integrator`` struct, where C reads and
    writes it (same name)."""

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    def __get__(self, instance: Any, owner: type | None = None) -> bool:
        return bool(getattr(instance.state, self.name))

    def __set__(self, instance: Any, value: bool) -> None:
        setattr(instance.state, self.name, value)


class NativeIntegrator(ModelExchangeIntegrator):
    """A `ModelExchangeIntegrator` whose solver loop runs in C (same arguments, same answers)."""

    def __init__(self, binding: FMIBinding, n_states: int, n_indicators: int, *args: Any, **kwargs: Any) -> None:
        self.state = state = MgIntegrator()
        super().__init__(binding, n_states, n_indicators, *args, **kwargs)
        self.library = load_library()
        version = binding.description.fmi_version
        state.fmi_version = version
        state.solver, state.method = _SOLVERS[self.solver_name]
        state.nx, state.nz = n_states, n_indicators
        state.needs_completed_integrator_step = self.needs_completed_integrator_step
        state.tolerance = self.tolerance
        state.step_size = self.step_size or 0.0
        self._buffers = {name: np.zeros(max(n, 1)) for name, n in
                         (("x", n_states), ("dx", n_states), ("z", n_indicators), ("previous_z", n_indicators))}
        self._buffers["roots"] = np.zeros(max(n_indicators, 1), dtype=np.int32)
        self._buffers["stages"] = np.zeros(4 * max(n_states, 1))
        for name, array in self._buffers.items():
            setattr(state, name, array.ctypes.data)
        if self.solver_name.startswith("cvode"):
            self._sundials = sundials()
            state.sundials = ctypes.pointer(self._sundials)
        self._advance = self.library.mg_integrator_advance
        self._ref = ctypes.byref(state)

    @property
    def next_event_time(self) -> float | None:  # type: ignore[override]
        return self.state.next_event_time if self.state.has_next_event else None

    @next_event_time.setter
    def next_event_time(self, value: float | None) -> None:
        self.state.has_next_event = value is not None
        self.state.next_event_time = 0.0 if value is None else value

    continuous = _StateFlag()
    stiff = _StateFlag()

    def _make_solver(self, time: float) -> None:
        """Point the struct at the instance as it is now (it may have been re-instantiated), and
        set the solver up at ``time``."""
        state, binding = self.state, self.binding
        if state.component != binding.component:
            state.component = binding.component
            for field, names in _FUNCTIONS.items():
                name = names[state.fmi_version - 1]
                setattr(state, field, None if name is None else binding.function_address(binding.PREFIX + name))
            self._set_time = binding.continuous_state_functions()["set_time"]
        self._check(self.library.mg_integrator_open(self._ref, time))

    def advance(self, time: float, stop: float) -> bool:
        """Integrate from ``time`` to ``stop``; returns True if the model asked to terminate."""
        return self._check(self._advance(self._ref, time, stop))

    def _check(self, outcome: int) -> bool:
        if outcome == IntegratorOutcome.FAILED:
            raise self.error()
        return outcome == IntegratorOutcome.TERMINATE

    def error(self) -> FMUError:
        """The error of the last call that failed, as the Python path raises it."""
        state, binding = self.state, self.binding
        if state.failed_call == IntegratorCall.SOLVER:
            message = state.message.decode(errors="replace") or f"CVode returned {state.fmi_status}"
            return FMUError(f"{binding.fmu_name}: the {self.solver_name} solver failed at t={state.failed_at}: {message}")
        names = _FUNCTIONS[_CALLS[state.failed_call - 1]]
        return binding.fail(binding.PREFIX + names[state.fmi_version - 1], state.fmi_status)

    def close(self) -> None:
        """Free CVode's memory."""
        self.library.mg_integrator_close(self._ref)

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:  # never raise from a finalizer
            pass
