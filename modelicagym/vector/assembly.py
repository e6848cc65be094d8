"""How a pool comes together: its worker processes started, the calling process's slice created,
shared memory handed out, the envs placed, and the dispatcher over all of it. Either everything
runs afterwards, or nothing is left behind (no process, no mapping, no env)."""

from __future__ import annotations

import multiprocessing
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import gymnasium as gym

from modelicagym.vector.creation import close_envs
from modelicagym.vector.dispatch import Dispatcher
from modelicagym.vector.env_slice import EnvSlice
from modelicagym.vector.placement import Placement, place_envs
from modelicagym.vector.protocol import EnvDescription, WorkerConfig
from modelicagym.vector.worker_set import WorkerSet

__all__ = ["PoolParts", "assemble"]


@dataclass
class PoolParts:
    """A running pool's parts; ``first`` describes the envs of worker 0 (or of the caller's slice)."""

    workers: WorkerSet
    placement: Placement
    dispatcher: Dispatcher
    first: EnvDescription


def assemble(
    env_fns: Sequence[Callable[[], gym.Env]],
    slices: list[range],
    local_slice: range | None,
    start_method: str,
    config: WorkerConfig,
    adapt_layout: bool | None,
) -> PoolParts:
    """Start a worker per slice of ``slices``, create ``local_slice`` here, share memory, place the
    envs (`modelicagym.vector.placement`) and set up the dispatcher; on any failure release it all
    and raise."""
    workers = WorkerSet(env_fns, slices, multiprocessing.get_context(start_method), config, config.startup_timeout)
    workers.launch()
    local = None
    try:
        local = None if local_slice is None else EnvSlice.create(
            list(env_fns), local_slice, len(slices), config.autoreset_mode, len(local_slice) / len(env_fns)
        )
        first = workers.connect(local)
        placement, local = place_envs(list(env_fns), workers, local, config.autoreset_mode, adapt_layout)
    except BaseException:
        if local is not None:
            close_envs(local.envs)
        workers.release()
        raise
    dispatcher = Dispatcher(workers.handles, local, workers.buffers, config.spin_time, config.step_timeout,
                            placement.stepping)
    return PoolParts(workers, placement, dispatcher, first)
