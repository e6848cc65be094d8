"""A slice of a pool's envs stepped in one C call.

`NativeBatch` points ``mg_batch`` (``csrc/slice.h``) at the envs' own ``mg_env`` structs (see
`modelicagym.env.native_step`) and at the pool's shared arrays, so one ``mg_step_batch`` call steps
every env of the slice with the pool's autoreset and writes observations, rewards, terminations,
truncations and timing where the parent reads them. What C leaves to Python (an FMU error, a reset
the reset ladder must do, an info to report, an action outside the space) is in the per-env
``flags``; the caller finishes those envs on the Python path. A slice whose envs end their steps in
Python (``python_endings``: a reward or termination written in Python) or make their observations
in Python (``python_observation``: an overridden ``observation``) steps in two C calls with
Python's part between them (`modelicagym.vector.slice.slice_endings`, ``csrc/endings.h``); one whose
inputs are Python's (``python_inputs``: an overridden ``action_to_inputs``) has them written before
its C call (`modelicagym.vector.slice.slice_edges`).

The processes' waits around it are theirs: a worker's in `modelicagym.vector.worker.native_server`,
the calling process's in `modelicagym.vector.dispatch.native_collector`.
"""

from __future__ import annotations

import ctypes
import functools
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from gymnasium.spaces import Box, Dict, Discrete, MultiBinary, MultiDiscrete
from gymnasium.vector import AutoresetMode

from modelicagym.errors import ArgumentError
from modelicagym.native.abi import AutoresetCode, Flags, MgBatch, MgEnv, MgPart, MgRange, NativeABIError
from modelicagym.native.library import load_library
from modelicagym.vector.env_contract import NativeEnv, PoolEnv
from modelicagym.vector.wire.buffers import SharedBuffers
from modelicagym.vector.wire.shared_fields import SHARED_FIELDS, SharedField, Values

__all__ = [
    "SLICE_FIELDS",
    "NativeBatch",
    "batch_path_reason",
    "check_batch_contract",
]

#: the spaces whose values are one row of the pool's shared memory per env
_ARRAY_SPACES = (Box, Discrete, MultiDiscrete, MultiBinary)
#: flags of an env that Python must finish after ``mg_step_batch``
NEEDS_PYTHON = Flags.FMU_ERROR | Flags.PYTHON_RESET | Flags.MODEL_ENDED | Flags.BAD_ACTION

_AUTORESET_CODES = {AutoresetMode.NEXT_STEP: AutoresetCode.NEXT_STEP, AutoresetMode.SAME_STEP: AutoresetCode.SAME_STEP,
                    AutoresetMode.DISABLED: AutoresetCode.DISABLED}


def python_sides(env: NativeEnv) -> tuple[bool, bool]:
    """Whether ``env`` (on the native path) computes its inputs, and its observation, in Python."""
    return bool(env.native_step.python_inputs), bool(getattr(env, "python_observation", False))


