"""Every C struct and constant of our native library as Python sees it, in one place, checked.

The ctypes mirrors below follow the C headers in ``csrc/`` field for field. A mirror that drifts from
its header would make C read and write the wrong bytes, silently; so the library exports its own
layout (``csrc/abi.c``: each struct's size, each field's offset, each constant's value) and
:func:`check_layout` compares it with these mirrors when the library is loaded. A mismatch is a
`NativeABIError` naming every difference, never memory corruption.

The layers that talk to C (the env's native step, the pool's native slices, the model-exchange
integrator, the Q-learning agent) take their structs and codes from here; nothing else declares one.
"""

from __future__ import annotations

import ctypes
from collections.abc import Mapping

import numpy as np

from modelicagym.errors import NativeBuildError

__all__ = [
    "COLLECT_DONE",
    "COLLECT_SLOW",
    "CONSTANTS",
    "NO_RESET",
    "RESET_THEN_REPORT",
    "RESET_THEN_STEP",
    "SERVE_PYTHON_STEP",
    "SERVE_TIMEOUT",
    "STRUCTS",
    "SUNDIALS_FUNCTIONS",
    "AutoresetCode",
    "CVodeMethod",
    "FailedCall",
    "Flags",
    "IntegratorCall",
    "IntegratorOutcome",
    "MgBarrier",
    "MgBatch",
    "MgComponent",
    "MgLink",
    "MgSystem",
    "MgTable",
    "MgCall",
    "MgCollector",
    "MgEnv",
    "MgIntegrator",
    "MgMove",
    "MgPart",
    "MgQLearner",
    "MgRange",
    "MgRecorder",
    "MgServer",
    "MgSundials",
    "MgWaiter",
    "NativeABIError",
    "Solver",
    "StepClock",
    "ValueType",
    "check_layout",
]


class NativeABIError(NativeBuildError):
    """The native library's structs or constants differ from the Python mirrors of ``native/abi.py``."""


# -- constants -------------------------------------------------------------------------------------


class Flags:
    """What ``mg_env_step`` / ``mg_step_batch`` report per env (``MG_TERMINATED``, ...), plain ints."""

    TERMINATED = 1
    TRUNCATED = 2
    MODEL_ENDED = 4
    FMU_ERROR = 8
    RESET_DONE = 16
    PYTHON_RESET = 32
    BAD_ACTION = 64

    @staticmethod
    def ending(flags: int) -> tuple[bool, bool, dict[str, bool]]:
        """``(terminated, truncated, info)`` of a step C finished with ``flags``: the one place
        they are read back into Gymnasium's terms (the single env and the pool's slice both use it)."""
        info = {"fmu_terminated": True} if flags & Flags.MODEL_ENDED else {}
        return bool(flags & Flags.TERMINATED), bool(flags & Flags.TRUNCATED), info


class FailedCall:
    """``mg_env.failed_call``: which call of a native step failed (``MG_CALL_*``)."""

    SET_INPUTS = 1
    DO_STEP = 2
    GET_OUTPUTS = 3
    SET_STATE = 4
    INTEGRATE = 5
    LOG_ERRORS = 6
    LOOP_GUARD = 7


class ValueType:
    """``mg_move.source_type`` / ``target_type`` (``MG_TYPE_*``): the numpy dtype of a moved value."""

    F64 = 0
    F32 = 1
    I8 = 2
    U8 = 3
    I16 = 4
    U16 = 5
    I32 = 6
    U32 = 7
    I64 = 8
    U64 = 9
    BOOL = 10

    @staticmethod
    def of(dtype: object) -> int:
        """The code of a numpy dtype (a `KeyError` for one C does not move: strings, objects)."""
        return _VALUE_TYPES[np.dtype(dtype).str[1:]]


_VALUE_TYPES = {"f8": ValueType.F64, "f4": ValueType.F32, "i1": ValueType.I8, "u1": ValueType.U8,
                "i2": ValueType.I16, "u2": ValueType.U16, "i4": ValueType.I32, "u4": ValueType.U32,
                "i8": ValueType.I64, "u8": ValueType.U64, "b1": ValueType.BOOL}


