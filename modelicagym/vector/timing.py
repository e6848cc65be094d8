"""Where the time of a pool step goes: inside the FMU, in the env's Python code, or in the pool.

Definitions, per batch step (one ``step_async`` + ``step_wait``):

- ``wall`` is measured by the parent, from the start of ``step_async`` to the end of ``step_wait``
  (actions copied in, workers woken, workers done, results copied out, infos merged).
- Each worker measures, per env, the wall time of the env's ``step`` (and of the ``reset`` an
  autoreset performs) with ``time.perf_counter_ns``, and the increase of
  ``env.unwrapped.fmu_time_ns`` over that call when the env has that counter (an FMU env keeps it:
  cumulative nanoseconds spent in FMU calls). Its *env time* is the sum over its envs.
- Workers run in parallel, so the batch waits for the *critical worker*: the one with the largest
  env time in that batch. ``fmu`` and ``env_python`` (env time minus FMU time) are taken from it,
  and ``pool_overhead = wall - fmu - env_python``: everything the pool adds on the critical path
  (synchronisation, copying actions and observations, pickling infos, reading actions from shared
  memory, worker-side bookkeeping, and waiting for a worker that got less CPU than the others).

So ``wall = fmu + env_python + pool_overhead`` exactly. The ``*_total`` fields add the envs of all
workers instead (the CPU work done per batch, e.g. to compare against a single process).
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["StepTiming"]


@dataclass(frozen=True)
class StepTiming:
    """Means per batch step, in seconds, over ``steps`` measured batch steps (see module docs)."""

    steps: int
    wall_s: float
    fmu_s: float
    env_python_s: float
    pool_overhead_s: float
    fmu_total_s: float
    env_python_total_s: float
    #: what runs where and why (``PoolVectorEnv.layout``), when read
    layout: str = ""
