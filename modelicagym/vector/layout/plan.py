"""How a pool is laid out before anything starts: envs per worker, and the start method."""

from __future__ import annotations

import math
import multiprocessing
from collections.abc import Callable, Sequence
from typing import Any, NamedTuple

from modelicagym.cores import usable_cores
from modelicagym.errors import ConfigError

__all__ = ["Layout", "default_start_method", "plan_layout", "plan_workers"]


class Layout(NamedTuple):
    """Which envs each worker steps, and which the calling process steps itself (or ``None``).

    With ``caller_if_safe`` the calling process gets ``caller_slice`` only if its envs are safe
    there (`modelicagym.vector.env_contract.safe_in_caller`); else one more worker steps it.
    ``reason`` says why every env is in a worker when ``caller_slice`` is ``None`` (else "").
    """

    worker_slices: list[range]
    caller_slice: range | None
    caller_if_safe: bool = False
    reason: str = ""


def plan_layout(
    env_fns: Sequence[Callable[[], Any]],
    num_workers: int | None,
    max_envs_per_worker: int | None,
    restart_dead_workers: bool,
    step_timeout: float | None,
    caller_steps: bool | None,
    batch_size: int | None = None,
    cores: int | None = None,
) -> Layout:
    """The pool's layout; see `PoolVectorEnv`'s ``caller_steps`` for when the caller steps a slice
    (by default, only a slice of envs safe in the calling process: ``caller_if_safe``). Partial
    batches (``batch_size``) put every env in a worker.

    An env fn's ``max_envs_per_process`` attribute caps the envs per worker like
    ``max_envs_per_worker``; the caller's slice is the last one. ``cores``: the usable cores
    (`modelicagym.cores.usable_cores`) the default plan has a party for, the caller's included.
    """
    caps = [max_envs_per_worker] + [getattr(fn, "max_envs_per_process", None) for fn in env_fns]
    caps = [cap for cap in caps if cap is not None]
    if num_workers == 0:
        return _caller_only_layout(len(env_fns), caps, restart_dead_workers, step_timeout, caller_steps)
    if batch_size is not None:
        caller_steps = False
    why_not = _why_no_caller_slice(env_fns, num_workers, max_envs_per_worker, restart_dead_workers, step_timeout,
                                   caller_steps, batch_size)
    chosen = caller_steps is not None
    if not chosen:
        caller_steps = not why_not
    if caller_steps and restart_dead_workers:
        raise ConfigError("caller_steps=True and restart_dead_workers=True: the calling process cannot be restarted")
    parties = num_workers + 1 if caller_steps and num_workers else num_workers
    slices = plan_workers(len(env_fns), parties, min(caps) if caps else None, cores)
    if caller_steps:
        return Layout(slices, slices.pop(), not chosen)
    return Layout(slices, None, reason=f"every env is in a worker: {'; '.join(why_not)}")


def _why_no_caller_slice(
    env_fns: Sequence[Callable[[], Any]],
    num_workers: int | None,
    max_envs_per_worker: int | None,
    restart_dead_workers: bool,
    step_timeout: float | None,
    caller_steps: bool | None,
    batch_size: int | None,
) -> list[str]:
    """What the pool was given that keeps the calling process from stepping a slice by default,
    in words (empty: nothing does)."""
    if batch_size is not None:
        return [f"batch_size={batch_size} (partial batches come from workers only)"]
    if caller_steps is False:
        return ["caller_steps=False"]
    asked = [
        (num_workers is not None, f"num_workers={num_workers} was given (caller_steps=True adds the calling process)"),
        (max_envs_per_worker is not None, f"max_envs_per_worker={max_envs_per_worker} was given"),
        (restart_dead_workers, "restart_dead_workers=True (a worker can be restarted, the calling process cannot)"),
        (step_timeout is not None, f"step_timeout={step_timeout} (a hung worker can be killed, the calling process "
                                   "cannot)"),
    ]
    reasons = [words for given, words in asked if given]
    capped = [k for k, fn in enumerate(env_fns) if getattr(fn, "max_envs_per_process", None) is not None]
    if capped:
        k = min(capped, key=lambda k: env_fns[k].max_envs_per_process)
        reasons.append(f"env {k}'s fn allows at most {env_fns[k].max_envs_per_process} env(s) per process "
                       "(max_envs_per_process; 1 for an FMU that may be instantiated only once per process, "
                       "kept so by its config: instances_per_process='one')")
    return reasons


