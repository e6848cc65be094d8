"""The CPUs a pool steps on, where its usable cores are fewer than the CPUs it may run on.

Inside a CPU quota (a container's ``--cpus=1`` on a larger host) or under ``MODELICAGYM_CORES``, the
pool plans fewer stepping processes than the affinity mask has CPUs (`modelicagym.cores`). Left
free, the kernel still spreads the calling process and its workers over every CPU of the mask, so
each batch's hand-over wakes a CPU that sits idle, through the hypervisor on a VM (~35 µs a round
trip on this project's): 8 light envs in a stand-in inside a 1-CPU quota on two CPUs ran at 0.39x
one env, against 1.20x with the stand-in and the calling thread on one CPU.

So the pool keeps to `modelicagym.cores.stepping_cpus`: its workers pin themselves when they start
(``WorkerConfig.cpus``), and `CallerAffinity` pins the one thread that made the pool, for as long
as it is open. The rule, and why not more or less (docs/design.md, "Stepping on the usable cores'
CPUs"):

- affinity is per thread on Linux: the process's other threads (a learner's, a logger's) keep
  their masks; threads this thread starts while the pool is open inherit its mask;
- the pin lasts the pool's life, not a step: setting and restoring a mask costs ~5.5 µs, which
  took a light batch from 1.20x to 0.92x one env when done around every step;
- closing the pool gives the thread its mask back, unless something else changed it meanwhile.

On a machine shared with other processes, the kernel tends to run a calling process and the worker
it wakes on the same CPU, and the neighbour on the other: 8 envs of ~80 µs beside one busy process
on 2 cores ran at 1.08x one env in every layout, as if the pool had one core. `PartiesApart` keeps
each stepping party on a CPU of its own while the layout policy says so: each worker pinned by the
parent, the calling thread around its own stepping only (its mask is back before the step returns,
so no thread it starts inherits the pin). With the parties apart, the same pool ran at 1.17-1.22x.
"""

from __future__ import annotations

import logging
import os
import threading

from modelicagym.cores import current_cpu

__all__ = ["CallerAffinity", "PartiesApart"]

logger = logging.getLogger(__name__)


class CallerAffinity:
    """The calling thread kept on a pool's CPUs while the pool is open (nothing where ``cpus`` is ``None``)."""

    def __init__(self, cpus: tuple[int, ...] | None) -> None:
        #: the CPUs the pool steps on (``None``: wherever the affinity mask allows)
        self.cpus = cpus
        self._thread_id = threading.get_native_id()
        self._mask: set[int] | None = None
        if cpus is not None:
            self._mask = os.sched_getaffinity(0)
            try:
                os.sched_setaffinity(0, cpus)
            except OSError as error:  # a CPU gone offline since the mask was read
                logger.info("the calling thread stays on CPUs %s, not %s: %s", sorted(self._mask), cpus, error)
                self._mask = None

    def release(self) -> None:
        """Give the thread back the mask it had, if the pool's is still its own (from any thread)."""
        if self._mask is None:
            return
        mask, self._mask = self._mask, None
        try:
            if os.sched_getaffinity(self._thread_id) == set(self.cpus or ()):
                os.sched_setaffinity(self._thread_id, mask)
        except OSError:  # the thread has ended: nothing to give back
            pass


class PartiesApart:
    """The stepping parties of a pool, each on a CPU of its own while :meth:`keep` says so: the
    workers (``pids``) pinned by the parent, the calling thread on `caller_cpu` around its own
    stepping (`modelicagym.vector.dispatch.dispatcher.Dispatcher.step_own_slice_on`). ``cpus``: the
    pool's CPUs (``None``: the calling thread's affinity mask)."""

    def __init__(self, pids: list[int], cpus: tuple[int, ...] | None) -> None:
        self._pids = pids
        self._cpus = sorted(os.sched_getaffinity(0) if cpus is None else cpus)
        #: the CPU the calling thread steps on (``None``: not apart, it steps where it runs)
        self.caller_cpu: int | None = None
        #: apart, the other CPUs, the workers' first, in order
        self._others: list[int] = []

    def keep(self, apart: bool, home_slower: bool = False) -> None:
        """Pin the parties apart, or give the workers the pool's CPUs back; nothing where there are
        fewer CPUs than parties, or where a worker cannot be pinned (it has ended). Apart, with
        ``home_slower`` (the calling thread's envs step slower than the workers': its CPU is the one
        the neighbour runs on), the calling thread takes the first worker's CPU, and that worker its."""
        if apart == (self.caller_cpu is not None) and not (apart and home_slower):
            return
        if apart and len(self._cpus) <= len(self._pids):
            return
        if self.caller_cpu is not None and apart:
            caller, others = self._others[0], [self.caller_cpu, *self._others[1:]]
        else:
            current = current_cpu()
            caller = current if current in self._cpus else self._cpus[0]
            others = [cpu for cpu in self._cpus if cpu != caller]
        try:
            for pid, cpu in zip(self._pids, others):
                os.sched_setaffinity(pid, {cpu} if apart else self._cpus)
        except OSError as error:
            logger.info("the pool's parties stay where they run: %s", error)
            return
        self.caller_cpu, self._others = (caller, others) if apart else (None, [])
        logger.debug("pool parties %s: the calling thread on CPU %s, workers on %s", "apart" if apart else "together",
                     caller, others[: len(self._pids)])

