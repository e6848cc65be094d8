"""`RayVectorEnv` on a real local Ray (2 CPUs, 127.0.0.1, token authentication on): the same
results as ``SyncVectorEnv``, rollouts, dead actors, ``make_vec(backend="ray")``."""

from __future__ import annotations

import os
import signal
import time

import gymnasium as gym
import numpy as np
import pytest
from ray_cluster import local_ray, ray

import modelicagym
from modelicagym.distributed import ActorDiedError, ClusterError, RayVectorEnv, Rollout
from modelicagym.registry import EnvFactory
from modelicagym.vector.dispatch.infos import env_info

N = 5
CARTPOLE = "modelicagym.models.cartpole.env:CartPoleEnv"


@pytest.fixture(scope="module", autouse=True)
def ray_instance():
    with local_ray(__name__, num_cpus=2) as temp_dir:
        yield temp_dir


def env_fns(n=N, **options):
    return [EnvFactory(CARTPOLE, {"max_episode_steps": 25, "force": 5.0 + i, **options}) for i in range(n)]


def push_by_velocity(observations):
    return (observations[:, 3] > 0).astype(np.int64)


def assert_same_infos(left, right):
    assert left.keys() == right.keys()
    for key in left:
        if isinstance(left[key], dict):
            assert_same_infos(left[key], right[key])
        elif left[key].dtype == object:
            for a, b in zip(left[key], right[key], strict=True):
                assert (a is None and b is None) or np.array_equal(a, b)
        else:
            np.testing.assert_array_equal(left[key], right[key])


@pytest.mark.parametrize(
    "layout, autoreset_mode",
    [({}, "NextStep"), ({}, "SameStep"), ({"cpus_per_actor": "node"}, "NextStep")],
    ids=["2-actors", "2-actors-same-step", "1-actor-per-node-pool"],
)
def test_same_results_as_sync_vector_env(layout, autoreset_mode):
    """Step by step, through autoresets, with the same seeds; by default one actor per CPU, with
    ``cpus_per_actor="node"`` the node's one actor reserves its 2 CPUs and hosts a pool."""
    envs = RayVectorEnv(env_fns(), autoreset_mode=autoreset_mode, **layout)
    sync = gym.vector.SyncVectorEnv(env_fns(), autoreset_mode=autoreset_mode)
    try:
        assert [plan.cpus for plan in envs.plans] == ([2] if layout else [1, 1])
        assert envs.single_observation_space == sync.single_observation_space
        assert envs.action_space == sync.action_space
        for left, right in zip(envs.reset(seed=7), sync.reset(seed=7), strict=True):
            assert_same_infos({"x": left}, {"x": right}) if isinstance(left, np.ndarray) else assert_same_infos(left, right)
        actions = np.random.default_rng(0).integers(0, 2, size=(80, N))
        ended = 0
        for batch in actions:
            ours, theirs = envs.step(batch), sync.step(batch)
            for a, b in zip(ours[:4], theirs[:4], strict=True):
                np.testing.assert_array_equal(a, b)
            assert_same_infos(ours[4], theirs[4])
            ended += int(ours[2].sum() + ours[3].sum())
        assert ended > N, "the run should cover autoresets"
        assert envs.get_attr("force") == sync.get_attr("force")
    finally:
        envs.close()
        sync.close()


