"""The adaptive layout: envs move between their worker and the calling process at episode
boundaries, every env's trajectory stays SyncVectorEnv's, and the policy moves them where batches
are measured to be cheaper; idle workers sleep."""

from __future__ import annotations

import itertools
import os
import subprocess
import sys
import time
from collections.abc import Callable
from functools import partial
from typing import Any

import numpy as np
import pytest
from cpu_pressure import Machine
from gymnasium.vector import AutoresetMode, SyncVectorEnv
from step_paths import cartpole_fns
from vector_rollouts import Flipping, assert_same, flipping, rollout_recording_layouts

import modelicagym
from modelicagym.errors import ConfigError
from modelicagym.vector import PoolVectorEnv
from modelicagym.vector.dispatch.dispatcher import go_poll_time
from modelicagym.vector.layout import placement
from modelicagym.vector.layout.cost_model import SAMPLE_EVERY, PartyTimes
from modelicagym.vector.layout.machine_load import READ_EVERY, ForeignLoad
from modelicagym.vector.layout.policy import (
    PROBE_FIRST_SECONDS,
    TRY_SHARE,
    WINDOW_PARTS,
    ConsolidationPolicy,
    LayoutPolicy,
)
from modelicagym.vector.pool import DEFAULT_SPIN_TIME
from modelicagym.vector.wire.sync import pool_native_library

#: a stand-in's layouts: one worker of 4 envs and the stand-in with 4 (the stand-in is the home party)
STAND_IN_SHAPES = placement.layout_shapes([range(4)], 4)

pytestmark = [
    pytest.mark.timeout(180),
    pytest.mark.skipif(pool_native_library() is None, reason="the adaptive layout needs the native library"),
]


@pytest.mark.parametrize("mode", list(AutoresetMode))
def test_envs_moving_between_processes_keep_sync_results(monkeypatch: pytest.MonkeyPatch, mode: AutoresetMode) -> None:
    monkeypatch.setattr(placement, "PART_BATCHES", 1)
    native, python = cartpole_fns(6)
    sync = SyncVectorEnv(python, autoreset_mode=mode)
    with PoolVectorEnv(native, autoreset_mode=mode, cores=2) as pool:
        assert pool.layout.adaptive, pool.layout
        policy = flipping(pool, every=7)
        actual, in_caller = rollout_recording_layouts(pool, 300)
        layout = pool.layout
    expected, _ = rollout_recording_layouts(sync, 300)
    sync.close()
    assert_same(expected, actual)
    assert policy.switches >= 40
    home = 6 // 2  # the caller's own slice: cores=2 plans one worker and the caller
    assert min(in_caller) == home and max(in_caller) == 6, in_caller  # every env moved both ways
    assert "scripted" in str(layout)


@pytest.mark.parametrize("mode", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP])
def test_moves_keep_sync_results_with_per_episode_parameters(monkeypatch: pytest.MonkeyPatch, mode: AutoresetMode) -> None:
    """An explicit reset with options resets both copies alike, so an env may move right after it;
    an env that moves after an autoreset (no options) must not keep the options' episode."""
    monkeypatch.setattr(placement, "PART_BATCHES", 1)
    native, python = cartpole_fns(4)
    sync = SyncVectorEnv(python, autoreset_mode=mode)
    with PoolVectorEnv(native, autoreset_mode=mode, cores=2) as pool:
        flipping(pool, every=1)
        for k in range(6):
            options = {"parameters": {"m_cart": 1.0 + k}}
            assert_same(sync.reset(seed=k, options=options), pool.reset(seed=k, options=options))
            for _ in range(14):
                actions = np.array([0, 1, 1, 0])
                assert_same(sync.step(actions), pool.step(actions))
            assert_same(sync.get_attr("episode_parameters"), pool.get_attr("episode_parameters"))
    sync.close()