def batch_path_reason(envs: list[PoolEnv]) -> str | None:
    """Why a slice of ``envs`` must step on the Python path, or ``None`` when it can be a
    `NativeBatch` (every env an unwrapped `FMUEnv` on the native path, all with the same spaces,
    array spaces: one row of shared memory per env, and the same ``python_edges`` sides: inputs
    or observation in Python for all or none). On the Python path of the slice each env steps
    through ``env.step``, which may still step its FMU in C."""
    for offset, env in enumerate(envs):
        if env is not env.unwrapped:
            return f"env {offset} of the slice is wrapped in {type(env).__name__} (the native path steps bare FMUEnvs)"
        if getattr(env, "step_path", None) != "native":
            reason = getattr(env, "step_path_reason", "it is not an FMUEnv")
            return f"env {offset} of the slice steps on the Python path: {reason}"
        sides, first_sides = python_sides(env), python_sides(envs[0])
        if sides != first_sides:
            return (f"env {offset} of the slice computes {env.python_edges or 'nothing'} in Python around its FMU's "
                    f"C step, env 0 {envs[0].python_edges or 'nothing'}: a native slice's envs agree on that")
        for role, space in (("action", env.action_space), ("observation", env.observation_space)):
            entries = space.items() if isinstance(space, Dict) else [(None, space)]
            for name, sub in entries:
                if not isinstance(sub, _ARRAY_SPACES):
                    what = f"entry {name!r} of the {role} space" if name else f"the {role} space {space}"
                    return (f"{what} is not a Box, Discrete, MultiDiscrete or MultiBinary (a native slice moves "
                            "rows of shared memory)")
        native, first = env.native_step, envs[0].native_step
        # C's layouts matter only for the rows C moves (Python reads and writes the user's spaces)
        layouts = [(mine, env_0) for python, mine, env_0 in (
            (sides[0], native.action_layout, first.action_layout),
            (sides[1], native.observation_layout, first.observation_layout)) if not python]
        for name, _, _, dtype in native.action_layout or ():
            if env.action_space[name].dtype != dtype:
                return (f"entry {name!r} of the action space is a {env.action_space[name].dtype} Box over "
                        f"{dtype} values: the pool's shared memory holds it as {env.action_space[name].dtype}")
        if any(mine != env_0 for mine, env_0 in layouts):
            return f"env {offset} lays out its Dict action or observation otherwise than env 0 (another input order)"
    return None


#: the ``mg_batch`` fields filled from the slice itself, not from shared memory (those are declared
#: in `SHARED_FIELDS`): what each holds
SLICE_FIELDS: dict[str, str] = {
    "envs": "the envs' mg_env structs",
    "n": "how many envs the slice has",
    "autoreset_mode": "the pool's autoreset (DISABLED in SAME_STEP when Python ends the steps or observes)",
    "caller": "the slice is the calling process's",
    "flags": "per env, what its last step left to Python (this process's array)",
    "first_env": "the pool index of the slice's first env",
}


def check_batch_contract(fields: Sequence[SharedField] = SHARED_FIELDS) -> None:
    """Raise `NativeABIError` unless every field of ``mg_batch`` is filled exactly once: from one
    of ``fields`` (their ``c_fields``) or from the slice (`SLICE_FIELDS`)."""
    filled = [name for field in fields for name in field.c_fields] + list(SLICE_FIELDS)
    struct = [name for name, _ in MgBatch._fields_]
    problems = [f"mg_batch.{name} is filled from no shared field nor from the slice"
                for name in struct if name not in filled]
    problems += [f"{name!r} is filled but mg_batch has no such field" for name in dict.fromkeys(filled)
                 if name not in struct]
    problems += [f"mg_batch.{name} is filled {filled.count(name)} times" for name in dict.fromkeys(filled)
                 if filled.count(name) > 1]
    if problems:
        raise NativeABIError("the shared-memory declaration (vector/wire/shared_fields.py SHARED_FIELDS, "
                             "native_slice.SLICE_FIELDS) does not fill mg_batch (native/csrc/slice.h): "
                             + "; ".join(problems))


def _row_address(array: np.ndarray, row: int) -> int:
    return array.ctypes.data + row * array.strides[0]


def _parts(layout: list[tuple[int, int, np.ndarray, np.ndarray | None]], first_env: int) -> ctypes.Array:
    """``mg_part``s of a Dict's entries: ``(offset in the env's row, bytes, shared array, final array)``."""
    parts = (MgPart * len(layout))()
    for part, (offset, size, array, final) in zip(parts, layout):
        part.offset, part.bytes, part.stride = offset, size, array.strides[0]
        part.base = _row_address(array, first_env)
        part.final_base = None if final is None else _row_address(final, first_env)
    return parts