def test_rollout_ships_the_policy_once_and_matches_a_local_loop():
    envs = modelicagym.make_vec("cartpole", n=N, backend="ray", num_actors=2, max_episode_steps=25)
    local = modelicagym.make_vec("cartpole", n=N, backend="sync", max_episode_steps=25)
    try:
        assert isinstance(envs, RayVectorEnv)
        envs.reset(seed=3)
        observations, _ = local.reset(seed=3)
        rollouts = envs.rollout(push_by_velocity, steps=40)
        assert [list(r.env_indices) for r in rollouts] == [list(s) for s in envs.slices]
        joined = Rollout.concatenate(rollouts)
        assert joined.observations.shape == (40, N, 4) and joined.actions.shape == (40, N)
        for t in range(40):
            np.testing.assert_array_equal(joined.observations[t], observations)
            actions = np.concatenate([push_by_velocity(observations[s.start:s.stop]) for s in envs.slices])
            np.testing.assert_array_equal(joined.actions[t], actions)
            observations, rewards, terminations, truncations, _ = local.step(actions)
            np.testing.assert_array_equal(joined.rewards[t], rewards)
            np.testing.assert_array_equal(joined.terminations[t], terminations)
            np.testing.assert_array_equal(joined.truncations[t], truncations)
        np.testing.assert_array_equal(joined.last_observations, observations)
        assert joined.terminations.any() or joined.truncations.any()
        shipped = envs._policy[1]
        again = Rollout.concatenate(envs.rollout(push_by_velocity, steps=3))
        assert envs._policy[1] is shipped, "the same policy is not shipped again"
        np.testing.assert_array_equal(again.observations[0], observations)
    finally:
        envs.close()
        local.close()


def test_a_rollout_keeps_the_infos_each_env_reported(family_fmu):
    """The staircase ends at t_stop = 1.3 s: its 13th step reports ``fmu_terminated``."""
    options = {"fmu": str(family_fmu("staircase", 2)), "mode": "me", "inputs": ["u"], "outputs": ["x", "level"],
               "parameters": {"period": 0.25, "t_stop": 1.3}, "time_step": 0.1}
    fns = [EnvFactory("modelicagym.env:FMUEnv", options) for _ in range(3)]
    half = lambda observations: np.full((len(observations), 1), 0.5)  # noqa: E731
    envs = RayVectorEnv(fns, num_actors=2)
    local = gym.vector.SyncVectorEnv(fns)
    try:
        envs.reset(seed=0)
        local.reset(seed=0)
        joined = Rollout.concatenate(envs.rollout(half, steps=20))
        expected = {}
        for t in range(20):
            infos = local.step(half(np.zeros(3)))[4]
            expected.update({(t, j): info for j in range(3) if (info := env_info(infos, j))})
        assert joined.infos == expected
        assert joined.infos[12, 2] == {"fmu_terminated": True}
    finally:
        envs.close()
        local.close()


def test_a_dead_actor_is_named_with_its_envs_and_can_be_restarted():
    envs = RayVectorEnv(env_fns(), num_actors=2)
    try:
        envs.reset(seed=1)
        first = envs.actor_pids()
        os.kill(first[1], signal.SIGKILL)
        with pytest.raises(ActorDiedError, match=r"actor 1 hosting envs 3-4 died") as caught:
            envs.step(np.zeros(N, dtype=np.int64))
        assert caught.value.env_indices == (3, 4) and caught.value.actor_index == 1
        assert envs.dead_actors == {1}
        assert envs.restart_actors() == [1]
        pids = envs.actor_pids()
        assert pids[0] == first[0] and pids[1] != first[1]
        observations, _ = envs.reset(seed=1)
        fresh = gym.vector.SyncVectorEnv(env_fns())
        try:  # the actors hold both CPUs: compare with a local vector env
            np.testing.assert_array_equal(observations, fresh.reset(seed=1)[0])
            np.testing.assert_array_equal(envs.step(np.ones(N, int))[0], fresh.step(np.ones(N, int))[0])
        finally:
            fresh.close()
    finally:
        envs.close()


def steps_as_bytes(envs, actions):
    return [tuple(part.tobytes() for part in envs.step(batch)[:4]) for batch in actions]


