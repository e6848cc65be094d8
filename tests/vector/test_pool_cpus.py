"""Where the usable cores are fewer than the CPUs of the affinity mask, the pool's stepping
processes keep to that many CPUs: its workers, and the thread that made the pool while it is open;
the process's other threads keep their masks, and closing gives the thread its mask back."""

from __future__ import annotations

import os
import threading

import pytest
from step_paths import cartpole_fns

from modelicagym.cores import CORES_VARIABLE
from modelicagym.vector import PoolVectorEnv

MASK = os.sched_getaffinity(0)

needs_two_cpus = pytest.mark.skipif(len(MASK) < 2, reason="the affinity mask has one CPU: nothing to keep to")


def _worker_masks(pool: PoolVectorEnv) -> list[set[int]]:
    return [os.sched_getaffinity(handle.process.pid) for handle in pool._workers.handles]


@needs_two_cpus
def test_one_usable_core_keeps_the_workers_and_the_calling_thread_on_one_cpu() -> None:
    native, _ = cartpole_fns(4)
    with PoolVectorEnv(native, num_workers=2, cores=1, start_method="fork") as pool:
        assert pool.cpus is not None and len(pool.cpus) == 1 and set(pool.cpus) <= MASK
        assert _worker_masks(pool) == [set(pool.cpus)] * 2
        assert os.sched_getaffinity(0) == set(pool.cpus)
        pool.reset(seed=0)
        pool.step(pool.action_space.sample())
    assert os.sched_getaffinity(0) == MASK


@needs_two_cpus
def test_the_variable_keeps_a_stand_in_on_the_calling_threads_cpu(monkeypatch: pytest.MonkeyPatch) -> None:
    """``MODELICAGYM_CORES=1``: the worker standing in for the calling process (caller_steps=False)
    and the calling thread share the one CPU, the one the thread ran on among them."""
    monkeypatch.setenv(CORES_VARIABLE, "1")
    native, _ = cartpole_fns(4)
    with PoolVectorEnv(native, caller_steps=False, start_method="fork") as pool:
        assert pool.cores == 1 and pool.num_workers == 1
        assert _worker_masks(pool) == [os.sched_getaffinity(0)] == [set(pool.cpus)]
    assert os.sched_getaffinity(0) == MASK


@needs_two_cpus
def test_other_threads_keep_their_masks() -> None:
    release = threading.Event()
    other = threading.Thread(target=release.wait)
    other.start()
    try:
        native, _ = cartpole_fns(2)
        with PoolVectorEnv(native, num_workers=1, cores=1, start_method="fork") as pool:
            assert os.sched_getaffinity(other.native_id) == MASK
            assert os.sched_getaffinity(0) == set(pool.cpus)
    finally:
        release.set()
        other.join()


@needs_two_cpus
def test_a_mask_changed_while_the_pool_is_open_is_left_as_it_is() -> None:
    native, _ = cartpole_fns(2)
    try:
        with PoolVectorEnv(native, num_workers=1, cores=1, start_method="fork") as pool:
            chosen = MASK - set(pool.cpus)
            os.sched_setaffinity(0, chosen)
        assert os.sched_getaffinity(0) == chosen
    finally:
        os.sched_setaffinity(0, MASK)


def test_cores_for_the_whole_mask_leave_every_cpu_to_the_pool() -> None:
    native, _ = cartpole_fns(2)
    with PoolVectorEnv(native, num_workers=1, cores=len(MASK), start_method="fork") as pool:
        assert pool.cpus is None
        assert _worker_masks(pool) == [MASK]
        assert os.sched_getaffinity(0) == MASK


def test_a_pool_without_workers_leaves_the_calling_thread_alone() -> None:
    native, _ = cartpole_fns(2)
    with PoolVectorEnv(native, num_workers=0, cores=1, start_method="fork") as pool:
        pool.reset(seed=0)
        assert pool.cpus is None and os.sched_getaffinity(0) == MASK
