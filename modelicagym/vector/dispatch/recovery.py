"""What the pool does when a worker fails: restart it (if allowed) and make its envs' results whole.

All failure handling of the pool is here, so its policy can be read in one place:

- ``restart_dead_workers=False`` (default): any failure stops the whole pool (every worker, all
  shared memory) and the failure is raised; the pool is closed afterwards.
- ``restart_dead_workers=True``: the failed worker is replaced by a fresh one with fresh envs;
  what its envs report depends on what was running (see :class:`Recovery`'s methods). A failure
  of the replacement during that first command stops the pool.
- Partial batches (``send``/``recv``) restart nothing: a failure stops the pool, whatever
  ``restart_dead_workers`` says (:meth:`Recovery.after_partial_step`).

After a failed step, each env of the restarted worker reports ``truncated=True``,
``terminated=False``, reward 0, with the reason in ``infos["pool_restart"]``. Then, as for any
truncation: in ``NEXT_STEP`` the next step resets it (the observation returned with the truncation
is its last one from before the failure); in ``SAME_STEP`` it is reset at once (``final_obs`` is
that last observation); in ``DISABLED`` the caller resets it.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NoReturn

from gymnasium.vector import AutoresetMode

from modelicagym.vector.dispatch.dispatcher import Dispatcher
from modelicagym.vector.dispatch.infos import Entries
from modelicagym.vector.dispatch.party import PendingCommand
from modelicagym.vector.dispatch.worker_handle import WorkerHandle
from modelicagym.vector.dispatch.worker_set import WorkerSet
from modelicagym.vector.errors import PoolError
from modelicagym.vector.wire.protocol import Command

__all__ = ["RESTART_INFO_KEY", "Recovery"]

#: info key set (to the reason, a string) on envs truncated because their worker was restarted
RESTART_INFO_KEY = "pool_restart"


class Recovery:
    """Restarts failed workers of a pool, or stops the pool.

    Args:
        workers: the pool's workers.
        dispatcher: to run the first command of a restarted worker.
        autoreset_mode: the pool's autoreset mode (what a restarted env reports depends on it).
        restart: whether failed workers are restarted at all.
        abort: stops the whole pool (called before any failure is raised).
    """

    def __init__(
        self,
        workers: WorkerSet,
        dispatcher: Dispatcher,
        autoreset_mode: AutoresetMode,
        restart: bool,
        abort: Callable[[], None],
    ) -> None:
        self._workers = workers
        self._dispatcher = dispatcher
        self._autoreset_mode = autoreset_mode
        self._restart = restart
        self._abort = abort

    def restart_or_raise(self, handle: WorkerHandle, failure: PoolError) -> str:
        """Restart ``handle`` if allowed (returns the reason, for infos), else stop the pool and raise."""
        if not self._restart:
            self._fail(failure)
        reason = str(failure)
        try:
            self._workers.restart(handle, reason, needs_reset=self._autoreset_mode is AutoresetMode.NEXT_STEP)
        except BaseException:
            self._abort()
            raise
        return reason

    def after_step(self, handle: WorkerHandle, failure: PoolError) -> Entries:
        """A worker failed a step: its new envs report a truncation with the reason in
        ``infos["pool_restart"]`` (and, in ``SAME_STEP``, are reset at once with the last
        observation from before the failure as ``final_obs``)."""
        buffers = self._workers.buffers
        indices = handle.env_indices
        last_observations = [buffers.observations.read(i) for i in indices]
        reason = self.restart_or_raise(handle, failure)
        buffers.rewards[indices.start : indices.stop] = 0.0
        buffers.terminations[indices.start : indices.stop] = False
        buffers.truncations[indices.start : indices.stop] = True
        if self._autoreset_mode is not AutoresetMode.SAME_STEP:
            return [(i, {RESTART_INFO_KEY: reason}) for i in indices]
        buffers.reset_mask[indices.start : indices.stop] = True
        reset_infos = self._run_first_command(PendingCommand(handle, Command.RESET), failure, "reset after restart")
        return [
            (
                i,
                {
                    "final_obs": last,
                    "final_info": {RESTART_INFO_KEY: reason},
                    **reset_infos.get(i, {}),
                    RESTART_INFO_KEY: reason,
                },
            )
            for i, last in zip(indices, last_observations, strict=True)
        ]

    def after_reset(self, handle: WorkerHandle, failure: PoolError, command: PendingCommand) -> Entries:
        """A worker failed a reset: reset its new envs the same way, once; they report the reason."""
        reason = self.restart_or_raise(handle, failure)
        infos = self._run_first_command(command, failure, "reset")
        mask = self._workers.buffers.reset_mask
        return [(i, {**infos.get(i, {}), RESTART_INFO_KEY: reason}) for i in handle.env_indices if mask[i]]

    def after_call(self, handle: WorkerHandle, failure: PoolError) -> NoReturn:
        """A worker failed ``call``/``set_attr``: restart it (if allowed) so the pool stays usable,
        and raise the failure either way: the call has no result for its envs."""
        self.restart_or_raise(handle, failure)
        raise failure

    def after_partial_step(self, failure: PoolError) -> NoReturn:
        """A worker failed a step of a partial batch: stop the pool and raise. Its other envs'
        results may be half-collected and other workers still stepping: nothing to resume."""
        self._fail(failure)

    def _run_first_command(self, command: PendingCommand, failure: PoolError, doing: str) -> dict[int, dict]:
        """Run a restarted worker's first command; its infos by env index. A second failure stops the pool."""
        self._dispatcher.send([command])
        for outcome in self._dispatcher.recv(None, doing):
            if outcome.failure is not None:
                self._abort()
                raise outcome.failure from failure
            return dict(outcome.message.data) if outcome.message is not None else {}
        return {}

    def _fail(self, failure: PoolError) -> NoReturn:
        self._abort()
        raise failure