class NativeBatch:
    """Envs ``first_env, ...`` of a pool (bare `FMUEnv` instances on the native path) stepped by one C call.

    Args:
        envs: the envs of the slice.
        first_env: the pool index of ``envs[0]``: the row of the shared arrays it uses.
        autoreset_mode: the pool's autoreset mode.
        buffers: the pool's shared memory; ``mg_batch`` is filled from its fields as
            `SHARED_FIELDS` declares (array spaces only), the rest from the slice (`SLICE_FIELDS`).
        slot: the slice's slot (its row of the per-slot fields: ``current_env``, ``timing``).
        caller: the slice is the calling process's: it steps the envs marked ``in_caller`` (a
            worker's those not marked).
        python_endings: Python decides how the envs' steps end: :meth:`step_open`, then
            :meth:`end_steps` (in ``SAME_STEP`` the C step then resets nothing itself).
        python_inputs: Python writes the envs' inputs before the C call (``mg_env.python_inputs``):
            C reads no action.
        python_observation: Python writes the envs' observations (``mg_env.python_observation``):
            C writes no observation row, and the slice steps as with ``python_endings``.
        fields: the declaration ``buffers`` was allocated from; checked to fill every field of
            ``mg_batch`` before any is filled (`check_batch_contract`).
    """

    def __init__(
        self,
        envs: list[NativeEnv],
        first_env: int,
        autoreset_mode: AutoresetMode,
        buffers: SharedBuffers,
        slot: int,
        caller: bool,
        python_endings: bool = False,
        python_inputs: bool = False,
        python_observation: bool = False,
        fields: Sequence[SharedField] = SHARED_FIELDS,
    ) -> None:
        check_batch_contract(fields)
        self.library = load_library()
        self.python_endings = python_endings
        self.python_inputs, self.python_observation = python_inputs, python_observation
        #: Python runs between the C step and the autoreset: :meth:`step_open`, then :meth:`end_steps`
        self.split = python_endings or python_observation
        #: Python runs around the C calls of every step (so ``mg_serve`` leaves each step to Python)
        self.python_phases = self.split or python_inputs
        self.first_env = first_env
        n = len(envs)
        self.natives = [env.native_step for env in envs]
        self.flags = np.zeros(n, dtype=np.int32)
        self._env_pointers = (ctypes.POINTER(MgEnv) * n)(*(ctypes.pointer(native.state) for native in self.natives))
        self._autoreset_code = _AUTORESET_CODES[autoreset_mode]
        same_step = autoreset_mode is AutoresetMode.SAME_STEP
        self.state = batch = MgBatch()
        space_values = {
            Values.ACTION: self._action_values(buffers.actions.read_batch(copy_out=False)),
            Values.OBSERVATION: self._observation_values(buffers.observations.read_batch(copy_out=False),
                                                         buffers.final_observations.read_batch(copy_out=False)),
        }
        for field in fields:
            for name, value in self._shared_values(field, buffers, slot, space_values).items():
                setattr(batch, name, value)
        batch.envs = ctypes.addressof(self._env_pointers)
        batch.n = n
        batch.autoreset_mode = AutoresetCode.DISABLED if self.split and same_step else self._autoreset_code
        batch.caller = int(caller)
        batch.flags = self.flags.ctypes.data
        batch.first_env = first_env
        self._step = self.library.mg_step_batch
        self.ref = ctypes.byref(batch)
        #: per env, after :meth:`step_open`: 1 where Python must end the env's step
        self.open = np.zeros(n, dtype=np.uint8)
        self._open_ptr = ctypes.c_void_p(self.open.ctypes.data)
        self._step_open, self._end_steps = self.library.mg_step_open, self.library.mg_end_steps

    def _shared_values(self, field: SharedField, buffers: SharedBuffers, slot: int,
                       space_values: dict[Values, dict[str, Any]]) -> dict[str, Any]:
        """The ``mg_batch`` fields ``field`` fills (its ``c_fields``, every one of them), by name:
        a row's address, or for a field of a space's values what its layout sets (``space_values``)."""
        if isinstance(field.dtype, Values):
            offered = space_values[field.dtype]
            values = {name: offered[name] for name in field.c_fields if name in offered}
        elif field.c_fields:
            row = field.rows.row(self.first_env, slot)
            values = {field.c_fields[0]: _row_address(getattr(buffers, field.name), row)}
        else:
            values = {}
        if values.keys() != set(field.c_fields):
            raise NativeABIError(f"shared field {field.name!r} declares mg_batch fields {sorted(field.c_fields)} "
                                 f"but NativeBatch fills {sorted(values)} from it")
        return values

    def _action_values(self, actions: np.ndarray | dict[str, np.ndarray]) -> dict[str, Any]:
        """A row of the shared actions per env, or a Dict action's entries gathered into a row per step."""
        first_env = self.first_env
        if self.python_inputs:  # C reads no action
            return {"actions": None, "action_stride": 0, "action_parts": None, "n_action_parts": 0, "scratch": None}
        if not isinstance(actions, dict):
            return {"actions": _row_address(actions, first_env), "action_stride": actions.strides[0],
                    "action_parts": None, "n_action_parts": 0, "scratch": None}
        layout = [(offset, size, actions[name], None) for name, offset, size, _ in self.natives[0].action_layout]
        self._scratch = np.zeros(self.natives[0].action_row_bytes, dtype=np.uint8)
        self._action_parts = _parts(layout, first_env)
        return {"actions": None, "action_stride": 0, "action_parts": ctypes.addressof(self._action_parts),
                "n_action_parts": len(layout), "scratch": self._scratch.ctypes.data}

    def _observation_values(self, observations: np.ndarray | dict[str, np.ndarray],
                            finals: np.ndarray | dict[str, np.ndarray]) -> dict[str, Any]:
        """The observations' and final observations' fields: a row per env, or a Dict observation's
        entries scattered from the row (each entry's final array beside it, in its part)."""
        first_env = self.first_env
        if self.python_observation:  # C writes no observation
            return {"observations": None, "obs_stride": 0, "obs_parts": None, "n_obs_parts": 0, "final_obs": None}
        if isinstance(observations, dict):
            layout = [(offset, size, observations[name], finals[name])
                      for name, (offset, size) in self.natives[0].observation_layout.items()]
            self._obs_parts = _parts(layout, first_env)
            return {"observations": None, "obs_stride": 0, "obs_parts": ctypes.addressof(self._obs_parts),
                    "n_obs_parts": len(layout), "final_obs": None}
        if finals.strides[0] != observations.strides[0]:
            raise ArgumentError("final observations must have the stride of the shared observations")
        return {"observations": _row_address(observations, first_env), "obs_stride": observations.strides[0],
                "obs_parts": None, "n_obs_parts": 0, "final_obs": _row_address(finals, first_env)}

    def step(self) -> int:
        """Step every env; returns how many need Python to finish (see ``flags``)."""
        return self._step(self.ref)

    def stepper_in_range(self, actions: MgRange) -> Callable[[], int]:
        """:meth:`step` after the range check ``actions`` of the whole batch, in the same C call
        (``mg_step_batch_in_range``): the callable returns -1, with nothing stepped, when a value
        is outside."""
        return functools.partial(self.library.mg_step_batch_in_range, self.ref, ctypes.byref(actions))

    def step_open(self) -> int:
        """Step every env, deciding no ending (``python_endings``); returns how many envs
        :attr:`open` marks: their observations are written, their rewards and terminations are
        Python's to write before :meth:`end_steps`."""
        return self._step_open(self.ref, self._open_ptr)

    def end_steps(self) -> int:
        """The pool's autoreset for the envs :attr:`open` marks, from the terminations and
        truncations in shared memory now; returns how many envs need Python (as :meth:`step`)."""
        return self._end_steps(self.ref, self._autoreset_code, self._open_ptr)

    def to_finish(self) -> np.ndarray:
        """Offsets of the envs Python must finish after the last :meth:`step`."""
        return np.flatnonzero((self.flags & NEEDS_PYTHON) != 0)
