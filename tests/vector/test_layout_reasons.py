"""``pool.layout.reason`` says truly why each env runs where it does, in every case: the bundled
models in the calling process, a user's FMU isolated with or without the stand-in worker, an FMU
allowed once per process, each option that puts every env in a worker, ``num_workers=0``, and
envs that cannot move. A reason names what the user gave (or what the envs are), and nothing that
was not given."""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from typing import Any

import pytest
from fmu_family import build
from step_paths import cartpole_fns

import modelicagym
from modelicagym import FMUEnv
from modelicagym.errors import ConfigError
from modelicagym.models.cartpole import OUTPUTS, cartpole_fmu
from modelicagym.vector import PoolVectorEnv
from modelicagym.vector.wire.sync import pool_native_library

pytestmark = [
    pytest.mark.timeout(120),
    pytest.mark.usefixtures("pool_services"),
    pytest.mark.skipif(pool_native_library() is None, reason="the reasons of adaptive layouts need the native library"),
]

#: the words of the old catch-all reason, true of none of these cases
CATCH_ALL = "were asked for"


def users_cartpole(**options: Any) -> FMUEnv:
    """Our cart-pole FMU as a user gives any FMU: its envs do not say they are safe in the caller."""
    return FMUEnv(fmu=cartpole_fmu(), inputs=["f"], outputs=list(OUTPUTS), time_step=0.05,
                  action_table=[[-15.0], [15.0]], termination={"x": (-2.4, 2.4)}, **options)


def bundled(n: int = 4, step_path: str = "native") -> list[Callable[[], Any]]:
    return cartpole_fns(n)[step_path == "python"]


def users(n: int = 4, **options: Any) -> list[Callable[[], Any]]:
    return [partial(users_cartpole, **options)] * n


def random_mass(rng: Any) -> float:
    return float(rng.uniform(0.5, 1.5))


def once_per_process_pool(**pool_options: Any) -> PoolVectorEnv:
    """The probe variant an FMU allows once per process, as a user pools it keeping that rule:
    ``make_vec`` of its config with ``instances_per_process="one"``."""
    config = {"fmu": str(build("probe_once", 2)), "inputs": ["force"], "outputs": ["position", "clock"],
              "parameters": {"gear": 1, "enable": True}, "time_step": 0.1, "instances_per_process": "one"}
    return modelicagym.make_vec(config, n=2, **pool_options)