class AutoresetCode:
    """``mg_batch.autoreset_mode`` (``MG_AUTORESET_*``)."""

    NEXT_STEP = 0
    SAME_STEP = 1
    DISABLED = 2


#: values of ``mg_batch.needs_reset``: none; the env ended and its next step is its reset
#: (``NEXT_STEP``); it moved to this process at an episode boundary (``SAME_STEP``): reset it, then step it
NO_RESET, RESET_THEN_REPORT, RESET_THEN_STEP = 0, 1, 2
#: ``mg_serve`` return values that are not command codes
SERVE_TIMEOUT, SERVE_PYTHON_STEP = -1, -2
#: ``mg_collect`` return values
COLLECT_DONE, COLLECT_SLOW = 0, 1


class Solver:
    """``mg_integrator.solver`` (``MG_SOLVER_*``)."""

    CVODE = 0
    EULER = 1
    RK4 = 2


class CVodeMethod:
    """``mg_integrator.method`` (``MG_CVODE_*``): BDF, Adams, or Adams until the model proves stiff."""

    BDF = 0
    ADAMS = 1
    AUTO = 2


class IntegratorOutcome:
    """What ``mg_integrator_open`` / ``mg_integrator_advance`` return (``MG_INTEGRATOR_*``)."""

    OK = 0
    TERMINATE = 1
    FAILED = 2


class IntegratorCall:
    """``mg_integrator.failed_call`` (``MG_FMU_CALL_*``): the FMU call that failed, or the solver."""

    SET_TIME = 1
    SET_X = 2
    GET_X = 3
    GET_DX = 4
    GET_Z = 5
    GET_NOMINALS = 6
    COMPLETED_STEP = 7
    ENTER_EVENT_MODE = 8
    UPDATE_DISCRETE_STATES = 9
    ENTER_CONTINUOUS_TIME_MODE = 10
    SOLVER = 11


def _prefixed(prefix: str, codes: type) -> dict[str, int]:
    return {f"{prefix}{name}": value for name, value in vars(codes).items() if name.isupper()}


#: every constant C and Python share: its C name -> the value Python uses
CONSTANTS: dict[str, int] = {
    **_prefixed("MG_", Flags),
    **_prefixed("MG_CALL_", FailedCall),
    **_prefixed("MG_AUTORESET_", AutoresetCode),
    "MG_NO_RESET": NO_RESET,
    "MG_RESET_THEN_REPORT": RESET_THEN_REPORT,
    "MG_RESET_THEN_STEP": RESET_THEN_STEP,
    "MG_SERVE_TIMEOUT": SERVE_TIMEOUT,
    "MG_SERVE_PYTHON_STEP": SERVE_PYTHON_STEP,
    "MG_COLLECT_DONE": COLLECT_DONE,
    "MG_COLLECT_SLOW": COLLECT_SLOW,
    **_prefixed("MG_SOLVER_", Solver),
    **_prefixed("MG_CVODE_", CVodeMethod),
    **_prefixed("MG_INTEGRATOR_", IntegratorOutcome),
    **_prefixed("MG_FMU_CALL_", IntegratorCall),
    **_prefixed("MG_TYPE_", ValueType),
}


# -- structs ---------------------------------------------------------------------------------------


def _pointers(*names: str) -> list[tuple[str, type]]:
    return [(name, ctypes.c_void_p) for name in names]


class MgRecorder(ctypes.Structure):
    """``mg_recorder`` (``csrc/step.h``): the first steps of a fresh instance, recorded by either
    step path (see `modelicagym.fmu.reference`)."""

    _fields_ = [
        *_pointers("dts", "inputs", "outputs"),
        ("input_bytes", ctypes.c_int64),
        ("output_bytes", ctypes.c_int64),
        ("capacity", ctypes.c_int64),
        ("count", ctypes.c_int64),
    ]


