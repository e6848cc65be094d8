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


def test_an_option_both_accept_must_be_placed(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(registry.ENVIRONMENTS, "colliding", ("ModelicaGym/Colliding-v0", f"{__name__}:CollidingEnv"))
    with pytest.raises(ArgumentError, match="'copy' is an option of both the env and the pool.*env_options"):
        modelicagym.make_vec("colliding", n=2, copy=False)
