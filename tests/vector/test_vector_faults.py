"""Faults: workers that segfault, exit, hang or raise; restarts; nothing leaks, ever."""

from __future__ import annotations

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
from typing import Any, Iterator

import numpy as np
import pytest
from gymnasium.error import ClosedEnvironmentError
from gymnasium.vector import AutoresetMode
from vector_envs import CountEnv, FaultyEnv, MalformedEnv
from vector_leaks import Snapshot, descendants, process_state

from modelicagym.errors import ConfigError, ConfigTypeError
from modelicagym.vector import (
    RESTART_INFO_KEY,
    ConcurrentUseError,
    EnvError,
    PoolClosedError,
    PoolVectorEnv,
    WorkerDiedError,
    WorkerTimeoutError,
)
from modelicagym.vector.wire.sync import pool_native_library

pytestmark = [pytest.mark.timeout(60), pytest.mark.usefixtures("pool_services")]

TESTS_DIR = Path(__file__).resolve().parents[1]


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
    """With no step timeout, only noticing the death can end the wait (or the test times out)."""
    pool = PoolVectorEnv(fns_with_fault("sigkill"), num_workers=2, step_timeout=None)
    with pytest.raises(WorkerDiedError, match="SIGKILL"):
        step_until_failure(pool)


@pytest.mark.usefixtures("no_leaks")
def test_hang_past_step_timeout() -> None:
    """The env hangs for an hour: only the step timeout can end the wait (or the test times out)."""
    pool = PoolVectorEnv(fns_with_fault("hang"), num_workers=2, step_timeout=0.5)
    with pytest.raises(WorkerTimeoutError, match="env 2") as info:
        step_until_failure(pool)
    assert isinstance(info.value, multiprocessing.TimeoutError)
    assert info.value.env_index == 2


@pytest.mark.usefixtures("no_leaks")
def test_exception_in_step_carries_the_original_traceback() -> None:
    pool = PoolVectorEnv(fns_with_fault("raise"), num_workers=2)
    with pytest.raises(EnvError, match=r"env 2 \(worker 1\) raised ValueError in step") as info:
        step_until_failure(pool)
    error = info.value
    assert isinstance(error.original, ValueError) and error.env_index == 2
    assert "_strike" in error.remote_traceback and "_strike" in str(error.__cause__)


class MovableCountEnv(CountEnv):
    """A :class:`CountEnv` whose reset is deterministic: it can move between processes, so where
    the calling process may not step it, a worker stands in for it."""

    reset_is_deterministic = True


class MovableFaultyEnv(FaultyEnv, MovableCountEnv):
    """A :class:`FaultyEnv` that can move."""


@pytest.mark.skipif(pool_native_library() is None, reason="a worker stands in only for a layout that adapts")
@pytest.mark.usefixtures("no_leaks")
def test_an_exception_in_the_stand_in_worker_names_it_as_standing_in_for_the_calling_process() -> None:
    """Env 3 is in the calling process's slice; its envs are not safe there, so worker 1 stands in
    for it and steps env 3 when it raises."""
    fns = [MovableCountEnv] * 3 + [partial(MovableFaultyEnv, "raise")]
    pool = PoolVectorEnv(fns, cores=2)
    assert pool.layout.stand_in and pool.layout.envs_in_stand_in == 2, pool.layout
    with pytest.raises(EnvError) as info:
        step_until_failure(pool)
    assert str(info.value).startswith(
        "env 3 (worker 1, standing in for the calling process) raised ValueError in step: raise at step 2"), info.value
    assert info.value.env_index == 3 and info.value.worker_index == 1


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
    """The env hangs for an hour: a close that waited for it would time the test out."""
    pool = PoolVectorEnv(fns_with_fault("hang"), num_workers=2, step_timeout=0.5)
    pool.reset(seed=0)
    pool.step(np.zeros(4, dtype=np.int64))
    pool.step_async(np.zeros(4, dtype=np.int64))
    pool.close(terminate=terminate)
    assert pool.closed


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


