"""The native step path of an `FMUEnv`: one C call per step instead of ~10 µs of Python.

An env's FMU steps in C (:func:`python_path_reason` says why not, in a sentence a user can act on)
in co-simulation (FMI 1.0, 2.0, 3.0) or model exchange with the native integrator (discrete inputs
included: C sets them in event mode and settles the event iteration at every step, as the Python
path does); with `FMUEnv`'s own ``step``; inputs and outputs (tunable parameters too) of any numeric
FMI type (String and Binary variables are never actions or observations), scalars and FMI 3.0
arrays; no strip chart to record (``render_mode="rgb_array"``). Everything else steps on the Python
path, with the same results.

What Python computes keeps the FMU's step in C around it, each edge by itself:

* the inputs: C moves the action's values into the inputs when the action space maps one to one
  onto them (a Box, MultiDiscrete, MultiBinary or Discrete over them, a Dict keyed by the inputs'
  names, or a Discrete over the config's ``action_table``) and ``action_to_inputs`` is `FMUEnv`'s;
  otherwise (:func:`python_inputs_reason`) Python writes ``action_to_inputs(action)`` into the
  instance's input buffers as the Python path does, and C steps with no action (in model exchange
  the solver restarts when those bytes changed, by the Python path's own rule);
* the observation: C writes it when the observation space is laid out as the outputs' own and
  ``observation`` is `FMUEnv`'s; otherwise (:func:`python_observation_reason`) the env returns
  ``observation()`` after the C step (termination bounds are on outputs: C still checks them);
* the ending: a reward or termination written in Python is computed after the C step
  (`modelicagym.env.endings`); C then checks no termination bounds when the termination is Python's.

A pool's native slice (one C call for many envs) runs the same edges per env around its one C call
(`modelicagym.vector.slice.slice_edges`): ``mg_env.python_inputs`` tells C to step the env from
the inputs Python wrote, ``mg_env.python_observation`` to write none of its observation rows.

A system of FMUs (`modelicagym.system`) steps in C too: its ``mg_env`` runs the master algorithm
over an ``mg_env`` per FMU and the copies along its connections (`modelicagym.env.native_system`).

`NativeStep` fills in ``mg_env`` (``csrc/step.h``) with pointers into the instance's own value
buffers and clock, so both paths read and write the same memory and either can take any step. C calls
one fmiSet/fmiGet per FMI type (the buffers are grouped so), converts the action's values into the
inputs and the outputs into a flat observation as numpy's casts do (``mg_move``): the single env
reads its observation from the buffers as the Python path does (`modelicagym.env.spaces.Observer`),
a pool's slice copies the flat one into shared memory.
"""

from __future__ import annotations

import ctypes
import logging
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from modelicagym.env.endings import overridden
from modelicagym.env.native_fmu import bind_instance, bind_snapshot, fmu_error, input_starts, instance_calls
from modelicagym.env.native_system import NativeSystem
from modelicagym.env.spaces import write_values
from modelicagym.fmu.errors import FMUError
from modelicagym.native.abi import MgEnv, MgMove, ValueType
from modelicagym.native.library import NativeBuildError, load_library
from modelicagym.system import SystemInstance

__all__ = ["NativeStep", "action_storage_dtype", "native_path_reason", "python_edges", "python_inputs_reason",
           "python_observation_reason", "python_path_reason"]

logger = logging.getLogger(__name__)

#: the spaces whose values C reads from a flat row (a Dict of them: one row per key, in input order)
_ARRAY_SPACES = (spaces.Box, spaces.Discrete, spaces.MultiDiscrete, spaces.MultiBinary)


def action_storage_dtype(space: spaces.Space) -> np.dtype:
    """The dtype an action of an array ``space`` is kept in on the way to C: as the pool's shared
    memory keeps it (a float Box as float64, so a float64 action reaches the inputs rounded once)."""
    if isinstance(space, spaces.Box) and space.dtype.kind == "f":
        return np.dtype(np.float64)
    return np.dtype(space.dtype)


def _space_values(space: spaces.Space) -> int:
    return 1 if isinstance(space, spaces.Discrete) else int(np.prod(space.shape))


