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
"""

from __future__ import annotations

import logging
import os
import threading

__all__ = ["CallerAffinity"]

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