@pytest.fixture
def ctrl_c_raises() -> Iterator[None]:
    """Python's own Ctrl-C handler, as in a terminal (a shell starts background jobs with SIGINT ignored)."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


@pytest.mark.usefixtures("no_leaks", "ctrl_c_raises")
def test_keyboard_interrupt_while_waiting_stops_the_pool(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Ctrl-C comes once the calling process blocks waiting for a worker inside a step that would
    last an hour: the step cannot have finished, so the interrupt was taken while waiting."""
    marker = tmp_path / "struck"
    pool = PoolVectorEnv([partial(FaultyEnv, "hang", at_step=1, marker=str(marker))] * 2, num_workers=2)
    try:
        pool.reset(seed=0)
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler, "the pool changed the SIGINT handler"
        assert signal.SIGINT not in signal.pthread_sigmask(signal.SIG_BLOCK, [])
        ctrl_c = CtrlC(monkeypatch)
        interrupter = threading.Thread(target=ctrl_c.press_when_waiting, args=(marker,), daemon=True)
        interrupter.start()
        try:
            with pytest.raises(KeyboardInterrupt):
                pool.step(np.zeros(2, dtype=np.int64))
        finally:
            ctrl_c.done.set()
            interrupter.join(10)
        assert ctrl_c.problem is None, ctrl_c.problem
        assert pool.closed
    finally:
        pool.close()


class CtrlC:
    """A Ctrl-C (SIGINT to the main thread) pressed once, when the main thread blocks in the pool's
    wait; pressed again only if CPython dropped it (a KeyboardInterrupt raised inside a finalizer
    run by the garbage collector is printed as unraisable and lost). So no second one can strike
    while the first is being handled, however slowly a loaded machine stops the pool."""

    #: seconds the main thread may take to block in the pool's wait
    PATIENCE = 30.0

    def __init__(self, monkeypatch: pytest.MonkeyPatch) -> None:
        self.done, self.dropped = threading.Event(), threading.Event()
        self.problem: str | None = None
        self._main = threading.main_thread().ident
        hook = sys.unraisablehook

        def unraisable(info: Any) -> None:
            if info.exc_type is not None and issubclass(info.exc_type, KeyboardInterrupt):
                self.dropped.set()
            else:
                hook(info)

        monkeypatch.setattr(sys, "unraisablehook", unraisable)

    def press_when_waiting(self, marker: Path) -> None:
        """Once ``marker`` exists: press when the main thread waits, again after each dropped press,
        until ``done``."""
        while self._wait_until_blocked(marker):
            self.dropped.clear()
            signal.pthread_kill(self._main, signal.SIGINT)
            while not (self.done.is_set() or self.dropped.is_set()):
                time.sleep(0.001)

    def _wait_until_blocked(self, marker: Path) -> bool:
        """Wait until the main thread blocks in the pool's wait; ``False`` if ``done`` came first."""
        deadline = time.monotonic() + self.PATIENCE
        while not (marker.exists() and self._blocked_in_wait()):
            if self.done.is_set():
                return False
            if time.monotonic() > deadline:  # press anyway, so that the test ends; it fails on `problem`
                self.problem = f"the main thread did not block in the pool's wait within {self.PATIENCE} s"
                return True
            time.sleep(0.001)
        return not self.done.is_set()

    def _blocked_in_wait(self) -> bool:
        """Whether the main thread's innermost frame is a ``wait`` of the pool's (a signal's)."""
        frame = sys._current_frames().get(self._main)
        return (frame is not None and frame.f_code.co_name == "wait"
                and frame.f_globals.get("__name__", "").startswith("modelicagym.vector"))


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
    assert_nothing_survives_killing([sys.executable, "-c", script], "ready")


def assert_nothing_survives_killing(command: list[str], ready: str) -> None:
    """Run ``command`` until it prints ``ready``, SIGKILL it, and check that every process it had
    started (workers, fork server, resource tracker) is gone within 10 s."""
    parent = subprocess.Popen(command, stdout=subprocess.PIPE, text=True)
    try:
        assert parent.stdout.readline().strip() == ready
        orphans = descendants(parent.pid)
        assert len(orphans) >= 2
    finally:
        parent.kill()
        parent.wait()
    deadline = time.monotonic() + 10.0
    while {pid for pid in orphans if process_state(pid) not in (None, "Z")} and time.monotonic() < deadline:
        time.sleep(0.05)
    alive = {pid: process_state(pid) for pid in orphans if process_state(pid) not in (None, "Z")}
    assert not alive, f"still running after their parent was killed: {alive}"


