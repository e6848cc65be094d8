"""How a pool comes together: its worker processes started, the calling process's slice created,
shared memory handed out, the envs placed, and the dispatcher over all of it. Either everything
runs afterwards, or nothing is left behind (no process, no mapping, no env).

By default the calling process steps a slice only of envs that are safe there
(`modelicagym.vector.env_contract.safe_in_caller`). Unless the env fns promise it, the pool asks:
one more worker starts, the stand-in, and creates a copy of every env; if they all say they are
safe, that worker stops and the calling process creates its own; if not, the stand-in keeps them
and does the caller's part instead: it steps the caller's slice, and on a crowded machine the
adaptive layout consolidates every env there (`modelicagym.vector.layout.placement`). So an env that does
not say it is safe is never created in the calling process unless the user puts envs there
(``caller_steps=True``): then the calling process also holds copies of the workers' envs, and the
adaptive layout moves envs into it when that is faster, as it does with envs safe there."""

from __future__ import annotations

import multiprocessing
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import gymnasium as gym

from modelicagym.vector.dispatch.dispatcher import Dispatcher
from modelicagym.vector.dispatch.worker_set import WorkerSet
from modelicagym.vector.env_contract import fn_safe_in_caller
from modelicagym.vector.layout.placement import Placement, no_stand_in_reason, place_envs, stand_in_fixed_reason
from modelicagym.vector.layout.plan import Layout
from modelicagym.vector.slice.creation import close_envs
from modelicagym.vector.slice.env_slice import EnvSlice
from modelicagym.vector.wire.protocol import EnvDescription, WorkerConfig

__all__ = ["PoolParts", "assemble"]


@dataclass
class PoolParts:
    """A running pool's parts; ``first`` describes the envs of worker 0 (or of the caller's slice)."""

    workers: WorkerSet
    placement: Placement
    dispatcher: Dispatcher
    first: EnvDescription

    @property
    def caller_steps(self) -> bool:
        """Whether the calling process steps a slice of the envs."""
        return self.dispatcher.local is not None


def _trusted(env_fns: Sequence[Callable[[], gym.Env]], layout: Layout) -> bool:
    """Whether the user put envs in the calling process (``caller_steps=True``), so that it may
    hold copies of the workers' envs to take them when that is faster, safe there or not: the same
    FMUs' code runs there already. Not for envs allowed a few per process (``max_envs_per_process``):
    copies would be more."""
    return (layout.caller_slice is not None and not layout.caller_if_safe
            and all(getattr(fn, "max_envs_per_process", None) is None for fn in env_fns))


def assemble(
    env_fns: Sequence[Callable[[], gym.Env]],
    layout: Layout,
    start_method: str,
    config: WorkerConfig,
    adapt_layout: bool | None,
    max_concurrency: int | None = None,
) -> PoolParts:
    """Start a worker per slice of the layout, create the caller's slice here (if it is safe
    there, with ``layout.caller_if_safe``: see the module docstring), share memory, place the envs
    (`modelicagym.vector.layout.placement`) and set up the dispatcher (at most ``max_concurrency`` parties
    running a step or reset at once); on any failure release it all and
    raise."""
    slices, local_slice = list(layout.worker_slices), layout.caller_slice
    ask = layout.caller_if_safe and not all(map(fn_safe_in_caller, env_fns[local_slice.start : local_slice.stop]))
    ctx = multiprocessing.get_context(start_method)
    workers = WorkerSet(env_fns, slices, ctx, config, config.startup_timeout, stand_in=ask)
    workers.launch()
    local = stand_in_slice = None
    isolated = layout.reason or None  # why the plan gave the calling process no slice
    try:
        if ask:
            description = workers.await_created()[-1]
            fixed = stand_in_fixed_reason(description, adapt_layout)
            if description.safe_in_caller:
                workers.drop_last()
            elif fixed is None:
                stand_in_slice, local_slice = local_slice, None
            else:  # its copies would only be reset and called, with resets that may differ: a plain worker
                workers.drop_last(replacement=local_slice)
                isolated = no_stand_in_reason(fixed)
                local_slice = None
        local = None if local_slice is None else EnvSlice.create(
            list(env_fns), local_slice, len(slices), config.autoreset_mode, len(local_slice) / len(env_fns)
        )
        first = workers.connect(local)
        placement, local = place_envs(
            list(env_fns), workers, local, config, adapt_layout, stand_in_slice, isolated, _trusted(env_fns, layout)
        )
    except BaseException:
        if local is not None:
            close_envs(local.envs)
        workers.release()
        raise
    dispatcher = Dispatcher(workers.handles, local, workers.buffers, config.spin_time, config.step_timeout,
                            placement.stepping, max_concurrency, config.cores)
    return PoolParts(workers, placement, dispatcher, first)
