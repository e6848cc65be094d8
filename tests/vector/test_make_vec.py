"""``make_vec`` routes each option to the env or to the pool, explicitly; ambiguity is an error."""

from __future__ import annotations

import inspect

import gymnasium as gym
import pytest

import modelicagym
from modelicagym import registry
from modelicagym.errors import ArgumentError
from modelicagym.vector import PoolVectorEnv
from modelicagym.vector.pool import POOL_OPTIONS


class CollidingEnv(gym.Env):
    """An env with an option named like one of the pool's."""

    def __init__(self, copy: bool = False) -> None:
        self.copy = copy


def test_pool_options_are_the_pools_keyword_arguments() -> None:
    parameters = set(inspect.signature(PoolVectorEnv.__init__).parameters) - {"self", "env_fns"}
    assert set(POOL_OPTIONS) == parameters


def test_top_level_options_go_where_they_belong() -> None:
    with modelicagym.make_vec("cartpole", n=2, num_workers=1, force=11.0) as pool:
        assert pool.num_workers == 1 and not pool.caller_steps
        assert pool.get_attr("force") == (11.0, 11.0)


def test_env_options_and_pool_options_go_only_where_they_say() -> None:
    with modelicagym.make_vec("cartpole", n=2, env_options={"force": 7.0}, pool_options={"caller_steps": True}) as pool:
        assert pool.caller_steps
        assert pool.get_attr("force") == (7.0, 7.0)


def test_a_misspelt_pool_option_is_named_as_one() -> None:
    with pytest.raises(ArgumentError, match="unknown pool option 'num_worker'. Did you mean 'num_workers'"):
        modelicagym.make_vec("cartpole", n=2, num_worker=1)
    with pytest.raises(ArgumentError, match="unknown pool option 'step_timout'"):
        modelicagym.make_vec("cartpole", n=2, pool_options={"step_timout": 1.0})


@pytest.mark.parametrize("n", ["4", 2.0, True, None])
def test_n_must_be_an_int(n: object) -> None:
    with pytest.raises(TypeError, match=f"n must be an int, got {type(n).__name__}"):
        modelicagym.make_vec("cartpole", n=n)


def test_an_option_both_accept_must_be_placed(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(registry.ENVIRONMENTS, "colliding", ("ModelicaGym/Colliding-v0", f"{__name__}:CollidingEnv"))
    with pytest.raises(ArgumentError, match="'copy' is an option of both the env and the pool.*env_options"):
        modelicagym.make_vec("colliding", n=2, copy=False)


def test_backends_are_checked_before_anything_starts() -> None:
    with pytest.raises(ValueError, match="unknown backend 'rey'; choose one of pool, sync, ray"):
        modelicagym.make_vec("cartpole", n=2, backend="rey")
    with pytest.raises(ValueError, match="ray_options apply to backend='ray' only"):
        modelicagym.make_vec("cartpole", n=2, ray_options={"num_actors": 1})
    with pytest.raises(ValueError, match="backend='sync' takes no pool options"):
        modelicagym.make_vec("cartpole", n=2, backend="sync", num_workers=1)


def test_the_sync_backend_is_gymnasiums_sync_vector_env() -> None:
    envs = modelicagym.make_vec("cartpole", n=2, backend="sync", autoreset_mode="SameStep", force=7.0)
    try:
        assert isinstance(envs, gym.vector.SyncVectorEnv) and envs.get_attr("force") == (7.0, 7.0)
        assert envs.metadata["autoreset_mode"] == gym.vector.AutoresetMode.SAME_STEP
    finally:
        envs.close()
