"""How many envs the calling process of an adaptive pool should step: measured, not assumed.

`LayoutPolicy` is the decision half of the adaptive layout (`modelicagym.vector.layout.placement` moves
the envs): it takes in what batches cost, part by part, and says how many of the workers' envs
the calling process should step. docs/design.md ("The adaptive layout") has the measurements
behind it.
"""

from __future__ import annotations

import logging
import statistics
import time
from collections.abc import Callable
from dataclasses import replace

from modelicagym.vector.layout.cost_model import Costs, PartyCosts, PartyTimes, Shape, best_shape
from modelicagym.vector.layout.cost_model import batch_us as batch_us_of
from modelicagym.vector.layout.machine_load import (
    FOREIGN_CORES_TO_SHARE,
    IDLE_CORES_TO_PROBE,
    READ_EVERY,
    TRUST_QUIET_FOR,
    TRUST_STALL_SHARE,
    IdleCores,
    MachineWatch,
)

__all__ = ["ConsolidationPolicy", "LayoutPolicy"]

logger = logging.getLogger(__name__)

#: the policy decides on the median part (of `modelicagym.vector.layout.placement.PART_BATCHES` batches)
#: of a window of at least this many parts and seconds (a median, so that one batch that met a
#: page fault or a preemption cannot decide)
WINDOW_PARTS = 5
WINDOW_SECONDS = 0.02
#: the workers' batches must cost more than this times the caller's own estimate to be given up
MARGIN = 1.1
#: seconds the caller steps everything before the first probe of the workers, and at most
PROBE_FIRST_SECONDS = 0.5
PROBE_MAX_SECONDS = 30.0
#: the share of the time a consolidation policy's tries that fail may cost: after one, the next try
#: waits at least ``1 / TRY_SHARE - 1`` times what it cost. Envs move only at episode boundaries,
#: so a failed try runs up to a whole episode in the slower layout before they are back: for 8
#: envs of ~1 ms a step and 500-step episodes, 4 s of every try at half speed (a pool of 8 ran at
#: 0.98x a single env in 5 s rounds, idle, where the spread layout alone does 1.9x)
TRY_SHARE = 0.05
#: on a shared machine, the batch (us) from which the stepping parties keep to CPUs of their own: the
#: calling thread pins itself around its own stepping, ~6 us a batch on this project's VM (5% of it)
APART_BATCH_US = 120.0
#: a try of the parties apart (or together again) stays if a batch's wall time is this much shorter
#: (at 3%, two heavy pools kept apart on a window's noise: their rates move ±10% from one 0.5 s to the next)
APART_MARGIN = 1.1
#: a try of the parties apart (or together) is judged on the mean wall time of this many windows, against
#: the median of `WALL_WINDOWS` before it (one window of 8 heavy envs beside a busy process, ~0.2 s,
#: moves ±12% in one layout)
APART_WINDOWS = 2
#: a try of every env in the caller, or of the other choice of the parties apart, must beat the median
#: wall time of the last this many windows of the layout it leaves: beside a busy process, one window of
#: 8 heavy envs with the parties apart read 820 us a batch among 470-530, and every env at home (610
#: us, 1.1x one env where that layout makes 1.25x) was tried on it and kept
WALL_WINDOWS = 3
#: a try of the parties apart (or together) moves the layout at most this many times before it is judged
APART_MOVES = 3
#: a part whose batches took this many times the wall time of the part before, workers stepping, held a
#: pause of the caller's (an evaluation, a learner's update between rollouts, another candidate's turn in
#: a benchmark): its window and the next are dropped, and a running try's cost leaves the pause out. A
#: try of the parties apart charged the 3 s between two of the benchmark's rounds waited 65 s before the
#: next, kept together at 1.01x one env; the first window after a pause, the kernel still placing the
#: neighbour, read 601 us a batch where the layout takes 500, and moved it
PAUSE_FACTOR = 10.0
#: apart, the workers' side over their stepping before it is measured: a worker sharing its CPU with
#: one busy process gets half of it (measured beside one: 3.1-3.9)
STRETCH_FIRST = 2.0
#: apart, the workers' stretch is the median of the last this many windows where the caller waited for
#: them: one window moves it ±20% (beside a busy process, one window's 3.7 among 2.8-3.2 moved 6 envs
#: at home to 7, where the pool made 1.15-1.18x one env against 1.26x)
STRETCH_WINDOWS = 5
#: apart, the calling thread takes a worker's CPU where its envs step this many times slower than the
#: workers' (it shares its CPU with the neighbour: 150 us against 75 us; apart and alone, within 20%;
#: 1.3 swapped more often in `bench shared` and was not faster)
APART_SWAP = 1.5


