"""A system's master algorithm on the native step path: the ``mg_system`` (``csrc/step.h``) of a
`SystemInstance`, so that one C call steps every component and copies along every connection.

Each FMU of the system gets an ``mg_env`` of its own (its calls, doStep or native integrator and
clock, `modelicagym.env.native_fmu`; the inputs written by the connections, no action, bounds or
observation), each table an ``mg_table`` (its times, columns, offset and clock). The connections
become ``mg_link``s between the components' own value buffers, with their unit conversion; the
action's values reach the components from the system's input values, the outputs the system's
output values, so the system env's action and observation moves work as one FMU's. The loop guard
(`modelicagym.system.loops.LoopGuard`) becomes ``mg_system.guards``: the address of each value it
checks, in its order; a diverged loop fails the C step and `error` raises the guard's error. Python resets
the system (a reset is never native: ``mg_env.native_reset`` stays 0) and `bind` points the
structs at the components' live instances afterwards.
"""

from __future__ import annotations

import ctypes
from typing import Any

import numpy as np

from modelicagym.env.native_fmu import FmuCalls, bind_instance, bind_snapshot, fmu_error, input_starts, instance_calls
from modelicagym.fmu.errors import FMUError
from modelicagym.native.abi import FailedCall, MgComponent, MgEnv, MgLink, MgSystem, MgTable, ValueType
from modelicagym.system import SystemInstance
from modelicagym.system.loops import LOOP_BOUND
from modelicagym.system.table import TIME_OFFSET, TableInstance

__all__ = ["NativeSystem"]


def _addresses(view: np.ndarray) -> list[tuple[int, int]]:
    """``(address, MG_TYPE_*)`` of each value of a buffer's view."""
    code = ValueType.of(view.dtype)
    return [(view.ctypes.data + k * view.itemsize, code) for k in range(view.size)]


def _links(pairs: list[tuple[np.ndarray, np.ndarray, float, float]]) -> ctypes.Array:
    """``mg_link``s for ``(target view, source view, scale, shift)``, value by value."""
    rows = [(source, target, scale, shift) for target_view, source_view, scale, shift in pairs
            for source, target in zip(_addresses(source_view), _addresses(target_view))]
    links = (MgLink * max(len(rows), 1))()
    for link, ((source, source_type), (target, target_type), scale, shift) in zip(links, rows):
        link.source, link.source_type, link.target, link.target_type = source, source_type, target, target_type
        link.scale, link.shift = scale, shift
    return links, len(rows)


class NativeSystem:
    """The ``mg_system`` of ``system`` stepped at ``time_step`` (module docstring); ``address`` is
    what the system env's ``mg_env.system`` points to."""

    def __init__(self, system: SystemInstance, time_step: float):
        self.system = system
        self._keep: list[Any] = []  # the arrays the structs point to
        self._fmus: list[tuple[str, MgEnv, Any, FmuCalls]] = []
        order = system.description.order
        components = (MgComponent * len(order))()
        by_target = {name: [] for name in order}
        for move, link in zip(system.link_moves, system.description.links):
            by_target[link.target].append(move)
        actions = {name: [] for name in order}
        for move, component in zip(system.action_moves, system.action_components):
            actions[component].append(move)
        for struct, name in zip(components, order):
            component = system.components[name]
            if isinstance(component, TableInstance):
                struct.table = ctypes.addressof(self._table(component))
            else:
                struct.env = ctypes.addressof(self._fmu(name, component, time_step / system.substeps))
            links, struct.n_links = self._keep_links(by_target[name])
            struct.links = ctypes.addressof(links)
            action_links, struct.n_action_links = self._keep_links(actions[name])
            struct.action_links = ctypes.addressof(action_links)
        outputs, n_outputs = self._keep_links(system.output_moves)
        guards, n_guards = self._keep_links([(values, values, 1.0, 0.0) for values in system.guard.values])
        self._components = components
        self.struct = MgSystem(components=ctypes.addressof(components), n_components=len(order),
                               jacobi=system.master == "jacobi", substeps=system.substeps,
                               output_links=ctypes.addressof(outputs), n_output_links=n_outputs,
                               guards=ctypes.addressof(guards), n_guards=n_guards, guard_bound=LOOP_BOUND)
        #: which guarded connection each row of ``guards`` belongs to (a connection of an array has one per value)
        self._guard_rows = [k for k, values in enumerate(system.guard.values) for _ in range(values.size)]
        self.address = ctypes.addressof(self.struct)

    def _keep_links(self, pairs: list[tuple[np.ndarray, np.ndarray, float, float]]) -> tuple[ctypes.Array, int]:
        links, n = _links(pairs)
        self._keep.append(links)
        return links, n

    def _fmu(self, name: str, fmu: Any, time_step: float) -> MgEnv:
        """An FMU component's ``mg_env``: its own step, the inputs written by the master."""
        starts = input_starts(fmu.inputs)
        self._keep.append(starts)
        state = MgEnv(fmi_version=fmu.description.fmi_version, python_inputs=1, event_mode_inputs=fmu.event_mode_inputs,
                      time_step=time_step, max_episode_steps=-1, clock=ctypes.pointer(fmu.clock),
                      input_starts=starts.ctypes.data)
        self._fmus.append((name, state, fmu, instance_calls(fmu, state)))
        return state

    def _table(self, table: Any) -> MgTable:
        outputs = (ctypes.c_void_p * max(len(table.output_variables), 1))(
            *(table.outputs.views[v.name].ctypes.data for v in table.output_variables))
        times = np.ascontiguousarray(table.data.times, dtype=np.float64)
        self._keep += [outputs, times]
        struct = MgTable(times=times.ctypes.data, n_times=times.size, values=table.matrix.ctypes.data,
                         outputs=ctypes.addressof(outputs), n_outputs=len(table.output_variables),
                         offset=table.offset_value.ctypes.data, clock=ctypes.pointer(table.clock))
        self._keep.append(struct)
        return struct

    def bind(self, values: Any = None) -> bool:
        """Point each FMU's struct at its live instance (after a reset re-instantiated one); whether
        C may reset the system for a reset with ``values`` (the config's; None: only Python may):
        every FMU restores its snapshot for its share of them, every table starts at the offset it
        has now."""
        split = None if values is None else self.system.split_values(values)
        native = split is not None
        for name, state, fmu, calls in self._fmus:
            bind_instance(state, fmu, calls)
            native = bind_snapshot(state, fmu, None if split is None else split[name]) and native
        for name, table in self.system.components.items():
            if isinstance(table, TableInstance) and native:
                native = table.offset == float(split[name].get(TIME_OFFSET, 0.0))
        return native

    def error(self, failed_call: int) -> FMUError:
        """The error of the component whose step failed in C (``failed_call``: the system env's
        ``mg_env.failed_call``), as the Python path raises it; a diverged loop raises its
        `LoopDivergedError` here, as the Python path's step does."""
        if failed_call == FailedCall.LOOP_GUARD:
            raise self.system.loop_error(self._guard_rows[self.struct.failed_guard])
        failed = self.system.description.order[self.struct.failed_component]
        _, state, fmu, _ = next(entry for entry in self._fmus if entry[0] == failed)
        return fmu_error(fmu, state)
