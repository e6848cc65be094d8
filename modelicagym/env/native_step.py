"""The native step path of an `FMUEnv`: one C call per step instead of ~10 µs of Python.

An env takes the native path when its step is fully defined by its config (:func:`python_path_reason`
says why not, in a sentence a user can act on): co-simulation; `FMUEnv`'s own step, observation
and action mapping; Float64 scalar inputs and outputs; a Box action copied to the inputs, or a
Discrete action looked up in the config's ``action_table``; no strip chart to record
(``render_mode="rgb_array"``). Everything else stays on the Python path, with the same results. A
reward or termination written in Python does not keep an env off the native path: C steps the FMU
and Python ends the step (`modelicagym.env.endings`); C then checks no termination bounds when the
termination is Python's.

`NativeStep` fills in ``mg_env`` (``csrc/step.h``) with pointers into the instance's own value
buffers and clock, so both paths read and write the same memory and either can take any step.
"""

from __future__ import annotations

import ctypes
import logging
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from modelicagym.fmu.binding import DISCARD
from modelicagym.fmu.errors import FMUError
from modelicagym.native.abi import FailedCall, MgEnv
from modelicagym.native.library import NativeBuildError, load_library

__all__ = ["NativeStep", "python_path_reason"]

logger = logging.getLogger(__name__)

_FLOAT64 = ("Real", "Float64")
_OVERRIDABLE = ("step", "action_to_inputs", "observation")
#: ``failed_call`` codes -> how the Python path names the failing call
_FAILED_CALLS = {FailedCall.SET_INPUTS: "set inputs", FailedCall.DO_STEP: "fmiDoStep",
                 FailedCall.GET_OUTPUTS: "get outputs", FailedCall.SET_STATE: "set FMU state",
                 FailedCall.INTEGRATE: "integrate"}


def python_path_reason(env: gym.Env, base: type[gym.Env]) -> str | None:
    """Why ``env`` (an `FMUEnv`) must step on the Python path, or ``None`` when it can take the
    native one; ``base`` is `FMUEnv`, whose step the C library reproduces (an override of any of
    its step methods keeps the env in Python)."""
    config, fmu = env.config, env.fmu
    cls = type(env)
    if config.step_path == "python":
        return "the config asks for step_path='python'"
    if env.strip_chart is not None:
        return "render_mode='rgb_array' records every step for the strip chart, in Python"
    if fmu.description.fmi_version == 1:
        return "FMI 1.0: the native step library calls FMI 2.0/3.0 functions only"
    if fmu.mode == "me":
        if fmu.integrator_path != "native":
            return f"model exchange with its solver loop in Python: {fmu.integrator_path_reason}"
        for v in fmu.input_variables:
            if v.variability != "continuous":
                return f"input {v.name!r} is {v.variability}: model exchange sets it in event mode (Python)"
    for name in _OVERRIDABLE:
        if getattr(cls, name) is not getattr(base, name):
            return f"{name} is overridden by {cls.__name__}"
    for role, variables in (("input", fmu.input_variables), ("output", fmu.output_variables)):
        for v in variables:
            if v.fmi_type not in _FLOAT64 or v.shape:
                kind = f"an array of {v.fmi_type}" if v.shape else f"of type {v.fmi_type}"
                return f"{role} {v.name!r} is {kind} (the native path moves Float64 scalars)"
    n_in, n_out = len(fmu.input_variables), len(fmu.output_variables)
    if config.action_table is not None:
        if env.action_space != spaces.Discrete(len(config.action_table)):
            return f"the action space {env.action_space} is not Discrete({len(config.action_table)}) of 'action_table'"
    elif not _is_float64_box(env.action_space, n_in):
        return f"the action space {env.action_space} is not a float64 Box of the {n_in} inputs"
    if not _is_float64_box(env.observation_space, n_out):
        return f"the observation space {env.observation_space} is not a float64 Box of the {n_out} outputs"
    try:
        load_library()
    except NativeBuildError as error:
        return f"the native library is not available: {error}"
    return None


def _is_float64_box(space: spaces.Space, n: int) -> bool:
    return type(space) is spaces.Box and space.dtype == np.float64 and space.shape == (n,)


def _address(array: np.ndarray | ctypes.Array) -> int:
    return array.ctypes.data if isinstance(array, np.ndarray) else ctypes.addressof(array)


