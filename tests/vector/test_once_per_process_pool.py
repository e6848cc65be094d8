"""A pool of FMUs allowed one instance per process: laid out like any FMU (several envs to a
worker, each further instance on a private copy of the binary), with the results of one env per
worker; ``instances_per_process="one"`` keeps one env per worker; workers leave no copies behind."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from once_copies import config, copies_in, copy_folders, observed

import modelicagym

N = 4
STEPS = 30


def rollout(envs: Any, seed: int = 0) -> list[list[str]]:
    """``envs`` reset and stepped ``STEPS`` times with seeded random actions: every observation,
    reward and ending, exactly (an episode of the probe lasts past them, moody's too)."""
    rng = np.random.default_rng(seed)
    rows = [observed(envs.reset(seed=seed)[0])]
    for _ in range(STEPS):
        observation, reward, terminated, truncated, _ = envs.step(rng.uniform(-1.0, 1.0, (N, 1)))
        rows.append(observed(observation) + observed(reward) + [str(terminated.tolist()), str(truncated.tolist())])
    return rows


@pytest.mark.parametrize("name", ["probe_once", "moody_once"])
def test_a_pool_of_once_per_process_envs_shares_workers_with_the_results_of_one_env_per_worker(
        name: str, fmi_version: int, no_leaks: None) -> None:
    env_config = config(name, fmi_version)
    one = modelicagym.make_vec({**env_config, "instances_per_process": "one"}, n=N)
    try:
        assert one.layout.num_workers == N and not one.layout.adaptive
        assert "an FMU that may be instantiated only once per process" in one.layout.reason
        expected = rollout(one)
    finally:
        one.close()
    assert len(expected) == STEPS + 1

    packed = modelicagym.make_vec(env_config, n=N, num_workers=1)  # every env in one worker
    try:
        [pid] = packed.worker_pids
        [folder] = copy_folders(pid)
        assert len(copies_in(folder)) == N - 1  # the FMU's binary and three copies
        assert rollout(packed) == expected
    finally:
        packed.close()
    assert copy_folders(pid) == []  # the worker removed its copies as it ended

    default = modelicagym.make_vec(env_config, n=N)  # the default layout: a stand-in worker, adaptive beside others
    try:
        pids = default.worker_pids
        layout = default.layout
        assert layout.stand_in and layout.num_workers < N and layout.adaptive == (layout.num_workers > 0), layout
        assert rollout(default) == expected
    finally:
        default.close()
    assert all(copy_folders(pid) == [] for pid in pids)


@pytest.mark.parametrize("name", ["probe_once", "moody_once"])
def test_a_sync_vector_env_holds_several_once_per_process_envs(name: str, fmi_version: int) -> None:
    """Gymnasium's ``SyncVectorEnv`` (every env in this process) gives the pool's results. (Not
    under ``no_leaks``: a process that made copies keeps one descriptor open, its folder's lock.)"""
    env_config = config(name, fmi_version)
    sync = modelicagym.make_vec(env_config, n=N, backend="sync")
    try:
        got = rollout(sync)
    finally:
        sync.close()
    pool = modelicagym.make_vec(env_config, n=N)
    try:
        assert got == rollout(pool)
    finally:
        pool.close()
