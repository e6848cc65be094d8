"""FMI 3.0 specifics of `FMIBinding`."""

from __future__ import annotations

import ctypes
from collections.abc import Callable
from functools import partial
from typing import Any

from fmpy.fmi3 import FMU3Model, FMU3Slave, fmi3IntermediateUpdateCallback

from modelicagym.fmu.binding import DISCARD, OK, TERMINATED, WARNING, FMIBinding
from modelicagym.fmu.logs import FMI3_LOGGER

_NO_INTERMEDIATE_UPDATE = fmi3IntermediateUpdateCallback()


class FMI3Binding(FMIBinding):
    PREFIX = "fmi3"
    FMPY_CLASSES = {"cs": FMU3Slave, "me": FMU3Model}
    TYPE_FUNCTIONS = {
        **{name: (name, ctype) for name, ctype in (
            ("Float64", ctypes.c_double), ("Float32", ctypes.c_float),
            ("Int8", ctypes.c_int8), ("UInt8", ctypes.c_uint8), ("Int16", ctypes.c_int16),
            ("UInt16", ctypes.c_uint16), ("Int32", ctypes.c_int32), ("UInt32", ctypes.c_uint32),
            ("Int64", ctypes.c_int64), ("UInt64", ctypes.c_uint64),
            ("Boolean", ctypes.c_bool), ("String", ctypes.c_char_p),
        )},
        "Enumeration": ("Int64", ctypes.c_int64),
    }
    BYTE = ctypes.c_uint8
    SERIALIZE_FUNCTIONS = ("SerializedFMUStateSize", "SerializeFMUState", "DeserializeFMUState")
    CONTINUOUS_STATE_FUNCTIONS = {
        "set_time": "SetTime", "get_x": "GetContinuousStates", "set_x": "SetContinuousStates",
        "get_dx": "GetContinuousStateDerivatives", "get_z": "GetEventIndicators",
        "get_nominals": "GetNominalsOfContinuousStates",
    }

    def _value_count_args(self, n_values: int) -> tuple[int, ...]:
        return (n_values,)

    def instantiate(self, logging_on: bool = False) -> None:
        resources = str(self.description.unzip_dir / "resources") + "/"
        common = (self.instance_name.encode(), self.description.guid.encode(), resources.encode(), False, logging_on)
        if self.mode == "cs":
            self.component = self.raw["fmi3InstantiateCoSimulation"](
                *common, False, False, None, 0, self.log.environment, FMI3_LOGGER, _NO_INTERMEDIATE_UPDATE
            )
        else:
            self.component = self.raw["fmi3InstantiateModelExchange"](*common, self.log.environment, FMI3_LOGGER)
        self._check_instantiated("fmi3Instantiate")

    def configure(self, values: dict[str, Any]) -> None:
        """Set structural parameters where FMI 3.0 allows it: in configuration mode, entered from
        the instantiated state (before initialization) and left before anything else is set."""
        self.call("EnterConfigurationMode")
        try:
            self.set_values(values)
        finally:
            self.call("ExitConfigurationMode")

    def enter_initialization(self, start_time: float, stop_time: float | None, tolerance: float | None) -> None:
        self.call(
            "EnterInitializationMode",
            tolerance is not None,
            tolerance or 0.0,
            start_time,
            stop_time is not None,
            stop_time or 0.0,
        )

    def do_step_call(self) -> Callable[[float, float], int]:
        flags = [ctypes.c_bool(False) for _ in range(3)]
        last_time = ctypes.c_double(0.0)
        terminate = flags[1]
        do_step = partial(self.raw["fmi3DoStep"], self.component)
        refs = [ctypes.byref(f) for f in flags] + [ctypes.byref(last_time)]

        def step(t: float, h: float) -> int:
            terminate.value = False
            status = do_step(t, h, True, *refs)
            if terminate.value and status <= DISCARD:
                return TERMINATED
            return OK if status <= WARNING else status

        return step

    def _state_name(self, verb: str) -> str:
        return f"{verb}FMUState"

    def update_discrete_states(self) -> tuple[bool, bool, bool, float | None]:
        flags = [ctypes.c_bool(False) for _ in range(5)]
        next_time = ctypes.c_double(0.0)
        self.call("UpdateDiscreteStates", *[ctypes.byref(f) for f in flags], ctypes.byref(next_time))
        needs_update, terminate, _, values_changed, time_defined = (f.value for f in flags)
        return needs_update, terminate, values_changed, next_time.value if time_defined else None

    def completed_integrator_step(self) -> tuple[bool, bool]:
        enter_event_mode, terminate = ctypes.c_bool(False), ctypes.c_bool(False)
        self.call("CompletedIntegratorStep", True, ctypes.byref(enter_event_mode), ctypes.byref(terminate))
        return enter_event_mode.value, terminate.value

