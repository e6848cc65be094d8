"""Partial batches: step some envs while others are still busy, as EnvPool's ``send``/``recv``.

The pool's ordinary ``step`` is a barrier: every env steps, the call returns when the slowest one
is done. With ``batch_size < num_envs`` the pool also works as EnvPool does: ``send(actions,
env_ids)`` hands actions to some envs and returns at once, ``recv()`` returns the first
``batch_size`` envs whose results are in, their ids in ``info["env_id"]``. A fast env is never
kept waiting for a slow one, so the cores stay busy when step costs differ.

Workers step whole slices, so the unit of work here is the part of a worker's slice that was
sent: the shared ``step_mask`` says which of its envs a ``STEP`` steps (on the native path too),
and a worker still busy when more of its envs are sent gets them as soon as it finishes. Each env
keeps its own autoreset (``NEXT_STEP``), so its trajectory is the one ``SyncVectorEnv`` gives for
the same seed and actions, whatever order the envs come back in. The commands go through the
pool's one dispatcher (``send``, then ``recv_any`` for the first workers done:
`modelicagym.vector.dispatch.dispatcher`), and a worker that fails stops the pool through its recovery
(`modelicagym.vector.dispatch.recovery`: partial batches restart nothing).

Example::

    envs = modelicagym.make_vec("cartpole", n=8, batch_size=4, num_workers=2)
    envs.async_reset(seed=0)
    for _ in range(100):
        observations, rewards, terminations, truncations, infos = envs.recv()
        envs.send(np.zeros(len(infos["env_id"]), dtype=np.int64), infos["env_id"])
    envs.close()
"""

from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np
from gymnasium.vector.utils import concatenate, create_empty_array

from modelicagym.errors import ArgumentError
from modelicagym.vector.checks import check_env_ids
from modelicagym.vector.dispatch.action_writer import ActionWriter
from modelicagym.vector.dispatch.dispatcher import Dispatcher
from modelicagym.vector.dispatch.infos import add_info
from modelicagym.vector.dispatch.party import Outcome, PendingCommand
from modelicagym.vector.dispatch.recovery import Recovery
from modelicagym.vector.wire.protocol import Command, Kind

__all__ = ["PartialBatches"]