class StepClock(ctypes.Structure):
    """``mg_clock`` (``csrc/step.h``): an instance's time bookkeeping, shared by the Python and the
    native step path (see `modelicagym.fmu.clock`)."""

    _fields_ = [
        ("time", ctypes.c_double),
        ("origin", ctypes.c_double),
        ("dt", ctypes.c_double),
        ("start_time", ctypes.c_double),
        ("steps", ctypes.c_int64),
        ("fmu_time_ns", ctypes.c_int64),
        ("terminated", ctypes.c_int32),
        ("broken", ctypes.c_int32),
        ("log_errors", ctypes.c_int32),
        ("log_error_limit", ctypes.c_int32),
        ("recorder", ctypes.POINTER(MgRecorder)),
    ]


#: the SUNDIALS functions the native integrator calls, in ``mg_sundials`` order
SUNDIALS_FUNCTIONS = (
    "SUNContext_Create", "SUNContext_Free", "SUNContext_ClearErrHandlers", "SUNContext_PushErrHandler",
    "N_VNew_Serial", "N_VDestroy", "N_VGetArrayPointer",
    "SUNDenseMatrix", "SUNMatDestroy", "SUNLinSol_Dense", "SUNLinSolFree", "SUNNonlinSol_FixedPoint",
    "SUNNonlinSolFree",
    "CVodeCreate", "CVodeInit", "CVodeReInit", "CVodeSVtolerances", "CVodeRootInit",
    "CVodeSetLinearSolver", "CVodeSetNonlinearSolver", "CVodeSetMaxNumSteps", "CVodeSetNoInactiveRootWarn",
    "CVodeSetUserData", "CVode", "CVodeGetRootInfo", "CVodeGetNumNonlinSolvConvFails", "CVodeFree",
)


class MgSundials(ctypes.Structure):
    """``mg_sundials`` (``csrc/integrator.h``): addresses of the SUNDIALS functions."""

    _fields_ = _pointers(*SUNDIALS_FUNCTIONS)


class MgIntegrator(ctypes.Structure):
    """``mg_integrator`` (``csrc/integrator.h``): one model-exchange instance's solver loop."""

    _fields_ = [
        ("fmi_version", ctypes.c_int32),
        ("solver", ctypes.c_int32),
        ("method", ctypes.c_int32),
        ("stiff", ctypes.c_int32),
        ("component", ctypes.c_void_p),
        *_pointers("set_time", "set_x", "get_x", "get_dx", "get_z", "get_nominals", "completed_integrator_step",
                   "enter_event_mode", "update_discrete_states", "enter_continuous_time_mode"),
        ("nx", ctypes.c_int64),
        ("nz", ctypes.c_int64),
        ("needs_completed_integrator_step", ctypes.c_int32),
        ("tolerance", ctypes.c_double),
        ("step_size", ctypes.c_double),
        ("continuous", ctypes.c_int32),
        ("has_next_event", ctypes.c_int32),
        ("next_event_time", ctypes.c_double),
        *_pointers("x", "dx", "z", "previous_z", "roots", "stages"),
        ("sundials", ctypes.POINTER(MgSundials)),
        *_pointers("context", "cvode", "y", "abstol", "matrix", "linear_solver", "nonlinear_solver"),
        ("failed_call", ctypes.c_int32),
        ("fmi_status", ctypes.c_int32),
        ("failed_at", ctypes.c_double),
        ("message", ctypes.c_char * 256),
    ]


class MgCall(ctypes.Structure):
    """``mg_call`` (``csrc/step.h``): one fmiSet/fmiGet call of a native step (one FMI type's buffer)."""

    _fields_ = [
        *_pointers("function", "refs"),
        ("n_refs", ctypes.c_int64),
        ("values", ctypes.c_void_p),
        ("n_values", ctypes.c_int64),
        ("n_bytes", ctypes.c_int64),
    ]


class MgMove(ctypes.Structure):
    """``mg_move`` (``csrc/step.h``): one value a native step moves and converts (``ValueType`` codes)."""

    _fields_ = [
        ("source", ctypes.c_int64),
        ("target", ctypes.c_int64),
        ("source_type", ctypes.c_int32),
        ("target_type", ctypes.c_int32),
    ]


