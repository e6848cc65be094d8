"""Where each env of a pool is stepped, and the adaptive layout that moves envs at episode boundaries.

A pool that plans its own layout steps the last slice of envs in the calling process and the
others in workers (`modelicagym.vector.layout.plan`). On an idle machine that is the fastest layout. On a
crowded one (another busy process, a second training beside this one) a worker may not get a core
when the batch needs it, and a light env's batch then waits tens of microseconds to milliseconds
for a step that takes one: stepping every env in the calling process, in one C call, is faster.
Which layout wins depends on the env's step cost and on the cores actually free, so the pool
measures both and moves envs between the two layouts while it runs.

**Who steps an env** is the shared ``in_caller`` array: 1 where the calling process steps the env,
0 where its worker does. Every native slice steps exactly the envs placed with it, so a move is one
byte written by the parent between two steps. An adaptive pool keeps a second copy of each worker
env in the calling process; resets, ``call`` and ``set_attr`` reach both copies, so they differ only
in the episode under way.

**Moving an env** happens only at an episode boundary, where its two copies agree: right after a
reset of the pool (both copies were reset alike), or after the step that ended its episode, when
the env's reset does not depend on where it runs (``env.reset_is_deterministic``: no random
parameters). In ``NEXT_STEP`` mode its next step is its reset wherever it runs (``needs_reset``
is already set); in ``SAME_STEP`` mode the old copy has already reset, so the new one resets
silently before its next step (`RESET_THEN_STEP`). ``DISABLED`` moves envs only at resets. Every
env's trajectory is therefore exactly the one `SyncVectorEnv` gives it, whatever layout runs.

**The policy** (`modelicagym.vector.layout.policy.LayoutPolicy`; docs/design.md, "The cost
model"): while workers step, the parent measures each batch's time stepping its own slice and then
waiting for the workers, in C, and the workers time their own stepping. Over a window of batches,
a cost model predicts the batch time of every target (`layout_shapes`: how many envs the caller
steps, how many the busiest worker, how many workers step) and the pool moves to the fastest by a
margin. While the caller steps everything, the workers sleep; when a core has been idle for a while
(``/proc/stat``), the envs move back to their workers on probation: the same measurement decides
again. A probe that fails waits twice as long before the next.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Protocol

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode

from modelicagym.errors import ConfigError
from modelicagym.native.abi import RESET_THEN_STEP
from modelicagym.vector.errors import PoolMemoryError
from modelicagym.vector.layout.affinity import PartiesApart
from modelicagym.vector.layout.cost_model import PartyTimes, Shape
from modelicagym.vector.layout.machine_load import ForeignLoad
from modelicagym.vector.layout.policy import ConsolidationPolicy, LayoutPolicy
from modelicagym.vector.slice.creation import close_envs, create_envs
from modelicagym.vector.slice.env_slice import EnvSlice, movable_reason
from modelicagym.vector.wire.buffers import SharedBuffers
from modelicagym.vector.wire.protocol import EnvDescription, StepPath, WorkerConfig
from modelicagym.vector.wire.sync import pool_native_library

__all__ = [
    "NOT_SAFE_IN_CALLER",
    "LayoutState",
    "Placement",
    "Workers",
    "layout_shapes",
    "move_order",
    "no_stand_in_reason",
    "place_envs",
    "stand_in_fixed_reason",
]

#: the policy's measurements come in parts of this many batches (summed in C)
PART_BATCHES = 64


class _Held(Protocol):
    """A worker, as placing envs sees it: the envs it holds."""

    @property
    def env_indices(self) -> range:
        """The contiguous range of env indices it holds."""


class Workers(Protocol):
    """What placing envs reads of the pool's workers (`modelicagym.vector.dispatch.worker_set.WorkerSet`,
    started and connected before the envs are placed)."""

    @property
    def handles(self) -> Sequence[_Held]:
        """One per worker, in slot order (a stand-in worker the last)."""

    @property
    def buffers(self) -> SharedBuffers:
        """The pool's shared memory."""

    @property
    def step_paths(self) -> Sequence[StepPath]:
        """Per env, the path its slice steps on."""

    def unsafe_in_caller(self) -> int | None:
        """The first env of the first worker whose envs are not all safe in the calling process, or ``None``."""


