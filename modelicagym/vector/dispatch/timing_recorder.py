"""The calling process's record of where each pool step's time went, summed into a `StepTiming`
(the definitions are in :mod:`modelicagym.vector.timing`)."""

from __future__ import annotations

import numpy as np

from modelicagym.vector.timing import StepTiming
from modelicagym.vector.wire.buffers import SharedBuffers

__all__ = ["TimingRecorder"]


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
