"""FMI 1.0 specifics of `FMIBinding`.

What FMI 1.0 does differently, as the runtime sees it:

* an FMU is either co-simulation or model exchange, and every function is named
  ``<modelIdentifier>_fmi<Name>`` (so ``PREFIX`` is per FMU, not per class);
* there is no initialization mode: ``fmiInitializeSlave`` / ``fmiInitialize`` initialize in one
  call, made here by `exit_initialization` (parameters and start values are set before it);
* model exchange has no event-mode calls: ``fmiInitialize`` returns the outcome of the initial
  event iteration, ``fmiEventUpdate`` runs one (entering and leaving event mode are no-ops here),
  and ``fmiCompletedIntegratorStep`` is always called;
* no FMU state snapshots, no reset for model exchange (``fmiResetSlave`` for co-simulation), no
  "terminated" status for a co-simulation slave;
* ``fmiBoolean`` is a ``char`` (bound here as ``int8`` so that buffers hold numbers).
"""

from __future__ import annotations

import ctypes
from collections.abc import Callable
from functools import partial
from typing import Any

from fmpy import calloc, free
from fmpy.fmi1 import (
    FMU1Model,
    FMU1Slave,
    fmi1CallbackAllocateMemoryTYPE,
    fmi1CallbackFreeMemoryTYPE,
    fmi1CallbackFunctions,
    fmi1EventInfo,
)
from fmpy.logging import addLoggerProxy

from modelicagym.fmu.binding import OK, WARNING, FMIBinding
from modelicagym.fmu.description import FMUDescription
from modelicagym.fmu.errors import UnsupportedFeatureError
from modelicagym.fmu.fmi2 import FMI2Binding
from modelicagym.fmu.logs import FMI1_LOGGER

_ALLOCATE = fmi1CallbackAllocateMemoryTYPE(calloc)
_FREE = fmi1CallbackFreeMemoryTYPE(free)
_TRUE, _FALSE = b"\x01", b"\x00"
_MIME_TYPE = b"application/x-fmu-sharedlibrary"
_STATUS_FUNCTIONS = {
    "cs": ("InitializeSlave", "DoStep", "CancelStep", "SetRealInputDerivatives", "GetRealOutputDerivatives",
           "GetStatus", "GetRealStatus", "GetIntegerStatus", "GetBooleanStatus", "GetStringStatus"),
    "me": (),
}


