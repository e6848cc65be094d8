"""Run sweeps: all settings x repeats of a sweep as the envs of one vector env, one batched agent.

Env ``i = s * repeats + r`` runs repeat ``r`` of setting ``s`` with its own options
(``options_per_env``). Repeat ``r`` gets the same seeds in every setting and every sweep (derived
from ``(config.seed, r)``), so settings are compared on common random numbers and a setting that
appears in two sweeps reproduces the same episodes when the env is deterministic.

Timing: ``wall_seconds`` is the wall-clock time of the training loop (pool start-up excluded, it is
``setup_seconds``); ``seconds_per_step`` divides it by all env steps of the sweep, so it is a
throughput on this machine's cores, not the latency of one step. ``agent_seconds`` is the part
spent in the agent. If the vector env can measure its step time (the pool's ``set_timing`` /
``timing``), its breakdown (FMU, env Python code, pool overhead per batch step) is stored as
``pool_timing``; if the envs count their time in FMU calls (``fmu_time_ns``), ``per_setting`` gets
the FMU seconds per env step of each setting.
"""

from __future__ import annotations

import contextlib
import dataclasses
import datetime
import importlib.metadata
import logging
import os
import platform
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from gymnasium import spaces
from gymnasium.vector import VectorEnv

from modelicagym.agents import Discretizer, QLearningAgent, train
from modelicagym.errors import ArgumentError, ArgumentTypeError
from modelicagym.experiments.bounds import DEFAULT_BUDGET, MakeEnv, sweep_bounds
from modelicagym.experiments.config import SweepConfig
from modelicagym.experiments.plots import plot_sweep
from modelicagym.experiments.results import (
    ELSEWHERE,
    PLOT_PNG,
    SweepResult,
    is_complete,
    read_sweep,
    sweep_dir,
    write_combined_csv,
    write_sweep,
)

__all__ = [
    "LocalRunner",
    "MakeVec",
    "SweepPart",
    "SweepRunner",
    "assemble_sweep",
    "run_sweep",
    "run_sweep_part",
    "run_sweeps",
]

logger = logging.getLogger(__name__)

#: ``make_vec(env_id, num_envs, *, options_per_env, [num_workers,] **options) -> VectorEnv``
MakeVec = Callable[..., VectorEnv]


def _default_make_vec() -> MakeVec:
    import modelicagym

    return modelicagym.make_vec


def _seeds(config: SweepConfig) -> tuple[list[np.random.SeedSequence], list[int]]:
    """Agent seed sequences and env reset seeds, per env, from ``(config.seed, repeat)``."""
    agent_seeds, env_seeds = [], []
    for _ in config.settings:
        for r in range(config.repeats):
            agent_seed, env_seed = np.random.SeedSequence(config.seed, spawn_key=(r,)).spawn(2)
            agent_seeds.append(agent_seed)
            env_seeds.append(int(env_seed.generate_state(1)[0]))
    return agent_seeds, env_seeds


def _make_agent(config: SweepConfig, envs: VectorEnv, seeds: Sequence[np.random.SeedSequence]) -> QLearningAgent:
    if not isinstance(envs.single_action_space, spaces.Discrete):
        raise ArgumentTypeError(f"tabular Q-learning needs a Discrete action space, got {envs.single_action_space!r}")
    spec = config.agent
    discretizer = Discretizer.for_box(envs.single_observation_space, spec.n_bins, spec.intervals)
    return QLearningAgent(
        discretizer, int(envs.single_action_space.n), n_envs=envs.num_envs, config=spec.q_learning, seeds=seeds
    )


def _start_pool_timing(envs: VectorEnv) -> None:
    """Switch on the pool's step-time measurement, if it has one."""
    if hasattr(envs, "set_timing"):
        envs.set_timing(True)


def _pool_timing(envs: VectorEnv) -> dict[str, Any] | None:
    """The pool's own timing report (means per batch step), if it has one."""
    if not hasattr(envs, "timing"):
        return None
    timing = envs.timing() if callable(envs.timing) else envs.timing
    return dataclasses.asdict(timing) if dataclasses.is_dataclass(timing) else timing


