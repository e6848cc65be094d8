"""The step's barrier (``native/csrc/slice.h``, ``mg_barrier``): the calling process wakes the
stepping workers and learns that all are done in one call each, in real processes over real
shared memory; a worker that dies mid-step still ends the wait; a worker not stepping is neither
woken nor waited for; pools with several workers step as SyncVectorEnv does."""

from __future__ import annotations

import ctypes
import mmap
import multiprocessing
import os
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from functools import partial

import numpy as np
import pytest
from gymnasium.vector import SyncVectorEnv
from step_paths import cartpole_fns, probe_env
from vector_envs import count_fns
from vector_rollouts import assert_native_equals_python, assert_same, rollout

from modelicagym.native.abi import COLLECT_DONE, COLLECT_SLOW, MgBarrier, MgWaiter
from modelicagym.vector import PoolVectorEnv, WorkerDiedError
from modelicagym.vector.dispatch.native_collector import NativeCollector
from modelicagym.vector.dispatch.recovery import RESTART_INFO_KEY
from modelicagym.vector.wire.sync import AnswerSignal, FutexSignal, GoSignal, pool_native_library

pytestmark = [pytest.mark.timeout(180),
              pytest.mark.skipif(pool_native_library() is None, reason="no native library or no futexes here")]

#: the page the tests share with their workers: the barrier, then per worker a cache line for each
#: of its go and done signals, its command, its reply and how many steps it ran
_SIGNALS, _COMMANDS, _REPLIES, _COUNTS = 256, 2048, 2304, 2560
#: command words: step (count one), stop (answer and exit), die (exit without answering)
_STEP, _STOP, _DIE = 1, 2, 3
MAX_WORKERS = 6


class Page:
    """The shared page of a barrier test, mapped in this process."""

    def __init__(self, fd: int) -> None:
        self.memory = mmap.mmap(fd, mmap.PAGESIZE)
        self.address = ctypes.addressof(ctypes.c_char.from_buffer(self.memory))
        self.commands = np.frombuffer(self.memory, np.int32, MAX_WORKERS, _COMMANDS)
        self.replies = np.frombuffer(self.memory, np.int32, MAX_WORKERS, _REPLIES)
        self.counts = np.frombuffer(self.memory, np.int64, MAX_WORKERS, _COUNTS)

    def go(self, k: int) -> GoSignal:
        return GoSignal(pool_native_library(), self.address + _SIGNALS + 128 * k, self.address, k)

    def done_address(self, k: int) -> int:
        return self.address + _SIGNALS + 128 * k + 64


def _worker(fd: int, k: int, spin_time: float) -> None:
    """Child process: wait for ``go`` (asleep on the bell when ``spin_time`` is 0), run the command, answer."""
    page = Page(fd)
    go, done = page.go(k), AnswerSignal(pool_native_library(), page.done_address(k), page.address)
    while True:
        assert go.wait(spin_time, 30.0)
        command = int(page.commands[k])
        if command == _DIE:
            os._exit(9)
        if command == _STEP:
            page.counts[k] += 1
        done.post()
        if command == _STOP:
            return


@contextmanager
def barrier_workers(n: int, spin_time: float, timeout: float = 30.0) -> Iterator[tuple[Page, NativeCollector, list]]:
    """``n`` worker processes on a fresh page, the calling process's collector over them; the
    workers are stopped (each through its own ``go``, not the barrier) and joined on the way out."""
    assert ctypes.sizeof(MgBarrier) <= _SIGNALS
    fd = os.memfd_create("barrier-test")
    os.ftruncate(fd, mmap.PAGESIZE)
    page = Page(fd)
    stepping = np.ones(n, dtype=np.uint8)
    collector = NativeCollector(
        [page.go(k).address for k in range(n)], [page.done_address(k) for k in range(n)], page.address,
        page.replies[:n], stepping, np.array([round(spin_time * 1e9)], dtype=np.int64), timeout, MgWaiter(),
    )
    context = multiprocessing.get_context("fork")
    children = [context.Process(target=_worker, args=(fd, k, spin_time), daemon=True) for k in range(n)]
    for child in children:
        child.start()
    try:
        yield page, collector, children
    finally:
        for k, child in enumerate(children):
            if child.is_alive():
                page.commands[k] = _STOP
                page.go(k).post()
                assert FutexSignal(pool_native_library(), page.done_address(k)).wait(0.0, 30.0)
            child.join(30)
        os.close(fd)


def _masks(n: int) -> list[np.ndarray]:
    """Every worker; every worker but one; one worker alone."""
    masks = [np.ones(n, dtype=np.uint8)]
    for k in range(n if n > 1 else 0):
        but, alone = np.ones(n, dtype=np.uint8), np.zeros(n, dtype=np.uint8)
        but[k], alone[k] = 0, 1
        masks += [but, alone]
    return masks


