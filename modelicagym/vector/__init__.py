"""The multi-process pool: many envs stepped in a few worker processes, fast.

:class:`PoolVectorEnv` is a drop-in for :class:`gymnasium.vector.AsyncVectorEnv`. It knows nothing
about FMI except that an env may be expensive to create and may crash. What an env can offer it:

- ``env.unwrapped.fmu_time_ns``: cumulative nanoseconds spent inside FMU calls (an int the env
  keeps up to date); with it, :meth:`PoolVectorEnv.timing` splits env time into FMU time and the
  env's own Python time. Envs without it count entirely as Python time.
- ``max_envs_per_process`` on the env fn (an attribute of the callable): at most that many envs in
  one worker process; 1 for FMUs with ``canBeInstantiatedOnlyOncePerProcess``.
- The env fn itself is pickled with cloudpickle and called in the worker: it must not capture
  live FMU instances (ctypes handles), only what is needed to create one.
"""

from modelicagym.vector.errors import EnvError, PoolError, WorkerDiedError, WorkerTimeoutError
from modelicagym.vector.pool import RESTART_INFO_KEY, PoolVectorEnv, plan_workers
from modelicagym.vector.timing import StepTiming

__all__ = [
    "RESTART_INFO_KEY",
    "EnvError",
    "PoolError",
    "PoolVectorEnv",
    "StepTiming",
    "WorkerDiedError",
    "WorkerTimeoutError",
    "plan_workers",
]
