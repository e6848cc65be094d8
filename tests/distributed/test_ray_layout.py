"""Where `RayVectorEnv` puts its actors (`modelicagym.distributed.layout`): planned from the
cluster's nodes before anything starts; no Ray needed."""

from __future__ import annotations

import pytest

from modelicagym.distributed.layout import ActorPlan, plan_actors, split_by_weight
from modelicagym.errors import ConfigError
from modelicagym.vector.layout.plan import plan_workers


def nodes(*cpus, dead=()):
    return [{"NodeID": f"node{k}", "Alive": k not in dead, "Resources": {"CPU": float(c)} if c else {}}
            for k, c in enumerate(cpus)]


def test_by_default_one_actor_per_free_cpu_hosts_an_even_share():
    assert plan_actors(nodes(2), free_cpus=2, num_envs=5) == [ActorPlan(range(0, 3), 1), ActorPlan(range(3, 5), 1)]
    assert plan_actors(nodes(2, 2), free_cpus=3, num_envs=7) == [
        ActorPlan(range(0, 3), 1), ActorPlan(range(3, 5), 1), ActorPlan(range(5, 7), 1)]
    assert plan_actors(nodes(8), free_cpus=8, num_envs=3) == [ActorPlan(range(k, k + 1), 1) for k in range(3)]
    # nothing free: one actor, which waits for a CPU (RayVectorEnv gives up after placement_timeout)
    assert plan_actors(nodes(2), free_cpus=0, num_envs=4) == [ActorPlan(range(0, 4), 1)]


def test_one_actor_per_node_reserves_its_cpus_and_hosts_envs_in_proportion():
    assert plan_actors(nodes(2, 6, 0, 4, dead=(3,)), free_cpus=8, num_envs=16, cpus_per_actor="node") == [
        ActorPlan(range(0, 12), 6, "node1"),
        ActorPlan(range(12, 16), 2, "node0"),
    ]
    assert plan_actors(nodes(1, 4, 2), free_cpus=7, num_envs=2, cpus_per_actor="node") == [
        ActorPlan(range(0, 1), 4, "node1"), ActorPlan(range(1, 2), 2, "node2")]  # the largest nodes first
    with pytest.raises(ConfigError, match="cpus_per_actor='node' places one actor on each node"):
        plan_actors(nodes(2), free_cpus=2, num_envs=4, num_actors=1, cpus_per_actor="node")


def test_given_actors_of_given_cpus_split_the_envs_evenly():
    assert plan_actors(nodes(2), free_cpus=2, num_envs=5, num_actors=2) == [
        ActorPlan(range(0, 3), 1), ActorPlan(range(3, 5), 1)]
    assert plan_actors(nodes(4, 3), free_cpus=7, num_envs=9, cpus_per_actor=2) == [
        ActorPlan(range(0, 3), 2), ActorPlan(range(3, 6), 2), ActorPlan(range(6, 9), 2)]


def test_actors_that_fit_on_no_node_are_refused_at_once():
    """Two 1-CPU nodes have 2 CPUs but no room for an actor of 2: Ray would wait forever."""
    with pytest.raises(ConfigError, match=r"1 actors of 2 CPU\(s\) need 2 CPUs, the cluster has 2 \(CPUs per node: 1, 1"):
        plan_actors(nodes(1, 1), free_cpus=2, num_envs=4, num_actors=1, cpus_per_actor=2)
    with pytest.raises(ConfigError, match="3 actors of 1 CPU"):
        plan_actors(nodes(2), free_cpus=2, num_envs=4, num_actors=3)
    with pytest.raises(ConfigError, match="cpus_per_actor must be an integer >= 1 or 'node', got 0"):
        plan_actors(nodes(2), free_cpus=2, num_envs=4, cpus_per_actor=0)
    with pytest.raises(ConfigError, match="no node with a CPU"):
        plan_actors(nodes(0), free_cpus=0, num_envs=4)


@pytest.mark.parametrize("num_envs, parts", [(5, 2), (7, 3), (8, 8), (100, 7)])
def test_equal_weights_split_as_the_pool_does(num_envs, parts):
    assert split_by_weight(num_envs, [3] * parts) == plan_workers(num_envs, parts, None)


def test_every_slice_gets_an_env_however_small_its_weight():
    assert [len(s) for s in split_by_weight(4, [100, 1, 1])] == [2, 1, 1]
    with pytest.raises(ConfigError, match="cannot split 2 envs into 3"):
        split_by_weight(2, [1, 1, 1])
