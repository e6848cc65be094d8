"""On a shared machine the layout policy may keep the pool's stepping parties apart: each worker
pinned to a CPU of its own, the calling thread on another while it steps its slice, its mask given
back after every step; when the policy says so, the caller takes a worker's CPU, and together
again gives the workers the pool's CPUs back."""

from __future__ import annotations

import os
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from step_paths import cartpole_fns

from modelicagym.vector import PoolVectorEnv
from modelicagym.vector.layout import placement
from modelicagym.vector.layout.affinity import PartiesApart

MASK = os.sched_getaffinity(0)

needs_two_cpus = pytest.mark.skipif(len(MASK) < 2, reason="the affinity mask has one CPU: no CPUs to keep apart")


class Scripted:
    """A layout policy that keeps the planned layout and says ``apart`` and ``home_slower`` as told."""

    def __init__(self, movable: int) -> None:
        self.movable, self.target, self.switches, self.last_decision = movable, 0, 0, ""
        self.apart = self.home_slower = False

    def observe(self, *measured: Any, **parties: Any) -> bool:
        return False


def _worker_masks(pool: PoolVectorEnv) -> list[set[int]]:
    return [os.sched_getaffinity(handle.process.pid) for handle in pool._workers.handles]


@needs_two_cpus
def test_apart_each_party_has_a_cpu_of_its_own_and_together_gives_them_back(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(placement, "PART_BATCHES", 1)
    native, _ = cartpole_fns(4)
    with PoolVectorEnv(native, cores=2, start_method="fork") as pool:
        assert pool.layout.adaptive and pool.num_workers == 1, pool.layout
        policy = Scripted(pool._placement.policy.movable)
        pool._placement.policy = policy
        pool.reset(seed=0)
        actions = np.zeros(4, dtype=np.int64)

        policy.apart = True
        pool.step(actions)
        caller = pool._placement.caller_cpu
        assert caller in MASK
        [worker] = _worker_masks(pool)
        assert len(worker) == 1 and caller not in worker
        assert os.sched_getaffinity(0) == MASK  # the calling thread's mask is back once the step returns

        policy.home_slower = True  # the caller's CPU is the crowded one: it takes the worker's
        pool.step(actions)
        assert pool._placement.caller_cpu in worker and _worker_masks(pool) == [{caller}]
        policy.home_slower = False
        pool.step(actions)
        assert _worker_masks(pool) == [{caller}]  # no swap unless the caller is slower again

        policy.apart = False
        for _ in range(3):
            pool.step(actions)
        assert pool._placement.caller_cpu is None
        assert _worker_masks(pool) == [MASK]
        assert os.sched_getaffinity(0) == MASK


class AffinityRecorder(gym.Env):
    """Records the calling thread's affinity mask at every step."""

    observation_space = gym.spaces.Box(-1.0, 1.0, (1,))
    action_space = gym.spaces.Discrete(2)

    def __init__(self) -> None:
        self.masks: list[set[int]] = []

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[np.ndarray, dict]:
        super().reset(seed=seed)
        return np.zeros(1, dtype=np.float32), {}

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict]:
        self.masks.append(os.sched_getaffinity(0))
        return np.zeros(1, dtype=np.float32), 0.0, False, False, {}


@needs_two_cpus
def test_the_calling_thread_steps_its_slice_on_its_cpu_and_gets_its_mask_back() -> None:
    with PoolVectorEnv([AffinityRecorder] * 2, num_workers=1, caller_steps=True, start_method="fork") as pool:
        [recorder] = pool._dispatcher.local.envs
        cpu = max(MASK)
        pool.reset(seed=0)
        pool._dispatcher.step_own_slice_on(cpu)
        pool.step(np.zeros(2, dtype=np.int64))
        assert recorder.masks[-1] == {cpu} and os.sched_getaffinity(0) == MASK
        pool._dispatcher.step_own_slice_on(None)
        pool.step(np.zeros(2, dtype=np.int64))
        assert recorder.masks[-1] == MASK
        pool._dispatcher.step_own_slice_on(4096)  # a CPU the thread may not take: it steps where it runs
        pool.step(np.zeros(2, dtype=np.int64))
        assert recorder.masks[-1] == MASK and os.sched_getaffinity(0) == MASK


def test_parties_that_outnumber_the_cpus_are_never_kept_apart() -> None:
    apart = PartiesApart([os.getpid()] * len(MASK), tuple(sorted(MASK)))
    apart.keep(True)
    assert apart.caller_cpu is None
    assert os.sched_getaffinity(0) == MASK
