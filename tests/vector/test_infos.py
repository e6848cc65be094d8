"""The pool's infos are merged by one function of ours (`modelicagym.vector.dispatch.infos`); they equal
``AsyncVectorEnv``'s for the same run, in every autoreset mode: each key's column and its ``_key``
mask, nested dicts, and ``final_obs`` / ``final_info`` whether an env's step ran in Python, or
natively with the reset done in C (the pool's bulk merge) or left to Python. `env_info`, the
inverse, gives each env its info back."""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from gymnasium.vector import AsyncVectorEnv, AutoresetMode
from step_paths import probe_env
from vector_envs import CountEnv
from vector_rollouts import assert_same, rollout

import modelicagym
from modelicagym.vector import PoolVectorEnv
from modelicagym.vector.dispatch.infos import add_info, env_info

pytestmark = pytest.mark.timeout(240)


def infos_of(records: list) -> list[dict[str, Any]]:
    return [record[-1] for record in records]


def env_groups(family_fmu: Callable[[str, int], Path]) -> dict[str, list[Callable[[], Any]]]:
    """Envs on the Python path with rich infos, cart-poles reset in C, and probes whose model ends."""
    probe = family_fmu("probe", 2)
    return {
        "python path": [partial(CountEnv, max_len=7), partial(CountEnv, max_len=5, info_every=2),
                        partial(CountEnv, max_len=4, info_every=1)],
        "native resets": [partial(modelicagym.make, "cartpole", max_episode_steps=6 + 3 * i) for i in range(3)],
        "model ends": [partial(probe_env, probe, parameters={"fault": 1, "fault_after": 3}, max_episode_steps=8),
                       partial(probe_env, probe, max_episode_steps=5),
                       partial(probe_env, probe, parameters={"fault": 1, "fault_after": 2}, max_episode_steps=9)],
    }


@pytest.mark.parametrize("group", ["python path", "native resets", "model ends"])
@pytest.mark.parametrize("mode", list(AutoresetMode), ids=lambda mode: mode.value)
def test_the_pools_infos_equal_async_vector_envs(mode: AutoresetMode, group: str,
                                                 family_fmu: Callable[[str, int], Path]) -> None:
    fns = env_groups(family_fmu)[group]
    reference = AsyncVectorEnv(fns, autoreset_mode=mode)
    try:
        expected = rollout(reference, 40)
    finally:
        reference.close()
    with PoolVectorEnv(fns, num_workers=1, caller_steps=True, autoreset_mode=mode) as pool:
        if group != "python path":
            assert {path for path, _ in pool.step_paths} == {"native"}, pool.step_paths
        actual = rollout(pool, 40)
    assert_same(infos_of(expected), infos_of(actual), "infos")
    assert_same(expected, actual)
    keys = set().union(*infos_of(expected), *(infos.get("final_info", {}) for infos in infos_of(expected)))
    if mode is AutoresetMode.SAME_STEP:
        assert {"final_obs", "_final_obs", "final_info", "_final_info"} <= keys
    if group != "native resets":
        assert any(key.startswith("_") and key not in ("_final_obs", "_final_info") for key in keys)


def test_add_info_marks_each_key_of_each_env_as_gymnasium_does() -> None:
    infos: dict[str, Any] = {}
    add_info(infos, {"a": 1, "nested": {"x": np.ones(2)}, "final_obs": np.zeros(3)}, 2, 4)
    add_info(infos, {"a": 5, "tag": "t"}, 0, 4)
    assert infos["a"].tolist() == [5, 0, 1, 0] and infos["_a"].tolist() == [True, False, True, False]
    assert infos["nested"]["x"].shape == (4, 2) and infos["nested"]["_x"].tolist() == [False, False, True, False]
    assert infos["_nested"].tolist() == [False, False, True, False]
    assert infos["final_obs"].dtype == object and infos["final_obs"][0] is None
    assert infos["tag"].tolist() == ["t", None, None, None]


def test_env_info_gives_each_env_back_the_info_add_info_merged() -> None:
    per_env = {
        0: {"a": 5, "tag": "t", "_own": 1.5},
        1: {},
        2: {"a": 1, "nested": {"x": np.ones(2), "deeper": {"n": 3}}, "final_obs": np.zeros(3)},
        3: {"nested": {"y": "only 3"}},
    }
    infos: dict[str, Any] = {}
    for index, info in per_env.items():
        add_info(infos, info, index, 4)
    for index, info in per_env.items():
        np.testing.assert_equal(env_info(infos, index), info, err_msg=f"env {index}")


def test_env_info_keeps_a_key_without_a_mask_as_every_envs_row() -> None:
    """A partial batch's ``env_id`` has no ``_env_id`` mask: row ``j`` is the id of the batch's env ``j``."""
    with PoolVectorEnv([partial(CountEnv, max_len=5, info_every=1) for _ in range(4)], num_workers=1) as pool:
        pool.reset(seed=0)
        infos = pool.step_envs(np.zeros(2, dtype=np.int64), [3, 1])[4]
    assert "env_id" in infos and "_env_id" not in infos
    assert [env_info(infos, j)["env_id"] for j in range(2)] == [3, 1]