class MgEnv(ctypes.Structure):
    """``mg_env`` (``csrc/step.h``): one env on the native step path."""

    _fields_ = [
        ("fmi_version", ctypes.c_int32),
        ("discrete", ctypes.c_int32),
        ("python_inputs", ctypes.c_int32),
        ("python_observation", ctypes.c_int32),
        *_pointers("component", "do_step", "get_boolean_status", "set_state", "snapshot", "integrator"),
        ("event_mode_inputs", ctypes.c_int32),
        ("snapshot_has_next_event", ctypes.c_int32),
        ("snapshot_next_event_time", ctypes.c_double),
        ("set_calls", ctypes.c_void_p),
        ("n_set_calls", ctypes.c_int64),
        ("get_calls", ctypes.c_void_p),
        ("n_get_calls", ctypes.c_int64),
        ("action_moves", ctypes.c_void_p),
        ("n_inputs", ctypes.c_int64),
        *_pointers("input_starts", "observation_moves"),
        ("n_outputs", ctypes.c_int64),
        ("observation", ctypes.c_void_p),
        ("observation_bytes", ctypes.c_int64),
        ("action_table", ctypes.c_void_p),
        ("n_actions", ctypes.c_int64),
        *_pointers("action_low", "action_high", "bound_index", "bound_low", "bound_high"),
        ("n_bounds", ctypes.c_int64),
        ("time_step", ctypes.c_double),
        ("positive_reward", ctypes.c_double),
        ("negative_reward", ctypes.c_double),
        ("max_episode_steps", ctypes.c_int64),
        ("elapsed_steps", ctypes.c_int64),
        ("native_reset", ctypes.c_int32),
        ("fmi_status", ctypes.c_int32),
        ("failed_call", ctypes.c_int32),
        ("clock", ctypes.POINTER(StepClock)),
        ("system", ctypes.c_void_p),
    ]


class MgLink(ctypes.Structure):
    """``mg_link`` (``csrc/step.h``): one connection of a system, ``target = scale * source + shift``."""

    _fields_ = [
        ("source", ctypes.c_int64),
        ("target", ctypes.c_int64),
        ("source_type", ctypes.c_int32),
        ("target_type", ctypes.c_int32),
        ("scale", ctypes.c_double),
        ("shift", ctypes.c_double),
    ]


class MgTable(ctypes.Structure):
    """``mg_table`` (``csrc/step.h``): a time table of a system, interpolated in C."""

    _fields_ = [
        ("times", ctypes.c_void_p),
        ("n_times", ctypes.c_int64),
        *_pointers("values", "outputs"),
        ("n_outputs", ctypes.c_int64),
        ("offset", ctypes.c_void_p),
        ("clock", ctypes.POINTER(StepClock)),
    ]


class MgComponent(ctypes.Structure):
    """``mg_component`` (``csrc/step.h``): one component of a system, in stepping order."""

    _fields_ = [
        *_pointers("env", "table", "links"),
        ("n_links", ctypes.c_int64),
        ("action_links", ctypes.c_void_p),
        ("n_action_links", ctypes.c_int64),
        ("inputs_changed", ctypes.c_int32),
    ]


class MgSystem(ctypes.Structure):
    """``mg_system`` (``csrc/step.h``): a system env's master algorithm over its components."""

    _fields_ = [
        ("components", ctypes.c_void_p),
        ("n_components", ctypes.c_int64),
        ("jacobi", ctypes.c_int32),
        ("substeps", ctypes.c_int32),
        ("output_links", ctypes.c_void_p),
        ("n_output_links", ctypes.c_int64),
        ("failed_component", ctypes.c_int64),
        ("guards", ctypes.c_void_p),
        ("n_guards", ctypes.c_int64),
        ("guard_bound", ctypes.c_double),
        ("failed_guard", ctypes.c_int64),
    ]


