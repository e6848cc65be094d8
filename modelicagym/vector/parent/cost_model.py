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
measured while the pool runs (`modelicagym.vector.parent.layout_policy`), so they carry what the
machine does to them: a light FMU's batch is mostly ``handover``, a heavy one's mostly stepping.

Cores enter where the stepping parties outnumber them: then parties take turns on a core, and
each one's step takes ``parties / cores`` times its own CPU time. Costs are measured in one layout
and predicted for another, so they are scaled by the ratio of the two layouts' sharing.

Worked examples are in docs/design.md ("The cost model").
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Costs", "Shape", "batch_us", "best_shape", "sharing"]


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
    return max(home, costs.handover_us + shape.worker_envs * costs.worker_env_us * scale)


def best_shape(costs: Costs, shapes: list[Shape], current: int, margin: float) -> int:
    """The index in ``shapes`` of the fastest predicted layout; ``current`` unless another is
    faster by ``margin`` (a ratio > 1: measurements are noisy, and a move costs episodes in the
    old layout)."""
    times = [batch_us(costs, shape) for shape in shapes]
    best = min(range(len(shapes)), key=lambda k: (times[k], k != current))
    return best if margin * times[best] < times[current] else current