@dataclass(frozen=True)
class LayoutState:
    """Where the envs of a pool run now, and why (``PoolVectorEnv.layout``)."""

    #: the pool moves envs between its workers and the calling process as conditions change
    adaptive: bool
    #: why the layout adapts, or why it cannot
    reason: str
    #: envs the calling process (or the worker standing in for it) is to step (it gets them at
    #: their next episode boundaries)
    target_in_caller: int
    #: envs the calling process steps now, of ``num_envs``
    envs_in_caller: int
    num_envs: int
    #: workers that step at least one env now, of ``num_workers``
    workers_stepping: int
    num_workers: int
    #: changes of target so far
    switches: int
    #: the measurement behind the last change of target (empty before the first)
    last_decision: str
    #: envs the worker standing in for the calling process steps now (where the calling process may
    #: not step the envs: `modelicagym.vector.dispatch.assembly`), of ``num_envs``
    envs_in_stand_in: int = 0
    #: that worker, for messages ("" without one)
    stand_in: str = ""

    def __str__(self) -> str:
        kind = "adaptive" if self.adaptive else "fixed"
        held = f"{self.envs_in_stand_in}/{self.num_envs} envs in {self.stand_in}, " if self.stand_in else ""
        where = (f"{held}{self.envs_in_caller}/{self.num_envs} envs in the calling process, "
                 f"{self.workers_stepping}/{self.num_workers} workers stepping")
        decision = f"; last change: {self.last_decision}" if self.last_decision else ""
        return f"{kind} layout ({self.reason}): {where}{decision}"


