"""The calling process steps a slice of the envs itself (``caller_steps``): same results, same errors."""

from __future__ import annotations

import gc
import os
from functools import partial

import numpy as np
import pytest
from gymnasium.vector import AutoresetMode, SyncVectorEnv
from vector_envs import CountEnv, FaultyEnv, SafeCountEnv, count_fns
from vector_leaks import Snapshot
from vector_rollouts import assert_same, rollout

from modelicagym.cores import usable_cores
from modelicagym.errors import ConfigError
from modelicagym.vector import EnvError, PoolVectorEnv

pytestmark = pytest.mark.timeout(120)


@pytest.mark.parametrize("mode", list(AutoresetMode))
@pytest.mark.parametrize("num_workers", [None, 1])
def test_identical_to_sync_when_the_caller_steps(mode: AutoresetMode, num_workers: int | None) -> None:
    fns = count_fns(5)
    sync = SyncVectorEnv(fns, autoreset_mode=mode)
    with PoolVectorEnv(fns, num_workers=num_workers, caller_steps=True, autoreset_mode=mode) as pool:
        assert pool.caller_steps
        expected, actual = rollout(sync, 200), rollout(pool, 200)
        assert pool.call("steps") == sync.call("steps")
    sync.close()
    assert_same(expected, actual)


def test_the_default_layout_lets_the_caller_step_the_last_slice_of_envs_safe_there() -> None:
    with PoolVectorEnv([partial(SafeCountEnv, max_len=4 + 3 * i) for i in range(4)]) as pool:
        assert pool.caller_steps
        assert pool.num_workers == min(usable_cores(), 4) - 1
        pids = pool.call("pid")
    assert pids[-1] == os.getpid()
    assert os.getpid() not in pids[: len(pids) - (4 // min(usable_cores(), 4))]


def test_fault_handling_keeps_every_env_in_a_worker() -> None:
    for options in ({"restart_dead_workers": True}, {"step_timeout": 5.0}, {"num_workers": 2}, {"max_envs_per_worker": 1}):
        with PoolVectorEnv(count_fns(2), **options) as pool:
            assert not pool.caller_steps, options
            assert os.getpid() not in pool.call("pid")
    with pytest.raises(ConfigError, match="cannot be restarted"):
        PoolVectorEnv(count_fns(2), caller_steps=True, restart_dead_workers=True)


def test_a_single_env_safe_in_the_caller_needs_no_worker() -> None:
    before = Snapshot.take()
    with PoolVectorEnv([SafeCountEnv]) as pool:
        assert pool.num_workers == 0 and pool.worker_pids == ()
        pool.reset(seed=0)
        observations, *_ = pool.step(np.zeros(1, dtype=np.int64))
        assert observations.shape == (1,) + pool.single_observation_space.shape
    before.assert_restored()


@pytest.mark.parametrize("when", ["step", "reset"])
def test_an_env_of_the_caller_that_raises_is_reported_with_its_index(when: str) -> None:
    before = Snapshot.take()
    fns = [CountEnv, CountEnv, CountEnv, partial(FaultyEnv, "raise", when=when)]
    pool = PoolVectorEnv(fns, num_workers=1, caller_steps=True)
    with pytest.raises(EnvError, match=f"env 3 \\(the calling process\\) raised ValueError in {when}") as info:
        pool.reset(seed=0)
        for _ in range(5):
            pool.step(np.zeros(4, dtype=np.int64))
    assert info.value.env_index == 3 and isinstance(info.value.original, ValueError)
    assert pool.closed
    del info  # its traceback holds the frames of the failed step
    gc.collect()
    before.assert_restored()


def test_an_env_of_the_caller_that_fails_to_start_closes_the_workers() -> None:
    before = Snapshot.take()
    fns = [CountEnv, partial(FaultyEnv, "raise", when="init")]
    with pytest.raises(ValueError):
        PoolVectorEnv(fns, num_workers=1, caller_steps=True)
    before.assert_restored()
