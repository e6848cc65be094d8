"""The multi-process pool: many envs stepped in a few worker processes, fast.

:class:`PoolVectorEnv` is a drop-in for :class:`gymnasium.vector.AsyncVectorEnv` and runs any
Gymnasium env. It imports nothing of ``modelicagym.fmu``; what it knows of FMUs is what an env may
offer it, stated once in :mod:`modelicagym.vector.env_contract`. The pool's parts and the path of a
step through them are mapped in ``docs/design.md``.
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
from modelicagym.vector.layout.plan import plan_workers
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