class PartialBatches:
    """The calling process's side of partial batches for a pool whose envs all live in workers.

    Args:
        dispatcher: the pool's dispatcher (its parties are the workers, in slot order).
        recovery: the pool's recovery, which a worker's failure goes to.
        actions: the pool's action writer (actions are checked as for a whole batch).
        batch_size: how many envs :meth:`recv` returns.
    """

    def __init__(self, dispatcher: Dispatcher, recovery: Recovery, actions: ActionWriter, batch_size: int) -> None:
        self.dispatcher = dispatcher
        self.recovery = recovery
        self.handles = dispatcher.handles
        self.buffers = buffers = dispatcher.buffers
        self.actions = actions
        self.batch_size = batch_size
        n = buffers.rewards.shape[0]
        self.num_envs = n
        self._owner = np.empty(n, dtype=np.int64)
        for k, handle in enumerate(self.handles):
            self._owner[handle.env_indices.start : handle.env_indices.stop] = k
        #: per worker: the env ids it is stepping now, and those sent while it was busy
        self._stepping: list[list[int]] = [[] for _ in self.handles]
        self._queued: list[list[int]] = [[] for _ in self.handles]
        #: env ids whose results are in and not yet returned, in the order they came in
        self._ready: deque[int] = deque()
        self._infos: dict[int, dict[str, Any]] = {}
        #: env ids that were returned by recv (or never sent) and may be sent
        self._idle = np.ones(n, dtype=np.bool_)

    @property
    def busy(self) -> bool:
        """Whether any env has been sent and not yet returned by :meth:`recv`."""
        return bool(self._ready) or self.in_flight

    @property
    def in_flight(self) -> bool:
        """Whether a worker is stepping envs, or has envs waiting for it."""
        return any(self._stepping) or any(self._queued)

    def drain(self) -> None:
        """Wait until no worker is stepping (before the pool closes); the results are dropped."""
        while self.in_flight:
            self._collect()
        self._ready.clear()
        self._infos.clear()

    def start(self, entries: list[tuple[int, dict[str, Any]]]) -> None:
        """After a reset of every env: all their results are in (``entries``: the reset infos)."""
        self._ready = deque(range(self.num_envs))
        self._infos = dict(entries)
        self._idle[:] = False

    def send(self, actions: Any, env_ids: Any) -> None:
        """Step envs ``env_ids`` with ``actions`` (one per id, in the same order)."""
        ids = self._check_ids(env_ids)
        if not isinstance(self.actions.shared.read_batch(copy_out=False), np.ndarray):
            raise ArgumentError(f"partial batches need actions of an array space (Box, Discrete, MultiDiscrete, "
                                f"MultiBinary), not {self.actions.space}")
        self.actions.write_rows(np.asarray(actions), ids)
        self._idle[ids] = False
        owners = self._owner[ids]
        for k in range(len(self.handles)):
            mine = ids[owners == k].tolist()
            if not mine:
                continue
            if self._stepping[k]:
                self._queued[k] += mine
            else:
                self._dispatch(k, mine)

    def recv(self) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """The first ``batch_size`` envs whose results are in: observations, rewards,
        terminations, truncations and infos as a batch of that many, their ids in
        ``infos["env_id"]``."""
        count = self.batch_size
        outstanding = len(self._ready) + sum(map(len, self._stepping)) + sum(map(len, self._queued))
        if count > outstanding:
            raise ArgumentError(f"recv() waits for {count} envs, but only {outstanding} were sent and not yet "
                                f"received: send() more envs first")
        while len(self._ready) < count:
            self._collect()
        ids = np.array([self._ready.popleft() for _ in range(count)], dtype=np.int64)
        self._idle[ids] = True
        return self._results(ids)

    def _check_ids(self, env_ids: Any) -> np.ndarray:
        ids = check_env_ids(env_ids, self.num_envs)
        busy = ids[~self._idle[ids]]
        if busy.size:
            raise ArgumentError(f"envs {busy.tolist()} were sent and not yet returned by recv(): each env can "
                                "be sent again only once recv() has returned it")
        return ids

    def _dispatch(self, k: int, ids: list[int]) -> None:
        """Send worker ``k`` a step of envs ``ids`` of its slice (it is idle)."""
        handle, buffers = self.handles[k], self.buffers
        indices = handle.env_indices
        buffers.step_mask[indices.start : indices.stop] = 0
        buffers.step_mask[ids] = 1
        self._stepping[k] = ids
        self.dispatcher.send([PendingCommand(handle, Command.STEP)])

    def _collect(self) -> None:
        """Wait until at least one busy worker is done; take in the results of every done one
        (all of them, so that no worker's results wait behind a faster worker's)."""
        for outcome in self.dispatcher.recv_any("step"):
            self._take(outcome)

    def _take(self, outcome: Outcome) -> None:
        """A worker answered: its envs' results are in (or its failure goes to the recovery); send
        it what was queued meanwhile."""
        if outcome.failure is not None:
            self.recovery.after_partial_step(outcome.failure)
        handle, buffers, message = outcome.party, self.buffers, outcome.message
        k = handle.index
        ids, self._stepping[k] = self._stepping[k], []
        indices = handle.env_indices
        buffers.step_mask[indices.start : indices.stop] = 1
        if message is not None and message.kind is Kind.INFOS:
            self._infos.update(message.data)
        for index in buffers.take_final_ready(indices.start, indices.stop).tolist():
            self._infos[index] = buffers.final_info(index)
        self._ready.extend(ids)
        if self._queued[k]:
            queued, self._queued[k] = self._queued[k], []
            self._dispatch(k, queued)

    def _results(self, ids: np.ndarray) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray, dict]:
        """The batch of results of envs ``ids`` (copies: the envs may be sent again at once)."""
        buffers = self.buffers
        observations = buffers.observations
        batch = observations.read_batch(copy_out=False)
        if isinstance(batch, np.ndarray):
            selected = batch[ids]
        else:
            space = observations.space
            selected = concatenate(space, [observations.read(i) for i in ids.tolist()],
                                   create_empty_array(space, len(ids)))
        infos: dict[str, Any] = {}
        for position, env in enumerate(ids.tolist()):
            info = self._infos.pop(env, None)
            if info:
                infos = add_info(infos, info, position, len(ids))
        infos["env_id"] = ids.astype(np.int32)
        return (selected, buffers.rewards[ids].copy(), buffers.terminations[ids].copy(),
                buffers.truncations[ids].copy(), infos)

