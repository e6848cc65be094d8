"""A system of FMUs on Ray: ``make_vec(system_config, backend="ray")`` gives what SyncVectorEnv
gives on the Python path, step for step (tests/system covers the pool)."""

from __future__ import annotations

from functools import partial

import pytest
from gymnasium.vector import SyncVectorEnv
from ray_cluster import local_ray
from system_cases import system_config
from vector_rollouts import assert_same, rollout

import modelicagym
from modelicagym import FMUEnv
from modelicagym.distributed import RayVectorEnv


@pytest.fixture(scope="module", autouse=True)
def ray_instance():
    with local_ray(__name__, num_cpus=2) as temp_dir:
        yield temp_dir


def test_systems_on_ray_match_sync_vector_env(family_fmu):
    config = system_config(family_fmu("motor", 2), family_fmu("inertia", 3), max_episode_steps=12)
    sync = SyncVectorEnv([partial(FMUEnv, {**config, "step_path": "python"})] * 3)
    expected = rollout(sync, 30)
    sync.close()
    envs = modelicagym.make_vec(config, n=3, backend="ray", num_actors=2)
    try:
        assert isinstance(envs, RayVectorEnv)
        actual = rollout(envs, 30)
    finally:
        envs.close()
    assert_same(expected, actual)