class Placement:
    """Which process steps each env (the shared ``in_caller`` array), and the moves of an adaptive layout.

    Args:
        in_caller, needs_reset: the pool's shared arrays of that name.
        worker_slices: the envs of each worker; ``caller_slice``: the calling process's own, or ``None``.
        autoreset_mode: the pool's.
        policy: the adaptive layout's policy, or ``None`` (a fixed layout).
        reason: why the layout adapts or why it does not.
        stand_in: the envs marked ``in_caller`` are stepped by one more worker, after those of
            ``worker_slices``, that holds a copy of every env (`modelicagym.vector.dispatch.assembly`),
            rather than by the calling process.
        env_ns: for an adaptive layout, the pool's ``timing[:, ENV_NS]``: the parties' stepping
            times are sampled from it for the policy (`modelicagym.vector.layout.cost_model.PartyTimes`).
    """

    def __init__(
        self,
        in_caller: np.ndarray,
        needs_reset: np.ndarray,
        worker_slices: list[range],
        caller_slice: range | None,
        autoreset_mode: AutoresetMode,
        policy: LayoutPolicy | ConsolidationPolicy | None,
        reason: str,
        stand_in: bool = False,
        env_ns: np.ndarray | None = None,
        apart: PartiesApart | None = None,
    ) -> None:
        self.in_caller = in_caller
        self._apart = apart
        self.needs_reset = needs_reset
        self.policy = policy
        self.reason = reason
        self._worker_slices = worker_slices
        self._same_step = autoreset_mode is AutoresetMode.SAME_STEP
        self._at_steps = autoreset_mode is not AutoresetMode.DISABLED
        in_caller[:] = 0
        if caller_slice is not None:
            in_caller[caller_slice.start : caller_slice.stop] = 1
        #: per worker, uint8: it steps at least one env (only those are woken for a step); a
        #: stand-in always steps its own slice
        self.stepping = np.ones(len(worker_slices) + stand_in, dtype=np.uint8)
        self._stand_in = f"worker {len(worker_slices)} (standing in for the calling process)" if stand_in else ""
        self._movable = np.zeros(len(in_caller), dtype=np.bool_)
        #: the movable envs in the order they go to the caller (`move_order`)
        self._order = move_order(worker_slices)
        #: per env, 1 where the policy wants it in the caller
        self._want = in_caller.copy()
        if policy is not None:
            self._movable[self._order] = True
        self._settled = True
        self._pending: np.ndarray | None = None
        #: steps until the next window of measurements is taken in (and the pool looks at the machine,
        #: which a stand-in's polling depends on); a fixed layout without a stand-in never is
        self._countdown = PART_BATCHES if policy is not None or stand_in else 1 << 62
        self._caller_envs = int(in_caller.sum())
        self._party_times = (None if env_ns is None or policy is None
                             else PartyTimes(env_ns, in_caller, worker_slices, self.stepping, stand_in))
        #: the party times while a worker steps (they sample nothing otherwise), else ``None``
        self._sampling = self._party_times

    @property
    def samples_parties(self) -> bool:
        """Whether the parties must time their steps now (``timing_enabled``) for the layout policy
        (`cost_model.PartyTimes`): while a worker steps. With every env at home, nothing is timed
        (for 2 light envs, 0.1-0.2 us a batch)."""
        return self._sampling is not None

    @property
    def adaptive(self) -> bool:
        return self.policy is not None

    def state(self) -> LayoutState:
        """What runs where now, and why."""
        policy = self.policy
        held = int(self.in_caller.sum())
        return LayoutState(
            self.adaptive, self.reason, int(self._want.sum()), 0 if self._stand_in else held, len(self.in_caller),
            int(self.stepping[: len(self._worker_slices)].sum()), len(self._worker_slices),
            0 if policy is None else policy.switches, "" if policy is None else policy.last_decision,
            held if self._stand_in else 0, self._stand_in,
        )

    def due(self) -> bool:
        """Count a step; whether :meth:`after_step` has work after it: a window of measurements
        is complete, or envs wait to move (cheap: the pool asks after every step)."""
        self._countdown -= 1
        if self._sampling is not None:
            self._sampling.count()
        return self._countdown <= 0 or not self._settled

    def after_step(
        self, terminations: np.ndarray, truncations: np.ndarray, take_times: Callable[[], tuple[int, int, int] | None]
    ) -> None:
        """Account the batches measured since the last call (``take_times``: the dispatcher's), and
        plan to move the envs this step ended that belong elsewhere. The move happens when the next
        step starts (:meth:`move_pending`): until then ``call`` and ``get_attr`` still see the copy
        that ended the episode, as ``SyncVectorEnv`` would show it."""
        if self._countdown <= 0:
            self._countdown = PART_BATCHES
            times = take_times()
            policy = self.policy
            parties = {} if self._party_times is None else {"parties": self._party_times}
            if times is not None and policy is not None and policy.observe(*times, self._caller_envs, self._settled,
                                                                          **parties):
                self._retarget()
            if self._apart is not None:
                self._apart.keep(policy.apart, policy.home_slower)
        if not self._settled and self._at_steps:
            self._pending = self._movers(terminations | truncations)

    @property
    def caller_cpu(self) -> int | None:
        """The CPU the calling thread steps its slice on while the parties are apart (else ``None``)."""
        return None if self._apart is None else self._apart.caller_cpu

    @property
    def pending(self) -> bool:
        """Whether envs wait to move when the next step starts."""
        return self._pending is not None

    def move_pending(self) -> bool:
        """Move the envs planned by :meth:`after_step` (the next step is about to start); ``True``
        when a worker starts or stops stepping (the dispatcher must know)."""
        movers, self._pending = self._pending, None
        return self._move(movers, RESET_THEN_STEP if self._same_step else None)

    def after_reset(self, reset: np.ndarray) -> bool:
        """Move the envs just reset, both copies alike, that belong elsewhere (now: the copies are
        the same); drops the moves planned after the last step. As :meth:`move_pending`."""
        self._pending = None
        if self.policy is None or self._settled:
            return False
        return self._move(self._movers(reset), None)

    def _retarget(self) -> None:
        """Take in the policy's new target: the first ``target`` envs of the order go to the caller."""
        self._want[self._order] = 0
        self._want[self._order[: self.policy.target]] = 1
        self._settled = False

    def _movers(self, at_boundary: np.ndarray) -> np.ndarray:
        """The movable envs at a boundary that are not where the policy wants them; notes whether
        any is left to move later."""
        away = self._movable & (self.in_caller != self._want)
        movers = away & at_boundary
        self._settled = not (away & ~movers).any()
        return movers

    def _move(self, movers: np.ndarray, needs_reset: int | None) -> bool:
        if not movers.any():
            return False
        if needs_reset is not None:
            self.needs_reset[movers] = needs_reset
        self.in_caller[movers] = self._want[movers]
        self._caller_envs = int(self.in_caller.sum())
        stepping = [not self.in_caller[s.start : s.stop].all() for s in self._worker_slices]
        if np.array_equal(stepping, self.stepping[: len(stepping)]):
            return False
        self.stepping[: len(stepping)] = stepping
        self._sampling = self._party_times if any(stepping) else None
        return True


