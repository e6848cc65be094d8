"""``PoolVectorEnv``: a multi-process vector env, a drop-in for ``gymnasium.vector.AsyncVectorEnv``.

This module is the public API only, each call a plain ``def`` and a short composition of the parts
(the path of one step through them is drawn in ``docs/design.md``, "Where a step is computed"):
:mod:`~modelicagym.vector.dispatch.assembly` starts it; every call is a send and a receive through the one
:mod:`~modelicagym.vector.dispatch.dispatcher` (``step`` = ``_send_step`` + ``_recv_step``, ``reset``,
``call`` alike; ``send``/``recv`` for partial batches), which talks to the parties
(:mod:`~modelicagym.vector.dispatch.party`); :mod:`~modelicagym.vector.dispatch.recovery` handles failures,
:mod:`~modelicagym.vector.layout.placement` decides where envs run, :mod:`~modelicagym.vector.checks`
checks each call (its decorator, ``public_call``, also applies the interrupt policy,
``_interrupted``), :mod:`~modelicagym.vector.dispatch.infos` merges infos, :mod:`~modelicagym.vector.timing`
keeps the timing. It is longer than our other
modules because ``AsyncVectorEnv``'s API is wide (reset, step, call and set_attr in their sync,
async and wait forms, partial batches, timing, close) and each call's docstring is the user's
reference; the logic behind them lives in the modules named above.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import Space
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.async_vector_env import AsyncState
from gymnasium.vector.utils import batch_differing_spaces, batch_space

from modelicagym.cores import stepping_cpus, usable_cores
from modelicagym.errors import ArgumentError, ConfigError
from modelicagym.vector.checks import (
    check_async_vector_env_options,
    check_batch_size,
    check_env_fns,
    check_env_ids,
    check_idle,
    check_max_concurrency,
    check_open,
    check_pool_options,
    check_reset_mask,
    check_reset_options,
    check_waiting,
    public_call,
    seeds_per_env,
    values_per_env,
)
from modelicagym.vector.dispatch.action_writer import ActionWriter
from modelicagym.vector.dispatch.assembly import assemble
from modelicagym.vector.dispatch.deadline import NEVER, Deadline
from modelicagym.vector.dispatch.infos import Entries, add_final_infos, merge_infos, select_infos
from modelicagym.vector.dispatch.partial_batches import PartialBatches
from modelicagym.vector.dispatch.party import Outcome
from modelicagym.vector.dispatch.recovery import RESTART_INFO_KEY, Recovery
from modelicagym.vector.dispatch.timing_recorder import TimingRecorder
from modelicagym.vector.errors import CallerTimeoutError, NoPendingCallError, PoolError
from modelicagym.vector.layout.affinity import CallerAffinity
from modelicagym.vector.layout.placement import LayoutState
from modelicagym.vector.layout.plan import default_start_method, plan_layout
from modelicagym.vector.reset_options import check_options_per_env, with_initial_state
from modelicagym.vector.saved_states import VectorState, split_states
from modelicagym.vector.timing import StepTiming
from modelicagym.vector.wire.buffers import SharedBuffers
from modelicagym.vector.wire.protocol import StepPath, WorkerConfig
from modelicagym.vector.wire.sync import pool_native_library

__all__ = ["POOL_OPTIONS", "PoolVectorEnv", "RESTART_INFO_KEY"]

logger = logging.getLogger(__name__)

#: seconds a waiting party spins before it blocks (see ``modelicagym.vector.wire.sync``)
DEFAULT_SPIN_TIME = 100e-6

#: values of the ``init`` option: each env initializes itself, or one does and the others start from its state
INIT_MODES = ("each", "once")

#: seconds ``close()`` waits for the workers to close their envs when no timeout is given
DEFAULT_CLOSE_TIMEOUT = 30.0

_RESERVED_CALLS = frozenset({"reset", "step", "close"})


#: the keyword options of `PoolVectorEnv` (``make_vec`` routes these names to the pool)
POOL_OPTIONS = (
    "num_workers", "start_method", "autoreset_mode", "step_timeout", "restart_dead_workers", "max_envs_per_worker",
    "measure_timing", "copy", "spin_time", "startup_timeout", "caller_steps", "context", "shared_memory", "daemon",
    "observation_mode", "worker", "batch_size", "adapt_layout", "init", "max_concurrency", "cores",
)


class PoolVectorEnv(VectorEnv):
    """Runs ``num_envs`` environments in a few worker processes (and the calling one), each
    stepping a contiguous slice: a drop-in for :class:`gymnasium.vector.AsyncVectorEnv` (same API,
    same results, same errors), built for speed and for envs that are expensive and may crash.

    Observations, actions, rewards and flags live in shared memory, nothing is pickled on an
    ordinary step, and infos travel only when non-empty; parties wake each other through futex
    words in that memory, spinning briefly before they sleep. FMU envs on the native step path
    step a whole slice in one C call (``step_paths`` says which envs do, and why). A worker that
    dies, hangs past ``step_timeout`` or whose env raises is reported with the env index and the
    exit signal or the original traceback. Spaces, metadata, ``render_mode`` and ``spec`` come from
    the envs of worker 0: the parent creates envs only for its own slice.

    The step and autoreset contract is Gymnasium's (https://farama.org/Vector-Autoreset-Mode),
    identical step by step to :class:`gymnasium.vector.SyncVectorEnv` over the same env fns and
    seeds: ``NEXT_STEP`` (default) resets an env that ended in the next step, which ignores its
    action and returns the reset observation, reward 0 and both flags false; ``SAME_STEP`` resets
    it in the same step and puts the last observation and info in ``infos["final_obs"]`` and
    ``infos["final_info"]``; ``DISABLED`` leaves it to ``reset(options={"reset_mask": mask})``.

    With ``restart_dead_workers=True`` a failed worker is restarted and its envs report a
    truncation with the reason in ``infos["pool_restart"]`` (:mod:`~modelicagym.vector.dispatch.recovery`);
    otherwise a failure stops the whole pool before the error is raised, and further calls raise
    ``ClosedEnvironmentError``. The default start method is ``forkserver``
    (:func:`~modelicagym.vector.layout.plan.default_start_method` says why); workers never re-run the
    caller's script (:func:`~modelicagym.vector.dispatch.worker_handle.main_module_hidden`), so scripts without a
    main guard, stdin and notebooks work; env fns must be picklable by ``cloudpickle``.

    Where it deliberately differs from ``AsyncVectorEnv`` (Gymnasium's own vector tests pass
    otherwise): actions are checked against the action space in the calling process, so an
    out-of-range action raises `ActionError` before any env sees it (each env still gets its
    action as ``SyncVectorEnv`` hands it over from an array: same dtype); spaces with no shared-memory layout (custom spaces,
    ``Graph``, ``Sequence``) travel pickled whatever ``shared_memory`` says, instead of being
    refused; an env's exception is raised once, as its own type carrying the env index and the
    remote traceback, rather than also logged per worker; and while the calling process steps a
    slice itself (``caller_steps``), a ``timeout`` given to ``step_wait``/``reset_wait``/``call_wait``
    cannot interrupt the caller's own envs: it raises `CallerTimeoutError` once they are done, if
    the deadline has passed (``caller_steps=False`` interrupts them all).

    Example:
        >>> import gymnasium as gym
        >>> from modelicagym.vector import PoolVectorEnv
        >>> envs = PoolVectorEnv([lambda: gym.make("CartPole-v1") for _ in range(4)], num_workers=2)
        >>> envs
        PoolVectorEnv(CartPole-v1, num_envs=4)
        >>> observations, infos = envs.reset(seed=42)
        >>> observations.shape
        (4, 4)
        >>> _ = envs.action_space.seed(42)
        >>> observations, rewards, terminations, truncations, infos = envs.step(envs.action_space.sample())
        >>> rewards
        array([1., 1., 1., 1.])
        >>> terminations, truncations
        (array([False, False, False, False]), array([False, False, False, False]))
        >>> envs.set_timing(True)
        >>> _ = envs.step(envs.action_space.sample())
        >>> envs.timing().steps
        1
        >>> envs.close()
    """

    def __init__(
        self,
        env_fns: Sequence[Callable[[], gym.Env]],
        *,
        num_workers: int | None = None,
        start_method: str | None = None,
        autoreset_mode: str | AutoresetMode = AutoresetMode.NEXT_STEP,
        step_timeout: float | None = None,
        restart_dead_workers: bool = False,
        max_envs_per_worker: int | None = None,
        measure_timing: bool = False,
        copy: bool = True,
        spin_time: float = DEFAULT_SPIN_TIME,
        startup_timeout: float | None = None,
        caller_steps: bool | None = None,
        context: str | None = None,
        shared_memory: bool = True,
        daemon: bool = True,
        observation_mode: str | tuple[Space, Space] = "same",
        worker: Callable[..., None] | None = None,
        batch_size: int | None = None,
        adapt_layout: bool | None = None,
        init: str = "each",
        max_concurrency: int | None = None,
        cores: int | None = None,
    ) -> None:
        """Start the workers, create the envs in them and set up shared memory.

        Args:
            env_fns: functions creating the envs, sent to the workers with cloudpickle. If one has
                an attribute ``max_envs_per_process`` (e.g. 1 for an FMU that can be instantiated
                only once per process, where its config keeps that rule: ``instances_per_process="one"``),
                it caps the envs per worker like ``max_envs_per_worker``.
            num_workers: worker processes; default one per usable core (less the caller's, see
                ``caller_steps``), never more than envs. ``0``: none, the calling process steps
                every env itself, whatever it runs (no fault handling then: nothing to isolate,
                restart or time out).
            start_method: ``multiprocessing`` start method; default ``forkserver`` (see above).
            autoreset_mode: ``AutoresetMode`` (or its value), default ``NEXT_STEP``.
            step_timeout: seconds any call into the envs (step, reset, call, set_attr) may take
                before its worker is declared hung and killed; ``None`` waits forever, but a dead
                worker is still noticed within 50 ms.
            restart_dead_workers: restart a worker whose process died, hung or whose env raised,
                recreate its envs and report them truncated (see above) instead of raising.
            max_envs_per_worker: at most this many envs in one worker process.
            measure_timing: measure where step time goes from the start (see :meth:`timing`).
            copy: return copies of the observations (else views of shared memory, overwritten by
                the next step).
            spin_time: seconds a waiting party polls before it blocks.
            startup_timeout: seconds a worker may take to create its envs (``None``: no limit).
            caller_steps: the calling process steps the last slice of envs itself while the
                workers step theirs, so that no more parties wait for each other than there are
                cores (the caller's share runs without process isolation: a crash there is the
                caller's; one line on stderr names the env and its FMU, `modelicagym.vector.dispatch.caller_watch`).
                ``None`` (default): when the pool plans its own layout and no fault handling is
                asked for, i.e. ``num_workers``, ``max_envs_per_worker`` (or an env fn's
                ``max_envs_per_process``), ``restart_dead_workers`` and ``step_timeout`` are unset,
                and only for envs that say they are safe there (``safe_in_caller``: the bundled
                models; `modelicagym.vector.env_contract`): any other env is never created in the
                calling process. ``True`` puts a slice of any envs there.
            observation_mode: ``AsyncVectorEnv``'s: ``"same"`` (every env has the same observation
                space), ``"different"`` (spaces may differ but share shape and dtype: the batched
                space is ``batch_differing_spaces`` of them), or a ``(batched, single)`` pair.
            context: ``AsyncVectorEnv``'s name for ``start_method`` (taken, as the three below, so
                that swapping the class is a one-word change); give one of the two, or the same.
            shared_memory: ``AsyncVectorEnv``'s; taken, but the pool always uses shared memory.
            daemon: ``AsyncVectorEnv``'s; ``True`` only (the workers are daemons, stopped with the
                pool; else a `ConfigError`).
            worker: ``AsyncVectorEnv``'s custom worker function; ``None`` only (else a `ConfigError`).
            batch_size: how many envs :meth:`recv` returns, for EnvPool-style partial batches
                (:meth:`async_reset`, :meth:`send`, :meth:`recv`; `modelicagym.vector.dispatch.partial_batches`);
                every env then lives in a worker. ``None``: ``num_envs``.
            adapt_layout: move envs between the workers and the calling process at episode
                boundaries, measuring which layout is faster as the machine's load changes
                (`modelicagym.vector.layout.placement`; :attr:`layout` says what runs where and why).
                ``None`` (default): when the pool plans its own layout with the caller stepping
                (``caller_steps``), every env is an FMU env on the native step path whose reset
                is deterministic and every worker's env is safe in the calling process; ``True``
                insists (a `ConfigError` says why it cannot);
                ``False``: a fixed layout. An adaptive pool keeps a copy of every worker env in
                the calling process too.
            init: ``"each"`` (default): every env initializes itself at its first reset.
                ``"once"``: the first reset resets one env, takes its state (``get_state()``) and
                starts the others from it (``reset(options={"initial_state": state})``), so an
                FMU whose initialization is slow pays it once (`modelicagym.vector.saved_states`);
                an env whose state would differ (parameters of its own) initializes itself, and
                if the first env cannot give its state every env does.
            max_concurrency: ``AsyncVectorEnv``'s: at most this many envs run ``reset`` or ``step``
                at once (``None``: no limit); calls and attributes are not limited. A party (a
                worker, or the calling process) runs its envs one after the other, so the pool's
                dispatcher lets at most this many parties run a step or reset at once and sends the
                next as one finishes (`modelicagym.vector.dispatch.dispatcher`).
            cores: the cores the pool may use: one stepping process per core, the calling
                process's included, and the layout's cost model plans for them. ``None``
                (default): ``MODELICAGYM_CORES`` if set, else the CPUs this process may run on,
                capped by a cgroup CPU quota (a container's ``--cpus``; `modelicagym.cores`).
        """
        #: ``{"thread": ident}`` while a thread is inside a public call (`public_call`)
        self._user: dict[str, int] = {}
        self.env_fns = list(env_fns)
        start_method = check_async_vector_env_options(start_method, context, daemon, observation_mode, worker)
        check_env_fns(self.env_fns)
        self.max_concurrency = check_max_concurrency(max_concurrency)
        check_pool_options(
            num_workers, max_envs_per_worker, step_timeout, startup_timeout, spin_time, start_method,
            {"restart_dead_workers": restart_dead_workers, "measure_timing": measure_timing, "copy": copy,
             "caller_steps": caller_steps, "shared_memory": shared_memory, "adapt_layout": adapt_layout},
        )
        if init not in INIT_MODES:
            raise ConfigError(f"init must be one of {INIT_MODES}, got {init!r}")
        #: ``init="once"`` until the first reset has done it
        self._init_once = init == "once"
        self._init_entries: Entries = []
        self.num_envs = len(self.env_fns)
        self.batch_size = check_batch_size(batch_size, self.num_envs, caller_steps)
        if batch_size is not None and num_workers == 0:
            raise ConfigError("batch_size (partial batches) needs every env in a worker; num_workers=0 starts none")
        try:
            self.autoreset_mode = AutoresetMode(autoreset_mode)
        except ValueError:
            raise ConfigError(f"autoreset_mode must be one of {[m.value for m in AutoresetMode]}, "
                              f"got {autoreset_mode!r}") from None
        self._same_step = self.autoreset_mode is AutoresetMode.SAME_STEP
        self.step_timeout = step_timeout
        self.restart_dead_workers = restart_dead_workers
        self.startup_timeout = startup_timeout
        self.copy = copy
        #: the usable cores the pool plans for
        self.cores = usable_cores(cores)
        #: the CPUs the pool steps on, where its cores are fewer than the calling thread's affinity
        #: mask (its workers, and the thread that made it, while it is open); ``None``: anywhere in the
        #: mask (and where no worker starts)
        self.cpus = stepping_cpus(self.cores)
        layout = plan_layout(self.env_fns, num_workers, max_envs_per_worker, restart_dead_workers, step_timeout,
                             caller_steps, batch_size, self.cores)
        self.start_method = start_method or default_start_method()
        self._state = AsyncState.DEFAULT
        #: a command is being sent (`_sending`)
        self._sending_now = False
        self._timing = TimingRecorder()
        self._timing_enabled = False
        self._step_started_ns = 0
        config = WorkerConfig(
            self.autoreset_mode,
            spin_time,
            shared_signals=pool_native_library() is not None,
            step_timeout=step_timeout,
            startup_timeout=startup_timeout,
            observation_mode="same" if observation_mode == "same" else "different",
            num_envs=self.num_envs,
            cores=self.cores,
            cpus=self.cpus,
        )
        try:
            parts = assemble(self.env_fns, layout, self.start_method, config, adapt_layout, self.max_concurrency)
        except BaseException:
            self.closed = True
            raise
        if not parts.workers.handles:  # no hand-over to keep on one CPU: the calling thread is left alone
            self.cpus = None
        self._caller_affinity = CallerAffinity(self.cpus)
        self.caller_steps = parts.caller_steps
        self.num_workers = len(parts.workers.handles)
        self._workers, self._placement, self._dispatcher = parts.workers, parts.placement, parts.dispatcher
        first = parts.first
        self.metadata = {**first.metadata, "autoreset_mode": self.autoreset_mode}
        self.render_mode = first.render_mode
        self.spec = first.spec
        self.single_observation_space = first.observation_space
        self.observation_mode = observation_mode
        self.single_action_space = first.action_space
        if isinstance(observation_mode, tuple):
            self.observation_space, self.single_observation_space = observation_mode
        elif observation_mode == "different":
            self.observation_space = batch_differing_spaces(self._workers.observation_spaces)
        else:
            self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self._buffers: SharedBuffers = self._workers.buffers
        self._actions = ActionWriter(
            self._buffers.actions, self.single_action_space, self._buffers.action_dtype, pool_native_library(),
            self._buffers.needs_reset if self.autoreset_mode is AutoresetMode.NEXT_STEP else None,
            clip=first.clips_actions,
        )
        #: a step with every env at home range-checks its actions in its C call (`Dispatcher.step_at_home`)
        self._range_checked_at_home = self._dispatcher.check_range_at_home(self._actions.native_range)
        self._recovery = Recovery(
            self._workers, self._dispatcher, self.autoreset_mode, restart_dead_workers, self._abort
        )
        self._partial: PartialBatches | None = None
        self.set_timing(measure_timing)

    # ------------------------------------------------------------------ reset

    @public_call
    def reset(
        self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        """Reset all envs (or those in ``options["reset_mask"]``); see ``AsyncVectorEnv.reset``.

        Args:
            seed: ``None`` (random seeds), an int (env ``i`` gets ``seed + i``) or one seed per env.
            options: passed to every env's ``reset``; a boolean array ``"reset_mask"`` of shape
                ``(num_envs,)`` selects the envs to reset (the others keep their observation);
                ``"options_per_env"``, a list of one dict per env, updates env ``i``'s options with
                its entry (e.g. ``{"state": s}`` to start it from a saved state).

        Returns:
            The batch of observations and the merged infos of the reset envs.
        """
        self._send_reset(seed, options)
        return self._recv_reset(None)

    @public_call
    def reset_async(self, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None) -> None:
        """Start resetting; collect the result with :meth:`reset_wait`."""
        self._send_reset(seed, options)

    @public_call
    def reset_wait(self, timeout: float | None = None) -> tuple[Any, dict[str, Any]]:
        """Wait for :meth:`reset_async`; ``timeout`` defaults to ``step_timeout``."""
        return self._recv_reset(timeout)

    def _send_reset(self, seed: int | list[int | None] | None, options: dict[str, Any] | None) -> None:
        """Check the arguments, then send the reset (``init="once"`` first resets one env alone)."""
        self._assert_is_running()
        seeds = seeds_per_env(seed, self.num_envs)
        check_reset_options(options)
        check_options_per_env(options, self.num_envs)
        self._assert_idle("reset_async")
        mask = np.ones(self.num_envs, dtype=np.bool_)
        if options is not None and "reset_mask" in options:
            options = dict(options)
            mask = check_reset_mask(options.pop("reset_mask"), self.num_envs)
        with self._sending():
            if self._init_once and mask.any():
                self._init_once = False
                options = self._initialized_once(seeds, options, mask)
            self._dispatcher.reset(seeds, options, mask)
            self._state = AsyncState.WAITING_RESET

    def _initialized_once(self, seeds: list[int | None], options: dict[str, Any] | None,
                          mask: np.ndarray) -> dict[str, Any] | None:
        """``init="once"``: reset the first env of ``mask`` alone, take its state, and return the
        options that start the others from it (``mask`` then leaves the first env out; the options
        as given if it cannot give its state)."""
        first = int(np.flatnonzero(mask)[0])
        alone = np.zeros_like(mask)
        alone[first] = True
        self._dispatcher.reset(seeds, options, alone)
        self._state = AsyncState.WAITING_RESET
        self._init_entries = self._reset_entries(None)
        mask[first] = False  # it is reset
        self._dispatcher.call_each("get_state", [() if i == first else None for i in range(self.num_envs)])
        self._state = AsyncState.WAITING_CALL
        try:
            state = self._call_results(None, "init='once'")[first]
        except PoolError:
            raise
        except Exception as error:  # it cannot serialize its state: each env initializes itself
            logger.info("init='once': env %d cannot give its state (%s); every env initializes itself", first, error)
            return options
        return with_initial_state(options, state, self.num_envs)

    def _recv_reset(self, timeout: float | None) -> tuple[Any, dict[str, Any]]:
        """The observations and merged infos of the reset sent (see :meth:`_raise_if_overran`)."""
        deadline = Deadline.after(timeout)
        entries, self._init_entries = self._init_entries + self._reset_entries(timeout), []
        self._raise_if_overran(deadline, "reset_wait")
        return self._buffers.observations.read_batch(self.copy), self._merge_infos(entries)

    def _reset_entries(self, timeout: float | None) -> Entries:
        """Receive the reset sent; the ``(env index, info)`` of the reset envs' non-empty infos."""
        self._assert_is_running()
        self._assert_waiting(AsyncState.WAITING_RESET, "reset_wait", "reset_async")
        entries: Entries = []
        for command, message, failure in self._receive(timeout, "reset"):
            if failure is not None:
                entries += self._recovery.after_reset(command.party, failure, command)
            elif message is not None:
                entries += message.data
        if self._placement.adaptive and self._placement.after_reset(self._buffers.reset_mask):
            self._stepping_changed()
        return entries

    # ------------------------------------------------------------------ step

    @public_call
    def step(self, actions: Any) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Step every env with its action; returns batched ``(obs, rewards, terminations,
        truncations, infos)`` as :class:`~gymnasium.vector.SyncVectorEnv` does: :meth:`step_async`
        then :meth:`step_wait`. A Ctrl-C while it runs leaves the pool as it was (the step never
        started) or stopped, never half-way.

        Where no worker steps and the calling process steps every env in one C call (every env
        at home, native), the step is that call (`Dispatcher.step_at_home`), with the same checks
        and results."""
        dispatcher = self._dispatcher
        if (dispatcher.steps_at_home and not self.closed and self._state is AsyncState.DEFAULT and self._partial is None
                and not self._placement.pending and not self._timing_enabled):
            self._actions.write(actions, self._range_checked_at_home)
            self._state = AsyncState.WAITING_STEP  # a Ctrl-C from here on stops the pool (`_interrupted`)
            quiet = dispatcher.step_at_home()
            if quiet is None:  # an action outside its space, nothing stepped
                self._state = AsyncState.DEFAULT
                self._actions.refuse_outside(actions)  # raises, or clips, or finds an env that ignores it
                self._state = AsyncState.WAITING_STEP
                quiet = dispatcher.step_at_home(check_range=False)
            self._state = AsyncState.DEFAULT
            return self._step_results([], False) if quiet else self._collect_step(None, NEVER)
        self._send_step(actions)
        return self._recv_step(None)

    @public_call
    def step_async(self, actions: Any) -> None:
        """Check the actions (`modelicagym.vector.dispatch.action_writer`: an `ActionError` naming the env leaves
        the pool as it was), write them to shared memory and wake the workers; see :meth:`step_wait`."""
        self._send_step(actions)

    @public_call
    def step_wait(self, timeout: float | None = None) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Wait for the step started by :meth:`step_async`; ``timeout`` defaults to ``step_timeout``."""
        return self._recv_step(timeout)

    @public_call
    def step_envs(self, actions: Any, env_ids: Any) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Step only envs ``env_ids`` (the others keep their state) and return their results, in
        the order of ``env_ids``, as a batch of that many; ``infos["env_id"]`` repeats the ids.
        ``env_ids`` may also be a boolean mask over all envs (the ids are then in increasing order).

        For loops where some envs have no more work: a finished env costs nothing. It is a
        :meth:`step` whose shared step mask leaves the other envs out (on the native path too),
        with the same autoreset.
        """
        self._assert_is_running()
        self._assert_idle("step_envs")
        ids = check_env_ids(env_ids, self.num_envs)
        mask = self._buffers.step_mask
        mask[:] = 0
        mask[ids] = 1
        try:
            self._send_step(actions, ids)
            observations, rewards, terminations, truncations, infos = self._recv_step(None)
        finally:
            if self._buffers is not None:
                mask[:] = 1
        infos = select_infos(infos, ids)
        infos["env_id"] = ids.astype(np.int32)
        return observations[ids], rewards[ids], terminations[ids], truncations[ids], infos

    def _send_step(self, actions: Any, ids: np.ndarray | None = None) -> None:
        """Check the actions (of envs ``ids`` only, if given), write them to shared memory and send the step."""
        if self.closed or self._state is not AsyncState.DEFAULT or self._partial is not None:
            self._assert_is_running()
            self._assert_idle("step_async")
        self._step_started_ns = time.perf_counter_ns() if self._timing_enabled else 0
        if ids is None:
            self._actions.write(actions)
        else:
            self._actions.write_rows(np.asarray(actions), ids)
        self._state = AsyncState.WAITING_STEP  # from here on a Ctrl-C stops the pool (`_interrupted`)
        if self._placement.pending and self._placement.move_pending():
            self._stepping_changed()
        self._dispatcher.send_step()

    def _recv_step(self, timeout: float | None) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """The results of the step sent: a failed worker's envs as :mod:`~modelicagym.vector.dispatch.recovery`
        reports them, the layout adapted, the timing recorded, the infos merged."""
        if self.closed or self._state is not AsyncState.WAITING_STEP:
            self._assert_is_running()
            self._assert_waiting(AsyncState.WAITING_STEP, "step_wait", "step_async")
        deadline = Deadline.after(timeout)  # the calling process's own envs count against it too
        self._state = AsyncState.DEFAULT
        self._dispatcher.run_own_slice()
        return self._collect_step(timeout, deadline)

    def _collect_step(self, timeout: float | None, deadline: Deadline
                      ) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Receive every party's answer to the step (the calling process's slice has run; ``timeout``
        from ``deadline`` on) and the results."""
        entries: Entries = []
        restarted = False
        for command, message, failure in self._dispatcher.recv(timeout, "step"):
            if failure is not None:
                entries += self._recovery.after_step(command.party, failure)
                restarted = True
            elif message is not None:
                entries += message.data
        results = self._step_results(entries, restarted)
        if timeout is not None:
            self._raise_if_overran(deadline, "step_wait")
        return results

    def _step_results(self, entries: Entries, restarted: bool) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray,
                                                                         dict[str, Any]]:
        """A step's results, once every party has answered (``entries``: their infos; ``restarted``:
        a worker was restarted): the layout adapted, the timing recorded, the infos merged."""
        buffers = self._buffers
        if self._placement.due():
            self._placement.after_step(buffers.terminations, buffers.truncations, self._dispatcher.take_collect_times)
            self._dispatcher.watch_machine()
            self._dispatcher.step_own_slice_on(self._placement.caller_cpu)
        if self._timing_enabled and not restarted:
            self._timing.add(time.perf_counter_ns() - self._step_started_ns, buffers.timing, self._placement.stepping)
        infos = self._merge_infos(entries) if entries else {}
        if self._same_step:
            add_final_infos(infos, buffers.take_final_ready(), buffers.final_observations, self.num_envs)
        return (
            buffers.observations.read_batch(self.copy),
            buffers.rewards.copy(),
            buffers.terminations.copy(),
            buffers.truncations.copy(),
            infos,
        )

    @property
    def layout(self) -> LayoutState:
        """Where the envs run now and why: adaptive or fixed, envs in the calling process,
        workers stepping, and the measurement behind the last change (see
        `modelicagym.vector.layout.placement`)."""
        return self._placement.state()

    # ------------------------------------------------------------------ partial batches

    @public_call
    def async_reset(self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None) -> None:
        """Reset every env and make their results the first to come back from :meth:`recv`
        (EnvPool's ``async_reset``; see `modelicagym.vector.dispatch.partial_batches`)."""
        self._send_reset(seed, options)
        entries = self._reset_entries(None)
        self._partial_batches(None).start(entries)

    @public_call
    def send(self, actions: Any, env_ids: Any) -> None:
        """Step envs ``env_ids`` (returned by :meth:`recv` since they were last sent) with
        ``actions``, one per id, and return at once (EnvPool's ``send``)."""
        self._assert_is_running()
        self._partial_batches("send").send(actions, env_ids)

    @public_call
    def recv(self) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """The first ``batch_size`` envs whose results are in, as a batch of that many; their
        indices are in ``infos["env_id"]`` (EnvPool's ``recv``)."""
        self._assert_is_running()
        return self._partial_batches("recv").recv()

    def _partial_batches(self, call: str | None) -> PartialBatches:
        """The partial batches' state; created by ``async_reset`` (``call=None``), which ``call`` needs first."""
        if self._partial is None:
            if call is not None:
                raise NoPendingCallError(f"Calling `{call}` before `async_reset`.", call)
            self._partial = PartialBatches(self._dispatcher, self._recovery, self._actions, self.batch_size)
        return self._partial

    # ------------------------------------------------------------------ call, attributes, render

    @public_call
    def call(self, name: str, *args: Any, **kwargs: Any) -> tuple[Any, ...]:
        """Call method ``name`` of every env (or read attribute ``name``); one result per env."""
        self._send_call(name, args, kwargs)
        return self._recv_call(None)

    @public_call
    def call_async(self, name: str, *args: Any, **kwargs: Any) -> None:
        """Start :meth:`call`; collect the results with :meth:`call_wait`."""
        self._send_call(name, args, kwargs)

    @public_call
    def call_wait(self, timeout: float | None = None) -> tuple[Any, ...]:
        """Wait for :meth:`call_async`; ``timeout`` defaults to ``step_timeout``."""
        return self._recv_call(timeout)

    def _send_call(self, name: str, args: tuple[Any, ...], kwargs: dict[str, Any]) -> None:
        self._assert_is_running()
        self._assert_idle("call_async")
        if name in _RESERVED_CALLS:
            raise ArgumentError(f"Trying to call function `{name}` with `call`, use `{name}` directly instead.")
        self._dispatcher.call(name, args, kwargs)
        self._state = AsyncState.WAITING_CALL

    def _recv_call(self, timeout: float | None) -> tuple[Any, ...]:
        self._assert_is_running()
        self._assert_waiting(AsyncState.WAITING_CALL, "call_wait", "call_async")
        deadline = Deadline.after(timeout)
        results = tuple(self._call_results(timeout, "call"))
        self._raise_if_overran(deadline, "call_wait")
        return results

    def get_states(self) -> VectorState:
        """Every env's state (``env.get_state()``), mid-episode, and which envs the pool resets at
        their next step: a checkpoint that :meth:`set_states` resumes exactly, in this pool or a new
        one of the same envs (`modelicagym.vector.saved_states`). Wrappers' own state is not in it."""
        states = self.call("get_state")
        return VectorState(tuple(states), tuple(int(flag) for flag in self._buffers.needs_reset))

    @public_call
    def set_states(self, states: VectorState | Sequence[Any]) -> None:
        """Put back :meth:`get_states`'s checkpoint (or one state per env, e.g. start states): each
        env's ``set_state``, then the pool's per-env reset flags. The next step goes on from there.

        All or nothing: every env first checks its state (:meth:`check_states`), and if one
        refuses it (another FMU's, a changed binary's, an FMU that cannot serialize) that env's
        error is raised and no env has changed."""
        self._check_states(states)
        env_states, needs_reset = split_states(states, self.num_envs)
        self._each_env("set_state", env_states, "set_states")
        if needs_reset is not None:
            self._buffers.needs_reset[:] = needs_reset

    @public_call
    def check_states(self, states: VectorState | Sequence[Any]) -> None:
        """Check that every env would load its state from ``states`` (as :meth:`set_states` takes
        them), changing nothing: a wrong count or type of ``states`` raises before anything is
        sent; then each env's ``check_state`` (the env contract's `StatefulEnv`) runs where the env
        is, and the first refusal is raised as an `EnvError` of its type that names the env."""
        self._check_states(states)

    def _check_states(self, states: VectorState | Sequence[Any]) -> None:
        self._assert_is_running()
        env_states, _ = split_states(states, self.num_envs)
        self._assert_idle("check_states")
        self._each_env("check_state", env_states, "set_states, before any env changed")

    def _each_env(self, name: str, values: list[Any], doing: str) -> list[Any]:
        """Call method ``name`` of env ``i`` with ``values[i]``; their results in env order (an
        env's error raised as an `EnvError` of its type naming the env and ``doing``)."""
        self._dispatcher.call_each(name, [(value,) for value in values])
        self._state = AsyncState.WAITING_CALL
        return self._call_results(None, doing, named=True)

    def get_attr(self, name: str) -> tuple[Any, ...]:
        """Attribute ``name`` of every env (through wrappers, like ``env.get_wrapper_attr``)."""
        return self.call(name)

    @public_call
    def set_attr(self, name: str, values: list[Any] | tuple[Any, ...] | Any) -> None:
        """Set attribute ``name`` of every env: a list/tuple gives one value per env, anything
        else is set on all of them."""
        self._assert_is_running()
        values = values_per_env(values, self.num_envs)
        self._assert_idle("set_attr")
        self._dispatcher.set_attr(name, values)
        self._state = AsyncState.WAITING_CALL
        self._call_results(None, "set_attr")

    def render(self) -> tuple[Any, ...] | None:
        """The rendered frames of the envs (``render_mode`` applies)."""
        return self.call("render")

    def _call_results(self, timeout: float | None, doing: str, named: bool = False) -> list[Any]:
        """Results of the call/set_attr sent, in env order; raises the first env's exception
        (with ``named``, as an `EnvError` of its type naming the env)."""
        outcomes = self._receive(timeout, doing)
        for command, _, failure in outcomes:
            if failure is not None:
                self._recovery.after_call(command.party, failure)
        return self._dispatcher.call_results(outcomes, doing, named)

    @property
    def np_random_seed(self) -> tuple[int, ...]:
        """The ``np_random_seed`` of every env."""
        return self.get_attr("np_random_seed")

    @property
    def np_random(self) -> tuple[np.random.Generator, ...]:
        """The ``np_random`` generator of every env."""
        return self.get_attr("np_random")

    @property
    def worker_pids(self) -> tuple[int, ...]:
        """The process ids of the workers, in worker order (a restarted worker has a new one)."""
        self._assert_is_running()
        return tuple(handle.process.pid for handle in self._workers.handles)

    @property
    def step_paths(self) -> list[StepPath]:
        """Per env, the path it steps on (``"native"`` or ``"python"``) and why: a slice of bare
        `~modelicagym.FMUEnv` instances whose configs define the whole step runs in one C call."""
        return list(self._workers.step_paths)

    # ------------------------------------------------------------------ timing

    @public_call
    def set_timing(self, enabled: bool) -> None:
        """Switch step-time measurement on or off (and forget what was measured so far).

        When off, the only cost is one flag check per worker and step.
        """
        self._assert_is_running()
        self._assert_idle("set_timing")
        self._timing_enabled = bool(enabled)
        self._time_steps()
        self._timing.clear()

    def _stepping_changed(self) -> None:
        """Envs moved and a worker started or stopped stepping: the dispatcher wakes only those
        that step, and the parties time their steps while a worker steps (`_time_steps`)."""
        self._dispatcher.stepping_changed()
        self._time_steps()

    def _time_steps(self) -> None:
        """The parties time their steps while timing is on, or while the layout policy samples them."""
        self._buffers.timing_enabled[0] = self._timing_enabled or self._placement.samples_parties

    def timing(self, reset: bool = False) -> StepTiming:
        """Where step time went, as means per batch step since timing was switched on.

        See :mod:`modelicagym.vector.timing` for the exact definitions; ``reset`` starts a new
        measurement after reading this one.
        """
        summary = dataclasses.replace(self._timing.summary(), layout=str(self.layout))
        if reset:
            self._timing.clear()
        return summary

    # ------------------------------------------------------------------ close

    def close_extras(self, timeout: float | None = None, terminate: bool = False) -> None:
        """Close the envs in their workers, stop the workers and free the shared memory.

        Args:
            timeout: seconds to wait, in all, for a pending call and then for the workers to close
                their envs and exit; ``None`` means ``step_timeout``, or ``DEFAULT_CLOSE_TIMEOUT``
                if that is ``None`` too. Workers still running after that are terminated.
            terminate: terminate the workers at once, without closing the envs.
        """
        if not self._workers.alive:
            return
        if timeout is None:
            timeout = DEFAULT_CLOSE_TIMEOUT if self.step_timeout is None else self.step_timeout
        deadline = Deadline.after(timeout)
        if self._state != AsyncState.DEFAULT:
            gym.logger.warn(f"Calling `close` while waiting for a pending call to `{self._state.value}` to complete.")
        if self._partial is not None and self._partial.in_flight and not terminate:
            try:
                self._partial.drain()
            except PoolError:
                terminate = True
        if self._state != AsyncState.DEFAULT and not terminate:
            terminate = any(outcome.failure is not None for outcome in self._receive(timeout, self._state.value))
        if not terminate and self._buffers is not None:
            for handle in self._dispatcher.close():
                handle.join(deadline.remaining())
        self._abort()

    def __enter__(self) -> PoolVectorEnv:
        return self

    def __exit__(self, *args: Any) -> None:
        self.close()

    # ------------------------------------------------------------------ internals

    def _receive(self, timeout: float | None, doing: str) -> list[Outcome]:
        """The calling process runs its own slice's share of the command sent (if it has a slice),
        then receives every party's answer (`modelicagym.vector.dispatch.dispatcher`)."""
        self._state = AsyncState.DEFAULT
        self._dispatcher.run_own_slice()
        return self._dispatcher.recv(timeout, doing)

    def _raise_if_overran(self, deadline: Deadline, doing: str) -> None:
        """Raise `CallerTimeoutError` if a ``timeout`` given to a ``*_wait`` passed while the calling
        process ran envs itself: it cannot interrupt them, so it says so once they are done."""
        if self._dispatcher.local is not None and deadline.passed():
            raise CallerTimeoutError(
                f"The call to `{doing}` has timed out after {deadline.timeout} second(s): the envs the calling "
                f"process runs itself could not be interrupted; the call completed and the pool is usable, but its "
                f"results are dropped, as AsyncVectorEnv drops them (caller_steps=False makes every env interruptible)"
            )

    def _interrupted(self) -> None:
        """The interrupt policy, for a ``KeyboardInterrupt`` or ``SystemExit`` in any public call
        (`modelicagym.vector.checks.public_call`): if a command is being sent (the call state
        says one is pending, or :meth:`_sending` is under way), or was sent and not all its answers
        received (running, or half-collected, partial batches included), the pool is stopped
        (``close()`` is then immediate): such a command cannot be resumed. Before anything was
        sent, or once everything was received, the pool is left as it was and stays usable."""
        out = self._sending_now or self._state is not AsyncState.DEFAULT or self._dispatcher.in_flight
        if out and not self.closed:
            self._abort()

    @contextmanager
    def _sending(self) -> Iterator[None]:
        """Marks where a command is being sent with what prepares it (``init="once"``'s first
        reset), for :meth:`_interrupted`; an error that is not an interrupt leaves the pool usable."""
        self._sending_now = True
        try:
            yield
        except (KeyboardInterrupt, SystemExit):
            raise
        except BaseException:
            self._sending_now = False
            raise
        self._sending_now = False

    def _abort(self) -> None:
        """Stop every worker and free everything, without waiting for the envs to close.

        The parent's mapping of the shared memory goes with the last reference to it: at once,
        unless the caller still holds observations returned with ``copy=False``.
        """
        self._state = AsyncState.DEFAULT
        self._sending_now = False
        self._workers.release()
        self._dispatcher.release()
        self._caller_affinity.release()
        self._buffers = self._actions = None
        self.closed = True

    def _assert_is_running(self) -> None:
        check_open(self.closed, type(self).__name__)

    def _assert_idle(self, call: str) -> None:
        check_idle(self._state, self._partial is not None and self._partial.busy, call)

    def _assert_waiting(self, state: AsyncState, call: str, prior: str) -> None:
        check_waiting(self._state, state, call, prior)

    def _merge_infos(self, entries: Entries) -> dict[str, Any]:
        return merge_infos(entries, self.num_envs)