def _fmu_time_ns(envs: VectorEnv) -> np.ndarray | None:
    """Each env's cumulative time inside FMU calls, for envs that count it (FMU envs do)."""
    try:
        return np.asarray(envs.get_attr("fmu_time_ns"), dtype=np.int64)
    except AttributeError:
        return None


def _per_setting(
    config: SweepConfig, lengths: np.ndarray, stepped: np.ndarray, fmu_ns: np.ndarray | None
) -> dict[str, dict[str, Any]]:
    """Learned and stepped env steps per setting and, when measured, FMU seconds per env step of
    the setting (over every step its envs took, autoresets included)."""
    shape = (len(config.settings), config.repeats)
    per_env_steps = lengths.sum(axis=1).reshape(shape)
    per_env_stepped = stepped.reshape(shape)
    out = {}
    for s, setting in enumerate(config.settings):
        entry: dict[str, Any] = {"env_steps": int(per_env_steps[s].sum()),
                                 "env_steps_stepped": int(per_env_stepped[s].sum())}
        if fmu_ns is not None:
            setting_ns = fmu_ns.reshape(shape)[s].sum()
            entry["fmu_seconds_per_step"] = float(setting_ns) / 1e9 / int(per_env_stepped[s].sum())
        out[setting.label] = entry
    return out


def _machine() -> dict[str, Any]:
    versions = {}
    for package in ("modelicagym", "numpy", "gymnasium", "fmpy"):
        with contextlib.suppress(importlib.metadata.PackageNotFoundError):
            versions[package] = importlib.metadata.version(package)
    return {
        "platform": platform.platform(),
        "processor": platform.processor() or platform.machine(),
        "cpu_count": os.cpu_count(),
        "python": platform.python_version(),
        "packages": versions,
    }


@contextlib.contextmanager
def progress_bar(total: int, description: str, enabled: bool) -> Iterator[Callable[[int], None] | None]:
    """A tqdm bar's ``update``, or ``None`` when disabled or tqdm is missing."""
    if not enabled:
        yield None
        return
    try:
        from tqdm import tqdm
    except ImportError:
        logger.warning("tqdm is not installed: no progress bar (pip install 'modelicagym[progress]')")
        yield None
        return
    with tqdm(total=total, desc=description, unit="episode", smoothing=0.05) as bar:
        yield bar.update


@dataclasses.dataclass
class SweepPart:
    """What training some envs of a sweep produced (all of them in a local run; a group of
    (setting, repeat) runs on a Ray task): env ``indices[j]`` is ``setting * repeats + repeat``."""

    indices: np.ndarray
    lengths: np.ndarray
    returns: np.ndarray
    agent: QLearningAgent
    #: per env of ``indices``, the steps it took (learned ones, autoresets, and any after its last episode)
    stepped: np.ndarray
    setup_seconds: float
    wall_seconds: float
    vector_steps: int
    agent_seconds: float
    num_workers: int | None
    pool_timing: dict[str, Any] | None
    fmu_ns: np.ndarray | None


