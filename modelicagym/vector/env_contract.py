"""What the pool relies on from the envs it runs, stated as `typing.Protocol`s.

Every env a pool runs is a `PoolEnv`: Gymnasium's `gymnasium.Env` interface and nothing more. An
env that offers more gets more, and the pool asks for it by these names only:

* a `TimedEnv` counts its time inside FMU calls, so the pool's timing splits env time into FMU
  time and the Python around it (every `~modelicagym.FMUEnv` does; so may a user's env);
* a `NativeEnv` (an unwrapped `~modelicagym.FMUEnv` whose ``step_path`` is ``"native"``) is stepped by
  the C library through its ``native_step`` struct, a whole slice in one call
  (`~modelicagym.vector.slice.native_slice.NativeBatch`); what C leaves to Python it finishes with
  ``observation()`` and ``native_step_failure()``; where its reward or termination is written in
  Python, its ``native_endings`` (``None`` otherwise) computes them after C stepped the FMUs, for
  every env of the slice sharing its ``key`` in one ``finish(envs, observations, actions,
  terminated)`` call (`~modelicagym.vector.slice.slice_endings`); where ``python_edges`` says
  Python computes its inputs or observation around the C step, the slice calls, per env, its
  ``check_action`` and ``native_step.write_inputs(action)`` before the C call and its
  ``observation()`` after it (`~modelicagym.vector.slice.slice_edges`; ``python_observation``
  says which);
* a `StatefulEnv` gives its whole state as a value (``get_state()``), loads one (``set_state``)
  and says, changing nothing, whether it would (``check_state``, which raises what ``set_state``
  would): the pool's ``get_states`` / ``set_states``, which checks every env before loading any;
* ``env.reset_is_deterministic`` (a reset without seed or options starts the same episode in any
  env the same env fn makes): with it, and the native step path, a pool whose layout it plans may
  move the env between the calling process and its worker at an episode boundary
  (`~modelicagym.vector.layout.placement`);
* ``env.unwrapped.safe_in_caller is True`` says that the env runs no native code but ours (the
  bundled models, built from this project's sources, say so): the pool may then step it in the
  calling process by default (``caller_steps=None``), where a crash would be the caller's. Any env
  that does not say so -- every `~modelicagym.FMUEnv` over a user's FMU, any other env -- runs
  only in worker processes unless the user asks for the calling process (``caller_steps=True``,
  ``num_workers=0``). The pool learns it from a worker that made the env, so an env that does not
  say so is never even created in the calling process (`safe_in_caller`);
* ``env.unwrapped.fault_label`` (a ``str``, optional) names what the env runs, e.g. its FMU's
  path: the one line printed when an env stepped in the calling process ends it (a crash,
  ``exit()``) names the env by its index and this label.

And of the env fn, the callable that makes an env: ``max_envs_per_process`` (an attribute of it) caps
the envs of one worker process (``make_vec`` sets 1 for an FMU with
``canBeInstantiatedOnlyOncePerProcess`` whose config says ``instances_per_process="one"``); it is
pickled with cloudpickle and called in the worker, so it must not capture live FMU instances
(ctypes handles), only what is needed to create one. ``safe_in_caller`` (an attribute of it, as of
the env) promises that its envs are safe in the calling process, so the pool need not ask a worker
first (the registry's env fns for the bundled models carry it).
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

from gymnasium import Space

__all__ = ["NativeEnv", "PoolEnv", "StatefulEnv", "StepResult", "TimedEnv", "fault_label", "fn_safe_in_caller", "safe_in_caller"]

#: ``(observation, reward, terminated, truncated, info)``, as ``gymnasium.Env.step`` returns it
StepResult = tuple[Any, float, bool, bool, dict[str, Any]]


class PoolEnv(Protocol):
    """The Gymnasium env interface, which is all the pool needs of an env."""

    observation_space: Space
    action_space: Space
    metadata: dict[str, Any]
    render_mode: str | None

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        ...

    def step(self, action: Any) -> StepResult: ...

    def close(self) -> None: ...

    def get_wrapper_attr(self, name: str) -> Any: ...

    def set_wrapper_attr(self, name: str, value: Any) -> None: ...


@runtime_checkable
class TimedEnv(Protocol):
    """An env that counts the nanoseconds it spent inside FMU calls, since it was created."""

    fmu_time_ns: int


class StatefulEnv(Protocol):
    """An env whose state is a value (see the module docstring; `modelicagym.FMUEnv` is one)."""

    def get_state(self) -> Any: ...

    def check_state(self, state: Any) -> None: ...

    def set_state(self, state: Any) -> None: ...


class NativeEnv(PoolEnv, Protocol):
    """An env the C library steps (see the module docstring)."""

    step_path: str
    step_path_reason: str
    #: what Python computes around the C step (an overridden ``action_to_inputs`` or ``observation``),
    #: as a phrase; ``None`` when C does the whole step up to its endings
    python_edges: str | None
    #: the observation is ``observation()``, computed in Python after the C step
    python_observation: bool

    @property
    def native_step(self) -> Any:
        """The env's ``mg_env`` struct and its buffers (`modelicagym.env.native_step.NativeStep`)."""

    def observation(self) -> Any:
        """The observation of the FMU's current state."""

    def check_action(self, action: Any) -> None:
        """Raise what ``step`` raises for an action outside the action space."""

    def native_step_failure(self) -> StepResult:
        """The step result of an FMU call that failed in C, raised or handled as the Python path would."""

    @property
    def native_endings(self) -> Any:
        """How the env's steps end in Python (`modelicagym.env.endings.PythonEndings`), or ``None``."""


def safe_in_caller(env: Any) -> bool:
    """Whether ``env`` says it runs no native code but ours (see the module docstring); ``False``
    unless its unwrapped env has ``safe_in_caller`` set to ``True``."""
    return getattr(getattr(env, "unwrapped", env), "safe_in_caller", False) is True


def fn_safe_in_caller(env_fn: Any) -> bool:
    """Whether the env fn promises envs that are safe in the calling process (its ``safe_in_caller``)."""
    return getattr(env_fn, "safe_in_caller", False) is True


def fault_label(env: Any) -> str:
    """What ``env`` runs, for the line that names it when it ends the calling process: its
    ``fault_label`` (e.g. an FMU's path), or its type's name."""
    unwrapped = getattr(env, "unwrapped", env)
    label = getattr(unwrapped, "fault_label", None)
    return label if isinstance(label, str) and label else type(unwrapped).__name__
