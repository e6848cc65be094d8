"""The adaptive layout's decisions on simulated machines: 1 to 64 cores, light to heavy envs, costs
that change with the env's state, a crowded machine.

A `SimulatedMachine` turns a layout into what the pool measures in it (the caller's own stepping,
its wait for the workers, each worker's stepping time) from true costs: one env's CPU time, the
wake-up of the workers, busy processes beside the pool. The policy sees only those measurements,
as in a pool, and its choices are checked against the true batch times of every layout it could
choose."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest
from cpu_pressure import Machine

from modelicagym.vector.layout.cost_model import SAMPLE_EVERY, Costs, PartyTimes, Shape, batch_us, best_shape, sharing
from modelicagym.vector.layout.placement import PART_BATCHES, layout_shapes, move_order
from modelicagym.vector.layout.plan import plan_workers
from modelicagym.vector.layout.policy import PROBE_FIRST_SECONDS, WINDOW_PARTS, ConsolidationPolicy, LayoutPolicy

#: one env's step, in microseconds: the bundled cart-pole, a medium FMU, a heavy one
LIGHT, MEDIUM, HEAVY = 3.0, 100.0, 1000.0
#: waking a worker and learning it is done, on an idle machine (us)
WAKE_US = 12.0
#: what a party that waits for a core loses per batch on a crowded machine (a share of a slice, us)
TURN_US = 400.0
CORES = (1, 2, 4, 8, 16, 64)


@dataclass
class SimulatedMachine:
    """``cores`` cores, ``busy`` processes beside the pool, envs of ``env_us`` CPU time a step."""

    cores: int
    env_us: float
    busy: int = 0

    def batch(self, shape: Shape) -> tuple[float, float, list[float]]:
        """The caller's own stepping, the batch's wall time and each stepping worker's stepping (us)."""
        runnable = shape.workers + 1 + self.busy
        share = sharing(runnable, self.cores)
        caller = shape.home_envs * self.env_us * share
        if shape.workers == 0:
            return caller, caller, []
        handover = WAKE_US + (TURN_US if runnable > self.cores else 0.0)
        workers = [shape.worker_envs * self.env_us * share] * shape.workers
        return caller, max(caller, handover + max(workers)), workers

    def best(self, shapes: list[Shape]) -> float:
        """The shortest true batch time of any of ``shapes``."""
        return min(self.batch(shape)[1] for shape in shapes)


