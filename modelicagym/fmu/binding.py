"""A version-neutral, thin layer over one FMU's C API.

`FMIBinding` loads the FMU's shared library through fmpy (which declares every FMI function's
ctypes signature on its public ``dll``, a ``ctypes.CDLL``) and then calls the raw C functions
itself (`FunctionTable`, which checks that each signature is really declared): fmpy's convenience methods build
ctypes arrays on every call and raise on warnings, while the runtime needs preallocated arrays on
the hot path and its own status handling. `fmi1.py`, `fmi2.py` and `fmi3.py` fill in what
differs between the standards; everything above them (`instance.py`, `model_exchange.py`) is
version-neutral.

Status codes are the FMI ones (fmiStatus, fmi2Status and fmi3Status share their values).
``do_step`` collapses the "did the model end the simulation" question that the versions answer
differently (FMI 1.0 not at all) into one extra code, `TERMINATED`.
"""

from __future__ import annotations

import ctypes
import logging
import os
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

import fmpy
import numpy as np

from modelicagym.fmu.description import FMUDescription
from modelicagym.fmu.errors import DISCARD, ERROR, FATAL, OK, WARNING, FMUCallError, FMUError
from modelicagym.fmu.library_copies import LibraryLease, check_instances_per_process, lease_library
from modelicagym.fmu.logs import FMULog
from modelicagym.fmu.trial import check_first_load

__all__ = ["DISCARD", "ERROR", "FATAL", "OK", "TERMINATED", "WARNING", "FMIBinding", "FunctionTable"]

logger = logging.getLogger(__name__)

TERMINATED = 10
"""Returned by ``do_step`` when the model asked to end the simulation (discard + terminated)."""


class FunctionTable(dict):
    """The FMU's C functions by full name (``raw["fmi2DoStep"]``), with the signatures fmpy declared.

    Read from fmpy's public ``dll`` (the loaded ``ctypes.CDLL``) on first use. A function without
    declared argument types would silently mangle its arguments, so that is an error here (an
    fmpy release that stops declaring them fails loudly, at load time of the function).
    """

    def __init__(self, library: ctypes.CDLL, fmu_name: str) -> None:
        super().__init__()
        self._library = library
        self._fmu_name = fmu_name

    def __missing__(self, name: str) -> Any:
        try:
            function = getattr(self._library, name)
        except AttributeError as error:
            raise FMUError(f"{self._fmu_name}: the FMU's library does not export {name}") from error
        if function.argtypes is None:
            raise FMUError(f"{self._fmu_name}: fmpy {fmpy.__version__} declared no signature for {name}; "
                           "modelicagym needs fmpy's declarations (fmpy 0.3.x)")
        self[name] = function
        return function


#: fmpy's objects for the libraries loaded in this process, by (fmpy class, library, model identifier)
_LOADED: dict[tuple[type, str, str], Any] = {}


