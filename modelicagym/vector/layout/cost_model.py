"""What a batch costs in a given layout, predicted from measured costs: the adaptive layout's model.

A synchronous batch ends when its slowest party ends. The calling process (the *home* party)
steps its own envs one after the other; meanwhile every stepping worker is woken, steps its envs
and signals that it is done. So a layout with ``h`` envs at home and at most ``w`` envs in any of
its ``k`` stepping workers takes

    batch = max(h * home_env, handover + w * worker_env)        (k > 0)
    batch = h * home_env                                        (k = 0)

where ``home_env`` and ``worker_env`` are one env's step at home and in a worker, and
``handover`` is what waking the workers and learning that they are done adds to the workers'
side (wake-up latency, the barrier, the home party's wait for the last signal). All three are
measured while the pool runs (`modelicagym.vector.layout.policy`), so they carry what the
machine does to them: a light FMU's batch is mostly ``handover``, a heavy one's mostly stepping.

A worker that shares its CPU with a busy neighbour (the parties apart on a shared machine,
`modelicagym.vector.layout.affinity.PartiesApart`) waits for its turn there in proportion to the
CPU time it asks for, so its side is its stepping stretched by a measured factor:
``w * worker_env * stretch`` (8 envs of ~85 us beside one busy process: 3.1x its stepping with 2
and with 3 envs in the worker; a constant hand-over of 530 us, measured with 3, picked 1).

Cores enter where the stepping parties outnumber them: then parties take turns on a core, and
each one's step takes ``parties / cores`` times its own CPU time. Costs are measured in one layout
and predicted for another, so they are scaled by the ratio of the two layouts' sharing.

The costs come from what the pool measures. The calling process times its own slice and its wait;
the workers' side cannot be read off a batch's wall time (on many cores it is mostly wake-ups and
the caller's wait), so while a layout adapts each party times its own stepping (one clock reading
per env in C, into the pool's shared ``timing`` array), and `PartyTimes` samples those times every
`SAMPLE_EVERY` steps: the busiest stepping worker's, the stand-in's and all the workers' together.
`PartyCosts` are a window's medians, with the envs behind each.

Worked examples are in docs/design.md ("The cost model").
"""

from __future__ import annotations

import statistics
from dataclasses import dataclass

import numpy as np

__all__ = ["SAMPLE_EVERY", "Costs", "PartyCosts", "PartyTimes", "Shape", "batch_us", "best_shape", "sharing"]


@dataclass(frozen=True)
class Costs:
    """Measured costs, in microseconds, and the cores they were measured on."""

    #: one env's step in the home party (the calling process, or the worker standing in for it)
    home_env_us: float
    #: one env's step in a worker
    worker_env_us: float
    #: what the workers' side of a batch adds to their stepping: wake-ups and done signals
    handover_us: float
    #: what the home party's time adds to its envs times ``home_env_us``: 0 for the calling process;
    #: for a stand-in worker, whose envs cost what they cost wherever they run, its measured time
    #: less its envs at ``home_env_us`` (negative where its own envs are the cheaper ones)
    home_offset_us: float = 0.0
    #: how much longer the workers' side takes than their stepping (1: on CPUs of their own; a worker
    #: sharing its CPU with a busy neighbour waits for its turn in proportion to its stepping)
    worker_stretch: float = 1.0
    #: the usable cores, and the stepping parties the costs were measured with
    cores: int = 1
    parties: int = 1


@dataclass(frozen=True)
class Shape:
    """A layout as the model sees it: envs at home, the most envs in one worker, stepping workers."""

    home_envs: int
    worker_envs: int
    workers: int


def sharing(parties: int, cores: int) -> float:
    """How much longer a party's step takes than its CPU time when ``parties`` step on ``cores``."""
    return max(1.0, parties / max(cores, 1))


def batch_us(costs: Costs, shape: Shape) -> float:
    """The predicted time of one batch in ``shape``."""
    scale = sharing(shape.workers + 1, costs.cores) / sharing(costs.parties, costs.cores)
    home = (costs.home_offset_us + shape.home_envs * costs.home_env_us) * scale
    if shape.workers == 0 or shape.worker_envs == 0:
        return home
    return max(home, costs.handover_us + shape.worker_envs * costs.worker_env_us * scale * costs.worker_stretch)


def best_shape(costs: Costs, shapes: list[Shape], current: int, margin: float) -> int:
    """The index in ``shapes`` of the fastest predicted layout; ``current`` unless another is
    faster by ``margin`` (a ratio > 1: measurements are noisy, and a move costs episodes in the
    old layout)."""
    times = [batch_us(costs, shape) for shape in shapes]
    best = min(range(len(shapes)), key=lambda k: (times[k], k != current))
    return best if margin * times[best] < times[current] else current


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