class MgBatch(ctypes.Structure):
    """``mg_batch`` (``csrc/slice.h``): a slice of a pool's envs and where its results go."""

    _fields_ = [
        ("envs", ctypes.c_void_p),
        ("n", ctypes.c_int64),
        ("autoreset_mode", ctypes.c_int32),
        ("actions", ctypes.c_void_p),
        ("action_stride", ctypes.c_int64),
        ("observations", ctypes.c_void_p),
        ("obs_stride", ctypes.c_int64),
        *_pointers("final_obs", "final_ready", "rewards", "terminations", "truncations", "needs_reset", "active",
                   "in_caller"),
        ("caller", ctypes.c_int32),
        *_pointers("flags", "current_env"),
        ("first_env", ctypes.c_int64),
        *_pointers("timing_enabled", "timing"),
        ("action_parts", ctypes.c_void_p),
        ("n_action_parts", ctypes.c_int64),
        ("obs_parts", ctypes.c_void_p),
        ("n_obs_parts", ctypes.c_int64),
        ("scratch", ctypes.c_void_p),
    ]


class MgPart(ctypes.Structure):
    """``mg_part`` (``csrc/slice.h``): one entry of a Dict space in the pool's shared memory."""

    _fields_ = [
        ("offset", ctypes.c_int64),
        ("bytes", ctypes.c_int64),
        *_pointers("base", "final_base"),
        ("stride", ctypes.c_int64),
    ]


class MgRange(ctypes.Structure):
    """``mg_range`` (``csrc/actions.h``): one array of a batch of actions to range-check."""

    _fields_ = [
        ("values", ctypes.c_void_p),
        ("n", ctypes.c_int64),
        ("width", ctypes.c_int64),
        ("is_float", ctypes.c_int32),
        ("low_int", ctypes.c_int64),
        ("high_int", ctypes.c_int64),
        *_pointers("low", "high"),
    ]

    @classmethod
    def over(cls, view: np.ndarray, low: np.ndarray, high: np.ndarray) -> tuple[MgRange, tuple[np.ndarray, ...]] | None:
        """The check of ``view`` (n rows of actions) against ``[low, high]`` per element, with the
        bound arrays it points into (keep them alive as long as it): int64 values within one range,
        float64 values within finite bounds; else ``None`` (C cannot check it)."""
        n, width = len(view), int(np.prod(view.shape[1:], dtype=np.int64))
        if view.dtype == np.int64 and low.min() == low.max() and high.min() == high.max():
            return cls(values=view.ctypes.data, n=n, width=width, is_float=0, low_int=int(low.min()),
                       high_int=int(high.max())), ()
        if view.dtype == np.float64 and np.isfinite(low).all() and np.isfinite(high).all():
            lows, highs = (np.ascontiguousarray(bound, dtype=np.float64) for bound in (low, high))
            return cls(values=view.ctypes.data, n=n, width=width, is_float=1, low=lows.ctypes.data,
                       high=highs.ctypes.data), (lows, highs)
        return None


class MgWaiter(ctypes.Structure):
    """``mg_waiter`` (``csrc/signal.h``): one waiting party's adaptive state and what its waits did."""

    _fields_ = [
        ("ready", ctypes.c_int64),
        ("spun", ctypes.c_int64),
        ("slept", ctypes.c_int64),
        ("blocked", ctypes.c_int64),
        ("long_waits", ctypes.c_int64),
    ]


class MgBarrier(ctypes.Structure):
    """``mg_barrier`` (``csrc/slice.h``): a pool step's barrier, in the pool's shared memory (Python
    only allocates it: `SharedBuffers.barrier`)."""

    _fields_ = [
        ("bell", ctypes.c_uint32),
        ("pad_bell", ctypes.c_uint32 * 15),
        ("countdown", ctypes.c_uint32),
        ("pad_countdown", ctypes.c_uint32 * 15),
        ("all_done", ctypes.c_uint8 * 16),  # an mg_signal (csrc/signal.h)
        ("pad_all_done", ctypes.c_uint8 * 48),
    ]


class MgServer(ctypes.Structure):
    """``mg_server`` (``csrc/slice.h``): a worker's command loop in C."""

    _fields_ = [
        *_pointers("batch", "go", "done", "barrier"),
        ("slot", ctypes.c_int64),
        *_pointers("command", "reply"),
        ("step_code", ctypes.c_int32),
        *_pointers("spin_ns"),
        ("timeout_ns", ctypes.c_int64),
        ("waiter", ctypes.c_void_p),
    ]