#: case -> (the pool, the words its reason holds, where its envs are: "caller" (a slice in the
#: calling process), "stand-in", "workers" (every env in a plain worker) or "caller only")
CASES: dict[str, tuple[Callable[[], PoolVectorEnv], tuple[str, ...], str]] = {
    "bundled, default": (lambda: PoolVectorEnv(bundled(), cores=2),
                         ("its envs can move between the workers and the calling process",), "caller"),
    "bundled, caller_steps=True and num_workers": (
        lambda: PoolVectorEnv(bundled(), num_workers=1, caller_steps=True),
        ("its envs can move between the workers and the calling process",), "caller"),
    "bundled, random parameters": (
        lambda: PoolVectorEnv([partial(modelicagym.make, "cartpole", m_cart=random_mass)] * 4, cores=2),
        ("does not reset deterministically",), "caller"),
    "bundled, Python step path": (lambda: PoolVectorEnv(bundled(step_path="python"), cores=2),
                                  ("an env steps on the Python path", "step_path='python'"), "caller"),
    "bundled, adapt_layout=False": (lambda: PoolVectorEnv(bundled(), adapt_layout=False, cores=2), ("adapt_layout=False",),
                                    "caller"),
    "user's FMU, default": (lambda: PoolVectorEnv(users(), cores=2),
                            ("do not all say they are safe in the calling process",
                             "they can move to one worker at episode boundaries"), "stand-in"),
    "user's FMU, one core": (lambda: PoolVectorEnv(users(), cores=1),
                             ("do not all say they are safe in the calling process",
                              "one worker steps them all, the pool's one party for 4 env(s) on 1 core(s)"), "stand-in"),
    "user's FMU, one env": (lambda: PoolVectorEnv(users(1), cores=4),
                            ("one worker steps them all, the pool's one party for 1 env(s) on 4 core(s)",), "stand-in"),
    "user's FMU, fixed": (lambda: PoolVectorEnv(users(), adapt_layout=False, cores=2),
                          ("do not all say they are safe in the calling process",
                           "no worker stands in for it, as the layout does not adapt: adapt_layout=False"), "workers"),
    "user's FMU, random parameters": (lambda: PoolVectorEnv(users(parameters={"m_cart": random_mass}), cores=2),
                                      ("no worker stands in for it", "does not reset deterministically"), "workers"),
    # the user put FMU code in the calling process: it holds copies of the workers' envs too
    "user's FMU, caller_steps=True": (lambda: PoolVectorEnv(users(), caller_steps=True, cores=2),
                                      ("its envs can move between the workers and the calling process",), "caller"),
    # ... but never more instances of an FMU allowed few per process than its rule allows
    "once per process, caller_steps=True": (lambda: once_per_process_pool(caller_steps=True),
                                            ("env 0 does not say it is safe in the calling process",), "caller"),
    "once per process": (once_per_process_pool,
                         ("env 0's fn allows at most 1 env(s) per process",
                          "an FMU that may be instantiated only once per process"), "workers"),
    "num_workers": (lambda: PoolVectorEnv(bundled(), num_workers=2), ("num_workers=2 was given",), "workers"),
    "max_envs_per_worker": (lambda: PoolVectorEnv(bundled(), max_envs_per_worker=2, cores=2),
                            ("max_envs_per_worker=2 was given",), "workers"),
    "restart_dead_workers": (lambda: PoolVectorEnv(bundled(), restart_dead_workers=True, cores=2),
                             ("restart_dead_workers=True (a worker can be restarted",), "workers"),
    "step_timeout": (lambda: PoolVectorEnv(bundled(), step_timeout=30.0, cores=2),
                     ("step_timeout=30.0 (a hung worker can be killed",), "workers"),
    "two at once": (lambda: PoolVectorEnv(bundled(), num_workers=2, step_timeout=30.0),
                    ("num_workers=2 was given", "; step_timeout=30.0 ("), "workers"),
    "batch_size": (lambda: PoolVectorEnv(bundled(), batch_size=2, cores=2),
                   ("batch_size=2 (partial batches come from workers only)",), "workers"),
    "caller_steps=False": (lambda: PoolVectorEnv(bundled(), caller_steps=False, cores=2), ("caller_steps=False",), "workers"),
    "num_workers=0": (lambda: PoolVectorEnv(bundled(), num_workers=0),
                      ("num_workers=0: every env is in the calling process",), "caller only"),
}


@pytest.mark.parametrize("case", list(CASES))
def test_the_layout_says_truly_why_its_envs_run_where_they_do(case: str) -> None:
    make, words, where = CASES[case]
    with make() as pool:
        layout = pool.layout
    for word in words:
        assert word in layout.reason, layout
    assert CATCH_ALL not in layout.reason, layout
    adaptive = "can move" in layout.reason
    assert layout.adaptive == adaptive, layout
    in_workers = layout.reason.startswith("every env is in a worker")
    if where == "caller":
        assert layout.envs_in_caller > 0 and layout.num_workers > 0 and not in_workers, layout
    elif where == "caller only":
        assert layout.envs_in_caller == layout.num_envs and layout.num_workers == 0, layout
    elif where == "stand-in":
        assert layout.envs_in_caller == 0 and layout.envs_in_stand_in > 0 and in_workers, layout
    else:
        assert layout.envs_in_caller == 0 and not layout.stand_in and in_workers, layout


def test_adapt_layout_true_with_one_party_for_a_users_envs_says_why_it_cannot() -> None:
    """One core and envs not safe in the calling process: one worker steps them all, nothing can move."""
    with pytest.raises(ConfigError, match="adapt_layout=True, but the layout cannot adapt: .*one worker steps them all"):
        PoolVectorEnv(users(), cores=1, adapt_layout=True)
