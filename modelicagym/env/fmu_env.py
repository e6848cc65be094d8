"""`FMUEnv`: any FMU as a Gymnasium environment, from a few lines of config.

The step contract, stated once:

* ``reset(seed, options)`` starts an episode at ``start_time`` with the config's parameters,
  updated by ``options["parameters"]`` for that episode only; it returns the outputs as the
  first observation and an empty info.
* ``step(action)`` checks the action (a clear ``ValueError`` otherwise), maps it to input values
  (`action_to_inputs`), advances the FMU by ``time_step`` and returns
  ``(observation, reward, terminated, truncated, info)``:
  ``terminated`` when `is_terminal` says so or the FMU itself ended the simulation
  (``info["fmu_terminated"]``); ``truncated`` after ``max_episode_steps``, or when the FMU
  failed (status Error/Fatal, or an error loop: more error messages in one step than
  ``modelicagym.fmu.logs.LOG_LIMITS`` allows): then ``info["fmu_error"]`` holds its message and the
  next reset re-instantiates the FMU. Infos are empty on ordinary steps.
* time is ``start_time + k * time_step``, read as ``env.time``.

Steps take the native path (one call into our C library, `modelicagym.env.native_step`) when the
config defines them completely, else the Python path; both give the same results.
``env.step_path`` says which, ``env.step_path_reason`` why.

``render_mode="rgb_array"`` draws the episode's strip chart (`modelicagym.env.strip_chart`: the
actions and observations over time; matplotlib, the ``plots`` extra), so Gymnasium's
``RecordVideo`` works for any FMU. Only then is each step recorded, in Python: such an env steps on
the Python path; without a render mode nothing is recorded and nothing on the step path changes.

Subclasses override what the paper's users override: `compute_reward`, `is_terminal`,
`action_to_inputs`, `make_action_space` / `make_observation_space` (with `observation`), and
`render` (a class that draws its own picture, as the cart-pole's, records no strip chart).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from dataclasses import replace
from typing import Any

import gymnasium as gym
import numpy as np

from modelicagym.action_checks import action_checker
from modelicagym.env.config import FMUEnvConfig
from modelicagym.env.config_checks import check_action_bound_names, check_parameter
from modelicagym.env.native_step import NativeStep, python_path_reason
from modelicagym.env.spaces import Observer, space_for, write_values
from modelicagym.env.strip_chart import StripChart, require_matplotlib
from modelicagym.errors import ConfigError
from modelicagym.fmu import FMUCallError, FMUError, FMUInstance, open_fmu
from modelicagym.fmu.logs import RateLimitedLog
from modelicagym.native.abi import Flags

logger = logging.getLogger(__name__)


class FMUEnv(gym.Env):
    """A Gymnasium environment around one FMU instance.

    Example::

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

    ``config`` may be a dict (e.g. loaded from a file); keyword arguments override it. See
    `FMUEnvConfig` for every key.
    """

    metadata: dict[str, Any] = {"render_modes": ["rgb_array"]}
    #: the FMU's native code is ours (built from this project's sources), so a pool may step this env
    #: in the calling process by default (`modelicagym.vector.env_contract`): only the bundled
    #: models say so; an FMUEnv over any FMU a user gives, even a copy of ours, does not
    safe_in_caller: bool = False

    def __init__(self, config: Mapping[str, Any] | None = None, /, *, render_mode: str | None = None, **options: Any):
        self.config = cfg = FMUEnvConfig.from_mapping({**(config or {}), **options})
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ConfigError(f"render_mode {render_mode!r} is not one of {self.metadata['render_modes']}")
        self.render_mode = render_mode
        if self._draws_strip_chart:
            require_matplotlib()  # before the FMU is loaded: a missing extra is one line, nothing to free
        used = [*cfg.inputs, *cfg.outputs, *cfg.parameters]  # bounds are on outputs
        self.description = description = open_fmu(cfg.fmu, validate=cfg.validate, used=used)
        if not cfg.outputs:
            raise ConfigError(f"{description.name}: 'outputs' is empty; outputs of this FMU: "
                             f"{', '.join(v.name for v in description.outputs) or 'none'}")
        for name, value in cfg.parameters.items():
            check_parameter(description.name, description.settable_variable(name), value)
        check_action_bound_names(description.name, cfg.action_bounds or {}, list(cfg.inputs))
        self.time_step = float(cfg.time_step or description.default_experiment.step_size or 0.0)
        if not self.time_step > 0:
            raise ConfigError(f"{description.name} declares no default step size: give 'time_step'")
        self.fmu = FMUInstance(
            description,
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
        )
        self.action_space = cfg.action_space or self.make_action_space()
        self.observation_space = cfg.observation_space or self.make_observation_space()
        self._observer = Observer(space_for(self.fmu.output_variables), self.fmu.outputs)
        self._check_action = action_checker(self.action_space)
        self._bounds_source, self._bounds = self._termination_bounds(cfg.termination)
        self.max_episode_steps = cfg.max_episode_steps
        self.positive_reward = float(cfg.positive_reward)
        self.negative_reward = float(cfg.negative_reward)
        self._elapsed_steps = 0
        self._failure_log = RateLimitedLog(logger, f"{description.name}'s truncated episodes")
        self.episode_parameters: dict[str, Any] = {}
        self.strip_chart = self._make_strip_chart()
        self._native: NativeStep | None = None
        reason = python_path_reason(self, FMUEnv)
        if reason is None:
            self._native = NativeStep(self)
            self.step_path, self.step_path_reason = "native", "the config defines the whole step"
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
        chart = StripChart(self.fmu, self.description.model_name, horizon)
        self.metadata = {"render_fps": 1.0 / self.time_step, **self.metadata}
        self.step, self.reset = self._step_and_record, self._reset_and_record
        return chart

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
        super().reset(seed=seed)
        options = options or {}
        overrides = options.get("parameters") or {}
        if not overrides and self._native is not None and self._native.reset():
            self.episode_parameters = dict(self.config.parameters)  # a native reset: no random ones
            return self.observation(), {}
        parameters = {**self.config.parameters, **overrides}
        self.episode_parameters = {
            name: value(self.np_random) if callable(value) else value for name, value in parameters.items()
        }
        self.fmu.reset(self.episode_parameters)
        self.elapsed_steps = 0
        if self._native is not None:
            self._native.bind()
        return self.observation(), {}

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        self._check_action(action)
        native = self._native
        if native is not None:
            flags = native.step(action)
            if flags & Flags.FMU_ERROR:
                return self.fmu_failure(native.error())
            return (native.observation(), native.reward, *Flags.ending(flags))
        write_values(self.fmu.inputs, self.action_to_inputs(action))
        info: dict[str, Any] = {}
        try:
            model_terminated = self.fmu.step(self.time_step)
        except (FMUCallError, FMUError) as error:
            return self.fmu_failure(error)
        observation = self.observation()
        terminated = self.is_terminal(observation)
        if model_terminated:
            terminated = True
            info["fmu_terminated"] = True
        self.elapsed_steps += 1
        truncated = self.max_episode_steps is not None and self.elapsed_steps >= self.max_episode_steps
        return observation, self.compute_reward(observation, action, terminated), terminated, truncated, info

    def fmu_failure(self, error: FMUError) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """The step result when the FMU failed: the episode is truncated with the FMU's message
        in ``info["fmu_error"]`` (the next reset re-instantiates the FMU)."""
        self._failure_log.log(logging.WARNING, "%s: episode truncated at t=%g: %s", self.description.name,
                              self.fmu.time, error)
        self.elapsed_steps += 1
        return self.observation(), 0.0, False, True, {"fmu_error": str(error)}

    @property
    def fault_label(self) -> str:
        """What this env runs, for the line that names it if its FMU ends the process: the FMU's path."""
        return f"FMU {self.config.fmu}"

    @property
    def reset_is_deterministic(self) -> bool:
        """Whether a reset without seed or options starts the same episode in every env made from
        the same config: no parameter drawn at random, no overridden ``reset``. The pool may then
        move the env between processes at an episode boundary (``modelicagym.vector.placement``)."""
        return type(self).reset is FMUEnv.reset and not any(callable(v) for v in self.config.parameters.values())

    @property
    def native_step(self) -> NativeStep | None:
        """This env's native step (its C struct and single-env step), ``None`` on the Python path."""
        return self._native

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
        """The observation space; default: derived from the output variables."""
        return space_for(self.fmu.output_variables)

    def observation(self) -> Any:
        """The observation from the FMU's current outputs (override with a custom observation space)."""
        return self._observer.observe()

    def action_to_inputs(self, action: Any) -> Any:
        """Input values for a (checked) action: an array-like in input order, or ``{name: value}``;
        default: the action itself, or its row of the config's ``action_table``."""
        if self.config.action_table is not None:
            return self.config.action_table[int(action)]
        return action

    def is_terminal(self, observation: Any) -> bool:
        """Whether the episode is over; default: the config's ``termination`` bounds or callable."""
        termination = self.config.termination
        if callable(termination):
            return bool(termination(self, observation))
        if self._bounds:
            values = self._bounds_source()
            for index, low, high in self._bounds:
                if not low <= values[index] <= high:
                    return True
        return False

    def compute_reward(self, observation: Any, action: Any, terminated: bool) -> float:
        """The reward of a step; default: the config's ``reward`` callable, else the paper's rule."""
        if self.config.reward is not None:
            return float(self.config.reward(self, observation, action, terminated))
        return self.negative_reward if terminated else self.positive_reward

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
