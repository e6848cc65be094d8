"""Where each env of a pool is stepped, and the adaptive layout that moves envs at episode boundaries.

A pool that plans its own layout steps the last slice of envs in the calling process and the
others in workers (`modelicagym.vector.plan`). On an idle machine that is the fastest layout. On a
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

**The policy** (`LayoutPolicy`; docs/design.md, "The adaptive layout", has the measurements): while
workers step, the parent measures each batch's time stepping its own slice and then waiting for the
workers, in C. Over a window of batches, the time per env of its own slice predicts what stepping
every env itself would cost; if the batches took more than that (by a margin), every env moves to
the calling process. While the caller steps everything, the workers sleep; when a core has been
idle for a while (``/proc/stat``), the envs move back to their workers on probation: the same
measurement decides again. A probe that fails waits twice as long before the next.
"""

from __future__ import annotations

import logging
import os
import statistics
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from gymnasium.vector import AutoresetMode

from modelicagym.native.batch import RESET_THEN_STEP

__all__ = ["LayoutPolicy", "LayoutState", "Placement"]

logger = logging.getLogger(__name__)

#: the policy measures in parts of this many batches (summed in C), and decides on the median part
#: of a window of at least this many parts and seconds (a median, so that one batch that met a
#: page fault or a preemption cannot decide)
PART_BATCHES = 64
WINDOW_PARTS = 5
WINDOW_SECONDS = 0.02
#: the workers' batches must cost more than this times the caller's own estimate to be given up
MARGIN = 1.1
#: seconds the caller steps everything before the first probe of the workers, and at most
PROBE_FIRST_SECONDS = 0.5
PROBE_MAX_SECONDS = 30.0
#: idle cores (averaged since the last look) that make a probe of the workers worth it
IDLE_CORES_TO_PROBE = 0.5


@dataclass(frozen=True)
class LayoutState:
    """Where the envs of a pool run now, and why (``PoolVectorEnv.layout``)."""

    #: the pool moves envs between its workers and the calling process as conditions change
    adaptive: bool
    #: why the layout adapts, or why it cannot
    reason: str
    #: envs the calling process is to step (it gets them at their next episode boundaries)
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

    def __str__(self) -> str:
        kind = "adaptive" if self.adaptive else "fixed"
        where = (f"{self.envs_in_caller}/{self.num_envs} envs in the calling process, "
                 f"{self.workers_stepping}/{self.num_workers} workers stepping")
        decision = f"; last change: {self.last_decision}" if self.last_decision else ""
        return f"{kind} layout ({self.reason}): {where}{decision}"