def move_order(worker_slices: list[range]) -> np.ndarray:
    """The workers' envs in the order they go to the caller: the last env of every worker, then the
    one before, ... (so that the workers give up envs evenly and keep stepping in parallel)."""
    return np.array([s[-1 - k] for k in range(max(map(len, worker_slices), default=0))
                     for s in worker_slices if k < len(s)], dtype=np.int64)


def layout_shapes(worker_slices: list[range], home_envs: int) -> list[Shape]:
    """Per target of an adaptive layout (envs of `move_order` in the caller, 0 to all), the layout
    it makes, as the cost model sees it (`modelicagym.vector.layout.cost_model.Shape`)."""
    held = [len(s) for s in worker_slices]
    owner = {env: k for k, s in enumerate(worker_slices) for env in s}
    shapes = [Shape(home_envs, max(held, default=0), sum(n > 0 for n in held))]
    for moved, env in enumerate(move_order(worker_slices), start=1):
        held[owner[int(env)]] -= 1
        shapes.append(Shape(home_envs + moved, max(held), sum(n > 0 for n in held)))
    return shapes


def place_envs(
    env_fns: Sequence[Callable[[], gym.Env]],
    workers: Workers,
    local: EnvSlice | None,
    config: WorkerConfig,
    adapt_layout: bool | None,
    stand_in_slice: range | None = None,
    isolated: str | None = None,
    trusted: bool = False,
) -> tuple[Placement, EnvSlice | None]:
    """The placement of a pool's envs (``config``: the pool's, for its autoreset mode and cores), and
    the calling process's slice: for an adaptive layout,
    every env (copies of the worker envs, then its own). With a stand-in worker (the last one, for
    envs not safe in the calling process), that worker steps ``stand_in_slice`` instead, and
    consolidates the envs when that is faster. ``isolated`` says why every env is in a worker,
    with no stand-in (given whenever ``local`` is ``None`` without one). ``trusted``: the user put
    envs in the calling process (``caller_steps=True``), so it may hold copies of the workers' envs
    too, safe there or not. Raises `ConfigError` if ``adapt_layout=True`` cannot be, saying why."""
    autoreset_mode = config.autoreset_mode
    if stand_in_slice is not None:
        return _place_with_stand_in(workers, stand_in_slice, config, adapt_layout), None
    buffers = workers.buffers
    caller_slice = None if local is None else local.env_indices
    reason = isolated or _fixed_layout_reason(workers, local, adapt_layout, trusted)
    if reason is None:
        copies: list[gym.Env] = []
        try:
            copies = create_envs(env_fns[: local.first], 0, "the calling process (copies of the workers' envs)")
            reason = movable_reason(copies, "a copy of env {} in the calling process")
            if reason is None:
                local.detach()
                local = EnvSlice(copies + local.envs, 0, local.slot, autoreset_mode, caller=True)
                local.attach(buffers, needs_reset=False)
        except PoolMemoryError as error:
            reason = f"copies of the workers' envs in the calling process would not fit in memory: {error}"
        except BaseException:
            close_envs(copies)
            raise
        if reason is not None:
            close_envs(copies)
    _refuse_adapt_layout(reason, adapt_layout)
    worker_slices = [handle.env_indices for handle in workers.handles]
    policy = env_ns = apart = None
    if reason is None:
        worker_pids = [handle.process.pid for handle in workers.handles]
        policy = LayoutPolicy(layout_shapes(worker_slices, len(caller_slice)), config.cores,
                              foreign_cores=ForeignLoad(lambda: [os.getpid(), *worker_pids]))
        env_ns = buffers.timing[:, SharedBuffers.ENV_NS]
        reason = "its envs can move between the workers and the calling process at episode boundaries"
        apart = PartiesApart(worker_pids, config.cpus)
    placement = Placement(
        buffers.in_caller, buffers.needs_reset, worker_slices, caller_slice, autoreset_mode, policy, reason,
        env_ns=env_ns, apart=apart,
    )
    return placement, local


