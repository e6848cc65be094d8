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

import numpy as np

from modelicagym.vector.buffers import SharedBuffers

__all__ = ["StepTiming", "TimingRecorder"]


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


class TimingRecorder:
    """Accumulates per-batch measurements; :meth:`summary` turns them into a :class:`StepTiming`."""

    def __init__(self) -> None:
        self.clear()

    def clear(self) -> None:
        """Forget all measurements."""
        self._steps = 0
        self._sums = [0] * 6

    def add(self, wall_ns: int, rows: np.ndarray, woken: np.ndarray) -> None:
        """Record one batch: its wall time and each party's env and FMU time (nanoseconds), from
        the pool's shared ``timing`` rows (a row per party, the calling process's last). ``woken``
        says, per worker, whether it stepped in this batch: one not woken left its last step's
        times in its row, which count as zero here (the rows are the parties', never written here).

        Plain Python integers: a handful of numpy calls would cost more than a light batch step."""
        envs, fmus = rows[:, SharedBuffers.ENV_NS].tolist(), rows[:, SharedBuffers.FMU_NS].tolist()
        if not woken.all():
            for k in np.flatnonzero(woken == 0).tolist():
                envs[k] = fmus[k] = 0
        critical = envs.index(max(envs))
        env_total, fmu_total = sum(envs), sum(fmus)
        critical_env, critical_fmu = envs[critical], fmus[critical]
        sums = self._sums
        sums[0] += wall_ns
        sums[1] += critical_fmu
        sums[2] += critical_env - critical_fmu
        sums[3] += wall_ns - critical_env
        sums[4] += fmu_total
        sums[5] += env_total - fmu_total
        self._steps += 1

    def summary(self) -> StepTiming:
        """Means per batch step so far (zeros if nothing was measured)."""
        steps = max(self._steps, 1)
        return StepTiming(self._steps, *(total / steps / 1e9 for total in self._sums))
