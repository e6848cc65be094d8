"""The multi-process pool: many envs stepped in a few worker processes, fast.

:class:`PoolVectorEnv` is a drop-in for :class:`gymnasium.vector.AsyncVectorEnv`; it knows nothing
about FMI except that an env may be expensive to create and may crash.
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