def _caller_only_layout(
    num_envs: int, caps: list[int], restart_dead_workers: bool, step_timeout: float | None, caller_steps: bool | None
) -> Layout:
    """``num_workers=0``: the calling process steps every env; nothing to isolate, restart or time out."""
    conflicts = [name for name, asked in (("caller_steps=False", caller_steps is False),
                                          ("restart_dead_workers=True", restart_dead_workers),
                                          ("step_timeout", step_timeout is not None),
                                          (f"at most {min(caps) if caps else 0} env(s) per process",
                                           bool(caps) and min(caps) < num_envs)) if asked]
    if conflicts:
        raise ConfigError(f"num_workers=0 (the calling process steps every env) and {conflicts[0]} contradict "
                          "each other: use worker processes")
    return Layout([], range(num_envs))


def plan_workers(
    num_envs: int, num_workers: int | None, max_envs_per_worker: int | None, cores: int | None = None
) -> list[range]:
    """Split ``num_envs`` envs into contiguous slices, one per worker.

    ``num_workers`` defaults to ``cores`` (default: the usable cores, `modelicagym.cores.usable_cores`),
    never more than ``num_envs``; with
    ``max_envs_per_worker`` the number of workers grows to ``ceil(num_envs / max_envs_per_worker)``
    if needed (an explicit ``num_workers`` that is too small for it is an error). The first
    ``num_envs % workers`` slices hold one env more than the others.
    """
    if num_envs < 1:
        raise ConfigError(f"a pool needs at least one env, got {num_envs}")
    if max_envs_per_worker is not None and max_envs_per_worker < 1:
        raise ConfigError(f"max_envs_per_worker must be >= 1, got {max_envs_per_worker}")
    needed = 1 if max_envs_per_worker is None else math.ceil(num_envs / max_envs_per_worker)
    if num_workers is None:
        workers = max(min(usable_cores() if cores is None else cores, num_envs), needed)
    else:
        if num_workers < 1:
            raise ConfigError(f"num_workers must be >= 1, got {num_workers}")
        if num_workers < needed:
            raise ConfigError(
                f"num_workers={num_workers} cannot hold {num_envs} envs with at most "
                f"{max_envs_per_worker} env(s) per worker; use at least {needed} workers"
            )
        workers = min(num_workers, num_envs)
    base, extra = divmod(num_envs, workers)
    slices, start = [], 0
    for k in range(workers):
        stop = start + base + (k < extra)
        slices.append(range(start, stop))
        start = stop
    return slices


def default_start_method() -> str:
    """``forkserver`` where available, else ``spawn``.

    Workers are forked from a small, single-threaded server process rather than from the caller,
    because the caller typically runs threads (PyTorch/BLAS pools, loggers) that make ``fork``
    unsafe, and workers are restarted mid-run when such threads certainly exist; workers also
    inherit nothing else from the caller (no FMU libraries it may have loaded, no other pools'
    pipes). The cost is paid once per worker start (about 0.2 s on the target machine, small next
    to creating an FMU env). Unlike a plain ``multiprocessing`` program, the caller's script needs
    no main guard: workers are started without it (``handle.main_module_hidden``).
    ``start_method="fork"`` starts fastest and suits tests and thread-free callers.
    """
    return "forkserver" if "forkserver" in multiprocessing.get_all_start_methods() else "spawn"
