"""A system in the pool: ``make_vec`` over a system config (processes, ``init="once"``, the
native path) gives what Gymnasium's SyncVectorEnv gives over the same envs on the Python path,
step for step."""

from __future__ import annotations

from functools import partial

import pytest
from gymnasium.vector import SyncVectorEnv
from ssp_cases import bindings, component, connect, connectors, system, write_ssp_folder
from system_cases import system_config
from vector_rollouts import assert_same, rollout

import modelicagym
from modelicagym import FMUEnv

pytestmark = [pytest.mark.processes, pytest.mark.timeout(120), pytest.mark.usefixtures("pool_services")]


@pytest.mark.parametrize("init", ["each", "once"])
def test_a_pool_of_systems_matches_sync_vector_env(family_fmu, tmp_path, init):
    table = tmp_path / "load.csv"
    table.write_text("time,torque\n0,0\n0.2,-0.05\n0.5,0.02\n")
    motor, inertia = family_fmu("motor", 2), family_fmu("inertia", 3)
    config = system_config(motor, inertia, max_episode_steps=15,
                           fmus={"motor": str(motor), "plant": str(inertia), "load": str(table)},
                           connections=[*system_config(motor, inertia)["connections"], ("load.torque", "plant.tau_load")],
                           termination={"plant.w": (-30.0, 30.0)})
    sync = SyncVectorEnv([partial(FMUEnv, {**config, "step_path": "python"})] * 3)
    expected = rollout(sync, 40)
    sync.close()
    with modelicagym.make_vec(config, n=3, num_workers=2, init=init) as pool:
        assert {path for path, _ in pool.step_paths} == {"native"}
        actual = rollout(pool, 40)
    assert_same(expected, actual)


def test_a_pool_of_a_nested_ssp_driven_through_its_own_connectors(family_fmu, tmp_path):
    inner = system("sub", [component("g", "gain", bindings({"k": 2.0}))],
                   [connect(".u", "g.u", factor=-1.0, offset=0.5), connect("g.y", ".y")],
                   connectors(u="input", y="output"))
    top = system("top", [inner, component("h", "gain")], [connect(".u", "sub.u"), connect(".u", "h.u"),
                                                          connect("sub.y", ".y")],
                 connectors(u="input", y="output"), bindings({"u": 1.5}))
    folder = write_ssp_folder(tmp_path / "nested", top, {"gain": family_fmu("gain", 2)})
    config = {"fmu": str(folder), "inputs": ["u"], "outputs": ["y", "h.y"], "time_step": 0.1,
              "max_episode_steps": 7, "action_bounds": {"u": (-2.0, 2.0)}}
    sync = SyncVectorEnv([partial(FMUEnv, {**config, "step_path": "python"})] * 3)
    expected = rollout(sync, 20)
    sync.close()
    with modelicagym.make_vec(config, n=3, num_workers=2, init="once") as pool:
        assert {path for path, _ in pool.step_paths} == {"native"}
        actual = rollout(pool, 20)
    assert_same(expected, actual)