class FMIBinding:
    """One loaded FMU library and at most one live instance of it.

    For an FMU allowed one instance per process, with ``instances_per_process="copies"`` (the
    default), the binding leases its library for its life (`modelicagym.fmu.library_copies`): the
    FMU's binary while no other binding of it lives in the process, else a private copy of it, so
    that each live instance has globals of its own. ``"one"`` loads the binary itself, always
    (and a ``"copies"`` binding beside it then takes a copy).

    Subclasses set ``PREFIX``, ``FMPY_CLASSES``, ``TYPE_FUNCTIONS`` (for every FMI value type,
    the suffix of its get/set functions and the ctypes type of its values) and
    ``CONTINUOUS_STATE_FUNCTIONS``; ``FREE_INSTANCE``, ``TERMINATE`` and ``RESET`` name the
    lifecycle functions where they differ. Function names are ``PREFIX`` + suffix.
    """

    TYPE_FUNCTIONS: dict[str, tuple[str, Any]] = {}
    PREFIX = ""
    FMPY_CLASSES: dict[str, type] = {}
    """fmpy's class for each mode; it loads the library and declares the C signatures."""
    FREE_INSTANCE = "FreeInstance"
    TERMINATE = "Terminate"
    RESET = "Reset"
    CONTINUOUS_STATE_FUNCTIONS: dict[str, str] = {}
    """Suffixes of the model-exchange functions `continuous_state_functions` binds, by key."""

    def __init__(self, description: FMUDescription, mode: str, instance_name: str | None = None,
                 instances_per_process: str = "copies"):
        self.description = description
        self.mode = mode
        self.fmu_name = description.name
        self.instance_name = instance_name or description.interface(mode).modelIdentifier
        library = description.library_path(mode)
        private = check_instances_per_process(instances_per_process) == "copies"
        self._lease: LibraryLease | None = None
        if description.once_per_process(mode):
            self._lease = lease_library(library, self.fmu_name, description.unzip_dir / "resources", private)
        try:
            self._fmu = self._load_library(library, self._lease.path if self._lease else library)
        except BaseException:
            self._release()
            raise
        self.raw = FunctionTable(self._fmu.dll, self.fmu_name)
        self._addresses: dict[str, int] = {}
        self.component: Any = None
        self.log = FMULog(description.model_name, self.instance_name)

    def _load_library(self, binary: Path, library: Path) -> Any:
        """fmpy's object for ``library`` (the FMU's ``binary`` or a private copy of it), made once
        per process and mode: it declares the C signatures on its ``dll``, which every instance of
        the library then shares (declaring them costs ~2 ms, which a pool of many envs used to pay
        per env).

        The first load of a binary on this machine is tried in a child process first
        (`modelicagym.fmu.trial`; a copy's verdict is its binary's). fmpy changes the working
        directory to the binary's folder while it loads the library and, if that fails, leaves it
        there: it is put back either way.
        """
        fmpy_class = self.FMPY_CLASSES[self.mode]
        identifier = self.description.interface(self.mode).modelIdentifier
        key = (fmpy_class, str(library), identifier)
        loaded = _LOADED.get(key)
        if loaded is None:
            check_first_load(self.description, self.mode, binary)
            working_directory = os.getcwd()
            try:
                loaded = fmpy_class(
                    guid=self.description.guid,
                    modelIdentifier=identifier,
                    unzipDirectory=str(library.parents[2]),  # FMI 3.0's class finds the library from it
                    instanceName=self.instance_name,
                    libraryPath=str(library),
                )
            except Exception as error:
                raise FMUError(f"{self.fmu_name}: cannot load {library}: {error}") from error
            finally:
                os.chdir(working_directory)
            _LOADED[key] = loaded
        return loaded

    def _check_instantiated(self, function: str) -> None:
        """Raise `FMUError` with the FMU's own messages if ``function`` returned no instance."""
        if not self.component:
            self.component = None
            messages = " | ".join(self.log.take_recent())
            raise FMUError(f"{self.fmu_name}: {function} failed{': ' + messages if messages else ''}")

    def function_address(self, name: str) -> int:
        """The address of the FMU's C function ``name`` (e.g. ``"fmi2DoStep"``), for native callers
        (looked up once: native paths re-bind after every reset)."""
        address = self._addresses.get(name)
        if address is None:
            address = self._addresses[name] = ctypes.cast(self.raw[name], ctypes.c_void_p).value
        return address

    # -- status handling -------------------------------------------------------------------------

    def fail(self, function: str, status: int) -> FMUCallError:
        """The error for a failed call, carrying what the FMU logged just before."""
        return FMUCallError(f"{self.fmu_name} ({self.instance_name})", function, status, self.log.take_recent())

    def call(self, function: str, *args: Any) -> int:
        """Call ``function`` on the live instance; raise `FMUCallError` unless it returns OK/Warning."""
        status = self.raw[self.PREFIX + function](self.component, *args)
        if status > WARNING:
            raise self.fail(self.PREFIX + function, status)
        return status

    # -- values ----------------------------------------------------------------------------------

    def value_ctype(self, fmi_type: str) -> Any:
        try:
            return self.TYPE_FUNCTIONS[fmi_type][1]
        except KeyError:
            raise FMUError(f"{self.fmu_name}: values of type {fmi_type} are not supported") from None

    def accessors(self, fmi_type: str, refs: Any, values: Any, n_values: int) -> tuple[Callable[[], int], Callable[[], int]]:
        """Zero-argument ``(get, set)`` calls moving ``values`` for value references ``refs``.

        Everything is bound in advance, so a call allocates nothing; rebind after re-instantiating.
        """
        suffix = self.TYPE_FUNCTIONS[fmi_type][0]
        getter, setter = self.raw[self.PREFIX + "Get" + suffix], self.raw[self.PREFIX + "Set" + suffix]
        extra = self._value_count_args(n_values)
        return (
            partial(getter, self.component, refs, len(refs), values, *extra),
            partial(setter, self.component, refs, len(refs), values, *extra),
        )

    def _value_count_args(self, n_values: int) -> tuple[int, ...]:
        return ()

    def set_values(self, values: dict[str, Any]) -> None:
        """Set variables by name (slow path: parameters and start values)."""
        for name, value in values.items():
            variable = self.description.variables[name]
            array = np.asarray(value).ravel()
            if variable.kind == "string":
                self._set_strings(variable.value_reference, [str(v) for v in array])
                continue
            ctype = self.value_ctype(variable.fmi_type)
            refs = (ctypes.c_uint * 1)(variable.value_reference)
            buffer = (ctype * array.size)(*array.tolist())
            _, setter = self.accessors(variable.fmi_type, refs, buffer, array.size)
            status = setter()
            if status > WARNING:
                raise FMUCallError(
                    f"{self.fmu_name} ({self.instance_name})",
                    f"{self.PREFIX}Set{self.TYPE_FUNCTIONS[variable.fmi_type][0]}({name}={value!r})",
                    status,
                    self.log.take_recent(),
                )

    def get_values(self, names: list[str]) -> dict[str, Any]:
        """Read variables by name (slow path, for inspection and tests)."""
        result: dict[str, Any] = {}
        for name in names:
            variable = self.description.variables[name]
            ctype = self.value_ctype(variable.fmi_type)
            refs = (ctypes.c_uint * 1)(variable.value_reference)
            buffer = (ctype * variable.size)()
            getter, _ = self.accessors(variable.fmi_type, refs, buffer, variable.size)
            status = getter()
            if status > WARNING:
                raise self.fail(f"{self.PREFIX}Get{self.TYPE_FUNCTIONS[variable.fmi_type][0]}({name})", status)
            values = list(buffer)
            result[name] = values[0] if not variable.shape else np.reshape(values, variable.shape)
        return result

    def _set_strings(self, value_reference: int, values: list[str]) -> None:
        refs = (ctypes.c_uint * 1)(value_reference)
        buffer = (ctypes.c_char_p * len(values))(*(v.encode() for v in values))
        self.call("SetString", refs, 1, buffer, *self._value_count_args(len(values)))

    # -- lifecycle (per version) -----------------------------------------------------------------

    def instantiate(self, logging_on: bool = False) -> None:
        raise NotImplementedError

    def free_instance(self) -> None:
        """Free the instance but keep the library loaded, so it can be instantiated again."""
        if self.component is not None:
            self.raw[self.PREFIX + self.FREE_INSTANCE](self.component)
            self.component = None

    def configure(self, values: dict[str, Any]) -> None:
        """Set structural parameters (FMI 3.0 configuration mode; earlier versions have none)."""
        raise FMUError(f"{self.fmu_name}: structural parameters ({', '.join(values)}) exist only in FMI 3.0")

    def enter_initialization(self, start_time: float, stop_time: float | None, tolerance: float | None) -> None:
        raise NotImplementedError

    def exit_initialization(self) -> None:
        self.call("ExitInitializationMode")

    def terminate(self) -> None:
        self.call(self.TERMINATE)

    def reset(self) -> None:
        self.call(self.RESET)

    def do_step_call(self) -> Callable[[float, float], int]:
        """A fast ``(t, h) -> status`` co-simulation step returning OK, TERMINATED, DISCARD, ERROR or FATAL."""
        raise NotImplementedError

    # -- state snapshots -------------------------------------------------------------------------

    def get_state(self, state: Any = None) -> Any:
        """Snapshot the instance; pass an earlier snapshot to overwrite it in place."""
        state = ctypes.c_void_p() if state is None else state
        self.call(self._state_name("Get"), ctypes.byref(state))
        return state

    def set_state(self, state: Any) -> None:
        self.call(self._state_name("Set"), state)

    def free_state(self, state: Any) -> None:
        if self.component is not None and state:
            self.raw[self.PREFIX + self._state_name("Free")](self.component, ctypes.byref(state))

    def _state_name(self, verb: str) -> str:
        raise NotImplementedError

    SERIALIZE_FUNCTIONS: tuple[str, str, str] = ("", "", "")
    """Suffixes of (size of a serialized state, serialize, deserialize)."""
    BYTE: Any = ctypes.c_char
    """The ctypes type of a serialized state's bytes."""

    def serialize_state(self, state: Any) -> bytes:
        """The bytes of snapshot ``state`` (from `get_state`), which `deserialize_state` turns back
        into a snapshot in any process that loaded the same FMU."""
        size_name, serialize_name, _ = self.SERIALIZE_FUNCTIONS  # fmpy declared their signatures
        size = ctypes.c_size_t(0)
        self.call(size_name, state, ctypes.byref(size))
        buffer = ctypes.create_string_buffer(size.value)
        self.call(serialize_name, state, self._byte_pointer(buffer), size)
        return buffer.raw

    def deserialize_state(self, data: bytes, state: Any = None) -> Any:
        """A snapshot (as `get_state` gives) made from ``data``; pass an earlier one to overwrite it."""
        state = ctypes.c_void_p() if state is None else state
        name = self.SERIALIZE_FUNCTIONS[2]
        buffer = ctypes.create_string_buffer(data, len(data))
        self.call(name, self._byte_pointer(buffer), len(data), ctypes.byref(state))
        return state

    def _byte_pointer(self, buffer: ctypes.Array) -> Any:
        """``buffer`` as a pointer to the version's byte type (fmi2Byte is char, fmi3Byte uint8)."""
        return ctypes.cast(buffer, ctypes.POINTER(self.BYTE))

    # -- model exchange (per version) --------------------------------------------------------------

    def enter_event_mode(self) -> None:
        self.call("EnterEventMode")

    def enter_continuous_time_mode(self) -> None:
        self.call("EnterContinuousTimeMode")

    def update_discrete_states(self) -> tuple[bool, bool, bool, float | None]:
        """One event iteration: ``(needs_more, terminate, states_changed, next_event_time)``."""
        raise NotImplementedError

    def completed_integrator_step(self) -> tuple[bool, bool]:
        """``(enter_event_mode, terminate)`` after an accepted integrator step."""
        raise NotImplementedError

    def continuous_state_functions(self) -> dict[str, Callable[..., int]]:
        """``(pointer, n)`` calls bound to this instance, raising `FMUCallError` as `call` does:
        set_time (``(t)``), get_x, set_x, get_dx, get_z, get_nominals."""
        return {key: self._checked(self.PREFIX + suffix) for key, suffix in self.CONTINUOUS_STATE_FUNCTIONS.items()}

    def _checked(self, function: str) -> Callable[..., int]:
        """`call` for one function, looked up once (a solver calls these thousands of times a step)."""
        raw = self.raw[function]

        def checked(*args: Any) -> int:
            status = raw(self.component, *args)
            if status > WARNING:
                raise self.fail(function, status)
            return status

        return checked

    def close(self) -> None:
        """Free the instance and release the log route and the library's lease; the library is
        left to the OS (loaded, for the next binding)."""
        try:
            self.free_instance()
        finally:
            self.log.close()
            self._release()

    def _release(self) -> None:
        if self._lease is not None:
            self._lease.release()
            self._lease = None