def test_init_once_across_actors_and_a_checkpoint_that_resumes_all_or_nothing():
    """``init="once"``: one initialization in all (two actors), the same results as ``"each"``;
    ``get_states``/``set_states`` resume bit for bit, and a state one env refuses changes none."""
    actions = np.random.default_rng(1).integers(0, 2, size=(30, N))
    runs = {}
    for init in ("each", "once"):
        envs = modelicagym.make_vec("cartpole", n=N, backend="ray", init=init, max_episode_steps=25)
        try:
            first, _ = envs.reset(seed=3)
            runs[init] = [first.tobytes()] + steps_as_bytes(envs, actions[:10])
            runs[init, "initializations"] = envs.get_attr("initializations")
            if init == "once":
                checkpoint = envs.get_states()
                runs[init] += steps_as_bytes(envs, actions[10:])
                other = modelicagym.make("cartpole", fmi_version=3)
                other.reset(seed=0)
                refused = [*checkpoint.states[:-1], other.get_state()]
                before = envs.get_states()
                with pytest.raises(modelicagym.fmu.StateMismatchError, match=f"env {N - 1} refuses its state"):
                    envs.set_states(refused)  # envs 0-2 on actor 0 would take theirs otherwise
                assert [(s.fmu.data, s.elapsed_steps) for s in envs.get_states().states] == [
                    (s.fmu.data, s.elapsed_steps) for s in before.states]
                envs.set_states(checkpoint)
                assert steps_as_bytes(envs, actions[10:]) == runs[init][11:]
            else:
                runs[init] += steps_as_bytes(envs, actions[10:])
        finally:
            envs.close()
    assert envs.num_actors == 2
    assert runs["once"] == runs["each"]
    assert runs["each", "initializations"] == (1,) * N and sum(runs["once", "initializations"]) == 1


def test_make_vec_routes_ray_and_pool_options():
    envs = modelicagym.make_vec("cartpole", n=3, backend="ray", num_actors=1, cpus_per_actor=2, force=7.0,
                                pool_options={"spin_time": 0.0})
    try:
        assert envs.num_actors == 1 and envs.get_attr("force") == (7.0, 7.0, 7.0)
    finally:
        envs.close()
    with pytest.raises(ValueError, match="unknown Ray option 'num_actor'"):
        modelicagym.make_vec("cartpole", n=2, backend="ray", ray_options={"num_actor": 1})


def test_more_actors_than_the_cluster_has_cpus_is_refused_at_once():
    """Ray would wait forever for CPUs the cluster does not have: say so instead."""
    with pytest.raises(ValueError, match="3 actors of 1 CPU\\(s\\) need 3 CPUs, the cluster has 2"):
        RayVectorEnv(env_fns(), num_actors=3)


def test_an_actor_ray_cannot_place_is_an_error_not_a_hang():
    """The first vector env holds both CPUs; the second's actor would wait for them forever."""
    holder = RayVectorEnv(env_fns(2))
    try:
        assert ray.available_resources().get("CPU", 0) == 0
        with pytest.raises(ClusterError, match=r"Ray could not place actor 0 \(envs 0-2, 2 CPU\(s\)\) within 1.5 s"):
            RayVectorEnv(env_fns(3), num_actors=1, cpus_per_actor=2, placement_timeout=1.5)
    finally:
        holder.close()
    deadline = time.monotonic() + 20
    while ray.available_resources().get("CPU", 0) < 2 and time.monotonic() < deadline:
        time.sleep(0.1)
    assert ray.available_resources().get("CPU", 0) == 2, "the actor that was never placed holds no CPU"
    envs = RayVectorEnv(env_fns(3), num_actors=1, cpus_per_actor=2)
    try:
        assert envs.reset(seed=0)[0].shape == (3, 4)
    finally:
        envs.close()


def test_ray_is_connected_with_token_authentication():
    from ray._raylet import AuthenticationMode, get_authentication_mode

    assert ray.is_initialized()
    assert get_authentication_mode() == AuthenticationMode.TOKEN
    assert {node["NodeManagerAddress"] for node in ray.nodes()} == {"127.0.0.1"}