class _Policy:
    """What both policies share: the layouts they choose among (``shapes``: per target, the layout
    it makes as the cost model sees it, `modelicagym.vector.layout.placement.layout_shapes`), the
    target they are in, the window of parts they measure, and the record of each change."""

    #: the home party, as the record of a change names it
    HOME = ""

    def __init__(self, shapes: list[Shape], cores: int, clock: Callable[[], float],
                 stall_us: Callable[[], int | None] | None) -> None:
        self.shapes = shapes
        self.movable, self.home = len(shapes) - 1, shapes[0].home_envs
        self.cores = cores
        self.target = 0
        self.switches = 0
        self.last_decision = ""
        self._clock = clock
        self._probe_wait = PROBE_FIRST_SECONDS
        self._switched_at = clock()
        self._stall_us = stall_us
        self._quiet: Callable[[], bool] | None = None
        #: when the policy's own watch started (it cannot tell a quiet machine for a while)
        self._watch_started: float | None = None
        #: while a try's window runs: the batch time of the layout it left, and that layout's target
        self._left_us: float | None = None
        self._left_target = 0
        #: when the last try started, and whether it failed and its envs are on their way back
        self._try_started = 0.0
        self._given_up = False
        self._window()

    def _window(self) -> None:
        """Start a window: its parts (per part, in microseconds) and the parties' samples."""
        self._parts: list = []
        self._party_samples: list[tuple[int, int, int]] = []
        self._window_start = self._clock()

    def _switch(self, target: int, now: float | None, why: str) -> bool:
        """Take ``target``; ``now``: when the layout changed (``None``: a change that does not
        delay the next try)."""
        self.target = target
        if now is not None:
            self._switched_at = now
        self.switches += 1
        self.last_decision = f"{self.home + target} envs to {self.HOME}: {why}"
        logger.debug("pool layout: %s", self.last_decision)
        return True

    def _account_failed_try(self) -> None:
        """The envs of a failed try are back (the layout is settled again): what the try cost
        bounds the wait before the next, so that failed tries cost at most `TRY_SHARE` of the time."""
        if self._given_up:
            self._given_up = False
            cost = self._clock() - self._try_started
            self._probe_wait = max(self._probe_wait, cost * (1 / TRY_SHARE - 1))

    def _start_try(self, target: int, batch_us: float, now: float, why: str) -> bool:
        """Try ``target`` for a window, remembering the batch time of the layout it leaves."""
        self._left_us, self._left_target, self._try_started = batch_us, self.target, now
        return self._switch(target, now, why)

    def _end_try(self, batch_us: float, now: float) -> bool:
        """The try's window measured ``batch_us`` a batch: keep the layout tried if it is faster by
        `MARGIN`, else go back and wait twice as long before the next try (``True``: going back)."""
        left_us, self._left_us = self._left_us, None
        if MARGIN * batch_us < left_us:
            self._probe_wait, self._switched_at = PROBE_FIRST_SECONDS, now
            return False
        self._probe_wait = min(2 * self._probe_wait, PROBE_MAX_SECONDS)
        self._given_up = True
        here, there = self._names(self.target), self._names(self._left_target)
        return self._switch(self._left_target, now, f"the parent waited {batch_us:.1f} us a batch with {here}, "
                                                    f"{left_us:.1f} us with {there}")

    def _machine_quiet(self, now: float) -> bool | None:
        """Whether the machine has been quiet for `TRUST_QUIET_FOR` seconds; ``None`` while the
        policy's own watch, started at its first window, cannot tell yet."""
        if self._quiet is None:
            watch = MachineWatch(self._stall_us, self._clock, quiet_for=TRUST_QUIET_FOR, stall_share=TRUST_STALL_SHARE)
            self._quiet, self._watch_started = watch.quiet, now
        quiet = self._quiet()
        if not quiet and now - self._watch_started < TRUST_QUIET_FOR + READ_EVERY:
            return None
        return quiet

    def _names(self, target: int) -> str:
        """The layout ``target`` makes, in words."""
        raise NotImplementedError