def _array_bounds(space: spaces.Space) -> tuple[np.ndarray, np.ndarray]:
    """Lowest and highest value of each element of an array space, flat, as doubles."""
    if isinstance(space, spaces.Box):
        return np.ravel(space.low).astype(np.float64), np.ravel(space.high).astype(np.float64)
    if isinstance(space, spaces.Discrete):
        return np.array([space.start], np.float64), np.array([space.start + space.n - 1], np.float64)
    if isinstance(space, spaces.MultiDiscrete):
        low = np.ravel(space.start).astype(np.float64)
        return low, low + np.ravel(space.nvec) - 1
    n = _space_values(space)
    return np.zeros(n), np.ones(n)


def _action_parts(space: spaces.Space, variables: list) -> list[tuple[str | None, spaces.Space]] | str:
    """The action row's parts in input order: ``[(None, space)]`` for an array space over all the
    input values, ``[(name, sub-space), ...]`` for a Dict keyed by the inputs; else why not."""
    n_values = sum(v.size for v in variables)
    if isinstance(space, _ARRAY_SPACES):
        if _space_values(space) != n_values or (isinstance(space, spaces.Box) and space.dtype.kind not in "fiub"):
            return f"the action space {space} does not hold one number per input value ({n_values})"
        return [(None, space)]
    if isinstance(space, spaces.Dict) and set(space.keys()) == {v.name for v in variables}:
        for v in variables:
            sub = space[v.name]
            if not isinstance(sub, _ARRAY_SPACES) or _space_values(sub) != v.size:
                return f"the action space's {v.name!r} entry {sub} does not hold the input's {v.size} value(s)"
        return [(v.name, space[v.name]) for v in variables]
    return f"the action space {space} is not an array or a Dict of the inputs' values"


def _same_layout(a: spaces.Space, b: spaces.Space) -> bool:
    """Whether values of ``a`` and ``b`` are laid out alike (type, shape and dtype; bounds may differ)."""
    if isinstance(a, spaces.Dict) or isinstance(b, spaces.Dict):
        return (type(a) is type(b) and list(a.keys()) == list(b.keys())
                and all(_same_layout(a[k], b[k]) for k in a))
    return type(a) is type(b) and a.shape == b.shape and a.dtype == b.dtype


def python_path_reason(env: gym.Env, base: type[gym.Env]) -> str | None:
    """Why ``env`` (an `FMUEnv`) must step wholly on the Python path, or ``None`` when its FMU can
    step in C; ``base`` is `FMUEnv`, whose step the C library reproduces (an override of ``step``
    keeps the env in Python; its inputs and observation may still be Python's around the C step:
    `python_inputs_reason`, `python_observation_reason`)."""
    config, fmu = env.config, env.fmu
    cls = type(env)
    if config.step_path == "python":
        return "the config asks for step_path='python'"
    if isinstance(fmu, SystemInstance):
        reason = fmu.python_step_reason()
        if reason is not None:
            return reason
    elif fmu.mode == "me" and fmu.integrator_path != "native":
        return f"model exchange with its solver loop in Python: {fmu.integrator_path_reason}"
    if env.strip_chart is not None:
        return "render_mode='rgb_array' records every step for the strip chart, in Python"
    if overridden(cls, base, "step"):
        return f"step is overridden by {cls.__name__}"
    try:
        load_library()
    except NativeBuildError as error:
        return f"the native library is not available: {error}"
    return None


def python_inputs_reason(env: gym.Env, base: type[gym.Env]) -> str | None:
    """Why Python computes ``env``'s input values from the action (``action_to_inputs``) before
    the C step, or ``None`` when C moves the action's values into the inputs itself (the action
    space maps one to one onto the input values, or is Discrete over the ``action_table``)."""
    config, fmu, cls = env.config, env.fmu, type(env)
    if overridden(cls, base, "action_to_inputs"):
        return f"action_to_inputs is overridden by {cls.__name__}"
    tracking = getattr(env, "tracking", None)
    if tracking is not None and tracking.keeps_state:
        return "the task keeps each step's action and error for its observation"
    n_values = sum(v.size for v in fmu.input_variables)
    if config.action_table is not None:
        if env.action_space != spaces.Discrete(len(config.action_table)):
            return f"the action space {env.action_space} is not Discrete({len(config.action_table)}) of 'action_table'"
        if len(config.action_table[0]) != n_values:
            return f"the rows of 'action_table' have {len(config.action_table[0])} values, the inputs {n_values}"
        return None
    parts = _action_parts(env.action_space, fmu.input_variables)
    return parts if isinstance(parts, str) else None