@pytest.mark.parametrize("fault", ["hang_in_c", "hang"])
@pytest.mark.parametrize("start_method", ["forkserver", "fork"])
def test_no_process_outlives_a_killed_parent_whose_worker_is_stuck(start_method: str, fault: str, tmp_path: Path) -> None:
    """The parent is SIGKILLed while a worker is stuck inside a step (a C call that never returns,
    or a Python one): the workers, the fork server and the resource tracker all go."""
    script = textwrap.dedent(
        f"""
        import functools, os, sys, time
        sys.path.insert(0, {str(TESTS_DIR)!r})
        from vector_envs import CountEnv, FaultyEnv
        from modelicagym.vector import PoolVectorEnv
        if __name__ == "__main__":
            marker = sys.argv[1]
            fns = [CountEnv, functools.partial(FaultyEnv, {fault!r}, at_step=1, marker=marker)]
            pool = PoolVectorEnv(fns, num_workers=2, start_method={start_method!r})
            pool.reset(seed=0)
            pool.step_async([0, 0])
            while not os.path.exists(marker):
                time.sleep(0.01)
            print("stuck", flush=True)
            time.sleep(60)
        """
    )
    assert_nothing_survives_killing([sys.executable, "-c", script, str(tmp_path / "struck")], "stuck")


@pytest.mark.parametrize("caller_steps", [True, False])
def test_a_ctrl_c_at_any_moment_leaves_the_pool_consistent(caller_steps: bool) -> None:
    """Interrupts land at random points of step/step_async/step_wait: afterwards the pool is
    either stopped or ready for the next call, never stuck in a pending state."""
    rng = np.random.default_rng(0)

    def interrupt(signum: int, frame: Any) -> None:
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGALRM, interrupt)
    outcomes = {"stopped": 0, "usable": 0}
    try:
        pool = None
        for _ in range(20):
            if pool is None or pool.closed:
                pool = PoolVectorEnv([CountEnv] * 3, caller_steps=caller_steps, num_workers=None if caller_steps else 2)
                pool.reset(seed=0)
            interrupted = False
            while not interrupted:
                try:
                    signal.setitimer(signal.ITIMER_REAL, float(rng.uniform(1e-5, 2e-3)))
                    deadline = time.monotonic() + 1.0
                    while time.monotonic() < deadline:
                        pool.step(np.zeros(3, dtype=np.int64))
                    # CPython drops a KeyboardInterrupt raised inside a finalizer: the alarm was lost, arm again
                except KeyboardInterrupt:
                    interrupted = True
                signal.setitimer(signal.ITIMER_REAL, 0)
            if pool.closed:
                outcomes["stopped"] += 1
            else:
                pool.step(np.zeros(3, dtype=np.int64))  # no PendingCallError: nothing half-done
                outcomes["usable"] += 1
        pool.close()
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
    assert sum(outcomes.values()) == 20


@pytest.mark.usefixtures("no_leaks")
@pytest.mark.parametrize("bad, cause", [("observation", "broadcast"), ("reward", "a lot")])
@pytest.mark.parametrize("caller_steps", [True, False])
def test_a_malformed_step_result_is_reported_with_its_env_and_cause(bad: str, cause: str, caller_steps: bool) -> None:
    fns = [CountEnv, CountEnv, partial(MalformedEnv, bad)]
    pool = PoolVectorEnv(fns, caller_steps=caller_steps, num_workers=None if caller_steps else 2)
    pool.reset(seed=0)
    with pytest.raises(EnvError, match=r"env 2\b") as info:
        pool.step(np.zeros(3, dtype=np.int64))
    assert cause in str(info.value.__cause__)
    pool.close()


@pytest.mark.parametrize(
    "options, error, match",
    [
        ({"step_timeout": float("nan")}, ConfigError, "step_timeout must be a finite number of seconds > 0"),
        ({"step_timeout": -1.0}, ConfigError, "step_timeout must be a finite number of seconds > 0"),
        ({"step_timeout": "1"}, ConfigTypeError, "step_timeout must be a number of seconds or None, got '1'"),
        ({"num_workers": -1}, ConfigError, "num_workers must be >= 0"),
        ({"num_workers": 0, "step_timeout": 1.0}, ConfigError, "num_workers=0 .* and step_timeout contradict"),
        ({"num_workers": 0, "restart_dead_workers": True}, ConfigError, "and restart_dead_workers=True contradict"),
        ({"num_workers": 0, "caller_steps": False}, ConfigError, "and caller_steps=False contradict"),
        ({"num_workers": 0, "batch_size": 1}, ConfigError, "batch_size .* needs every env in a worker"),
        ({"num_workers": 1.5}, ConfigTypeError, "num_workers must be an integer"),
        ({"spin_time": float("inf")}, ConfigError, "spin_time must be a finite number"),
        ({"start_method": "threads"}, ConfigError, "start_method must be one of"),
        ({"autoreset_mode": "later"}, ConfigError, "autoreset_mode must be one of"),
        ({"restart_dead_workers": "yes"}, ConfigTypeError, "restart_dead_workers must be True or False"),
    ],
)
@pytest.mark.usefixtures("no_leaks")
def test_the_pools_own_options_are_checked_before_anything_starts(options: dict, error: type, match: str) -> None:
    with pytest.raises(error, match=match):
        PoolVectorEnv([CountEnv] * 2, **options)


