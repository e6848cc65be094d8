"""Faults: workers that segfault, exit, hang or raise; restarts; nothing leaks, ever."""

from __future__ import annotations

import gc
import multiprocessing
import os
import signal
import subprocess
import sys
import textwrap
import threading
import time
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from gymnasium.error import ClosedEnvironmentError
from gymnasium.vector import AutoresetMode
from vector_envs import CountEnv, FaultyEnv
from vector_leaks import Snapshot, descendants

from modelicagym.vector import RESTART_INFO_KEY, EnvError, PoolVectorEnv, WorkerDiedError, WorkerTimeoutError

pytestmark = pytest.mark.timeout(60)

TESTS_DIR = Path(__file__).resolve().parent


@pytest.fixture(scope="module", autouse=True)
def _warm_up() -> None:
    """Start the fork server and the resource tracker once, so they are not counted as leaks."""
    PoolVectorEnv([CountEnv]).close()


@pytest.fixture
def no_leaks() -> Any:
    """Fail the test if it leaves processes, /dev/shm entries or file descriptors behind."""
    before = Snapshot.take()
    yield
    gc.collect()
    before.assert_restored()


def fns_with_fault(fault: str, **kwargs: Any) -> list:
    """Four envs in two workers; env 2 (worker 1, with env 3) fails."""
    return [CountEnv, CountEnv, partial(FaultyEnv, fault, **kwargs), CountEnv]


def step_until_failure(pool: PoolVectorEnv, steps: int = 5) -> None:
    pool.reset(seed=0)
    for _ in range(steps):
        pool.step(np.zeros(pool.num_envs, dtype=np.int64))


@pytest.mark.usefixtures("no_leaks")
def test_segfault_names_the_env_and_the_signal() -> None:
    pool = PoolVectorEnv(fns_with_fault("segfault"), num_workers=2)
    with pytest.raises(WorkerDiedError) as info:
        step_until_failure(pool)
    error = info.value
    assert (error.env_index, error.worker_index, error.exitcode) == (2, 1, -signal.SIGSEGV)
    assert "env 2" in str(error) and "SIGSEGV" in str(error)
    assert pool.closed, "an unrecovered failure stops the pool"
    with pytest.raises(ClosedEnvironmentError):
        pool.reset()
    pool.close()


@pytest.mark.usefixtures("no_leaks")
def test_exit_code_is_reported() -> None:
    pool = PoolVectorEnv(fns_with_fault("exit"), num_workers=2)
    with pytest.raises(WorkerDiedError, match="exited with code 3") as info:
        step_until_failure(pool)
    assert info.value.exitcode == 3


@pytest.mark.usefixtures("no_leaks")
def test_dead_worker_is_noticed_without_a_timeout() -> None:
    pool = PoolVectorEnv(fns_with_fault("sigkill"), num_workers=2, step_timeout=None)
    start = time.monotonic()
    with pytest.raises(WorkerDiedError, match="SIGKILL"):
        step_until_failure(pool)
    assert time.monotonic() - start < 5.0


@pytest.mark.usefixtures("no_leaks")
def test_hang_past_step_timeout() -> None:
    pool = PoolVectorEnv(fns_with_fault("hang"), num_workers=2, step_timeout=0.5)
    start = time.monotonic()
    with pytest.raises(WorkerTimeoutError, match="env 2") as info:
        step_until_failure(pool)
    assert isinstance(info.value, multiprocessing.TimeoutError)
    assert info.value.env_index == 2
    assert time.monotonic() - start < 5.0


@pytest.mark.usefixtures("no_leaks")
def test_exception_in_step_carries_the_original_traceback() -> None:
    pool = PoolVectorEnv(fns_with_fault("raise"), num_workers=2)
    with pytest.raises(EnvError, match="env 2 .* ValueError in step") as info:
        step_until_failure(pool)
    error = info.value
    assert isinstance(error.original, ValueError) and error.env_index == 2
    assert "_strike" in error.remote_traceback and "_strike" in str(error.__cause__)