def python_observation_reason(env: gym.Env, base: type[gym.Env]) -> str | None:
    """Why Python makes ``env``'s observation (``observation()``) after the C step, or ``None``
    when C writes it (the observation space is laid out as the outputs' own)."""
    cls = type(env)
    if overridden(cls, base, "observation"):
        return f"observation is overridden by {cls.__name__}"
    tracking = getattr(env, "tracking", None)
    if tracking is not None and tracking.entries:
        return f"the task's observation entries {', '.join(tracking.labels)} follow the outputs"
    if not _same_layout(env.observation_space, env._observer.space):
        return (f"the observation space {env.observation_space} is not laid out as the outputs' own "
                f"{env._observer.space}")
    return None


def _and(parts: list[str]) -> str:
    return parts[0] if len(parts) == 1 else f"{', '.join(parts[:-1])} and {parts[-1]}"


def _edges(inputs_reason: str | None, observation_reason: str | None) -> tuple[list[str], list[str]]:
    """What Python computes before the C step (the inputs) and after it (the observation), as phrases."""
    return ([f"the inputs ({inputs_reason})"] if inputs_reason else [],
            [f"the observation ({observation_reason})"] if observation_reason else [])


def python_edges(inputs_reason: str | None, observation_reason: str | None) -> str | None:
    """What of a native step Python computes around C, as a phrase (``None``: nothing)."""
    before, after = _edges(inputs_reason, observation_reason)
    return _and(before + after) if before or after else None


def native_path_reason(inputs_reason: str | None, observation_reason: str | None, endings: list[str],
                       components: int | None = None) -> str:
    """``step_path_reason`` of an env on the native path: what runs in C, and what in Python
    before it (the inputs) and after it (the observation, then ``endings``: its reward and
    termination written in Python, `modelicagym.env.endings.PythonEndings.parts`). ``components``:
    the env is a system of that many components (all of them, and its connections, step in C)."""
    before, after = _edges(inputs_reason, observation_reason)
    after += endings
    what = "the FMU" if components is None else f"the system ({components} components and its connections)"
    if not (before or after):
        whole = "the config defines the whole step"
        return whole if components is None else f"{whole}: {what} steps in C in one call"
    said = ([f"{_and(before)} in Python before it"] if before else []) + (
        [f"{_and(after)} in Python after it"] if after else [])
    return f"{what} steps in C; {'; '.join(said)}"


#: the array spaces whose actions' values C checks itself (`NativeStep.value_checked`)
_VALUE_CHECKED_SPACES = (spaces.Box, spaces.MultiDiscrete, spaces.MultiBinary)
#: the dtypes a float Box's action row (float64) holds exactly, its own first
_FLOATS = (np.dtype(np.float64), np.dtype(np.float32), np.dtype(np.float16))


def _unchecked(library: ctypes.CDLL, name: str) -> Any:
    """``library``'s function ``name`` without ctypes' conversion of its arguments (about 0.2 us
    less a call than with ``argtypes``): for calls whose arguments are all pointers already
    (``byref``, ``c_void_p``, None)."""
    function = type(getattr(library, name))((name, library))
    function.restype = getattr(library, name).restype
    return function


def _address(array: np.ndarray | ctypes.Array) -> int:
    return array.ctypes.data if isinstance(array, np.ndarray) else ctypes.addressof(array)


def _value_addresses(buffer: Any, variable: Any) -> list[tuple[int, int]]:
    """``(address, MG_TYPE_*)`` of each of a variable's values in an instance's buffer."""
    view = buffer.views[variable.name]
    code = ValueType.of(view.dtype)
    return [(view.ctypes.data + k * view.itemsize, code) for k in range(variable.size)]


def _storage_dtypes(space: spaces.Space, variables: list) -> list[np.dtype]:
    """The dtype of each value of the outputs in a flat observation of ``space`` (variable order)."""
    if isinstance(space, spaces.Dict):
        return [np.dtype(space[v.name].dtype) for v in variables for _ in range(v.size)]
    return [np.dtype(space.dtype)] * sum(v.size for v in variables)