class FMI1Binding(FMIBinding):
    FMPY_CLASSES = {"cs": FMU1Slave, "me": FMU1Model}
    #: as FMI 2.0's, except that ``fmiBoolean`` is a ``char`` and one function has another name
    TYPE_FUNCTIONS = {**FMI2Binding.TYPE_FUNCTIONS, "Boolean": ("Boolean", ctypes.c_int8)}
    CONTINUOUS_STATE_FUNCTIONS = {**FMI2Binding.CONTINUOUS_STATE_FUNCTIONS, "get_nominals": "GetNominalContinuousStates"}

    def __init__(self, description: FMUDescription, mode: str, instance_name: str | None = None,
                 instances_per_process: str = "copies"):
        super().__init__(description, mode, instance_name, instances_per_process)
        self.PREFIX = f"{description.interface(mode).modelIdentifier}_fmi"
        if mode == "cs":
            self.FREE_INSTANCE, self.TERMINATE, self.RESET = "FreeSlaveInstance", "TerminateSlave", "ResetSlave"
        else:
            self.FREE_INSTANCE = "FreeModelInstance"
        self._fix_declarations()
        self._experiment: tuple[float, float | None, float | None] = (0.0, None, None)
        self._initial_event: tuple[bool, bool, bool, float | None] | None = None

    def _fix_declarations(self) -> None:
        """Correct fmpy 0.3's FMI 1.0 declarations where they differ from the standard: several
        co-simulation functions are declared to return a string instead of a status, and Boolean
        values are ``char`` arrays (``int8`` has the same layout and gives numpy numbers)."""
        for name in _STATUS_FUNCTIONS[self.mode]:
            self.raw[self.PREFIX + name].restype = ctypes.c_int
        for verb in ("Get", "Set"):
            function = self.raw[f"{self.PREFIX}{verb}Boolean"]
            function.argtypes = [*function.argtypes[:3], ctypes.POINTER(ctypes.c_int8)]

    def instantiate(self, logging_on: bool = False) -> None:
        callbacks = fmi1CallbackFunctions()
        callbacks.logger = FMI1_LOGGER
        callbacks.allocateMemory = _ALLOCATE
        callbacks.freeMemory = _FREE
        callbacks.stepFinished = None
        addLoggerProxy(ctypes.byref(callbacks))
        self._callbacks = callbacks  # the FMU may keep the logger it was given
        name, guid, logging = self.instance_name.encode(), self.description.guid.encode(), _TRUE if logging_on else _FALSE
        with self.log.instantiating():
            if self.mode == "cs":
                location = self.description.unzip_dir.as_uri().encode()
                self.component = self.raw[self.PREFIX + "InstantiateSlave"](
                    name, guid, location, _MIME_TYPE, 0.0, _FALSE, _FALSE, callbacks, logging
                )
            else:
                self.component = self.raw[self.PREFIX + "InstantiateModel"](name, guid, callbacks, logging)
        self._check_instantiated(self.PREFIX + ("InstantiateSlave" if self.mode == "cs" else "InstantiateModel"))
        self.log.route_component(self.component)

    def free_instance(self) -> None:
        self.log.unroute_components()
        super().free_instance()

    def enter_initialization(self, start_time: float, stop_time: float | None, tolerance: float | None) -> None:
        """FMI 1.0 initializes in one call: remember the experiment for `exit_initialization`
        (model exchange sets its start time now, with ``fmiSetTime``)."""
        self._experiment = (start_time, stop_time, tolerance)
        if self.mode == "me":
            self.call("SetTime", start_time)

    def exit_initialization(self) -> None:
        start_time, stop_time, tolerance = self._experiment
        if self.mode == "cs":
            self.call("InitializeSlave", start_time, _TRUE if stop_time is not None else _FALSE, stop_time or 0.0)
            return
        info = fmi1EventInfo()
        self.call("Initialize", _TRUE if tolerance is not None else _FALSE, tolerance or 0.0, ctypes.byref(info))
        self._initial_event = _event_outcome(info)

    def reset(self) -> None:
        if self.mode == "me":
            raise UnsupportedFeatureError(f"{self.fmu_name}: FMI 1.0 model exchange has no reset; re-instantiate")
        super().reset()

    def do_step_call(self) -> Callable[[float, float], int]:
        do_step = partial(self.raw[self.PREFIX + "DoStep"], self.component)

        def step(t: float, h: float) -> int:
            status = do_step(t, h, _TRUE)
            return OK if status <= WARNING else status

        return step

    def _state_name(self, verb: str) -> str:
        raise UnsupportedFeatureError(f"{self.fmu_name}: FMI 1.0 FMUs cannot save and restore their state")

    # -- model exchange --------------------------------------------------------------------------

    def enter_event_mode(self) -> None:
        """FMI 1.0 has no event mode to enter: ``fmiEventUpdate`` handles the event."""

    def enter_continuous_time_mode(self) -> None:
        """FMI 1.0 has no continuous-time mode to enter."""

    def update_discrete_states(self) -> tuple[bool, bool, bool, float | None]:
        """The initial event iteration's outcome right after ``fmiInitialize``, else one
        ``fmiEventUpdate`` that iterates until converged."""
        if self._initial_event is not None:
            outcome, self._initial_event = self._initial_event, None
            return outcome
        info = fmi1EventInfo()
        self.call("EventUpdate", _FALSE, ctypes.byref(info))
        return _event_outcome(info)

    def completed_integrator_step(self) -> tuple[bool, bool]:
        call_event_update = ctypes.c_char(_FALSE)
        self.call("CompletedIntegratorStep", ctypes.byref(call_event_update))
        return call_event_update.value != _FALSE, False


def _event_outcome(info: Any) -> tuple[bool, bool, bool, float | None]:
    """``(needs_more, terminate, states_changed, next_event_time)`` of an ``fmiEventInfo``."""
    return (
        info.iterationConverged == _FALSE,
        info.terminateSimulation != _FALSE,
        info.stateValuesChanged != _FALSE,
        info.nextEventTime if info.upcomingTimeEvent != _FALSE else None,
    )