@pytest.mark.usefixtures("no_leaks")
def test_exception_in_reset() -> None:
    pool = PoolVectorEnv(fns_with_fault("raise", when="reset"), num_workers=2)
    with pytest.raises(EnvError, match="env 2 .* in reset"):
        pool.reset(seed=0)


@pytest.mark.usefixtures("no_leaks")
@pytest.mark.parametrize("fault, error", [("raise", EnvError), ("segfault", WorkerDiedError)])
def test_failure_while_creating_envs(fault: str, error: type) -> None:
    with pytest.raises(error, match="creation"):
        PoolVectorEnv(fns_with_fault(fault, when="init"), num_workers=2)


@pytest.mark.usefixtures("no_leaks")
def test_creation_timeout() -> None:
    with pytest.raises(WorkerTimeoutError):
        PoolVectorEnv(fns_with_fault("hang", when="init"), num_workers=2, startup_timeout=1.0)


@pytest.mark.usefixtures("no_leaks")
@pytest.mark.parametrize("fault", ["segfault", "hang", "raise", "exit"])
@pytest.mark.parametrize("mode", list(AutoresetMode))
def test_restart_dead_workers(tmp_path: Path, fault: str, mode: AutoresetMode) -> None:
    fns = fns_with_fault(fault, at_step=3, marker=str(tmp_path / "struck"))
    with PoolVectorEnv(
        fns, num_workers=2, autoreset_mode=mode, restart_dead_workers=True, step_timeout=0.5
    ) as pool:
        obs, _ = pool.reset(seed=0)
        actions = np.zeros(4, dtype=np.int64)
        for _ in range(2):
            obs, *_ = pool.step(actions)
        new_obs, rewards, terminations, truncations, infos = pool.step(actions)
        np.testing.assert_array_equal(truncations[2:], [True, True])
        np.testing.assert_array_equal(terminations[2:], [False, False])
        np.testing.assert_array_equal(rewards[2:], [0.0, 0.0])
        np.testing.assert_array_equal(infos[f"_{RESTART_INFO_KEY}"], [False, False, True, True])
        assert "env 2" in infos[RESTART_INFO_KEY][2]
        assert rewards[0] > 0 and not truncations[0]
        if mode is AutoresetMode.SAME_STEP:
            np.testing.assert_array_equal(infos["final_obs"][2], obs[2])
            assert infos["final_info"][RESTART_INFO_KEY][2] == infos[RESTART_INFO_KEY][2]
            assert "length" in infos, "the reset info of the recreated envs"
        else:
            np.testing.assert_array_equal(new_obs[2:], obs[2:])
        if mode is AutoresetMode.DISABLED:
            pool.reset(options={"reset_mask": truncations | terminations})
        _, rewards, *_ = pool.step(actions)
        if mode is AutoresetMode.NEXT_STEP:
            np.testing.assert_array_equal(rewards[2:], [0.0, 0.0])
        for _ in range(20):
            _, _, terminations, truncations, _ = pool.step(actions)
            if mode is AutoresetMode.DISABLED and (terminations | truncations).any():
                pool.reset(options={"reset_mask": terminations | truncations})
        assert pool.get_attr("max_len") == (20,) * 4


@pytest.mark.usefixtures("no_leaks")
def test_restart_during_reset(tmp_path: Path) -> None:
    fns = fns_with_fault("segfault", when="reset", marker=str(tmp_path / "struck"))
    with PoolVectorEnv(fns, num_workers=2, restart_dead_workers=True) as pool:
        _, infos = pool.reset(seed=3)
        np.testing.assert_array_equal(infos[f"_{RESTART_INFO_KEY}"], [False, False, True, True])
        assert pool.np_random_seed == (3, 4, 5, 6), "the reset was redone with the same seeds"
        pool.step(np.zeros(4, dtype=np.int64))