class SimulatedPool:
    """A pool of ``num_envs`` envs laid out as a pool plans it on ``machine``, its policy fed what
    the machine gives, part after part; envs move as soon as the policy says (as if every episode
    ended every batch). The busy processes show only in the parties' times, never as foreign load
    or CPU pressure: these tests check the model's decisions (the tries a shared machine makes are
    checked in tests/vector/test_vector_layout.py)."""

    def __init__(self, machine: SimulatedMachine, num_envs: int) -> None:
        slices = plan_workers(num_envs, None, None, machine.cores)
        self.machine = machine
        self.caller_slice, self.worker_slices = slices[-1], slices[:-1]
        self.shapes = layout_shapes(self.worker_slices, len(self.caller_slice))
        self.now = [0.0]
        self.idle = [0.0]
        self.policy = LayoutPolicy(self.shapes, machine.cores, clock=lambda: self.now[0],
                                   idle_cores=lambda: self.idle[0], stall_us=lambda: 0, foreign_cores=lambda: 0.0)
        self.in_caller = np.zeros(num_envs, dtype=np.uint8)
        self.stepping = np.ones(len(self.worker_slices), dtype=np.uint8)
        self.env_ns = np.zeros(len(self.worker_slices) + 1, dtype=np.int64)
        self.parties = PartyTimes(self.env_ns, self.in_caller, self.worker_slices, self.stepping, stand_in=False)
        self._order = move_order(self.worker_slices)
        self._place()

    def _place(self) -> None:
        self.in_caller[:] = 0
        self.in_caller[self.caller_slice.start : self.caller_slice.stop] = 1
        self.in_caller[self._order[: self.policy.target]] = 1
        self.stepping[:] = [not self.in_caller[s.start : s.stop].all() for s in self.worker_slices]

    def window(self) -> bool:
        """Run up to a window of parts in the current layout, until the policy changes its target
        (then ``True``)."""
        shape = self.shapes[self.policy.target]
        caller, batch, workers = self.machine.batch(shape)
        row = iter(workers)
        self.env_ns[: len(self.worker_slices)] = [round(next(row) * 1e3) if s else 0 for s in self.stepping]
        for _ in range(WINDOW_PARTS):
            for _ in range(PART_BATCHES // SAMPLE_EVERY * SAMPLE_EVERY):
                self.parties.count()
            self.now[0] += 0.01
            if self.policy.observe(PART_BATCHES, round(PART_BATCHES * caller * 1e3),
                                   round(PART_BATCHES * (batch - caller) * 1e3), shape.home_envs,
                                   parties=self.parties):
                self._place()
                return True
        return False

    def settle(self, windows: int = 12) -> float:
        """Run ``windows`` windows; the true batch time of the layout the policy ends in, over the best."""
        for _ in range(windows):
            self.window()
        return self.machine.batch(self.shapes[self.policy.target])[1] / self.machine.best(self.shapes)


class SimulatedStandIn:
    """A pool whose envs are not safe in the calling process, on an idle machine of ``cores``
    cores: a worker stands in for the caller, and each env costs ``env_us[i]`` wherever it runs.
    Its `ConsolidationPolicy` is fed what such a pool measures (the parent's wait per batch, the
    parties' own stepping times); envs move as soon as it says."""

    def __init__(self, cores: int, env_us: list[float]) -> None:
        slices = plan_workers(len(env_us), None, None, cores)
        self.home, self.worker_slices = slices[-1], slices[:-1]
        self.shapes = layout_shapes(self.worker_slices, len(self.home))
        self.machine = Machine()
        self.policy = ConsolidationPolicy(self.shapes, cores, clock=lambda: self.machine.now, stall_us=self.machine.stall)
        self.env_us = np.array(env_us)
        self.in_caller = np.zeros(len(env_us), dtype=np.uint8)
        self.stepping = np.ones(len(self.worker_slices) + 1, dtype=np.uint8)
        self.env_ns = np.zeros(len(self.worker_slices) + 1, dtype=np.int64)
        self.parties = PartyTimes(self.env_ns, self.in_caller, self.worker_slices, self.stepping)
        self._order = move_order(self.worker_slices)

    def parties_us(self, target: int) -> tuple[list[float], float]:
        """Each worker's stepping and the stand-in's, with ``target`` of the workers' envs in it."""
        held = np.zeros(len(self.env_us), dtype=bool)
        held[self.home.start : self.home.stop] = True
        held[self._order[:target]] = True
        return [float(self.env_us[s.start : s.stop][~held[s.start : s.stop]].sum()) for s in self.worker_slices], \
            float(self.env_us[held].sum())

    def batch(self, target: int) -> float:
        """The true batch time with ``target`` of the workers' envs in the stand-in."""
        workers, stand_in = self.parties_us(target)
        return WAKE_US + max(stand_in, *workers)

    def window(self) -> None:
        target = self.policy.target
        self.in_caller[:] = 0
        self.in_caller[self.home.start : self.home.stop] = 1
        self.in_caller[self._order[:target]] = 1
        workers, stand_in = self.parties_us(target)
        self.stepping[: len(workers)] = [us > 0 for us in workers]
        self.env_ns[:] = [round(us * 1e3) for us in workers] + [round(stand_in * 1e3)]
        for _ in range(WINDOW_PARTS):
            for _ in range(PART_BATCHES // SAMPLE_EVERY * SAMPLE_EVERY):
                self.parties.count()
            self.machine.run(0.01, 0.0)
            if self.policy.observe(PART_BATCHES, 0, round(PART_BATCHES * self.batch(target) * 1e3), 0,
                                   parties=self.parties):
                return

    def settle(self, windows: int = 40) -> float:
        """Run ``windows`` windows; the true batch time of the spread layout the policy ends in, over
        the best spread layout's."""
        for _ in range(windows):
            self.window()
        best = min(self.batch(target) for target in range(self.policy.movable))
        return self.batch(self.policy.spread) / best


@pytest.mark.parametrize("cores", [2, 4, 8, 16])
@pytest.mark.parametrize("heavy_us", [MEDIUM, HEAVY], ids=["100us", "1ms"])
def test_a_stand_in_takes_envs_until_the_parties_finish_together(cores: int, heavy_us: float) -> None:
    """The first worker's envs, or the first half of all envs, cost ``heavy_us``, the rest 5 us:
    the stand-in, planned with light envs only, takes heavy ones where that shortens the batch
    (within the model's margin: on 8 cores half the envs make four heavy workers, which one
    stand-in cannot relieve), and stays spread: one worker for every env would take longer.
    The model knows each party's time, not each env's: an env that moves carries the workers' mean
    cost, so where one worker holds every heavy env it may end a few envs off (8 cores: 18 envs in
    the stand-in, 1.11 times the best batch, which has 12)."""
    num_envs = 4 * cores
    for heavy, margin in ((4, 1.15), (num_envs // 2, 1.1)):
        pool = SimulatedStandIn(cores, [heavy_us if i < heavy else 5.0 for i in range(num_envs)])
        assert pool.settle() <= margin, (heavy, pool.policy.last_decision)
        assert pool.policy.target == pool.policy.spread, pool.policy.last_decision
        if cores == 2:
            assert pool.policy.spread == 2, pool.policy.last_decision  # 220 us against 200 a batch


def test_the_plan_has_a_party_per_core_and_none_beyond_the_envs() -> None:
    for cores in CORES:
        slices = plan_workers(64, None, None, cores)
        assert len(slices) == min(cores, 64)
        assert sum(map(len, slices)) == 64 and max(map(len, slices)) - min(map(len, slices)) <= 1
    assert len(plan_workers(3, None, None, 16)) == 3


@pytest.mark.parametrize("cores", [c for c in CORES if c > 1])
@pytest.mark.parametrize("env_us", [LIGHT, MEDIUM, HEAVY], ids=["light", "100us", "1ms"])
@pytest.mark.parametrize("num_envs", [16, 64, 1024])
def test_on_an_idle_machine_the_layout_ends_within_a_margin_of_the_fastest(
    cores: int, env_us: float, num_envs: int
) -> None:
    pool = SimulatedPool(SimulatedMachine(cores, env_us), num_envs)
    assert pool.settle() <= 1.1, pool.policy.last_decision


@pytest.mark.parametrize("cores", [c for c in CORES if c > 1])
@pytest.mark.parametrize("num_envs", [64, 1024])
def test_light_envs_on_an_idle_machine_keep_their_workers(cores: int, num_envs: int) -> None:
    """The planned layout's workers step in parallel: the caller's time is never taken as theirs, so
    it does not pull envs in (64 light envs on 16 cores once ended with 51 in the caller)."""
    pool = SimulatedPool(SimulatedMachine(cores, LIGHT), num_envs)
    pool.settle()
    caller_envs = pool.shapes[pool.policy.target].home_envs
    assert caller_envs <= 2 * len(pool.caller_slice) + WAKE_US / LIGHT, pool.policy.last_decision
    assert pool.shapes[pool.policy.target].workers == cores - 1


@pytest.mark.parametrize("cores", [2, 4, 8, 16])
def test_light_envs_on_a_crowded_machine_go_to_the_caller(cores: int) -> None:
    """With a busy process per core beside the pool, every worker waits for a core each batch: the
    caller alone steps 64 light envs faster. (The model sees other processes only in what its own
    parties measure: on 64 such cores, one env per party, it predicts the caller alone 1.09 times
    faster, within its margin, where it would be twice as fast.)"""
    pool = SimulatedPool(SimulatedMachine(cores, LIGHT, busy=cores), 64)
    assert pool.settle() <= 1.1
    assert pool.policy.target == pool.policy.movable, pool.policy.last_decision
    assert "envs to the calling process" in pool.policy.last_decision


@pytest.mark.parametrize("cores", [c for c in CORES if c > 1])
def test_heavy_envs_on_a_crowded_machine_stay_spread(cores: int) -> None:
    """1 ms envs lose a turn on a core per batch at most: their workers still win."""
    pool = SimulatedPool(SimulatedMachine(cores, HEAVY, busy=cores), 4 * cores)
    assert pool.settle() <= 1.1
    assert pool.shapes[pool.policy.target].workers >= 1, pool.policy.last_decision


def test_on_one_core_the_caller_steps_every_env_and_nothing_is_decided() -> None:
    assert plan_workers(64, None, None, 1) == [range(64)]


@pytest.mark.parametrize("cores", [2, 4])
def test_costs_that_change_with_the_state_move_the_layout_and_back(cores: int) -> None:
    """A stiff phase makes every env 30 times costlier for a while, then the envs are light again:
    the layout follows each phase to within a margin of its fastest layout, and stays put while a
    phase lasts."""
    machine = SimulatedMachine(cores, LIGHT, busy=cores)
    pool = SimulatedPool(machine, 8 * cores)
    for env_us in (LIGHT, 30 * LIGHT, LIGHT):
        machine.env_us = env_us
        assert pool.settle() <= 1.1, (env_us, pool.policy.last_decision)
        switches = pool.policy.switches
        pool.settle(6)
        assert pool.policy.switches == switches


def test_every_env_in_the_caller_tries_the_workers_again_once_a_core_is_idle() -> None:
    machine = SimulatedMachine(2, LIGHT, busy=2)
    pool = SimulatedPool(machine, 8)
    pool.settle()
    assert pool.policy.target == pool.policy.movable
    pool.now[0] += 10.0
    assert not pool.window()  # no idle core: the caller keeps every env
    pool.idle[0] = 1.0
    assert pool.window() and pool.policy.target == 0 and "idle cores" in pool.policy.last_decision
    # the machine is still crowded: the probe fails, and the next waits twice as long
    assert pool.window() and pool.policy.target == pool.policy.movable
    pool.now[0] += 1.5 * PROBE_FIRST_SECONDS
    assert not pool.window()
    pool.now[0] += PROBE_FIRST_SECONDS
    assert pool.window() and pool.policy.target == 0
    machine.busy = 0  # the machine is idle again: the workers keep their envs
    pool.settle()
    assert pool.policy.target < pool.policy.movable


def test_the_model_predicts_the_slowest_party_and_the_sharing_of_cores() -> None:
    costs = Costs(home_env_us=2.0, worker_env_us=3.0, handover_us=10.0, cores=4, parties=4)
    assert batch_us(costs, Shape(home_envs=4, worker_envs=4, workers=3)) == 22.0  # the workers' side
    assert batch_us(costs, Shape(home_envs=16, worker_envs=0, workers=0)) == 32.0  # the caller alone
    assert batch_us(costs, Shape(home_envs=12, worker_envs=4, workers=3)) == 24.0  # now the caller's
    # measured with 8 parties on 4 cores (each at half speed): 4 parties would step twice as fast
    shared = Costs(2.0, 3.0, 10.0, cores=4, parties=8)
    assert batch_us(shared, Shape(4, 4, 3)) == 16.0
    shapes = [Shape(4, 4, 3), Shape(16, 0, 0)]
    assert best_shape(costs, shapes, current=1, margin=1.1) == 0
    assert best_shape(Costs(2.0, 3.0, 21.0, cores=4, parties=4), shapes, current=1, margin=1.1) == 1  # 33 vs 32
    # a stand-in (home) whose 4 own envs take 5 us each, beside workers' envs of 100 us that move to it
    stand_in = Costs(100.0, 100.0, 0.0, home_offset_us=20.0 - 4 * 100.0, cores=2, parties=2)
    assert batch_us(stand_in, Shape(4, 4, 1)) == 400.0  # the worker's side
    assert batch_us(stand_in, Shape(6, 2, 1)) == 220.0  # the stand-in's: 20 us and two moved envs


def test_layout_shapes_follow_the_move_order() -> None:
    slices = [range(3), range(3, 6)]
    shapes = layout_shapes(slices, home_envs=2)
    assert list(move_order(slices)) == [2, 5, 1, 4, 0, 3]
    assert shapes[0] == Shape(2, 3, 2) and shapes[1] == Shape(3, 3, 2) and shapes[2] == Shape(4, 2, 2)
    assert shapes[5] == Shape(7, 1, 1) and shapes[6] == Shape(8, 0, 0)
