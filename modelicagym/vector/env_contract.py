"""What the pool relies on from the envs it runs, stated as `typing.Protocol`s.

Every env a pool runs is a `PoolEnv`: Gymnasium's `gymnasium.Env` interface and nothing more. An
env that offers more gets more, and the pool asks for it by these names only:

* a `TimedEnv` counts its time inside FMU calls, so the pool's timing splits env time into FMU
  time and the Python around it (every `~modelicagym.FMUEnv` does; so may a user's env);
* a `NativeEnv` (an unwrapped `~modelicagym.FMUEnv` whose ``step_path`` is ``"native"``) is stepped by
  the C library through its ``native_step`` struct, a whole slice in one call
  (`~modelicagym.vector.native_slice.NativeBatch`); what C leaves to Python it finishes with
  ``observation()`` and ``native_step_failure()``;
* ``env.reset_is_deterministic`` (a reset without seed or options starts the same episode in any
  env the same env fn makes): with it, and the native step path, a pool whose layout it plans may
  move the env between the calling process and its worker at an episode boundary
  (`~modelicagym.vector.placement`).

And of the env fn, the callable that makes an env: ``max_envs_per_process`` (an attribute of it) caps
the envs of one worker process (1 for FMUs with ``canBeInstantiatedOnlyOncePerProcess``); it is
pickled with cloudpickle and called in the worker, so it must not capture live FMU instances
(ctypes handles), only what is needed to create one.
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

from gymnasium import Space

__all__ = ["NativeEnv", "PoolEnv", "StepResult", "TimedEnv"]

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


class NativeEnv(PoolEnv, Protocol):
    """An env the C library steps (see the module docstring)."""

    step_path: str
    step_path_reason: str

    @property
    def native_step(self) -> Any:
        """The env's ``mg_env`` struct and its buffers (`modelicagym.env.native_step.NativeStep`)."""

    def observation(self) -> Any:
        """The observation of the FMU's current state."""

    def native_step_failure(self) -> StepResult:
        """The step result of an FMU call that failed in C, raised or handled as the Python path would."""