class LayoutPolicy(_Policy):
    """Decides, from what batches cost, how many movable envs the calling process steps.

    ``target`` is that number: 0 is the planned layout (every movable env in its worker),
    ``movable`` is every env in the caller. Over a window of parts it measures, as medians, one
    env's step in the caller (its own slice's time), one env's step in the workers (their own
    stepping times, `modelicagym.vector.layout.cost_model.PartyTimes`) and the hand-over (what
    the batch took beyond its busiest worker's stepping, when the caller waited for the workers),
    and asks the cost model (`modelicagym.vector.layout.cost_model`) which target gives the
    shortest batch; it moves there when that is faster than the current one by `MARGIN`.

    The workers' costs are their own measurements, never derived from the caller's: a caller that
    is the bottleneck says nothing about the workers, so its time cannot hold envs in it (the
    hand-over keeps its last value measured while the caller waited). While every env is in the
    caller the workers measure nothing: once a core has been idle they are tried again, and a try
    that loses waits twice as long before the next.

    Args:
        shapes: per target, the layout it makes (`modelicagym.vector.layout.placement.layout_shapes`);
            ``shapes[0].home_envs`` is
            the caller's own slice.
        cores: the usable cores (`modelicagym.cores.usable_cores`).
        clock: seconds, monotonic (a parameter for tests).
        idle_cores: idle cores since the last call (a parameter for tests; default reads ``/proc/stat``).
    """

    HOME = "the calling process"

    def __init__(
        self,
        shapes: list[Shape],
        cores: int,
        clock: Callable[[], float] = time.monotonic,
        idle_cores: Callable[[], float] | None = None,
        stall_us: Callable[[], int | None] | None = None,
        foreign_cores: Callable[[], float | None] | None = None,
    ) -> None:
        #: the hand-over (us; ``None``: none yet): the last measured while the caller waited for the
        #: workers, and at most what a window since left for it within the caller's own slice
        self.handover_us: float | None = None
        #: apart, the workers' side of a batch over their stepping, in the last `STRETCH_WINDOWS` windows
        #: where the caller waited for the workers (the model takes their median, `_costs`)
        self._stretches: list[float] = []
        #: the costs measured when every env last moved to the caller
        self._left: Costs | None = None
        #: when the last part was observed (a part's wall time runs from there), and a batch's wall time in it
        self._observed_at: float | None = None
        self._part_wall_us: float | None = None
        #: the window running started after a pause (it is dropped)
        self._after_pause = False
        self._idle_cores = idle_cores or IdleCores(cores)
        self._foreign_cores = foreign_cores or (lambda: None)
        self._probing = False
        #: whether the stepping parties should each keep to a CPU of their own
        #: (`modelicagym.vector.layout.affinity.PartiesApart`): on a shared machine, while workers step
        #: batches of at least `APART_BATCH_US`, where a try showed it faster (`_keep_apart`)
        self.apart = False
        #: an env's step in the calling process took `APART_SWAP` times one in a worker in the last
        #: window: apart, the caller's CPU is the crowded one
        self.home_slower = False
        #: while a try of the other choice of `apart` runs: a batch's wall time before it
        self._apart_left_us: float | None = None
        #: that try's layout before it, whether it has swapped the calling thread's CPU for a
        #: worker's (`home_slower`), and how often it moved the layout
        self._apart_left_target = 0
        self._apart_swapped, self._apart_moves = False, 0
        #: a batch's wall time in the last windows (at most `WALL_WINDOWS`) since the parties last changed
        #: CPUs or every env was at home (the model's moves keep them: two trainings of 64 light envs
        #: each, whose layouts move every few windows, otherwise never tried every env at home)
        self._walls: list[float] = []
        #: whether the parties were apart before a try of every env in the caller (back with them if it fails)
        self._apart_before_try = False
        self._apart_wait = PROBE_FIRST_SECONDS
        self._apart_tried_at = clock()
        super().__init__(shapes, cores, clock, stall_us)

    def observe(
        self, batches: int, local_ns: int, wait_ns: int, local_envs: int, settled: bool = True,
        parties: PartyTimes | None = None,
    ) -> bool:
        """Account a part of ``batches`` batches: ``local_ns`` stepping ``local_envs`` envs a batch
        in the caller, then ``wait_ns`` waiting for the workers, and the workers' sampled stepping times (``parties``); ``True`` when the target changed.
        Parts measured while envs still move (not ``settled``) are dropped: the model's shapes are
        those of settled layouts."""
        samples = [] if parties is None else parties.take()
        if not settled:
            self._window()
            return False
        self._account_failed_try()
        now = self._clock()
        since, self._observed_at = self._observed_at, now
        # every env in the caller, no try running: its probes read idle cores and the parts' medians
        in_caller = self.target == self.movable and self._left_us is None
        if batches and local_envs:
            local_us = local_ns / batches / 1e3
            batch_us = (local_ns + wait_ns) / batches / 1e3
            wall_us = batch_us if since is None else (now - since) / batches * 1e6
            before_us, self._part_wall_us = self._part_wall_us, wall_us
            if not in_caller and before_us is not None and wall_us > PAUSE_FACTOR * before_us:
                self._paused((wall_us - before_us) * batches / 1e6)
                return False
            # a batch (stepping and waiting), an env in the caller, the caller's own slice, a batch's wall time
            self._parts.append((batch_us, local_us / local_envs, local_us, wall_us))
            self._party_samples += samples
        if now - self._window_start < WINDOW_SECONDS or (not in_caller and len(self._parts) < WINDOW_PARTS):
            return False
        if self._after_pause:
            self._after_pause = False
            self._window()
            return False
        if self._left_us is not None:
            changed = self._end_try(statistics.median(part[3] for part in self._parts), now)
            if self.target == self.movable:  # kept: the workers come back once a core is idle
                self._left = None
            elif changed:  # failed: back to the layout it left, the parties as they were
                self.apart = self._apart_before_try
        elif in_caller:
            changed = self._probe(now)
        else:
            changed = self._decide(now, None if parties is None else parties.costs(self._party_samples))
        self._window()
        return changed

    def _paused(self, seconds: float) -> None:
        """The caller paused for about ``seconds`` within the last part: this window and the next
        are dropped (`PAUSE_FACTOR`), and a try running leaves the pause out of its cost (`TRY_SHARE`)."""
        self._window()
        self._after_pause = True
        if self._apart_left_us is not None:
            self._apart_tried_at += seconds
        if self._left_us is not None or self._given_up:
            self._try_started += seconds

    def _probe(self, now: float) -> bool:
        """Every env is in the caller: try the workers again once a core has been idle, or once the
        caller's envs cost so much more than when they moved that the workers, their last costs
        scaled alike, are predicted faster. Where a try of whole batches put every env here
        (`_try_every_env_here`), the workers' return is such a try too: the model chose them before."""
        if now - self._switched_at < self._probe_wait:
            return False
        idle = self._idle_cores()
        target, why = 0, f"{idle:.1f} idle cores: the workers are tried again"
        if self._left is None:  # here by a try
            if idle < IDLE_CORES_TO_PROBE or not self._parts:
                return False
            return self._start_try(0, statistics.median(part[3] for part in self._parts), now, why)
        if idle < IDLE_CORES_TO_PROBE:
            if not self._parts or self._left.home_env_us <= 0:
                return False
            home_env_us = statistics.median(part[1] for part in self._parts)
            scale = home_env_us / self._left.home_env_us
            costs = replace(self._left, home_env_us=home_env_us, worker_env_us=self._left.worker_env_us * scale)
            target = best_shape(costs, self.shapes, self.movable, MARGIN)
            if target == self.movable:
                return False
            why = (f"an env takes {home_env_us:.1f} us in the calling process, {scale:.1f} times what it took "
                   f"when the envs moved there: the workers are tried again")
        self._probing = True
        return self._switch(target, now, why)

    def _decide(self, now: float, parties: PartyCosts | None) -> bool:
        """The target the cost model predicts fastest from the window's medians."""
        if not self._parts or parties is None or parties.all_worker_envs == 0:
            return False
        batch_us = statistics.median(part[0] for part in self._parts)
        home_env_us = statistics.median(part[1] for part in self._parts)
        waited = batch_us > 1.05 * statistics.median(part[2] for part in self._parts)
        shared = self._shared(now)
        wall_us = statistics.median(part[3] for part in self._parts)
        costs = self._costs(batch_us, home_env_us, waited, parties, wall_us if shared else batch_us)
        # on a shared machine the costs carry the caller's waits for a core, which every env at home
        # may meet as well: that layout is left to a try by whole batches (`_try_every_env_here`)
        target = best_shape(costs, self.shapes[: self.movable] if shared else self.shapes, self.target, MARGIN)
        if self._probing:
            self._probing = False
            self._probe_wait = (min(2 * self._probe_wait, PROBE_MAX_SECONDS) if target == self.movable
                                else PROBE_FIRST_SECONDS)
        self.home_slower = costs.home_env_us > APART_SWAP * costs.worker_env_us
        if self._apart_left_us is not None:
            return self._judge_apart(now, target, costs, batch_us, wall_us)
        if self.apart and self.home_slower:  # the calling thread swaps CPUs with a worker (`PartiesApart.keep`)
            self._walls = []  # they were of the CPUs it leaves
            return False if target == self.target else self._move(target, now, costs, batch_us)
        self._walls = [*self._walls[1 - WALL_WINDOWS :], wall_us]
        if target == self.target:
            if self._keep_apart(now, shared and batch_us >= APART_BATCH_US):
                return False
            return self._try_every_env_here(now, costs, shared)
        return self._move(target, now, costs, batch_us)

    def _move(self, target: int, now: float, costs: Costs, batch_us: float) -> bool:
        """Take ``target``, the model's choice on ``costs`` (a batch took ``batch_us``)."""
        side = (f"the workers' side {costs.worker_stretch:.1f} times their stepping (apart)" if self.apart
                else f"a hand-over {costs.handover_us:.1f} us")
        if target == self.movable:
            self._idle_cores()  # the idle-core reading starts now
            self._left = costs
            self.apart, self._walls = False, []
        predicted = batch_us_of(costs, self.shapes[target])
        # a move within the spread layouts does not delay the next try; every env at home starts the probes' wait
        changed_at = now if target == self.movable else None
        return self._switch(target, changed_at, f"an env takes {costs.home_env_us:.1f} us in the calling process and "
                                                f"{costs.worker_env_us:.1f} us in a worker, {side}: "
                                                f"a batch took {batch_us:.1f} us, "
                                                f"{self.home + target}/{self.home + self.movable} envs in the "
                                                f"calling process are predicted to take {predicted:.1f} us")

    def _costs(self, batch_us: float, home_env_us: float, waited: bool, parties: PartyCosts, lived_us: float) -> Costs:
        """The model's costs from a window: ``batch_us`` a batch stepped and waited, ``home_env_us``
        an env in the caller, whether the caller ``waited`` for the workers, their stepping
        (``parties``), and ``lived_us``: a batch as the caller lives it (on a shared machine its
        wall time: beside a busy process, the caller of 8 envs of ~80 us with the parties together
        waits 150-300 us a batch for a core between steps, more the more it waits for its worker).

        Waiting, the caller saw the workers' side whole; not waiting, it saw that side end within
        its own slice, so what was measured before, in another layout, is at most what fits there.
        Apart, the workers' side is their stepping stretched by their turns on the neighbour's CPU
        (`modelicagym.vector.layout.cost_model.Costs.worker_stretch`: a median over windows,
        `STRETCH_WINDOWS`; before it is measured, `STRETCH_FIRST`); together, their stepping and a
        hand-over."""
        shape = self.shapes[self.target]
        worker_env_us = parties.workers_total_us / parties.all_worker_envs
        if self.apart and parties.worker_us > 0:
            seen = batch_us / parties.worker_us
            if waited:
                self._stretches = [*self._stretches[1 - STRETCH_WINDOWS :], seen]
            known = statistics.median(self._stretches) if self._stretches else STRETCH_FIRST
            stretch = known if waited else min(known, seen)  # the workers' side ended within the caller's
            return Costs(home_env_us, worker_env_us, 0.0, worker_stretch=stretch, cores=self.cores,
                         parties=shape.workers + 1)
        seen_us = max(lived_us - parties.worker_us, 0.0)
        self.handover_us = seen_us if waited or self.handover_us is None else min(self.handover_us, seen_us)
        return Costs(home_env_us, worker_env_us, self.handover_us, cores=self.cores, parties=shape.workers + 1)

    def _try_every_env_here(self, now: float, costs: Costs, shared: bool) -> bool:
        """Try every env in the calling process, judged by whole batches, unless its own envs' cost
        rules that out: stepping them all at home, at the cost per env measured now, must be faster
        by `MARGIN` than a batch's wall time now (the median of the layout's last `WALL_WINDOWS`
        windows; 8 envs of ~75 us beside a busy process, the parties apart: 592 us at home against
        560 us a batch; each try lost 20% for its window).
        A try runs for a window, as a consolidation policy's does; ``shared``: the machine is.

        The model sees only what the pool's parties measure, stepping and waiting. Two costs
        escape it, and whole batches show both:

        - *the pool's own code around a step with workers* (sending, collecting: 2-3 us a batch on
          this project's VM), which a step with every env at home saves, being one C call
          (`~modelicagym.vector.dispatch.dispatcher.Dispatcher.step_at_home`): 2 light envs
          settled with one in the worker at 8.6 us a batch, where every env at home takes 6.3;
        - *other processes*: two trainings at once settle where each one's caller steps most envs
          and its worker the rest; each pool's wake-ups and stepping take turns on the cores with
          the other pool's, and neither pool's parties show what that costs the other (64 light
          envs each: 385k and 428k steps/s, where every env in each caller made 575k each).

        A try is judged by the batches' wall time (from one part to the next, the caller's own code
        included; medians of windows), not by the time the pool stepped and waited: in a crowd the
        caller also waits for a core between steps, and that wait is what the workers' wake-ups
        cost it (54 of 64 light envs in the caller: 106 us stepped and waited, 166 us a batch).
        Where the caller's code between steps is long (a learner's update), a try rarely wins by
        `MARGIN` and backs off, at most `TRY_SHARE` of the time."""
        if now - self._switched_at < self._probe_wait or len(self._walls) < WALL_WINDOWS:
            return False
        wall_us = statistics.median(self._walls)
        if MARGIN * batch_us_of(costs, self.shapes[self.movable]) >= wall_us:
            return False
        self._apart_before_try, self.apart, self._walls = self.apart, False, []
        where = "the machine is shared and " if shared else ""
        return self._start_try(self.movable, wall_us, now, f"{where}a batch takes {wall_us:.1f} us with "
                                                           f"{self._names(self.target)}: "
                                                           f"{self._names(self.movable)} is tried")

    def _keep_apart(self, now: float, may: bool) -> bool:
        """Whether the stepping parties keep to CPUs of their own (`apart`), tried by whole batches
        as layouts are: once `apart_wait` has passed, a try of the other choice starts
        (`_judge_apart`); ``True`` when one does. ``may``: the machine is shared and the batches
        long enough (`APART_BATCH_US`); otherwise the parties are together.

        Apart helps beside a busy process that runs wherever a CPU is free (8 envs of ~80 us: 1.08x
        one env together, 1.17-1.22x apart), and hurts beside another pool kept apart, whose parties
        cannot fill each other's idle CPU (two such trainings summed 0.93x two single envs apart,
        1.08x together): only a try can tell them apart."""
        if not may:
            if self.apart:
                self.apart, self._walls = False, []
            return False
        if now - self._apart_tried_at < self._apart_wait or len(self._walls) < WALL_WINDOWS:
            return False
        self._apart_left_us, self._apart_left_target = statistics.median(self._walls), self.target
        self.apart, self._apart_tried_at, self._walls = not self.apart, now, []
        self._apart_swapped, self._apart_moves = False, 0
        return True

    def _judge_apart(self, now: float, target: int, costs: Costs, batch_us: float, wall_us: float) -> bool:
        """A window of a try of the other choice of `apart` (``target``: the model's choice on this
        window's ``costs``; ``True`` when the target changed). The try is of that choice with the
        layout the model picks for it, as each choice has a layout of its own (beside a busy
        process, 8 envs of ~80 us: apart, 6 at home; together, 7 or fewer):

        - apart, the calling thread first leaves the neighbour's CPU where it stepped there
          (`home_slower`: it swaps with a worker, `PartiesApart.keep`);
        - the layout moves where the model predicts another faster, up to `APART_MOVES` times (the
          model learns the workers' stretch apart from the first layout it measures there);
        - then `APART_WINDOWS` windows judge the try by a batch's wall time against the median of
          the `WALL_WINDOWS` before it: kept if shorter by `APART_MARGIN`, else back to the choice
          and the layout it left, and the next try waits twice as long, and at least 19 times what
          the try cost (`TRY_SHARE`). A first window no shorter than those before ends the try at once: the
          second could not bring it under them by the margin (beside a busy process, the parties
          together took 600 us a batch where apart took 500; the try's cost halved)."""
        if target == self.movable:  # every env to the caller: no parties left to place
            self._apart_left_us = None
            return self._move(target, now, costs, batch_us)
        if self.apart and self.home_slower and not self._apart_swapped:
            self._apart_swapped, self._walls = True, []
            return False
        if target != self.target and self._apart_moves < APART_MOVES:
            self._apart_moves += 1
            return self._move(target, now, costs, batch_us)
        self._walls.append(wall_us)
        if len(self._walls) < APART_WINDOWS and wall_us < self._apart_left_us:
            return False
        left_us, self._apart_left_us = self._apart_left_us, None
        tried_us, cost = statistics.fmean(self._walls), now - self._apart_tried_at
        self._apart_tried_at = now
        if APART_MARGIN * tried_us < left_us:
            return False
        self.apart, self._walls = not self.apart, []
        self._apart_wait = max(min(2 * self._apart_wait, PROBE_MAX_SECONDS), cost * (1 / TRY_SHARE - 1))
        if self.target == self._apart_left_target:
            return False
        tried = "apart" if not self.apart else "together"
        return self._switch(self._apart_left_target, None, f"the parties {tried} took {tried_us:.1f} us a batch with "
                                                           f"{self._names(self.target)}, {left_us:.1f} us "
                                                           f"with {self._names(self._apart_left_target)}")

    def _shared(self, now: float) -> bool:
        """Whether other processes keep `FOREIGN_CORES_TO_SHARE` of the pool's CPUs busy, or
        threads wait for cores (`TRUST_STALL_SHARE`)."""
        crowded = self._machine_quiet(now) is False  # every window: the watch reads the pressure as it goes
        foreign = self._foreign_cores()
        return crowded or (foreign is not None and foreign >= FOREIGN_CORES_TO_SHARE)

    def _names(self, target: int) -> str:
        if target == self.movable:
            return "every env in the calling process"
        return f"{self.home + target}/{self.home + self.movable} envs in the calling process"


