"""The Ray runner: a sweep's (setting, repeat) groups as Ray tasks; results assembled on the driver.

The envs of a sweep (env ``i = setting * repeats + repeat``) are split into contiguous groups,
one Ray task each (one CPU by default). A task trains its group's agents on a local vector env
of its node (``SyncVectorEnv`` on one CPU, the pool on more) with the seeds those envs have in a
whole local run, so the episodes are the same as a local run's. The task returns its episodes
and Q-tables to the driver; the driver assembles the sweep's result
(`~modelicagym.experiments.runner.assemble_sweep`) and the caller writes it exactly as a local
run does. Nothing is written before every group is back.

A task whose worker process or node dies is retried by Ray (``max_retries`` times, on any node);
an exception inside a group, or a group lost more often than that, cancels the other groups and
raises `SweepGroupError` naming the group's envs: nothing of that sweep is written.

`RayRunner` is what `~modelicagym.experiments.run_sweeps` takes (``runner=RayRunner()``; ``modelicagym
reproduce --ray``); the local runner (`~modelicagym.experiments.runner.LocalRunner`) knows nothing of it.
"""

from __future__ import annotations

import dataclasses
import datetime
import logging
import time
from typing import Any

from modelicagym.distributed.cluster import connect, format_env_range
from modelicagym.distributed.errors import SweepGroupError
from modelicagym.experiments.config import SweepConfig
from modelicagym.experiments.results import SweepResult
from modelicagym.experiments.runner import MakeVec, SweepPart, assemble_sweep, progress_bar, run_sweep_part
from modelicagym.vector.api import plan_workers

__all__ = ["DEFAULT_MAX_RETRIES", "RayRunner", "run_sweep_on_ray"]

logger = logging.getLogger(__name__)

#: how often Ray runs a group again whose process or node died
DEFAULT_MAX_RETRIES = 3


@dataclasses.dataclass(frozen=True)
class RayRunner:
    """A `~modelicagym.experiments.runner.SweepRunner` that runs each sweep on a Ray cluster
    (`run_sweep_on_ray` with these settings)."""

    address: str | None = None
    groups: int | None = None
    cpus_per_group: int = 1
    max_retries: int = DEFAULT_MAX_RETRIES

    def __call__(self, config: SweepConfig, *, make_vec: MakeVec | None, progress: bool) -> SweepResult:
        return run_sweep_on_ray(config, address=self.address, make_vec=make_vec, groups=self.groups,
                                cpus_per_group=self.cpus_per_group, max_retries=self.max_retries, progress=progress)


def run_sweep_on_ray(
    config: SweepConfig,
    *,
    address: str | None = None,
    make_vec: MakeVec | None = None,
    groups: int | None = None,
    cpus_per_group: int = 1,
    max_retries: int = DEFAULT_MAX_RETRIES,
    progress: bool = True,
) -> SweepResult:
    """Run ``config`` on a Ray cluster, one task per group of (setting, repeat) envs.

    Args:
        config: the sweep.
        address: the cluster (see `~modelicagym.distributed.connect`) if not connected yet.
        make_vec: as `~modelicagym.experiments.run_sweep`'s (it travels to the tasks); default
            ``modelicagym.make_vec`` on the task's node.
        groups: Ray tasks (default: the cluster's CPUs over ``cpus_per_group``, at most one per env).
        cpus_per_group: CPUs each task reserves; its local pool uses them all.
        max_retries: how often a task is run again after its process or node died.
        progress: a progress bar over finished groups' episodes.
    """
    ray = connect(address)
    n_envs = len(config.settings) * config.repeats
    if groups is None:
        groups = max(1, int(ray.cluster_resources().get("CPU", 1)) // cpus_per_group)
    slices = plan_workers(n_envs, min(groups, n_envs), None)
    task = ray.remote(_run_group).options(num_cpus=cpus_per_group, max_retries=max_retries, retry_exceptions=False)
    logger.info("sweep %r: %d envs in %d Ray tasks", config.name, n_envs, len(slices))
    started = datetime.datetime.now(datetime.timezone.utc)
    clock = time.perf_counter()
    pending = {task.remote(config, list(envs), make_vec, cpus_per_group): envs for envs in slices}
    parts: list[SweepPart] = []
    with progress_bar(n_envs * config.episodes, config.name, progress) as on_episodes:
        while pending:
            [ready], _ = ray.wait(list(pending), num_returns=1)
            envs = pending.pop(ready)
            try:
                parts.append(ray.get(ready))
            except ray.exceptions.RayError as error:
                for ref in pending:
                    ray.cancel(ref, force=True)
                raise _group_error(ray, config, envs, error, max_retries) from error
            if on_episodes is not None:
                on_episodes(len(envs) * config.episodes)
    return assemble_sweep(config, parts, started, time.perf_counter() - clock, len(slices))


def _run_group(config: SweepConfig, indices: list[int], make_vec: MakeVec | None, cpus: int) -> SweepPart:
    """The Ray task: train envs ``indices`` of ``config`` on this node."""
    options: dict[str, Any] = {}
    if make_vec is None:
        import modelicagym

        make_vec = modelicagym.make_vec
        options = {"backend": "sync"} if cpus <= 1 else {"num_workers": cpus - 1, "caller_steps": True}
    return run_sweep_part(config, indices, make_vec=make_vec, progress=False, **options)


def _group_error(ray: Any, config: SweepConfig, envs: range, error: Exception, max_retries: int) -> SweepGroupError:
    where = f"sweep {config.name!r}, {format_env_range(envs)}"
    if isinstance(error, ray.exceptions.RayTaskError):
        cause = error.cause if getattr(error, "cause", None) is not None else error
        message = f"{where} raised {type(cause).__name__}: {str(cause).strip().splitlines()[-1]}"
    else:
        message = (f"{where} was lost with its Ray worker or node, also on {max_retries} retries: "
                   f"{str(error).strip().splitlines()[0]}")
    return SweepGroupError(f"{message}; nothing of this sweep was written", config.name, list(envs))