class LayoutPolicy:
    """Decides, from what batches cost, how many movable envs the calling process steps.

    ``target`` is that number: 0 is the planned layout (every movable env in its worker),
    ``movable`` is every env in the caller. From a window's median part it estimates the cost of an
    env in the caller (its own slice's time per env) and in the workers (the batch's time, when the
    caller waited for them, over their envs: their share of a core and the wake-ups included), and
    picks the split that balances both sides; every env goes to the caller unless a split is
    predicted faster by `MARGIN`. A light env on a crowded machine ends there (its workers' time is
    mostly waking up); a heavy one beside a busy process ends balanced (its worker has half a core).

    Args:
        movable: envs that may move (the workers' envs); ``home``: the caller's own.
        cores: the cores this process may use (for the idle-core reading).
        clock: seconds, monotonic (a parameter for tests).
        idle_cores: idle cores since the last call (a parameter for tests; default reads ``/proc/stat``).
    """

    def __init__(
        self,
        movable: int,
        home: int,
        cores: int,
        clock: Callable[[], float] = time.monotonic,
        idle_cores: Callable[[], float] | None = None,
    ) -> None:
        self.movable, self.home = movable, home
        self.target = 0
        self.switches = 0
        self.last_decision = ""
        self._clock = clock
        self._idle_cores = idle_cores or IdleCores(cores)
        self._probe_wait = PROBE_FIRST_SECONDS
        self._probing = False
        self._switched_at = clock()
        self._window()

    def _window(self) -> None:
        #: per part: (microseconds a batch took, microseconds an env took in the caller)
        self._parts: list[tuple[float, float]] = []
        self._envs = (0, 0)
        self._window_start = self._clock()

    def observe(self, batches: int, local_ns: int, wait_ns: int, local_envs: int, all_envs: int) -> bool:
        """Account a part of ``batches`` batches: ``local_ns`` stepping ``local_envs`` envs a batch
        in the caller, then ``wait_ns`` waiting for the workers, ``all_envs`` envs a batch in all;
        ``True`` when the target changed."""
        if batches and local_envs:
            self._parts.append(((local_ns + wait_ns) / batches / 1e3, local_ns / (local_envs * batches) / 1e3))
            self._envs = (local_envs, all_envs)
        now = self._clock()
        in_caller = self.target == self.movable
        if now - self._window_start < WINDOW_SECONDS or (not in_caller and len(self._parts) < WINDOW_PARTS):
            return False
        changed = self._probe(now) if in_caller else self._balance(now)
        self._window()
        return changed

    def _probe(self, now: float) -> bool:
        """Every env is in the caller: try the workers again once a core has been idle."""
        if now - self._switched_at < self._probe_wait:
            return False
        idle = self._idle_cores()
        if idle < IDLE_CORES_TO_PROBE:
            return False
        self._probing = True
        return self._switch(0, now, f"{idle:.1f} idle cores: the workers are tried again")

    def _balance(self, now: float) -> bool:
        """The split of the window's median part's costs that gives the shortest batch."""
        local_envs, all_envs = self._envs
        worker_envs = all_envs - local_envs
        if not self._parts or worker_envs <= 0:
            return False
        batch_us = statistics.median(part[0] for part in self._parts)
        env_us = statistics.median(part[1] for part in self._parts)
        local_us = env_us * local_envs
        # the workers' time per env: the batch's, if the caller waited for them; else at most the caller's
        worker_env_us = (batch_us if batch_us > 1.05 * local_us else local_us) / worker_envs
        alone_us = env_us * all_envs

        def batch(in_caller: int) -> float:
            return max(in_caller * env_us, (all_envs - in_caller) * worker_env_us)

        balanced = all_envs * worker_env_us / (env_us + worker_env_us)
        in_caller = min(max(round(balanced), self.home), all_envs)
        if in_caller < all_envs and MARGIN * batch(in_caller) >= alone_us:
            in_caller = all_envs
        target = in_caller - self.home
        if target == self.movable:
            if self._probing:
                self._probing, self._probe_wait = False, min(2 * self._probe_wait, PROBE_MAX_SECONDS)
            self._idle_cores()  # the idle-core reading starts now
            return self._switch(target, now, f"a batch took {batch_us:.1f} us with the workers; the calling "
                                             f"process alone would take {alone_us:.1f} us")
        if self._probing:
            self._probing, self._probe_wait = False, PROBE_FIRST_SECONDS
        current = self.home + self.target
        if target == self.target or batch(in_caller) > 0.95 * batch(current):
            return False
        return self._switch(target, now, f"an env takes {env_us:.1f} us in the calling process and "
                                         f"{worker_env_us:.1f} us in the workers: {in_caller}/{all_envs} envs "
                                         f"in the calling process balance them")

    def _switch(self, target: int, now: float, why: str) -> bool:
        self.target, self._switched_at = target, now
        self.switches += 1
        self.last_decision = f"{self.home + target} envs to the calling process: {why}"
        logger.debug("pool layout: %s", self.last_decision)
        return True