@pytest.mark.parametrize("spin_time", [0.0, 100e-6])
@pytest.mark.parametrize("n", [1, 2, 3, 5])
def test_the_barrier_wakes_exactly_the_stepping_workers_and_waits_for_all_of_them(n: int, spin_time: float) -> None:
    """After each collection the count of every stepping worker went up by one and that of every
    other worker did not move: the barrier waited for all, and woke nobody else. With no spin the
    workers and the caller sleep on every batch (the bell's bits, the one wake-up of the parent)."""
    masks = _masks(n)
    with barrier_workers(n, spin_time) as (page, collector, children):
        page.commands[:n] = _STEP
        expected = np.zeros(n, dtype=np.int64)
        for batch in range(300):
            collector.stepping[:] = masks[batch % len(masks)]
            collector.post()
            assert collector.collect() == COLLECT_DONE, f"batch {batch}"
            expected += collector.stepping
            np.testing.assert_array_equal(page.counts[:n], expected, err_msg=f"batch {batch}")
    assert [child.exitcode for child in children] == [0] * n


def test_a_worker_that_dies_mid_step_ends_the_wait_and_the_others_stay_done() -> None:
    """Worker 1 exits without answering: the collection gives up after its timeout (the pool's slow
    path then finds the death), and the answers it took from the others are there again."""
    with barrier_workers(3, 0.0, timeout=0.2) as (page, collector, children):
        page.commands[:3] = _STEP
        collector.post()
        assert collector.collect() == COLLECT_DONE
        page.commands[1] = _DIE
        collector.post()
        assert collector.collect() == COLLECT_SLOW
        children[1].join(10)
        assert children[1].exitcode == 9
        for k in (0, 2):
            done = FutexSignal(pool_native_library(), page.done_address(k))
            assert done.wait(0.0, 1.0), f"worker {k}'s done was lost"
        # the next batch, without the dead worker, is counted afresh
        page.commands[1] = _STEP
        collector.stepping[1] = 0
        collector.post()
        assert collector.collect() == COLLECT_DONE
        np.testing.assert_array_equal(page.counts[:3], [3, 1, 3])


def test_a_worker_with_a_reply_sends_the_step_to_the_slow_path() -> None:
    with barrier_workers(2, 0.0) as (page, collector, _):
        page.commands[:2] = _STEP
        page.replies[1] = 1
        collector.post()
        assert collector.collect() == COLLECT_SLOW
        page.replies[1] = 0
        for k in (0, 1):  # both answered, and their dones are kept for the slow path
            assert FutexSignal(pool_native_library(), page.done_address(k)).wait(0.0, 1.0)


@pytest.mark.parametrize("num_workers", [1, 3, 5])
def test_pools_of_several_workers_step_as_sync_does(num_workers: int) -> None:
    """Python envs (the workers wait and answer from Python) and native ones (in C)."""
    fns = count_fns(7)
    sync = SyncVectorEnv(fns)
    with PoolVectorEnv(fns, num_workers=num_workers) as pool:
        expected, actual = rollout(sync, 120), rollout(pool, 120)
    sync.close()
    assert_same(expected, actual)
    native, python = cartpole_fns(num_workers + 1)
    assert_native_equals_python(native, python, steps=120, num_workers=num_workers)


@pytest.mark.usefixtures("no_leaks")
def test_a_crash_among_four_workers_is_named_and_the_barrier_goes_on_after_the_restart(family_fmu: Callable) -> None:
    fns = [partial(probe_env, family_fmu("probe", 2), parameters={"fault": 3, "fault_after": 4} if i == 5 else {})
           for i in range(8)]
    with PoolVectorEnv(fns, num_workers=4, restart_dead_workers=True) as pool:
        pool.reset(seed=0)
        restarted = [pool.step(np.ones((8, 1)))[4].get(RESTART_INFO_KEY) for _ in range(5)]
        assert restarted[:4] == [None] * 4
        assert [reason is not None for reason in restarted[4]] == [False] * 4 + [True, True] + [False] * 2
        assert "env 5" in restarted[4][5]
        for _ in range(3):  # the fresh env 5 crashes again after 4 steps
            observations, _, _, _, infos = pool.step(np.ones((8, 1)))
            assert RESTART_INFO_KEY not in infos
        assert observations.shape == (8, 2)
    with pytest.raises(WorkerDiedError, match=r"env 5\b"), PoolVectorEnv(fns, num_workers=4) as pool:
        pool.reset(seed=0)
        for _ in range(5):
            pool.step(np.ones((8, 1)))
