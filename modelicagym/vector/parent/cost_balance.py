"""Balancing a pool's envs by their measured step cost: the workers against the stand-in worker.

Where a worker stands in for the calling process (`modelicagym.vector.parent.assembly`), it holds a copy
of every env, so it can take any of the workers' envs at an episode boundary, and give them back.
When the envs' step costs differ (a stiff phase, an event storm, a parameter that makes one env
costlier than another), a synchronous step waits for the slowest party while the other's core
idles. The parties' own stepping times, sampled from the pool's shared ``timing`` array every
`SAMPLE_EVERY` steps, say which party is the bottleneck and what one of its envs costs;
`balance_shift` turns that into a number of envs to move (`ConsolidationPolicy` decides when).
"""

from __future__ import annotations

import statistics
from dataclasses import dataclass

import numpy as np

__all__ = ["SAMPLE_EVERY", "PartyCosts", "PartyTimes", "balance_shift"]

#: steps between two samples of the parties' stepping times (a sample costs a few microseconds)
SAMPLE_EVERY = 8
#: one env moves only if the busier party's excess is at least this many of its envs' mean cost
#: (1 would make a move that merely swaps the bottleneck; above it, the batch gets shorter)
MOVE_AT = 1.5


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


def balance_shift(costs: PartyCosts, lent: int, movable: int) -> int:
    """Envs to move from the workers to the stand-in (positive) or back (negative) so that both
    finish a batch at about the same time: the excess of the busier party, over twice the mean
    cost of one of its envs (moving half the excess evens them), rounded down after `MOVE_AT`.
    ``lent``: the workers' envs the stand-in steps now (it can give back no more); ``movable``:
    all the workers' envs (at least one stays with them: every env in the stand-in is the
    consolidated layout, which the policy tries on its own)."""
    excess = costs.worker_us - costs.stand_in_us
    giver_us, giver_envs = ((costs.worker_us, costs.worker_envs) if excess > 0
                            else (costs.stand_in_us, costs.stand_in_envs))
    if giver_envs <= 0 or giver_us <= 0:
        return 0
    env_us = giver_us / giver_envs
    envs = int((abs(excess) / env_us - MOVE_AT) / 2 + 1) if abs(excess) >= MOVE_AT * env_us else 0
    if excess > 0:
        return min(envs, movable - 1 - lent, costs.worker_envs - 1)
    return -min(envs, lent)


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