@pytest.mark.usefixtures("no_leaks")
def test_an_env_fn_that_cannot_be_pickled_is_named_with_the_reason() -> None:
    lock = threading.Lock()
    with pytest.raises(ConfigError, match=r"env fn 1 .* cannot be sent to a worker process: cloudpickle says TypeError"):
        PoolVectorEnv([CountEnv, lambda: (lock, CountEnv())[1]], num_workers=2)


@pytest.mark.usefixtures("no_leaks")
def test_a_bad_seed_is_refused_and_the_pool_stays_usable() -> None:
    with PoolVectorEnv([CountEnv] * 2, num_workers=2) as pool:
        for seed in (1.5, "seed", [1, 2, 3], [1.0, 2.0], -1, [0, -5]):
            with pytest.raises((TypeError, ValueError), match="seed"):
                pool.reset(seed=seed)
        with pytest.raises(TypeError, match="options must be None or a dict, got int 5"):
            pool.reset(seed=0, options=5)
        pool.reset(seed=[1, None])
        pool.step(np.zeros(2, dtype=np.int64))
    with pytest.raises(PoolClosedError, match="after a call to `close"):
        pool.worker_pids  # noqa: B018 - the property raises


def test_a_step_timeout_names_the_limit_and_the_option() -> None:
    pool = PoolVectorEnv(fns_with_fault("hang"), num_workers=2, step_timeout=0.5)
    pool.reset(seed=0)
    with pytest.raises(WorkerTimeoutError, match=r"within step_timeout=0.5 s; it was killed \(a larger step_timeout"):
        step_until_failure(pool)


@pytest.mark.usefixtures("no_leaks")
def test_an_env_fn_that_exits_is_reported_with_its_reason() -> None:
    def leaves() -> CountEnv:
        sys.exit("no licence for this model")

    with pytest.raises(EnvError, match=r"env 1\b") as info:
        PoolVectorEnv([CountEnv, leaves], num_workers=2)
    assert "no licence for this model" in str(info.value.__cause__)


def test_a_failure_releases_the_shared_memory_at_once(pool_services: None) -> None:
    """No garbage collection needed: the error's traceback may hold views of the memory, but not
    its file descriptor."""
    before = Snapshot.take()
    pool = PoolVectorEnv(fns_with_fault("segfault"), num_workers=2)
    with pytest.raises(WorkerDiedError) as info:
        step_until_failure(pool)
    assert info.value.__traceback__ is not None
    before.assert_restored()


@pytest.mark.parametrize("options", [{"num_workers": 2}, {}], ids=["workers", "default layout"])
def test_a_second_thread_gets_a_clear_error_and_the_pool_stays_usable(options: dict[str, Any]) -> None:
    """Two threads stepping one pool used to hang both (and the next reset); now the second is told."""
    with PoolVectorEnv([CountEnv] * 4, **options) as pool:
        pool.reset(seed=0)
        errors: list[BaseException] = []
        start = threading.Barrier(2)

        def hammer() -> None:
            start.wait()
            for _ in range(3000):
                try:
                    pool.step(np.zeros(4, dtype=np.int64))
                    pool.get_attr("steps")
                except ConcurrentUseError as error:
                    errors.append(error)

        threads = [threading.Thread(target=hammer) for _ in range(2)]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join(60)
        assert not any(thread.is_alive() for thread in threads), "a thread hung"
        assert errors and "from a second thread" in str(errors[0])
        assert not pool.closed
        pool.reset(seed=1)
        observations, *_ = pool.step(np.zeros(4, dtype=np.int64))
        assert observations.shape[0] == 4
