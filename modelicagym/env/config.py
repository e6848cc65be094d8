"""The configuration of an `FMUEnv`: a few lines that turn an FMU into an environment.

A config is keyword arguments or a dict (so a JSON/TOML file works), checked once when the
environment is made. Unknown keys are an error with a suggestion, like unknown variable names.
"""

from __future__ import annotations

import difflib
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np
from gymnasium import spaces

from modelicagym.env.config_checks import (
    check_action_bounds,
    check_batch_hooks,
    check_fixed_inputs,
    check_numbers,
    check_termination,
)
from modelicagym.env.saved_state import EnvState, StartStates
from modelicagym.env.tracking import check_observe, check_setpoints, json_draws
from modelicagym.errors import ConfigError, ConfigTypeError
from modelicagym.fmu.library_copies import check_instances_per_process

Bounds = Mapping[str, Sequence[float]]

#: values of the ``step_path`` config key
STEP_PATHS = ("auto", "python")
#: values of the ``action_out_of_bounds`` config key
ACTION_OUT_OF_BOUNDS = ("error", "clip")


@dataclass
class FMUEnvConfig:
    """Everything `FMUEnv` needs to know about an FMU.

    Attributes:
        fmu: path of the ``.fmu`` file (or extracted folder), or of an SSP system (an ``.ssp``
            archive or a folder with ``SystemStructure.ssd``: `modelicagym.system`).
        fmus / connections: a system of FMUs instead of ``fmu``: ``{name: path}`` of its
            components (FMUs, or CSV/MAT time tables; ``{"fmu": path, "mode": "me"}`` runs an FMU
            in a mode of its own) and ``[("motor.tau", "plant.tau"), ...]`` (output, input). A
            system's variables are named ``component.variable`` everywhere in the config.
        master: a system's master algorithm, ``"gauss-seidel"`` (default) or ``"jacobi"``
            (`modelicagym.system.master`).
        loop_breaks: for a system under Gauss-Seidel, the connections of its loops of direct
            feedthrough to read from the previous step, ``["plant.y -> controller.u"]``; default:
            where the stepping order breaks each loop (`modelicagym.system.loops`).
        substeps: a system's communication steps per env step (default 1).
        inputs: input variables driven by the action, in order.
        outputs: variables observed after every step, in order.
        parameters: values (or callables ``f(np_random) -> value``) applied at every reset; in a JSON
            config, ``{"uniform": [low, high]}`` is such a draw (`modelicagym.env.tracking.uniform`).
        fixed_inputs: ``{input: value}`` for the inputs the agent does not drive: each is held at its
            value for the episode (a callable ``f(np_random) -> value`` is drawn at every reset, as a
            parameter's: a boundary condition that varies from one episode to the next). An input is
            in ``inputs`` (the action) or here, not both; an FMU's input in neither keeps its start value.
        time_step: seconds per environment step; default: the model's ``defaultExperiment stepSize``.
        start_time: default: the model's ``defaultExperiment startTime``.
        max_episode_steps: truncate an episode after this many steps (None: never).
        positive_reward / negative_reward: the paper's default reward — ``positive_reward`` for
            every step the episode goes on, ``negative_reward`` on the step it terminates.
        termination: ``{variable: (low, high)}``: the episode terminates when an output leaves
            its interval; or a callable ``f(env, observation) -> bool``.
        reward: a callable ``f(env, observation, action, terminated) -> float`` replacing the
            default reward.
        batch_reward / batch_termination: the reward / termination written on arrays, the fast way
            in a pool: ``f(envs, observations, actions, terminated) -> rewards`` and
            ``f(envs, observations) -> terminated``, row ``k`` of each array being ``envs[k]``'s
            (see `modelicagym.env.endings`). Give ``reward`` or ``batch_reward``, not both (and
            ``termination`` or ``batch_termination``).
        action_bounds: ``{input: (low, high)}``: finite bounds of the action space for these
            inputs, replacing the model description's (e.g. for an input that declares none, so that
            random exploration stays near its physical range; ``modelicagym info`` infers them).
        action_space / observation_space: override the spaces derived from the model description.
        action_table: for a discrete action space: one row of input values per action (action
            ``k`` sets the inputs to ``action_table[k]``); the action space is then
            ``Discrete(len(action_table))``.
        step_path: ``"auto"`` (default): the native step path when the config allows it (see
            `modelicagym.env.native_step`), else Python, and in model exchange the solver loop in C
            (`modelicagym.fmu.native_integrator`); ``"python"`` forces the Python path and the Python
            solver loop (the reference both native paths are tested against).
        mode: ``"cs"`` or ``"me"``; default: co-simulation when the FMU offers it.
        reset_rung, solver, tolerance, solver_step, validate, logging_on: passed to `FMUInstance`.
        instances_per_process: for an FMU allowed one instance per process: ``"copies"``
            (default: each further instance in a process loads a private copy of the FMU's binary,
            so a pool lays such envs out like any other) or ``"one"`` (one env per process: a pool
            keeps one env per worker; for an FMU whose restriction is not about globals, e.g. one
            writing fixed file names). Passed to `FMUInstance`.
        setpoints: ``{output: signal}``: what each output should follow, a number, a callable
            ``f(np_random)`` drawn at every reset, a schedule ``[(time, value), ...]`` or a CSV table's
            path (`modelicagym.env.tracking`); ``env.setpoints`` holds their values now, for a reward.
        observe: what the observation holds after the outputs, in order: ``"setpoint"``,
            ``"error"``, ``"error_integral"``, ``"previous_action"`` or a held input's name
            (`modelicagym.env.tracking`); ``env.observation_names`` names every value.
        action_out_of_bounds: ``"error"`` (default: an action outside the action space is refused
            with a ``ValueError``) or ``"clip"`` (a Box action is clipped into its bounds first; NaN
            is still refused), in the env and in the pool alike.
        start_states: states (``env.unwrapped.get_state()``, `modelicagym.env.saved_state`) or a
            `StartStates`: every reset that brings no state of its own starts from one, drawn with
            the env's generator (e.g. a plant's recorded operating points).
    """

    fmu: str | os.PathLike[str] | None = None
    fmus: Mapping[str, Any] | None = None
    connections: Sequence[Any] = ()
    master: str = "gauss-seidel"
    loop_breaks: Sequence[Any] = ()
    substeps: int = 1
    inputs: Sequence[str] = ()
    outputs: Sequence[str] = ()
    parameters: Mapping[str, Any] = field(default_factory=dict)
    fixed_inputs: Mapping[str, Any] = field(default_factory=dict)
    time_step: float | None = None
    start_time: float | None = None
    max_episode_steps: int | None = None
    positive_reward: float = 1.0
    negative_reward: float = -100.0
    termination: Bounds | Callable[..., bool] | None = None
    reward: Callable[..., float] | None = None
    batch_reward: Callable[..., Any] | None = None
    batch_termination: Callable[..., Any] | None = None
    action_bounds: Bounds | None = None
    action_space: spaces.Space | None = None
    observation_space: spaces.Space | None = None
    action_table: Sequence[Sequence[float]] | None = None
    step_path: str = "auto"
    mode: str | None = None
    reset_rung: str = "auto"
    solver: str = "cvode"
    tolerance: float | None = None
    solver_step: float | None = None
    validate: bool = True
    logging_on: bool = False
    instances_per_process: str = "copies"
    start_states: Sequence[EnvState] | StartStates | None = None
    setpoints: Mapping[str, Any] = field(default_factory=dict)
    observe: Sequence[str] = ()
    action_out_of_bounds: str = "error"

    @property
    def reset_values(self) -> dict[str, Any]:
        """What every reset applies before the episode starts: the parameters and the fixed inputs
        (values, or callables drawn per episode)."""
        return {**self.parameters, **self.fixed_inputs}

    @classmethod
    def from_mapping(cls, mapping: Mapping[str, Any]) -> FMUEnvConfig:
        """Build a config from a dict, with a clear error for unknown or missing keys."""
        known = [f.name for f in fields(cls)]
        for key in mapping:
            if key not in known:
                close = difflib.get_close_matches(key, known, n=2)
                hint = f" Did you mean {' or '.join(repr(c) for c in close)}?" if close else ""
                raise ConfigTypeError(f"unknown FMUEnv config key {key!r}.{hint} Known keys: {', '.join(known)}")
        if "fmu" not in mapping and "fmus" not in mapping:
            raise ConfigTypeError("an FMUEnv config needs 'fmu': the path of the .fmu file (or of an SSP system; or "
                                  "'fmus' and 'connections' for a system of FMUs)")
        config = cls(**mapping)
        config.inputs = list([config.inputs] if isinstance(config.inputs, str) else config.inputs)
        config.outputs = list([config.outputs] if isinstance(config.outputs, str) else config.outputs)
        config.parameters = json_draws(dict(config.parameters))
        check_fixed_inputs(config)
        config.fixed_inputs = json_draws(config.fixed_inputs)
        check_numbers(config)
        check_termination(config.termination)
        check_batch_hooks(config)
        check_action_bounds(config.action_bounds)
        if config.action_bounds is not None:
            config.action_bounds = {name: (float(low), float(high))
                                    for name, (low, high) in config.action_bounds.items()}
        if config.start_states is not None and not isinstance(config.start_states, StartStates):
            config.start_states = StartStates(config.start_states)
        check_instances_per_process(config.instances_per_process)
        config.setpoints = check_setpoints(config.setpoints)
        config.observe = check_observe(config.observe)
        if config.action_out_of_bounds not in ACTION_OUT_OF_BOUNDS:
            raise ConfigError(f"action_out_of_bounds must be one of {ACTION_OUT_OF_BOUNDS}, "
                              f"got {config.action_out_of_bounds!r}")
        if config.step_path not in STEP_PATHS:
            raise ConfigError(f"step_path must be one of {STEP_PATHS}, got {config.step_path!r}")
        if config.action_table is not None:
            config.action_table = [[float(v) for v in np.atleast_1d(row)] for row in config.action_table]
            if not config.action_table or len({len(row) for row in config.action_table}) != 1:
                raise ConfigError("action_table needs at least one row, and every row the same number of input values")
            if config.action_bounds:
                raise ConfigError("action_bounds has no effect with action_table (a Discrete action picks a row): "
                                  "drop one")
        return config