class ConsolidationPolicy(_Policy):
    """Decides whether a stand-in worker steps every env (consolidated) or shares them with the
    other workers (spread), and in the spread layout how many of theirs it takes.

    Where the calling process may not step a user's envs, a worker stands in for it
    (`modelicagym.vector.dispatch.assembly`): it is the home party of the cost model
    (`modelicagym.vector.layout.cost_model`), and ``target`` counts the workers' envs it steps.

    *The spread layout* is chosen by the model, as `LayoutPolicy` chooses: from a window's party
    costs (`modelicagym.vector.layout.cost_model.PartyTimes`: the stand-in's and the workers'
    stepping times) it takes the spread target predicted fastest by `MARGIN`, so that a
    synchronous step does not wait on one party while another's core idles. Unlike the calling
    process, the stand-in is a worker like the others: an env costs the same in either, and the
    envs that move carry the workers' mean cost (`_spread_model`).

    *Consolidation* is what the model cannot predict: one stand-in for every env saves the
    workers' wake-ups, which cost most on a crowded machine, where two woken workers may share a
    core and each party's time counts the other's turn. So the two layouts are compared by what
    the parent measures, its wait per batch: after a window (taken once the envs have moved:
    ``settled``) in one layout, and once ``probe_wait`` has passed, it tries the other; it keeps
    the other if its batches are faster by `MARGIN`, else goes back and waits twice as long
    before the next try (0.5 s up to 30 s), and long enough that failed tries cost at most
    `TRY_SHARE` of the time. On a quiet machine (``quiet``: threads waited for a core less than
    `TRUST_STALL_SHARE` of the last `TRUST_QUIET_FOR` seconds) the model does rule out a try: one
    worker stepping every env takes at least the parties' stepping summed, and a try is skipped
    while that fills the spread layout's batch within `MARGIN` (envs move back only at episode
    boundaries: 8 envs of ~1 ms a step lost 4-6 s at half speed to the first try).
    ``target``: ``spread`` in the spread layout (0 at first: the planned one) or ``movable``.

    Args:
        shapes: per target, the layout it makes (`modelicagym.vector.layout.placement.layout_shapes`,
            the stand-in as the home party).
        cores: the usable cores (`modelicagym.cores.usable_cores`).
        clock: seconds, monotonic (a parameter for tests).
        stall_us: the CPU pressure the policy's `MachineWatch` takes (started at its first window,
            after the pool's start-up; a parameter for tests; default: the machine's probe).
    """

    HOME = "the stand-in worker"

    def __init__(self, shapes: list[Shape], cores: int, clock: Callable[[], float] = time.monotonic,
                 stall_us: Callable[[], int | None] | None = None) -> None:
        #: the target of the spread layout, chosen by the cost model
        self.spread = 0
        super().__init__(shapes, cores, clock, stall_us)

    def observe(
        self, batches: int, local_ns: int, wait_ns: int, local_envs: int, settled: bool = True,
        parties: PartyTimes | None = None,
    ) -> bool:
        """Account a part of ``batches`` batches that took ``local_ns + wait_ns`` in all (the
        parent's measurement, as `LayoutPolicy.observe`'s), and the parties' sampled costs
        (``parties``, if the pool samples them); ``True`` when the target changed."""
        samples = [] if parties is None else parties.take()
        if not settled:
            self._window()
            return False
        self._account_failed_try()
        if batches:
            self._parts.append((local_ns + wait_ns) / batches / 1e3)
        self._party_samples += samples
        now = self._clock()
        if now - self._window_start < WINDOW_SECONDS or len(self._parts) < WINDOW_PARTS:
            return False
        batch_us = statistics.median(self._parts)
        costs = None if parties is None else parties.costs(self._party_samples)
        quiet = self._machine_quiet(now)  # every window: the watch reads the pressure as it goes
        self._window()
        if self._left_us is not None:
            return self._end_try(batch_us, now)
        spread = None if costs is None or self.target == self.movable else self._spread_model(costs)
        if spread is not None and (target := best_shape(spread, self.shapes[: self.movable], self.target,
                                                        MARGIN)) != self.target:
            self.spread = target
            predicted = batch_us_of(spread, self.shapes[target])
            return self._switch(target, None, f"the busiest worker stepped its {costs.worker_envs} envs in "
                                              f"{costs.worker_us:.1f} us a batch, the stand-in its "
                                              f"{costs.stand_in_envs} in {costs.stand_in_us:.1f} us: predicted "
                                              f"{predicted:.1f} us of stepping")
        if now - self._switched_at < self._probe_wait:
            return False
        if spread is not None and MARGIN * self._consolidated_us(costs) >= batch_us:
            # the parties' own stepping alone fills the batch: on a quiet machine, one stand-in for all
            # cannot be faster; until the watch can tell, the try waits
            if quiet:
                self._switched_at = now
            if quiet is not False:
                return False
        here, there = self._names(self.target), self._names(self._other())
        return self._start_try(self._other(), batch_us, now, f"the parent waits {batch_us:.1f} us a batch with "
                                                             f"{here}; {there} are tried")

    def _spread_model(self, costs: PartyCosts) -> Costs | None:
        """The cost model of the spread layout from a window's party costs (``None`` where a party
        steps nothing). Both parties are workers, so an env costs what it costs wherever it runs:
        the envs that move (from every worker in turn, `modelicagym.vector.layout.placement.move_order`)
        carry the workers' mean cost into the stand-in's measured time, or out of it; the batch's
        worker side is its busiest worker's, at that worker's cost per env. The hand-over is left
        out: every spread target wakes the same parties."""
        if costs.stand_in_envs == 0 or costs.all_worker_envs == 0 or costs.worker_envs == 0:
            return None
        moved_env_us = costs.workers_total_us / costs.all_worker_envs
        return Costs(moved_env_us, costs.worker_us / costs.worker_envs, 0.0,
                     home_offset_us=costs.stand_in_us - costs.stand_in_envs * moved_env_us,
                     cores=self.cores, parties=self.shapes[self.target].workers + 1)

    def _consolidated_us(self, costs: PartyCosts) -> float:
        """What the model predicts for every env in the stand-in, its hand-over left out: the
        parties' stepping summed, without their sharing of the cores."""
        envs = costs.stand_in_envs + costs.all_worker_envs
        every_env_us = costs.total_us / envs
        model = Costs(every_env_us, every_env_us, 0.0, cores=self.cores, parties=self.shapes[self.target].workers + 1)
        return batch_us_of(model, self.shapes[self.movable])

    def _other(self) -> int:
        """The target of the layout not running now."""
        return self.spread if self.target == self.movable else self.movable

    def _names(self, target: int) -> str:
        if target == self.movable:
            return "every env in the stand-in worker"
        return "the envs in their workers" if target == 0 else f"{target} of the workers' envs in the stand-in"
