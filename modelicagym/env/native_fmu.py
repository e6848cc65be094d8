"""An FMU instance's part of an ``mg_env`` (``csrc/step.h``): its fmiSet/fmiGet calls over its own
value buffers, the functions C calls bound to its live instance, its snapshot for a native reset,
and the error of a call that failed in C, as the Python path raises it. `modelicagym.env.native_step` fills an env's struct
with them, `modelicagym.env.native_system` each FMU of a system's."""

from __future__ import annotations

import ctypes
from typing import Any

import numpy as np

from modelicagym.fmu.binding import DISCARD
from modelicagym.fmu.errors import FMUError
from modelicagym.native.abi import FailedCall, MgCall, MgEnv

__all__ = ["FmuCalls", "bind_instance", "bind_snapshot", "fmu_error", "input_starts", "instance_calls", "make_calls"]

#: ``failed_call`` codes -> how the Python path names the failing call
_FAILED_CALLS = {FailedCall.SET_INPUTS: "set inputs", FailedCall.DO_STEP: "fmiDoStep",
                 FailedCall.GET_OUTPUTS: "get outputs", FailedCall.SET_STATE: "set FMU state",
                 FailedCall.INTEGRATE: "integrate"}

#: the function a native reset restores the snapshot with (FMI 1.0 has none)
_SET_STATE = {2: "fmi2SetFMUstate", 3: "fmi3SetFMUState"}

#: per direction (``"set"``, ``"get"``): the ``mg_call`` array and each call's (FMI type, function suffix)
FmuCalls = dict[str, tuple[ctypes.Array, list[tuple[str, str]]]]


def make_calls(buffer: Any, binding: Any) -> tuple[ctypes.Array, list[tuple[str, str]]]:
    """One ``mg_call`` per FMI type of ``buffer`` (its function is bound by `bind_instance`), and
    the function names to bind."""
    groups = buffer.groups()
    calls = (MgCall * max(len(groups), 1))()
    names = []
    for call, (fmi_type, refs, n_refs, values, n_values, n_bytes) in zip(calls, groups):
        call.refs, call.n_refs, call.values, call.n_values, call.n_bytes = refs, n_refs, values, n_values, n_bytes
        names.append((fmi_type, binding.TYPE_FUNCTIONS[fmi_type][0]))
    return calls, names


def input_starts(inputs: Any) -> np.ndarray:
    """The bytes of an input buffer as a reset leaves it (its start values), for ``mg_env.input_starts``."""
    current = inputs.snapshot()
    inputs.fill_start_values()
    starts = inputs.snapshot()
    inputs.load(current)
    return np.frombuffer(starts, dtype=np.uint8).copy()


def instance_calls(fmu: Any, state: MgEnv) -> FmuCalls:
    """``fmu``'s set and get calls (`make_calls`), pointed to by ``state``."""
    calls = {"set": make_calls(fmu.inputs, fmu.binding), "get": make_calls(fmu.outputs, fmu.binding)}
    state.set_calls, state.n_set_calls = ctypes.addressof(calls["set"][0]), len(calls["set"][1])
    state.get_calls, state.n_get_calls = ctypes.addressof(calls["get"][0]), len(calls["get"][1])
    return calls


def bind_instance(state: MgEnv, fmu: Any, calls: FmuCalls) -> None:
    """Point ``state`` at ``fmu``'s live instance: its component, its set/get functions, its doStep
    (co-simulation) or its native integrator (model exchange)."""
    binding = fmu.binding
    prefix = binding.PREFIX
    state.component = binding.component
    for verb, (array, names) in zip(("Set", "Get"), (calls["set"], calls["get"])):
        for call, (_, suffix) in zip(array, names):
            call.function = binding.function_address(prefix + verb + suffix)
    integrator = fmu.native_integrator
    if integrator is None:
        state.do_step = binding.function_address(prefix + "DoStep")
        state.get_boolean_status = binding.function_address("fmi2GetBooleanStatus") if prefix == "fmi2" else None
    state.integrator = None if integrator is None else ctypes.addressof(integrator.state)


def bind_snapshot(state: MgEnv, fmu: Any, values: Any) -> bool:
    """Let C reset ``fmu`` by restoring its snapshot when a reset with ``values`` (None: a reset
    only Python can do, e.g. parameters drawn per episode) would simply restore it (its verified
    snapshot rung, `FMUInstance.restorable_snapshot`); whether it can."""
    snapshot = None if values is None else fmu.restorable_snapshot(values)
    state.set_state = None if snapshot is None else fmu.binding.function_address(_SET_STATE[state.fmi_version])
    state.snapshot = snapshot
    state.native_reset = snapshot is not None
    next_event = fmu.snapshot_next_event_time
    state.snapshot_has_next_event = next_event is not None
    state.snapshot_next_event_time = next_event or 0.0
    return snapshot is not None


def fmu_error(fmu: Any, state: MgEnv) -> FMUError:
    """The error of ``fmu``'s step that failed in C (``state.failed_call``, ``state.fmi_status``),
    as the Python path raises it."""
    if state.failed_call == FailedCall.LOG_ERRORS:
        return fmu.error_loop()
    call = _FAILED_CALLS[state.failed_call]
    if call == "integrate":
        return fmu.native_integrator.error()
    if call == "fmiDoStep" and state.fmi_status == DISCARD:
        call = "fmiDoStep (discard without termination)"
    return fmu.binding.fail(call, state.fmi_status)