class NativeStep:
    """The ``mg_env`` of one env on the native path, and its single-env step.

    Call :meth:`bind` after every reset the Python path did (the instance, its functions or its
    snapshot may have changed). ``python_termination``: the env's termination is Python's, so C
    checks no bounds (it still reports the model ending the simulation).
    """

    def __init__(self, env: gym.Env, python_termination: bool = False) -> None:
        self.env = env
        self.library = load_library()
        fmu, config = env.fmu, env.config
        self.state = state = MgEnv()
        state.fmi_version = fmu.description.fmi_version
        self._prefix = "fmi2" if state.fmi_version == 2 else "fmi3"
        self._names = ("SetReal", "GetReal") if state.fmi_version == 2 else ("SetFloat64", "GetFloat64")
        starts = [0.0 if v.start is None else float(v.start) for v in fmu.input_variables]
        names = [v.name for v in fmu.output_variables]
        termination = {} if python_termination else dict(config.termination or {})
        bounds = [(name, float(low), float(high)) for name, (low, high) in termination.items()]
        # arrays the struct points to: kept alive by this object
        self._keep = {
            "input_starts": np.array(starts, dtype=np.float64),
            "bound_index": np.array([names.index(name) for name, _, _ in bounds], dtype=np.int64),
            "bound_low": np.array([low for _, low, _ in bounds], dtype=np.float64),
            "bound_high": np.array([high for _, _, high in bounds], dtype=np.float64),
        }
        if config.action_table is not None:
            table = np.array(config.action_table, dtype=np.float64).reshape(len(config.action_table), len(starts))
            self._keep["action_table"] = table
            state.discrete, state.n_actions = 1, len(table)
        else:
            self._keep["action_low"] = np.array(env.action_space.low, dtype=np.float64)
            self._keep["action_high"] = np.array(env.action_space.high, dtype=np.float64)
        for field, array in self._keep.items():
            setattr(state, field, _address(array))
        state.n_inputs, state.n_outputs, state.n_bounds = len(starts), len(names), len(bounds)
        state.time_step = env.time_step
        state.positive_reward, state.negative_reward = env.positive_reward, env.negative_reward
        state.max_episode_steps = -1 if env.max_episode_steps is None else env.max_episode_steps
        state.clock = ctypes.pointer(fmu.clock)
        self._action_index = ctypes.c_int64(0)
        self._action_values = np.zeros(len(starts), dtype=np.float64)
        self._reward = ctypes.c_double(0.0)
        # resets only Python can do: parameters drawn per episode, or a start state drawn from a list
        self._random_parameters = (any(callable(value) for value in config.parameters.values())
                                   or config.start_states is not None)
        self._step = self.library.mg_env_step
        self._reset = self.library.mg_env_reset
        self._state_ref = ctypes.byref(state)
        self._reward_ref = ctypes.byref(self._reward)
        self._index_ref = ctypes.byref(self._action_index)
        self._values_ptr = ctypes.c_void_p(self._action_values.ctypes.data)
        self.bind()

    def bind(self) -> None:
        """Point the struct at the instance as it is now: its component, functions, buffers and snapshot."""
        fmu, state = self.env.fmu, self.state
        binding = fmu.binding
        prefix = self._prefix
        state.component = binding.component
        state.set_real = binding.function_address(prefix + self._names[0])
        state.get_real = binding.function_address(prefix + self._names[1])
        integrator = fmu.native_integrator
        if integrator is None:
            state.do_step = binding.function_address(prefix + "DoStep")
            state.get_boolean_status = binding.function_address("fmi2GetBooleanStatus") if prefix == "fmi2" else None
        state.integrator = None if integrator is None else ctypes.addressof(integrator.state)
        state.set_state = binding.function_address(prefix + ("SetFMUstate" if prefix == "fmi2" else "SetFMUState"))
        state.input_refs, state.inputs = fmu.inputs.addresses()
        state.output_refs, state.outputs = fmu.outputs.addresses()
        # a native reset stands for reset() without options: the config's parameters
        snapshot = None if self._random_parameters else fmu.restorable_snapshot(self.env.config.parameters)
        state.snapshot = snapshot
        state.native_reset = snapshot is not None
        next_event = fmu.snapshot_next_event_time
        state.snapshot_has_next_event = next_event is not None
        state.snapshot_next_event_time = next_event or 0.0

    def reset(self) -> bool:
        """Start an episode with the config's parameters in C, by restoring the instance's verified
        snapshot (as `FMUInstance.reset` would); False (nothing done) when only Python can, or the
        restore failed (the Python reset then takes over)."""
        return bool(self.state.native_reset) and self._reset(self._state_ref) == 0

    def step(self, action: Any) -> int:
        """One step with a checked action; returns the flags (the reward is in :attr:`reward`)."""
        if self.state.discrete:
            self._action_index.value = action
            return self._step(self._state_ref, self._index_ref, self._reward_ref)
        self._action_values[:] = action
        return self._step(self._state_ref, self._values_ptr, self._reward_ref)

    @property
    def reward(self) -> float:
        """The reward of the last :meth:`step`."""
        return self._reward.value

    def error(self) -> FMUError:
        """The error of a step that returned ``Flags.FMU_ERROR``, as the Python path raises it."""
        state = self.state
        if state.failed_call == FailedCall.LOG_ERRORS:
            return self.env.fmu.error_loop()
        call = _FAILED_CALLS[state.failed_call]
        if call == "integrate":
            return self.env.fmu.native_integrator.error()
        if call == "fmiDoStep" and state.fmi_status == DISCARD:
            call = "fmiDoStep (discard without termination)"
        return self.env.fmu.binding.fail(call, state.fmi_status)
