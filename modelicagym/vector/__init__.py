"""The multi-process pool: many envs stepped in a few worker processes, fast.

:class:`PoolVectorEnv` is a drop-in for :class:`gymnasium.vector.AsyncVectorEnv` and runs any
Gymnasium env. It imports nothing of ``modelicagym.fmu``; what it knows of FMUs is what an env may
offer it, by these names:

- ``env.unwrapped.fmu_time_ns``: cumulative nanoseconds the env spent inside its simulator (for an
  FMU env: in FMU calls), an int the env keeps up to date; with it, :meth:`PoolVectorEnv.timing`
  splits env time into that inner time (reported as ``fmu_s``) and the env's own Python time.
  Envs without it count entirely as Python time.
- ``max_envs_per_process`` on the env fn (an attribute of the callable): at most that many envs in
  one worker process; 1 for FMUs with ``canBeInstantiatedOnlyOncePerProcess``.
- ``env.step_path == "native"`` with ``env.native_step``, ``env.native_step_failure()`` and
  ``env.observation()`` (an `FMUEnv` on the native step path, unwrapped): a slice of such envs steps
  in one C call of :mod:`modelicagym.vector.native_slice`, with the same results.
- ``env.reset_is_deterministic``: a reset without seed or options starts the same episode in any
  env the same env fn makes. With it (and the native step path), a pool whose layout the pool
  plans may move the env between the calling process and its worker at an episode boundary
  (:mod:`~modelicagym.vector.placement`).
- The env fn itself is pickled with cloudpickle and called in the worker: it must not capture
  live FMU instances (ctypes handles), only what is needed to create one.
"""

from modelicagym.vector.errors import (
    CallerTimeoutError,
    ConcurrentUseError,
    EnvError,
    NoPendingCallError,
    PendingCallError,
    PoolClosedError,
    PoolError,
    PoolMemoryError,
    SpaceMismatchError,
    WorkerDiedError,
    WorkerTimeoutError,
)
from modelicagym.vector.plan import plan_workers
from modelicagym.vector.pool import RESTART_INFO_KEY, PoolVectorEnv
from modelicagym.vector.timing import StepTiming

__all__ = [
    "RESTART_INFO_KEY",
    "CallerTimeoutError",
    "ConcurrentUseError",
    "EnvError",
    "NoPendingCallError",
    "PendingCallError",
    "PoolClosedError",
    "PoolError",
    "PoolMemoryError",
    "PoolVectorEnv",
    "SpaceMismatchError",
    "StepTiming",
    "WorkerDiedError",
    "WorkerTimeoutError",
    "plan_workers",
]
