"""`RayVectorEnv`: a Gymnasium vector env whose envs live in Ray actors across a cluster.

The envs are split into contiguous slices, one per actor (`~modelicagym.distributed.host`); each
actor steps its slice on a local pool on its node. By default there is one actor per free CPU
(`~modelicagym.distributed.layout`). ``step`` sends each actor its actions and
gathers the batches in env order: the same results, step by step, as ``SyncVectorEnv`` over the
same env fns and seeds. One remote call
costs far more than a light env step, so for sampling at scale use :meth:`RayVectorEnv.rollout`:
the policy travels once, each actor steps ``T`` times locally and returns arrays.

An actor that dies (its process or node lost) raises `ActorDiedError` naming its envs; the vector
env stays usable once :meth:`RayVectorEnv.restart_actors` has started it again and ``reset`` has
been called.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space, concatenate, create_empty_array

from modelicagym.distributed.cluster import connect, format_env_range, wait_for_free_cpus
from modelicagym.distributed.errors import ActorDiedError
from modelicagym.distributed.host import EnvHost, Policy, Rollout
from modelicagym.distributed.layout import plan_actors
from modelicagym.errors import ArgumentError, ClusterError, ConfigError
from modelicagym.vector import PoolClosedError
from modelicagym.vector.api import (
    INIT_MODES,
    VectorState,
    add_info,
    check_options_per_env,
    check_reset_mask,
    env_info,
    options_for,
    seeds_per_env,
    split_states,
    values_per_env,
    with_initial_state,
)

__all__ = ["RAY_OPTIONS", "RayVectorEnv"]

logger = logging.getLogger(__name__)

#: the keyword options of `RayVectorEnv` that ``make_vec(..., backend="ray")`` routes to it
RAY_OPTIONS = ("num_actors", "cpus_per_actor", "address", "actor_options", "placement_timeout")


class RayVectorEnv(VectorEnv):
    """Runs ``len(env_fns)`` envs in ``num_actors`` Ray actors, each stepping a contiguous slice.

    Example::

        import modelicagym

        envs = modelicagym.make_vec("cartpole", n=64, backend="ray", num_actors=4)
        observations, infos = envs.reset(seed=0)
        batches = envs.rollout(lambda obs: (obs[:, 3] > 0).astype(int), steps=256)   # one per actor
        envs.close()
    """

    def __init__(
        self,
        env_fns: Sequence[Callable[[], gym.Env]],
        *,
        num_actors: int | None = None,
        cpus_per_actor: int | str | None = None,
        address: str | None = None,
        autoreset_mode: str | AutoresetMode = AutoresetMode.NEXT_STEP,
        pool_options: Mapping[str, Any] | None = None,
        actor_options: Mapping[str, Any] | None = None,
        placement_timeout: float = 60.0,
        init: str = "each",
    ) -> None:
        """Connect to Ray (see `~modelicagym.distributed.connect`) and start the actors.

        Args:
            env_fns: functions creating the envs; they travel to the actors with cloudpickle.
            num_actors: actors (default: as many as the free CPUs hold at ``cpus_per_actor``
                each; never more than envs).
            cpus_per_actor: CPUs each actor reserves and uses (default 1): with more than one, its
                envs step in a local pool of that many processes. ``"node"``: one actor on each
                node, reserving all its CPUs.
            address: the cluster to connect to when this process is not connected yet.
            autoreset_mode: Gymnasium's autoreset mode, for every actor.
            pool_options: `~modelicagym.vector.PoolVectorEnv` options of the actors' pools.
            actor_options: more Ray actor options (``resources``, ``scheduling_strategy``, ...).
            placement_timeout: seconds to wait for Ray to place an actor (find it the CPUs) before
                giving up with a `ClusterError`; creating its envs afterwards may take longer.
            init: ``"each"`` (default): every env initializes itself at its first reset.
                ``"once"``: the first reset resets the actor of the first env, takes that env's
                state and starts every other env, on every actor, from it (the pool's
                ``init="once"``, across actors: one initialization in all, where the envs allow).
        """
        self.env_fns = list(env_fns)
        if not self.env_fns:
            raise ConfigError("a RayVectorEnv needs at least one env fn")
        try:
            self.autoreset_mode = AutoresetMode(autoreset_mode)
        except ValueError:
            raise ConfigError(f"autoreset_mode must be one of {[m.value for m in AutoresetMode]}, "
                              f"got {autoreset_mode!r}") from None
        self._ray = connect(address)
        self.num_envs = len(self.env_fns)
        self.plans = plan_actors(self._ray.nodes(), self._ray.available_resources().get("CPU", 0.0), self.num_envs,
                                 num_actors, cpus_per_actor)
        self.slices = [plan.envs for plan in self.plans]
        self.num_actors = len(self.plans)
        self._host_class = self._ray.remote(EnvHost)
        self._actor_options = {"max_restarts": 0, "max_concurrency": 1, **(actor_options or {})}
        if init not in INIT_MODES:
            raise ConfigError(f"init must be one of {INIT_MODES}, got {init!r}")
        if "init" in (pool_options or {}):
            raise ConfigError("give RayVectorEnv init=... itself, not in pool_options: it initializes once across actors")
        #: ``init="once"`` until the first reset has done it; the actors' pools have it too
        self._init_once = init == "once"
        self._pool_options = {**(pool_options or {}), "init": init}
        self.placement_timeout = placement_timeout
        self._policy: tuple[Policy, Any] | None = None
        self._actors: list[Any] = [None] * self.num_actors
        self.dead_actors: set[int] = set()
        self.closed = False
        try:
            first = self._start(range(self.num_actors))[0]
        except BaseException:
            self.close_extras()
            raise
        self.single_observation_space = first["single_observation_space"]
        self.single_action_space = first["single_action_space"]
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.metadata = {**first["metadata"], "autoreset_mode": self.autoreset_mode}
        self.render_mode = first["render_mode"]
        self.spec = first["spec"]

    def __repr__(self) -> str:
        return f"RayVectorEnv(num_envs={self.num_envs}, num_actors={self.num_actors})"

    # ------------------------------------------------------------------ the vector API

    def reset(
        self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        """Reset every env (or those in ``options["reset_mask"]``); seeds as ``SyncVectorEnv``'s."""
        self._check_open()
        seeds = seeds_per_env(seed, self.num_envs)
        check_options_per_env(options, self.num_envs)
        mask = None
        if options is not None and "reset_mask" in options:
            options = dict(options)
            mask = check_reset_mask(options.pop("reset_mask"), self.num_envs)
        refs: list[Any] = [None] * self.num_actors
        if self._init_once and (mask is None or mask.any()):
            self._init_once = False
            options = self._initialized_once(seeds, options, mask, refs)
        for k in range(self.num_actors):
            if refs[k] is None:
                refs[k] = self._reset_actor(k, seeds, options, mask)
        return self._batch_reset(refs)

    def _reset_actor(self, k: int, seeds: list[int | None], options: dict[str, Any] | None,
                     mask: np.ndarray | None) -> Any:
        """Start resetting actor ``k``'s envs with their part of ``seeds``, ``options`` and ``mask``."""
        envs = self.slices[k]
        part = options_for(options, envs)
        if mask is not None:
            part = {**(part or {}), "reset_mask": mask[envs.start:envs.stop]}
        return self._actors[k].reset.remote(seeds[envs.start:envs.stop], part)

    def _initialized_once(self, seeds: list[int | None], options: dict[str, Any] | None, mask: np.ndarray | None,
                          refs: list[Any]) -> dict[str, Any] | None:
        """``init="once"``: reset the actor of the first env to reset (its pool initializes it once
        and starts its other envs from its state), take that env's state, and return the options
        that start every other actor's envs from it (as given if it cannot give its state)."""
        first = 0 if mask is None else int(np.flatnonzero(mask)[0])
        k = next(k for k, envs in enumerate(self.slices) if first in envs)
        refs[k] = self._reset_actor(k, seeds, options, mask)
        try:
            state = self._get([self._actors[k].call.remote("get_state", (), {})], [k])[0][first - self.slices[k].start]
        except self._ray.exceptions.RayTaskError as error:  # it cannot give its state: each actor initializes its own
            logger.info("init='once': env %d cannot give its state (%s); each actor initializes its envs", first,
                        str(error).splitlines()[0])
            return options
        return with_initial_state(options, state, self.num_envs)

    def step(self, actions: Any) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Step every env with its action; one remote call per actor, in parallel."""
        self._check_open()
        actions = np.asarray(actions)
        if actions.ndim == 0 or len(actions) != self.num_envs:
            raise ArgumentError(f"expected a batch of {self.num_envs} actions, got {actions!r}")
        refs = [self._actors[k].step.remote(actions[envs.start:envs.stop]) for k, envs in enumerate(self.slices)]
        parts = self._get(refs, range(self.num_actors))
        observations = self._observations([p[0] for p in parts])
        rewards, terminations, truncations = (np.concatenate([p[i] for p in parts]) for i in (1, 2, 3))
        return observations, rewards, terminations, truncations, self._infos([p[4] for p in parts])

    def call(self, name: str, *args: Any, **kwargs: Any) -> tuple[Any, ...]:
        """Call method ``name`` of every env (or read attribute ``name``); one result per env."""
        self._check_open()
        refs = [actor.call.remote(name, args, kwargs) for actor in self._actors]
        return tuple(value for part in self._get(refs, range(self.num_actors)) for value in part)

    def get_states(self) -> VectorState:
        """Every env's state and reset flag, from every actor's pool (`PoolVectorEnv.get_states`):
        a checkpoint that :meth:`set_states` resumes exactly, here or in another vector env of the
        same envs (a pool too)."""
        self._check_open()
        parts = self._get([actor.get_states.remote() for actor in self._actors], range(self.num_actors))
        return VectorState(tuple(s for part in parts for s in part.states),
                           tuple(flag for part in parts for flag in part.needs_reset))

    def set_states(self, states: VectorState | Sequence[Any]) -> None:
        """Put back :meth:`get_states`'s checkpoint (or one state per env), all or nothing: every
        actor first checks its envs' states, and a refusal (naming the env) changes no env."""
        self._check_open()
        env_states, needs_reset = split_states(states, self.num_envs)
        parts = [env_states[envs.start:envs.stop] if needs_reset is None else
                 VectorState(tuple(env_states[envs.start:envs.stop]), tuple(needs_reset[envs.start:envs.stop].tolist()))
                 for envs in self.slices]
        actors = range(self.num_actors)
        self._get([self._actors[k].check_states.remote(parts[k]) for k in actors], actors)
        self._get([self._actors[k].set_states.remote(parts[k]) for k in actors], actors)

    def get_attr(self, name: str) -> tuple[Any, ...]:
        """Attribute ``name`` of every env."""
        return self.call(name)

    def set_attr(self, name: str, values: list[Any] | tuple[Any, ...] | Any) -> None:
        """Set attribute ``name`` of every env (a list/tuple: one value per env)."""
        self._check_open()
        values = values_per_env(values, self.num_envs)
        refs = [self._actors[k].set_attr.remote(name, values[envs.start:envs.stop]) for k, envs in enumerate(self.slices)]
        self._get(refs, range(self.num_actors))

    def render(self) -> tuple[Any, ...] | None:
        """The rendered frames of the envs."""
        return self.call("render")

    # ------------------------------------------------------------------ rollouts

    def rollout(self, policy: Policy, steps: int) -> list[Rollout]:
        """Step every env ``steps`` times on its actor, with ``policy(observations) -> actions``
        applied to each actor's batch; returns one `Rollout` per actor (``Rollout.concatenate``
        joins them in env order).

        The policy is serialised once (``ray.put``, cloudpickle) and sent to the actors only when
        it is a different object than the last one; the envs continue from where they are (reset
        them first), and ``step`` may follow.
        """
        self._check_open()
        if not isinstance(steps, int) or steps < 1:
            raise ArgumentError(f"steps must be an integer >= 1, got {steps!r}")
        if self._policy is None or self._policy[0] is not policy:
            reference = self._ray.put(policy)
            self._get([actor.set_policy.remote(reference) for actor in self._actors], range(self.num_actors))
            self._policy = (policy, reference)
        return self._get([actor.rollout.remote(steps) for actor in self._actors], range(self.num_actors))

    # ------------------------------------------------------------------ actors

    def restart_actors(self, actors: Sequence[int] | None = None) -> list[int]:
        """Start again the actors that died (or those in ``actors``), with fresh envs; returns
        their indices. Call ``reset`` before stepping again."""
        self._check_open()
        which = sorted(self.dead_actors if actors is None else set(actors))
        for k in which:
            if self._actors[k] is not None:
                self._ray.kill(self._actors[k], no_restart=True)
        self._start(which)
        if self._policy is not None:
            self._get([self._actors[k].set_policy.remote(self._policy[1]) for k in which], which)
        return which

    def actor_pids(self) -> tuple[int, ...]:
        """The process id of every actor (on its node)."""
        return tuple(d["pid"] for d in self._get([a.describe.remote() for a in self._actors], range(self.num_actors)))

    def close_extras(self, **kwargs: Any) -> None:
        """Close every actor's envs and end the actors (Ray itself stays connected)."""
        live = [k for k, actor in enumerate(self._actors) if actor is not None and k not in self.dead_actors]
        for k, ref in zip(live, [self._actors[k].close.remote() for k in live], strict=True):
            try:
                self._ray.get(ref)
            except self._ray.exceptions.RayError as error:
                logger.warning("actor %d could not close its envs: %s", k, error)
        free = self._ray.available_resources().get("CPU", 0.0)
        for actor in self._actors:
            if actor is not None:
                self._ray.kill(actor, no_restart=True)
        # Ray frees the CPUs a moment later: wait, so that the next vector env finds them free
        total = self._ray.cluster_resources().get("CPU", 0.0)
        wait_for_free_cpus(min(total, free + sum(self.plans[k].cpus for k in live)), timeout=10.0)
        self._actors = [None] * self.num_actors
        self._policy = None

    # ------------------------------------------------------------------ internals

    def _start(self, which: Sequence[int]) -> list[dict[str, Any]]:
        """Start the actors in ``which`` and their envs; their `EnvHost.describe`."""
        for k in which:
            plan = self.plans[k]
            options = {"num_cpus": plan.cpus, **self._actor_options}
            if plan.node_id is not None and "scheduling_strategy" not in options:
                from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy

                options["scheduling_strategy"] = NodeAffinitySchedulingStrategy(plan.node_id, soft=False)
            self._actors[k] = self._host_class.options(**options).remote(
                self.env_fns[plan.envs.start:plan.envs.stop], list(plan.envs), plan.cpus, self.autoreset_mode,
                self._pool_options,
            )
            self.dead_actors.discard(k)
        self._wait_for_placement(which)
        return self._get([self._actors[k].start.remote() for k in which], which)

    def _wait_for_placement(self, which: Sequence[int]) -> None:
        """Wait until Ray has placed the actors in ``which``; a `ClusterError` (and no actor left
        behind) after ``placement_timeout`` seconds, since Ray itself would wait forever."""
        ray = self._ray
        refs = [self._actors[k].pid.remote() for k in which]
        _, pending = ray.wait(refs, num_returns=len(refs), timeout=self.placement_timeout)
        if not pending:
            return
        waiting = [k for k, ref in zip(which, refs, strict=True) if ref in pending]
        for k in which:
            ray.kill(self._actors[k], no_restart=True)
            self._actors[k] = None
        k = waiting[0]
        raise ClusterError(
            f"Ray could not place actor {k} ({format_env_range(self.slices[k])}, {self.plans[k].cpus} CPU(s)"
            f"{' on node ' + self.plans[k].node_id if self.plans[k].node_id else ''}) within {self.placement_timeout} s"
            f" ({len(waiting)} of {len(which)} actors waiting; free CPUs now: "
            f"{ray.available_resources().get('CPU', 0):g}): other actors or tasks may hold the CPUs. Close them, "
            "ask for fewer actors or CPUs per actor (num_actors, cpus_per_actor), or raise placement_timeout"
        )

    def _get(self, refs: Sequence[Any], actors: Sequence[int]) -> list[Any]:
        """The results of ``refs`` (one per actor in ``actors``); an actor lost raises
        `ActorDiedError` naming its envs, after every result has been waited for."""
        ray = self._ray
        results, died = [], []
        for k, ref in zip(actors, refs, strict=True):
            try:
                results.append(ray.get(ref))
            except ray.exceptions.RayActorError as error:
                self.dead_actors.add(k)
                died.append((k, error))
                results.append(None)
        if died:
            k, error = died[0]
            others = f" (and actors {[d[0] for d in died[1:]]})" if len(died) > 1 else ""
            raise ActorDiedError(
                f"Ray actor {k} hosting {format_env_range(self.slices[k])} died{others}: "
                f"{str(error).splitlines()[0].rstrip('.')}. Call restart_actors() and reset() to go on.",
                k, list(self.slices[k]),
            ) from error
        return results

    def _batch_reset(self, refs: list[Any]) -> tuple[Any, dict[str, Any]]:
        parts = self._get(refs, range(self.num_actors))
        return self._observations([p[0] for p in parts]), self._infos([p[1] for p in parts])

    def _observations(self, parts: list[Any]) -> Any:
        items = [item for part, envs in zip(parts, self.slices, strict=True)
                 for item in gym.vector.utils.iterate(
                     batch_space(self.single_observation_space, len(envs)), part)]
        return concatenate(self.single_observation_space, items,
                           create_empty_array(self.single_observation_space, self.num_envs))

    def _infos(self, parts: list[dict[str, Any]]) -> dict[str, Any]:
        infos: dict[str, Any] = {}
        for part, envs in zip(parts, self.slices, strict=True):
            for j, index in enumerate(envs):
                info = env_info(part, j)
                if info:
                    infos = add_info(infos, info, index, self.num_envs)
        return infos

    def _check_open(self) -> None:
        if self.closed:
            raise PoolClosedError("Trying to operate on `RayVectorEnv`, after a call to `close()`.")