def _reader(values: np.ndarray, space: spaces.Space) -> Callable[[], Any]:
    """Reads one (sub-)space's value out of its flat ``values`` in the observation row."""
    if isinstance(space, spaces.Discrete):
        return lambda: values[0]
    return values.reshape(space.shape).copy


def _moves(pairs: list[tuple[int, int, int, int]]) -> ctypes.Array:
    moves = (MgMove * max(len(pairs), 1))()
    for move, (source, source_type, target, target_type) in zip(moves, pairs):
        move.source, move.source_type, move.target, move.target_type = source, source_type, target, target_type
    return moves


class NativeStep:
    """The ``mg_env`` of one env on the native path, and its single-env step.

    Call :meth:`bind` after every reset the Python path did (the instance, its functions or its
    snapshot may have changed). ``python_termination``: the env's termination is Python's, so C
    checks no bounds (it still reports the model ending the simulation). ``python_inputs``: the
    env's ``action_to_inputs`` computes the input values in Python (`python_inputs_reason`);
    :meth:`step` writes them into the instance's buffers as the Python path does (:meth:`write_inputs`)
    and C steps from there (``mg_env_step`` with no action). ``python_observation``: the env's
    ``observation()`` is Python's, so a pool's native slice writes none of its observation rows.
    """

    def __init__(self, env: gym.Env, python_termination: bool = False, python_inputs: bool = False,
                 python_observation: bool = False) -> None:
        self.env = env
        self.library = load_library()
        fmu, config = env.fmu, env.config
        self.state = state = MgEnv()
        state.fmi_version = 0 if isinstance(fmu, SystemInstance) else fmu.description.fmi_version
        state.event_mode_inputs = fmu.event_mode_inputs
        state.python_inputs, state.python_observation = python_inputs, python_observation
        inputs = [pair for v in fmu.input_variables for pair in _value_addresses(fmu.inputs, v)]
        outputs = [pair for v in fmu.output_variables for pair in _value_addresses(fmu.outputs, v)]
        names = [v.name for v in fmu.output_variables]
        positions = np.cumsum([0] + [v.size for v in fmu.output_variables])
        termination = {} if python_termination else dict(config.termination or {})
        bounds = [(name, float(low), float(high)) for name, (low, high) in termination.items()]
        # arrays the struct points to: kept alive by this object
        self._keep: dict[str, Any] = {
            "input_starts": input_starts(fmu.inputs),
            "bound_index": np.array([positions[names.index(name)] for name, _, _ in bounds], dtype=np.int64),
            "bound_low": np.array([low for _, low, _ in bounds], dtype=np.float64),
            "bound_high": np.array([high for _, _, high in bounds], dtype=np.float64),
        }
        self._discrete = config.action_table is not None and not python_inputs
        #: ``(shape, dtypes)`` of the numpy arrays whose values C checks against the
        #: action space as `check_action` would (bounds, finite: ``mg_env_step`` refuses a value
        #: outside with ``Flags.BAD_ACTION``, writing nothing): arrays of the action row's own dtype,
        #: or of any float dtype the row holds exactly (a float Box's), so that the values C sees are
        #: the action's. The env checks only their shape and dtype before :meth:`step`. None: every
        #: action goes through the env's `check_action` first.
        self.value_checked: tuple[tuple[int, ...], tuple[np.dtype, ...]] | None = None
        #: the input values are Python's: then C moves no action and checks no action bounds
        self.python_inputs = python_inputs
        #: model exchange with Python's inputs: the solver's restart rule, as the Python path applies it
        self._note_inputs = (fmu.note_written_inputs if python_inputs and not isinstance(fmu, SystemInstance)
                             and fmu.mode == "me" else None)
        #: a Dict action's entries in the action row C reads: ``(name, byte offset, bytes, dtype)``
        self.action_layout: list[tuple[str, int, int, np.dtype]] | None = None
        #: a Dict observation's entries in the row C writes: ``{name: (byte offset, bytes)}``
        self.observation_layout: dict[str, tuple[int, int]] | None = None
        if self._discrete:
            table = np.array(config.action_table, dtype=np.float64).reshape(len(config.action_table), len(inputs))
            self._keep["action_table"] = table
            state.discrete, state.n_actions = 1, len(table)
            sources = [(8 * k, ValueType.F64) for k in range(len(inputs))]
            self._action_index = ctypes.c_int64(0)
            self._action_ref = ctypes.byref(self._action_index)
        elif python_inputs:
            sources, self._action_ref, self.action_row_bytes = [], None, 0
        else:
            sources = self._action_row(_action_parts(env.action_space, fmu.input_variables))
        self._keep["action_moves"] = _moves([(*source, *target) for source, target in zip(sources, inputs)])
        self._keep["observation"] = observation = self._observation_row(outputs, env._observer.space)
        #: the observation of the last C step or reset, as the env's `Observer` gives it (a fresh copy)
        self.observation: Callable[[], Any] = self._observation_reader(observation, env._observer.space)
        self._keep["observation_moves"] = _moves(self._observation_pairs)
        for field, array in self._keep.items():
            setattr(state, field, _address(array))
        state.n_inputs, state.n_outputs, state.n_bounds = len(sources), len(outputs), len(bounds)
        state.observation_bytes = observation.nbytes
        #: a system's components in C (`NativeSystem`); None for one FMU, whose own calls C makes
        self._system = NativeSystem(fmu, env.time_step) if isinstance(fmu, SystemInstance) else None
        if self._system is None:
            self._calls = instance_calls(fmu, state)
        else:
            state.system = self._system.address
        state.time_step = env.time_step
        state.positive_reward, state.negative_reward = env.positive_reward, env.negative_reward
        state.max_episode_steps = -1 if env.max_episode_steps is None else env.max_episode_steps
        state.clock = ctypes.pointer(fmu.clock)
        #: the C double each step writes its reward into (:attr:`reward` reads it)
        self.reward_cell = self._reward = ctypes.c_double(0.0)
        # resets only Python can do: parameters drawn per episode, or a start state drawn from a list
        tracking = getattr(env, "tracking", None)
        self._random_parameters = (any(callable(value) for value in config.reset_values.values())
                                   or config.start_states is not None
                                   or (tracking is not None and tracking.needs_python_reset))
        self._step = _unchecked(self.library, "mg_env_step")
        self._reset = self.library.mg_env_reset
        self._state_ref = ctypes.byref(state)
        self._reward_ref = ctypes.byref(self._reward)
        self.bind()

    def _action_row(self, parts: list[tuple[str | None, spaces.Space]]) -> list[tuple[int, int]]:
        """Lay out the action row C reads (one typed array per part, in input order) and return
        ``(byte offset, MG_TYPE_*)`` of each of its values; :meth:`step` fills it."""
        float32 = {v.name for v in self.env.fmu.input_variables if v.fmi_type == "Float32"}
        dtypes = [np.dtype(np.float32) if name in float32 and space.dtype == np.float32 else action_storage_dtype(space)
                  for name, space in parts]  # a Dict's float32 entry over Float32 values: as the pool keeps it
        sizes = [_space_values(space) for _, space in parts]
        offsets = np.cumsum([0] + [-(-n * d.itemsize // 8) * 8 for n, d in zip(sizes, dtypes)])
        self._row = row = np.zeros(int(offsets[-1]) // 8 or 1, dtype=np.float64)
        self.action_row_bytes = row.nbytes
        raw = row.view(np.uint8)
        views = [raw[offsets[k] : offsets[k] + sizes[k] * dtypes[k].itemsize].view(dtypes[k]) for k in range(len(parts))]
        self._views = [(name, view if isinstance(space, spaces.Discrete) else view.reshape(space.shape))
                       for (name, space), view in zip(parts, views)]
        self._single = self._views[0][1] if parts[0][0] is None else None
        space = parts[0][1]
        if self._single is not None and type(space) in _VALUE_CHECKED_SPACES:
            exact = _FLOATS if type(space) is spaces.Box and space.dtype.kind == "f" else (np.dtype(space.dtype),)
            self.value_checked = (space.shape, exact)
        self.action_layout = None if self._single is not None else [
            (name, int(offsets[k]), sizes[k] * dtypes[k].itemsize, dtypes[k]) for k, (name, _) in enumerate(parts)]
        self._action_ref = ctypes.c_void_p(row.ctypes.data)
        lows, highs = zip(*(_array_bounds(space) for _, space in parts))
        self._keep["action_low"], self._keep["action_high"] = np.concatenate(lows), np.concatenate(highs)
        return [(int(offsets[k]) + j * dtypes[k].itemsize, ValueType.of(dtypes[k]))
                for k in range(len(parts)) for j in range(sizes[k])]

    def _observation_row(self, outputs: list[tuple[int, int]], space: spaces.Space) -> np.ndarray:
        """The flat observation C writes (as the pool's shared memory holds one), and the moves
        from the outputs into it (``self._observation_pairs``)."""
        dtypes = _storage_dtypes(space, self.env.fmu.output_variables)
        offsets = np.cumsum([0] + [d.itemsize for d in dtypes])
        self._observation_pairs = [(address, code, int(offset), ValueType.of(dtype))
                                   for (address, code), offset, dtype in zip(outputs, offsets, dtypes)]
        return np.zeros(max(int(offsets[-1]), 1), dtype=np.uint8)

    def _observation_reader(self, row: np.ndarray, space: spaces.Space) -> Callable[[], Any]:
        """A function returning the observation C wrote into ``row`` as the env's `Observer` gives
        it (fresh arrays of the space's dtypes and shapes; a Discrete value as a numpy integer)."""
        if not isinstance(space, spaces.Dict):
            return _reader(row[: _space_values(space) * space.dtype.itemsize].view(space.dtype), space)
        readers, offset = {}, 0
        self.observation_layout = {}
        for v in self.env.fmu.output_variables:  # C lays the values out in variable order
            sub = space[v.name]
            size = v.size * sub.dtype.itemsize
            readers[v.name] = _reader(row[offset : offset + size].view(sub.dtype), sub)
            self.observation_layout[v.name] = (offset, size)
            offset += size
        entries = [(name, readers[name]) for name in space]
        return lambda: {name: read() for name, read in entries}

    def bind(self) -> None:
        """Point the struct at the instance as it is now: its component, functions and snapshot
        (a system's: each of its FMUs')."""
        fmu, state = self.env.fmu, self.state
        # a native reset stands for reset() without options: the config's parameters
        values = None if self._random_parameters else self.env.config.reset_values
        if self._system is not None:
            state.native_reset = self._system.bind(values)
            return
        bind_instance(state, fmu, self._calls)
        bind_snapshot(state, fmu, values)

    def reset(self) -> bool:
        """Start an episode with the config's parameters in C, by restoring the instance's verified
        snapshot (as `FMUInstance.reset` would); False (nothing done) when only Python can, or the
        restore failed (the Python reset then takes over)."""
        return bool(self.state.native_reset) and self._reset(self._state_ref) == 0

    def step(self, action: Any) -> int:
        """One step with a checked action; returns the flags (the reward is in :attr:`reward`)."""
        if self.python_inputs:
            self.write_inputs(action)
            return self._step(self._state_ref, None, self._reward_ref)
        if self._discrete:
            self._action_index.value = action
        elif self._single is not None:
            self._single[...] = action
        else:
            for name, view in self._views:
                view[...] = action[name]
        return self._step(self._state_ref, self._action_ref, self._reward_ref)

    def array_step(self) -> Callable[[np.ndarray], int]:
        """:meth:`step` for an array `value_checked` describes, as a closure over the struct and
        the action row (the single env's fast path: no attribute look-ups, no branches)."""
        row, step, state, action, reward = self._single, self._step, self._state_ref, self._action_ref, self._reward_ref

        def step_array(values: np.ndarray) -> int:
            row[...] = values
            return step(state, action, reward)

        return step_array

    def write_inputs(self, action: Any) -> None:
        """Write ``action_to_inputs(action)`` (a checked action) into the instance's input buffers,
        as the Python path does, for C to step from (``python_inputs``)."""
        tracking = self.env.tracking
        if tracking is not None:
            tracking.before_step(action)
        write_values(self.env.fmu.inputs, self.env.action_to_inputs(action))
        if self._note_inputs is not None:
            self._note_inputs()

    @property
    def action_pointer(self) -> Any:
        """The action as the last :meth:`step` handed it to C (for ``mg_loop``, the benchmarks' C loop)."""
        return self._action_ref

    @property
    def reward(self) -> float:
        """The reward of the last :meth:`step`."""
        return self._reward.value

    def error(self) -> FMUError:
        """The error of a step that returned ``Flags.FMU_ERROR``, as the Python path raises it."""
        if self._system is not None:
            return self._system.error(self.state.failed_call)
        return fmu_error(self.env.fmu, self.state)
