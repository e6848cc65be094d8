"""Where a `RayVectorEnv`'s actors go, how many CPUs each reserves and which envs it hosts.

Planned before anything starts, from the cluster's nodes, so that a layout Ray could never place
is refused at once instead of waiting forever. The default is one actor per node, reserving the
node's CPUs and stepping its envs on a local pool of that many processes: Ray's cost (a remote
call, its barrier across actors) is paid once per node, and within the node the pool's shared
memory does the rest. With ``num_actors`` or ``cpus_per_actor`` given, actors of that many CPUs go
wherever Ray places them.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from modelicagym.errors import ConfigError
from modelicagym.vector.plan import plan_workers

__all__ = ["ActorPlan", "plan_actors", "split_by_weight"]


@dataclass(frozen=True)
class ActorPlan:
    """One actor: the envs it hosts, the CPUs it reserves, the node it is pinned to (or None)."""

    envs: range
    cpus: int
    node_id: str | None = None


def plan_actors(
    nodes: Sequence[Mapping[str, Any]],
    free_cpus: float,
    num_envs: int,
    num_actors: int | None = None,
    cpus_per_actor: int | None = None,
) -> list[ActorPlan]:
    """The actors for ``num_envs`` envs on a cluster of ``nodes`` (``ray.nodes()``) with
    ``free_cpus`` not reserved by anything else (``ray.available_resources()``).

    Both ``None``: one actor per node with CPUs (the largest first, at most ``num_envs``), each
    reserving all of its node's CPUs, envs in proportion to them; while other work holds CPUs, one
    actor per free CPU instead. Otherwise ``num_actors`` actors (default: as many as fit) of
    ``cpus_per_actor`` CPUs (default 1), envs split evenly. Raises `ConfigError` for actors that
    cannot fit on any node, or more actors than fit.
    """
    node_cpus = sorted(((int(n["Resources"].get("CPU", 0)), n["NodeID"]) for n in nodes if n.get("Alive", True)),
                       key=lambda item: -item[0])
    node_cpus = [(cpus, node_id) for cpus, node_id in node_cpus if cpus >= 1]
    total = sum(cpus for cpus, _ in node_cpus)
    if not node_cpus:
        raise ConfigError("the Ray cluster has no node with a CPU: envs need CPUs to step on")
    if num_actors is None and cpus_per_actor is None:
        if free_cpus >= total:
            chosen = node_cpus[:num_envs]
            slices = split_by_weight(num_envs, [cpus for cpus, _ in chosen])
            return [ActorPlan(envs, cpus, node_id) for envs, (cpus, node_id) in zip(slices, chosen, strict=True)]
        cpus_per_actor, num_actors = 1, max(1, min(num_envs, int(free_cpus)))
    cpus = 1 if cpus_per_actor is None else cpus_per_actor
    if not isinstance(cpus, int) or cpus < 1:
        raise ConfigError(f"cpus_per_actor must be an integer >= 1, got {cpus!r}")
    room = sum(node // cpus for node, _ in node_cpus)
    if num_actors is None:
        num_actors = min(num_envs, room)
    if not 1 <= num_actors <= room:
        nodes_text = ", ".join(str(node) for node, _ in node_cpus)
        raise ConfigError(
            f"{num_actors} actors of {cpus} CPU(s) need {num_actors * cpus} CPUs, the cluster has {total} "
            f"(CPUs per node: {nodes_text}; an actor's CPUs are on one node): Ray would wait for them forever. "
            "Ask for fewer actors (num_actors) or CPUs per actor, or add nodes first"
        )
    return [ActorPlan(envs, cpus) for envs in plan_workers(num_envs, num_actors, None)]


def split_by_weight(num_envs: int, weights: Sequence[int]) -> list[range]:
    """Contiguous slices of ``num_envs`` envs in proportion to ``weights`` (largest remainders
    first, earlier slices on ties; each slice at least one env). Equal weights split as
    `~modelicagym.vector.plan.plan_workers` does."""
    if not 1 <= len(weights) <= num_envs:
        raise ConfigError(f"cannot split {num_envs} envs into {len(weights)} non-empty slices")
    total = sum(weights)
    spare = num_envs - len(weights)  # each slice has one env; the rest goes by weight
    quotas = [spare * w / total for w in weights]
    counts = [1 + int(q) for q in quotas]
    by_remainder = sorted(range(len(weights)), key=lambda k: (-(quotas[k] - int(quotas[k])), k))
    for k in by_remainder[: num_envs - sum(counts)]:
        counts[k] += 1
    slices, start = [], 0
    for count in counts:
        slices.append(range(start, start + count))
        start += count
    return slices