class IdleCores:
    """Idle cores of the machine since the last call, averaged (``/proc/stat``; all of them where it
    cannot be read, so that the policy still probes, as its back-off allows)."""

    def __init__(self, cores: int) -> None:
        self._cores = cores
        self._machine_cores = os.cpu_count() or cores
        self._last = self._read()

    def __call__(self) -> float:
        now = self._read()
        last, self._last = self._last, now
        if now is None or last is None or now[1] <= last[1]:
            return float(self._cores)
        return self._machine_cores * (now[0] - last[0]) / (now[1] - last[1])

    def _read(self) -> tuple[int, int] | None:
        """(idle, total) jiffies of all CPUs."""
        try:
            with open("/proc/stat", "rb") as handle:
                fields = handle.readline().split()[1:]
        except OSError:
            return None
        values = [int(f) for f in fields]
        return values[3] + values[4], sum(values[:8])


class Placement:
    """Which process steps each env (the shared ``in_caller`` array), and the moves of an adaptive layout.

    Args:
        in_caller, needs_reset: the pool's shared arrays of that name.
        worker_slices: the envs of each worker; ``caller_slice``: the calling process's own, or ``None``.
        autoreset_mode: the pool's.
        policy: the adaptive layout's policy, or ``None`` (a fixed layout).
        reason: why the layout adapts or why it does not.
    """

    def __init__(
        self,
        in_caller: np.ndarray,
        needs_reset: np.ndarray,
        worker_slices: list[range],
        caller_slice: range | None,
        autoreset_mode: AutoresetMode,
        policy: LayoutPolicy | None,
        reason: str,
    ) -> None:
        self.in_caller = in_caller
        self.needs_reset = needs_reset
        self.policy = policy
        self.reason = reason
        self._worker_slices = worker_slices
        self._same_step = autoreset_mode is AutoresetMode.SAME_STEP
        self._at_steps = autoreset_mode is not AutoresetMode.DISABLED
        in_caller[:] = 0
        if caller_slice is not None:
            in_caller[caller_slice.start : caller_slice.stop] = 1
        #: per worker, uint8: it steps at least one env (only those are woken for a step)
        self.stepping = np.ones(len(worker_slices), dtype=np.uint8)
        self._movable = np.zeros(len(in_caller), dtype=np.bool_)
        #: the movable envs in the order they go to the caller: the last env of every worker, then
        #: the one before, ... (so that the workers give up envs evenly)
        self._order = np.array([s[-1 - k] for k in range(max(map(len, worker_slices), default=0))
                                for s in worker_slices if k < len(s)], dtype=np.int64)
        #: per env, 1 where the policy wants it in the caller
        self._want = in_caller.copy()
        if policy is not None:
            self._movable[self._order] = True
        self._settled = True
        self._pending: np.ndarray | None = None
        #: steps until the next window of measurements is taken in; a fixed layout never is
        self._countdown = PART_BATCHES if policy is not None else 1 << 62
        self._caller_envs = int(in_caller.sum())

    @property
    def adaptive(self) -> bool:
        return self.policy is not None

    def state(self) -> LayoutState:
        """What runs where now, and why."""
        policy = self.policy
        return LayoutState(
            self.adaptive, self.reason, int(self._want.sum()), int(self.in_caller.sum()),
            len(self.in_caller), int(self.stepping.sum()), len(self.stepping),
            0 if policy is None else policy.switches, "" if policy is None else policy.last_decision,
        )

    def due(self) -> bool:
        """Count a step; whether :meth:`after_step` has work after it: a window of measurements
        is complete, or envs wait to move (cheap: the pool asks after every step)."""
        self._countdown -= 1
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
            if times is not None and self.policy.observe(*times, self._caller_envs, len(self.in_caller)):
                self._retarget()
        if not self._settled and self._at_steps:
            self._pending = self._movers(terminations | truncations)

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
        stepping = np.array([not self.in_caller[s.start : s.stop].all() for s in self._worker_slices], dtype=np.uint8)
        if np.array_equal(stepping, self.stepping):
            return False
        self.stepping[:] = stepping
        return True
