"""The parties' own stepping times, sampled while an adaptive layout runs: what the cost model is fed.

A batch's wall time says little about where it went: on many cores it is mostly wake-ups and the
calling process's wait. So while a layout adapts, each party times its own stepping (one clock
reading per env in C, into the pool's shared ``timing`` array), and `PartyTimes` samples those
times every `SAMPLE_EVERY` steps: the busiest stepping worker's, the stand-in's and all the
workers' together. `PartyCosts` are a window's medians, with the envs behind each, from which the
layout policies (`modelicagym.vector.parent.layout_policy`) take the costs of the model: an env's
step in a worker, and in a stand-in, which the parent cannot tell apart from the other workers'
by its own clock.
"""

from __future__ import annotations

import statistics
from dataclasses import dataclass

import numpy as np

__all__ = ["SAMPLE_EVERY", "PartyCosts", "PartyTimes"]

#: steps between two samples of the parties' stepping times (a sample costs a few microseconds)
SAMPLE_EVERY = 8


@dataclass(frozen=True)
class PartyCosts:
    """Median stepping times of a window's sampled batches, in microseconds, and the envs behind them."""

    #: the busiest stepping worker's time, and its envs
    worker_us: float
    worker_envs: int
    #: the stand-in's time, and its envs
    stand_in_us: float
    stand_in_envs: int
    #: every stepping worker's time, summed (what the stand-in alone would at least take for their envs)
    workers_total_us: float = 0.0
    #: the envs every worker steps, summed
    all_worker_envs: int = 0

    @property
    def total_us(self) -> float:
        """The parties' stepping times summed: a lower bound of a batch with every env in the stand-in."""
        return self.workers_total_us + self.stand_in_us


class PartyTimes:
    """Samples, every `SAMPLE_EVERY` steps, how long the busiest stepping worker and the stand-in
    took over the last batch (their ``timing`` rows: written while ``timing_enabled`` is set).

    Args:
        env_ns: the pool's ``timing[:, ENV_NS]``, a row per worker, then the stand-in's or the
            calling process's (whose time the parent measures itself: its sample reads 0).
        in_caller: the pool's shared array (1: the stand-in or the calling process steps the env).
        worker_slices: the envs of each worker (not the stand-in).
        stepping: per worker, whether it steps any env (an idle worker's row is stale).
        stand_in: the row after the workers' is a stand-in worker's.
    """

    def __init__(self, env_ns: np.ndarray, in_caller: np.ndarray, worker_slices: list[range],
                 stepping: np.ndarray, stand_in: bool = True) -> None:
        self._env_ns = env_ns
        self._in_caller = in_caller
        self._worker_slices = worker_slices
        self._stepping = stepping[: len(worker_slices)]
        self._workers = len(worker_slices)
        self._stand_in = stand_in
        self._countdown = SAMPLE_EVERY
        self._samples: list[tuple[int, int]] = []

    def count(self) -> None:
        """Count a step; take a sample every `SAMPLE_EVERY`."""
        self._countdown -= 1
        if self._countdown > 0:
            return
        self._countdown = SAMPLE_EVERY
        stepping = self._stepping.astype(bool)
        if stepping.any():
            workers_ns = self._env_ns[: self._workers][stepping]
            stand_in_ns = int(self._env_ns[self._workers]) if self._stand_in else 0
            self._samples.append((int(workers_ns.max()), stand_in_ns, int(workers_ns.sum())))

    def take(self) -> list[tuple[int, int, int]]:
        """The samples since the last take: (busiest worker's ns, stand-in's ns, all workers' ns)
        per sampled batch."""
        samples, self._samples = self._samples, []
        return samples

    def costs(self, samples: list[tuple[int, int, int]]) -> PartyCosts | None:
        """The medians of ``samples`` (taken in the current layout) with the envs each party
        steps now; ``None`` without samples."""
        if not samples:
            return None
        held = self._in_caller.astype(bool)
        envs = [int((~held[s.start : s.stop]).sum()) for s in self._worker_slices]
        return PartyCosts(statistics.median(s[0] for s in samples) / 1e3, max(envs),
                          statistics.median(s[1] for s in samples) / 1e3, int(held.sum()),
                          statistics.median(s[2] for s in samples) / 1e3, sum(envs))