def _place_with_stand_in(workers: Workers, home: range, config: WorkerConfig, adapt_layout: bool | None) -> Placement:
    """The placement of a pool whose calling process steps nothing: a worker stands in for it,
    with a copy of every env, and steps ``home``; it takes every env when that is faster (the
    pool made it only for a layout that can adapt: `stand_in_fixed_reason`); with no other worker to
    share them (one core), it steps them all in a fixed layout."""
    worker_slices = [handle.env_indices for handle in workers.handles[:-1]]
    buffers = workers.buffers
    if not worker_slices:  # one party for one core: nothing to move
        reason = NOT_SAFE_IN_CALLER + (f"one worker steps them all, the pool's one party for {len(home)} env(s) on "
                           f"{config.cores} core(s)")
        _refuse_adapt_layout(reason, adapt_layout)
        return Placement(buffers.in_caller, buffers.needs_reset, [], home, config.autoreset_mode, None, reason,
                         stand_in=True)
    policy = ConsolidationPolicy(layout_shapes(worker_slices, len(home)), config.cores)
    return Placement(buffers.in_caller, buffers.needs_reset, worker_slices, home, config.autoreset_mode, policy,
                     NOT_SAFE_IN_CALLER + "they can move to one worker at episode boundaries", stand_in=True,
                     env_ns=buffers.timing[:, SharedBuffers.ENV_NS])


#: why every env is in a worker where the envs do not all say they are safe in the calling process
NOT_SAFE_IN_CALLER = ("every env is in a worker: its envs do not all say they are safe in the calling process "
                      "(safe_in_caller; caller_steps=True puts a slice there); ")


def no_stand_in_reason(fixed: str) -> str:
    """Why every env is in a plain worker, none standing in for the calling process: its envs are not
    safe there, and a stand-in serves only a layout that adapts, which this one cannot (``fixed``: why)."""
    return NOT_SAFE_IN_CALLER + f"no worker stands in for it, as the layout does not adapt: {fixed}"


def _refuse_adapt_layout(reason: str | None, adapt_layout: bool | None) -> None:
    """Raise `ConfigError` where ``adapt_layout=True`` asks for a layout that cannot adapt (``reason``: why)."""
    if reason is not None and adapt_layout:
        raise ConfigError(f"adapt_layout=True, but the layout cannot adapt: {reason}")


def _never_adapts_reason(adapt_layout: bool | None) -> str | None:
    """Why no layout of this pool adapts, whatever its envs (``None``: one may)."""
    if adapt_layout is False:
        return "adapt_layout=False"
    if pool_native_library() is None:
        return "no native library: the pool signals through semaphores"
    return None


def stand_in_fixed_reason(description: EnvDescription, adapt_layout: bool | None) -> str | None:
    """Why a layout with a stand-in worker whose envs ``description`` describes could not adapt
    (``None``: it can)."""
    return _never_adapts_reason(adapt_layout) or description.movable_reason


def _fixed_layout_reason(workers: Workers, local: EnvSlice, adapt_layout: bool | None,
                         trusted: bool = False) -> str | None:
    """Why the layout of a pool whose calling process steps ``local`` cannot adapt (``None``: it
    can), before any copy is made (``trusted``: as `place_envs`)."""
    if not workers.handles:
        return "num_workers=0: every env is in the calling process"
    never = _never_adapts_reason(adapt_layout)
    if never is not None:
        return never
    unsafe = None if trusted else workers.unsafe_in_caller()
    if unsafe is not None:
        return (f"env {unsafe} does not say it is safe in the calling process (safe_in_caller), so no copy of it "
                "is made there")
    paths = {path for path in workers.step_paths if path.path != "native"}
    if paths:
        return f"an env steps on the Python path: {next(iter(paths)).reason}"
    return movable_reason(local.envs, "env {}", local.first)