class MgCollector(ctypes.Structure):
    """``mg_collector`` (``csrc/slice.h``): the parent's side of a pool step."""

    _fields_ = [
        ("n_workers", ctypes.c_int64),
        *_pointers("go", "done", "barrier", "replies", "stepping", "spin_ns"),
        ("timeout_ns", ctypes.c_int64),
        ("waiter", ctypes.c_void_p),
        ("calls", ctypes.c_int64),
        ("wait_ns", ctypes.c_int64),
    ]


class MgQLearner(ctypes.Structure):
    """``mg_qlearner`` (``csrc/qlearning.h``): one Q-learning agent's tables and settings."""

    _fields_ = [
        ("n_envs", ctypes.c_int64),
        ("n_states", ctypes.c_int64),
        ("n_actions", ctypes.c_int64),
        ("n_vars", ctypes.c_int64),
        ("max_edges", ctypes.c_int64),
        *_pointers("q", "epsilon", "edges", "strides"),
        ("learning_rate", ctypes.c_double),
        ("discount", ctypes.c_double),
        ("exploration_decay", ctypes.c_double),
        ("bootstrap_on_truncation", ctypes.c_int32),
    ]


#: every struct C and Python share: its C name -> its mirror
STRUCTS: dict[str, type[ctypes.Structure]] = {
    "mg_recorder": MgRecorder,
    "mg_clock": StepClock,
    "mg_sundials": MgSundials,
    "mg_integrator": MgIntegrator,
    "mg_call": MgCall,
    "mg_move": MgMove,
    "mg_env": MgEnv,
    "mg_link": MgLink,
    "mg_table": MgTable,
    "mg_component": MgComponent,
    "mg_system": MgSystem,
    "mg_batch": MgBatch,
    "mg_part": MgPart,
    "mg_range": MgRange,
    "mg_waiter": MgWaiter,
    "mg_barrier": MgBarrier,
    "mg_server": MgServer,
    "mg_collector": MgCollector,
    "mg_qlearner": MgQLearner,
}


# -- the check -------------------------------------------------------------------------------------


class _Entry(ctypes.Structure):
    """``mg_abi_entry`` (``csrc/abi.c``): a struct's size, a field's offset or a constant's value."""

    _fields_ = [("name", ctypes.c_char_p), ("value", ctypes.c_int64)]


def exported_layout(library: ctypes.CDLL) -> dict[str, int]:
    """What the library says of itself: ``{"mg_env": size, "mg_env.component": offset, "MG_...": value}``."""
    entries = ctypes.POINTER(_Entry)()
    count = library.mg_abi(ctypes.byref(entries))
    return {entries[i].name.decode(): entries[i].value for i in range(count)}


def expected_layout() -> dict[str, int]:
    """The same table from the Python mirrors."""
    layout: dict[str, int] = dict(CONSTANTS)
    for name, struct in STRUCTS.items():
        layout[name] = ctypes.sizeof(struct)
        for field, _ in struct._fields_:
            layout[f"{name}.{field}"] = getattr(struct, field).offset
    return layout


def layout_differences(exported: Mapping[str, int], expected: Mapping[str, int]) -> list[str]:
    """One line per difference between the library's layout and the mirrors' (empty: they agree)."""
    problems = []
    for name in sorted(expected.keys() | exported.keys()):
        if name not in exported:
            problems.append(f"{name}: in the Python mirror ({expected[name]}), not in the C library")
        elif name not in expected:
            problems.append(f"{name}: in the C library ({exported[name]}), not in the Python mirror")
        elif exported[name] != expected[name]:
            what = "value" if name.isupper() else "offset" if "." in name else "size"
            problems.append(f"{name}: {what} {exported[name]} in C, {expected[name]} in Python")
    return problems


def check_layout(library: ctypes.CDLL, path: str) -> None:
    """Raise `NativeABIError` unless every struct and constant of ``library`` matches its mirror."""
    problems = layout_differences(exported_layout(library), expected_layout())
    if problems:
        listed = "\n  ".join(problems)
        raise NativeABIError(
            f"the native library {path} does not match modelicagym/native/abi.py ({len(problems)} "
            f"difference(s)); a header in native/csrc changed without its mirror:\n  {listed}"
        )
