"""FMI 2.0 specifics of `FMIBinding`."""

from __future__ import annotations

import ctypes
import pathlib
from collections.abc import Callable
from functools import partial

from fmpy import calloc, free
from fmpy.fmi2 import (
    FMU2Model,
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2EventInfo,
    fmi2Terminated,
)
from fmpy.logging import addLoggerProxy

from modelicagym.fmu.binding import DISCARD, OK, TERMINATED, WARNING, FMIBinding
from modelicagym.fmu.logs import FMI2_LOGGER

_ALLOCATE = fmi2CallbackAllocateMemoryTYPE(calloc)
_FREE = fmi2CallbackFreeMemoryTYPE(free)


class FMI2Binding(FMIBinding):
    PREFIX = "fmi2"
    FMPY_CLASSES = {"cs": FMU2Slave, "me": FMU2Model}
    TYPE_FUNCTIONS = {
        "Real": ("Real", ctypes.c_double),
        "Integer": ("Integer", ctypes.c_int),
        "Enumeration": ("Integer", ctypes.c_int),
        "Boolean": ("Boolean", ctypes.c_int),
        "String": ("String", ctypes.c_char_p),
    }
    SERIALIZE_FUNCTIONS = ("SerializedFMUstateSize", "SerializeFMUstate", "DeSerializeFMUstate")
    CONTINUOUS_STATE_FUNCTIONS = {
        "set_time": "SetTime", "get_x": "GetContinuousStates", "set_x": "SetContinuousStates",
        "get_dx": "GetDerivatives", "get_z": "GetEventIndicators", "get_nominals": "GetNominalsOfContinuousStates",
    }

    def instantiate(self, logging_on: bool = False) -> None:
        callbacks = fmi2CallbackFunctions()
        callbacks.logger = FMI2_LOGGER
        callbacks.allocateMemory = _ALLOCATE
        callbacks.freeMemory = _FREE
        callbacks.componentEnvironment = self.log.environment
        addLoggerProxy(ctypes.byref(callbacks))
        self._callbacks = callbacks  # the FMU keeps a pointer to it
        resources = pathlib.Path(self.description.unzip_dir, "resources").as_uri()
        self.component = self.raw["fmi2Instantiate"](
            self.instance_name.encode(),
            1 if self.mode == "cs" else 0,
            self.description.guid.encode(),
            resources.encode(),
            ctypes.byref(callbacks),
            0,
            1 if logging_on else 0,
        )
        self._check_instantiated("fmi2Instantiate")

    def enter_initialization(self, start_time: float, stop_time: float | None, tolerance: float | None) -> None:
        self.call(
            "SetupExperiment",
            tolerance is not None,
            tolerance or 0.0,
            start_time,
            stop_time is not None,
            stop_time or 0.0,
        )
        self.call("EnterInitializationMode")

    def do_step_call(self) -> Callable[[float, float], int]:
        do_step = partial(self.raw["fmi2DoStep"], self.component)
        get_boolean_status = self.raw["fmi2GetBooleanStatus"]
        component = self.component
        terminated = ctypes.c_int(0)
        terminated_ref = ctypes.byref(terminated)

        def step(t: float, h: float) -> int:
            status = do_step(t, h, 1)
            if status <= WARNING:
                return OK
            if status == DISCARD and get_boolean_status(component, fmi2Terminated, terminated_ref) <= WARNING:
                return TERMINATED if terminated.value else DISCARD
            return status

        return step

    def _state_name(self, verb: str) -> str:
        return f"{verb}FMUstate"

    def update_discrete_states(self) -> tuple[bool, bool, bool, float | None]:
        info = fmi2EventInfo()
        self.call("NewDiscreteStates", ctypes.byref(info))
        next_time = info.nextEventTime if info.nextEventTimeDefined else None
        return bool(info.newDiscreteStatesNeeded), bool(info.terminateSimulation), bool(info.valuesOfContinuousStatesChanged), next_time

    def completed_integrator_step(self) -> tuple[bool, bool]:
        enter_event_mode, terminate = ctypes.c_int(0), ctypes.c_int(0)
        self.call("CompletedIntegratorStep", 1, ctypes.byref(enter_event_mode), ctypes.byref(terminate))
        return bool(enter_event_mode.value), bool(terminate.value)

