"""`FMUEnv`: any FMU as a Gymnasium environment, from a few lines of config.

The step contract, stated once:

* ``reset(seed, options)`` starts an episode at ``start_time`` with the config's parameters and
  fixed inputs (``episode_parameters`` holds both as set), updated by ``options["parameters"]`` for
  that episode only; it returns the outputs as the first observation and an empty info.
* ``step(action)`` checks the action (a clear ``ValueError`` otherwise), maps it to input values
  (`action_to_inputs`), advances the FMU by ``time_step`` and returns
  ``(observation, reward, terminated, truncated, info)``:
  ``terminated`` when `is_terminal` says so or the FMU itself ended the simulation
  (``info["fmu_terminated"]``); ``truncated`` after ``max_episode_steps``, or when the FMU
  failed (status Error/Fatal, or an error loop: more error messages in one step than
  ``modelicagym.fmu.logs.LOG_LIMITS`` allows): then ``info["fmu_error"]`` holds its message and the
  next reset re-instantiates the FMU. Infos are empty on ordinary steps.
* time is ``start_time + k * time_step``, read as ``env.time``.
* ``get_state()`` / ``set_state(state)``: the env's whole state as a picklable value, loadable in
  any process with the same FMU (`modelicagym.env.saved_state`); ``reset(options={"state": s})``
  starts an episode there, and the config's ``start_states`` makes every other reset draw one.

Steps take the native path (one call into our C library, `modelicagym.env.native_step`) unless
``step`` is overridden or the FMU cannot step in C (then the Python path); both give the same
results. ``env.step_path`` says which, ``env.step_path_reason`` why. What Python computes keeps the
FMU's step in C around it: an overridden ``action_to_inputs`` (or an action space C cannot map onto
the inputs) writes the input values before the C step, an overridden ``observation`` (or a space
laid out otherwise than the outputs) makes the observation after it, and a reward or termination
written in Python decides how the step ends (`modelicagym.env.endings`; a pool calls
``compute_rewards`` / ``are_terminal`` on a slice's arrays).

``render_mode="rgb_array"`` draws the episode's strip chart (`modelicagym.env.strip_chart`: the
actions and observations over time; matplotlib, the ``plots`` extra), so Gymnasium's
``RecordVideo`` works for any FMU. Only then is each step recorded, in Python: such an env steps on
the Python path; without a render mode nothing is recorded and nothing on the step path changes.

Subclasses override what the paper's users override: `compute_reward`, `is_terminal` (or their
array forms, the classmethods `compute_rewards`, `are_terminal`), `action_to_inputs`,
`make_action_space` / `make_observation_space` (with `observation`), and `render` (a class that
draws its own picture, as the cart-pole's, records no strip chart).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from typing import Any

import gymnasium as gym
import numpy as np

from modelicagym.action_checks import action_checker, action_clipper, describe_action
from modelicagym.env.config import FMUEnvConfig
from modelicagym.env.config_checks import check_action_bound_names, check_fixed_input_names, check_parameter
from modelicagym.env.endings import (
    PythonEndings,
    batch_reward_defined,
    batch_termination_defined,
    check_array_hooks,
    overridden,
    python_endings,
    reward_of_one,
    termination_of_one,
)
from modelicagym.env.native_step import (
    NativeStep,
    native_path_reason,
    python_edges,
    python_inputs_reason,
    python_observation_reason,
    python_path_reason,
)
from modelicagym.env.saved_state import EnvState, generator_state, restored_generator
from modelicagym.env.spaces import Observer, space_for, write_values
from modelicagym.env.strip_chart import Series, StripChart, require_matplotlib
from modelicagym.env.tracking import Tracking
from modelicagym.errors import ActionError, ArgumentError, ArgumentTypeError, ConfigError
from modelicagym.fmu import FMUCallError, FMUError
from modelicagym.fmu.logs import RateLimitedLog
from modelicagym.native.abi import Flags
from modelicagym.system import SystemDescription, new_instance, open_model

logger = logging.getLogger(__name__)


class FMUEnv(gym.Env):
    """A Gymnasium environment around one FMU instance, or a system of connected FMUs and time
    tables (``fmus`` and ``connections``, or an SSP archive as ``fmu``: `modelicagym.system`), whose
    variables are then named ``component.variable``.

    Args:
        config: the config as a dict (e.g. loaded from a file): `FMUEnvConfig` lists every key.
        render_mode: ``"rgb_array"``: `render` draws the episode's strip chart (the ``plots``
            extra); ``None``: no rendering.
        **options: config keys as keyword arguments; they override ``config``'s.

    Example::

        import numpy as np
        from modelicagym import FMUEnv
        from modelicagym.models.cartpole import cartpole_fmu

        env = FMUEnv(
            fmu=cartpole_fmu(),
            inputs=["f"],
            outputs=["x", "x_dot", "theta", "theta_dot"],
            parameters={"m_cart": 10.0},
            time_step=0.05,
            termination={"x": (-2.4, 2.4)},
            max_episode_steps=500,
        )
        observation, info = env.reset(seed=0)
        observation, reward, terminated, truncated, info = env.step(np.array([5.0]))
    """

    metadata: dict[str, Any] = {"render_modes": ["rgb_array"]}
    #: the FMU's native code is ours (built from this project's sources), so a pool may step this env
    #: in the calling process by default (`modelicagym.vector.env_contract`): only the bundled
    #: models say so; an FMUEnv over any FMU a user gives, even a copy of ours, does not
    safe_in_caller: bool = False
    #: the class's own per-env hooks (an overridden ``observation``, ``action_to_inputs``, ``step``,
    #: ``compute_reward`` or ``is_terminal``) keep no state in the env from one episode to the next:
    #: an adaptive pool may then hold a copy of the env in a second process and move it there at an
    #: episode boundary (`per_env_hooks`); by default such envs keep their place
    stateless_hooks: bool = False

    def __init__(self, config: Mapping[str, Any] | None = None, /, *, render_mode: str | None = None, **options: Any):
        self.config = cfg = FMUEnvConfig.from_mapping({**(config or {}), **options})
        check_array_hooks(type(self), FMUEnv)  # before the FMU is loaded: nothing to free
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ConfigError(f"render_mode {render_mode!r} is not one of {self.metadata['render_modes']}")
        self.render_mode = render_mode
        if self._draws_strip_chart:
            require_matplotlib()  # before the FMU is loaded: a missing extra is one line, nothing to free
        used = [*cfg.inputs, *cfg.outputs, *cfg.parameters, *cfg.fixed_inputs]  # bounds are on outputs
        self.description = description = open_model(cfg.fmu, fmus=cfg.fmus, connections=cfg.connections,
                                                    loop_breaks=cfg.loop_breaks, validate=cfg.validate, used=used)
        if not cfg.outputs:
            raise ConfigError(f"{description.name}: 'outputs' is empty; outputs of this FMU: "
                             f"{', '.join(v.name for v in description.outputs) or 'none'}")
        for name, value in cfg.parameters.items():
            check_parameter(description.name, description.settable_variable(name), value)
        held = check_fixed_input_names(description.name, cfg.fixed_inputs, description.variables, description.inputs)
        for variable in held:  # settable: a system refuses an input a connection feeds
            check_parameter(description.name, description.settable_variable(variable.name),
                            cfg.fixed_inputs[variable.name], "fixed input")
        check_action_bound_names(description.name, cfg.action_bounds or {}, list(cfg.inputs))
        self.time_step = float(cfg.time_step or description.default_experiment.step_size or 0.0)
        if not self.time_step > 0:
            raise ConfigError(f"{description.name} declares no default step size: give 'time_step'")
        self.fmu = new_instance(
            description,
            master=cfg.master,
            substeps=cfg.substeps,
            mode=cfg.mode,
            inputs=cfg.inputs,
            outputs=cfg.outputs,
            start_time=cfg.start_time,
            reset_rung=cfg.reset_rung,
            solver=cfg.solver,
            tolerance=cfg.tolerance,
            solver_step=cfg.solver_step,
            integrator="python" if cfg.step_path == "python" else "auto",
            validate=cfg.validate,
            logging_on=cfg.logging_on,
            step_size=self.time_step,
            instances_per_process=cfg.instances_per_process,
        )
        if isinstance(description, SystemDescription):
            #: a system's loops of direct feedthrough, one line each: where the master reads it from the previous step
            self.metadata = {**self.metadata, "loops": description.loop_lines(cfg.master)}
        self.action_space = cfg.action_space or self.make_action_space()
        self._observer = Observer(space_for(self.fmu.output_variables), self.fmu.outputs)
        #: the config's setpoints and observation entries beyond the outputs (`modelicagym.env.tracking`), or None
        self.tracking = Tracking(self, cfg.setpoints, cfg.observe) if cfg.setpoints or cfg.observe else None
        self.observation_space = cfg.observation_space or self.make_observation_space()
        self._check_action = action_checker(self.action_space)
        #: with ``action_out_of_bounds="clip"``: the action clipped into a Box's bounds, then checked
        self._clip = action_clipper(self.action_space) if cfg.action_out_of_bounds == "clip" else None
        self._bounds_source, self._bounds = self._termination_bounds(cfg.termination)
        self.max_episode_steps = cfg.max_episode_steps
        self.positive_reward = float(cfg.positive_reward)
        self.negative_reward = float(cfg.negative_reward)
        self._elapsed_steps = 0
        self._failure_log = RateLimitedLog(logger, f"{description.name}'s truncated episodes")
        self.episode_parameters: dict[str, Any] = {}
        self._start_states = cfg.start_states  # read on every reset: one attribute, not two
        self.strip_chart = self._make_strip_chart()
        self._native: NativeStep | None = None
        #: on the native path, how its steps end in Python (its reward or termination is Python's); else None
        self.native_endings: PythonEndings | None = None
        self._batch_reward = batch_reward_defined(self, FMUEnv)
        self._batch_termination = batch_termination_defined(self, FMUEnv)
        #: on the native path, what Python computes around the C step (the inputs, the observation)
        #: as a phrase; None when C does the step up to its endings
        self.python_edges: str | None = None
        self._python_observation = False
        self._value_checked: tuple[tuple[int, ...], tuple[np.dtype, ...]] | None = None
        self._c_whole_step = False
        reason = python_path_reason(self, FMUEnv)
        if reason is None:
            inputs_reason = python_inputs_reason(self, FMUEnv)
            observation_reason = python_observation_reason(self, FMUEnv)
            self.native_endings = endings = python_endings(self, FMUEnv)
            self._python_observation = observation_reason is not None
            self._native = NativeStep(self, python_termination=endings is not None and endings.termination,
                                      python_inputs=inputs_reason is not None,
                                      python_observation=self._python_observation)
            self.python_edges = python_edges(inputs_reason, observation_reason)
            self.step_path = "native"
            #: the arrays whose values C checks (`NativeStep.value_checked`), unless they are clipped
            #: first, and the native step of one (`NativeStep.array_step`)
            self._value_checked = self._native.value_checked if self._clip is None else None
            self._step_array = None if self._value_checked is None else self._native.array_step()
            #: C makes the whole step: the observation, the reward and the ending
            self._c_whole_step = endings is None and not self._python_observation
            self._native_observation, self._native_reward = self._native.observation, self._native.reward_cell
            components = getattr(self.fmu, "components", None)
            self.step_path_reason = native_path_reason(inputs_reason, observation_reason,
                                                       [] if endings is None else endings.parts,
                                                       None if components is None else len(components))
        else:
            self.step_path, self.step_path_reason = "python", reason

    def _make_strip_chart(self) -> StripChart | None:
        """The chart `render` draws when this env renders and its class draws no picture of its own;
        then its ``step`` and ``reset`` record into it (set on the instance: an env without the
        chart runs its class's methods untouched), and ``metadata["render_fps"]`` plays a video of it
        in real time unless the class says otherwise."""
        if not self._draws_strip_chart:
            return None
        horizon = None if self.max_episode_steps is None else self.max_episode_steps * self.time_step
        extra, read_extra = self._chart_extras()
        chart = StripChart(self.fmu, self.description.model_name, horizon, extra, read_extra)
        self.metadata = {"render_fps": 1.0 / self.time_step, **self.metadata}
        self.step, self.reset = self._step_and_record, self._reset_and_record
        return chart

    def _chart_extras(self) -> tuple[list[Series], Callable[[], list[float]] | None]:
        """What the chart draws beside the FMU's variables: each setpoint (dashed, over its output)
        and each scalar held input (a panel of its own), with the function that reads their values."""
        units = {v.name: v.unit or "" for v in self.fmu.output_variables}
        setpoints = list(self.config.setpoints)
        held = [name for name, value in self.config.fixed_inputs.items() if np.ndim(value) == 0 or callable(value)]
        held = [name for name in held if not self.description.variable(name).shape]
        if not setpoints and not held:
            return [], None
        extra = [Series(f"setpoint of {name}", units[name], "setpoint", "float", follows=name) for name in setpoints]
        extra += [Series(name, self.description.variable(name).unit or "", "held input", "float", stepwise=True)
                  for name in held]

        def read() -> list[float]:
            values = self.setpoints
            return ([values.get(name, np.nan) for name in setpoints]
                    + [float(np.asarray(self.episode_parameters.get(name, np.nan))) for name in held])

        return extra, read

    @property
    def _draws_strip_chart(self) -> bool:
        return self.render_mode == "rgb_array" and type(self).render is FMUEnv.render

    def _step_and_record(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        result = type(self).step(self, action)
        self.strip_chart.record()
        return result

    def _reset_and_record(self, *, seed: int | None = None,
                          options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        result = type(self).reset(self, seed=seed, options=options)
        self.strip_chart.restart()
        return result

    # -- the Gymnasium API -----------------------------------------------------------------------

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        """Start an episode at ``start_time``, with the config's parameters and fixed inputs.

        Args:
            seed: seeds the env's generator (``np_random``), which draws the parameters and fixed
                inputs given as callables, and start states.
            options: ``{"parameters": {name: value}}`` sets parameters for this episode only;
                ``{"state": state}`` starts it from a state `get_state` gave (the two exclude each
                other: a state carries its episode's parameters).

        Returns:
            The first observation (the outputs) and an empty info.
        """
        super().reset(seed=seed)
        if (options or self._start_states is not None) and self._started_from_state(seed, options or {}):
            return self.observation(), {}
        overrides = options.get("parameters") if options else None
        if not overrides and self._native is not None and self._native.reset():
            self.episode_parameters = self.config.reset_values  # a native reset: no random ones
            self._start_tracking()
            return self.observation(), {}
        parameters = {**self.config.reset_values, **(overrides or {})}
        self.episode_parameters = {
            name: value(self.np_random) if callable(value) else value for name, value in parameters.items()
        }
        self.fmu.reset(self.episode_parameters)
        self.elapsed_steps = 0
        self._start_tracking()
        if self._native is not None:
            self._native.bind()
        return self.observation(), {}

    def _start_tracking(self) -> None:
        """Draw the episode's setpoints (after its parameters, with the same generator) and zero
        what the task keeps per episode."""
        if self.tracking is not None:
            self.tracking.reset(self.np_random)

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """Apply ``action`` to the FMU's inputs (`action_to_inputs`) and advance it by ``time_step``.

        Returns:
            ``(observation, reward, terminated, truncated, info)``: ``terminated`` when
                `is_terminal` says so or the FMU ended the simulation (``info["fmu_terminated"]``);
                ``truncated`` after ``max_episode_steps``, or when the FMU failed, its message then in
                ``info["fmu_error"]`` (the next reset starts the FMU afresh). The info is empty on an
                ordinary step.

        Raises:
            ActionError: the action is outside the action space (a ``ValueError``); with
                ``action_out_of_bounds="clip"`` a Box action outside its bounds is clipped into them
                instead (NaN and a wrong shape are still refused).
        """
        native, checked = self._native, self._value_checked
        # an array whose values C checks (bounds, finite) goes to C as it is; any other action is checked here
        if checked is not None and type(action) is np.ndarray and action.dtype in checked[1] \
                and action.shape == checked[0]:
            flags = self._step_array(action)
        else:
            if self._clip is None:
                self._check_action(action)
            else:
                action = self._clip(action)
            if native is None:
                return self._python_step(action)
            flags = native.step(action)
        if not flags and self._c_whole_step:
            return self._native_observation(), self._native_reward.value, False, False, {}
        if flags & Flags.BAD_ACTION:  # C stepped nothing
            self._refuse(action)
        if flags & Flags.FMU_ERROR:
            return self.fmu_failure(native.error())
        terminated, truncated, info = Flags.ending(flags)
        endings = self.native_endings
        observation = self.observation() if self._python_observation else native.observation()
        if endings is None:
            return observation, native.reward, terminated, truncated, info
        # C stepped the FMU; the ending is Python's, as on the Python path
        if endings.termination:
            terminated = self.is_terminal(observation)
            if flags & Flags.MODEL_ENDED:
                terminated = True
        return observation, self.compute_reward(observation, action, terminated), terminated, truncated, info

    def _python_step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """`step` on the Python path, for a checked action."""
        if self.tracking is not None:
            self.tracking.before_step(action)
        write_values(self.fmu.inputs, self.action_to_inputs(action))
        info: dict[str, Any] = {}
        try:
            model_terminated = self.fmu.step(self.time_step)
        except (FMUCallError, FMUError) as error:
            return self.fmu_failure(error)
        self.elapsed_steps += 1  # before the ending is decided, as on the native path
        observation = self.observation()
        terminated = self.is_terminal(observation)
        if model_terminated:
            terminated = True
            info["fmu_terminated"] = True
        truncated = self.max_episode_steps is not None and self.elapsed_steps >= self.max_episode_steps
        return observation, self.compute_reward(observation, action, terminated), terminated, truncated, info

    def _refuse(self, action: Any) -> None:
        """Raise the `ActionError` of an action C refused (``Flags.BAD_ACTION``), as `check_action` words it."""
        self._check_action(action)
        raise ActionError(f"invalid action {describe_action(action)}: a value is outside the bounds or not finite; "
                          f"the action space is {self.action_space}")

    def _started_from_state(self, seed: int | None, options: dict[str, Any]) -> bool:
        """Start the episode from ``options["state"]``, or one drawn from the config's
        ``start_states``; False when there is none (an ordinary reset then follows)."""
        initial = options.get("initial_state")
        if initial is not None and self._starts_from_initial(initial, options):
            return True
        state = options.get("state")
        if state is not None and options.get("parameters"):
            raise ArgumentError(f"{self.description.name}: reset options 'state' and 'parameters' exclude each other "
                                "(a state carries its episode's parameters)")
        drawn = state is None and self._start_states is not None
        if drawn:
            state = self._start_states.sample(self.np_random)
        if state is None:
            return False
        # a seed given, or the generator that drew the state, goes on; not the state's generator
        self.set_state(state, restore_generator=seed is None and not drawn)
        self.elapsed_steps = 0
        if self.tracking is not None:  # a new episode: the state's setpoints, nothing kept of its steps
            self.tracking.restart()
        return True

    def _starts_from_initial(self, initial: EnvState, options: dict[str, Any]) -> bool:
        """The pool's ``init="once"``: start a never-initialized FMU from ``initial`` (saved right
        after another env's first reset) when this env's episode would have the same parameters;
        False otherwise (parameters of its own, drawn ones, or an FMU already running): it then
        resets as usual, with the same outcome."""
        if not isinstance(initial, EnvState):
            raise ArgumentTypeError(f"{self.description.name}: reset option 'initial_state' takes an EnvState, "
                                    f"got {type(initial).__name__}")
        parameters = {**self.config.reset_values, **(options.get("parameters") or {})}
        if (self.fmu.initialized or any(callable(v) for v in parameters.values())
                or not _same_values(parameters, initial.episode_parameters)):
            return False
        self.fmu.start_from(initial.fmu, parameters)
        self.episode_parameters = parameters
        self.elapsed_steps = 0
        self._start_tracking()
        if self._native is not None:
            self._native.bind()
        return True

    def get_state(self) -> EnvState:
        """The env's whole state now, as a picklable value (`EnvState`): `set_state` puts it back
        here or in another process with the same FMU, mid-episode, and the env goes on bit for bit
        as this one would. Raises `UnsupportedFeatureError` (one line) when the FMU cannot
        serialize its state (``canSerializeFMUstate`` false, FMI 1.0)."""
        return EnvState(self.fmu.save_state(), self.elapsed_steps, dict(self.episode_parameters),
                        generator_state(self._np_random), None if self.tracking is None else self.tracking.state())

    def set_state(self, state: EnvState, restore_generator: bool = True) -> None:
        """Put back a state `get_state` gave (this env's or another's over the same FMU): the
        FMU, the episode's steps and parameters, and (unless ``restore_generator`` is false) the
        random generator. A state of another FMU is refused (`StateMismatchError`), nothing changed."""
        self.check_state(state)
        self.fmu.load_state(state.fmu, state.episode_parameters)
        self.episode_parameters = dict(state.episode_parameters)
        if restore_generator and state.rng is not None:
            self._np_random = restored_generator(state.rng)
        if self.tracking is not None:
            if state.task is not None:
                self.tracking.restore(state.task)
            else:  # saved by an env without setpoints: this env's are drawn as at a reset
                self.tracking.reset(self.np_random)
        if self._native is not None:
            self._native.bind()
        self.elapsed_steps = state.elapsed_steps

    def check_state(self, state: EnvState) -> None:
        """Raise what `set_state` would raise before changing anything (not an `EnvState`, a state
        of another FMU, an FMU that cannot serialize), changing nothing: a pool's ``set_states``
        checks every env's state so before it loads any."""
        if not isinstance(state, EnvState):
            raise ArgumentTypeError(f"{self.description.name}: set_state takes an EnvState "
                                    f"(env.unwrapped.get_state()), got {type(state).__name__}")
        self.fmu.check_state(state.fmu)

    def fmu_failure(self, error: FMUError) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """The step result when the FMU failed: the episode is truncated with the FMU's message
        in ``info["fmu_error"]`` (the next reset re-instantiates the FMU)."""
        self._failure_log.log(logging.WARNING, "%s: episode truncated at t=%g: %s", self.description.name,
                              self.fmu.time, error)
        self.elapsed_steps += 1
        return self.observation(), 0.0, False, True, {"fmu_error": str(error)}

    @property
    def initializations(self) -> int:
        """How many times the FMU's own initialization ran in this env (a pool's ``init="once"``
        starts every env but one from a saved state instead)."""
        return self.fmu.initializations

    @property
    def fault_label(self) -> str:
        """What this env runs, for the line that names it if its FMU ends the process: the FMU's path
        (a system's, or its components')."""
        if self.config.fmus is not None:
            return f"system of FMUs {', '.join(str(path) for path in self.config.fmus.values())}"
        return f"FMU {self.config.fmu}"

    @property
    def reset_is_deterministic(self) -> bool:
        """Whether a reset without seed or options starts the same episode in every env made from
        the same config: no parameter drawn at random, no overridden ``reset``. The pool may then
        move the env between processes at an episode boundary (``modelicagym.vector.layout.placement``)."""
        return (type(self).reset is FMUEnv.reset and self.config.start_states is None
                and not any(callable(v) for v in self.config.reset_values.values())
                and not any(callable(v) for v in self.config.setpoints.values()))

    @property
    def per_env_hooks(self) -> list[str]:
        """The methods of this env's class that run Python per env and step and may keep state in
        the env (overridden ``step``, ``observation``, ``action_to_inputs``, a reward or termination
        per env: not their array forms, which get a slice's envs); empty when there are none or the
        class says they keep no state (`stateless_hooks`). A pool keeps such an env where it is."""
        if self.stateless_hooks:
            return []
        cls = type(self)
        hooks = [name for name in ("step", "action_to_inputs", "observation") if overridden(cls, FMUEnv, name)]
        endings = self.native_endings or python_endings(self, FMUEnv)
        if endings is not None and endings.per_env:
            hooks.append("compute_reward / is_terminal")
        return hooks

    @property
    def native_step(self) -> NativeStep | None:
        """This env's native step (its C struct and single-env step), ``None`` on the Python path."""
        return self._native

    @property
    def python_observation(self) -> bool:
        """Whether, on the native path, the observation is ``observation()`` computed in Python
        after the C step (an overridden ``observation``, or a space laid out otherwise than the outputs)."""
        return self._python_observation

    @property
    def clips_actions(self) -> bool:
        """Whether an action outside the Box's bounds is clipped into them (``action_out_of_bounds="clip"``)
        rather than refused; a pool of such envs clips the batch so."""
        return self._clip is not None and isinstance(self.action_space, gym.spaces.Box)

    def check_action(self, action: Any) -> None:
        """Raise the ``ValueError`` `step` raises for an action outside the action space."""
        self._check_action(action)

    def native_step_failure(self) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """The step result after the native step reported an FMU error (see `fmu_failure`)."""
        return self.fmu_failure(self._native.error())

    @property
    def elapsed_steps(self) -> int:
        """Steps taken in this episode (on the native path the C struct keeps the count)."""
        return self._native.state.elapsed_steps if self._native is not None else self._elapsed_steps

    @elapsed_steps.setter
    def elapsed_steps(self, value: int) -> None:
        if self._native is not None:
            self._native.state.elapsed_steps = value
        else:
            self._elapsed_steps = value

    def render(self) -> np.ndarray | None:
        """With ``render_mode="rgb_array"``: the strip chart of the episode so far, an ``H x W x 3``
        uint8 image (`modelicagym.env.strip_chart`); else ``None``."""
        return None if self.strip_chart is None else self.strip_chart.draw()

    def close(self) -> None:
        """Free the FMU instance (flushing the log of truncated episodes); the env cannot step after it."""
        failure_log = getattr(self, "_failure_log", None)
        if failure_log is not None:
            failure_log.flush()
        fmu = getattr(self, "fmu", None)
        if fmu is not None:
            fmu.close()

    # -- what subclasses override ----------------------------------------------------------------

    def make_action_space(self) -> gym.Space:
        """The action space; default: ``Discrete`` over the config's ``action_table``, else derived
        from the input variables (see `modelicagym.env.spaces`), with the config's ``action_bounds``
        in place of their declared ones."""
        if self.config.action_table is not None:
            return gym.spaces.Discrete(len(self.config.action_table))
        if not self.fmu.input_variables:
            raise ConfigError(f"{self.description.name}: 'inputs' is empty; inputs of this FMU: "
                             f"{', '.join(v.name for v in self.description.inputs) or 'none'}")
        bounds = self.config.action_bounds or {}
        return space_for([
            replace(v, min=bounds[v.name][0], max=bounds[v.name][1]) if v.name in bounds else v
            for v in self.fmu.input_variables
        ])

    def make_observation_space(self) -> gym.Space:
        """The observation space; default: derived from the output variables, followed by the
        config's ``observe`` entries (a float Box then: `modelicagym.env.tracking`)."""
        space = space_for(self.fmu.output_variables)
        if self.tracking is None or not self.tracking.entries:
            return space
        if not isinstance(space, gym.spaces.Box) or space.dtype.kind != "f" or len(space.shape) != 1:
            raise ConfigError(f"{self.description.name}: 'observe' appends values to a flat array of float outputs; "
                              f"the outputs' observation is {space}")
        low, high = self.tracking.bounds
        return gym.spaces.Box(np.concatenate([space.low, low]), np.concatenate([space.high, high]), dtype=np.float64)

    def observation(self) -> Any:
        """The observation from the FMU's current outputs (override with a custom observation space),
        followed by the config's ``observe`` entries."""
        if self.tracking is None or not self.tracking.entries:
            return self._observer.observe()
        return np.concatenate([self._observer.observe(), self.tracking.values(self.episode_parameters)])

    @property
    def observation_names(self) -> list[str]:
        """What each value of the (default, flat) observation is: the outputs' names, then the
        ``observe`` entries' (``"setpoint:T"``, ``"error_integral:T"``, ``"previous_action"``, a
        held input's name)."""
        names = [v.name if v.size == 1 else f"{v.name}[{k}]" for v in self.fmu.output_variables for k in range(v.size)]
        return names + ([] if self.tracking is None else self.tracking.labels)

    @property
    def setpoints(self) -> dict[str, float]:
        """Each setpoint's value now (``{}`` without ``setpoints``): what a reward compares the outputs with."""
        return {} if self.tracking is None else self.tracking.setpoint_values()

    @property
    def episode_setpoints(self) -> dict[str, Any]:
        """The setpoints of this episode as drawn at its reset: a number, or a `Schedule`."""
        return {} if self.tracking is None else dict(self.tracking.episode_setpoints)

    def action_to_inputs(self, action: Any) -> Any:
        """Input values for a (checked) action: an array-like in input order, or ``{name: value}``;
        default: the action itself, or its row of the config's ``action_table``."""
        if self.config.action_table is not None:
            return self.config.action_table[int(action)]
        return action

    def is_terminal(self, observation: Any) -> bool:
        """Whether the episode is over; default: the config's ``termination`` bounds or callable,
        or the array form (`are_terminal`) on one row when there is one."""
        termination = self.config.termination
        if callable(termination):
            return bool(termination(self, observation))
        if self._batch_termination:
            return termination_of_one(self, observation)
        if self._bounds:
            values = self._bounds_source()
            for index, low, high in self._bounds:
                if not low <= values[index] <= high:
                    return True
        return False

    def compute_reward(self, observation: Any, action: Any, terminated: bool) -> float:
        """The reward of a step; default: the config's ``reward`` callable, or the array form
        (`compute_rewards`) on one row when there is one, else the paper's rule."""
        if self.config.reward is not None:
            return float(self.config.reward(self, observation, action, terminated))
        if self._batch_reward:
            return reward_of_one(self, observation, action, terminated)
        return self.negative_reward if terminated else self.positive_reward

    @classmethod
    def compute_rewards(cls, envs: Sequence[FMUEnv], observations: Any, actions: Any,
                        terminated: np.ndarray) -> np.ndarray:
        """The rewards of several envs' steps at once, on arrays: row ``k`` of ``observations``,
        ``actions`` and ``terminated`` (bool) is ``envs[k]``'s step; one reward per row.

        Override it (a classmethod: it sees the envs, not one of them) to write the reward on
        arrays; a pool's slice calls it once a step for all its envs of this class (a single env
        with one row), on the native step path. Default: the config's ``batch_reward``, else
        `compute_reward` per env.
        """
        batch_reward = envs[0].config.batch_reward
        if batch_reward is not None:
            return batch_reward(envs, observations, actions, terminated)
        return np.array([env.compute_reward(observation, action, ended)
                         for env, observation, action, ended in zip(envs, observations, actions, terminated.tolist())],
                        dtype=np.float64)

    @classmethod
    def are_terminal(cls, envs: Sequence[FMUEnv], observations: Any) -> np.ndarray:
        """Whether several envs' episodes are over, on arrays: row ``k`` of ``observations`` is
        ``envs[k]``'s; one bool per row. As `compute_rewards`: override it to write the
        termination on arrays. Default: the config's ``batch_termination``, else `is_terminal` per env."""
        batch_termination = envs[0].config.batch_termination
        if batch_termination is not None:
            return batch_termination(envs, observations)
        return np.array([env.is_terminal(observation) for env, observation in zip(envs, observations)], dtype=np.bool_)

    # -- timing, for the pool --------------------------------------------------------------------

    @property
    def time(self) -> float:
        """Simulation time of the FMU."""
        return self.fmu.time

    @property
    def fmu_time_ns(self) -> int:
        """Nanoseconds spent inside FMU calls by `step`, cumulative (the pool's timing reads it)."""
        return self.fmu.fmu_time_ns

    # -- helpers ---------------------------------------------------------------------------------

    def _termination_bounds(self, termination: Any) -> tuple[Callable[[], Any] | None, list[tuple[Any, float, float]]]:
        """How to read the bounded outputs, and ``(index, low, high)`` per bound (indices into
        what the reader returns).

        When all outputs share one FMI type the values are read as one list (fast); otherwise
        by variable name.
        """
        if termination is None or callable(termination):
            return None, []
        outputs = self.fmu.outputs
        positions, offset = {}, 0
        for v in self.fmu.output_variables:
            positions[v.name] = offset if v.size == 1 else None
            offset += v.size
        flat = outputs.flat is not None

        def scalar_outputs() -> dict[str, float]:
            return {name: float(view) for name, view in outputs.views.items() if view.size == 1}

        bounds = []
        for name, (low, high) in dict(termination).items():
            if name not in positions:
                self.description.variable(name)
                raise ConfigError(f"{self.description.name}: termination bound on {name!r}, which is not in 'outputs'")
            if positions[name] is None:
                raise ConfigError(f"{self.description.name}: termination bound on {name!r}, an array; use a callable")
            bounds.append((positions[name] if flat else name, float(low), float(high)))
        return (outputs.flat.tolist if flat else scalar_outputs), bounds


def _same_values(a: Mapping[str, Any], b: Mapping[str, Any]) -> bool:
    """Whether two sets of parameter values are equal, arrays element by element."""
    return a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a)