def run_sweep_part(
    config: SweepConfig,
    indices: Sequence[int],
    *,
    make_vec: MakeVec | None = None,
    num_workers: int | None = None,
    progress: bool = True,
    **vector_options: Any,
) -> SweepPart:
    """Train the agents of envs ``indices`` of ``config`` side by side in one vector env.

    Env ``i`` gets the options and seeds it has in the whole sweep, so any split of a sweep into
    parts gives the same episodes as running it whole. ``vector_options`` go to ``make_vec``.
    """
    make_vec = make_vec or _default_make_vec()
    indices = np.asarray(indices, dtype=np.int64)
    all_options = [dict(setting.options) for setting in config.settings for _ in range(config.repeats)]
    options_per_env = [all_options[i] for i in indices]
    extra = {} if num_workers is None else {"num_workers": num_workers}
    all_agent_seeds, all_env_seeds = _seeds(config)
    agent_seeds, env_seeds = [all_agent_seeds[i] for i in indices], [all_env_seeds[i] for i in indices]
    clock = time.perf_counter()
    envs = make_vec(
        config.env, len(indices), options_per_env=options_per_env, **extra, **vector_options, **config.base_options
    )
    try:
        agent = _make_agent(config, envs, agent_seeds)
        setup_seconds = time.perf_counter() - clock
        _start_pool_timing(envs)
        fmu_before = _fmu_time_ns(envs)
        clock = time.perf_counter()
        with progress_bar(len(indices) * config.episodes, config.name, progress) as on_episodes:
            log = train(envs, agent, config.episodes, seed=env_seeds, on_episodes=on_episodes)
        wall_seconds = time.perf_counter() - clock
        pool_timing = _pool_timing(envs)
        fmu_after = _fmu_time_ns(envs)
    finally:
        envs.close()
    return SweepPart(
        indices, log.lengths, log.returns, agent, log.env_steps_stepped, setup_seconds, wall_seconds, log.vector_steps,
        log.agent_seconds,
        getattr(envs, "num_workers", num_workers), pool_timing,
        None if fmu_before is None else fmu_after - fmu_before,
    )


def run_sweep(
    config: SweepConfig,
    *,
    make_vec: MakeVec | None = None,
    num_workers: int | None = None,
    progress: bool = True,
) -> SweepResult:
    """Train one agent per (setting, repeat) of ``config`` side by side and collect the episodes."""
    n_envs = len(config.settings) * config.repeats
    started = datetime.datetime.now(datetime.timezone.utc)
    logger.info(
        "sweep %r: %d envs (%d settings x %d repeats), %d episodes each",
        config.name,
        n_envs,
        len(config.settings),
        config.repeats,
        config.episodes,
    )
    part = run_sweep_part(config, range(n_envs), make_vec=make_vec, num_workers=num_workers, progress=progress)
    return assemble_sweep(config, [part], started, part.wall_seconds, part.num_workers)


def assemble_sweep(
    config: SweepConfig,
    parts: Sequence[SweepPart],
    started: datetime.datetime,
    wall_seconds: float,
    num_workers: int | None,
) -> SweepResult:
    """The `SweepResult` of ``parts`` that together cover every env of ``config`` once.

    ``timing`` has the same fields however the sweep was split: ``setup_seconds`` is the slowest
    part's, ``vector_steps`` and ``agent_seconds`` add up over the parts, ``pool_timing`` is the
    pool's own report for a sweep run in one part (``None`` otherwise).
    """
    n_envs = len(config.settings) * config.repeats
    order = np.concatenate([part.indices for part in parts])
    if sorted(order.tolist()) != list(range(n_envs)):
        raise ArgumentError(f"the parts of sweep {config.name!r} cover envs {sorted(order.tolist())}, not 0-{n_envs - 1}")
    position = np.argsort(order)
    lengths = np.concatenate([part.lengths for part in parts])[position]
    returns = np.concatenate([part.returns for part in parts])[position]
    stepped = np.concatenate([part.stepped for part in parts])[position]
    fmu_ns = None
    if all(part.fmu_ns is not None for part in parts):
        fmu_ns = np.concatenate([part.fmu_ns for part in parts])[position]
    agent = parts[0].agent if len(parts) == 1 else _joined_agent(parts, position)
    shape = (len(config.settings), config.repeats, config.episodes)
    env_steps = int(lengths.sum())
    timing = {
        "started": started.isoformat(timespec="seconds"),
        "setup_seconds": max(part.setup_seconds for part in parts),
        "wall_seconds": wall_seconds,
        "env_steps": env_steps,
        "env_steps_stepped": int(stepped.sum()),
        "vector_steps": sum(part.vector_steps for part in parts),
        "seconds_per_step": wall_seconds / env_steps,
        "agent_seconds": sum(part.agent_seconds for part in parts),
        "num_envs": n_envs,
        "num_workers": num_workers,
        "pool_timing": parts[0].pool_timing if len(parts) == 1 else None,
        "per_setting": _per_setting(config, lengths, stepped, fmu_ns),
    }
    logger.info(
        "sweep %r: %d env steps in %.1f s (%.1f us per env step)",
        config.name,
        env_steps,
        wall_seconds,
        1e6 * wall_seconds / env_steps,
    )
    return SweepResult(config, lengths.reshape(shape), returns.reshape(shape), timing, _machine(), agent=agent)