@pytest.mark.usefixtures("no_leaks")
def test_call_raising_keeps_the_pool_usable_and_a_crash_in_call_restarts(tmp_path: Path) -> None:
    fns = fns_with_fault("segfault", when="never", marker=str(tmp_path / "struck"))
    with PoolVectorEnv(fns, num_workers=2, restart_dead_workers=True) as pool:
        with pytest.raises(KeyError):
            pool.call("fail")
        with pytest.raises(WorkerDiedError, match="during call of env 2"):
            pool.call("_strike")
        assert pool.call("double", 2) == (4,) * 4


@pytest.mark.usefixtures("no_leaks")
@pytest.mark.parametrize("terminate", [False, True])
def test_close_with_a_hung_call_pending_gives_up(terminate: bool) -> None:
    pool = PoolVectorEnv(fns_with_fault("hang"), num_workers=2, step_timeout=0.5)
    pool.reset(seed=0)
    pool.step(np.zeros(4, dtype=np.int64))
    pool.step_async(np.zeros(4, dtype=np.int64))
    start = time.monotonic()
    pool.close(terminate=terminate)
    assert pool.closed and time.monotonic() - start < 3.0


def test_close_releases_everything() -> None:
    before = Snapshot.take()
    pool = PoolVectorEnv([CountEnv] * 3, num_workers=3)
    pool.reset(seed=0)
    assert len(descendants() - before.processes) >= 3
    pool.close()
    before.assert_restored()


@pytest.mark.usefixtures("no_leaks")
def test_garbage_collected_pool_releases_everything() -> None:
    pool = PoolVectorEnv([CountEnv] * 2, num_workers=2)
    pool.reset(seed=0)
    del pool


@pytest.mark.usefixtures("no_leaks")
def test_keyboard_interrupt_while_waiting_stops_the_pool() -> None:
    pool = PoolVectorEnv([partial(CountEnv, cost=3.0)] * 2, num_workers=2)
    pool.reset(seed=0)
    timer = threading.Timer(0.3, os.kill, (os.getpid(), signal.SIGINT))
    timer.start()
    start = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        pool.step(np.zeros(2, dtype=np.int64))
    timer.join()
    assert time.monotonic() - start < 2.5, "interrupted at once, not after the step"
    assert pool.closed


def test_workers_ignore_sigint() -> None:
    with PoolVectorEnv([CountEnv] * 2, num_workers=2) as pool:
        pool.reset(seed=0)
        for pid in pool.worker_pids:
            os.kill(pid, signal.SIGINT)
        time.sleep(0.2)
        pool.step(np.zeros(2, dtype=np.int64))


@pytest.mark.parametrize("start_method", ["forkserver", "fork"])
def test_workers_exit_when_the_parent_is_killed(start_method: str) -> None:
    script = textwrap.dedent(
        f"""
        import sys, time
        sys.path.insert(0, {str(TESTS_DIR)!r})
        from vector_envs import CountEnv
        from modelicagym.vector import PoolVectorEnv
        if __name__ == "__main__":
            pool = PoolVectorEnv([CountEnv] * 2, num_workers=2, start_method={start_method!r})
            pool.reset(seed=0)
            print("ready", flush=True)
            time.sleep(60)
        """
    )
    parent = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    try:
        assert parent.stdout.readline().strip() == "ready"
        orphans = descendants(parent.pid)
        assert len(orphans) >= 2
    finally:
        parent.kill()
        parent.wait()
    deadline = time.monotonic() + 10.0
    while orphans & descendants(1) and time.monotonic() < deadline:
        time.sleep(0.05)
    alive = {pid for pid in orphans if os.path.exists(f"/proc/{pid}") and _state(pid) != "Z"}
    assert not alive, f"orphaned workers still running: {alive}"


def _state(pid: int) -> str:
    try:
        with open(f"/proc/{pid}/stat") as f:
            stat = f.read()
    except OSError:
        return "Z"
    return stat[stat.rindex(")") + 2]
