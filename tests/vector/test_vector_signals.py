"""The pool's wake-up signals: futex words in shared memory (native), semaphores as the fallback."""

from __future__ import annotations

import ctypes
import mmap
import multiprocessing
import os
import time

import pytest
from gymnasium.vector import AutoresetMode, SyncVectorEnv
from vector_envs import count_fns
from vector_rollouts import assert_same, rollout

import modelicagym.vector.pool
from modelicagym.vector import PoolVectorEnv
from modelicagym.vector.wire.sync import FutexSignal, pool_native_library

pytestmark = pytest.mark.timeout(60)

library = pool_native_library()
needs_futex = pytest.mark.skipif(library is None, reason="no native library or no futexes here")


def _echo(fd: int, rounds: int, spin_time: float) -> None:
    """Child process: wait for ``go`` and answer ``done``, ``rounds`` times."""
    memory = mmap.mmap(fd, mmap.PAGESIZE)
    address = _address(memoryview(memory))
    go, done = FutexSignal(library, address), FutexSignal(library, address + 64)
    for _ in range(rounds):
        assert go.wait(spin_time, 10.0)
        done.post()


def _address(view: memoryview) -> int:
    return ctypes.addressof(ctypes.c_char.from_buffer(view))


@needs_futex
@pytest.mark.parametrize("spin_time", [0.0, 100e-6])
def test_futex_signals_cross_processes_without_losing_a_post(spin_time: float) -> None:
    fd = os.memfd_create("signal-test")
    os.ftruncate(fd, mmap.PAGESIZE)
    memory = mmap.mmap(fd, mmap.PAGESIZE)
    address = _address(memoryview(memory))
    go, done = FutexSignal(library, address), FutexSignal(library, address + 64)
    child = multiprocessing.get_context("fork").Process(target=_echo, args=(fd, 500, spin_time))
    child.start()
    try:
        for _ in range(500):
            go.post()
            assert done.wait(spin_time, 10.0)
    finally:
        child.join(10)
        os.close(fd)
    assert child.exitcode == 0


@needs_futex
def test_a_futex_wait_times_out_and_a_post_is_kept_for_the_next_wait() -> None:
    memory = mmap.mmap(-1, mmap.PAGESIZE)
    signal = FutexSignal(library, _address(memoryview(memory)))
    started = time.monotonic()
    assert not signal.wait(1e-4, 0.02)
    assert time.monotonic() - started >= 0.02
    signal.post()
    assert signal.wait(0.0, 0.0)
    assert not signal.wait(0.0, 0.0)


@pytest.mark.parametrize("mode", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP])
def test_semaphores_when_there_is_no_native_library(monkeypatch: pytest.MonkeyPatch, mode: AutoresetMode) -> None:
    monkeypatch.setattr(modelicagym.vector.pool, "pool_native_library", lambda: None)
    fns = count_fns(4)
    sync = SyncVectorEnv(fns, autoreset_mode=mode)
    with PoolVectorEnv(fns, num_workers=2, autoreset_mode=mode) as pool:
        assert pool._workers.handles[0].go.__class__.__name__ == "SemaphoreSignal"
        expected, actual = rollout(sync, 100), rollout(pool, 100)
    sync.close()
    assert_same(expected, actual)