def _joined_agent(parts: Sequence[SweepPart], position: np.ndarray) -> QLearningAgent:
    """One agent holding the Q-tables and epsilons of every part's agent, in env order."""
    first = parts[0].agent
    agent = QLearningAgent(first.discretizer, first.n_actions, n_envs=len(position), config=first.config, seeds=0)
    agent.q_table = np.concatenate([part.agent.q_table for part in parts])[position]
    agent.epsilon = np.concatenate([part.agent.epsilon for part in parts])[position]
    return agent


class SweepRunner(Protocol):
    """Where a sweep runs: called with a config, returns its result; `run_sweeps` writes it.

    `LocalRunner` runs it in one vector env on this machine;
    `~modelicagym.experiments.ray_runner.RayRunner` as Ray tasks on a cluster.
    """

    def __call__(self, config: SweepConfig, *, make_vec: MakeVec | None, progress: bool) -> SweepResult: ...


@dataclasses.dataclass(frozen=True)
class LocalRunner:
    """Every env of a sweep in one vector env on this machine (`run_sweep`)."""

    num_workers: int | None = None

    def __call__(self, config: SweepConfig, *, make_vec: MakeVec | None, progress: bool) -> SweepResult:
        return run_sweep(config, make_vec=make_vec, num_workers=self.num_workers, progress=progress)


def _plot(results_dir: Path, result: SweepResult) -> None:
    plot_sweep(result, sweep_dir(results_dir, result.config.name) / PLOT_PNG, elsewhere=ELSEWHERE)


def run_sweeps(
    configs: Sequence[SweepConfig],
    results_dir: str | Path,
    *,
    runner: SweepRunner | None = None,
    resume: bool = False,
    make_vec: MakeVec | None = None,
    progress: bool = True,
    make: MakeEnv | None = None,
    bounds_budget: int = DEFAULT_BUDGET,
) -> list[SweepResult | None]:
    """Run ``configs`` one after the other, writing each sweep's results as soon as it completes.

    ``runner`` says where a sweep runs: `LocalRunner` (the default) on this machine,
    `~modelicagym.experiments.ray_runner.RayRunner` as Ray tasks across a cluster, whose results
    come back to this process and are written exactly as a local run writes them, with the same
    episodes.

    With ``resume``, sweeps already complete in ``results_dir`` with the same config are skipped
    (``None`` in the returned list); their plots are drawn again, and the combined table is made
    again from the verified sweeps even when nothing ran, so a table or plot damaged since is
    whole again. An interruption loses only the sweep that was running. The
    longest possible episode of every setting is searched for with single envs from ``make``
    (default ``modelicagym.make``), at most ``bounds_budget`` env steps per setting (0: no search),
    and stored with the results.
    """
    runner = LocalRunner() if runner is None else runner
    results_dir = Path(results_dir)
    outcomes: list[SweepResult | None] = []
    for config in configs:
        if resume and is_complete(results_dir, config):
            logger.info("sweep %r already complete in %s: skipped", config.name, results_dir)
            _plot(results_dir, read_sweep(results_dir, config.name))
            outcomes.append(None)
            continue
        result = runner(config, make_vec=make_vec, progress=progress)
        if bounds_budget > 0:
            result.bounds = sweep_bounds(config, make=make, budget=bounds_budget)
        write_sweep(results_dir, result)
        _plot(results_dir, result)
        write_combined_csv(results_dir)
        outcomes.append(result)
    if all(outcome is None for outcome in outcomes):  # nothing ran: make the table again all the same
        write_combined_csv(results_dir)
    return outcomes