def test_workers_that_step_nothing_are_not_woken(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(placement, "PART_BATCHES", 1)
    native, _ = cartpole_fns(4)
    with PoolVectorEnv(native, cores=2) as pool:
        policy = flipping(pool, every=1)
        pool.reset(seed=0)
        pool.step(np.ones(4, dtype=np.int64))
        assert policy.target == policy.movable
        policy._every = 10**9  # stay with the caller from this first flip on
        for _ in range(200):
            pool.step(np.ones(4, dtype=np.int64))
        assert pool.layout.envs_in_caller == 4 and pool.layout.workers_stepping == 0, pool.layout
        assert pool._buffers.timing_enabled[0] == 0  # no worker steps: the policy samples nothing, nothing is timed
        pool.set_timing(True)
        before = _cpu_seconds(pool.worker_pids[0])
        for _ in range(20_000):
            pool.step(np.ones(4, dtype=np.int64))
        assert _cpu_seconds(pool.worker_pids[0]) - before < 0.05
        timing = pool.timing()
        assert "4/4 envs in the calling process, 0/1 workers stepping" in timing.layout
        assert 0 < timing.fmu_s <= timing.fmu_total_s  # the caller's slice is the critical one, all of it
        pool.set_timing(False)
        policy._every = 1  # the workers step again, and are timed for the policy
        pool.step(np.ones(4, dtype=np.int64))
        policy._every = 10**9
        assert policy.target == 0
        for _ in range(200):
            if pool.layout.workers_stepping:
                break
            pool.step(np.ones(4, dtype=np.int64))
        assert pool.layout.workers_stepping == 1 and pool._buffers.timing_enabled[0] == 1, pool.layout


@pytest.mark.parametrize("options", [{"adapt_layout": False}, {}])
def test_a_worker_waiting_for_a_command_sleeps(options: dict[str, Any]) -> None:
    native, _ = cartpole_fns(4)
    with PoolVectorEnv(native, **options, cores=2) as pool:
        pool.reset(seed=0)
        for _ in range(100):
            pool.step(np.zeros(4, dtype=np.int64))
        pid = pool.worker_pids[0]
        before = _cpu_seconds(pid)
        time.sleep(1.0)
        assert _cpu_seconds(pid) - before < 0.05  # asleep on its futex, not polling


def test_the_layout_says_why_it_is_fixed_and_adapt_layout_true_says_why_it_cannot() -> None:
    native, _ = cartpole_fns(4)
    with PoolVectorEnv(native, num_workers=2) as pool:
        assert not pool.layout.adaptive and "in a worker" in pool.layout.reason
    with PoolVectorEnv(native, adapt_layout=False, cores=2) as pool:
        assert not pool.layout.adaptive and pool.layout.envs_in_caller == 2
    random_mass = [partial(modelicagym.make, "cartpole", m_cart=_uniform_mass) for _ in range(4)]
    with PoolVectorEnv(random_mass, cores=2) as pool:
        assert not pool.layout.adaptive and "does not reset deterministically" in pool.layout.reason
    with pytest.raises(ConfigError, match="adapt_layout=True.*does not reset deterministically"):
        PoolVectorEnv(random_mass, adapt_layout=True, cores=2)


def _uniform_mass(rng: np.random.Generator) -> float:
    return float(rng.uniform(0.5, 1.5))


def _cpu_seconds(pid: int) -> float:
    """User and system CPU time of process ``pid``."""
    with open(f"/proc/{pid}/stat") as handle:
        fields = handle.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _users_cartpole(**options: Any) -> modelicagym.FMUEnv:
    """The cart-pole's FMU as a user's FMU: its envs may not run in the calling process."""
    from modelicagym.models.cartpole import OUTPUTS, cartpole_fmu

    return modelicagym.FMUEnv(fmu=cartpole_fmu(), inputs=["f"], outputs=list(OUTPUTS), time_step=0.05,
                              action_table=[[-15.0], [15.0]], termination={"x": (-2.4, 2.4)}, **options)


@pytest.mark.parametrize("step_path", ["auto", "python"])
@pytest.mark.parametrize("mode", list(AutoresetMode))
def test_a_users_envs_moving_to_the_stand_in_worker_keep_sync_results(monkeypatch: pytest.MonkeyPatch,
                                                                      mode: AutoresetMode, step_path: str) -> None:
    """Envs not safe in the calling process: a worker stands in for it (a copy of every env), and
    the adaptive layout moves envs between it and their workers, on either step path."""
    monkeypatch.setattr(placement, "PART_BATCHES", 1)
    stepped = [partial(_users_cartpole, max_episode_steps=5 + 4 * i, step_path=step_path) for i in range(6)]
    python = [partial(_users_cartpole, max_episode_steps=5 + 4 * i, step_path="python") for i in range(6)]
    sync = SyncVectorEnv(python, autoreset_mode=mode)
    with PoolVectorEnv(stepped, autoreset_mode=mode, cores=2) as pool:
        layout = pool.layout
        assert not pool.caller_steps and layout.adaptive and layout.envs_in_caller == 0, layout
        assert layout.envs_in_stand_in == 3 and "standing in for the calling process" in str(layout)
        policy = flipping(pool, every=7)
        actual, in_stand_in = rollout_recording_layouts(pool, 300)
        stepping = pool.layout.workers_stepping
        go_spin_ns = int(pool._workers.buffers.go_spin_ns[0])
        quiet = pool._dispatcher._machine_quiet
    expected, _ = rollout_recording_layouts(sync, 300)
    sync.close()
    assert_same(expected, actual)
    assert policy.switches >= 40
    home = 6 // 2  # the stand-in's own slice: cores=2 plans one worker and the stand-in
    assert min(in_stand_in) == home and max(in_stand_in) == 6, in_stand_in
    assert stepping in (0, 1)
    # a stand-in's workers poll for their next command only on a quiet machine, and then while they fit the cores
    expected = go_poll_time(DEFAULT_SPIN_TIME, stepping + 1, 2, quiet_stand_in=True) if quiet else 0.0
    assert go_spin_ns == round(expected * 1e9)


def test_the_consolidation_policy_keeps_the_faster_layout_and_backs_off() -> None:
    now = [0.0]
    policy = ConsolidationPolicy(STAND_IN_SHAPES, 2, clock=lambda: now[0])

    def window(batch_us: float, settled: bool = True) -> bool:
        changed = False
        for _ in range(WINDOW_PARTS):
            now[0] += 0.01
            changed |= policy.observe(64, 0, int(64 * batch_us * 1e3), 4, settled)
        return changed

    now[0] += PROBE_FIRST_SECONDS
    assert window(50.0) and policy.target == 4  # the planned layout measured: consolidation is tried
    assert not window(20.0, settled=False)  # envs still moving: not measured
    assert not window(20.0) and policy.target == 4  # faster: kept
    now[0] += PROBE_FIRST_SECONDS
    assert window(20.0) and policy.target == 0  # the planned layout is tried again
    assert window(40.0) and policy.target == 4, policy.last_decision  # slower: back
    assert "40.0 us" in policy.last_decision and "20.0 us" in policy.last_decision
    assert not window(20.0)  # back at once (the envs moved at once)
    now[0] += 1.5 * PROBE_FIRST_SECONDS
    assert not window(20.0)  # the next try waits twice as long (and 19x the 0.06 s the try cost)
    now[0] += PROBE_FIRST_SECONDS
    assert window(20.0) and policy.target == 0


def test_a_failed_try_that_took_long_to_undo_delays_the_next_one_in_proportion() -> None:
    """Envs move only at episode boundaries: a failed try of heavy envs runs a whole episode in
    the slower layout before they are back, and the tries must not eat the pool's time."""
    now = [0.0]
    policy = ConsolidationPolicy(STAND_IN_SHAPES, 2, clock=lambda: now[0])

    def window(batch_us: float, settled: bool = True) -> bool:
        changed = False
        for _ in range(WINDOW_PARTS):
            now[0] += 0.01
            changed |= policy.observe(8, 0, int(8 * batch_us * 1e3), 4, settled)
        return changed

    now[0] += PROBE_FIRST_SECONDS
    assert window(4000.0) and policy.target == 4  # consolidation tried
    tried = now[0] - WINDOW_PARTS * 0.01
    assert window(8000.0) and policy.target == 0  # slower: back
    now[0] += 4.0  # the envs wait for their episodes to end in the slower layout
    assert not window(8000.0, settled=False)
    assert not window(4000.0)  # back: what the try cost is known now
    cost = now[0] - WINDOW_PARTS * 0.01 - tried
    now[0] = tried + cost * (1 / TRY_SHARE - 1) * 0.9
    assert not window(4000.0), "a failed try that cost 4 s was tried again too soon"
    now[0] = tried + cost / TRY_SHARE
    assert window(4000.0) and policy.target == 4


def feed_window(policy: LayoutPolicy, machine: Machine, local_us: float, worker_us: float, batch_us: float,
                wall_us: float) -> bool:
    """A window of parts of a pool of 8 envs with one worker, in ``policy``'s layout: per batch the caller
    stepped its envs in ``local_us`` and the worker its envs in ``worker_us``, the batch took
    ``batch_us`` stepping and waiting, and ``wall_us`` in all; ``True`` when the target changed (the
    window ends there: the parts of a layout the envs are leaving are not the next one's)."""
    shape = policy.shapes[policy.target]
    worker_slice = range(policy.movable)
    in_caller = np.array([0] * shape.worker_envs + [1] * (8 - shape.worker_envs), dtype=np.uint8)
    changed = False
    for _ in range(WINDOW_PARTS):
        if changed:
            break
        machine.run(640 * wall_us * 1e-6, 0.0)
        times = PartyTimes(np.array([worker_us * 1e3, 0]), in_caller, [worker_slice],
                           np.array([shape.worker_envs > 0, 1], np.uint8), stand_in=False)
        for _ in range(SAMPLE_EVERY):
            times.count()
        changed |= policy.observe(640, int(640 * local_us * 1e3), int(640 * (batch_us - local_us) * 1e3),
                                  shape.home_envs, parties=times)
    return changed


class SharedMachine:
    """A pool of 8 light envs (3 us a step), one worker and the calling process with 4 each, fed to
    a `LayoutPolicy`: the hand-over costs ``handover_us``, and on a shared machine each batch
    that wakes the worker also loses ``unseen_us`` that no party measures (the caller waiting for
    a core between steps), which only the batches' wall time shows; with every env at home, each
    batch loses ``alone_us`` likewise."""

    ENV_US = 3.0

    def __init__(self, foreign_cores: float, handover_us: float = 10.0, unseen_us: float = 40.0,
                 alone_us: float = 0.0, apart_us: float = 0.0) -> None:
        self.machine = Machine()
        self.foreign_cores, self.handover_us, self.unseen_us = foreign_cores, handover_us, unseen_us
        #: what every env at home costs beyond their steps (the caller then shares its core with the neighbour)
        self.alone_us = alone_us
        #: what a batch gains (< 0) or loses with the parties apart
        self.apart_us = apart_us
        self.apart_changes = 0
        #: the cores idle between two readings of the policy
        self.idle_cores = 0.0
        self.policy = LayoutPolicy(placement.layout_shapes([range(4)], 4), 2, clock=lambda: self.machine.now,
                                   idle_cores=lambda: self.idle_cores, stall_us=self.machine.stall,
                                   foreign_cores=lambda: self.foreign_cores)

    def window(self) -> bool:
        """A window of parts in the policy's layout; ``True`` when the target changed."""
        shape = self.policy.shapes[self.policy.target]
        local_us = shape.home_envs * self.ENV_US
        worker_us = shape.worker_envs * self.ENV_US
        batch_us = max(local_us, self.handover_us + worker_us) if worker_us else local_us
        wall_us = batch_us + (self.unseen_us if worker_us else self.alone_us) + (self.apart_us if self.policy.apart else 0)
        apart = self.policy.apart
        changed = feed_window(self.policy, self.machine, local_us, worker_us, batch_us, wall_us)
        self.apart_changes += apart != self.policy.apart
        return changed

    def run(self, seconds: float) -> list[int]:
        """Windows for ``seconds``; the targets the policy took."""
        targets, until = [], self.machine.now + seconds
        while self.machine.now < until:
            if self.window():
                targets.append(self.policy.target)
        return targets


def test_on_a_machine_of_its_own_the_layout_policy_tries_nothing_where_the_model_sees_every_cost() -> None:
    pool = SharedMachine(foreign_cores=0.0, unseen_us=0.0)
    targets = pool.run(30.0)
    assert targets and pool.policy.movable not in targets, pool.policy.last_decision


def test_every_env_at_home_is_tried_where_whole_batches_show_a_cost_the_model_misses() -> None:
    """On a machine of its own: the pool's code around a step with workers (sending, collecting)
    is in no party's time, and a step with every env at home saves it. Every env at home is tried
    and kept; the workers, tried again whenever a core was idle, lose by whole batches and wait
    longer each time."""
    pool = SharedMachine(foreign_cores=0.0, unseen_us=40.0)
    pool.idle_cores = 1.0
    movable, returns = pool.policy.movable, []
    until = pool.machine.now + 120.0
    while pool.machine.now < until:
        before = pool.policy.target
        if pool.window() and before == movable:
            returns.append(pool.machine.now)
    assert pool.policy.target == movable, pool.policy.last_decision
    assert "the machine is shared" not in pool.policy.last_decision
    assert len(returns) >= 3, returns
    gaps = np.diff(returns)
    assert all(later >= 0.99 * earlier for earlier, later in itertools.pairwise(gaps)), gaps
    assert gaps[-1] >= 4 * gaps[0], gaps


def test_on_a_shared_machine_every_env_in_the_caller_is_tried_and_kept_if_batches_are_faster() -> None:
    """Two trainings at once: the model alone keeps a worker, whose wake-ups cost what no party
    measures; a try of every env in the calling process shows it in whole batches, and stays."""
    pool = SharedMachine(foreign_cores=1.0)
    targets = pool.run(30.0)
    assert targets[-1] == pool.policy.movable, pool.policy.last_decision
    assert targets.count(pool.policy.movable) == 1, targets  # kept: no core idle, no probe of the workers
    assert "the machine is shared" in pool.policy.last_decision


def test_on_a_shared_machine_a_try_that_is_slower_goes_back_and_waits_longer() -> None:
    pool = SharedMachine(foreign_cores=1.0, alone_us=80.0)
    tries: list[float] = []
    until = pool.machine.now + 120.0
    while pool.machine.now < until:
        if pool.window() and pool.policy.target == pool.policy.movable:
            tries.append(pool.machine.now)
    assert pool.policy.target != pool.policy.movable, pool.policy.last_decision
    assert len(tries) >= 3, tries
    gaps = np.diff(tries)
    assert all(later >= 0.99 * earlier for earlier, later in itertools.pairwise(gaps)), gaps  # backs off, up to a cap
    assert gaps[-1] >= 4 * gaps[0], gaps
    assert "us a batch with every env in the calling process" in pool.policy.last_decision


def test_a_shared_machine_tries_no_layout_whose_envs_at_home_would_take_longer_than_a_batch() -> None:
    """Envs of 100 us: 8 at home, at their cost measured now, would take 800 us, a batch takes
    under 500 us with the worker, hidden costs included: no try."""
    pool = SharedMachine(foreign_cores=1.0, handover_us=0.0, unseen_us=50.0)
    pool.ENV_US = 100.0
    targets = pool.run(30.0)
    assert pool.policy.movable not in targets, pool.policy.last_decision


@pytest.mark.parametrize("apart_us", [-100.0, 100.0], ids=["faster", "slower"])
def test_on_a_shared_machine_the_parties_go_apart_where_batches_are_shorter_so(apart_us: float) -> None:
    """Heavy batches (8 envs of 100 us): apart is tried, and kept only where a batch's wall time is
    shorter; the tries of the losing choice back off."""
    pool = SharedMachine(foreign_cores=1.0, handover_us=0.0, unseen_us=50.0, apart_us=apart_us)
    pool.ENV_US = 100.0
    pool.run(60.0)
    assert pool.apart_changes >= 2, pool.apart_changes  # the other choice was tried too
    pool.apart_changes, choices = 0, []
    until = pool.machine.now + 60.0
    while pool.machine.now < until:
        pool.window()
        choices.append(pool.policy.apart)
    assert choices.count(apart_us < 0) >= 0.9 * len(choices), choices  # the other choice only in its tries
    assert pool.apart_changes <= 4, pool.apart_changes  # backed off: at most a try every 30 s


def test_on_a_machine_of_its_own_the_parties_are_never_apart() -> None:
    pool = SharedMachine(foreign_cores=0.0, handover_us=0.0, unseen_us=50.0, apart_us=-100.0)
    pool.ENV_US = 100.0
    pool.run(30.0)
    assert pool.apart_changes == 0 and not pool.policy.apart


class BusyNeighbour:
    """A pool of 8 heavy envs (80 us a step), one worker and the calling process with 4 each, beside
    one busy process on 2 cores, fed to a `LayoutPolicy` as this project's VM measured it:

    - together, the kernel runs the caller and the worker it wakes on one CPU at times: a hand-over
      of 300 us, and each batch loses 150 us that no party measures (the caller waiting for a core);
    - apart, the worker shares its CPU with the neighbour and waits for its turn there: its side
      takes 3.1 times its stepping, and a batch loses 40 us outside the parties. The calling thread
      starts on the neighbour's CPU (its envs take 1.6 times as long, the worker's side is its
      stepping) until the policy's ``home_slower`` swaps it with the worker (`PartiesApart.keep`);
    - every env at home: a batch is their steps and ``alone_us``; the calling thread runs on a CPU
      of its own, and keeps it when the parties go apart from there.
    """

    ENV_US, HANDOVER_US, TOGETHER_US, STRETCH, APART_US = 80.0, 300.0, 150.0, 3.1, 40.0

    def __init__(self, alone_us: float = 60.0) -> None:
        self.machine = Machine()
        self.alone_us = alone_us
        self.swapped = False
        self.policy = LayoutPolicy(placement.layout_shapes([range(4)], 4), 2, clock=lambda: self.machine.now,
                                   idle_cores=lambda: 0.0, stall_us=self.machine.stall, foreign_cores=lambda: 1.0)

    def window(self) -> bool:
        """A window of parts in the policy's layout; ``True`` when the target changed."""
        policy = self.policy
        shape = policy.shapes[policy.target]
        crowded_home = policy.apart and not self.swapped
        local_us = shape.home_envs * self.ENV_US * (1.6 if crowded_home else 1.0)
        worker_us = shape.worker_envs * self.ENV_US
        if not worker_us:
            batch_us, wall_us = local_us, local_us + self.alone_us
        elif policy.apart:
            batch_us = max(local_us, worker_us * (1.0 if crowded_home else self.STRETCH))
            wall_us = batch_us + self.APART_US
        else:
            batch_us = max(local_us, self.HANDOVER_US + worker_us)
            wall_us = batch_us + self.TOGETHER_US
        return self.feed(local_us, worker_us, batch_us, wall_us)

    def feed(self, local_us: float, worker_us: float, batch_us: float, wall_us: float) -> bool:
        """A window measured as given (`feed_window`); ``True`` when the target changed."""
        policy = self.policy
        changed = feed_window(policy, self.machine, local_us, worker_us, batch_us, wall_us)
        at_home = policy.target == policy.movable
        self.swapped = at_home or (policy.apart and (self.swapped or policy.home_slower))
        return changed

    def run(self, seconds: float) -> list[tuple[int, bool]]:
        """Windows for ``seconds``; the layout (target, apart) after each."""
        layouts, until = [], self.machine.now + seconds
        while self.machine.now < until:
            self.window()
            layouts.append((self.policy.target, self.policy.apart))
        return layouts


def test_beside_a_busy_process_heavy_envs_settle_apart_where_the_workers_turns_allow() -> None:
    """Apart, the worker's turns on the neighbour's CPU grow with what it steps: 6 envs at home
    and 2 in the worker (536 us a batch) beat 7 and 1 (600 us), and every layout together (630 us
    and more). A try of the parties apart moves to the layout the model picks for them, once the
    calling thread has left the neighbour's CPU, and the tries of the parties together lose."""
    pool = BusyNeighbour()
    layouts = pool.run(60.0)
    last = layouts[-len(layouts) // 4 :]
    assert last.count((2, True)) >= 0.8 * len(last), last


def test_beside_a_busy_process_one_slow_window_does_not_send_every_env_home() -> None:
    """Settled apart with 6 envs at home (536 us a batch), every fourth window takes 820 us, outside
    the parties' own times (the calling thread waited for a core). Every env at home (704 us with
    the margin) beats such a window, but not the layout's usual batch: it is never tried."""
    pool = BusyNeighbour()
    pool.run(60.0)
    layouts = []
    for window in range(200):
        if window % 4 == 3:
            pool.feed(480.0, 160.0, 496.0, 820.0)
        else:
            pool.window()
        layouts.append((pool.policy.target, pool.policy.apart))
    assert (pool.policy.movable, False) not in layouts, pool.policy.last_decision
    assert layouts.count((2, True)) >= 0.8 * len(layouts), layouts


def test_beside_a_busy_process_a_try_of_the_parties_together_that_starts_slower_ends_at_once() -> None:
    """Settled apart (536 us a batch), each try of the parties together takes 630 us in its first
    window: no second window could bring it under the 536 by the margin, so it ends after one."""
    pool = BusyNeighbour()
    pool.run(60.0)
    together, runs = 0, []
    for _ in range(100):
        pool.window()
        if pool.policy.apart:
            runs, together = [*runs, together] if together else runs, 0
        else:
            together += 1
    assert runs and set(runs) == {1}, runs


def test_apart_one_window_of_late_turns_on_the_neighbours_cpu_moves_nothing() -> None:
    """6 envs at home and 2 in the worker, the parties apart: the worker's side takes 3 times its
    stepping (480 us a batch), and every fifth window 3.7 times (592 us). On such a window alone, 7
    envs at home (513 us) would be predicted faster by the margin; on the windows' median, not."""
    machine = Machine()
    policy = LayoutPolicy(placement.layout_shapes([range(2)], 6), 2, clock=lambda: machine.now,
                          idle_cores=lambda: 0.0, stall_us=machine.stall, foreign_cores=lambda: 1.0)
    policy.apart = True
    for window in range(40):
        late = window % 5 == 4
        feed_window(policy, machine, 440.0, 160.0, 592.0 if late else 480.0, 610.0 if late else 500.0)
        assert policy.target == 0, policy.last_decision


def test_a_failed_try_of_every_env_at_home_brings_the_parties_back_apart() -> None:
    """6 envs at home and 2 in the worker, the parties apart: a batch's wall time (736 us) looks
    beatable by every env at home (640 us at today's cost), which is tried and loses (1040 us): the
    layout it left comes back with the parties apart, as they were."""
    machine = Machine()
    policy = LayoutPolicy(placement.layout_shapes([range(2)], 6), 2, clock=lambda: machine.now,
                          idle_cores=lambda: 0.0, stall_us=machine.stall, foreign_cores=lambda: 1.0)
    policy.apart = True
    home_tries = 0
    until = machine.now + 30.0
    while machine.now < until:
        if policy.target == policy.movable:
            changed = feed_window(policy, machine, 640.0, 0.0, 640.0, 1040.0)
            home_tries += changed
            if changed:
                assert policy.apart, policy.last_decision
        elif policy.apart:
            feed_window(policy, machine, 480.0, 160.0, 496.0, 736.0)
        else:
            feed_window(policy, machine, 480.0, 160.0, 480.0, 900.0)
    assert home_tries >= 1
    assert policy.apart and policy.target == 0, policy.last_decision


def test_a_hand_over_the_caller_stopped_waiting_for_moves_nothing() -> None:
    """6 envs at home and 2 in the worker (80 us a step): in one window the caller waited for the
    worker (595 us a batch, a hand-over of 435 us); in the next its own slice was the batch (76 us
    an env, 462 us), so the worker's side ended within it. The hand-over of the window before
    would predict 7 envs at home (532 us) faster than the 462 us a batch takes now."""
    machine = Machine()
    policy = LayoutPolicy(placement.layout_shapes([range(2)], 6), 2, clock=lambda: machine.now,
                          idle_cores=lambda: 0.0, stall_us=machine.stall, foreign_cores=lambda: 0.0)
    assert not feed_window(policy, machine, 480.0, 160.0, 595.0, 595.0)
    for _ in range(20):
        assert not feed_window(policy, machine, 456.0, 160.0, 462.0, 462.0), policy.last_decision
    assert policy.target == 0


def test_the_foreign_load_counts_other_processes_and_not_the_pools_own() -> None:
    """Over the same interval, a busy process counts as foreign load unless it is one of the pool's."""
    busy = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        clock = [0.0]
        theirs = ForeignLoad(lambda: [os.getpid()], clock=lambda: clock[0])
        ours = ForeignLoad(lambda: [os.getpid(), busy.pid], clock=lambda: clock[0])
        ticks = os.sysconf("SC_CLK_TCK")
        started = time.monotonic()
        while _cpu_ticks(busy.pid) < 0.3 * ticks and time.monotonic() - started < 30:
            time.sleep(0.05)
        clock[0] = READ_EVERY
        foreign, own_excluded = theirs(), ours()
        share = _cpu_ticks(busy.pid) / ticks / (time.monotonic() - started)
    finally:
        busy.kill()
        busy.wait()
    assert foreign is not None and own_excluded is not None
    assert foreign - own_excluded == pytest.approx(share, abs=0.15), (foreign, own_excluded, share)


def _cpu_ticks(pid: int) -> int:
    with open(f"/proc/{pid}/stat", "rb") as handle:
        fields = handle.read().rsplit(b")", 1)[1].split()
    return int(fields[11]) + int(fields[12])


def _moody(fmu: str, threshold: float, **options: Any) -> modelicagym.FMUEnv:
    """The moody test FMU (tests/fmus/moody): its step costs 100x more while x > ``threshold``."""
    return modelicagym.FMUEnv(fmu=fmu, inputs=["u"], outputs=["x", "effort"], time_step=0.05,
                              action_table=[[-1.0], [1.0]], parameters={"threshold": threshold}, **options)


def test_the_moody_fmu_steps_costlier_exactly_in_its_moody_phase(family_fmu: Any) -> None:
    """Its ``effort`` output (the factor on its internal steps) is the ratio exactly while x is above
    the threshold, and a push one way then the other takes x through both phases."""
    with _moody(str(family_fmu("moody", 2)), 0.5) as env:
        env.reset(seed=0)
        observations = [env.step(action)[0] for action in [1] * 30 + [0] * 30]
    efforts = {float(effort) for x, effort in observations}
    assert efforts == {1.0, 100.0}
    assert all((effort == 100.0) == (x > 0.5) for x, effort in observations)


@pytest.mark.parametrize("mode", list(AutoresetMode))
def test_moody_envs_whose_cost_varies_keep_sync_results_as_they_move(family_fmu: Any, monkeypatch: pytest.MonkeyPatch,
                                                                      mode: AutoresetMode) -> None:
    """Envs whose step cost varies with their state (and between envs: thresholds differ) move
    between their worker and the stand-in at episode boundaries; each keeps SyncVectorEnv's
    trajectory."""
    monkeypatch.setattr(placement, "PART_BATCHES", 1)
    fmu = str(family_fmu("moody", 3))
    fns = [partial(_moody, fmu, 0.2 * i, max_episode_steps=6 + 3 * i) for i in range(6)]
    sync = SyncVectorEnv([partial(fn, step_path="python") for fn in fns], autoreset_mode=mode)
    with PoolVectorEnv(fns, autoreset_mode=mode, cores=2) as pool:
        assert pool.layout.adaptive and pool.layout.envs_in_stand_in == 3, pool.layout
        policy = Cycling(pool._placement.policy.movable, every=5)
        pool._placement.policy = policy
        actual, in_stand_in = rollout_recording_layouts(pool, 200)
    expected, _ = rollout_recording_layouts(sync, 200)
    sync.close()
    assert_same(expected, actual)
    assert policy.switches >= 30 and in_stand_in == {3, 4, 5, 6}, in_stand_in


class Cycling(Flipping):
    """A policy that gives the stand-in one more of the workers' envs every ``every`` parts it
    observes, then all of them back: every partial balance in turn."""

    def observe(self, *measured: Any, **parties: Any) -> bool:
        self._seen += 1
        if self._seen % self._every:
            return False
        self.target = (self.target + 1) % (self.movable + 1)
        self.switches += 1
        return True


def _party_times(worker_us: float, stand_in_us: float, lent: int) -> PartyTimes:
    """Sampled party times of a pool of 8 envs, 4 per worker and stand-in, ``lent`` of the worker's
    in the stand-in."""
    in_caller = np.array([0] * (4 - lent) + [1] * (4 + lent), dtype=np.uint8)
    times = PartyTimes(np.array([worker_us * 1e3, stand_in_us * 1e3]), in_caller, [range(4)], np.ones(2, np.uint8))
    for _ in range(SAMPLE_EVERY):
        times.count()
    return times


def test_the_spread_layout_takes_the_target_the_cost_model_predicts_fastest() -> None:
    """Both parties are workers, so an env costs the same in either: 4 envs of 100 us in the worker
    against 4 of 5 us in the stand-in are even with 2 moved (220 us against 200 us a batch), not 3
    (320 against 100); when the stand-in's envs grow costlier, envs go back."""
    machine = Machine()
    policy = ConsolidationPolicy(STAND_IN_SHAPES, 2, clock=lambda: machine.now, stall_us=machine.stall)
    window = _windows_of(policy, machine, stall_share=0.0)
    assert window(400.0, 400.0, 20.0) and policy.target == policy.spread == 2, policy.last_decision
    assert "predicted 220.0 us" in policy.last_decision
    assert not window(220.0, 200.0, 220.0) and policy.target == 2  # balanced: stays
    assert window(420.0, 200.0, 420.0) and policy.target == 1  # 320 us predicted with one back: better by 10%
    assert not window(320.0, 300.0, 320.0) and policy.target == 1


def _windows_of(policy: ConsolidationPolicy, machine: Machine, stall_share: float) -> Callable[..., bool]:
    """A window of measurements for ``policy``: five parts of 64 batches, 0.1 s each, in which some
    thread waited for a core ``stall_share`` of the time; ``True`` when the target changed."""

    def window(batch_us: float, worker_us: float, stand_in_us: float) -> bool:
        changed = False
        for _ in range(WINDOW_PARTS):
            machine.run(0.1, stall_share)
            parties = _party_times(worker_us, stand_in_us, policy.target)
            changed |= policy.observe(64, 0, int(64 * batch_us * 1e3), 0, True, parties=parties)
        return changed

    return window


@pytest.mark.parametrize("quiet", [True, False])
def test_the_consolidation_policy_balances_the_spread_layout_by_party_costs(quiet: bool) -> None:
    machine = Machine()
    policy = ConsolidationPolicy(STAND_IN_SHAPES, 2, clock=lambda: machine.now, stall_us=machine.stall)
    window = _windows_of(policy, machine, stall_share=0.0 if quiet else 0.3)  # 0.3: a busy process beside

    assert window(400.0, 400.0, 20.0) and policy.target == policy.spread == 2, policy.last_decision
    assert "400.0 us" in policy.last_decision and "20.0 us" in policy.last_decision
    assert not window(220.0, 210.0, 220.0) and policy.target == 2  # balanced: stays
    machine.run(PROBE_FIRST_SECONDS, 0.0 if quiet else 0.3)
    if quiet:  # the parties' stepping fills the batch (210 + 220 us of 220): one worker for all would take 430 us
        assert not window(220.0, 210.0, 220.0) and policy.target == 2, "a try that could only lose was made"
    else:  # they may have shared a core, each counting the other's turn: the try is made
        assert window(220.0, 210.0, 220.0) and policy.target == 4
        assert window(420.0, 0.0, 420.0) and policy.target == 2
        assert not window(220.0, 210.0, 220.0)  # back: what the try cost is known
    machine.run(40.0, 0.0 if quiet else 0.3)  # past any back-off (a failed try of 1 s waits 19 s)
    # the batch is mostly waking up (50 + 50 us of 220): consolidation is tried ...
    assert window(220.0, 50.0, 50.0) and policy.target == 4
    assert window(420.0, 0.0, 420.0) and policy.target == 2  # ... and loses: back to the balanced spread


def test_a_consolidation_try_waits_until_the_machine_watch_can_tell() -> None:
    """The pool's start-up crowds the machine; the policy's watch starts at its first window, and a
    try that the party costs rule out waits until the watch has seen the machine for a while."""
    machine = Machine()
    policy = ConsolidationPolicy(STAND_IN_SHAPES, 2, clock=lambda: machine.now, stall_us=machine.stall)
    machine.run(PROBE_FIRST_SECONDS, 0.5)  # start-up: workers spawned, FMUs instantiated
    window = _windows_of(policy, machine, stall_share=0.0)
    assert not window(220.0, 210.0, 220.0)  # the first window: the watch starts, cannot tell yet
    assert not window(220.0, 210.0, 220.0) and policy.target == 0  # quiet: the try that cannot win is skipped
    machine.run(PROBE_FIRST_SECONDS, 0.3)  # a busy process starts beside the pool
    crowded = _windows_of(policy, machine, stall_share=0.3)
    assert crowded(220.0, 210.0, 220.0) and policy.target == 4, policy.last_decision  # tried


def test_a_lone_stand_in_keeps_watching_the_machine(monkeypatch: pytest.MonkeyPatch) -> None:
    """One env: the stand-in is the pool's one worker, in a fixed layout, and it still polls only
    on a quiet machine, so the pool keeps looking at the machine after each window of steps."""
    monkeypatch.setattr(placement, "PART_BATCHES", 4)
    with PoolVectorEnv([partial(_users_cartpole, max_episode_steps=50)], cores=2) as pool:
        assert not pool.layout.adaptive and pool.layout.stand_in, pool.layout
        looks = []
        monkeypatch.setattr(pool._dispatcher, "watch_machine", lambda: looks.append(1))
        pool.reset(seed=0)
        for _ in range(12):
            pool.step(np.zeros(1, dtype=np.int64))
    assert len(looks) == 3


def test_a_stand_in_pool_samples_its_parties_stepping_times_with_timing_off() -> None:
    """The cost model's input: the parties time their steps while a stand-in layout adapts, whatever
    the user's ``set_timing`` says (the pool's own timing summary stays off)."""
    with PoolVectorEnv([partial(_users_cartpole, max_episode_steps=50)] * 4, cores=2) as pool:
        assert pool.layout.envs_in_stand_in == 2, pool.layout
        pool.set_timing(False)
        pool.reset(seed=0)
        for _ in range(7 * SAMPLE_EVERY):
            pool.step(np.zeros(4, dtype=np.int64))
        samples = pool._placement._party_times.take()
        assert pool.timing().steps == 0
    assert len(samples) == 7 and all(busiest > 0 and stand_in > 0 and total >= busiest
                                     for busiest, stand_in, total in samples), samples
